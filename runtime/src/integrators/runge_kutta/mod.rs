//! Explicit Runge–Kutta methods on the tree coordinates of natural partitioning: `rk4`
//! (classical, fixed step), `dopri5` (Dormand–Prince 5(4), error-controlled, with
//! dense output) and `dop853` (Dormand–Prince 8(5,3), error-controlled, with seventh-order
//! dense output).
//!
//! ## The differential equation
//!
//! The state is per body the pose (mass-centre position, Euler parameters) and the twist
//! (mass-centre velocity, body-frame angular velocity), 13 numbers, with
//!
//! ```text
//! ṙ = v,   q̇ = ½ q̂ ⊗ (0, ω),   (v̇, ω̇) = ü(t, r, q̂, v, ω),   q̂ = q/|q|,
//! ```
//!
//! `ü = A q̈ + Ȧq̇` the body accelerations of the tree's reduced equations
//! `AᵀMA q̈ = Aᵀ(F − ω × Jω − MȦq̇)` ([`super::natural`]): every stage derivative is one
//! factorization and one tree solve, `O(N)` (`Natural::tree_accelerations`).
//! The right-hand side is smooth near the constraint manifold (unit quaternions, tree
//! joints satisfied, `u = A q̇`), and the manifold is invariant under its exact flow, so
//! the Runge–Kutta method applied to it has its classical order: a stage evaluates the
//! dynamics at `q/|q|`, which agrees with the unnormalized equation on `|q| = 1` and
//! leaves `|q|` invariant (`q · (q ⊗ (0, ω)) = 0`).
//!
//! ## Projection after each step, and why it keeps the order
//!
//! After each step the new state is put back on the manifold: `|q| = 1`, the positions
//! onto the tree joints root → leaf
//! ([`tree_joints::project`](crate::kernels::tree_joints::project)), the velocities onto
//! the null space `u = A q̇` at those positions (`Natural::tree_project`). The projection
//! is smooth and the identity on the manifold, and the step's result is within its local
//! error `O(h^{p+1})` of the exact solution, which lies on the manifold; so the projection
//! moves it by `O(h^{p+1})` and the global error stays `O(h^p)` (Hairer–Lubich–Wanner,
//! *Geometric Numerical Integration*, §IV.4, Theorem 4.2). The joints then hold to
//! round-off at every step and every output frame, without drift.
//!
//! The FSAL stage of `dopri5` and `dop853` is evaluated at the step's unprojected result:
//! the next step starts from the projected state with that derivative, a difference of the
//! projection's size (`O(h^{p+1})`, times h), which keeps the order and saves one evaluation
//! per step. `dopri5` evaluates it with the other stages of every attempt; `dop853` only once
//! the step is accepted (its result and error estimates do not use it), as Hairer's code.
//!
//! ## Error control and output
//!
//! `dopri5` ([`controller`]): the embedded fourth-order estimate in the weighted RMS norm
//! with absolute and relative tolerance `tol`, the PI controller of Gustafsson with
//! Hairer's `DOPRI5` constants, the user's `step` as the first and the largest internal
//! step. `dop853`: the fifth- and third-order estimates combined as Hairer's `DOP853`
//! ([`controller::dop853_combine`], an `h⁸` estimate) in the same norm, and the controller
//! with Hairer's `DOP853` constants (exponent 1/8, β = 0). Each call of
//! [`Integrator::step`] advances the reported time by exactly `step`: the internal steps
//! run past it and the output state there comes from the continuous extension ([`dense`]),
//! projected onto the manifold like a step's result (the internal sequence goes on from its
//! own steps, not from the output). An internal step is never longer than `step`, so each
//! output falls in its own step; `dop853`'s extension needs three more evaluations, made
//! only for a step with an output inside it (none when the step ends on the output time).
//! `rk4` takes one step of `step` per call.
//!
//! ## Closed loops and other rows outside the tree
//!
//! Cut joints, drivers and every other row outside the spanning tree enter each stage by
//! their index-1 multipliers, `G λ = B_c a₀ − γ_c` with `G = (B_c A)(AᵀMA)⁻¹(B_c A)ᵀ`
//! formed by one tree solve per cut row ([`Loops`]); the projection after each step puts
//! the positions back on the cut rows too (Newton in the tree's coordinates, to
//! round-off) and the velocities on their velocity equations, so loops stay closed at
//! round-off and the order is kept by the argument above. The multipliers of the
//! reported state come from its own stage evaluation (for `rk4`, the next step's first
//! stage; otherwise one more evaluation per reported step). A lock that engages during the
//! run (an impact) is refused at the start: the methods assume a smooth motion.

