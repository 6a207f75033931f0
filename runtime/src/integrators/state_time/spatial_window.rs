//! One window of the state-time method on a spatial scene: the Newton–Euler equations of
//! notes F §1.5–1.8 in three dimensions, assembled by reading "D" (§1.10) and solved by
//! [`super::newton`].
//!
//! **Unknowns.** Per body fifteen fields, interpolated by quadratic Lagrange functions on
//! each element: the angle-like integral `q` of the body-frame angular velocity (three;
//! `ω = q̇`, `q = 0` at the window's start), the mass-centre position `x` (three, world) and
//! the nine direction cosines `C = ᴺCᴮ` (row-major; treated as independent unknowns,
//! orthonormality is not imposed, notes F §1.7). Their nodal values at the `2E` nodes after
//! the window's start are unknown. Per (spherical) joint the three world components of the
//! force on side b, interpolated linearly, with unknown values at all `E + 1` element ends.
//!
//! **Equations.** Per body and global quadratic test function `Ψ_j`, `j = 0 … 2E − 1`:
//! - Euler's law in body components, integrated by parts once,
//!   `δ_j0 J ω₀ + ∫ [J q̇ Ψ̇_j + (M − q̇ × J q̇) Ψ_j] dt = 0`, with the moment
//!   `M = CᵀT + Σ σ ρ × (Cᵀf)` of the applied torque `T` (world) and the joint forces `f`
//!   (`σ = +1` on side b, −1 on side a; `ρ` the attachment in body components);
//! - Newton's law, `δ_j0 m v₀ + ∫ [m ẋ Ψ̇_j + (F + Σ σ f) Ψ_j] dt = 0`;
//! - Poisson's equation `Ċ = C[ω]×`, row by row `ċᵢ = cᵢ × q̇`: `∫ (ċᵢ − cᵢ × q̇) Ψ_j dt = 0`.
//!
//! Per joint and global linear hat `Φ_n`, `n = 0 … E`: the velocity-level point constraint
//! `∫ (ẋ_a + Ċ_a ρ_a − ẋ_b − Ċ_b ρ_b) Φ_n dt = 0` (notes F eq. (15), linear). Equations
//! and unknowns are both `30·E·bodies + 3·(E + 1)·joints`. The system is at most quadratic
//! (the gyroscopic term, `C f` and `C q̇`), so the analytic Jacobian is exact.
//!
//! **Order.** Unknowns and equations are numbered time-major (node by node), so the
//! Jacobian is banded.

use super::grid::{Grid, NG};
use super::newton::{self, Discretization, ElementBuffer, Failure, NewtonStats, Places};
use super::shape::{dpsi, phi, psi};
use super::spatial::Spatial;
use crate::contract::math::skew;
use nalgebra::{Matrix3, Vector3};

/// Fields per body: `q` (3), `x` (3), `C` (9, row-major).
pub const FIELDS: usize = 15;
const Q: usize = 0;
const X: usize = 3;
const C: usize = 6;

/// Names of a body's equations and unknowns, by field index (for failure reports).
const BODY_EQUATIONS: [&str; FIELDS] = [
    "Euler's law (x)",
    "Euler's law (y)",
    "Euler's law (z)",
    "Newton's law (x)",
    "Newton's law (y)",
    "Newton's law (z)",
    "Poisson's equation (C11)",
    "Poisson's equation (C12)",
    "Poisson's equation (C13)",
    "Poisson's equation (C21)",
    "Poisson's equation (C22)",
    "Poisson's equation (C23)",
    "Poisson's equation (C31)",
    "Poisson's equation (C32)",
    "Poisson's equation (C33)",
];
const BODY_UNKNOWNS: [&str; FIELDS] = [
    "unknown q (x)",
    "unknown q (y)",
    "unknown q (z)",
    "unknown x",
    "unknown y",
    "unknown z",
    "unknown C11",
    "unknown C12",
    "unknown C13",
    "unknown C21",
    "unknown C22",
    "unknown C23",
    "unknown C31",
    "unknown C32",
    "unknown C33",
];
const XYZ: [&str; 3] = ["x", "y", "z"];

/// The known state of one body at the window's start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyStart {
    /// Mass-centre position, world, m.
    pub x: Vector3<f64>,
    /// Mass-centre velocity, world, m/s.
    pub v: Vector3<f64>,
    /// Direction cosines `ᴺCᴮ`.
    pub c: Matrix3<f64>,
    /// Angular velocity, body components, rad/s.
    pub w: Vector3<f64>,
}

