//! The two-stage explicit coordinate integrator (CINT) of Park, Chiou and Downer with three
//! interchangeable constraint-force modules (LINT): the staggered stabilization
//! (`staggered`), Baumgarte's index-1 stabilization (`baumgarte`) and the penalty method
//! (`penalty`). Sharing the coordinate integrator makes the comparison of the papers a
//! comparison of the constraint treatment alone.
//!
//! ## CINT (notes A §1.8–1.9, C §3.5)
//! The coordinates are advanced by the explicit central-difference (leapfrog) update: at
//! each step the positions at τ and the velocities at τ − h/2 become
//!
//! `u̇ ← u̇ + h M⁻¹(Q̄ − Bᵀλ)`, `r ← r + h v`, `q ← cayley(q, ω, h)`,
//!
//! where the Euler parameters use the midpoint-implicit (Cayley) rule with the corrected
//! `Δ = 1 + h²|ω|²/16` ([`crate::contract::math::cayley_update`]) and `Q̄ = F − ω × Jω`.
//!
//! The gyroscopic term must be evaluated at a synchronous ω: extrapolating it explicitly "can
//! lead quickly to computational instability" (C3 §IV.B, Fig. 7). Three treatments, chosen by
//! [`Gyroscopic`]:
//! - [`Gyroscopic::Midpoint`] (default): one leapfrog sequence, and the rotational kick by
//!   the implicit midpoint rule `J(ω⁺ − ω)/h + ω̄ × Jω̄ = τ − (Bᵀλ)_ω`, `ω̄ = (ω + ω⁺)/2`,
//!   solved per body by a 3×3 Newton iteration. A free body's energy and angular momentum
//!   are conserved to round-off (the midpoint rule conserves quadratic invariants), and the
//!   heavy top precesses to 1e-3° of theory.
//! - [`Gyroscopic::Synchronous`]: the paper's two-stage scheme, two sequences offset by h/2,
//!   each advanced by a full step at its own half-step times and taking ω from the other,
//!   which is at τ exactly. The exchange is the only coupling between the sequences, and
//!   their difference (the leapfrog's computational mode) sees it with the opposite sign
//!   while the kinematics through the constraints keeps its own: on a gyroscopically
//!   stabilized constrained system (a heavy top on its tip) that mode grows at the rate the
//!   top would fall without spin (≈ 9 /s), whatever the step, and the top falls over within
//!   2 s. On a chaotic system (the 3-D double pendulum) the two weakly coupled sequences
//!   also decorrelate after ~100 s: each is a good trajectory, but their mix is not, and the
//!   energy error jumps from 1e-4 J to ~9 J. This is why the default keeps one sequence.
//! - [`Gyroscopic::Lagged`]: one sequence with the lagged ω^{n−1/2}, the conventional update
//!   (C3 eq. 41), kept for the comparison of C3 Fig. 7.
//!
//! With one sequence the velocities live at half steps; the output velocity at τ is the
//! second-order extrapolation `1.5 v(τ − h/2) − 0.5 v(τ − 3h/2)`, so reported velocities and
//! energies are synchronous with the positions. Damping forces use the lagged velocity (with
//! a velocity from the future the leapfrog is unstable for any damping, notes A §1.9;
//! lagged, it is stable for `c·h < 2`).
//!
//! ## LINT: the staggered stabilization (default, [`LintForm::Exact`])
//! The method regularizes the constraints by the penalty law `λ = Φ/ε` and integrates
//! `ε λ̇ = Φ̇` for λ as a state variable (notes A §1.6, C2 §IV). That equation has the exact
//! integral `ε(λ − λ⁰) = Φ − Φ⁰`. The default LINT imposes it implicitly at the positions
//! the CINT step produces, with `Φ⁰ = 0` (an initial violation is removed):
//!
//! `ε (λ − λ⁰) = Φ(X_λ(τ + h))`,
//!
//! solved by Newton iterations on λ with the matrix `εI + h² B M⁻¹ Bᵀ` (the holonomic
//! iteration matrix `εI + δ²BM⁻¹Bᵀ` of C2 Remark 5 with δ = h). Nonholonomic rows impose
//! `ε(λ − λ⁰) = Φ_N` on the new velocity, scaled by h so that the matrix stays symmetric
//! positive definite when both kinds share bodies. The matrix is nonsingular even where
//! `B M⁻¹ Bᵀ` is singular (links that line up, redundant joints), which is the robustness
//! argument of the method; the constraint error is `ε Δλ` and does not drift.
//!
//! [`LintForm::Midpoint`] is the paper's discretization (C3 eq. 34, notes A §1.6): the λ
//! equation with the velocity predictor `u̇ + (h/2)M⁻¹(Q̄ − Bᵀλ)` advanced over each half
//! step by the midpoint rule, `(εI + (h²/8)K) λ̃ = ελ + (h/8)(r_prev + r)`, `λ ← 2λ̃ − λ`,
//! with the corrected h/8 (`paper_literal`: the printed h/4). It is kept to reproduce the
//! paper: its constraint modes are undamped (the midpoint velocity is enforced, so the
//! constraint velocity changes sign each step instead of decaying), and because the λ history
//! alternates between the two sequences their multiplier errors feed each other; the
//! physical pendulum released at 170° diverges after ~5 s at every ε we tried (see
//! docs/methods.md).
//!
//! ## ε
//! Default rule: a per-row regularization `E_r = 10⁻⁹ · h² · K_rr` (K = B M⁻¹ Bᵀ at the
//! start), i.e. `10⁻⁹ I` added to the Jacobi-scaled matrix. The condition number of
//! `E + h²K` is then at most about 10⁹ however ill-conditioned `K` becomes — the paper's rule
//! `ε ∼ c / cond(BM⁻¹Bᵀ)` with the desired accuracy c = 10⁻⁹ expressed relative to the step
//! and to each row's own scale — while the constraint error `E_r Δλ_r` stays at round-off for
//! every row, light or heavy, translational or rotational. A scalar ε given by the user is
//! used as is (`E = ε` on holonomic rows, `εh` on nonholonomic ones).
//!
//! ## Baumgarte and penalty
//! `baumgarte`: `B M⁻¹ Bᵀ λ = B M⁻¹ Q̄ − γ + 2α Φ̇ + β² Φ` (`Φ̈ + 2αΦ̇ + β²Φ = 0`; nonholonomic
//! rows `Φ̇_N + 2αΦ_N = 0`), solved by Cholesky without regularization — where the matrix
//! becomes singular the step fails and reports it. `penalty`: `λ = Φ/ε` explicitly (eq. 23),
//! default `ε = h² max diag K` so that the penalty frequency stays below the explicit limit.
//!
//! ## Start
//! λ⁰ is the consistent index-1 multiplier (`K λ = B M⁻¹ Q̄ − γ`). Sequence B starts with
//! velocities `u̇⁰ − (h/2)u̇'⁰`, sequence A with positions at h/2 from a second-order Taylor step.

use super::beam_forces::BeamForces;
use super::beam_subcycle::Subcycle;
use super::common::{self, accel, b_minv, b_times, bt_lambda, qbar, Index1};
use super::{Integrator, StartError, State, StepError, StepInfo};
use crate::contract::math::cayley_update;
use crate::contract::persist::{self, StateVisitor};
use crate::contract::scene::{Factorization, Gyroscopic, LintForm, Relaxation, StaggeredOptions};
use crate::contract::system::{ConstraintEval, Need, Pose, RowKind, System, Twist, Wrench};
use crate::linalg::{Backend, Definiteness, KSolver, KSolverOptions, LinalgError};

/// One leapfrog sequence.
#[derive(Clone, Debug)]
struct Seq {
    pose: Vec<Pose>,
    vel: Vec<Twist>,
}

/// The constraint-force module.
#[derive(Clone, Debug)]
enum Law {
    Staggered {
        lint: LintForm,
        gyroscopic: Gyroscopic,
    },
    Baumgarte {
        alpha: f64,
        beta: f64,
    },
    Penalty,
}