pub mod controller;
pub mod dense;
pub mod tableau;

use nalgebra::{Quaternion, Vector3};

use super::natural::{tree::Tree, Loops, Natural};
use super::{Integrator, StartError, State, StepError, StepInfo};
use crate::contract::math::quat_rate;
use crate::contract::persist::{self, StateVisitor};
use crate::contract::system::{Pose, System, Twist};
use controller::Controller;
use tableau::{Dense, ErrorEstimate, Fsal, Tableau};

/// Numbers per body in the state vector: position, Euler parameters, velocity, ω.
const PER_BODY: usize = 13;

/// Most rows outside the spanning tree the methods take: each stage forms the dense
/// cut-row matrix by one tree solve per row (about `2m + 4` tree solves and an `m × m`
/// product and factorization per stage, [`Loops`]), which at 96 rows costs some 50 times a
/// tree's stage. Above it a run is refused, pointing to `natural_partitioning`, whose
/// cut-row PCG applies the same matrix without forming it.
pub const MAX_CUT_ROWS: usize = 96;

/// Most internal steps (accepted and rejected) within one call of `step` (one output step):
/// beyond it the run stops with a report rather than crawl (a stiff contact, a kink).
const MAX_ATTEMPTS: u64 = 10_000;

/// An explicit Runge–Kutta method on the tree (see the module doc).
pub struct RungeKutta {
    tab: &'static Tableau,
    nat: Natural,
    /// The cut rows' multipliers and projection (`None` on a tree).
    loops: Option<Loops>,
    /// The multipliers of the reported state (one per layout row; tree rows 0).
    out_lambda: Vec<f64>,
    /// Scratch for the stage evaluation that gives the reported multipliers.
    k_out: Vec<f64>,
    /// The reported step (the driver's `step`; the largest internal step).
    h: f64,
    /// Tolerance and controller of the error-controlled methods.
    control: Option<(f64, Controller)>,
    /// The next internal step.
    h_next: f64,
    /// Internal time and state.
    t: f64,
    y: Vec<f64>,
    /// The state at the start of the last accepted step (dense output).
    y_old: Vec<f64>,
    h_last: f64,
    y_new: Vec<f64>,
    y_stage: Vec<f64>,
    /// The error estimate of the last attempt (for `dop853` its fifth-order estimate, then
    /// the combined one).
    err: Vec<f64>,
    /// `dop853`'s third-order error estimate (empty for the other methods).
    err3: Vec<f64>,
    /// Stage derivatives.
    k: Vec<Vec<f64>>,
    /// The stage derivatives of the continuous extension beyond the step's (three for
    /// `dop853`, none otherwise), made in the constructor, filled only for an output.
    k_extra: Vec<Vec<f64>>,
    /// `k[0]` holds `f(t, y)`.
    k0_valid: bool,
    /// The last stage of the accepted step is the derivative at its result (FSAL).
    fsal_pending: bool,
    // body-level buffers: the projected result of the last accepted step right after it,
    // scratch for the stage evaluations otherwise
    pose: Vec<Pose>,
    vel: Vec<Twist>,
    acc: Vec<Twist>,
    /// The reported state at `t_out`.
    out_pose: Vec<Pose>,
    out_vel: Vec<Twist>,
    t0: f64,
    t_out: f64,
    reported_steps: u64,
    active: Vec<bool>,
    // statistics
    steps: u64,
    rejected: u64,
    evaluations: u64,
    dense_outputs: u64,
    error_norm_max: f64,
    local_error_max: f64,
    step_min: f64,
    step_max: f64,
}