/// One joint side acting on a body.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Side {
    joint: usize,
    /// +1 on side b (the joint force acts on it), −1 on side a.
    sigma: f64,
    /// The attachment in body components from the mass centre.
    rho: Vector3<f64>,
}

/// Applied loads at one Gauss point of one body: force and torque, world components.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Load {
    /// Force at the mass centre, N.
    pub f: Vector3<f64>,
    /// Torque, N·m.
    pub t: Vector3<f64>,
}

/// A body's fields at one Gauss point.
#[derive(Clone, Copy, Debug)]
struct Point {
    /// `q̇ = ω` (body), `ẋ` (world).
    w: Vector3<f64>,
    xd: Vector3<f64>,
    /// `C` and `Ċ`.
    c: Matrix3<f64>,
    cd: Matrix3<f64>,
}

/// The problem of one spatial window: constants, numbering and the current iterate.
pub struct SpatialWindow {
    /// The numbering and quadrature.
    pub grid: Grid,
    nb: usize,
    nj: usize,
    mass: Vec<f64>,
    inertia: Vec<Matrix3<f64>>,
    /// Per body: the joint sides acting on it.
    sides: Vec<Vec<Side>>,
    /// Per joint: the two sides' body (`None`: ground) and attachment.
    joint_sides: Vec<[(Option<usize>, Vector3<f64>); 2]>,
    start: Vec<BodyStart>,
    /// Applied loads at `[(e·NG + g)·nb + b]`.
    loads: Vec<Load>,
    /// Unknowns.
    pub u: Vec<f64>,
    bufs: Vec<ElementBuffer>,
    names: (Vec<String>, Vec<String>),
}