/// The two-stage integrator with its constraint-force module.
pub struct TwoStage {
    law: Law,
    name: &'static str,
    h: f64,
    /// One leapfrog sequence (the default and the conventional update), or the paper's two.
    one_sequence: bool,
    paper_literal: bool,
    epsilon: f64,
    /// Regularization per row (ε holonomic, εh nonholonomic).
    e: Vec<f64>,
    /// The regularization of the current LINT attempt.
    e_eff: Vec<f64>,
    lambda_guess: Vec<f64>,
    regularized_steps: u64,
    /// Gyroscopic term by the implicit midpoint rule inside each sequence.
    midpoint_gyro: bool,
    /// One sequence: its velocities at the previous half step (for synchronized output).
    vel_prev: Vec<Twist>,
    /// One sequence, Baumgarte: the velocity at τ estimated from the half steps (second
    /// order), for γ and the gyroscopic load of the index-1 λ solve.
    vel_sync: Vec<Twist>,
    tau: f64,
    t0: f64,
    half_steps: u64,
    seq: [Seq; 2],
    x: usize,
    lambda: Vec<f64>,
    /// λ at the previous LINT (for output interpolation) and its time.
    lambda_prev: Vec<f64>,
    tau_lambda: f64,
    lambda0: Vec<f64>,
    active: Vec<bool>,
    next_active: Vec<bool>,
    // midpoint LINT history
    r_prev: Vec<f64>,
    fresh: Vec<bool>,
    // per-half-step buffers
    qbar: Vec<Wrench>,
    flam: Vec<Wrench>,
    applied: Vec<Wrench>,
    ce: ConstraintEval,
    ce_trial: ConstraintEval,
    trial: Seq,
    tmp: Vec<f64>,
    res: Vec<f64>,
    dl: Vec<f64>,
    ks: KSolver,
    /// Relative tolerance of the LINT Newton iteration (times 1 + the largest distance of a
    /// body from the origin, in m or rad).
    tol: f64,
    // statistics
    iterations: u64,
    lints: u64,
    max_iterations: u32,
    min_pivot_ratio: f64,
    /// The flexible beams' internal forces (`None` without beams).
    beams: Option<BeamForces>,
    /// The beams' substeps (`beam_substeps` > 1; `None` otherwise).
    subcycle: Option<Subcycle>,
    /// Dynamic relaxation by kinetic damping.
    relax: bool,
    /// Kinetic energy of the previous step's velocities (relaxation).
    ke_prev: f64,
    /// Velocity resets made by the relaxation.
    relax_resets: u64,
    /// Relaxation: the positions at the start of the step.
    relax_pose: Vec<Pose>,
    /// Relaxation: the out-of-balance load of the last step relative to the loads in play
    /// ([`TwoStage::relaxation_residual`]), and the length that weighs forces against
    /// torques in it.
    relax_residual: f64,
    relax_length: f64,
}

const MAX_NEWTON: u32 = 25;

/// A run with `relaxation kinetic` has converged to its static solution when its
/// out-of-balance ratio ([`TwoStage::relaxation_residual`]) at the end is at most this;
/// otherwise it ends with a warning ([`Integrator::end_notice`]). Measured on the
/// validation's cantilevers (docs/methods.md), the displacement error was at most 4 times
/// the ratio (and usually below it), so this keeps the relaxation's error below 5·10⁻⁵,
/// under the discretization error of the meshes used.
pub const RELAXATION_TOLERANCE: f64 = 1e-5;

/// An upper bound of `K_rr = (B M⁻¹ Bᵀ)_rr` over every configuration the joint can take, for
/// the penalty method's default ε. A position row acts on body b through `(u, r × Cᵀu)` with
/// the lever arm r fixed in the body: `K_rr ≤ Σ_b |u|²(1/m_b + |r|² max_{w ⟂ r} wᵀJ_b⁻¹w)`,
/// with r recovered from the joint's position rows (`r = ½ Σ_i ûᵢ × âᵢ` over three orthonormal
/// directions; with fewer, the largest |âᵢ| and the largest eigenvalue of J⁻¹). A rotational
/// row's direction may turn in the body: `|a|² λ_max(J_b⁻¹)`.
fn penalty_k_bound(
    layout: &crate::contract::system::Layout,
    ce: &ConstraintEval,
    pose: &[Pose],
    j: &crate::contract::system::JointLayout,
    r: usize,
) -> f64 {
    use nalgebra::{Matrix3, Vector3};
    let rows = j.first_row..j.first_row + j.rows;
    let mut k = 0.0;
    for (side, body) in [(0, j.a), (1, j.b)] {
        let Some(b) = body.filter(|&b| b < layout.bodies()) else {
            continue;
        };
        let part = |row: usize| -> (Vector3<f64>, Vector3<f64>) {
            let p = if side == 0 {
                &ce.jac[row].a
            } else {
                &ce.jac[row].b
            };
            (
                Vector3::new(p[0], p[1], p[2]),
                Vector3::new(p[3], p[4], p[5]),
            )
        };
        let mp = &layout.mass[b];
        let jinv: Matrix3<f64> = mp.j_inv;
        let lmax = jinv.symmetric_eigen().eigenvalues.max();
        let (lin, ang) = part(r);
        let l2 = lin.norm_squared();
        if l2 == 0.0 {
            k += ang.norm_squared() * lmax;
            continue;
        }
        // the lever arm from the joint's position rows (body components)
        let c = pose[b].c;
        let mut sum = Vector3::zeros();
        let (mut count, mut arm2): (usize, f64) = (0, 0.0);
        for q in rows.clone() {
            let (u, a) = part(q);
            let n = u.norm();
            if n == 0.0 {
                continue;
            }
            let (ub, ab) = (c.transpose() * (u / n), a / n);
            sum += ub.cross(&ab);
            arm2 = arm2.max(ab.norm_squared());
            count += 1;
        }
        let rb = sum * 0.5;
        let consistent = count >= 3
            && rows.clone().all(|q| {
                let (u, a) = part(q);
                let n = u.norm();
                n == 0.0
                    || (rb.cross(&(c.transpose() * (u / n))) - a / n).norm()
                        <= 1e-9 * (1.0 + rb.norm())
            });
        let rot = if consistent && rb.norm() > 0.0 {
            let rh = rb.normalize();
            let proj = Matrix3::identity() - rh * rh.transpose();
            rb.norm_squared() * (proj * jinv * proj).symmetric_eigen().eigenvalues.max()
        } else {
            arm2 * lmax
        };
        k += l2 * (1.0 / mp.m + rot);
    }
    k
}

impl TwoStage {
    /// The staggered explicit–implicit method.
    pub fn staggered<S: System>(
        sys: &S,
        h: f64,
        opts: &StaggeredOptions,
        start: &State,
    ) -> Result<TwoStage, StartError> {
        // `single_stage` is the conventional update (C3 eq. 41): the lagged gyroscopic term.
        let gyroscopic = if opts.single_stage {
            Gyroscopic::Lagged
        } else {
            opts.gyroscopic
        };
        let law = Law::Staggered {
            lint: opts.lint,
            gyroscopic,
        };
        let backend = match opts.factorization {
            Factorization::Auto => Backend::Auto,
            Factorization::Dense => Backend::Dense,
            Factorization::Sparse => Backend::Sparse,
        };
        let mut s = TwoStage::new(
            sys,
            h,
            law,
            "staggered",
            opts.epsilon,
            opts.paper_literal,
            backend,
            start,
        )?;
        s.relax = opts.relaxation == Relaxation::Kinetic;
        if s.relax {
            s.relax_pose = s.seq[0].pose.clone();
            // the extent of the scene: the diagonal of the bodies' bounding box
            let mut d = 0.0;
            if let Some(first) = start.pose.first() {
                let (mut lo, mut hi) = (first.r, first.r);
                for p in &start.pose {
                    lo = lo.inf(&p.r);
                    hi = hi.sup(&p.r);
                }
                d = (hi - lo).norm();
            }
            s.relax_length = if d > 0.0 { d } else { 1.0 };
        }
        if s.relax && !s.one_sequence {
            return Err(StartError::Invalid(
                "`relaxation kinetic` needs one leapfrog sequence: drop `gyroscopic synchronous`"
                    .into(),
            ));
        }
        if opts.beam_substeps > 1 {
            s.start_subcycle(sys, opts, start)?;
        }
        Ok(s)
    }

