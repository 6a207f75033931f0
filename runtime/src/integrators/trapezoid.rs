//! The simultaneous implicit solution with the trapezoidal rule (notes A §1.2, eqs. 8–13):
//! the reference method the staggered procedure is compared with.
//!
//! Per step, the unknowns `z = (u̇ⁿ⁺¹, μ)` (velocities of every body and one multiplier per
//! constraint row) satisfy, with `δ = h/2`,
//!
//! - `rⁿ⁺¹ = rⁿ + δ(vⁿ + vⁿ⁺¹)`, and the trapezoidal rule on `q̇ = ½ q ⊗ (0, ω)` solved in
//!   closed form: `qⁿ⁺¹ = qⁿ ⊗ (1, hωⁿ/4) ⊗ (1, hωⁿ⁺¹/4)`, normalised;
//! - `M(u̇ⁿ⁺¹ − u̇ⁿ) = δ(Q̄ⁿ + Q̄ⁿ⁺¹) − h B(q_mid)ᵀ μ`: the trapezoidal rule for the applied and
//!   gyroscopic forces `Q̄`, and the constraint force as an impulse over the step with the
//!   Jacobian at the midpoint configuration (`r_mid = (rⁿ + rⁿ⁺¹)/2`,
//!   `q_mid = qⁿ ⊗ (1, hωⁿ/4)`, normalised); μ approximates λ at `tⁿ⁺½`;
//! - `Φ(qⁿ⁺¹, tⁿ⁺¹) = 0` for holonomic rows (position level, so no drift), `Φ_N(qⁿ⁺¹, u̇ⁿ⁺¹) = 0`
//!   for nonholonomic rows.
//!
//! **Difference from the paper.** Eqs. (8)–(13) apply the trapezoidal rule to the accelerations
//! too, `u̇ⁿ⁺¹ = u̇ⁿ + δ(u̇'ⁿ + u̇'ⁿ⁺¹)` with `M u̇' + Bᵀλ = Q̄` at both ends, and impose the
//! constraints at acceleration level (`B ü = c`, index 1), which drifts. Imposed at position
//! level instead, that form leaves an alternating mode in λⁿ (it enters the velocities only
//! through `(Bₙ − Bₙ₊₁)ᵀ`, so nothing damps it): on the 3-D double pendulum it grew to 6e5 N
//! within 5 s and Newton stalled. The midpoint impulse has no such mode, keeps second order,
//! and is still one simultaneous Newton solve for velocities and multipliers.
//!
//! After the iteration the velocities are projected onto `B u̇ + b = 0` at the end
//! configuration (as in RATTLE): position-level constraints cannot see a velocity that
//! alternates in sign from step to step, and a velocity jump (a lock engaging, an inconsistent
//! start) would otherwise leave such a mode undamped, with multipliers growing like 1/h.
//!
//! The multipliers reported are the step's whole constraint impulse over h, `μ + ν/h` with ν
//! the projection's multiplier, and rows that are combinations of the others (redundant joints)
//! are left out of the Newton system (see the fields `lambda_out` and `solved`).
//!
//! Newton iterations use the matrix
//! `[[M + δG + δC_t + δ²K_t, B_midᵀ], [B₁, 0]]` (unknown `hμ`; holonomic residuals scaled by
//! 1/δ), where `G` is the gyroscopic tangent `ω̃J − (Jω)~` and `K_t`, `C_t` the tangent stiffness
//! and damping of the applied forces by finite differences (only when the system's forces
//! depend on the state). The matrix is factored at the first iteration of each step and again
//! whenever the iteration contracts by less than 1/2 (modified Newton).

use nalgebra::{DMatrix, Matrix3, Quaternion, Vector3};

use super::common::{self, accel, bt_lambda, qbar, Index1};
use super::{Integrator, StartError, State, StepError, StepInfo};
use crate::contract::math::{rotation, skew};
use crate::contract::persist::{self, StateVisitor};
use crate::contract::system::{ConstraintEval, Need, Pose, RowKind, System, Twist, Wrench};
use crate::linalg::{Backend, Definiteness, DenseLu, KSolver, KSolverOptions, DEFAULT_PIVOT_TOL};

