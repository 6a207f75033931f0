//! The yardstick: a hand-written, carefully optimized implementation of the staggered method
//! with its defaults (`runtime/src/integrators/staggered.rs`), specialized to one scene — the
//! 3-D double pendulum of `models/double_pendulum_3d.mbd`: two bodies, a spherical joint
//! ground–body 0 and a spherical joint body 0–body 1, gravity.
//!
//! Same algorithm as the runtime, step for step:
//! - one leapfrog sequence: positions at τ, velocities at τ − h/2;
//! - CINT per body: `v ← v + h(F − f_λ)/m`, the rotational kick by the implicit midpoint rule
//!   `J(ω⁺ − ω)/h + ω̄ × Jω̄ = τ − τ_λ` solved by a 3×3 Newton iteration, `r ← r + h v`, and
//!   the Cayley quaternion update with `Δ = 1 + h²|ω|²/16`;
//! - LINT in the exact-integral form `E(λ − λ⁰) = Φ(X_λ(τ + h))`, solved by Newton on λ with
//!   the matrix `E + h² B M⁻¹ Bᵀ` (B at τ), warm-started by `2λ − λ_prev`, with the
//!   runtime's tolerance and stopping rule and its retry with a larger E;
//! - `E_r = 10⁻⁹ h² K_rr` from `K = B M⁻¹ Bᵀ` at the start, λ⁰ the consistent index-1
//!   multiplier, the sequence started at −h/2 with `v⁰ − (h/2) v̇⁰` and ω by the midpoint
//!   rule run backwards over h/2.
//!
//! What a hand writer knows and the runtime cannot: the six rows, their two bodies, the block
//! pattern of B (translational blocks ±I, rotational blocks `∓C ρ̃`), so `B M⁻¹ Bᵀ` is three
//! 3×3 blocks built from `W J⁻¹ Wᵀ` products, the 6×6 Cholesky is straight-line code on a
//! fixed array, `Bᵀλ` is two 3-vectors per body, and nothing is stored that is not used
//! (Φ only at the trial positions, no bias or γ during a step).
//!
//! The numbers (masses, inertias, joint points, gravity, initial state) are read from the
//! scene at construction; the structure is fixed and checked.

// Index loops are the plainest form of the fixed-size matrix code below.
#![allow(clippy::needless_range_loop)]

use mbdc_runtime::integrators::State;
use mbdc_runtime::interp::Interp;
use mbdc_runtime::nalgebra::{Matrix3, Quaternion, Vector3};
use mbdc_runtime::scene::{BodyRef, JointKind, Scene};
use mbdc_runtime::system::{Pose, System};

/// Newton iterations of the LINT before giving up (the runtime's `MAX_NEWTON`).
const MAX_NEWTON: u32 = 25;

/// One body's constant data.
#[derive(Clone, Copy, Debug)]
struct Body {
    inv_m: f64,
    j: Matrix3<f64>,
    j_inv: Matrix3<f64>,
}

/// One body's state in the leapfrog sequence.
#[derive(Clone, Copy, Debug)]
struct Dyn {
    r: Vector3<f64>,
    q: Quaternion<f64>,
    c: Matrix3<f64>,
    v: Vector3<f64>,
    w: Vector3<f64>,
}

/// The staggered method on the 3-D double pendulum (see the module doc).
#[derive(Clone, Debug)]
pub struct DoublePendulum {
    h: f64,
    b: [Body; 2],
    /// Gravity force per body.
    f: [Vector3<f64>; 2],
    /// Joint points, body components: shoulder on body 0, elbow on body 0 and on body 1.
    rho_s: Vector3<f64>,
    rho_e0: Vector3<f64>,
    rho_e1: Vector3<f64>,
    /// The ground point of the shoulder, world components.
    ground_s: Vector3<f64>,
    /// Regularization per row.
    e: [f64; 6],
    x: [Dyn; 2],
    lambda: [f64; 6],
    lambda_prev: [f64; 6],
    lambda0: [f64; 6],
    tau: f64,
    steps: u64,
    t0: f64,
    /// Newton iterations of the LINT in total.
    pub iterations: u64,
}

/// Rotational Jacobian blocks at a pose: for the shoulder rows on body 0 (`C ρ̃_s`), the
/// elbow rows on body 0 (`−C ρ̃_e0`) and on body 1 (`C ρ̃_e1`); `W[k]` is row k.
#[derive(Clone, Copy, Debug)]
struct Jac {
    ws: Matrix3<f64>,
    we0: Matrix3<f64>,
    we1: Matrix3<f64>,
}

