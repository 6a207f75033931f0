//! One window of the state-time method on a planar scene: the unknowns of `E` time
//! elements, the Galerkin residuals of notes F §1.5–1.8 assembled by reading "D" (§1.10),
//! their analytic Jacobian, and Newton's method with a sparse LU.
//!
//! **Unknowns.** Per body five fields, interpolated by quadratic Lagrange functions on each
//! element: the angle-like integral of the angular velocity about the plane's normal `q`,
//! the in-plane mass-centre coordinates `x`, `y`, and the direction cosines `c`, `s` (the
//! cosine and sine of the rotation since the window's start, treated as independent
//! unknowns, notes F §2.1). Their nodal values at the `2E` nodes after the window's start
//! are unknown (the start node is the known initial state). Per joint two force
//! components (world, in-plane; the force on side b), interpolated linearly, with unknown
//! values at all `E + 1` element ends.
//!
//! **Equations.** Per body and global quadratic test function `Ψ_j`, `j = 0 … 2E − 1`
//! (every node but the last): Euler's and Newton's laws integrated by parts once (the
//! initial angular velocity and velocity enter as natural boundary terms at `t₀`), and
//! the two Poisson equations `ċ = −q̇ s`, `ṡ = q̇ c`. Per joint and global linear hat
//! `Φ_n`, `n = 0 … E`: the velocity-level point constraint in the linear form of notes F
//! eq. (15) (`ẋ + Ċρ` equal on both sides). Equations and unknowns are both
//! `10·E·bodies + 2·(E + 1)·joints` (1540 for the double pendulum at `E = 64`).
//!
//! **Order.** Unknowns and equations are numbered time-major (node by node), so the
//! Jacobian is banded: no equation reaches an unknown more than one element away.
//!
//! **Assembly and solve** are those of [`super::newton`]: per element in parallel, added in
//! element order, a sequential sparse LU.

use super::grid::{Grid, NG};
use super::newton::{self, Discretization, ElementBuffer, Failure, NewtonStats, Places};
use super::planar::Planar;
use super::shape::{dpsi, phi, psi};

/// Fields per body: `q, x, y, c, s`.
pub const FIELDS: usize = 5;
const Q: usize = 0;
const X: usize = 1;
const Y: usize = 2;
const C: usize = 3;
const S: usize = 4;

/// Names of a body's equations, by field index (for failure reports).
const BODY_EQUATIONS: [&str; FIELDS] = [
    "Euler's law",
    "Newton's law (x)",
    "Newton's law (y)",
    "Poisson's equation (c)",
    "Poisson's equation (s)",
];

/// The known state of one body at the window's start (plane components).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BodyStart {
    /// Mass-centre position in the plane, m.
    pub x: [f64; 2],
    /// Mass-centre velocity in the plane, m/s.
    pub v: [f64; 2],
    /// Angular velocity about the normal, rad/s.
    pub w: f64,
}

/// One joint side acting on a body.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Side {
    joint: usize,
    /// +1 on side b (the joint force acts on it), −1 on side a.
    sigma: f64,
    /// The attachment's in-plane offset from the mass centre at the window's start.
    rho: [f64; 2],
}

/// The problem of one window: constants, numbering and the current iterate.
pub struct Window {
    /// The numbering and quadrature.
    pub grid: Grid,
    nb: usize,
    nj: usize,
    mass: Vec<f64>,
    jn: Vec<f64>,
    /// Per body: the joint sides acting on it.
    sides: Vec<Vec<Side>>,
    /// Per joint: the two sides' body (`None`: ground) and offset at the start.
    joint_sides: Vec<[(Option<usize>, [f64; 2]); 2]>,
    start: Vec<BodyStart>,
    /// Applied loads `(Fx, Fy, Tn)` at `[(e·NG + g)·nb + b]`.
    loads: Vec<[f64; 3]>,
    /// Unknowns.
    pub u: Vec<f64>,
    bufs: Vec<ElementBuffer>,
    names: (Vec<String>, Vec<String>),
}