/// The implicit trapezoidal integrator.
pub struct Trapezoid {
    h: f64,
    tol: f64,
    max_iter: u32,
    t: f64,
    pose: Vec<Pose>,
    vel: Vec<Twist>,
    vel_prev: Vec<Twist>,
    /// `Q̄ⁿ` (applied minus gyroscopic) at the current state.
    qbar_n: Vec<Wrench>,
    /// Accelerations at t = 0 (for the first predictor only).
    acc0: Vec<Twist>,
    /// μ of the last step (λ at its midpoint): the Newton unknown.
    lambda: Vec<f64>,
    /// The multipliers reported: the step's whole constraint impulse over h, `μ + ν/h`, with
    /// ν the velocity projection's multiplier. The projection takes out what the position-level
    /// rule leaves in the velocities (the kink of a driver, an inconsistent start, and on a
    /// turning body the O((hω)²) gap between the closed-form rotation and the trapezoidal
    /// angle), so μ alone misses that impulse: it showed −45 N·m of bias on a rotor driven at
    /// 100 rad/s against a ±4.9 N·m gravity torque, and nothing at a driver's kink.
    lambda_out: Vec<f64>,
    active: Vec<bool>,
    next_active: Vec<bool>,
    /// Rows in the Newton system: active and not redundant. A row that is a combination of
    /// the others (a planar loop of spatial revolutes) makes the Newton matrix singular, and
    /// a near-zero pivot in its place turns round-off into multipliers that wreck the
    /// velocities (0.18 m off on a four-bar of four revolutes, with |Φ| at round-off); such
    /// rows are left out of the solve (μ = 0), and their Φ is still part of the convergence
    /// test, so a row that stops being implied by the others fails the step, naming it.
    solved: Vec<bool>,
    /// How many active rows are set aside as redundant.
    redundant: usize,
    // iteration buffers
    pose1: Vec<Pose>,
    pose_mid: Vec<Pose>,
    vel1: Vec<Twist>,
    applied: Vec<Wrench>,
    qbar1: Vec<Wrench>,
    flam: Vec<Wrench>,
    ce: ConstraintEval,
    ce_mid: ConstraintEval,
    jac: DMatrix<f64>,
    lu: DenseLu,
    proj: KSolver,
    vres: Vec<f64>,
    z: Vec<f64>,
    fd_base: Vec<Wrench>,
    fd_pose: Vec<Pose>,
    fd_vel: Vec<Twist>,
    /// The constraint Jacobian and `B_midᵀ μ` at a perturbed midpoint (the geometric
    /// stiffness by differences, [`Trapezoid::constraint_tangent`]).
    ce_fd: ConstraintEval,
    flam_fd: Vec<Wrench>,
    pos_scale: f64,
    // statistics
    iterations: u64,
    steps: u64,
    max_iterations: u32,
}

