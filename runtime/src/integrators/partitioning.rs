//! Generalized coordinate partitioning (notes A §1.3, eqs. 14–19; Wehage and Haug).
//!
//! The m active constraint rows select m *dependent* velocity components among the 6n body
//! velocities (`B = [B_d B_i]` with `B_d` square and well conditioned, chosen by
//! column-pivoted elimination of B with the holonomic rows first, so that the holonomic rows'
//! own dependent block is nonsingular too). The remaining components are independent.
//!
//! - Accelerations from the reduced equations (the paper's (17)–(19) written for a general
//!   block-diagonal M): with `T = B_d⁻¹B_i` and `Z = [−T; I]`,
//!   `(ZᵀMZ) ü_i = Zᵀ(Q̄ − M ü_p)`, `ü_p = [B_d⁻¹γ; 0]`, `ü = Zü_i + ü_p`. The multipliers
//!   follow from the dependent rows of `M ü + Bᵀλ = Q̄`: `B_dᵀλ = (Q̄ − Mü)_d`.
//! - Time stepping: velocity Verlet on all coordinates (half kick, drift with the Euler
//!   parameters by the Cayley rule, half kick with the new accelerations, iterated twice
//!   because the accelerations depend on the velocities through the gyroscopic and γ terms).
//! - Dependent coordinates from the constraints after each drift: Newton on `Φ(q) = 0`
//!   correcting only the dependent positions (translations, and body-frame rotation
//!   increments applied to the Euler parameters), then the dependent velocities from
//!   `B_d u̇_d = −(B_i u̇_i + b)`.
//! - The partition is chosen again when `B_d` becomes ill conditioned against `B` itself: when
//!   the smallest pivot of its LU factorization, relative to the largest entry of `B`, falls
//!   below 1/10 of its value when the partition was chosen (near a singular `B_d` the partition
//!   must change: notes A §4). The measure must be relative to `B`, not to `B_d`'s own largest
//!   pivot: a one-row `B_d` (a distance joint's single row) always has a pivot ratio of 1, and
//!   a point-mass pendulum swung through the vertical with its dependent coordinate `x`, whose
//!   Jacobian entry goes to zero there, ended 0.48 m off with "partitions: 1".

use nalgebra::{DMatrix, Vector3};

use super::common::{self, qbar};
use super::{Integrator, StartError, State, StepError, StepInfo};
use crate::contract::math::cayley_update;
use crate::contract::persist::{self, StateVisitor};
use crate::contract::system::{ConstraintEval, Layout, Need, Pose, RowKind, System, Twist, Wrench};
use crate::linalg::DenseLu as Lu;

/// The coordinate-partitioning integrator.
pub struct Partitioning {
    h: f64,
    t: f64,
    pose: Vec<Pose>,
    vel: Vec<Twist>,
    acc: Vec<Twist>,
    lambda: Vec<f64>,
    active: Vec<bool>,
    next_active: Vec<bool>,
    // partition
    rows: Vec<usize>,
    hol: usize,
    dep: Vec<usize>,
    ind: Vec<usize>,
    is_dep: Vec<bool>,
    /// `min |pivot of LU(B_d)| / max |B|` when the partition was chosen (NaN until the first
    /// factorization after a choice).
    pivot_at_choice: f64,
    /// The row whose elimination pivot was the smallest when the partition was chosen.
    weakest_row: usize,
    partitions: u64,
    // buffers
    ce: ConstraintEval,
    applied: Vec<Wrench>,
    q: Vec<Wrench>,
    b: DMatrix<f64>,
    work: DMatrix<f64>,
    bd: DMatrix<f64>,
    lu_d: Lu,
    lu_h: Lu,
    bh: DMatrix<f64>,
    t_mat: DMatrix<f64>,
    mz: DMatrix<f64>,
    mred: DMatrix<f64>,
    lu_red: Lu,
    vhalf: Vec<Twist>,
    xv: Vec<f64>,
    yv: Vec<f64>,
    rhs: Vec<f64>,
    tol: f64,
    newton_iterations: u64,
}

const MAX_NEWTON: u32 = 20;

fn get(t: &Twist, c: usize) -> f64 {
    if c < 3 {
        t.v[c]
    } else {
        t.w[c - 3]
    }
}

fn set(t: &mut Twist, c: usize, v: f64) {
    if c < 3 {
        t.v[c] = v
    } else {
        t.w[c - 3] = v
    }
}