/// `y` (13 per body) into poses (Euler parameters normalized) and twists.
fn unpack(y: &[f64], pose: &mut [Pose], vel: &mut [Twist]) {
    for (b, (p, v)) in pose.iter_mut().zip(vel.iter_mut()).enumerate() {
        let s = &y[PER_BODY * b..PER_BODY * (b + 1)];
        *p = Pose::new(
            Vector3::new(s[0], s[1], s[2]),
            Quaternion::new(s[3], s[4], s[5], s[6]),
        );
        *v = Twist {
            v: Vector3::new(s[7], s[8], s[9]),
            w: Vector3::new(s[10], s[11], s[12]),
        };
    }
}

/// Poses and twists into `y`.
fn pack(pose: &[Pose], vel: &[Twist], y: &mut [f64]) {
    for (b, (p, v)) in pose.iter().zip(vel).enumerate() {
        let s = &mut y[PER_BODY * b..PER_BODY * (b + 1)];
        s[..3].copy_from_slice(p.r.as_slice());
        s[3..7].copy_from_slice(&[p.q.w, p.q.i, p.q.j, p.q.k]);
        s[7..10].copy_from_slice(v.v.as_slice());
        s[10..13].copy_from_slice(v.w.as_slice());
    }
}

/// The right-hand side at `(t, y)` into `out` (see the module doc), with the body-level
/// buffers. One tree solve, and `m + 1` more with `m` cut rows.
#[allow(clippy::too_many_arguments)]
fn rhs<S: System>(
    nat: &mut Natural,
    loops: &mut Option<Loops>,
    sys: &S,
    t: f64,
    y: &[f64],
    pose: &mut [Pose],
    vel: &mut [Twist],
    acc: &mut [Twist],
    out: &mut [f64],
) -> Result<(), StepError> {
    unpack(y, pose, vel);
    match loops {
        Some(l) => l.stage(nat, sys, t, pose, vel, acc)?,
        None => nat.tree_accelerations(sys, t, pose, vel, acc)?,
    }
    for b in 0..pose.len() {
        let o = &mut out[PER_BODY * b..PER_BODY * (b + 1)];
        let qd = quat_rate(&pose[b].q, &vel[b].w);
        o[..3].copy_from_slice(vel[b].v.as_slice());
        o[3..7].copy_from_slice(&[qd.w, qd.i, qd.j, qd.k]);
        o[7..10].copy_from_slice(acc[b].v.as_slice());
        o[10..13].copy_from_slice(acc[b].w.as_slice());
    }
    Ok(())
}

/// Put `(pose, vel)` at `t` back on the joints: the tree's, and the cut rows' with
/// `loops` ([`Loops::project`]).
fn project<S: System>(
    nat: &mut Natural,
    loops: &mut Option<Loops>,
    sys: &S,
    t: f64,
    pose: &mut [Pose],
    vel: &mut [Twist],
) -> Result<(), StepError> {
    match loops {
        Some(l) => l.project(nat, sys, t, pose, vel, true).map(|_| ()),
        None => {
            nat.tree_project(sys, pose, vel);
            Ok(())
        }
    }
}

/// `out = y + h Σ_j w_j k_j` (zero weights skipped).
fn combine(y: &[f64], k: &[Vec<f64>], w: &[f64], h: f64, out: &mut [f64]) {
    combine_increment(k, w, h, out);
    for (o, y) in out.iter_mut().zip(y) {
        *o += y;
    }
}