impl Window {
    /// The window of `elements` elements of length `h` from `t0` for `model`, starting from
    /// `start` (per body) with the joint attachments' in-plane offsets `offsets` (per joint,
    /// sides a and b: the world offset from the mass centre for a body side, the world
    /// point for ground) and the applied loads from `load(t, body)` (`[Fx, Fy, Tn]`).
    pub fn new(
        model: &Planar,
        elements: usize,
        h: f64,
        t0: f64,
        start: Vec<BodyStart>,
        offsets: &[[[f64; 2]; 2]],
        mut load: impl FnMut(f64, &mut [[f64; 3]]),
    ) -> Window {
        let nb = model.bodies.len();
        let nj = model.joints.len();
        let e = elements;
        let mut sides = vec![Vec::new(); nb];
        let mut joint_sides = Vec::with_capacity(nj);
        for (k, j) in model.joints.iter().enumerate() {
            if let Some(a) = j.a {
                sides[a].push(Side {
                    joint: k,
                    sigma: -1.0,
                    rho: offsets[k][0],
                });
            }
            if let Some(b) = j.b {
                sides[b].push(Side {
                    joint: k,
                    sigma: 1.0,
                    rho: offsets[k][1],
                });
            }
            joint_sides.push([(j.a, offsets[k][0]), (j.b, offsets[k][1])]);
        }
        let grid = Grid::new(e, h, t0, FIELDS * nb, 2 * nj);
        let loads = grid.sample(nb, &mut load);
        Window {
            u: vec![0.0; grid.unknowns],
            grid,
            nb,
            nj,
            mass: model.bodies.iter().map(|b| b.m).collect(),
            jn: model.bodies.iter().map(|b| b.jn).collect(),
            sides,
            joint_sides,
            start,
            loads,
            bufs: vec![ElementBuffer::default(); e],
            names: (
                model.bodies.iter().map(|b| b.name.clone()).collect(),
                model.joints.iter().map(|j| j.name.clone()).collect(),
            ),
        }
    }

    /// Number of bodies.
    pub fn bodies(&self) -> usize {
        self.nb
    }

    /// Number of unknowns (= equations).
    pub fn unknowns(&self) -> usize {
        self.u.len()
    }

    /// The index of field `f` of body `b` at node `j` (`None` at the known start node).
    #[inline]
    fn ku(&self, j: usize, b: usize, f: usize) -> Option<usize> {
        (j > 0).then(|| self.grid.kin_off[j] + FIELDS * b + f)
    }

    /// The index of force component `c` of joint `k` at force node `n`.
    #[inline]
    fn fu(&self, n: usize, k: usize, c: usize) -> usize {
        self.grid.frc_off[n] + 2 * k + c
    }

    /// Field `f` of body `b` at node `j` in `u`.
    #[inline]
    fn kin(&self, u: &[f64], j: usize, b: usize, f: usize) -> f64 {
        match self.ku(j, b, f) {
            Some(i) => u[i],
            None => match f {
                X => self.start[b].x[0],
                Y => self.start[b].x[1],
                C => 1.0,
                _ => 0.0,
            },
        }
    }

    /// Set body `b`'s fields at node `j ≥ 1`: `[q, x, y, c, s]`.
    pub fn set_kin(&mut self, j: usize, b: usize, v: [f64; FIELDS]) {
        if let Some(i) = self.ku(j, b, 0) {
            self.u[i..i + FIELDS].copy_from_slice(&v);
        }
    }

    /// Set joint `k`'s force (on side b, world in-plane components) at force node `n`.
    pub fn set_force(&mut self, n: usize, k: usize, f: [f64; 2]) {
        let i = self.fu(n, k, 0);
        self.u[i..i + 2].copy_from_slice(&f);
    }

    /// Body `b`'s fields `[q, x, y, c, s]` and their time derivatives at `τ` in element `e`.
    pub fn body_at(&self, e: usize, tau: f64, b: usize) -> ([f64; FIELDS], [f64; FIELDS]) {
        let p = psi(tau);
        let d = dpsi(tau);
        let mut v = [0.0; FIELDS];
        let mut dv = [0.0; FIELDS];
        for f in 0..FIELDS {
            for a in 0..3 {
                let x = self.kin(&self.u, 2 * e + a, b, f);
                v[f] += x * p[a];
                dv[f] += x * d[a] / self.grid.h;
            }
        }
        (v, dv)
    }