#[inline(always)]
fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// `A⁻¹ b` for a 3×3 matrix by cofactors; `None` if singular.
#[inline(always)]
fn solve3(a: &Matrix3<f64>, b: &Vector3<f64>) -> Option<Vector3<f64>> {
    let c0 = a.column(1).cross(&a.column(2));
    let c1 = a.column(2).cross(&a.column(0));
    let c2 = a.column(0).cross(&a.column(1));
    let det = a.column(0).dot(&c0);
    if det == 0.0 {
        return None;
    }
    // rows of the inverse are the cofactor vectors / det
    Some(Vector3::new(c0.dot(b), c1.dot(b), c2.dot(b)) / det)
}

/// The implicit midpoint rotational kick over `h` (as the runtime's `midpoint_kick`).
#[inline(always)]
fn kick(b: &Body, w0: &Vector3<f64>, tau: &Vector3<f64>, h: f64) -> Vector3<f64> {
    let j = &b.j;
    let inv_h = 1.0 / h;
    let mut w1 = w0 + b.j_inv * tau * h;
    for _ in 0..8 {
        let wb = (w0 + w1) * 0.5;
        let jwb = j * wb;
        let f = j * (w1 - w0) * inv_h + wb.cross(&jwb) - tau;
        let jac = j * inv_h + (skew(&wb) * j - skew(&jwb)) * 0.5;
        let Some(d) = solve3(&jac, &f) else { break };
        w1 -= d;
        if d.norm() <= 1e-15 * (1.0 + w1.norm()) {
            break;
        }
    }
    w1
}

/// The Cayley update of the Euler parameters (`Δ = 1 + h²|ω|²/16`), normalized.
#[inline(always)]
fn cayley(q: &Quaternion<f64>, w: &Vector3<f64>, h: f64) -> Quaternion<f64> {
    let delta = 1.0 + h * h * w.norm_squared() / 16.0;
    let a = w * (0.25 * h);
    let p = Quaternion::new(1.0, a.x, a.y, a.z);
    let qt = q * p / delta;
    let qn = qt * 2.0 - q;
    qn / qn.norm()
}

/// In-place Cholesky of a symmetric positive definite 6×6 matrix (lower triangle), then
/// solves with it. Returns `false` on a non-positive pivot.
#[inline(always)]
fn cholesky6(a: &mut [[f64; 6]; 6]) -> bool {
    for j in 0..6 {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[j][k] * a[j][k];
        }
        if d <= 0.0 || !d.is_finite() {
            return false;
        }
        let d = d.sqrt();
        a[j][j] = d;
        let inv = 1.0 / d;
        for i in j + 1..6 {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k];
            }
            a[i][j] = s * inv;
        }
    }
    true
}

#[inline(always)]
fn cholesky6_solve(l: &[[f64; 6]; 6], x: &mut [f64; 6]) {
    for i in 0..6 {
        let mut s = x[i];
        for k in 0..i {
            s -= l[i][k] * x[k];
        }
        x[i] = s / l[i][i];
    }
    for i in (0..6).rev() {
        let mut s = x[i];
        for k in i + 1..6 {
            s -= l[k][i] * x[k];
        }
        x[i] = s / l[i][i];
    }
}