impl Trapezoid {
    /// Start from `start`.
    pub fn new<S: System>(
        sys: &S,
        h: f64,
        tolerance: f64,
        max_iterations: u32,
        start: &State,
    ) -> Result<Trapezoid, StartError> {
        let layout = sys.layout();
        let (nb, m) = (layout.bodies(), layout.rows);
        let (t0, pose, vel) = (start.t, start.pose.clone(), start.twist.clone());
        let active = start.active.clone();
        let mut ce = ConstraintEval::new(m);
        sys.constraints(t0, &pose, &vel, Need::ALL, &mut ce);
        let mut applied = vec![Wrench::default(); nb];
        sys.applied(t0, &pose, &vel, &mut applied);
        let mut q = vec![Wrench::default(); nb];
        qbar(layout, &applied, &vel, &mut q);
        let mut lambda = vec![0.0; m];
        Index1::new(layout)?.solve(layout, &ce, &q, &active, &mut lambda)?;
        let mut flam = vec![Wrench::default(); nb];
        bt_lambda(layout, &ce, &lambda, &active, &mut flam);
        let acc0 = (0..nb)
            .map(|i| {
                accel(
                    &layout.mass[i],
                    &Wrench {
                        f: q[i].f - flam[i].f,
                        t: q[i].t - flam[i].t,
                    },
                )
            })
            .collect();
        let n = 6 * nb + m;
        let pos_scale = pose.iter().fold(1.0f64, |a, p| a.max(p.r.norm()));
        let mut s = Trapezoid {
            h,
            tol: tolerance,
            max_iter: max_iterations.max(1),
            t: t0,
            pose1: pose.clone(),
            pose_mid: pose.clone(),
            vel1: vel.clone(),
            fd_pose: pose.clone(),
            fd_vel: vel.clone(),
            vel_prev: vel.clone(),
            pose,
            vel,
            qbar_n: q.clone(),
            qbar1: q,
            acc0,
            lambda_out: lambda.clone(),
            lambda,
            next_active: active.clone(),
            solved: active.clone(),
            redundant: 0,
            active,
            applied,
            flam,
            ce,
            ce_mid: ConstraintEval::new(m),
            jac: DMatrix::zeros(n, n),
            lu: DenseLu::new(n),
            proj: KSolver::new(
                layout,
                KSolverOptions {
                    backend: Backend::Auto,
                    definiteness: Definiteness::SemiDefinite {
                        tol: DEFAULT_PIVOT_TOL,
                    },
                },
            )?,
            vres: vec![0.0; m],
            z: vec![0.0; n],
            fd_base: vec![Wrench::default(); nb],
            ce_fd: ConstraintEval::new(m),
            flam_fd: vec![Wrench::default(); nb],
            pos_scale,
            iterations: 0,
            steps: 0,
            max_iterations: 0,
        };
        s.choose_rows(layout)?;
        Ok(s)
    }

    /// The rows of the Newton system from the Jacobian in `self.ce`: the active rows less
    /// those the pivoted Cholesky factorization of `B M⁻¹ Bᵀ` finds dependent.
    fn choose_rows(&mut self, layout: &crate::contract::system::Layout) -> Result<(), StepError> {
        self.proj
            .assemble(&self.ce.jac, &layout.mass, 1.0, 0.0, Some(&self.active));
        self.proj.factor().map_err(|e| StepError::Linalg {
            what: "implicit trapezoid redundancy test",
            message: e.to_string(),
        })?;
        self.solved.copy_from_slice(&self.active);
        self.redundant = 0;
        for &r in self.proj.dependent_rows() {
            if self.active[r] {
                self.solved[r] = false;
                self.redundant += 1;
            }
        }
        Ok(())
    }

    /// Whether row `r` is active but left out of the solve as redundant.
    fn is_redundant(&self, r: usize) -> bool {
        self.active[r] && !self.solved[r]
    }

    /// End and midpoint configurations from the velocities `vel1`.
    fn positions(&mut self) {
        let d = self.h / 2.0;
        for i in 0..self.pose.len() {
            let p = &self.pose[i];
            let (w0, w1) = (
                self.vel[i].w * (self.h / 4.0),
                self.vel1[i].w * (self.h / 4.0),
            );
            let qm = p.q * Quaternion::new(1.0, w0.x, w0.y, w0.z);
            let q1 = qm * Quaternion::new(1.0, w1.x, w1.y, w1.z);
            let (qm, q1) = (qm / qm.norm(), q1 / q1.norm());
            let r1 = p.r + (self.vel[i].v + self.vel1[i].v) * d;
            self.pose1[i] = Pose {
                r: r1,
                q: q1,
                c: rotation(&q1),
            };
            self.pose_mid[i] = Pose {
                r: (p.r + r1) / 2.0,
                q: qm,
                c: rotation(&qm),
            };
        }
    }