    /// Set up `beam_substeps` (see [`super::beam_subcycle`]): refuse the options it does not
    /// combine with, and start the beam nodes' half-step velocities at their own step.
    fn start_subcycle<S: System>(
        &mut self,
        sys: &S,
        opts: &StaggeredOptions,
        start: &State,
    ) -> Result<(), StartError> {
        let n = opts.beam_substeps;
        let refuse = |why: &str| Err(StartError::Invalid(format!("`beam_substeps {n}` {why}")));
        if self.beams.is_none() {
            return refuse("needs a scene with flexible beams: this one has none");
        }
        if !self.midpoint_gyro || !self.one_sequence {
            return refuse("needs the default `gyroscopic midpoint` (one leapfrog sequence with the implicit midpoint kick)");
        }
        if opts.lint != LintForm::Exact {
            return refuse("needs the default `lint exact`");
        }
        if self.relax {
            return refuse("does not combine with `relaxation kinetic` (a static solution: give the beams' step to the whole scene)");
        }
        let mut sub = Subcycle::new(sys, n, &self.e, opts.epsilon.is_none(), self.tol)
            .map_err(StartError::Invalid)?;
        sub.start(&self.lambda, &self.seq[0].vel);
        // the nodes' velocities half a substep back (the whole step's start went back h/2)
        let layout = sys.layout();
        let hs = self.h / n as f64;
        for &i in sub.fast_bodies() {
            let net = Wrench {
                f: self.qbar[i].f - self.flam[i].f,
                t: self.qbar[i].t - self.flam[i].t,
            };
            let a = accel(&layout.mass[i], &net);
            self.seq[0].vel[i].v = start.twist[i].v - a.v * (hs / 2.0);
            // the torque without the gyroscopic term, which the midpoint rule supplies
            let tau = self.applied[i].t - self.flam[i].t;
            self.seq[0].vel[i].w =
                midpoint_kick(&layout.mass[i], &start.twist[i].w, &tau, -hs / 2.0);
        }
        self.subcycle = Some(sub);
        Ok(())
    }

    /// The step of body `b`'s own coordinate update: the substep for a beam node when the
    /// beams are subcycled, else the step.
    fn own_step(&self, b: usize) -> f64 {
        match &self.subcycle {
            Some(sub) if sub.is_fast(b) => self.h / sub.substeps() as f64,
            _ => self.h,
        }
    }

    /// Baumgarte's stabilization on the same coordinate integrator.
    pub fn baumgarte<S: System>(
        sys: &S,
        h: f64,
        alpha: f64,
        beta: f64,
        start: &State,
    ) -> Result<TwoStage, StartError> {
        TwoStage::new(
            sys,
            h,
            Law::Baumgarte { alpha, beta },
            "baumgarte",
            None,
            false,
            Backend::Auto,
            start,
        )
    }