impl Partitioning {
    /// Start from the system's initial state.
    pub fn new<S: System>(sys: &S, h: f64, start: &State) -> Result<Partitioning, StartError> {
        let layout = sys.layout();
        let (nb, m) = (layout.bodies(), layout.rows);
        let (t0, pose, vel) = (start.t, start.pose.clone(), start.twist.clone());
        let active = start.active.clone();
        let n = 6 * nb;
        let scale = pose.iter().fold(1.0f64, |a, p| a.max(p.r.norm()));
        let mut s = Partitioning {
            h,
            t: t0,
            acc: vec![Twist::default(); nb],
            lambda: vec![0.0; m],
            next_active: active.clone(),
            active,
            rows: Vec::with_capacity(m),
            hol: 0,
            dep: Vec::with_capacity(m),
            ind: Vec::with_capacity(n),
            is_dep: vec![false; n],
            pivot_at_choice: f64::NAN,
            weakest_row: 0,
            partitions: 0,
            ce: ConstraintEval::new(m),
            applied: vec![Wrench::default(); nb],
            q: vec![Wrench::default(); nb],
            b: DMatrix::zeros(m, n),
            work: DMatrix::zeros(m, n),
            bd: DMatrix::zeros(m, m),
            lu_d: Lu::new(0),
            lu_h: Lu::new(0),
            bh: DMatrix::zeros(0, 0),
            t_mat: DMatrix::zeros(m, n),
            mz: DMatrix::zeros(n, n),
            mred: DMatrix::zeros(n, n),
            lu_red: Lu::new(0),
            vhalf: vec![Twist::default(); nb],
            xv: vec![0.0; n.max(m)],
            yv: vec![0.0; n.max(m)],
            rhs: vec![0.0; n.max(m)],
            tol: 1e-13 * scale,
            newton_iterations: 0,
            pose,
            vel,
        };
        // consistent initial accelerations
        sys.constraints(t0, &s.pose, &s.vel, Need::ALL, &mut s.ce);
        s.partition(sys)?;
        s.accelerations(sys, t0)?;
        Ok(s)
    }

    /// Dense B of the active rows (holonomic rows first) from `self.ce`.
    fn dense_b(&mut self, layout: &Layout) {
        self.rows.clear();
        for pass in [RowKind::Holonomic, RowKind::Nonholonomic] {
            for r in 0..layout.rows {
                if self.active[r] && layout.row_kind[r] == pass {
                    self.rows.push(r);
                }
            }
            if pass == RowKind::Holonomic {
                self.hol = self.rows.len();
            }
        }
        let ma = self.rows.len();
        if self.b.nrows() != ma {
            self.b = DMatrix::zeros(ma, 6 * layout.bodies());
        }
        self.b.fill(0.0);
        for (k, &r) in self.rows.iter().enumerate() {
            let (a, bb) = layout.row_bodies(r);
            let row = &self.ce.jac[r];
            if let Some(a) = a {
                for c in 0..6 {
                    self.b[(k, 6 * a + c)] += row.a[c];
                }
            }
            if let Some(bb) = bb {
                for c in 0..6 {
                    self.b[(k, 6 * bb + c)] += row.b[c];
                }
            }
        }
    }