impl DoublePendulum {
    /// The method on `scene` with step `h`, started as the runtime starts it. Panics if the
    /// scene is not a double pendulum of that structure.
    pub fn new(scene: &Scene, h: f64) -> DoublePendulum {
        let sys = Interp::new(scene).expect("a rigid scene");
        let layout = sys.layout();
        assert_eq!(layout.bodies(), 2, "two bodies");
        assert_eq!(scene.joints.len(), 2, "two joints");
        let (js, je) = (&scene.joints[0], &scene.joints[1]);
        assert!(
            matches!(js.kind, JointKind::Spherical) && matches!(je.kind, JointKind::Spherical),
            "two spherical joints"
        );
        assert!(
            js.a.body == BodyRef::Ground
                && js.b.body == BodyRef::Body(0)
                && je.a.body == BodyRef::Body(0)
                && je.b.body == BodyRef::Body(1),
            "ground–0 and 0–1"
        );
        let v3 = |a: &[f64; 3]| Vector3::new(a[0], a[1], a[2]);
        let g = scene.gravity.map(|g| v3(&g)).unwrap_or_else(Vector3::zeros);
        let body = |i: usize| {
            let m = &layout.mass[i];
            Body {
                inv_m: 1.0 / m.m,
                j: m.j,
                j_inv: m.j_inv,
            }
        };
        let st = State::initial(&sys);
        let dyn_of = |i: usize| Dyn {
            r: st.pose[i].r,
            q: st.pose[i].q,
            c: st.pose[i].c,
            v: st.twist[i].v,
            w: st.twist[i].w,
        };
        let mut s = DoublePendulum {
            h,
            b: [body(0), body(1)],
            f: [g * layout.mass[0].m, g * layout.mass[1].m],
            rho_s: v3(&js.b.point),
            rho_e0: v3(&je.a.point),
            rho_e1: v3(&je.b.point),
            ground_s: v3(&js.a.point),
            e: [0.0; 6],
            x: [dyn_of(0), dyn_of(1)],
            lambda: [0.0; 6],
            lambda_prev: [0.0; 6],
            lambda0: [0.0; 6],
            tau: st.t,
            steps: 0,
            t0: st.t,
            iterations: 0,
        };
        s.start();
        s
    }

    /// λ⁰, E and the velocities at −h/2 (the runtime's start).
    fn start(&mut self) {
        let h = self.h;
        let jac = self.jacobian();
        let k = self.k_matrix(&jac, 1.0);
        // E_r = 10⁻⁹ h² K_rr (floored as the runtime does)
        let kdiag = (0..6).map(|r| k[r][r]).fold(0.0, f64::max);
        let floor = 1e-9 * h * h * kdiag * f64::EPSILON;
        for r in 0..6 {
            self.e[r] = (1e-9 * h * h * k[r][r]).max(floor).max(f64::MIN_POSITIVE);
        }
        // Q̄ with the gyroscopic term at the start
        let q: [(Vector3<f64>, Vector3<f64>); 2] = std::array::from_fn(|i| {
            let (b, x) = (&self.b[i], &self.x[i]);
            (self.f[i], -x.w.cross(&(b.j * x.w)))
        });
        // K λ = B M⁻¹ Q̄ − γ
        let bm = self.b_minv(&jac, &q);
        let gamma = self.gamma();
        let mut l = k;
        assert!(cholesky6(&mut l), "K at the start is positive definite");
        let mut lam: [f64; 6] = std::array::from_fn(|r| bm[r] - gamma[r]);
        cholesky6_solve(&l, &mut lam);
        self.lambda = lam;
        self.lambda_prev = lam;
        self.lambda0 = lam;
        // v(−h/2) by an explicit half step back; ω(−h/2) by the implicit midpoint rule run
        // backwards over h/2 with the torque without the gyroscopic term
        let fl = self.bt_lambda(&jac, &lam);
        for i in 0..2 {
            let (b, x) = (self.b[i], &mut self.x[i]);
            let av = (q[i].0 - fl[i].0) * b.inv_m;
            x.v -= av * (h / 2.0);
            x.w = kick(&b, &x.w, &(-fl[i].1), -h / 2.0);
        }
    }

    /// The rotational Jacobian blocks at the current positions.
    #[inline(always)]
    fn jacobian(&self) -> Jac {
        let (c0, c1) = (&self.x[0].c, &self.x[1].c);
        Jac {
            // shoulder: Φ = g − (r₀ + C₀ρ_s): ∂/∂ω₀ = C₀ρ̃_s
            ws: c0 * skew(&self.rho_s),
            // elbow: Φ = r₀ + C₀ρ_e0 − r₁ − C₁ρ_e1
            we0: -(c0 * skew(&self.rho_e0)),
            we1: c1 * skew(&self.rho_e1),
        }
    }