    /// Residuals into `self.z` (negated, ready for the Newton update); returns the largest
    /// constraint residual (holonomic rows in position units) and its row. Redundant rows
    /// count in the residual but have no equation (their unknown stays 0).
    fn residual<S: System>(&mut self, sys: &S, t1: f64) -> (f64, Option<usize>) {
        let layout = sys.layout();
        let d = self.h / 2.0;
        self.positions();
        sys.applied(t1, &self.pose1, &self.vel1, &mut self.applied);
        qbar(layout, &self.applied, &self.vel1, &mut self.qbar1);
        sys.constraints(
            t1,
            &self.pose1,
            &self.vel1,
            Need {
                phi: true,
                jac: true,
                gamma: false,
            },
            &mut self.ce,
        );
        sys.constraints(
            t1 - d,
            &self.pose_mid,
            &self.vel1,
            Need::JAC,
            &mut self.ce_mid,
        );
        // the constraint impulse h·B_midᵀ μ (μ is stored in `lambda`)
        bt_lambda(
            layout,
            &self.ce_mid,
            &self.lambda,
            &self.solved,
            &mut self.flam,
        );
        for i in 0..layout.bodies() {
            let mp = &layout.mass[i];
            let dv = self.vel1[i].v - self.vel[i].v;
            let dw = self.vel1[i].w - self.vel[i].w;
            let rf = dv * mp.m - (self.qbar_n[i].f + self.qbar1[i].f) * d + self.flam[i].f * self.h;
            let rt = mp.j * dw - (self.qbar_n[i].t + self.qbar1[i].t) * d + self.flam[i].t * self.h;
            for c in 0..3 {
                self.z[6 * i + c] = -rf[c];
                self.z[6 * i + 3 + c] = -rt[c];
            }
        }
        let (mut worst, mut worst_row): (f64, Option<usize>) = (0.0, None);
        let off = 6 * layout.bodies();
        for r in 0..layout.rows {
            if !self.active[r] {
                self.z[off + r] = 0.0;
                continue;
            }
            let (size, v) = if layout.row_kind[r] == RowKind::Holonomic {
                (self.ce.phi[r].abs(), self.ce.phi[r] / d)
            } else {
                (self.ce.phi[r].abs() * self.h, self.ce.phi[r])
            };
            if size > worst || worst_row.is_none() {
                (worst, worst_row) = (size.max(worst), Some(r));
            }
            self.z[off + r] = if self.solved[r] { -v } else { 0.0 };
        }
        (worst, worst_row)
    }

    /// The Newton matrix at the current iterate (unknowns `Δu̇` and `Δ(hμ)`).
    fn jacobian<S: System>(&mut self, sys: &S, t1: f64, geometric: bool) {
        let layout = sys.layout();
        let (nb, m) = (layout.bodies(), layout.rows);
        let d = self.h / 2.0;
        self.jac.fill(0.0);
        for i in 0..nb {
            let mp = &layout.mass[i];
            let w = self.vel1[i].w;
            let g: Matrix3<f64> = skew(&w) * mp.j - skew(&(mp.j * w));
            for c in 0..3 {
                self.jac[(6 * i + c, 6 * i + c)] = mp.m;
                for e in 0..3 {
                    self.jac[(6 * i + 3 + c, 6 * i + 3 + e)] = mp.j[(c, e)] + d * g[(c, e)];
                }
            }
        }
        if sys.has_state_forces() {
            self.force_tangent(sys, t1);
        }
        if geometric {
            self.constraint_tangent(sys, t1);
        }
        let off = 6 * nb;
        for r in 0..m {
            if !self.solved[r] {
                self.jac[(off + r, off + r)] = 1.0;
                continue;
            }
            let (a, b) = layout.row_bodies(r);
            let (row1, rowm) = (self.ce.jac[r], self.ce_mid.jac[r]);
            for (body, b1, bm) in [(a, row1.a, rowm.a), (b, row1.b, rowm.b)] {
                if let Some(k) = body {
                    for c in 0..6 {
                        self.jac[(off + r, 6 * k + c)] = b1[c];
                        self.jac[(6 * k + c, off + r)] = bm[c];
                    }
                }
            }
        }
    }