    /// Choose dependent columns by elimination with column pivoting, rows in order.
    fn partition<S: System>(&mut self, sys: &S) -> Result<(), StepError> {
        let layout = sys.layout();
        self.dense_b(layout);
        let (ma, n) = (self.rows.len(), 6 * layout.bodies());
        self.work = self.b.clone();
        self.dep.clear();
        self.is_dep.iter_mut().for_each(|d| *d = false);
        let mut smallest = f64::INFINITY;
        let mut largest: f64 = 0.0;
        self.weakest_row = self.rows.first().copied().unwrap_or(0);
        for k in 0..ma {
            let mut best = (0.0, usize::MAX);
            for c in 0..n {
                if !self.is_dep[c] && self.work[(k, c)].abs() > best.0 {
                    best = (self.work[(k, c)].abs(), c);
                }
            }
            largest = largest.max(best.0);
            if best.1 == usize::MAX || best.0 <= 1e-12 * largest.max(1e-300) {
                return Err(StepError::Singular {
                    what: "coordinate partitioning (B has dependent rows)",
                    row: self.rows[k],
                });
            }
            if best.0 < smallest {
                smallest = best.0;
                self.weakest_row = self.rows[k];
            }
            let c = best.1;
            self.dep.push(c);
            self.is_dep[c] = true;
            let p = self.work[(k, c)];
            for i in k + 1..ma {
                let f = self.work[(i, c)] / p;
                if f != 0.0 {
                    for j in 0..n {
                        self.work[(i, j)] -= f * self.work[(k, j)];
                    }
                }
            }
        }
        self.ind.clear();
        for c in 0..n {
            if !self.is_dep[c] {
                self.ind.push(c);
            }
        }
        // the conditioning of this B_d is measured at its first factorization
        self.pivot_at_choice = f64::NAN;
        self.partitions += 1;
        let ni = self.ind.len();
        self.bd = DMatrix::zeros(ma, ma);
        self.lu_d = Lu::new(ma);
        self.bh = DMatrix::zeros(self.hol, self.hol);
        self.lu_h = Lu::new(self.hol);
        self.t_mat = DMatrix::zeros(ma, ni);
        self.mz = DMatrix::zeros(n, ni);
        self.mred = DMatrix::zeros(ni, ni);
        self.lu_red = Lu::new(ni);
        Ok(())
    }

    /// Factor `B_d` from the current `self.b`; re-partition if it has become ill conditioned
    /// against `B` (see the module documentation).
    fn factor_bd<S: System>(&mut self, sys: &S) -> Result<(), StepError> {
        for attempt in 0..2 {
            let ma = self.rows.len();
            for k in 0..ma {
                for (j, &c) in self.dep.iter().enumerate() {
                    self.bd[(k, j)] = self.b[(k, c)];
                }
            }
            if ma == 0 {
                return Ok(());
            }
            let bmax = self.b.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let quality = match self.lu_d.factor(&self.bd) {
                Ok(st) => st.min_abs_pivot / bmax.max(1e-300),
                Err(_) => 0.0,
            };
            if self.pivot_at_choice.is_nan() {
                // a fresh partition: its own conditioning is the reference
                self.pivot_at_choice = quality;
                if quality > 0.0 {
                    return Ok(());
                }
            } else if quality >= 0.1 * self.pivot_at_choice {
                return Ok(());
            }
            if attempt == 0 {
                self.partition(sys)?;
            }
        }
        Err(StepError::Singular {
            what: "coordinate partitioning B_d (no choice of dependent coordinates is well conditioned here)",
            row: self.weakest_row,
        })
    }