    /// `s·B M⁻¹ Bᵀ` as a full symmetric 6×6 array (rows 0–2 shoulder, 3–5 elbow).
    #[inline(always)]
    fn k_matrix(&self, jac: &Jac, s: f64) -> [[f64; 6]; 6] {
        let (b0, b1) = (&self.b[0], &self.b[1]);
        let a_s = jac.ws * b0.j_inv;
        let a_e0 = jac.we0 * b0.j_inv;
        let a_e1 = jac.we1 * b1.j_inv;
        let kss = a_s * jac.ws.transpose();
        let kse = a_s * jac.we0.transpose();
        let kee = a_e0 * jac.we0.transpose() + a_e1 * jac.we1.transpose();
        let mut k = [[0.0; 6]; 6];
        for i in 0..3 {
            for j in 0..3 {
                let d = if i == j { 1.0 } else { 0.0 };
                // translational parts: shoulder −I on body 0, elbow +I on 0 and −I on 1
                k[i][j] = s * (kss[(i, j)] + d * b0.inv_m);
                k[i][j + 3] = s * (kse[(i, j)] - d * b0.inv_m);
                k[j + 3][i] = k[i][j + 3];
                k[i + 3][j + 3] = s * (kee[(i, j)] + d * (b0.inv_m + b1.inv_m));
            }
        }
        k
    }

    /// `Bᵀλ` per body: (force, torque in body components).
    #[inline(always)]
    fn bt_lambda(&self, jac: &Jac, l: &[f64; 6]) -> [(Vector3<f64>, Vector3<f64>); 2] {
        let ls = Vector3::new(l[0], l[1], l[2]);
        let le = Vector3::new(l[3], l[4], l[5]);
        [
            (le - ls, jac.ws.tr_mul(&ls) + jac.we0.tr_mul(&le)),
            (-le, jac.we1.tr_mul(&le)),
        ]
    }

    /// `B M⁻¹ F` for per-body wrenches.
    fn b_minv(&self, jac: &Jac, q: &[(Vector3<f64>, Vector3<f64>); 2]) -> [f64; 6] {
        let a0 = (q[0].0 * self.b[0].inv_m, self.b[0].j_inv * q[0].1);
        let a1 = (q[1].0 * self.b[1].inv_m, self.b[1].j_inv * q[1].1);
        let s = -a0.0 + jac.ws * a0.1;
        let e = a0.0 + jac.we0 * a0.1 - a1.0 + jac.we1 * a1.1;
        [s.x, s.y, s.z, e.x, e.y, e.z]
    }

    /// γ of the two spherical joints at the current state (start only).
    fn gamma(&self) -> [f64; 6] {
        let pdd = |x: &Dyn, rho: &Vector3<f64>| {
            let w = x.c * x.w;
            let s = x.c * rho;
            w.cross(&w.cross(&s))
        };
        // γ = −(p̈_a − p̈_b) velocity-product parts
        let s = pdd(&self.x[0], &self.rho_s);
        let e = -(pdd(&self.x[0], &self.rho_e0) - pdd(&self.x[1], &self.rho_e1));
        [s.x, s.y, s.z, e.x, e.y, e.z]
    }

    /// Φ of the two joints at a state.
    #[inline(always)]
    fn phi(&self, x: &[Dyn; 2]) -> [f64; 6] {
        let s = self.ground_s - (x[0].r + x[0].c * self.rho_s);
        let e = (x[0].r + x[0].c * self.rho_e0) - (x[1].r + x[1].c * self.rho_e1);
        [s.x, s.y, s.z, e.x, e.y, e.z]
    }

    /// The CINT of both bodies with the constraint forces `fl`.
    #[inline(always)]
    fn cint(&self, fl: &[(Vector3<f64>, Vector3<f64>); 2]) -> [Dyn; 2] {
        let h = self.h;
        std::array::from_fn(|i| {
            let (b, x) = (&self.b[i], &self.x[i]);
            let v = x.v + (self.f[i] - fl[i].0) * (b.inv_m * h);
            let w = kick(b, &x.w, &(-fl[i].1), h);
            let q = cayley(&x.q, &w, h);
            Dyn {
                r: x.r + v * h,
                q,
                c: mbdc_runtime::math::rotation(&q),
                v,
                w,
            }
        })
    }

    /// One step of h.
    pub fn step(&mut self) {
        // warm start
        for r in 0..6 {
            let (l1, l0) = (self.lambda[r], self.lambda_prev[r]);
            self.lambda_prev[r] = l1;
            self.lambda[r] = 2.0 * l1 - l0;
        }
        let jac = self.jacobian();
        let guess = self.lambda;
        let mut done = false;
        for scale in [1.0, 1e3, 1e6, 1e9] {
            self.lambda = guess;
            if self.lint(&jac, scale) {
                done = true;
                break;
            }
        }
        assert!(done, "the LINT Newton iteration did not converge");
        self.steps += 1;
        self.tau = self.t0 + (2 * self.steps) as f64 * self.h / 2.0;
    }

