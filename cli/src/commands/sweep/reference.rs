//! Reference solutions and the error measures of a sweep.
//!
//! A reference gives, for each body it knows, the mass-centre position and/or the
//! orientation at any time a run has a frame:
//! - [`Analytic`]: the scene's `reference { body B { position …; orientation … } }`
//!   functions of time, evaluated exactly at the frame times;
//! - [`Table`]: `reference { table "file.csv" }`, a table with the columns of
//!   `bodies.csv`, interpolated in time (cubic Hermite with the velocities where the table
//!   has them — `vx vy vz` for positions, `wx wy wz` for orientations — linear otherwise);
//! - [`Sampled`]: a numerical reference run, sampled at exactly the frame times of the
//!   sweep's runs (cubic Hermite between its own steps where a time falls inside one).
//!
//! # Error measures
//! At each frame time t of a run:
//! - position error e_r(t) = √( (1/n_r) Σ_b |r_b(t) − r_b,ref(t)|² ), m — the RMS over the
//!   n_r bodies with a reference position;
//! - orientation error e_θ(t) = √( (1/n_q) Σ_b θ_b(t)² ), rad, with θ_b the angle of the
//!   rotation q_b,ref⁻¹ q_b (`2 atan2(|vec|, |w|)`, so q and −q agree) — the RMS over the
//!   n_q bodies with a reference orientation.
//!
//! Each is reported at the final time (`final`) and as the maximum over the frames
//! (`max`).

use mbdc_runtime::fn1;
use mbdc_runtime::run_loop::{Frame, Observer};
use mbdc_runtime::scene::{BodyReference, Scene};

use super::runner::Track;

/// What a reference knows about one body at one time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RefBody {
    /// Mass-centre position, world, m.
    pub r: Option<[f64; 3]>,
    /// Orientation, unit quaternion body → world.
    pub q: Option<[f64; 4]>,
}

/// A reference solution.
pub trait RefSolution {
    /// Fill `out` (one entry per scene body) with the reference at time `t`.
    ///
    /// # Errors
    /// If the reference does not cover `t` (a table that ends early, a time that was not
    /// sampled).
    fn at(&self, t: f64, out: &mut [RefBody]) -> Result<(), String>;
}

fn qnormalize(q: [f64; 4]) -> Option<[f64; 4]> {
    let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    (n > 1e-12 && n.is_finite()).then(|| q.map(|x| x / n))
}