    /// Joint `k`'s force on side b at `τ` in element `e` (world, in-plane).
    pub fn force_at(&self, e: usize, tau: f64, k: usize) -> [f64; 2] {
        let f = phi(tau);
        let mut out = [0.0; 2];
        for c in 0..2 {
            out[c] = f[0] * self.u[self.fu(e, k, c)] + f[1] * self.u[self.fu(e + 1, k, c)];
        }
        out
    }

    /// Body `b`'s momentum-consistent ("weak") velocity at the end of element `e`: the one
    /// the global test function of that node would hand over (notes F §1.10),
    /// `[ω, vx, vy]`.
    pub fn end_velocity(&self, e: usize, b: usize) -> [f64; 3] {
        let mut out = [0.0; 3];
        let nodal = |f: usize, a: usize| self.kin(&self.u, 2 * e + a, b, f);
        for g in 0..NG {
            let (w, p, d) = (self.grid.tw[g], self.grid.tp[g], self.grid.td[g]);
            let val = |f: usize| (0..3).map(|a| nodal(f, a) * p[a]).sum::<f64>();
            let der = |f: usize| (0..3).map(|a| nodal(f, a) * d[a]).sum::<f64>();
            let (c, s) = (val(C), val(S));
            let ld = self.loads[(e * NG + g) * self.nb + b];
            let (mut fx, mut fy, mut mz) = (ld[0], ld[1], ld[2]);
            for sd in &self.sides[b] {
                let f = self.force_at_g(&self.u, e, g, sd.joint);
                let (rx, ry) = rotate(c, s, sd.rho);
                fx += sd.sigma * f[0];
                fy += sd.sigma * f[1];
                mz += sd.sigma * (rx * f[1] - ry * f[0]);
            }
            out[0] += w * (der(Q) * d[2] + mz / self.jn[b] * p[2]);
            out[1] += w * (der(X) * d[2] + fx / self.mass[b] * p[2]);
            out[2] += w * (der(Y) * d[2] + fy / self.mass[b] * p[2]);
        }
        out
    }

    #[inline]
    fn force_at_g(&self, u: &[f64], e: usize, g: usize, k: usize) -> [f64; 2] {
        let f = self.grid.tf[g];
        [
            f[0] * u[self.fu(e, k, 0)] + f[1] * u[self.fu(e + 1, k, 0)],
            f[0] * u[self.fu(e, k, 1)] + f[1] * u[self.fu(e + 1, k, 1)],
        ]
    }