    /// Newton on λ for `E(λ − λ⁰) = Φ(X_λ(τ + h))` with E scaled by `scale`; on success the
    /// sequence is advanced.
    #[inline(always)]
    fn lint(&mut self, jac: &Jac, scale: f64) -> bool {
        let h = self.h;
        let e: [f64; 6] = std::array::from_fn(|r| self.e[r] * scale);
        let mut a = self.k_matrix(jac, h * h);
        for r in 0..6 {
            a[r][r] += e[r];
        }
        if !cholesky6(&mut a) {
            return false;
        }
        let extent = self.x[0].r.norm().max(self.x[1].r.norm());
        let tol = 1e-13 * (1.0 + extent);
        let mut prev = f64::INFINITY;
        for it in 0..MAX_NEWTON {
            let fl = self.bt_lambda(jac, &self.lambda);
            let trial = self.cint(&fl);
            let phi = self.phi(&trial);
            let mut res = [0.0; 6];
            let mut worst: f64 = 0.0;
            for r in 0..6 {
                res[r] = phi[r] - e[r] * (self.lambda[r] - self.lambda0[r]);
                worst = worst.max(res[r].abs());
            }
            if !worst.is_finite() {
                return false;
            }
            if worst <= tol || (it >= 2 && worst <= 1e3 * tol && worst >= 0.5 * prev) {
                self.x = trial;
                self.iterations += it as u64;
                return true;
            }
            prev = worst;
            cholesky6_solve(&a, &mut res);
            for r in 0..6 {
                self.lambda[r] += res[r];
            }
        }
        false
    }

    /// Time.
    pub fn time(&self) -> f64 {
        self.tau
    }

    /// The poses at the current time.
    pub fn poses(&self) -> [Pose; 2] {
        std::array::from_fn(|i| Pose {
            r: self.x[i].r,
            q: self.x[i].q,
            c: self.x[i].c,
        })
    }

    /// The multipliers of the last LINT.
    pub fn lambda(&self) -> [f64; 6] {
        self.lambda
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mbdc_runtime::integrators;

    /// The yardstick follows the runtime's trajectory over the scene's whole run (10 000 steps,
    /// 10 s, through large chaotic swings): positions and Euler parameters equal to 1e-11
    /// (absolute; m and 1, the bars are 1 m long; measured 1e-12) and the multipliers to 1e-9
    /// of the largest (measured 7e-11: the Newton iteration stops at a residual of 1e-13 m,
    /// which leaves λ free at that level). The two differ only in the order of operations.
    #[test]
    fn agrees_with_the_runtime() {
        let path = format!(
            "{}/../models/double_pendulum_3d.mbd",
            env!("CARGO_MANIFEST_DIR")
        );
        let scene = mbdc_compiler::load_file(&path, &[]).scene.expect("loads");
        let h = scene.simulate.step;
        let sys = Interp::new(&scene).expect("rigid");
        let start = State::initial(&sys);
        let mut it = integrators::make(&scene.simulate.method, &sys, h, &start).expect("starts");
        let mut ys = DoublePendulum::new(&scene, h);
        let mut st = State::initial(&sys);
        let (mut dx, mut dl, mut lmax) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..10_000 {
            it.step(&sys).expect("steps");
            ys.step();
            it.state(&sys, &mut st);
            assert!((st.t - ys.time()).abs() < 1e-12);
            for (p, y) in st.pose.iter().zip(ys.poses()) {
                dx = dx.max((p.r - y.r).amax());
                dx = dx.max((p.q.coords - y.q.coords).amax());
            }
        }
        // The runtime reports λ extrapolated from the last LINT (at the start of the step)
        // to the end of the step: λ + (λ − λ_prev).
        let l = ys.lambda();
        for r in 0..6 {
            let slope = l[r] - ys.lambda_prev[r];
            dl = dl.max((st.lambda[r] - (l[r] + slope)).abs());
            lmax = lmax.max(l[r].abs());
        }
        eprintln!(
            "after 10000 steps: positions differ by {dx:e}, multipliers by {dl:e} (max {lmax:e})"
        );
        assert!(dx <= 1e-11, "positions differ by {dx:e}");
        assert!(
            dl <= 1e-9 * lmax,
            "multipliers differ by {dl:e} (max {lmax:e})"
        );
    }
}