    /// Accelerations (and λ) at the current state from the reduced equations.
    fn accelerations<S: System>(&mut self, sys: &S, t: f64) -> Result<(), StepError> {
        let layout = sys.layout();
        let nb = layout.bodies();
        sys.applied(t, &self.pose, &self.vel, &mut self.applied);
        qbar(layout, &self.applied, &self.vel, &mut self.q);
        sys.constraints(t, &self.pose, &self.vel, Need::ALL, &mut self.ce);
        self.dense_b(layout);
        if self.rows.is_empty() {
            // no active constraint: ü = M⁻¹ Q̄
            for i in 0..nb {
                self.acc[i] = common::accel(&layout.mass[i], &self.q[i]);
            }
            return Ok(());
        }
        self.factor_bd(sys)?;
        let (ma, ni, n) = (self.rows.len(), self.ind.len(), 6 * nb);
        // T = B_d⁻¹ B_i, column by column
        for (j, &c) in self.ind.iter().enumerate() {
            for k in 0..ma {
                self.xv[k] = self.b[(k, c)];
            }
            self.lu_d.solve_in_place(&mut self.xv[..ma]);
            for k in 0..ma {
                self.t_mat[(k, j)] = self.xv[k];
            }
        }
        // particular acceleration ü_p = [B_d⁻¹ γ; 0]
        for (k, &r) in self.rows.iter().enumerate() {
            self.yv[k] = self.ce.gamma[r];
        }
        self.lu_d.solve_in_place(&mut self.yv[..ma]);
        // M Z column j: Z_j has −T[:, j] on dependent columns and 1 on ind[j]
        self.mz.fill(0.0);
        for j in 0..ni {
            // build Z_j as a full vector in xv
            self.xv[..n].iter_mut().for_each(|v| *v = 0.0);
            for (k, &c) in self.dep.iter().enumerate() {
                self.xv[c] = -self.t_mat[(k, j)];
            }
            self.xv[self.ind[j]] = 1.0;
            for i in 0..nb {
                let mp = &layout.mass[i];
                for c in 0..3 {
                    self.mz[(6 * i + c, j)] = mp.m * self.xv[6 * i + c];
                }
                let w = Vector3::new(self.xv[6 * i + 3], self.xv[6 * i + 4], self.xv[6 * i + 5]);
                let jw = mp.j * w;
                for c in 0..3 {
                    self.mz[(6 * i + 3 + c, j)] = jw[c];
                }
            }
        }
        // reduced mass ZᵀMZ and right-hand side Zᵀ(Q̄ − M ü_p)
        // rhs vector in full space: Q̄ − M ü_p
        for i in 0..nb {
            let mp = &layout.mass[i];
            let mut ap = [0.0; 6];
            for (k, &c) in self.dep.iter().enumerate() {
                if c / 6 == i {
                    ap[c % 6] = self.yv[k];
                }
            }
            let jw = mp.j * Vector3::new(ap[3], ap[4], ap[5]);
            for c in 0..3 {
                self.rhs[6 * i + c] = self.q[i].f[c] - mp.m * ap[c];
                self.rhs[6 * i + 3 + c] = self.q[i].t[c] - jw[c];
            }
        }
        for a in 0..ni {
            // Z_aᵀ x = x[ind[a]] − Σ_k T[k,a] x[dep[k]]
            let za = |x: &[f64], t_mat: &DMatrix<f64>, dep: &[usize], ind: &[usize]| {
                let mut s = x[ind[a]];
                for (k, &c) in dep.iter().enumerate() {
                    s -= t_mat[(k, a)] * x[c];
                }
                s
            };
            for b in 0..ni {
                let mut s = self.mz[(self.ind[a], b)];
                for (k, &c) in self.dep.iter().enumerate() {
                    s -= self.t_mat[(k, a)] * self.mz[(c, b)];
                }
                self.mred[(a, b)] = s;
            }
            self.xv[a] = za(&self.rhs, &self.t_mat, &self.dep, &self.ind);
        }
        self.lu_red
            .factor(&self.mred)
            .map_err(|_| StepError::Singular {
                what: "reduced mass matrix",
                row: self.weakest_row,
            })?;
        self.lu_red.solve_in_place(&mut self.xv[..ni]);
        // ü = Z ü_i + ü_p
        for i in 0..nb {
            self.acc[i] = Twist::default();
        }
        for (j, &c) in self.ind.iter().enumerate() {
            set(&mut self.acc[c / 6], c % 6, self.xv[j]);
        }
        for (k, &c) in self.dep.iter().enumerate() {
            let mut s = self.yv[k];
            for j in 0..ni {
                s -= self.t_mat[(k, j)] * self.xv[j];
            }
            set(&mut self.acc[c / 6], c % 6, s);
        }
        // λ from B_dᵀ λ = (Q̄ − M ü)_d
        for (k, &c) in self.dep.iter().enumerate() {
            let i = c / 6;
            let mp = &layout.mass[i];
            let jw = mp.j * self.acc[i].w;
            let v = if c % 6 < 3 {
                self.q[i].f[c % 6] - mp.m * self.acc[i].v[c % 6]
            } else {
                self.q[i].t[c % 6 - 3] - jw[c % 6 - 3]
            };
            self.yv[k] = v;
        }
        // solve B_dᵀ y = rhs with the factorization of B_d
        self.lu_d.solve_transpose_in_place(&mut self.yv[..ma]);
        self.lambda.iter_mut().for_each(|l| *l = 0.0);
        for (k, &r) in self.rows.iter().enumerate() {
            self.lambda[r] = self.yv[k];
        }
        Ok(())
    }