/// `out = h Σ_j w_j k_j` (zero weights skipped).
fn combine_increment(k: &[Vec<f64>], w: &[f64], h: f64, out: &mut [f64]) {
    for (m, o) in out.iter_mut().enumerate() {
        let mut acc = 0.0;
        for (j, wj) in w.iter().enumerate() {
            if *wj != 0.0 {
                acc += wj * k[j][m];
            }
        }
        *o = h * acc;
    }
}

impl RungeKutta {
    /// The method `tab` on `sys` with the reported step `h`, starting from `start`.
    /// `tolerance`: error control with that tolerance (the tableau must have an embedded
    /// estimate; `h` is then the first and the largest internal step); `None`: fixed steps
    /// of `h`. Rows outside the spanning tree (closed loops, drivers) enter by their
    /// index-1 multipliers ([`Loops`]); a lock that engages during the run is refused,
    /// naming its joint.
    pub fn new<S: System>(
        sys: &S,
        tab: &'static Tableau,
        h: f64,
        tolerance: Option<f64>,
        start: &State,
    ) -> Result<RungeKutta, StartError> {
        let layout = sys.layout();
        if let Some(r) = start.active.iter().position(|a| !a) {
            let j = &layout.joints[layout.row_joint[r]];
            return Err(StartError::Invalid(format!(
                "joint '{}' ({}) engages during the run: an impact, which the explicit Runge–Kutta methods do not model (they assume a smooth motion); use natural_partitioning or staggered for this scene",
                j.name, j.kind
            )));
        }
        let cut = Tree::new(layout).cut_rows.len();
        if cut > MAX_CUT_ROWS {
            return Err(StartError::Invalid(format!(
                "{cut} constraint rows lie outside the spanning tree (closed loops, drivers, distance and other non-tree joints; `mbdc check --topology` lists them): the explicit Runge–Kutta methods form their {cut} × {cut} matrix at every stage and take at most {MAX_CUT_ROWS}; use natural_partitioning for this scene"
            )));
        }
        let control = tab.error.control();
        if tolerance.is_some() && (control.is_none() || tab.dense == Dense::None) {
            return Err(StartError::Invalid(format!(
                "{} has no embedded error estimate or no dense output: it runs with a fixed step",
                tab.name
            )));
        }
        let mut nat = Natural::new(sys, h, None, 1e-12, start).map_err(|e| match e {
            StartError::Unsupported(_) => StartError::Unsupported(tab.name),
            e => e,
        })?;
        let nb = layout.bodies();
        let n = PER_BODY * nb;
        let mut pose = start.pose.clone();
        let mut vel = start.twist.clone();
        let scale = start.pose.iter().fold(1.0f64, |a, p| a.max(p.r.norm()));
        let mut loops = Loops::new(&nat, layout, scale);
        match &mut loops {
            Some(l) => l
                .project(&mut nat, sys, start.t, &mut pose, &mut vel, false)
                .map_err(|e| {
                    let at = match &e {
                        StepError::NoConvergence { row: Some(r), .. } => {
                            format!(" (worst at joint '{}')", layout.joints[layout.row_joint[*r]].name)
                        }
                        _ => String::new(),
                    };
                    StartError::Invalid(format!(
                        "the initial state cannot be put on the closed loops: {e}{at}; check that the bodies' initial positions close every loop (`mbdc run --assemble` moves them onto the joints)"
                    ))
                })
                .map(|_| ())?,
            None => nat.tree_project(sys, &mut pose, &mut vel),
        }
        let mut y = vec![0.0; n];
        pack(&pose, &vel, &mut y);
        let control = match (tolerance, control) {
            (Some(tol), Some(k)) => Some((tol, Controller::new(k))),
            _ => None,
        };
        let extra = match tab.dense {
            Dense::Dop853 => 3,
            Dense::None | Dense::Dopri5 => 0,
        };
        let err3 = match tab.error {
            ErrorEstimate::Dop853 { .. } => n,
            ErrorEstimate::None | ErrorEstimate::Embedded { .. } => 0,
        };
        let with_loops = loops.is_some();
        Ok(RungeKutta {
            tab,
            nat,
            loops,
            out_lambda: vec![0.0; layout.rows],
            k_out: vec![0.0; if with_loops { n } else { 0 }],
            h,
            control,
            h_next: h,
            t: start.t,
            y_old: y.clone(),
            h_last: 0.0,
            y_new: vec![0.0; n],
            y_stage: vec![0.0; n],
            err: vec![0.0; n],
            err3: vec![0.0; err3],
            k: vec![vec![0.0; n]; tab.stages()],
            k_extra: vec![vec![0.0; n]; extra],
            k0_valid: false,
            fsal_pending: false,
            out_pose: pose.clone(),
            out_vel: vel.clone(),
            pose,
            vel,
            acc: vec![Twist::default(); nb],
            y,
            t0: start.t,
            t_out: start.t,
            reported_steps: 0,
            active: start.active.clone(),
            steps: 0,
            rejected: 0,
            evaluations: 0,
            dense_outputs: 0,
            error_norm_max: 0.0,
            local_error_max: 0.0,
            step_min: f64::INFINITY,
            step_max: 0.0,
        })
    }