    /// Element `e`'s residual and Jacobian entries at `u` into `buf`. The entries are the
    /// same in number and order at every `u` (the Jacobian's pattern is fixed).
    fn element(&self, e: usize, u: &[f64], buf: &mut ElementBuffer) {
        buf.res.clear();
        buf.jac.clear();
        let two_e = 2 * self.grid.elements;
        let (tp, td, tf, tw) = (&self.grid.tp, &self.grid.td, &self.grid.tf, &self.grid.tw);
        // joint forces at the Gauss points
        let mut fj = vec![[[0.0; 2]; NG]; self.nj];
        for (k, f) in fj.iter_mut().enumerate() {
            for g in 0..NG {
                f[g] = self.force_at_g(u, e, g, k);
            }
        }
        // body fields and derivatives at the Gauss points
        let mut val = vec![[[0.0; FIELDS]; NG]; self.nb];
        let mut der = vec![[[0.0; FIELDS]; NG]; self.nb];
        for b in 0..self.nb {
            for a in 0..3 {
                for f in 0..FIELDS {
                    let x = self.kin(u, 2 * e + a, b, f);
                    for g in 0..NG {
                        val[b][g][f] += x * tp[g][a];
                        der[b][g][f] += x * td[g][a];
                    }
                }
            }
        }
        let mut jac = |r: Option<usize>, c: Option<usize>, v: f64| {
            if let (Some(r), Some(c)) = (r, c) {
                buf.jac.push((r, c, v));
            }
        };
        for b in 0..self.nb {
            let (m, jn) = (self.mass[b], self.jn[b]);
            let vb = &val[b];
            let db = &der[b];
            for r in 0..3 {
                let j = 2 * e + r;
                if j >= two_e {
                    continue;
                }
                let row = |f: usize| Some(self.grid.kin_row[j] + FIELDS * b + f);
                // residuals
                let mut res = [0.0; FIELDS];
                for g in 0..NG {
                    let (w, p, d) = (tw[g], tp[g][r], td[g][r]);
                    let (c, s) = (vb[g][C], vb[g][S]);
                    let ld = self.loads[(e * NG + g) * self.nb + b];
                    let (mut fx, mut fy, mut mz) = (ld[0], ld[1], ld[2]);
                    for sd in &self.sides[b] {
                        let f = fj[sd.joint][g];
                        let (rx, ry) = rotate(c, s, sd.rho);
                        fx += sd.sigma * f[0];
                        fy += sd.sigma * f[1];
                        mz += sd.sigma * (rx * f[1] - ry * f[0]);
                    }
                    let qd = db[g][Q];
                    res[0] += w * (jn * qd * d + mz * p);
                    res[1] += w * (m * db[g][X] * d + fx * p);
                    res[2] += w * (m * db[g][Y] * d + fy * p);
                    res[3] += w * (db[g][C] + qd * s) * p;
                    res[4] += w * (db[g][S] - qd * c) * p;
                }
                if j == 0 {
                    let st = &self.start[b];
                    res[0] += jn * st.w;
                    res[1] += m * st.v[0];
                    res[2] += m * st.v[1];
                }
                for f in 0..FIELDS {
                    buf.res
                        .push((self.grid.kin_row[j] + FIELDS * b + f, res[f]));
                }
                // Jacobian
                for a in 0..3 {
                    let col = |f: usize| self.ku(2 * e + a, b, f);
                    let (mut kk, mut gg, mut gs, mut gc, mut qs, mut qc) =
                        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
                    let (mut ec, mut es) = (0.0, 0.0);
                    for g in 0..NG {
                        let (w, p, d) = (tw[g], tp[g][r], td[g][r]);
                        let (pa, da) = (tp[g][a], td[g][a]);
                        kk += w * da * d;
                        gg += w * da * p;
                        gs += w * da * vb[g][S] * p;
                        gc += w * da * vb[g][C] * p;
                        qs += w * db[g][Q] * pa * p;
                        qc += w * db[g][Q] * pa * p;
                        for sd in &self.sides[b] {
                            let f = fj[sd.joint][g];
                            let (ra, rb) = (sd.rho[0], sd.rho[1]);
                            ec += w * p * sd.sigma * pa * (ra * f[1] - rb * f[0]);
                            es += w * p * sd.sigma * pa * (-rb * f[1] - ra * f[0]);
                        }
                    }
                    jac(row(0), col(Q), jn * kk);
                    jac(row(0), col(C), ec);
                    jac(row(0), col(S), es);
                    jac(row(1), col(X), m * kk);
                    jac(row(2), col(Y), m * kk);
                    jac(row(3), col(C), gg);
                    jac(row(3), col(Q), gs);
                    jac(row(3), col(S), qs);
                    jac(row(4), col(S), gg);
                    jac(row(4), col(Q), -gc);
                    jac(row(4), col(C), -qc);
                }
                for sd in &self.sides[b] {
                    for k2 in 0..2 {
                        let (mut fxm, mut fym, mut fn_) = (0.0, 0.0, 0.0);
                        for g in 0..NG {
                            let (w, p) = (tw[g], tp[g][r]);
                            let (rx, ry) = rotate(vb[g][C], vb[g][S], sd.rho);
                            let wf = w * p * sd.sigma * tf[g][k2];
                            fxm += -wf * ry;
                            fym += wf * rx;
                            fn_ += wf;
                        }
                        let cx = Some(self.fu(e + k2, sd.joint, 0));
                        let cy = Some(self.fu(e + k2, sd.joint, 1));
                        jac(row(0), cx, fxm);
                        jac(row(0), cy, fym);
                        jac(row(1), cx, fn_);
                        jac(row(2), cy, fn_);
                    }
                }
            }
        }
        // velocity-level joint constraints against the hats of the element's ends
        for k in 0..self.nj {
            for k2 in 0..2 {
                let n = e + k2;
                let rx = Some(self.grid.frc_row[n] + 2 * k);
                let ry = Some(self.grid.frc_row[n] + 2 * k + 1);
                let mut res = [0.0; 2];
                for (si, &(body, rho)) in self.joint_sides[k].iter().enumerate() {
                    let Some(b) = body else { continue };
                    let sgn = if si == 0 { 1.0 } else { -1.0 };
                    let (ra, rb) = (rho[0], rho[1]);
                    for g in 0..NG {
                        let wf = tw[g] * tf[g][k2] * sgn;
                        let d = &der[b][g];
                        res[0] += wf * (d[X] + d[C] * ra - d[S] * rb);
                        res[1] += wf * (d[Y] + d[S] * ra + d[C] * rb);
                    }
                    for a in 0..3 {
                        let col = |f: usize| self.ku(2 * e + a, b, f);
                        let s: f64 = (0..NG).map(|g| tw[g] * tf[g][k2] * td[g][a]).sum();
                        let s = s * sgn;
                        jac(rx, col(X), s);
                        jac(rx, col(C), s * ra);
                        jac(rx, col(S), -s * rb);
                        jac(ry, col(Y), s);
                        jac(ry, col(S), s * ra);
                        jac(ry, col(C), s * rb);
                    }
                }
                buf.res.push((self.grid.frc_row[n] + 2 * k, res[0]));
                buf.res.push((self.grid.frc_row[n] + 2 * k + 1, res[1]));
            }
        }
    }