    /// `h ∂(B_midᵀ μ)/∂u̇`: the geometric stiffness of the constraint forces — how the
    /// constraint impulse turns as the bodies move under a loaded joint — by forward
    /// differences of the midpoint's translations (`r_mid = r + δ(u + u̇)/2`, so
    /// `∂r_mid/∂u̇ = h/4`; the midpoint rotation does not depend on `u̇`). Without it the
    /// Newton iteration converges linearly at a rate near (hω)²/4 for a constrained mode ω
    /// stiffened by its joint's load: a 1 g bob carrying 10 kg on two rods (ω = 1400 rad/s)
    /// stalled at a residual of 1e-8 after 20 iterations at h = 1 ms, rate 0.49
    /// (`models/hard/light_over_heavy.mbd`). Added only when the iteration contracts slowly.
    fn constraint_tangent<S: System>(&mut self, sys: &S, t1: f64) {
        let layout = sys.layout();
        let nb = layout.bodies();
        let d = self.h / 2.0;
        let weight = self.h * self.h / 4.0;
        for k in 0..nb {
            for c in 0..3 {
                self.fd_pose.copy_from_slice(&self.pose_mid);
                let eps = 1e-7 * (1.0 + self.pose_mid[k].r.norm());
                self.fd_pose[k].r[c] += eps;
                sys.constraints(
                    t1 - d,
                    &self.fd_pose,
                    &self.vel1,
                    Need::JAC,
                    &mut self.ce_fd,
                );
                bt_lambda(
                    layout,
                    &self.ce_fd,
                    &self.lambda,
                    &self.solved,
                    &mut self.flam_fd,
                );
                let col = 6 * k + c;
                for i in 0..nb {
                    let df = (self.flam_fd[i].f - self.flam[i].f) / eps;
                    let dt = (self.flam_fd[i].t - self.flam[i].t) / eps;
                    for e in 0..3 {
                        self.jac[(6 * i + e, col)] += weight * df[e];
                        self.jac[(6 * i + 3 + e, col)] += weight * dt[e];
                    }
                }
            }
        }
    }

    /// `−δ ∂Q̄/∂u̇ − δ² ∂Q̄/∂x` by forward differences of the applied forces.
    fn force_tangent<S: System>(&mut self, sys: &S, t1: f64) {
        let layout = sys.layout();
        let nb = layout.bodies();
        let d = self.h / 2.0;
        sys.applied(t1, &self.pose1, &self.vel1, &mut self.fd_base);
        for k in 0..nb {
            for c in 0..12 {
                self.fd_pose.copy_from_slice(&self.pose1);
                self.fd_vel.copy_from_slice(&self.vel1);
                let (eps, weight);
                match c {
                    0..=2 => {
                        eps = 1e-7 * (1.0 + self.pose1[k].r.norm());
                        self.fd_pose[k].r[c] += eps;
                        weight = d * d;
                    }
                    3..=5 => {
                        eps = 1e-7;
                        let mut phi = Vector3::zeros();
                        phi[c - 3] = eps;
                        self.fd_pose[k] =
                            common::rotate_body(&self.pose1[k], Vector3::zeros(), phi);
                        weight = d * d;
                    }
                    6..=8 => {
                        eps = 1e-7 * (1.0 + self.vel1[k].v.norm());
                        self.fd_vel[k].v[c - 6] += eps;
                        weight = d;
                    }
                    _ => {
                        eps = 1e-7 * (1.0 + self.vel1[k].w.norm());
                        self.fd_vel[k].w[c - 9] += eps;
                        weight = d;
                    }
                }
                sys.applied(t1, &self.fd_pose, &self.fd_vel, &mut self.applied);
                let col = 6 * k + (c % 6);
                for i in 0..nb {
                    let df = (self.applied[i].f - self.fd_base[i].f) / eps;
                    let dt = (self.applied[i].t - self.fd_base[i].t) / eps;
                    for e in 0..3 {
                        self.jac[(6 * i + e, col)] -= weight * df[e];
                        self.jac[(6 * i + 3 + e, col)] -= weight * dt[e];
                    }
                }
            }
        }
    }
}