    /// The first stage `k[0] = f(t, y)`.
    fn first_stage<S: System>(&mut self, sys: &S) -> Result<(), StepError> {
        rhs(
            &mut self.nat,
            &mut self.loops,
            sys,
            self.t,
            &self.y,
            &mut self.pose,
            &mut self.vel,
            &mut self.acc,
            &mut self.k[0],
        )?;
        self.evaluations += 1;
        Ok(())
    }

    /// One attempt of size `hs` from `(t, y)` into `y_new` (and the error estimates into
    /// `err`, `err3` for an embedded method).
    fn attempt<S: System>(&mut self, sys: &S, hs: f64) -> Result<(), StepError> {
        let tab = self.tab;
        let s = tab.stages();
        if !self.k0_valid {
            if self.fsal_pending {
                self.k.swap(0, s - 1);
            } else {
                self.first_stage(sys)?;
            }
            self.k0_valid = true;
            self.fsal_pending = false;
        }
        // the stages the result and the error estimates use (not a FSAL stage evaluated on
        // acceptance)
        let used = tab.step_stages();
        for i in 1..used {
            let row = tab.a[i];
            for (m, ys) in self.y_stage.iter_mut().enumerate() {
                let mut acc = 0.0;
                for (j, a) in row.iter().enumerate() {
                    if *a != 0.0 {
                        acc += a * self.k[j][m];
                    }
                }
                *ys = self.y[m] + hs * acc;
            }
            let (_, tail) = self.k.split_at_mut(i);
            rhs(
                &mut self.nat,
                &mut self.loops,
                sys,
                self.t + tab.c[i] * hs,
                &self.y_stage,
                &mut self.pose,
                &mut self.vel,
                &mut self.acc,
                &mut tail[0],
            )?;
            self.evaluations += 1;
        }
        if tab.fsal == Fsal::InStep {
            // the last stage is the result
            self.y_new.copy_from_slice(&self.y_stage);
        } else {
            combine(
                &self.y,
                &self.k[..used],
                &tab.b[..used],
                hs,
                &mut self.y_new,
            );
        }
        match tab.error {
            ErrorEstimate::None => {}
            ErrorEstimate::Embedded { e, .. } => {
                combine_increment(&self.k[..used], &e[..used], hs, &mut self.err)
            }
            ErrorEstimate::Dop853 { e5, e3, .. } => {
                combine_increment(&self.k[..used], &e5[..used], hs, &mut self.err);
                combine_increment(&self.k[..used], &e3[..used], hs, &mut self.err3);
            }
        }
        Ok(())
    }