    /// Newton on Φ_H = 0 over the dependent coordinates of the holonomic rows.
    fn project_positions<S: System>(&mut self, sys: &S, t: f64) -> Result<u32, StepError> {
        let layout = sys.layout();
        let hol = self.hol;
        if hol == 0 {
            return Ok(0);
        }
        let (mut worst, mut worst_row): (f64, usize) = (0.0, self.rows[0]);
        for it in 0..MAX_NEWTON {
            sys.constraints(
                t,
                &self.pose,
                &self.vel,
                Need {
                    phi: true,
                    jac: true,
                    gamma: false,
                },
                &mut self.ce,
            );
            worst = 0.0;
            for (k, &r) in self.rows[..hol].iter().enumerate() {
                self.xv[k] = -self.ce.phi[r];
                // NaN counts as the worst
                if self.ce.phi[r].is_nan() || self.ce.phi[r].abs() > worst {
                    (worst, worst_row) = (self.ce.phi[r].abs(), r);
                }
            }
            if worst <= self.tol {
                return Ok(it);
            }
            self.dense_b(layout);
            for k in 0..hol {
                for j in 0..hol {
                    self.bh[(k, j)] = self.b[(k, self.dep[j])];
                }
            }
            self.lu_h
                .factor(&self.bh)
                .map_err(|_| StepError::Singular {
                    what: "coordinate partitioning position projection",
                    row: self.weakest_row,
                })?;
            self.lu_h.solve_in_place(&mut self.xv[..hol]);
            for j in 0..hol {
                let c = self.dep[j];
                let i = c / 6;
                let d = self.xv[j];
                if c % 6 < 3 {
                    self.pose[i].r[c % 6] += d;
                } else {
                    let mut phi = Vector3::zeros();
                    phi[c % 6 - 3] = d;
                    self.pose[i] = common::rotate_body(&self.pose[i], Vector3::zeros(), phi);
                }
            }
        }
        Err(StepError::NoConvergence {
            what: "coordinate partitioning position projection",
            iterations: MAX_NEWTON,
            residual: worst,
            row: Some(worst_row),
        })
    }

    /// Dependent velocities from `B_d u̇_d = −(B_i u̇_i + b)`.
    fn project_velocities<S: System>(&mut self, sys: &S, t: f64) -> Result<(), StepError> {
        let layout = sys.layout();
        sys.constraints(t, &self.pose, &self.vel, Need::JAC, &mut self.ce);
        self.dense_b(layout);
        if self.rows.is_empty() {
            return Ok(());
        }
        self.factor_bd(sys)?;
        let ma = self.rows.len();
        for (k, &r) in self.rows.iter().enumerate() {
            let mut s = self.ce.bias[r];
            for &c in &self.ind {
                s += self.b[(k, c)] * get(&self.vel[c / 6], c % 6);
            }
            self.xv[k] = -s;
        }
        self.lu_d.solve_in_place(&mut self.xv[..ma]);
        for (k, &c) in self.dep.iter().enumerate() {
            set(&mut self.vel[c / 6], c % 6, self.xv[k]);
        }
        Ok(())
    }
}

