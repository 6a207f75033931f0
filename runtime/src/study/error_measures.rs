//! The error of a run against a reference.
//!
//! At each frame time t of a run:
//! - position error e_r(t) = √( (1/n_r) Σ_b |r_b(t) − r_b,ref(t)|² ), m — the RMS over the
//!   n_r bodies with a reference position;
//! - orientation error e_θ(t) = √( (1/n_q) Σ_b θ_b(t)² ), rad, with θ_b the angle of the
//!   rotation q_b,ref⁻¹ q_b (`2 atan2(|vec|, |w|)`, so q and −q agree) — the RMS over the
//!   n_q bodies with a reference orientation.
//!
//! Each is reported at the final time (`final`) and as the maximum over the frames
//! (`max`): the four [`Errors`]; [`Measure`] names one of them.

use super::error::ReferenceError;
use super::reference::{RefBody, RefSolution};
use super::sampled::Sampled;
use super::track::{qmul, Track};

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

/// One of the four error measures: the one a study fits and a report plots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Measure {
    /// Largest position error over the frames (m).
    PosMax,
    /// Position error at the final time (m).
    PosFinal,
    /// Largest orientation error over the frames (rad).
    RotMax,
    /// Orientation error at the final time (rad).
    RotFinal,
}

impl Measure {
    /// The value of this measure.
    pub fn of(self, e: &Errors) -> Option<f64> {
        match self {
            Measure::PosMax => e.pos_max,
            Measure::PosFinal => e.pos_final,
            Measure::RotMax => e.rot_max,
            Measure::RotFinal => e.rot_final,
        }
    }

    /// What it is, with the unit.
    pub fn label(self) -> &'static str {
        match self {
            Measure::PosMax => "max-over-time position error, RMS over bodies (m)",
            Measure::PosFinal => "final-time position error, RMS over bodies (m)",
            Measure::RotMax => "max-over-time orientation error, RMS over bodies (rad)",
            Measure::RotFinal => "final-time orientation error, RMS over bodies (rad)",
        }
    }

    /// Short name (the column of `sweep.csv`).
    pub fn short(self) -> &'static str {
        match self {
            Measure::PosMax => "pos_err_max_m",
            Measure::PosFinal => "pos_err_final_m",
            Measure::RotMax => "rot_err_max_rad",
            Measure::RotFinal => "rot_err_final_rad",
        }
    }

    /// The unit.
    pub fn unit(self) -> &'static str {
        match self {
            Measure::PosMax | Measure::PosFinal => "m",
            Measure::RotMax | Measure::RotFinal => "rad",
        }
    }

    /// Whether this is a position measure.
    pub fn is_position(self) -> bool {
        matches!(self, Measure::PosMax | Measure::PosFinal)
    }
}

/// The angle of the rotation taking `a` to `b` (both unit quaternions `[w, x, y, z]`), rad,
/// in [0, π].
pub fn rotation_angle(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    let ac = [a[0], -a[1], -a[2], -a[3]];
    let d = qmul(&ac, b);
    let v = (d[1] * d[1] + d[2] * d[2] + d[3] * d[3]).sqrt();
    2.0 * v.atan2(d[0].abs())
}

/// The errors of a run's frames against a reference (see the module doc). A NaN state is
/// an infinite error.
///
/// # Errors
/// If the reference does not cover a frame time, or the run has no frames.
pub fn measure(track: &Track, reference: &dyn RefSolution) -> Result<Errors, ReferenceError> {
    let n = track.bodies;
    if track.t.is_empty() {
        return Err(ReferenceError::NotCovered("the run has no frames".into()));
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

/// Compare two tracks of the same frame times: `a` against `b` as the reference.
pub(super) fn difference(a: &Track, b: &Track) -> Option<Errors> {
    measure(a, &Sampled::new(b.clone())).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::sampled::Sampled;
    use crate::study::track::tests::uniform_rotation;

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
}