    /// The error norm of the last attempt with tolerance `tol` (`≤ 1` accepts it); for
    /// `dop853` it first combines the two estimates into `err`.
    fn error_norm(&mut self, tol: f64) -> f64 {
        if let ErrorEstimate::Dop853 { .. } = self.tab.error {
            controller::dop853_combine(&mut self.err, &self.err3, &self.y, &self.y_new, tol);
        }
        controller::error_norm(&self.err, &self.y, &self.y_new, tol)
    }

    /// Take the attempt of size `hs`: `y ← y_new` projected onto the manifold (for a FSAL
    /// stage evaluated on acceptance, the derivative at the unprojected result first).
    fn accept<S: System>(&mut self, sys: &S, hs: f64) -> Result<(), StepError> {
        let s = self.tab.stages();
        if self.tab.fsal == Fsal::OnAccept {
            rhs(
                &mut self.nat,
                &mut self.loops,
                sys,
                self.t + hs,
                &self.y_new,
                &mut self.pose,
                &mut self.vel,
                &mut self.acc,
                &mut self.k[s - 1],
            )?;
            self.evaluations += 1;
        }
        std::mem::swap(&mut self.y_old, &mut self.y);
        std::mem::swap(&mut self.y, &mut self.y_new);
        self.t += hs;
        unpack(&self.y, &mut self.pose, &mut self.vel);
        project(
            &mut self.nat,
            &mut self.loops,
            sys,
            self.t,
            &mut self.pose,
            &mut self.vel,
        )?;
        pack(&self.pose, &self.vel, &mut self.y);
        self.h_last = hs;
        self.k0_valid = false;
        self.fsal_pending = self.tab.fsal != Fsal::No;
        self.steps += 1;
        self.step_min = self.step_min.min(hs);
        self.step_max = self.step_max.max(hs);
        Ok(())
    }

    /// The reported state from `y` (already projected) or, at `θ` inside the last step,
    /// from the continuous extension, projected. `dop853`'s extension evaluates its three
    /// extra stages here, from the step's start `y_old`.
    fn output<S: System>(&mut self, sys: &S, theta: Option<f64>) -> Result<(), StepError> {
        self.output_state(sys, theta)?;
        if self.loops.is_none() {
            return Ok(());
        }
        // the reported multipliers: a stage evaluation at the reported state (for a method
        // without FSAL at a step's end, the next step's first stage)
        if theta.is_none() && self.tab.fsal == Fsal::No {
            self.first_stage(sys)?;
            self.k0_valid = true;
        } else {
            let t = match theta {
                Some(th) => self.t - self.h_last + th * self.h_last,
                None => self.t,
            };
            pack(&self.out_pose, &self.out_vel, &mut self.y_stage);
            rhs(
                &mut self.nat,
                &mut self.loops,
                sys,
                t,
                &self.y_stage,
                &mut self.pose,
                &mut self.vel,
                &mut self.acc,
                &mut self.k_out,
            )?;
            self.evaluations += 1;
        }
        if let (Some(l), nat) = (&self.loops, &self.nat) {
            l.multipliers(nat, &mut self.out_lambda);
        }
        Ok(())
    }

    /// The reported pose and twist of [`RungeKutta::output`].
    fn output_state<S: System>(&mut self, sys: &S, theta: Option<f64>) -> Result<(), StepError> {
        let Some(th) = theta else {
            self.out_pose.copy_from_slice(&self.pose);
            self.out_vel.copy_from_slice(&self.vel);
            return Ok(());
        };
        let h = self.h_last;
        match self.tab.dense {
            Dense::Dopri5 => dense::dopri5(&self.y_old, &self.y, &self.k, h, th, &mut self.y_stage),
            Dense::Dop853 => {
                let t_old = self.t - h;
                for r in 0..tableau::DOP853_EXTRA_C.len() {
                    let (done, rest) = self.k_extra.split_at_mut(r);
                    dense::dop853_extra_state(&self.y_old, &self.k, done, h, r, &mut self.y_stage);
                    rhs(
                        &mut self.nat,
                        &mut self.loops,
                        sys,
                        t_old + tableau::DOP853_EXTRA_C[r] * h,
                        &self.y_stage,
                        &mut self.pose,
                        &mut self.vel,
                        &mut self.acc,
                        &mut rest[0],
                    )?;
                    self.evaluations += 1;
                }
                dense::dop853(
                    &self.y_old,
                    &self.y,
                    &self.k,
                    &self.k_extra,
                    h,
                    th,
                    &mut self.y_stage,
                );
            }
            // the constructor refuses error control without a continuous extension, and a
            // fixed step ends on the output time
            Dense::None => unreachable!("an output inside a step of a method without dense output"),
        }
        self.dense_outputs += 1;
        unpack(&self.y_stage, &mut self.out_pose, &mut self.out_vel);
        let t = self.t - h + th * h;
        project(
            &mut self.nat,
            &mut self.loops,
            sys,
            t,
            &mut self.out_pose,
            &mut self.out_vel,
        )
    }