impl SpatialWindow {
    /// The window of `elements` elements of length `h` from `t0` for `model`, starting from
    /// `start` (per body), with the applied loads from `load(t, out)` (per body, world).
    pub fn new(
        model: &Spatial,
        elements: usize,
        h: f64,
        t0: f64,
        start: Vec<BodyStart>,
        mut load: impl FnMut(f64, &mut [Load]),
    ) -> SpatialWindow {
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
                    rho: j.pa,
                });
            }
            if let Some(b) = j.b {
                sides[b].push(Side {
                    joint: k,
                    sigma: 1.0,
                    rho: j.pb,
                });
            }
            joint_sides.push([(j.a, j.pa), (j.b, j.pb)]);
        }
        let grid = Grid::new(e, h, t0, FIELDS * nb, 3 * nj);
        let loads = grid.sample(nb, &mut load);
        SpatialWindow {
            u: vec![0.0; grid.unknowns],
            grid,
            nb,
            nj,
            mass: model.bodies.iter().map(|b| b.m).collect(),
            inertia: model.bodies.iter().map(|b| b.j).collect(),
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

    /// The index of field `f` of body `b` at node `j` (`None` at the known start node).
    #[inline]
    fn ku(&self, j: usize, b: usize, f: usize) -> Option<usize> {
        (j > 0).then(|| self.grid.kin_off[j] + FIELDS * b + f)
    }

    /// The index of force component `c` of joint `k` at force node `n`.
    #[inline]
    fn fu(&self, n: usize, k: usize, c: usize) -> usize {
        self.grid.frc_off[n] + 3 * k + c
    }

    /// Field `f` of body `b` at node `j` in `u`.
    #[inline]
    fn kin(&self, u: &[f64], j: usize, b: usize, f: usize) -> f64 {
        match self.ku(j, b, f) {
            Some(i) => u[i],
            None => match f {
                X..=5 => self.start[b].x[f - X],
                C.. => self.start[b].c[((f - C) / 3, (f - C) % 3)],
                _ => 0.0,
            },
        }
    }

    /// Set body `b`'s fields at node `j ≥ 1`: `q`, `x`, `C`.
    pub fn set_kin(
        &mut self,
        j: usize,
        b: usize,
        q: &Vector3<f64>,
        x: &Vector3<f64>,
        c: &Matrix3<f64>,
    ) {
        if let Some(i) = self.ku(j, b, 0) {
            for k in 0..3 {
                self.u[i + Q + k] = q[k];
                self.u[i + X + k] = x[k];
                for l in 0..3 {
                    self.u[i + C + 3 * k + l] = c[(k, l)];
                }
            }
        }
    }

    /// Set joint `k`'s force on side b (world) at force node `n`.
    pub fn set_force(&mut self, n: usize, k: usize, f: &Vector3<f64>) {
        let i = self.fu(n, k, 0);
        self.u[i..i + 3].copy_from_slice(f.as_slice());
    }

    /// Body `b`'s fields at `τ` in element `e`: position `x`, direction cosines `C`, and
    /// the velocity `ẋ` and body angular velocity `q̇` from the interpolants.
    pub fn body_at(
        &self,
        e: usize,
        tau: f64,
        b: usize,
    ) -> (Vector3<f64>, Matrix3<f64>, Vector3<f64>, Vector3<f64>) {
        let p = psi(tau);
        let d = dpsi(tau).map(|d| d / self.grid.h);
        let (pt, x) = self.point(&self.u, e, b, &p, &d);
        (x, pt.c, pt.xd, pt.w)
    }

    /// Body `b`'s fields and rates at local weights `p`, `d`: a [`Point`] and the position.
    fn point(
        &self,
        u: &[f64],
        e: usize,
        b: usize,
        p: &[f64; 3],
        d: &[f64; 3],
    ) -> (Point, Vector3<f64>) {
        let mut pt = Point {
            w: Vector3::zeros(),
            xd: Vector3::zeros(),
            c: Matrix3::zeros(),
            cd: Matrix3::zeros(),
        };
        let mut x = Vector3::zeros();
        for a in 0..3 {
            let n = 2 * e + a;
            for k in 0..3 {
                let qv = self.kin(u, n, b, Q + k);
                pt.w[k] += qv * d[a];
                let xv = self.kin(u, n, b, X + k);
                x[k] += xv * p[a];
                pt.xd[k] += xv * d[a];
                for l in 0..3 {
                    let cv = self.kin(u, n, b, C + 3 * k + l);
                    pt.c[(k, l)] += cv * p[a];
                    pt.cd[(k, l)] += cv * d[a];
                }
            }
        }
        (pt, x)
    }

    /// Joint `k`'s force on side b at `τ` in element `e` (world).
    pub fn force_at(&self, e: usize, tau: f64, k: usize) -> Vector3<f64> {
        let f = phi(tau);
        Vector3::from_fn(|c, _| {
            f[0] * self.u[self.fu(e, k, c)] + f[1] * self.u[self.fu(e + 1, k, c)]
        })
    }

    #[inline]
    fn force_at_g(&self, u: &[f64], e: usize, g: usize, k: usize) -> Vector3<f64> {
        let f = self.grid.tf[g];
        Vector3::from_fn(|c, _| f[0] * u[self.fu(e, k, c)] + f[1] * u[self.fu(e + 1, k, c)])
    }

    /// The moment about the mass centre (body components) and the force (world) on body
    /// `b` at Gauss point `g` of element `e`, with direction cosines `c` and joint forces
    /// `fj` (per joint, at this point).
    fn wrench(
        &self,
        e: usize,
        g: usize,
        b: usize,
        c: &Matrix3<f64>,
        fj: &[Vector3<f64>],
    ) -> (Vector3<f64>, Vector3<f64>) {
        let ld = self.loads[(e * NG + g) * self.nb + b];
        let ct = c.transpose();
        let mut m = ct * ld.t;
        let mut f = ld.f;
        for sd in &self.sides[b] {
            let fk = sd.sigma * fj[sd.joint];
            m += sd.rho.cross(&(ct * fk));
            f += fk;
        }
        (m, f)
    }

    /// Body `b`'s momentum-consistent ("weak") velocities at the end of element `e`: the
    /// ones the global test function of that node would hand over (notes F §1.10), the
    /// angular velocity (body) and the velocity (world).
    pub fn end_velocity(&self, e: usize, b: usize) -> (Vector3<f64>, Vector3<f64>) {
        let (j, m) = (&self.inertia[b], self.mass[b]);
        let mut hw = Vector3::zeros();
        let mut mv = Vector3::zeros();
        let mut fj = vec![Vector3::zeros(); self.nj];
        for g in 0..NG {
            let (w, p, d) = (self.grid.tw[g], self.grid.tp[g], self.grid.td[g]);
            let (pt, _) = self.point(&self.u, e, b, &p, &d);
            for (k, f) in fj.iter_mut().enumerate() {
                *f = self.force_at_g(&self.u, e, g, k);
            }
            let (mo, fo) = self.wrench(e, g, b, &pt.c, &fj);
            let jw = j * pt.w;
            hw += w * (jw * d[2] + (mo - pt.w.cross(&jw)) * p[2]);
            mv += w * (m * pt.xd * d[2] + fo * p[2]);
        }
        let omega = j.try_inverse().map_or(Vector3::zeros(), |ji| ji * hw);
        (omega, mv / m)
    }

    /// The largest entry of `CᵀC − I` over the nodes of the window and the bodies.
    pub fn orthogonality_drift(&self) -> f64 {
        let mut worst = 0.0f64;
        for n in 1..=2 * self.grid.elements {
            for b in 0..self.nb {
                let c = Matrix3::from_fn(|k, l| self.kin(&self.u, n, b, C + 3 * k + l));
                let d = c.transpose() * c - Matrix3::identity();
                worst = worst.max(d.amax());
            }
        }
        worst
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

/// Push a dense 3×3 block at `(row, col)` (nothing for the known start node).
#[inline]
fn block(buf: &mut ElementBuffer, row: usize, col: Option<usize>, m: &Matrix3<f64>) {
    if let Some(col) = col {
        for k in 0..3 {
            for l in 0..3 {
                buf.jac.push((row + k, col + l, m[(k, l)]));
            }
        }
    }
}

/// Push `s·I` at `(row, col)`: three diagonal entries.
#[inline]
fn diagonal(buf: &mut ElementBuffer, row: usize, col: Option<usize>, s: f64) {
    if let Some(col) = col {
        for k in 0..3 {
            buf.jac.push((row + k, col + k, s));
        }
    }
}

impl Discretization for SpatialWindow {
    fn unknowns(&self) -> usize {
        self.u.len()
    }
    fn elements(&self) -> usize {
        self.grid.elements
    }

    fn element(&self, e: usize, u: &[f64], buf: &mut ElementBuffer) {
        buf.res.clear();
        buf.jac.clear();
        let two_e = 2 * self.grid.elements;
        let (tp, td, tf, tw) = (&self.grid.tp, &self.grid.td, &self.grid.tf, &self.grid.tw);
        // joint forces and body fields at the Gauss points
        let fj: Vec<[Vector3<f64>; NG]> = (0..self.nj)
            .map(|k| std::array::from_fn(|g| self.force_at_g(u, e, g, k)))
            .collect();
        let pts: Vec<[Point; NG]> = (0..self.nb)
            .map(|b| std::array::from_fn(|g| self.point(u, e, b, &tp[g], &td[g]).0))
            .collect();
        let mut fg = vec![Vector3::zeros(); self.nj];
        for b in 0..self.nb {
            let (m, jb) = (self.mass[b], &self.inertia[b]);
            for r in 0..3 {
                let j = 2 * e + r;
                if j >= two_e {
                    continue;
                }
                let row = self.grid.kin_row[j] + FIELDS * b;
                // residuals
                let mut re = Vector3::zeros();
                let mut rn = Vector3::zeros();
                let mut rp = Matrix3::zeros();
                for g in 0..NG {
                    let (w, p, d) = (tw[g], tp[g][r], td[g][r]);
                    let pt = &pts[b][g];
                    for (k, f) in fg.iter_mut().enumerate() {
                        *f = fj[k][g];
                    }
                    let (mo, fo) = self.wrench(e, g, b, &pt.c, &fg);
                    let jw = jb * pt.w;
                    re += w * (jw * d + (mo - pt.w.cross(&jw)) * p);
                    rn += w * (m * pt.xd * d + fo * p);
                    for i in 0..3 {
                        let ci = pt.c.row(i).transpose();
                        let res = pt.cd.row(i).transpose() - ci.cross(&pt.w);
                        let acc = rp.row(i) + (w * p * res).transpose();
                        rp.set_row(i, &acc);
                    }
                }
                if j == 0 {
                    let st = &self.start[b];
                    re += jb * st.w;
                    rn += m * st.v;
                }
                for k in 0..3 {
                    buf.res.push((row + Q + k, re[k]));
                    buf.res.push((row + X + k, rn[k]));
                    for l in 0..3 {
                        buf.res.push((row + C + 3 * k + l, rp[(k, l)]));
                    }
                }
                // Jacobian against the body's own fields at the element's three nodes
                for a in 0..3 {
                    let col = |f: usize| self.ku(2 * e + a, b, f);
                    let mut eq = Matrix3::zeros();
                    let mut ec = [Matrix3::zeros(); 3];
                    let mut nx = 0.0;
                    let mut pc = Matrix3::zeros();
                    let mut pq = [Matrix3::zeros(); 3];
                    for g in 0..NG {
                        let (w, p, d) = (tw[g], tp[g][r], td[g][r]);
                        let (pa, da) = (tp[g][a], td[g][a]);
                        let pt = &pts[b][g];
                        let jw = jb * pt.w;
                        let sw = skew(&pt.w);
                        // Euler against q: J ψ̇ψ̇ − ∂(ω × Jω)/∂ω ψ̇ψ
                        eq += w * (jb * (da * d) - (sw * jb - skew(&jw)) * (da * p));
                        // Euler against C row i: ∂M/∂C_ik = T_i e_k + Σ σ f_i ρ × e_k
                        let ld = self.loads[(e * NG + g) * self.nb + b];
                        for (i, eci) in ec.iter_mut().enumerate() {
                            let mut bi = Matrix3::identity() * ld.t[i];
                            for sd in &self.sides[b] {
                                bi += skew(&sd.rho) * (sd.sigma * fj[sd.joint][g][i]);
                            }
                            *eci += bi * (w * pa * p);
                        }
                        nx += w * m * da * d;
                        // Poisson row i against c_i: ψ̇ I + ψ [ω]×; against q: −[c_i]× ψ̇
                        pc += (Matrix3::identity() * da + sw * pa) * (w * p);
                        for (i, pqi) in pq.iter_mut().enumerate() {
                            let ci = pt.c.row(i).transpose();
                            *pqi -= skew(&ci) * (w * p * da);
                        }
                    }
                    block(buf, row + Q, col(Q), &eq);
                    for (i, eci) in ec.iter().enumerate() {
                        block(buf, row + Q, col(C + 3 * i), eci);
                    }
                    diagonal(buf, row + X, col(X), nx);
                    for (i, pqi) in pq.iter().enumerate() {
                        block(buf, row + C + 3 * i, col(C + 3 * i), &pc);
                        block(buf, row + C + 3 * i, col(Q), pqi);
                    }
                }
                // Jacobian against the forces of the joints acting on the body
                for sd in &self.sides[b] {
                    for k2 in 0..2 {
                        let mut ef = Matrix3::zeros();
                        let mut nf = 0.0;
                        for g in 0..NG {
                            let wf = tw[g] * tp[g][r] * sd.sigma * tf[g][k2];
                            ef += skew(&sd.rho) * pts[b][g].c.transpose() * wf;
                            nf += wf;
                        }
                        let col = Some(self.fu(e + k2, sd.joint, 0));
                        block(buf, row + Q, col, &ef);
                        diagonal(buf, row + X, col, nf);
                    }
                }
            }
        }
        // velocity-level joint constraints against the hats of the element's ends
        for k in 0..self.nj {
            for k2 in 0..2 {
                let row = self.grid.frc_row[e + k2] + 3 * k;
                let mut res = Vector3::zeros();
                for (si, &(body, rho)) in self.joint_sides[k].iter().enumerate() {
                    let Some(b) = body else { continue };
                    let sgn = if si == 0 { 1.0 } else { -1.0 };
                    for g in 0..NG {
                        let pt = &pts[b][g];
                        res += (tw[g] * tf[g][k2] * sgn) * (pt.xd + pt.cd * rho);
                    }
                    for a in 0..3 {
                        let col = |f: usize| self.ku(2 * e + a, b, f);
                        let s: f64 = (0..NG).map(|g| tw[g] * tf[g][k2] * td[g][a]).sum();
                        let s = s * sgn;
                        diagonal(buf, row, col(X), s);
                        // (Ċρ)_i = Σ_k Ċ_ik ρ_k
                        if let Some(c0) = col(C) {
                            for i in 0..3 {
                                for kk in 0..3 {
                                    buf.jac.push((row + i, c0 + 3 * i + kk, s * rho[kk]));
                                }
                            }
                        }
                    }
                }
                for i in 0..3 {
                    buf.res.push((row + i, res[i]));
                }
            }
        }
    }

    fn place_of_unknown(&self, i: usize) -> String {
        let nodes = 1..2 * self.grid.elements + 1;
        self.places().find(
            i,
            (&self.grid.kin_off, nodes, &BODY_UNKNOWNS),
            (&self.grid.frc_off, "force", &XYZ),
        )
    }

    fn place_of_equation(&self, i: usize) -> String {
        let nodes = 0..2 * self.grid.elements;
        self.places().find(
            i,
            (&self.grid.kin_row, nodes, &BODY_EQUATIONS),
            (&self.grid.frc_row, "velocity constraint", &XYZ),
        )
    }
}