impl<S: System> Integrator<S> for Partitioning {
    fn name(&self) -> &'static str {
        "coordinate_partitioning"
    }

    fn time(&self) -> f64 {
        self.t
    }

    fn step_size(&self) -> f64 {
        self.h
    }

    fn step(&mut self, sys: &S) -> Result<StepInfo, StepError> {
        let h = self.h;
        let nb = sys.layout().bodies();
        let t1 = self.t + h;
        // half kick and drift
        for i in 0..nb {
            let a = self.acc[i];
            let v = &mut self.vel[i];
            v.v += a.v * (h / 2.0);
            v.w += a.w * (h / 2.0);
            let p = &mut self.pose[i];
            p.r += v.v * h;
            let q = cayley_update(&p.q, &v.w, h, false);
            p.set_q(q);
        }
        let it = self.project_positions(sys, t1)?;
        self.newton_iterations += it as u64;
        // second half kick, iterated because the accelerations depend on the velocities
        self.vhalf.copy_from_slice(&self.vel);
        for _ in 0..3 {
            for i in 0..nb {
                let (a, v) = (self.acc[i], self.vhalf[i]);
                self.vel[i] = Twist {
                    v: v.v + a.v * (h / 2.0),
                    w: v.w + a.w * (h / 2.0),
                };
            }
            self.project_velocities(sys, t1)?;
            self.accelerations(sys, t1)?;
        }
        self.t = t1;
        self.next_active.copy_from_slice(&self.active);
        if sys
            .update_locks(&self.pose, &self.vel, &mut self.next_active)
            .is_some()
        {
            self.active.copy_from_slice(&self.next_active);
            self.partition(sys)?;
        }
        Ok(StepInfo { iterations: it })
    }

    fn state(&self, _sys: &S, out: &mut State) {
        out.t = self.t;
        out.pose.copy_from_slice(&self.pose);
        out.twist.copy_from_slice(&self.vel);
        out.lambda.copy_from_slice(&self.lambda);
    }

    fn persist(&mut self, v: &mut dyn StateVisitor) -> bool {
        // the step size and the projection tolerance (from the initial positions), the state
        // (positions, velocities, the accelerations the next half kick uses, λ), the rows'
        // activity, the partition in use with the conditioning it was chosen at (a partition
        // chosen afresh at the restart state would differ, and with it every later step), the
        // statistics, and the buffers. The LU factorizations are redone from these matrices
        // before every use within a step, so they are not carried: only their sizes, which
        // follow the partition, are set again after loading.
        persist::f64(v, "h", &mut self.h);
        persist::f64(v, "t", &mut self.t);
        persist::f64(v, "tol", &mut self.tol);
        persist::poses(v, "pose", &mut self.pose);
        persist::twists(v, "vel", &mut self.vel);
        persist::twists(v, "acc", &mut self.acc);
        v.f64s("lambda", &mut self.lambda);
        v.bools("active", &mut self.active);
        v.bools("next_active", &mut self.next_active);
        persist::vec_usize(v, "rows", &mut self.rows);
        persist::usize(v, "hol", &mut self.hol);
        persist::vec_usize(v, "dep", &mut self.dep);
        persist::vec_usize(v, "ind", &mut self.ind);
        v.bools("is_dep", &mut self.is_dep);
        persist::f64(v, "pivot_at_choice", &mut self.pivot_at_choice);
        persist::usize(v, "weakest_row", &mut self.weakest_row);
        persist::u64(v, "partitions", &mut self.partitions);
        persist::u64(v, "newton_iterations", &mut self.newton_iterations);
        persist::constraint_eval(v, &mut self.ce);
        persist::wrenches(v, "applied", &mut self.applied);
        persist::wrenches(v, "q", &mut self.q);
        persist::twists(v, "vhalf", &mut self.vhalf);
        v.f64s("xv", &mut self.xv);
        v.f64s("yv", &mut self.yv);
        v.f64s("rhs", &mut self.rhs);
        for (name, m) in [
            ("b", &mut self.b),
            ("work", &mut self.work),
            ("bd", &mut self.bd),
            ("bh", &mut self.bh),
            ("t_mat", &mut self.t_mat),
            ("mz", &mut self.mz),
            ("mred", &mut self.mred),
        ] {
            persist::dmatrix(v, name, m);
        }
        // factorizations sized for the loaded partition (as `partition` sizes them)
        let (ma, ni) = (self.rows.len(), self.ind.len());
        if self.lu_d.dim() != ma {
            self.lu_d = Lu::new(ma);
        }
        if self.lu_h.dim() != self.hol {
            self.lu_h = Lu::new(self.hol);
        }
        if self.lu_red.dim() != ni {
            self.lu_red = Lu::new(ni);
        }
        true
    }

    fn active(&self) -> &[bool] {
        &self.active
    }

    fn stats(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("partitions", self.partitions as f64),
            ("projection_iterations", self.newton_iterations as f64),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::testsys::RodPendulum;

    #[test]
    fn pendulum_constraint_and_energy() {
        let sys = RodPendulum::new(1.0, 1.0, 0.01, 170f64.to_radians());
        let mut it = Partitioning::new(&sys, 1e-3, &State::initial(&sys)).unwrap();
        let mut st = State::new(1, 3);
        let e = |st: &State| {
            let m = &sys.layout.mass[0];
            0.5 * m.m * st.twist[0].v.norm_squared()
                + 0.5 * st.twist[0].w.dot(&(m.j * st.twist[0].w))
                + sys.potential_energy(0.0, &st.pose)
        };
        Integrator::<RodPendulum>::state(&it, &sys, &mut st);
        let e0 = e(&st);
        let (mut we, mut wp): (f64, f64) = (0.0, 0.0);
        for _ in 0..8000 {
            it.step(&sys).unwrap();
            Integrator::<RodPendulum>::state(&it, &sys, &mut st);
            we = we.max((e(&st) - e0).abs());
            wp = wp.max((st.pose[0].r + st.pose[0].c * Vector3::new(0.0, 0.0, 0.5)).norm());
        }
        eprintln!(
            "coordinate partitioning: max |ΔE| = {we:e}, max |Φ| = {wp:e}, partitions {}",
            it.partitions
        );
        assert!(wp < 1e-10);
        assert!(we < 1e-3);
    }
}