/// `a ⊗ b` for quaternions `[w, x, y, z]`.
pub fn qmul(a: &[f64; 4], b: &[f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// The angle of the rotation taking `a` to `b` (both unit quaternions), rad, in [0, π].
pub fn rotation_angle(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let ac = [a[0], -a[1], -a[2], -a[3]];
    let d = qmul(&ac, b);
    let v = (d[1] * d[1] + d[2] * d[2] + d[3] * d[3]).sqrt();
    2.0 * v.atan2(d[0].abs())
}

/// The scene's analytic reference.
#[derive(Clone, Debug)]
pub struct Analytic {
    items: Vec<BodyReference>,
}

impl Analytic {
    /// From the scene's `reference` block (`None` if it has no body functions).
    pub fn new(scene: &Scene) -> Option<Analytic> {
        let r = scene.reference.as_ref()?;
        (!r.bodies.is_empty()).then(|| Analytic {
            items: r.bodies.clone(),
        })
    }
}

impl RefSolution for Analytic {
    fn at(&self, t: f64, out: &mut [RefBody]) -> Result<(), String> {
        out.fill(RefBody::default());
        for it in &self.items {
            let slot = &mut out[it.body];
            if let Some(p) = &it.position {
                slot.r = Some([
                    fn1::value(&p[0], t),
                    fn1::value(&p[1], t),
                    fn1::value(&p[2], t),
                ]);
            }
            if let Some(q) = &it.orientation {
                let raw = [
                    fn1::value(&q[0], t),
                    fn1::value(&q[1], t),
                    fn1::value(&q[2], t),
                    fn1::value(&q[3], t),
                ];
                slot.q = Some(qnormalize(raw).ok_or_else(|| {
                    format!("the reference orientation at t = {t} s is not a rotation: {raw:?}")
                })?);
            }
        }
        Ok(())
    }
}

fn hermite(p0: f64, m0: f64, p1: f64, m1: f64, dt: f64, s: f64) -> f64 {
    let s2 = s * s;
    let s3 = s2 * s;
    (2.0 * s3 - 3.0 * s2 + 1.0) * p0
        + (s3 - 2.0 * s2 + s) * dt * m0
        + (-2.0 * s3 + 3.0 * s2) * p1
        + (s3 - s2) * dt * m1
}

/// `q̇ = ½ q ⊗ (0, ω)` with ω in body components.
fn qdot(q: &[f64; 4], w: &[f64; 3]) -> [f64; 4] {
    qmul(q, &[0.0, w[0], w[1], w[2]]).map(|x| 0.5 * x)
}

/// Interpolate body `b` of a track between frames `i` and `i + 1` at `t` (cubic
/// Hermite with the velocities).
fn interpolate(track: &Track, i: usize, t: f64, b: usize) -> ([f64; 3], [f64; 4]) {
    let n = track.bodies;
    let (t0, t1) = (track.t[i], track.t[i + 1]);
    let dt = t1 - t0;
    let s = if dt > 0.0 { (t - t0) / dt } else { 0.0 };
    let (k0, k1) = (i * n + b, (i + 1) * n + b);
    let r = std::array::from_fn(|c| {
        hermite(
            track.r[k0][c],
            track.v[k0][c],
            track.r[k1][c],
            track.v[k1][c],
            dt,
            s,
        )
    });
    let q0 = track.q[k0];
    let mut q1 = track.q[k1];
    let d0 = qdot(&q0, &track.w[k0]);
    let mut d1 = qdot(&q1, &track.w[k1]);
    if q0.iter().zip(&q1).map(|(a, b)| a * b).sum::<f64>() < 0.0 {
        q1 = q1.map(|x| -x);
        d1 = d1.map(|x| -x);
    }
    let q: [f64; 4] = std::array::from_fn(|c| hermite(q0[c], d0[c], q1[c], d1[c], dt, s));
    (r, qnormalize(q).unwrap_or(q0))
}

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

/// Times closer than this (relative to max(1, |t|)) are the same frame time.
const SAME_TIME: f64 = 1e-9;

impl RefSolution for Sampled {
    fn at(&self, t: f64, out: &mut [RefBody]) -> Result<(), String> {
        let ts = &self.track.t;
        let i = ts.partition_point(|x| *x < t);
        let tol = SAME_TIME * t.abs().max(1.0);
        let hit = [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter(|&k| k < ts.len())
            .find(|&k| (ts[k] - t).abs() <= tol)
            .ok_or_else(|| format!("the reference has no frame at t = {t} s"))?;
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
                push_frame_of(&mut self.out, &cur, 0, t);
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
                    let (r, q) = interpolate(&pair, 0, t, b);
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
}

fn push_frame_of(out: &mut Track, src: &Track, i: usize, t: f64) {
    let n = src.bodies;
    out.t.push(t);
    out.r.extend_from_slice(&src.r[i * n..(i + 1) * n]);
    out.q.extend_from_slice(&src.q[i * n..(i + 1) * n]);
    out.v.extend_from_slice(&src.v[i * n..(i + 1) * n]);
    out.w.extend_from_slice(&src.w[i * n..(i + 1) * n]);
}

/// `reference { table "file.csv" }`: a table with the columns of `bodies.csv`.
#[derive(Clone, Debug)]
pub struct Table {
    path: std::path::PathBuf,
    t: Vec<f64>,
    /// Per scene body: (has position, has velocity, has orientation, has angular velocity).
    has: Vec<[bool; 4]>,
    track: Track,
}

impl Table {
    /// Read the table for `scene` (bodies matched by name; other columns are ignored).
    ///
    /// # Errors
    /// If the file cannot be read, has no `t` column, no column of any scene body, or its
    /// times do not increase.
    pub fn read(path: &std::path::Path, scene: &Scene) -> Result<Table, String> {
        let head = crate::plot::data::header(path).map_err(|e| e.to_string())?;
        if !head.iter().any(|h| h == "t") {
            return Err(format!("{}: the table has no `t` column", path.display()));
        }
        let n = scene.bodies.len();
        let groups: [&[&str]; 4] = [
            &["x", "y", "z"],
            &["vx", "vy", "vz"],
            &["qw", "qx", "qy", "qz"],
            &["wx", "wy", "wz"],
        ];
        let mut has = vec![[false; 4]; n];
        let mut names = vec!["t".to_string()];
        let mut cols: Vec<(usize, usize, usize, usize)> = Vec::new(); // (body, group, comp, column)
        for (b, body) in scene.bodies.iter().enumerate() {
            for (g, comps) in groups.iter().enumerate() {
                let want: Vec<String> =
                    comps.iter().map(|c| format!("{}.{c}", body.name)).collect();
                if want.iter().all(|w| head.contains(w)) {
                    has[b][g] = true;
                    for (c, w) in want.into_iter().enumerate() {
                        cols.push((b, g, c, names.len()));
                        names.push(w);
                    }
                }
            }
        }
        if has.iter().all(|h| !h[0] && !h[2]) {
            return Err(format!(
                "{}: the table has no position (`BODY.x .y .z`) or orientation (`BODY.qw .qx .qy .qz`) columns of the scene's bodies",
                path.display()
            ));
        }
        let c = crate::plot::data::read(path, &names).map_err(|e| e.to_string())?;
        let t = c.data[0].clone();
        if t.len() < 2 || t.windows(2).any(|w| w[1] <= w[0]) {
            return Err(format!(
                "{}: the table needs at least two rows with increasing `t`",
                path.display()
            ));
        }
        let mut track = Track::new(n);
        track.t = t.clone();
        track.r = vec![[0.0; 3]; t.len() * n];
        track.v = vec![[0.0; 3]; t.len() * n];
        track.q = vec![[1.0, 0.0, 0.0, 0.0]; t.len() * n];
        track.w = vec![[0.0; 3]; t.len() * n];
        for &(b, g, comp, col) in &cols {
            for (f, x) in c.data[col].iter().enumerate() {
                let k = f * n + b;
                match g {
                    0 => track.r[k][comp] = *x,
                    1 => track.v[k][comp] = *x,
                    2 => track.q[k][comp] = *x,
                    _ => track.w[k][comp] = *x,
                }
            }
        }
        for q in &mut track.q {
            *q = qnormalize(*q).unwrap_or(*q);
        }
        Ok(Table {
            path: path.to_path_buf(),
            t,
            has,
            track,
        })
    }
}

impl RefSolution for Table {
    fn at(&self, t: f64, out: &mut [RefBody]) -> Result<(), String> {
        let (first, last) = (self.t[0], self.t[self.t.len() - 1]);
        let tol = SAME_TIME * t.abs().max(1.0);
        if t < first - tol || t > last + tol {
            return Err(format!(
                "{}: the reference table covers t = {first} … {last} s, not t = {t} s",
                self.path.display()
            ));
        }
        let i = self
            .t
            .partition_point(|x| *x <= t)
            .clamp(1, self.t.len() - 1)
            - 1;
        let n = self.track.bodies;
        let (t0, t1) = (self.t[i], self.t[i + 1]);
        let s = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        for (b, o) in out.iter_mut().enumerate() {
            let [pos, vel, ori, ang] = self.has[b];
            *o = RefBody::default();
            if !pos && !ori {
                continue;
            }
            let (rh, qh) = interpolate(&self.track, i, t, b);
            let (k0, k1) = (i * n + b, (i + 1) * n + b);
            if pos {
                o.r = Some(if vel {
                    rh
                } else {
                    std::array::from_fn(|c| {
                        (1.0 - s) * self.track.r[k0][c] + s * self.track.r[k1][c]
                    })
                });
            }
            if ori {
                o.q = Some(if ang {
                    qh
                } else {
                    let q0 = self.track.q[k0];
                    let mut q1 = self.track.q[k1];
                    if q0.iter().zip(&q1).map(|(a, b)| a * b).sum::<f64>() < 0.0 {
                        q1 = q1.map(|x| -x);
                    }
                    let q: [f64; 4] = std::array::from_fn(|c| (1.0 - s) * q0[c] + s * q1[c]);
                    qnormalize(q).unwrap_or(q0)
                });
            }
        }
        Ok(())
    }
}

/// The four error measures of one run (`None`: no reference for that quantity).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Errors {
    /// Position error at the final time, m.
    pub pos_final: Option<f64>,
    /// Largest position error over the frames, m.
    pub pos_max: Option<f64>,
    /// Orientation error at the final time, rad.
    pub rot_final: Option<f64>,
    /// Largest orientation error over the frames, rad.
    pub rot_max: Option<f64>,
}

impl Errors {
    /// Every measure multiplied by `k` (for Richardson estimates).
    pub fn scaled(self, k: f64) -> Errors {
        Errors {
            pos_final: self.pos_final.map(|x| x * k),
            pos_max: self.pos_max.map(|x| x * k),
            rot_final: self.rot_final.map(|x| x * k),
            rot_max: self.rot_max.map(|x| x * k),
        }
    }
}

/// The errors of a run's frames against a reference (see the module doc).
///
/// # Errors
/// If the reference does not cover a frame time, or the run has no frames.
pub fn measure(track: &Track, reference: &dyn RefSolution) -> Result<Errors, String> {
    let n = track.bodies;
    if track.t.is_empty() {
        return Err("the run has no frames".into());
    }
    let mut refs = vec![RefBody::default(); n];
    let mut e = Errors::default();
    let last = track.t.len() - 1;
    for (f, &t) in track.t.iter().enumerate() {
        reference.at(t, &mut refs)?;
        let (mut sr, mut nr, mut sq, mut nq) = (0.0, 0usize, 0.0, 0usize);
        for (b, rb) in refs.iter().enumerate() {
            let k = f * n + b;
            if let Some(r) = rb.r {
                let d: f64 = (0..3).map(|c| (track.r[k][c] - r[c]).powi(2)).sum();
                sr += d;
                nr += 1;
            }
            if let Some(q) = rb.q {
                sq += rotation_angle(&q, &track.q[k]).powi(2);
                nq += 1;
            }
        }
        let pos = (nr > 0).then(|| (sr / nr as f64).sqrt());
        let rot = (nq > 0).then(|| (sq / nq as f64).sqrt());
        let upd = |m: &mut Option<f64>, v: Option<f64>| {
            if let Some(v) = v {
                // NaN propagates: a NaN state is an infinite error
                let v = if v.is_nan() { f64::INFINITY } else { v };
                *m = Some(m.map_or(v, |x: f64| x.max(v)));
            }
        };
        upd(&mut e.pos_max, pos);
        upd(&mut e.rot_max, rot);
        if f == last {
            e.pos_final = pos;
            e.rot_final = rot;
        }
    }
    Ok(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_angle_is_sign_blind() {
        let half = 0.3f64;
        let q = [half.cos(), 0.0, half.sin(), 0.0];
        let id = [1.0, 0.0, 0.0, 0.0];
        assert!((rotation_angle(&id, &q) - 0.6).abs() < 1e-15);
        let neg = q.map(|x| -x);
        assert!((rotation_angle(&id, &neg) - 0.6).abs() < 1e-15);
        assert!(rotation_angle(&q, &q).abs() < 1e-15);
    }

    #[test]
    fn hermite_is_exact_for_cubics() {
        // p(t) = t³ on [1, 2]
        let p = |t: f64| t * t * t;
        let d = |t: f64| 3.0 * t * t;
        let x = hermite(p(1.0), d(1.0), p(2.0), d(2.0), 1.0, 0.3);
        assert!((x - p(1.3)).abs() < 1e-13);
    }

    fn uniform_rotation(times: &[f64], rate: f64) -> Track {
        let mut tr = Track::new(1);
        for &t in times {
            tr.t.push(t);
            tr.r.push([t.cos(), t.sin(), 0.0]);
            tr.v.push([-t.sin(), t.cos(), 0.0]);
            let a = rate * t / 2.0;
            tr.q.push([a.cos(), 0.0, 0.0, a.sin()]);
            tr.w.push([0.0, 0.0, rate]);
        }
        tr
    }

    #[test]
    fn interpolation_of_a_circle_and_a_spin() {
        let tr = uniform_rotation(&[0.0, 0.01], 2.0);
        let (r, q) = interpolate(&tr, 0, 0.004, 0);
        // cubic Hermite: error ≤ h⁴/384 · max|r⁗| ≈ 2.6e-11 here
        assert!((r[0] - 0.004f64.cos()).abs() < 5e-11, "{r:?}");
        assert!((r[1] - 0.004f64.sin()).abs() < 5e-11);
        let exact = [0.004f64.cos(), 0.0, 0.0, 0.004f64.sin()];
        assert!(rotation_angle(&q, &exact) < 1e-10);
    }

    #[test]
    fn measures_and_sampled_lookup() {
        let times: Vec<f64> = (0..=10).map(|i| i as f64 * 0.1).collect();
        let exact = uniform_rotation(&times, 1.0);
        let mut run = exact.clone();
        for (f, r) in run.r.iter_mut().enumerate() {
            r[0] += 1e-3 * f as f64; // error growing to 1e-2 at the end
        }
        let e = measure(&run, &Sampled::new(exact.clone())).expect("measures");
        assert!((e.pos_final.expect("pos") - 1e-2).abs() < 1e-15);
        assert!((e.pos_max.expect("pos") - 1e-2).abs() < 1e-15);
        assert_eq!(e.rot_max, Some(0.0));
        let mut shifted = run.clone();
        shifted.t[3] += 1e-6;
        assert!(measure(&shifted, &Sampled::new(exact)).is_err());
    }

    #[test]
    fn sampler_hits_and_interpolates() {
        let fine: Vec<f64> = (0..=100).map(|i| i as f64 * 0.01).collect();
        let tr = uniform_rotation(&fine, 1.0);
        let want = [0.0, 0.2, 0.255, 1.0];
        let mut s = Sampler::new(1, &want);
        for f in 0..tr.t.len() {
            // feed the frames through the same code path as the observer
            let mut cur = Track::new(1);
            push_frame_of(&mut cur, &tr, f, tr.t[f]);
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
