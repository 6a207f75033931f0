//! The body states of a run at its output frames, and the interpolation between two frames
//! that the references use.

use crate::driver::run_loop::Frame;

/// Body states at the output frames of a run, frame-major (`r[f * bodies + b]`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Track {
    /// Number of bodies.
    pub bodies: usize,
    /// Frame times, s.
    pub t: Vec<f64>,
    /// Mass-centre positions, world, m.
    pub r: Vec<[f64; 3]>,
    /// Orientations, unit quaternions `[w, x, y, z]` body → world.
    pub q: Vec<[f64; 4]>,
    /// Mass-centre velocities, world, m/s.
    pub v: Vec<[f64; 3]>,
    /// Angular velocities, body components, rad/s.
    pub w: Vec<[f64; 3]>,
}

impl Track {
    /// An empty track for `bodies` bodies.
    pub fn new(bodies: usize) -> Track {
        Track {
            bodies,
            ..Track::default()
        }
    }

    /// Number of frames.
    pub fn frames(&self) -> usize {
        self.t.len()
    }

    /// Append a frame from the run driver's state.
    pub fn push_frame(&mut self, f: &Frame<'_>) {
        self.t.push(f.state.t);
        for (p, tw) in f.state.pose.iter().zip(&f.state.twist) {
            self.r.push([p.r.x, p.r.y, p.r.z]);
            self.q.push([p.q.w, p.q.i, p.q.j, p.q.k]);
            self.v.push([tw.v.x, tw.v.y, tw.v.z]);
            self.w.push([tw.w.x, tw.w.y, tw.w.z]);
        }
    }

    /// Append frame `i` of `src` (same number of bodies) with the time `t`.
    pub(super) fn push_frame_of(&mut self, src: &Track, i: usize, t: f64) {
        let n = src.bodies;
        self.t.push(t);
        self.r.extend_from_slice(&src.r[i * n..(i + 1) * n]);
        self.q.extend_from_slice(&src.q[i * n..(i + 1) * n]);
        self.v.extend_from_slice(&src.v[i * n..(i + 1) * n]);
        self.w.extend_from_slice(&src.w[i * n..(i + 1) * n]);
    }

    /// Position and orientation of body `b` at `t`, between frames `i` and `i + 1`: cubic
    /// Hermite with the velocities (q̇ = ½ q ⊗ (0, ω) for the orientation, renormalized).
    pub(super) fn interpolate(&self, i: usize, t: f64, b: usize) -> ([f64; 3], [f64; 4]) {
        let n = self.bodies;
        let (t0, t1) = (self.t[i], self.t[i + 1]);
        let dt = t1 - t0;
        let s = if dt > 0.0 { (t - t0) / dt } else { 0.0 };
        let (k0, k1) = (i * n + b, (i + 1) * n + b);
        let r = std::array::from_fn(|c| {
            hermite(
                self.r[k0][c],
                self.v[k0][c],
                self.r[k1][c],
                self.v[k1][c],
                dt,
                s,
            )
        });
        let q0 = self.q[k0];
        let mut q1 = self.q[k1];
        let d0 = qdot(&q0, &self.w[k0]);
        let mut d1 = qdot(&q1, &self.w[k1]);
        if dot4(&q0, &q1) < 0.0 {
            q1 = q1.map(|x| -x);
            d1 = d1.map(|x| -x);
        }
        let q: [f64; 4] = std::array::from_fn(|c| hermite(q0[c], d0[c], q1[c], d1[c], dt, s));
        (r, qnormalize(q).unwrap_or(q0))
    }
}

/// The cubic Hermite interpolant through `p0` (slope `m0`) at s = 0 and `p1` (slope `m1`)
/// at s = 1, on an interval of length `dt`.
pub(super) fn hermite(p0: f64, m0: f64, p1: f64, m1: f64, dt: f64, s: f64) -> f64 {
    let s2 = s * s;
    let s3 = s2 * s;
    (2.0 * s3 - 3.0 * s2 + 1.0) * p0
        + (s3 - 2.0 * s2 + s) * dt * m0
        + (-2.0 * s3 + 3.0 * s2) * p1
        + (s3 - s2) * dt * m1
}

/// `q / |q|`, or `None` for a zero or non-finite `q`.
pub(super) fn qnormalize(q: [f64; 4]) -> Option<[f64; 4]> {
    let n = dot4(&q, &q).sqrt();
    (n > 1e-12 && n.is_finite()).then(|| q.map(|x| x / n))
}

pub(super) fn dot4(a: &[f64; 4], b: &[f64; 4]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `a ⊗ b` for quaternions `[w, x, y, z]`.
pub(super) fn qmul(a: &[f64; 4], b: &[f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// `q̇ = ½ q ⊗ (0, ω)` with ω in body components.
fn qdot(q: &[f64; 4], w: &[f64; 3]) -> [f64; 4] {
    qmul(q, &[0.0, w[0], w[1], w[2]]).map(|x| 0.5 * x)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::study::error_measures::rotation_angle;

    #[test]
    fn hermite_is_exact_for_cubics() {
        // p(t) = t³ on [1, 2]
        let p = |t: f64| t * t * t;
        let d = |t: f64| 3.0 * t * t;
        let x = hermite(p(1.0), d(1.0), p(2.0), d(2.0), 1.0, 0.3);
        assert!((x - p(1.3)).abs() < 1e-13);
    }

    /// One body on the unit circle in the x–y plane, turning about z at `rate`.
    pub(in crate::study) fn uniform_rotation(times: &[f64], rate: f64) -> Track {
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
        let (r, q) = tr.interpolate(0, 0.004, 0);
        // cubic Hermite: error ≤ h⁴/384 · max|r⁗| ≈ 2.6e-11 here
        assert!((r[0] - 0.004f64.cos()).abs() < 5e-11, "{r:?}");
        assert!((r[1] - 0.004f64.sin()).abs() < 5e-11);
        let exact = [0.004f64.cos(), 0.0, 0.0, 0.004f64.sin()];
        assert!(rotation_angle(&q, &exact) < 1e-10);
    }
}