    /// The penalty method on the same coordinate integrator.
    pub fn penalty<S: System>(
        sys: &S,
        h: f64,
        epsilon: Option<f64>,
        start: &State,
    ) -> Result<TwoStage, StartError> {
        TwoStage::new(
            sys,
            h,
            Law::Penalty,
            "penalty",
            epsilon,
            false,
            Backend::Auto,
            start,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn new<S: System>(
        sys: &S,
        h: f64,
        law: Law,
        name: &'static str,
        epsilon: Option<f64>,
        paper_literal: bool,
        backend: Backend,
        start: &State,
    ) -> Result<TwoStage, StartError> {
        let layout = sys.layout();
        let (nb, m) = (layout.bodies(), layout.rows);
        let (t0, pose, vel) = (start.t, start.pose.clone(), start.twist.clone());
        let active = start.active.clone();

        // Consistent λ⁰ and accelerations at t0.
        let mut ce = ConstraintEval::new(m);
        sys.constraints(t0, &pose, &vel, Need::ALL, &mut ce);
        let mut applied = vec![Wrench::default(); nb];
        sys.applied(t0, &pose, &vel, &mut applied);
        let beam_kernels =
            super::beam_kernels::BeamKernels::of_system(sys).map_err(StartError::Invalid)?;
        let beams = BeamForces::with_kernels(layout, &beam_kernels, start)?;
        if let Some(b) = &beams {
            b.add_to(&mut applied);
        }
        let mut q0 = vec![Wrench::default(); nb];
        qbar(layout, &applied, &vel, &mut q0);
        let mut lambda = vec![0.0; m];
        Index1::new(layout)?.solve(layout, &ce, &q0, &active, &mut lambda)?;
        let mut flam = vec![Wrench::default(); nb];
        bt_lambda(layout, &ce, &lambda, &active, &mut flam);

        let mut ks = KSolver::new(
            layout,
            KSolverOptions {
                backend,
                definiteness: Definiteness::Positive,
            },
        )?;
        ks.assemble(&ce.jac, &layout.mass, 1.0, 0.0, Some(&active));
        let mut kd = vec![0.0; m];
        let (kdiag, kmax) = common::k_bounds(&ks, &active, &mut kd);
        // Regularization per row. Given ε: E = ε on holonomic rows, εh on nonholonomic ones
        // (their equation is scaled by h). Default: E_r = 10⁻⁹·h²·K_rr, i.e. 10⁻⁹ I on the
        // Jacobi-scaled matrix, which bounds cond(E + h²K) by about 10⁹ whatever K does.
        let rho = 1e-9;
        let (epsilon, e): (f64, Vec<f64>) = match (&law, epsilon) {
            (Law::Penalty, Some(eps)) => (eps, vec![eps; m]),
            (Law::Penalty, None) => {
                // Per row, ε_r = g·h²·K_rr, where g bounds λ_max of the Jacobi-scaled K: for a
                // positive semi-definite K, |K_rc| ≤ √(K_rr K_cc), so g = the most rows coupled
                // to one row (through the bodies of its joint). Then the penalty frequencies
                // √(λ_max(E⁻¹K))·h stay at most 1, half the explicit limit 2, and each row's
                // sag ε_rλ_r follows its own stiffness: one scalar ε sized for the stiffest
                // row (a slender rod's axial rotation) let the translations sag by decimetres.
                // K_rr is that of any configuration the run may reach, not only the start's
                // ([`penalty_k_bound`]): sized at a start where a row's lever arm lies along
                // the row, a bob on a revolute blew up at every step down to 1e-5 s once it
                // swung, always at the same time (its penalty frequency grew 80-fold).
                let mut on_body = vec![0usize; nb];
                for j in &layout.joints {
                    for b in j.a.into_iter().chain(j.b) {
                        on_body[b] += j.rows;
                    }
                }
                let mut e = vec![0.0; m];
                for j in &layout.joints {
                    let g =
                        j.a.into_iter()
                            .chain(j.b)
                            .map(|b| on_body[b])
                            .sum::<usize>();
                    for r in j.first_row..j.first_row + j.rows {
                        // rows inactive at the start (locks) have no K_rr yet: the bound
                        // of the whole matrix
                        let bound = penalty_k_bound(layout, &ce, &pose, j, r);
                        let k = if kd[r] > 0.0 {
                            g.max(1) as f64 * kd[r].max(bound)
                        } else {
                            kmax.max(g.max(1) as f64 * bound)
                        };
                        e[r] = (h * h * k).max(f64::MIN_POSITIVE);
                    }
                }
                let eps = (0..m)
                    .filter(|&r| layout.row_kind[r] == RowKind::Holonomic)
                    .map(|r| e[r])
                    .fold(0.0, f64::max);
                (eps, e)
            }
            (_, Some(eps)) => (
                eps,
                (0..m)
                    .map(|r| {
                        if layout.row_kind[r] == RowKind::Holonomic {
                            eps
                        } else {
                            eps * h
                        }
                    })
                    .collect(),
            ),
            (_, None) => {
                let floor = rho * h * h * kdiag * f64::EPSILON;
                let e: Vec<f64> = kd
                    .iter()
                    .map(|k| (rho * h * h * k).max(floor).max(f64::MIN_POSITIVE))
                    .collect();
                // the ε reported is that of the largest holonomic row
                let eps = (0..m)
                    .filter(|&r| layout.row_kind[r] == RowKind::Holonomic)
                    .map(|r| e[r])
                    .fold(0.0, f64::max);
                (eps, e)
            }
        };
        let mut seq_b = Seq {
            pose: pose.clone(),
            vel: vel.clone(),
        };
        let mut seq_a = Seq {
            pose: pose.clone(),
            vel: vel.clone(),
        };
        for i in 0..nb {
            let net = Wrench {
                f: q0[i].f - flam[i].f,
                t: q0[i].t - flam[i].t,
            };
            let a = accel(&layout.mass[i], &net);
            seq_b.vel[i].v = vel[i].v - a.v * (h / 2.0);
            seq_b.vel[i].w = vel[i].w - a.w * (h / 2.0);
            let dr = vel[i].v * (h / 2.0) + a.v * (h * h / 8.0);
            let phi = vel[i].w * (h / 2.0) + a.w * (h * h / 8.0);
            seq_a.pose[i] = common::rotate_body(&pose[i], dr, phi);
        }

        // One sequence with the gyroscopic term by the implicit midpoint rule (default, and
        // for Baumgarte and penalty); the paper's two sequences exchanging ω; or one sequence
        // with the lagged ω (the conventional update).
        let gyro = match law {
            Law::Staggered { gyroscopic, .. } => gyroscopic,
            _ => Gyroscopic::Midpoint,
        };
        let one_sequence = gyro != Gyroscopic::Synchronous;
        let midpoint_gyro = gyro == Gyroscopic::Midpoint;
        if midpoint_gyro {
            // ω(−h/2) by the same implicit midpoint rule run backwards over h/2 (the torque
            // without the gyroscopic term, which the rule supplies): the kicks then conserve
            // the initial ωᵀJω of a free body, not that of an explicit half step's ω.
            for i in 0..nb {
                let tau = applied[i].t - flam[i].t;
                seq_b.vel[i].w = midpoint_kick(&layout.mass[i], &vel[i].w, &tau, -h / 2.0);
            }
        }
        let mut s = TwoStage {
            law,
            name,
            h,
            one_sequence,
            paper_literal,
            epsilon,
            vel_prev: vel.clone(),
            vel_sync: vel.clone(),
            e_eff: e.clone(),
            lambda_guess: vec![0.0; m],
            regularized_steps: 0,
            midpoint_gyro,
            e,
            tau: t0,
            t0,
            half_steps: 0,
            trial: seq_b.clone(),
            seq: [seq_b, seq_a],
            x: 0,
            lambda_prev: lambda.clone(),
            tau_lambda: t0,
            lambda0: lambda.clone(),
            lambda,
            next_active: active.clone(),
            active,
            r_prev: vec![0.0; m],
            fresh: vec![true; m],
            qbar: q0,
            flam,
            applied,
            ce,
            ce_trial: ConstraintEval::new(m),
            tmp: vec![0.0; m],
            res: vec![0.0; m],
            dl: vec![0.0; m],
            ks,
            tol: 1e-13,
            iterations: 0,
            lints: 0,
            max_iterations: 0,
            min_pivot_ratio: f64::INFINITY,
            beams,
            subcycle: None,
            relax: false,
            ke_prev: 0.0,
            relax_resets: 0,
            relax_pose: Vec::new(),
            relax_residual: f64::INFINITY,
            relax_length: 1.0,
        };
        s.lambda_prev.copy_from_slice(&s.lambda);
        Ok(s)
    }

    fn cint_opts(&self) -> CintOpts {
        CintOpts {
            h: self.h,
            literal: self.paper_literal,
            midpoint_gyro: self.midpoint_gyro,
        }
    }

    /// With `relaxation kinetic`, how far the last step was from a static equilibrium: the
    /// out-of-balance load `Σ|r_f|·L + Σ|r_τ|` (per body, `r = Q̄ − Bᵀλ`, which is `M` times
    /// its acceleration) relative to the loads in play `Σ(|Q̄_f| + |(Bᵀλ)_f|)·L + Σ(|Q̄_τ| +
    /// |(Bᵀλ)_τ|)` (applied and internal forces, and reactions), `L` the extent of the scene
    /// at the start (torques and forces weighed as virtual work). 0 in equilibrium; a
    /// remaining error `e` in the lowest mode leaves `r = K e`, so the ratio is of the order
    /// of the relative error of the displacements there, and larger for an error in the
    /// higher modes (see docs/methods.md for its measured relation to the error). `None`
    /// without relaxation; infinite before the first step.
    pub fn relaxation_residual(&self) -> Option<f64> {
        self.relax.then_some(self.relax_residual)
    }

    /// The out-of-balance ratio of [`TwoStage::relaxation_residual`] for the step just made
    /// (`qbar` and `flam` hold its loads and constraint forces).
    fn out_of_balance(&self, layout: &crate::contract::system::Layout) -> f64 {
        let l = self.relax_length;
        let (mut res, mut scale) = (0.0, 0.0);
        for i in 0..layout.bodies() {
            let (q, f) = (&self.qbar[i], &self.flam[i]);
            res += (q.f - f.f).norm() * l + (q.t - f.t).norm();
            scale += (q.f.norm() + f.f.norm()) * l + q.t.norm() + f.t.norm();
        }
        if scale > 0.0 {
            res / scale
        } else {
            0.0
        }
    }

    /// The ε in use (m/N for position rows; for nonholonomic rows (m/s)/N).
    pub fn epsilon(&self) -> f64 {
        self.epsilon
    }

    /// Forces and constraints at τ for sequence `x` (positions at τ, velocities at τ − h/2),
    /// with the synchronous velocities of sequence `y` (used for the gyroscopic term only with
    /// [`Gyroscopic::Synchronous`]; with the midpoint rule it is in the coordinate update).
    fn evaluate<S: System>(&mut self, sys: &S, x: usize, y: usize) {
        let layout = sys.layout();
        let (px, vx, vy) = (&self.seq[x].pose, &self.seq[x].vel, &self.seq[y].vel);
        sys.applied(self.tau, px, vx, &mut self.applied);
        if let Some(b) = &self.beams {
            b.add_to(&mut self.applied);
        }
        if self.midpoint_gyro {
            self.qbar.copy_from_slice(&self.applied);
        } else {
            qbar(layout, &self.applied, vy, &mut self.qbar);
        }
        // Baumgarte's index-1 λ needs γ at a synchronous velocity: with one sequence the
        // estimate `vel_sync` (the sequence's own velocity lags by h/2, an O(h) error in λ)
        let vc = if self.one_sequence && matches!(self.law, Law::Baumgarte { .. }) {
            &self.vel_sync
        } else {
            vy
        };
        sys.constraints(self.tau, px, vc, Need::ALL, &mut self.ce);
    }

    /// Advance `src` by h with the current `qbar` and `flam` into `dst`.
    fn cint(
        layout: &crate::contract::system::Layout,
        o: CintOpts,
        qbar: &[Wrench],
        flam: &[Wrench],
        src: &Seq,
        dst: &mut Seq,
    ) {
        for i in 0..layout.bodies() {
            (dst.pose[i], dst.vel[i]) = cint_body(
                &layout.mass[i],
                o,
                &qbar[i],
                &flam[i],
                &src.pose[i],
                &src.vel[i],
            );
        }
    }

    /// Advance `seq` by h in place.
    fn cint_in_place(
        layout: &crate::contract::system::Layout,
        o: CintOpts,
        qbar: &[Wrench],
        flam: &[Wrench],
        seq: &mut Seq,
    ) {
        for i in 0..layout.bodies() {
            (seq.pose[i], seq.vel[i]) = cint_body(
                &layout.mass[i],
                o,
                &qbar[i],
                &flam[i],
                &seq.pose[i],
                &seq.vel[i],
            );
        }
    }

    /// Staggered LINT (exact form) for sequence `x`: Newton on λ until the positions after the
    /// CINT satisfy `Φ = ε(λ − λ⁰)`. Leaves the advanced sequence in `self.trial`.
    fn lint_exact<S: System>(&mut self, sys: &S, x: usize) -> Result<u32, StepError> {
        // Near a singular configuration (links that line up, lock-up) the regularization of
        // the default ε can be too small for the iteration to converge: retry the step with it
        // raised ×10³ at a time, up to about h²K_rr (each such step is counted), then go back.
        self.lambda_guess.copy_from_slice(&self.lambda);
        let mut last = None;
        for (k, scale) in [1.0, 1e3, 1e6, 1e9].into_iter().enumerate() {
            if k > 0 {
                self.lambda.copy_from_slice(&self.lambda_guess);
            }
            for r in 0..self.e.len() {
                self.e_eff[r] = self.e[r] * scale;
            }
            match self.lint_exact_with(sys, x) {
                Ok(it) => {
                    if k > 0 {
                        self.regularized_steps += 1;
                    }
                    return Ok(it);
                }
                Err(e @ StepError::NoConvergence { .. }) => last = Some(e),
                Err(e) => return Err(e),
            }
        }
        Err(last.expect("at least one attempt"))
    }

    /// One attempt of [`Self::lint_exact`] with the regularization `self.e_eff`.
    fn lint_exact_with<S: System>(&mut self, sys: &S, x: usize) -> Result<u32, StepError> {
        let layout = sys.layout();
        let h = self.h;
        let m = layout.rows;
        // The Newton matrix: ∂Φ(X(τ+h))/∂λ ≈ −h² B(τ+h) M⁻¹ B(τ)ᵀ, approximated by the
        // symmetric −h² B(τ) M⁻¹ B(τ)ᵀ (the force direction B(τ)ᵀ is exact). The difference
        // is O(hω) and antisymmetric; it slows the iteration when inertias differ by orders
        // of magnitude (a slender rod's axial inertia): ~6 iterations on the slider-crank,
        // 2–3 on ordinary scenes.
        self.ks
            .assemble(&self.ce.jac, &layout.mass, h * h, 0.0, Some(&self.active));
        self.ks.add_diagonal(&self.e_eff, Some(&self.active));
        self.factor("LINT (εI + h²BM⁻¹Bᵀ)")?;
        let t_end = self.tau + h;
        let extent = self.seq[x]
            .pose
            .iter()
            .fold(0.0f64, |a, p| a.max(p.r.norm()));
        let tol = self.tol * (1.0 + extent);
        let mut prev = f64::INFINITY;
        for it in 0..MAX_NEWTON {
            bt_lambda(layout, &self.ce, &self.lambda, &self.active, &mut self.flam);
            let trial = std::mem::replace(
                &mut self.trial,
                Seq {
                    pose: Vec::new(),
                    vel: Vec::new(),
                },
            );
            let mut trial = trial;
            Self::cint(
                layout,
                self.cint_opts(),
                &self.qbar,
                &self.flam,
                &self.seq[x],
                &mut trial,
            );
            sys.constraints(
                t_end,
                &trial.pose,
                &trial.vel,
                Need::PHI,
                &mut self.ce_trial,
            );
            // nonholonomic rows: average of the residual at the start and end positions
            b_times(layout, &self.ce, &trial.vel, &mut self.tmp);
            self.trial = trial;
            let mut worst: f64 = 0.0;
            for r in 0..m {
                if !self.active[r] {
                    self.res[r] = 0.0;
                    continue;
                }
                let phi = if layout.row_kind[r] == RowKind::Holonomic {
                    self.ce_trial.phi[r]
                } else {
                    h * 0.5 * (self.ce_trial.phi[r] + self.tmp[r] + self.ce.bias[r])
                };
                self.res[r] = phi - self.e_eff[r] * (self.lambda[r] - self.lambda0[r]);
                worst = worst.max(self.res[r].abs());
            }
            if !worst.is_finite() || self.res.iter().any(|r| !r.is_finite()) {
                break;
            }
            // Converged at the tolerance relative to the current positions (round-off in Φ
            // grows with the distance from the origin), or stagnating at round-off.
            if worst <= tol || (it >= 2 && worst <= 1e3 * tol && worst >= 0.5 * prev) {
                return Ok(it);
            }
            prev = worst;
            self.dl.copy_from_slice(&self.res);
            self.ks.solve_in_place(&mut self.dl);
            for r in 0..m {
                self.lambda[r] += self.dl[r];
            }
        }
        let worst = super::worst_entry(&self.res);
        Err(StepError::NoConvergence {
            what: "staggered LINT Newton iteration",
            iterations: MAX_NEWTON,
            residual: worst.map_or(0.0, |w| w.1),
            row: worst.map(|w| w.0),
        })
    }

    /// The paper's midpoint LINT (C3 eq. 34) for sequence `x`.
    fn lint_midpoint<S: System>(
        &mut self,
        sys: &S,
        x: usize,
        lam_step: f64,
    ) -> Result<(), StepError> {
        let layout = sys.layout();
        let m = layout.rows;
        let delta = self.h / 2.0;
        // r: holonomic B(u̇_x + δ M⁻¹Q̄) + Φ_t ; nonholonomic δ(B M⁻¹ Q̄ − γ)
        b_minv(layout, &self.ce, &self.qbar, &mut self.res);
        b_times(layout, &self.ce, &self.seq[x].vel, &mut self.tmp);
        for r in 0..m {
            self.res[r] = if !self.active[r] {
                0.0
            } else if layout.row_kind[r] == RowKind::Holonomic {
                self.tmp[r] + delta * self.res[r] + self.ce.bias[r]
            } else {
                delta * (self.res[r] - self.ce.gamma[r])
            };
        }
        let rhs_factor = midpoint_rhs_factor(lam_step, self.paper_literal);
        let e_mid = |e: f64, kind: RowKind| {
            if kind == RowKind::Holonomic {
                e
            } else {
                e / self.h * delta
            }
        };
        self.ks.assemble(
            &self.ce.jac,
            &layout.mass,
            lam_step / 2.0 * delta,
            0.0,
            Some(&self.active),
        );
        for r in 0..m {
            self.dl[r] = e_mid(self.e[r], layout.row_kind[r]);
        }
        self.ks.add_diagonal(&self.dl, Some(&self.active));
        for r in 0..m {
            if !self.active[r] {
                self.tmp[r] = 0.0;
                continue;
            }
            let e = e_mid(self.e[r], layout.row_kind[r]);
            if self.fresh[r] {
                self.r_prev[r] = self.res[r];
                self.fresh[r] = false;
            }
            self.tmp[r] = e * self.lambda[r] + rhs_factor * (self.r_prev[r] + self.res[r]);
        }
        self.factor("LINT (εI + h²/8·BM⁻¹Bᵀ)")?;
        self.dl.copy_from_slice(&self.tmp);
        self.ks.solve_in_place(&mut self.dl);
        for r in 0..m {
            self.lambda[r] = if self.active[r] {
                2.0 * self.dl[r] - self.lambda[r]
            } else {
                0.0
            };
        }
        self.r_prev.copy_from_slice(&self.res);
        Ok(())
    }

    /// Baumgarte's index-1 multipliers for sequence `x`. The rate feedback `2αΦ̇` is a
    /// damping term, so it uses X's own lagged velocity (the synchronous velocity of the
    /// other sequence makes the leapfrog unstable for it, notes A §1.9); γ is gyroscopic in
    /// nature and uses the synchronous one (through `self.ce`).
    fn lint_baumgarte<S: System>(
        &mut self,
        sys: &S,
        x: usize,
        alpha: f64,
        beta: f64,
    ) -> Result<(), StepError> {
        let layout = sys.layout();
        let m = layout.rows;
        if self.midpoint_gyro {
            // the coordinate update applies the gyroscopic term itself, so `qbar` lacks it;
            // the λ solve needs it (at the synchronous ω): flam is free until bt_lambda
            let w = if self.one_sequence {
                &self.vel_sync
            } else {
                &self.seq[1 - x].vel
            };
            qbar(layout, &self.applied, w, &mut self.flam);
            b_minv(layout, &self.ce, &self.flam, &mut self.res);
        } else {
            b_minv(layout, &self.ce, &self.qbar, &mut self.res);
        }
        // The rate term Φ̇ = Bu̇ at τ. With one sequence and 2αh ≤ 1/2, from the
        // second-order estimate `vel_sync` (AB2 in effect for this damping-like term: stable
        // for 2αh < 1). The sequence's own velocity is h/2 old against the Jacobian at τ, an
        // O(h) rate error that the feedback turns into a steady violation of about αhω²r/β²
        // (1.5e-3 m on the pendulum at h = 1 ms, α = β = 10); it is kept where AB2 would be
        // near its limit (stable for 2αh < 2: the crank's α = 70 at h = 0.01). With two
        // sequences, the lagged velocity: the other sequence's couples them and was unstable.
        let rate_vel = if self.one_sequence && 2.0 * alpha * self.h <= 0.5 {
            &self.vel_sync
        } else {
            &self.seq[x].vel
        };
        b_times(layout, &self.ce, rate_vel, &mut self.tmp);
        for r in 0..m {
            if !self.active[r] {
                self.res[r] = 0.0;
                continue;
            }
            let rate = self.tmp[r] + self.ce.bias[r];
            self.res[r] += -self.ce.gamma[r]
                + if layout.row_kind[r] == RowKind::Holonomic {
                    2.0 * alpha * rate + beta * beta * self.ce.phi[r]
                } else {
                    2.0 * alpha * rate
                };
        }
        self.ks
            .assemble(&self.ce.jac, &layout.mass, 1.0, 0.0, Some(&self.active));
        self.factor("Baumgarte (BM⁻¹Bᵀ)")?;
        self.lambda.copy_from_slice(&self.res);
        self.ks.solve_in_place(&mut self.lambda);
        Ok(())
    }

    /// Cholesky of the assembled matrix; a non-positive pivot is a singular matrix.
    fn factor(&mut self, what: &'static str) -> Result<(), StepError> {
        match self.ks.factor() {
            Ok(st) => {
                self.min_pivot_ratio = self.min_pivot_ratio.min(st.pivot_ratio());
                Ok(())
            }
            Err(LinalgError::NotPositiveDefinite { row, .. }) => {
                Err(StepError::Singular { what, row })
            }
            Err(e) => Err(StepError::Linalg {
                what,
                message: e.to_string(),
            }),
        }
    }

    /// One half step (or a full step in single-stage mode) of sequence `x` at τ.
    fn advance<S: System>(&mut self, sys: &S, x: usize, y: usize) -> Result<u32, StepError> {
        let layout = sys.layout();
        self.evaluate(sys, x, y);
        let mut iters = 0;
        let advanced = match self.law.clone() {
            Law::Staggered {
                lint: LintForm::Exact,
                ..
            } => {
                // warm start: λ(τ) ≈ 2λ(τ − Δ) − λ(τ − 2Δ)
                for r in 0..layout.rows {
                    let (l1, l0) = (self.lambda[r], self.lambda_prev[r]);
                    self.lambda_prev[r] = l1;
                    self.lambda[r] = if self.active[r] { 2.0 * l1 - l0 } else { 0.0 };
                }
                iters = self.lint_exact(sys, x)?;
                true
            }
            Law::Staggered {
                lint: LintForm::Midpoint,
                ..
            } => {
                self.lambda_prev.copy_from_slice(&self.lambda);
                let lam_step = if self.one_sequence {
                    self.h
                } else {
                    self.h / 2.0
                };
                self.lint_midpoint(sys, x, lam_step)?;
                false
            }
            Law::Baumgarte { alpha, beta } => {
                self.lambda_prev.copy_from_slice(&self.lambda);
                self.lint_baumgarte(sys, x, alpha, beta)?;
                false
            }
            Law::Penalty => {
                self.lambda_prev.copy_from_slice(&self.lambda);
                // λ = Φ/ε; nonholonomic rows penalize the velocity residual with the lagged
                // velocity and ε/h (explicit damping, stable for (h/ε_N)·λ_max(K)·h < 2).
                b_times(layout, &self.ce, &self.seq[x].vel, &mut self.tmp);
                for r in 0..layout.rows {
                    self.lambda[r] = if !self.active[r] {
                        0.0
                    } else if layout.row_kind[r] == RowKind::Holonomic {
                        self.ce.phi[r] / self.e[r]
                    } else {
                        (self.tmp[r] + self.ce.bias[r]) * self.h / self.e[r]
                    };
                }
                false
            }
        };
        self.tau_lambda = self.tau;
        self.lints += 1;
        self.iterations += iters as u64;
        self.max_iterations = self.max_iterations.max(iters);
        if advanced {
            std::mem::swap(&mut self.seq[x], &mut self.trial);
        } else {
            bt_lambda(layout, &self.ce, &self.lambda, &self.active, &mut self.flam);
            Self::cint_in_place(
                layout,
                self.cint_opts(),
                &self.qbar,
                &self.flam,
                &mut self.seq[x],
            );
        }
        Ok(iters)
    }

    fn check_locks<S: System>(&mut self, sys: &S) {
        let vel_seq = if self.one_sequence {
            self.x
        } else {
            1 - self.x
        };
        self.next_active.copy_from_slice(&self.active);
        if sys
            .update_locks(
                &self.seq[self.x].pose,
                &self.seq[vel_seq].vel,
                &mut self.next_active,
            )
            .is_some()
        {
            for r in 0..self.active.len() {
                if self.next_active[r] && !self.active[r] {
                    self.fresh[r] = true;
                    self.lambda[r] = 0.0;
                    self.lambda0[r] = 0.0;
                }
                self.active[r] = self.next_active[r];
            }
        }
    }
}

/// Settings of one coordinate update.
#[derive(Clone, Copy, Debug)]
struct CintOpts {
    h: f64,
    /// Printed Δ of the Euler-parameter update.
    literal: bool,
    /// Gyroscopic term by the implicit midpoint rule (else it is in `qbar` already).
    midpoint_gyro: bool,
}

/// Coefficient of `(r_prev + r)` in the midpoint LINT over a λ step `lam_step`: the
/// consistent `lam_step/4` (h/8 for the half step), or the printed `lam_step/2` (h/4), whose
/// fixed point is `2A⁻¹r` instead of `A⁻¹r` (notes A §1.6).
fn midpoint_rhs_factor(lam_step: f64, paper_literal: bool) -> f64 {
    if paper_literal {
        lam_step / 2.0
    } else {
        lam_step / 4.0
    }
}

/// CINT for one body: `u̇ + h M⁻¹(Q̄ − f_λ)`, then positions with the new velocity.
#[inline]
fn cint_body(
    m: &crate::contract::system::MassProps,
    o: CintOpts,
    qbar: &Wrench,
    flam: &Wrench,
    p: &Pose,
    v: &Twist,
) -> (Pose, Twist) {
    let a = accel(
        m,
        &Wrench {
            f: qbar.f - flam.f,
            t: qbar.t - flam.t,
        },
    );
    let (h, literal) = (o.h, o.literal);
    let v = if o.midpoint_gyro {
        // implicit midpoint for the rotational equation: J(ω⁺ − ω)/h + ω̄ × Jω̄ = τ
        Twist {
            v: v.v + a.v * h,
            w: midpoint_kick(m, &v.w, &(qbar.t - flam.t), h),
        }
    } else {
        Twist {
            v: v.v + a.v * h,
            w: v.w + a.w * h,
        }
    };
    let q = cayley_update(&p.q, &v.w, h, literal);
    (
        Pose {
            r: p.r + v.v * h,
            q,
            c: crate::contract::math::rotation(&q),
        },
        v,
    )
}

/// The mass inner product `Σ m a·b + a_ωᵀ J b_ω` of two sets of velocities.
fn mass_dot(layout: &crate::contract::system::Layout, a: &[Twist], b: &[Twist]) -> f64 {
    layout
        .mass
        .iter()
        .zip(a.iter().zip(b))
        .map(|(m, (a, b))| m.m * a.v.dot(&b.v) + a.w.dot(&(m.j * b.w)))
        .sum()
}

/// Kinetic energy `Σ ½ m|v|² + ½ ωᵀJω` of a set of velocities.
fn kinetic(layout: &crate::contract::system::Layout, vel: &[Twist]) -> f64 {
    layout
        .mass
        .iter()
        .zip(vel)
        .map(|(m, t)| 0.5 * (m.m * t.v.norm_squared() + t.w.dot(&(m.j * t.w))))
        .sum()
}

/// The velocity half a step ahead of `v1` by second-order extrapolation from the velocity
/// `v0` one step before it: `1.5 v₁ − 0.5 v₀` (the sequence's velocities lag by h/2).
fn half_ahead(v1: &Twist, v0: &Twist) -> Twist {
    Twist {
        v: v1.v * 1.5 - v0.v * 0.5,
        w: v1.w * 1.5 - v0.w * 0.5,
    }
}

/// The implicit midpoint rule for the rotational equation over `h`:
/// `J(ω⁺ − ω)/h + ω̄ × Jω̄ = τ`, `ω̄ = (ω + ω⁺)/2`, solved for ω⁺ by Newton iterations
/// (started from the explicit update). Conserves `ωᵀJω` and `|Jω|` when τ = 0.
fn midpoint_kick(
    m: &crate::contract::system::MassProps,
    w0: &nalgebra::Vector3<f64>,
    tau: &nalgebra::Vector3<f64>,
    h: f64,
) -> nalgebra::Vector3<f64> {
    let (j, w0) = (&m.j, *w0);
    let mut w1 = w0 + m.j_inv * tau * h;
    for _ in 0..8 {
        let wb = (w0 + w1) * 0.5;
        let f = j * (w1 - w0) / h + wb.cross(&(j * wb)) - tau;
        let jac = j / h
            + (crate::contract::math::skew(&wb) * j - crate::contract::math::skew(&(j * wb))) * 0.5;
        let Some(inv) = jac.try_inverse() else { break };
        let d = inv * f;
        w1 -= d;
        if d.norm() <= 1e-15 * (1.0 + w1.norm()) {
            break;
        }
    }
    w1
}

impl<S: System> Integrator<S> for TwoStage {
    fn name(&self) -> &'static str {
        self.name
    }

    fn persist(&mut self, v: &mut dyn StateVisitor) -> bool {
        // what the start set from the initial state (ε, tolerance, relaxation length) and
        // everything a step leaves for the next: both sequences, the half-step velocities,
        // the multipliers and their history, the loads of the last kick, the activity of the
        // rows, the statistics and the beams' element states
        persist::f64(v, "h", &mut self.h);
        persist::f64(v, "epsilon", &mut self.epsilon);
        v.f64s("e", &mut self.e);
        v.f64s("e_eff", &mut self.e_eff);
        v.f64s("lambda_guess", &mut self.lambda_guess);
        persist::u64(v, "regularized_steps", &mut self.regularized_steps);
        persist::twists(v, "vel_prev", &mut self.vel_prev);
        persist::twists(v, "vel_sync", &mut self.vel_sync);
        persist::f64(v, "tau", &mut self.tau);
        persist::f64(v, "t0", &mut self.t0);
        persist::u64(v, "half_steps", &mut self.half_steps);
        for seq in self.seq.iter_mut().chain(std::iter::once(&mut self.trial)) {
            persist::poses(v, "seq.pose", &mut seq.pose);
            persist::twists(v, "seq.vel", &mut seq.vel);
        }
        persist::usize(v, "x", &mut self.x);
        v.f64s("lambda", &mut self.lambda);
        v.f64s("lambda_prev", &mut self.lambda_prev);
        persist::f64(v, "tau_lambda", &mut self.tau_lambda);
        v.f64s("lambda0", &mut self.lambda0);
        v.bools("active", &mut self.active);
        v.bools("next_active", &mut self.next_active);
        v.f64s("r_prev", &mut self.r_prev);
        v.bools("fresh", &mut self.fresh);
        persist::wrenches(v, "qbar", &mut self.qbar);
        persist::wrenches(v, "flam", &mut self.flam);
        persist::wrenches(v, "applied", &mut self.applied);
        persist::constraint_eval(v, &mut self.ce);
        persist::constraint_eval(v, &mut self.ce_trial);
        v.f64s("tmp", &mut self.tmp);
        v.f64s("res", &mut self.res);
        v.f64s("dl", &mut self.dl);
        persist::f64(v, "tol", &mut self.tol);
        persist::u64(v, "iterations", &mut self.iterations);
        persist::u64(v, "lints", &mut self.lints);
        persist::u32(v, "max_iterations", &mut self.max_iterations);
        persist::f64(v, "min_pivot_ratio", &mut self.min_pivot_ratio);
        persist::f64(v, "ke_prev", &mut self.ke_prev);
        persist::u64(v, "relax_resets", &mut self.relax_resets);
        persist::poses(v, "relax_pose", &mut self.relax_pose);
        persist::f64(v, "relax_residual", &mut self.relax_residual);
        persist::f64(v, "relax_length", &mut self.relax_length);
        let mut has_beams = self.beams.is_some();
        persist::bool(v, "beams", &mut has_beams);
        if let Some(b) = &mut self.beams {
            b.persist(v);
        }
        if let Some(sub) = &mut self.subcycle {
            sub.persist(v);
        }
        true
    }

    fn time(&self) -> f64 {
        self.tau
    }

    fn step_size(&self) -> f64 {
        self.h
    }

    fn step(&mut self, sys: &S) -> Result<StepInfo, StepError> {
        let mut iterations = 0;
        if self.one_sequence {
            if matches!(self.law, Law::Baumgarte { .. }) {
                // v(τ) ≈ v(τ − h/2) + (v(τ − h/2) − v(τ − 3h/2))/2; at the start, the initial
                // velocity itself (vel_prev holds it before the first step)
                for i in 0..self.vel_sync.len() {
                    let (v1, v0) = (self.seq[0].vel[i], self.vel_prev[i]);
                    self.vel_sync[i] = if self.half_steps == 0 {
                        v0
                    } else {
                        half_ahead(&v1, &v0)
                    };
                }
            }
            self.vel_prev.copy_from_slice(&self.seq[0].vel);
            if self.relax {
                self.relax_pose.copy_from_slice(&self.seq[0].pose);
            }
            if let Some(sub) = &mut self.subcycle {
                sub.begin(&self.seq[0].pose, &mut self.seq[0].vel);
            }
            iterations += self.advance(sys, 0, 0)?;
            if let (Some(sub), Some(beams)) = (&mut self.subcycle, &mut self.beams) {
                // the beam nodes by their substeps, along the bodies' path of this step
                let literal = self.paper_literal;
                let kick = |m: &crate::contract::system::MassProps,
                            q: &Wrench,
                            f: &Wrench,
                            p: &Pose,
                            v: &Twist,
                            h: f64| {
                    cint_body(
                        m,
                        CintOpts {
                            h,
                            literal,
                            midpoint_gyro: true,
                        },
                        q,
                        f,
                        p,
                        v,
                    )
                };
                let seq = &mut self.seq[0];
                sub.run(
                    sys,
                    self.tau,
                    self.h,
                    &kick,
                    beams,
                    &self.lambda0,
                    &self.active,
                    &mut seq.pose,
                    &mut seq.vel,
                )?;
                for (i, &b) in sub.fast_bodies().iter().enumerate() {
                    self.vel_prev[b] = *sub.vel_before_last(i);
                }
            }
            self.half_steps += 2;
            self.tau = self.t0 + self.half_steps as f64 * self.h / 2.0;
        } else {
            for _ in 0..2 {
                let x = self.x;
                iterations += self.advance(sys, x, 1 - x)?;
                self.half_steps += 1;
                self.tau = self.t0 + self.half_steps as f64 * self.h / 2.0;
                self.x = 1 - x;
            }
        }
        if self.relax {
            // Kinetic damping: when the kinetic energy has passed a peak during this step,
            // go back to the positions at its start (nearer the peak, where the potential
            // energy is lowest) and stop every body. The leapfrog conserves
            // `u̇ᵀMu̇ + …` only up to the cross term `u̇⁻ᵀ M u̇⁺` of the two half-step
            // velocities, which is what a reset removes: reset only when it is positive (the
            // velocities did not reverse within the step), so a reset never adds energy.
            // Zeroing at the end positions instead pumps the modes with h·ω near 1.
            let layout = sys.layout();
            let ke = kinetic(layout, &self.seq[0].vel);
            let cross = mass_dot(layout, &self.vel_prev, &self.seq[0].vel);
            self.relax_residual = self.out_of_balance(layout);
            if ke < self.ke_prev && cross > 0.0 {
                self.seq[0].pose.copy_from_slice(&self.relax_pose);
                for v in self.seq[0].vel.iter_mut().chain(self.vel_prev.iter_mut()) {
                    *v = Twist::default();
                }
                self.relax_resets += 1;
                self.ke_prev = 0.0;
            } else {
                self.ke_prev = ke;
            }
        }
        if let (Some(b), None) = (&mut self.beams, &self.subcycle) {
            // the elements at the new positions; their forces act in the next kick
            // (subcycled: the last substep evaluated them)
            let v = if self.one_sequence { 0 } else { 1 - self.x };
            b.update(&self.seq[self.x].pose, &self.seq[v].vel)?;
        }
        self.check_locks(sys);
        Ok(StepInfo { iterations })
    }

    fn state(&self, sys: &S, out: &mut State) {
        let layout = sys.layout();
        out.t = self.tau;
        out.pose.copy_from_slice(&self.seq[self.x].pose);
        if self.one_sequence {
            // The sequence has velocities at t − h/2 (and had them at t − 3h/2). Translation:
            // a half kick with the last kick's acceleration, v(t) ≈ v₁ + (v₁ − v₀)/2 (second
            // order). Rotation with the midpoint gyroscopic kick: a half kick by the same
            // implicit midpoint rule, with the gyroscopic term at the new ω and the rest of the
            // last kick's torque, τ_ext = J(ω₁ − ω₀)/h + ω̄ × Jω̄. Second order too, and on a
            // torque-free body it conserves energy and |L| exactly, as the step does (plain
            // extrapolation overshoots a fast precession by up to ×1.7 near h·ω = 2).
            for i in 0..layout.bodies() {
                let h = self.own_step(i);
                if self.half_steps == 0 {
                    // before the first step `vel_prev` holds the initial velocity itself
                    out.twist[i] = self.vel_prev[i];
                    continue;
                }
                let (v1, v0) = (self.seq[0].vel[i], self.vel_prev[i]);
                let mut v = half_ahead(&v1, &v0);
                if self.midpoint_gyro {
                    let m = &layout.mass[i];
                    let wb = (v0.w + v1.w) * 0.5;
                    let tau = m.j * (v1.w - v0.w) / h + wb.cross(&(m.j * wb));
                    v.w = midpoint_kick(m, &v1.w, &tau, h / 2.0);
                }
                out.twist[i] = v;
            }
        } else {
            out.twist.copy_from_slice(&self.seq[1 - self.x].vel);
        }
        match &self.beams {
            Some(b) => {
                out.beams.clear();
                out.beams.extend_from_slice(b.states());
            }
            None => out.beams.clear(),
        }
        // λ was last computed at tau_lambda (h/2 or h before t): extrapolate linearly.
        let dt = self.tau - self.tau_lambda;
        let gap = if self.one_sequence {
            self.h
        } else {
            self.h / 2.0
        };
        for r in 0..self.lambda.len() {
            let slope = (self.lambda[r] - self.lambda_prev[r]) / gap;
            out.lambda[r] = if self.active[r] {
                self.lambda[r] + slope * dt
            } else {
                0.0
            };
        }
    }

    fn active(&self) -> &[bool] {
        &self.active
    }

    fn stats(&self) -> Vec<(&'static str, f64)> {
        let mut v = vec![("epsilon", self.epsilon)];
        if matches!(
            self.law,
            Law::Staggered {
                lint: LintForm::Exact,
                ..
            }
        ) {
            v.push((
                "newton_iterations_mean",
                self.iterations as f64 / self.lints.max(1) as f64,
            ));
            v.push(("newton_iterations_max", self.max_iterations as f64));
            v.push(("regularized_steps", self.regularized_steps as f64));
        }
        v.push(("min_pivot_ratio", self.min_pivot_ratio));
        if let Some(r) = self.relaxation_residual() {
            v.push(("relaxation_resets", self.relax_resets as f64));
            v.push(("relaxation_residual", r));
            v.push(("relaxation_tolerance", RELAXATION_TOLERANCE));
        }
        if let Some(b) = &self.beams {
            v.push(("beam_large_rotation_steps", b.large_rotation_steps() as f64));
        }
        if let Some(sub) = &self.subcycle {
            v.extend(sub.stats());
        }
        v
    }

    fn take_notice(&mut self) -> Option<String> {
        let t = self.tau;
        self.beams.as_mut()?.take_notice(t)
    }

    fn end_notice(&self) -> Option<String> {
        let r = self.relaxation_residual()?;
        (r.is_nan() || r > RELAXATION_TOLERANCE).then(|| {
            format!(
                "warning: the dynamic relaxation has not converged at t = {:.6} s: the out-of-balance load is {r:.3e} of the loads in play (converged means below {RELAXATION_TOLERANCE:.0e}; after {} velocity resets), so the final positions are not the static solution (their error is of the order of that ratio, or larger). Run longer: raise `duration` in `simulate` or give --duration",
                self.tau, self.relax_resets
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Quaternion, Vector3};

    use super::*;
    use crate::integrators::testsys::RodPendulum;

    /// Exact period of a physical pendulum (complete elliptic integral by AGM).
    fn exact_period(sys: &RodPendulum) -> f64 {
        let m = &sys.layout.mass[0];
        let d = sys.l / 2.0;
        let ip = m.j[(0, 0)] + m.m * d * d;
        let w0 = (m.m * sys.g * d / ip).sqrt();
        let k = (sys.theta0 / 2.0).sin();
        let (mut a, mut b) = (1.0f64, (1.0 - k * k).sqrt());
        for _ in 0..30 {
            let (a1, b1) = ((a + b) / 2.0, (a * b).sqrt());
            a = a1;
            b = b1;
        }
        4.0 * std::f64::consts::PI / (2.0 * a) / w0
    }

    /// Period from the leftward zero crossings of the c.m. x coordinate; max |Φ| on the way.
    fn measured_period(sys: &RodPendulum, it: &mut TwoStage, periods: usize) -> (f64, f64) {
        let mut st = State::new(1, 3);
        let mut crossings = Vec::new();
        let mut prev: Option<(f64, f64)> = None;
        let mut max_phi: f64 = 0.0;
        while crossings.len() < periods + 1 {
            it.step(sys).unwrap();
            Integrator::<RodPendulum>::state(it, sys, &mut st);
            let x = st.pose[0].r.x;
            let phi = (st.pose[0].r + st.pose[0].c * Vector3::new(0.0, 0.0, sys.l / 2.0)).norm();
            max_phi = max_phi.max(phi);
            if let Some((t0, x0)) = prev {
                if x0 > 0.0 && x <= 0.0 {
                    crossings.push(t0 + (st.t - t0) * x0 / (x0 - x));
                }
            }
            prev = Some((st.t, x));
        }
        (
            (crossings[periods] - crossings[0]) / periods as f64,
            max_phi,
        )
    }

    #[test]
    fn pendulum_period_is_second_order_and_constraint_does_not_drift() {
        let sys = RodPendulum::new(1.0, 1.0, 0.01, 170f64.to_radians());
        let exact = exact_period(&sys);
        let mut errs = Vec::new();
        for h in [4e-3, 2e-3, 1e-3] {
            let mut it =
                TwoStage::staggered(&sys, h, &StaggeredOptions::default(), &State::initial(&sys))
                    .unwrap();
            let (t, phi) = measured_period(&sys, &mut it, 3);
            let err = (t - exact).abs() / exact;
            eprintln!("h={h:e} period={t:.9} exact={exact:.9} rel={err:.3e} max|Φ|={phi:.3e}");
            assert!(phi < 1e-10, "constraint violation {phi:e}");
            errs.push(err);
        }
        let order = (errs[1] / errs[2]).log2();
        assert!(errs[2] < 1e-5, "period error {:.3e} at h = 1e-3", errs[2]);
        assert!((order - 2.0).abs() < 0.3, "observed order {order}");
    }

    #[test]
    fn lint_steady_state_is_consistent() {
        // A rod hanging at rest: λ must equal the weight (A⁻¹r). The exact LINT holds it from
        // the consistent start; the corrected midpoint LINT converges to it from λ = 0, and
        // the printed h/4 converges to twice the weight (notes A §1.6).
        let sys = RodPendulum::new(2.0, 1.0, 0.01, 0.0);
        let weight = 2.0 * 9.81;
        let mut st = State::new(1, 3);
        let mut it = TwoStage::staggered(
            &sys,
            1e-3,
            &StaggeredOptions::default(),
            &State::initial(&sys),
        )
        .unwrap();
        for _ in 0..1000 {
            it.step(&sys).unwrap();
        }
        Integrator::<RodPendulum>::state(&it, &sys, &mut st);
        assert!(
            (st.lambda[2] + weight).abs() < 1e-9 * weight,
            "exact: λ = {:?}",
            st.lambda
        );
        // Midpoint LINT: the scalar recursion (ε + (Δλ/2)δA) λ̃ = ελ + f(r + r), λ ← 2λ̃ − λ
        // with constant A and r must settle at (δA)⁻¹r (δ = h/2) with the corrected coefficient.
        let (h, a, r, eps) = (1e-2, 2.0, 3.0, 2e-5);
        for (literal, expect) in [(false, 1.0), (true, 2.0)] {
            let lam_step = h / 2.0;
            let f = midpoint_rhs_factor(lam_step, literal);
            let mut lam: f64 = 0.0;
            for _ in 0..200 {
                let lt = (eps * lam + f * 2.0 * r) / (eps + lam_step / 2.0 * (h / 2.0) * a);
                lam = 2.0 * lt - lam;
            }
            assert!(
                (lam / (r / (h / 2.0 * a)) - expect).abs() < 1e-9,
                "literal={literal}: λ = {lam}"
            );
        }
    }

    #[test]
    fn midpoint_lint_is_not_robust_on_the_pendulum() {
        // Documents why the exact form is the default (docs/methods.md).
        let sys = RodPendulum::new(1.0, 1.0, 0.01, 170f64.to_radians());
        let opts = StaggeredOptions {
            lint: LintForm::Midpoint,
            ..Default::default()
        };
        let mut it = TwoStage::staggered(&sys, 1e-3, &opts, &State::initial(&sys)).unwrap();
        let mut st = State::new(1, 3);
        let mut worst: f64 = 0.0;
        for _ in 0..8000 {
            if it.step(&sys).is_err() {
                worst = f64::INFINITY;
                break;
            }
            Integrator::<RodPendulum>::state(&it, &sys, &mut st);
            let phi = (st.pose[0].r + st.pose[0].c * Vector3::new(0.0, 0.0, 0.5)).norm();
            if !phi.is_finite() {
                worst = f64::INFINITY;
                break;
            }
            worst = worst.max(phi);
        }
        assert!(worst > 1e-2, "the midpoint LINT stayed at |Φ| ≤ {worst:e}");
    }

    #[test]
    fn cayley_preserves_norm() {
        let q = Quaternion::new(0.5, 0.5, 0.5, 0.5);
        let w = Vector3::new(3.0, -2.0, 1.0);
        assert!((cayley_update(&q, &w, 0.1, false).norm() - 1.0).abs() < 1e-15);
    }
}
