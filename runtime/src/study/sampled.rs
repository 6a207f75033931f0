//! A numerical reference: a run's states at exactly the frame times of the study's runs.
//! [`Sampler`] takes them while the reference runs (cubic Hermite between its own steps
//! where a frame time falls inside one); [`Sampled`] serves them as a reference.

use crate::driver::run_loop::{Frame, Observer};

use super::error::ReferenceError;
use super::reference::{RefBody, RefSolution, SAME_TIME};
use super::track::Track;

/// A numerical reference (or any run used as one): states at known times.
#[derive(Clone, Debug)]
pub struct Sampled {
    track: Track,
}

impl Sampled {
    /// Use the frames of `track` as the reference at exactly their times.
    pub fn new(track: Track) -> Sampled {
        Sampled { track }
    }
}

impl RefSolution for Sampled {
    fn at(&self, t: f64, out: &mut [RefBody]) -> Result<(), ReferenceError> {
        let ts = &self.track.t;
        let i = ts.partition_point(|x| *x < t);
        let tol = SAME_TIME * t.abs().max(1.0);
        let hit = [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter(|&k| k < ts.len())
            .find(|&k| (ts[k] - t).abs() <= tol)
            .ok_or_else(|| {
                ReferenceError::NotCovered(format!("the reference has no frame at t = {t} s"))
            })?;
        let n = self.track.bodies;
        for (b, o) in out.iter_mut().enumerate().take(n) {
            o.r = Some(self.track.r[hit * n + b]);
            o.q = Some(self.track.q[hit * n + b]);
        }
        Ok(())
    }
}

/// Samples a run at requested times: at a frame whose time matches, or by cubic Hermite
/// interpolation between two consecutive frames (run it with a frame every step).
pub struct Sampler<'a> {
    times: &'a [f64],
    next: usize,
    prev: Track,
    out: Track,
}

impl<'a> Sampler<'a> {
    /// Sample at `times` (sorted ascending).
    pub fn new(bodies: usize, times: &'a [f64]) -> Sampler<'a> {
        Sampler {
            times,
            next: 0,
            prev: Track::new(bodies),
            out: Track::new(bodies),
        }
    }

    /// The samples taken (fewer than requested if the run stopped early).
    pub fn finish(self) -> Track {
        self.out
    }
}

impl Sampler<'_> {
    /// Take the samples due at or before the frame `cur` (a one-frame track).
    fn frame_track(&mut self, cur: Track) {
        let n = self.out.bodies;
        let tc = cur.t[0];
        while self.next < self.times.len() {
            let t = self.times[self.next];
            let tol = SAME_TIME * t.abs().max(1.0);
            if t > tc + tol {
                break;
            }
            if (t - tc).abs() <= tol || self.prev.t.is_empty() {
                self.out.push_frame_of(&cur, 0, t);
            } else {
                let mut pair = Track::new(n);
                pair.t = vec![self.prev.t[0], tc];
                for src in [&self.prev, &cur] {
                    pair.r.extend_from_slice(&src.r);
                    pair.q.extend_from_slice(&src.q);
                    pair.v.extend_from_slice(&src.v);
                    pair.w.extend_from_slice(&src.w);
                }
                self.out.t.push(t);
                for b in 0..n {
                    let (r, q) = pair.interpolate(0, t, b);
                    self.out.r.push(r);
                    self.out.q.push(q);
                    // samples are compared by position and orientation only
                    self.out.v.push([0.0; 3]);
                    self.out.w.push([0.0; 3]);
                }
            }
            self.next += 1;
        }
        self.prev = cur;
    }
}

impl Observer for Sampler<'_> {
    fn frame(&mut self, f: &Frame<'_>) {
        let mut cur = Track::new(self.out.bodies);
        cur.push_frame(f);
        self.frame_track(cur);
    }
    /// The reference run stops on SIGINT or SIGTERM in a program that handles them (see
    /// [`crate::study::InterpRunner`]'s runs).
    fn stop_requested(&mut self) -> Option<&'static str> {
        crate::app::StopSignals::pending().map(crate::app::Signal::name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::error_measures::rotation_angle;
    use crate::study::track::tests::uniform_rotation;

    #[test]
    fn sampler_hits_and_interpolates() {
        let fine: Vec<f64> = (0..=100).map(|i| i as f64 * 0.01).collect();
        let tr = uniform_rotation(&fine, 1.0);
        let want = [0.0, 0.2, 0.255, 1.0];
        let mut s = Sampler::new(1, &want);
        for f in 0..tr.t.len() {
            // feed the frames through the same code path as the observer
            let mut cur = Track::new(1);
            cur.push_frame_of(&tr, f, tr.t[f]);
            s.frame_track(cur);
        }
        let out = s.finish();
        assert_eq!(out.t, want.to_vec());
        for (k, &t) in want.iter().enumerate() {
            assert!((out.r[k][0] - t.cos()).abs() < 1e-9, "{t}");
            let exact = [(t / 2.0).cos(), 0.0, 0.0, (t / 2.0).sin()];
            assert!(rotation_angle(&out.q[k], &exact) < 1e-9);
        }
    }
}