    /// Newton's method from the current unknowns ([`newton::solve`]).
    pub fn newton(&mut self, tol: f64, max_iterations: u32) -> Result<NewtonStats, Failure> {
        let mut u = std::mem::take(&mut self.u);
        let mut bufs = std::mem::take(&mut self.bufs);
        let out = newton::solve(&*self, &mut u, &mut bufs, tol, max_iterations);
        (self.u, self.bufs) = (u, bufs);
        out
    }

    fn places(&self) -> Places<'_> {
        Places {
            t0: self.grid.t0,
            h: self.grid.h,
            body_names: &self.names.0,
            joint_names: &self.names.1,
        }
    }
}

impl Discretization for Window {
    fn unknowns(&self) -> usize {
        self.u.len()
    }
    fn elements(&self) -> usize {
        self.grid.elements
    }
    fn element(&self, e: usize, u: &[f64], buf: &mut ElementBuffer) {
        Window::element(self, e, u, buf);
    }
    fn place_of_unknown(&self, i: usize) -> String {
        let fields = [
            "unknown q",
            "unknown x",
            "unknown y",
            "unknown c",
            "unknown s",
        ];
        let nodes = 1..2 * self.grid.elements + 1;
        self.places().find(
            i,
            (&self.grid.kin_off, nodes, &fields),
            (&self.grid.frc_off, "force", &["x", "y"]),
        )
    }
    fn place_of_equation(&self, i: usize) -> String {
        let nodes = 0..2 * self.grid.elements;
        self.places().find(
            i,
            (&self.grid.kin_row, nodes, &BODY_EQUATIONS),
            (&self.grid.frc_row, "velocity constraint", &["x", "y"]),
        )
    }
}

/// The in-plane offset `(a, b)` turned by the cosines `(c, s)`.
#[inline]
fn rotate(c: f64, s: f64, rho: [f64; 2]) -> (f64, f64) {
    (c * rho[0] - s * rho[1], s * rho[0] + c * rho[1])
}