    /// What stopped the step-size control, in words (`shrank`: the step went to round-off;
    /// otherwise too many internal steps for one output step).
    fn control_failure(&self, shrank: bool) -> &'static str {
        match (self.tab.name, shrank) {
            ("dop853", false) => "the step-size control of dop853 (more than 10 000 internal steps for one output step: the motion is too fast or not smooth for this tolerance)",
            ("dop853", true) => "the step-size control of dop853 (the step shrank to round-off: the motion is too fast or not smooth for this tolerance)",
            (_, false) => "the step-size control of dopri5 (more than 10 000 internal steps for one output step: the motion is too fast or not smooth for this tolerance)",
            (_, true) => "the step-size control of dopri5 (the step shrank to round-off: the motion is too fast or not smooth for this tolerance)",
        }
    }

    /// The error-controlled steps up to `target`, with the output there.
    fn controlled<S: System>(&mut self, sys: &S, target: f64) -> Result<u32, StepError> {
        let eps = 1e-12 * self.h;
        let mut attempts: u64 = 0;
        loop {
            if attempts >= MAX_ATTEMPTS {
                return Err(StepError::NoConvergence {
                    what: self.control_failure(false),
                    iterations: attempts.min(u32::MAX as u64) as u32,
                    residual: self.error_norm_max,
                    row: None,
                });
            }
            let hs = self.h_next.min(self.h);
            self.attempt(sys, hs)?;
            let tol = self.control.as_ref().expect("controlled method").0;
            let norm = self.error_norm(tol);
            let (ok, next) = self
                .control
                .as_mut()
                .expect("controlled method")
                .1
                .next(hs, norm);
            attempts += 1;
            if ok {
                self.error_norm_max = self.error_norm_max.max(norm);
                let local = self.err.iter().fold(0.0f64, |a, e| a.max(e.abs()));
                self.local_error_max = self.local_error_max.max(local);
                self.h_next = next;
                self.accept(sys, hs)?;
                if self.t >= target - eps {
                    let theta = (target - (self.t - hs)) / hs;
                    self.output(sys, (self.t > target + eps).then_some(theta))?;
                    return Ok(attempts.min(u32::MAX as u64) as u32);
                }
            } else {
                self.rejected += 1;
                self.h_next = next;
                let floor = 1e-14 * self.t.abs().max(self.h);
                if next.partial_cmp(&floor) != Some(std::cmp::Ordering::Greater) {
                    return Err(StepError::NoConvergence {
                        what: self.control_failure(true),
                        iterations: attempts.min(u32::MAX as u64) as u32,
                        residual: norm,
                        row: None,
                    });
                }
            }
        }
    }
}