impl<S: System> Integrator<S> for Trapezoid {
    fn name(&self) -> &'static str {
        "implicit_trapezoid"
    }

    fn time(&self) -> f64 {
        self.t
    }

    fn step_size(&self) -> f64 {
        self.h
    }

    fn step(&mut self, sys: &S) -> Result<StepInfo, StepError> {
        let layout = sys.layout();
        let nb = layout.bodies();
        let t1 = self.t + self.h;
        // Predictor: from the initial accelerations on the first step, then linear
        // extrapolation of the velocities.
        for i in 0..nb {
            self.vel1[i] = if self.steps == 0 {
                Twist {
                    v: self.vel[i].v + self.acc0[i].v * self.h,
                    w: self.vel[i].w + self.acc0[i].w * self.h,
                }
            } else {
                Twist {
                    v: self.vel[i].v * 2.0 - self.vel_prev[i].v,
                    w: self.vel[i].w * 2.0 - self.vel_prev[i].w,
                }
            };
        }
        let tol_phi = self.tol * self.pos_scale;
        let mut prev_norm = f64::INFINITY;
        let mut prev_dmax = f64::INFINITY;
        let mut converged = false;
        let mut it = 0;
        let mut worst_row = None;
        // Whether the matrix has the constraints' geometric stiffness: from the third
        // iteration on, once the iteration contracts by less than 1/10 per iteration, the
        // matrix is made again with it (and again at each such iteration).
        let mut geometric = false;
        while it < self.max_iter {
            let (phi, row) = self.residual(sys, t1);
            worst_row = row;
            let rnorm = self.z.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            let slow = it >= 2 && rnorm > 0.1 * prev_norm;
            if it == 0 || rnorm > 0.5 * prev_norm || slow {
                geometric |= slow;
                self.jacobian(sys, t1, geometric);
                self.lu.factor(&self.jac).map_err(|e| match e {
                    crate::linalg::LinalgError::Singular { pivot } => StepError::Singular {
                        what: "trapezoidal Newton",
                        row: pivot.saturating_sub(6 * nb),
                    },
                    e => StepError::Linalg {
                        what: "trapezoidal Newton",
                        message: e.to_string(),
                    },
                })?;
            }
            prev_norm = rnorm;
            self.lu.solve_in_place(&mut self.z);
            let mut dmax: f64 = 0.0;
            let mut vmax: f64 = 1.0;
            for i in 0..nb {
                for c in 0..3 {
                    self.vel1[i].v[c] += self.z[6 * i + c];
                    self.vel1[i].w[c] += self.z[6 * i + 3 + c];
                    dmax = dmax
                        .max(self.z[6 * i + c].abs())
                        .max(self.z[6 * i + 3 + c].abs());
                    vmax = vmax
                        .max(self.vel1[i].v[c].abs())
                        .max(self.vel1[i].w[c].abs());
                }
            }
            for r in 0..layout.rows {
                self.lambda[r] += self.z[6 * nb + r] / self.h;
            }
            it += 1;
            // Converged, or stagnating at round-off (an ill-conditioned Newton matrix — mass
            // ratios of 1e6 — leaves increments of a few ulps that do not shrink).
            let stagnant = it >= 3 && dmax >= 0.5 * prev_dmax && dmax <= 1e3 * self.tol * vmax;
            if (dmax <= self.tol * vmax || stagnant) && phi <= tol_phi.max(dmax * self.h) {
                converged = true;
                break;
            }
            prev_dmax = dmax;
        }
        if !converged {
            let residual = self.z.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            let redundant_row = worst_row.is_some_and(|r| self.is_redundant(r));
            return Err(StepError::NoConvergence {
                what: if redundant_row {
                    "implicit trapezoid Newton iteration (its worst row was set aside at the start as redundant, a combination of the other joints' rows, and is no longer implied by them)"
                } else {
                    "implicit trapezoid Newton iteration"
                },
                iterations: it,
                residual,
                row: worst_row,
            });
        }
        // Velocity projection onto B u̇ + b = 0 at the end configuration (as in RATTLE): the
        // position-level constraints cannot see a velocity that alternates in sign from step
        // to step (it does not move the trapezoidal positions), and a velocity jump — a lock
        // engaging, an inconsistent start — would otherwise leave such a mode undamped.
        self.positions();
        sys.constraints(t1, &self.pose1, &self.vel1, Need::JAC, &mut self.ce);
        common::velocity_residual(layout, &self.ce, &self.vel1, &mut self.vres);
        self.lambda_out.copy_from_slice(&self.lambda);
        if self
            .vres
            .iter()
            .zip(&self.solved)
            .any(|(v, a)| *a && *v != 0.0)
        {
            for (v, a) in self.vres.iter_mut().zip(&self.solved) {
                if !*a {
                    *v = 0.0;
                }
            }
            self.proj
                .assemble(&self.ce.jac, &layout.mass, 1.0, 0.0, Some(&self.solved));
            self.proj.factor().map_err(|e| StepError::Linalg {
                what: "trapezoid velocity projection",
                message: e.to_string(),
            })?;
            self.proj.solve_in_place(&mut self.vres);
            bt_lambda(layout, &self.ce, &self.vres, &self.solved, &mut self.flam);
            for r in 0..layout.rows {
                if self.solved[r] {
                    self.lambda_out[r] += self.vres[r] / self.h;
                }
            }
            for i in 0..nb {
                let d = accel(&layout.mass[i], &self.flam[i]);
                self.vel1[i].v -= d.v;
                self.vel1[i].w -= d.w;
            }
        }
        // accept (positions and Q̄ at the converged velocities)
        sys.applied(t1, &self.pose1, &self.vel1, &mut self.applied);
        qbar(layout, &self.applied, &self.vel1, &mut self.qbar_n);
        self.pose.copy_from_slice(&self.pose1);
        self.vel_prev.copy_from_slice(&self.vel);
        self.vel.copy_from_slice(&self.vel1);
        self.t = t1;
        self.steps += 1;
        self.iterations += it as u64;
        self.max_iterations = self.max_iterations.max(it);
        self.next_active.copy_from_slice(&self.active);
        if sys
            .update_locks(&self.pose, &self.vel, &mut self.next_active)
            .is_some()
        {
            for r in 0..layout.rows {
                if self.next_active[r] && !self.active[r] {
                    self.lambda[r] = 0.0;
                    self.lambda_out[r] = 0.0;
                }
            }
            self.active.copy_from_slice(&self.next_active);
            // the rows of the Newton system change with the active set
            sys.constraints(self.t, &self.pose, &self.vel, Need::JAC, &mut self.ce);
            self.choose_rows(layout)?;
        }
        Ok(StepInfo { iterations: it })
    }

    fn state(&self, _sys: &S, out: &mut State) {
        out.t = self.t;
        out.pose.copy_from_slice(&self.pose);
        out.twist.copy_from_slice(&self.vel);
        out.lambda.copy_from_slice(&self.lambda_out);
    }

    fn persist(&mut self, v: &mut dyn StateVisitor) -> bool {
        // the options and the position scale of the tolerance (from the initial positions),
        // the state with what the predictor extrapolates from (the previous velocities, and
        // the initial accelerations before the first step), Q̄ⁿ, the Newton unknown μ and the
        // reported multipliers, the rows' activity and which rows the Newton system solves
        // (chosen at the start and when locks change: a choice redone at the restart state
        // could differ), the statistics (the predictor depends on the step count), and the
        // iteration buffers. The Newton matrix and the projection are factored again before
        // every use within a step, so their factorizations are not carried.
        persist::f64(v, "h", &mut self.h);
        persist::f64(v, "tol", &mut self.tol);
        persist::u32(v, "max_iter", &mut self.max_iter);
        persist::f64(v, "t", &mut self.t);
        persist::f64(v, "pos_scale", &mut self.pos_scale);
        persist::poses(v, "pose", &mut self.pose);
        persist::twists(v, "vel", &mut self.vel);
        persist::twists(v, "vel_prev", &mut self.vel_prev);
        persist::wrenches(v, "qbar_n", &mut self.qbar_n);
        persist::twists(v, "acc0", &mut self.acc0);
        v.f64s("lambda", &mut self.lambda);
        v.f64s("lambda_out", &mut self.lambda_out);
        v.bools("active", &mut self.active);
        v.bools("next_active", &mut self.next_active);
        v.bools("solved", &mut self.solved);
        persist::usize(v, "redundant", &mut self.redundant);
        persist::poses(v, "pose1", &mut self.pose1);
        persist::poses(v, "pose_mid", &mut self.pose_mid);
        persist::twists(v, "vel1", &mut self.vel1);
        persist::wrenches(v, "applied", &mut self.applied);
        persist::wrenches(v, "qbar1", &mut self.qbar1);
        persist::wrenches(v, "flam", &mut self.flam);
        persist::constraint_eval(v, &mut self.ce);
        persist::constraint_eval(v, &mut self.ce_mid);
        persist::dmatrix(v, "jac", &mut self.jac);
        v.f64s("vres", &mut self.vres);
        v.f64s("z", &mut self.z);
        persist::wrenches(v, "fd_base", &mut self.fd_base);
        persist::poses(v, "fd_pose", &mut self.fd_pose);
        persist::twists(v, "fd_vel", &mut self.fd_vel);
        persist::u64(v, "iterations", &mut self.iterations);
        persist::u64(v, "steps", &mut self.steps);
        persist::u32(v, "max_iterations", &mut self.max_iterations);
        true
    }

    fn active(&self) -> &[bool] {
        &self.active
    }

    fn stats(&self) -> Vec<(&'static str, f64)> {
        vec![
            (
                "newton_iterations_mean",
                self.iterations as f64 / self.steps.max(1) as f64,
            ),
            ("newton_iterations_max", self.max_iterations as f64),
            ("redundant_rows", self.redundant as f64),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::testsys::RodPendulum;

    #[test]
    fn pendulum_energy_and_constraint() {
        let sys = RodPendulum::new(1.0, 1.0, 0.01, 170f64.to_radians());
        let mut it = Trapezoid::new(&sys, 1e-3, 1e-10, 20, &State::initial(&sys)).unwrap();
        let mut st = State::new(1, 3);
        let e = |st: &State| {
            let m = &sys.layout.mass[0];
            0.5 * m.m * st.twist[0].v.norm_squared()
                + 0.5 * st.twist[0].w.dot(&(m.j * st.twist[0].w))
                + sys.potential_energy(0.0, &st.pose)
        };
        Integrator::<RodPendulum>::state(&it, &sys, &mut st);
        let e0 = e(&st);
        let mut worst_e: f64 = 0.0;
        let mut worst_phi: f64 = 0.0;
        for _ in 0..8000 {
            it.step(&sys).unwrap();
            Integrator::<RodPendulum>::state(&it, &sys, &mut st);
            worst_e = worst_e.max((e(&st) - e0).abs());
            let phi = (st.pose[0].r + st.pose[0].c * Vector3::new(0.0, 0.0, 0.5)).norm();
            worst_phi = worst_phi.max(phi);
        }
        eprintln!(
            "max |ΔE| = {worst_e:e}, max |Φ| = {worst_phi:e}, mean iterations {}",
            it.iterations as f64 / it.steps as f64
        );
        assert!(worst_phi < 1e-9);
        assert!(worst_e < 1e-3);
        // λ at the midpoint of the last step equals the hanging-rod reaction to O(h²) when
        // the motion is slow: no alternating mode
        assert!(it.lambda.iter().all(|l| l.is_finite()));
    }
}