impl<S: System> Integrator<S> for RungeKutta {
    fn name(&self) -> &'static str {
        self.tab.name
    }

    fn time(&self) -> f64 {
        self.t_out
    }

    fn step_size(&self) -> f64 {
        self.h
    }

    fn step(&mut self, sys: &S) -> Result<StepInfo, StepError> {
        let target = self.t0 + (self.reported_steps + 1) as f64 * self.h;
        let iterations = if self.control.is_some() {
            self.controlled(sys, target)?
        } else {
            let hs = target - self.t;
            self.attempt(sys, hs)?;
            self.accept(sys, hs)?;
            self.output(sys, None)?;
            0
        };
        self.reported_steps += 1;
        self.t_out = target;
        Ok(StepInfo { iterations })
    }

    fn state(&self, _sys: &S, out: &mut State) {
        out.t = self.t_out;
        out.pose.copy_from_slice(&self.out_pose);
        out.twist.copy_from_slice(&self.out_vel);
        out.lambda.copy_from_slice(&self.out_lambda);
    }

    fn active(&self) -> &[bool] {
        &self.active
    }

    fn stats(&self) -> Vec<(&'static str, f64)> {
        let mut v = vec![
            ("order", self.tab.order as f64),
            ("stages", self.tab.stages() as f64),
            ("internal_steps", self.steps as f64),
            ("rhs_evaluations", self.evaluations as f64),
        ];
        if let Some((tol, _)) = &self.control {
            v.push(("tolerance", *tol));
            v.push(("rejected_steps", self.rejected as f64));
            v.push(("dense_outputs", self.dense_outputs as f64));
            v.push(("error_estimate_max", self.error_norm_max * tol));
            v.push(("local_error_max", self.local_error_max));
            v.push(("step_min", self.step_min));
            v.push(("step_max", self.step_max));
        }
        if let Some(l) = &self.loops {
            v.push(("loop_drift_max", l.drift_max));
            v.push(("loop_projection_iterations", l.projection_iterations as f64));
            v.push(("cut_rows_void", l.void_start.unwrap_or(0) as f64));
            v.push(("cut_rows_void_max", l.void_max as f64));
        }
        v
    }

    fn persist(&mut self, v: &mut dyn StateVisitor) -> bool {
        // the sequence (state, the last step for dense output, the stage derivatives and
        // which are valid), the controller, the reported state and the time bookkeeping;
        // the tree's nodes are remade at every evaluation
        persist::f64(v, "h", &mut self.h);
        persist::f64(v, "h_next", &mut self.h_next);
        persist::f64(v, "t", &mut self.t);
        v.f64s("y", &mut self.y);
        v.f64s("y_old", &mut self.y_old);
        persist::f64(v, "h_last", &mut self.h_last);
        for k in self.k.iter_mut() {
            v.f64s("k", k);
        }
        persist::bool(v, "k0_valid", &mut self.k0_valid);
        persist::bool(v, "fsal_pending", &mut self.fsal_pending);
        if let Some((tol, c)) = &mut self.control {
            persist::f64(v, "tolerance", tol);
            c.persist(v);
        }
        persist::poses(v, "pose", &mut self.pose);
        persist::twists(v, "vel", &mut self.vel);
        persist::poses(v, "out_pose", &mut self.out_pose);
        persist::twists(v, "out_vel", &mut self.out_vel);
        persist::f64(v, "t0", &mut self.t0);
        persist::f64(v, "t_out", &mut self.t_out);
        persist::u64(v, "reported_steps", &mut self.reported_steps);
        v.bools("active", &mut self.active);
        persist::u64(v, "steps", &mut self.steps);
        persist::u64(v, "rejected", &mut self.rejected);
        persist::u64(v, "evaluations", &mut self.evaluations);
        persist::u64(v, "dense_outputs", &mut self.dense_outputs);
        persist::f64(v, "error_norm_max", &mut self.error_norm_max);
        persist::f64(v, "local_error_max", &mut self.local_error_max);
        persist::f64(v, "step_min", &mut self.step_min);
        persist::f64(v, "step_max", &mut self.step_max);
        if let Some(l) = &mut self.loops {
            v.f64s("out_lambda", &mut self.out_lambda);
            l.persist(v);
        }
        true
    }
}

#[cfg(test)]
mod tests;
