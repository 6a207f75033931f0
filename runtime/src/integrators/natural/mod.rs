//! Natural partitioning (notes C §1, Chiou–Park–Farhat): the null space of the spanning
//! tree's constraint Jacobian built joint by joint, the reduced equations solved through
//! the Schur complement of the arrowhead system, closed loops by cut joints with the
//! staggered stabilization, all on the two-stage staggered coordinate integrator.
//!
//! ## What is solved
//!
//! The layout's tree-eligible joints form a spanning forest ([`tree`], the same as
//! `mbdc check --topology` prints); every other row (cut joints closing loops, drivers,
//! distance, curve, rolling, point-velocity rows, locks) is a *cut row*, `B_c`. With the
//! tree null space `u̇ = A q̇` ([`tree_joints`](crate::kernels::tree_joints): per joint `u_c = X u_p + S q̇`, the dependent
//! translational blocks `B^d = ∓I` inverted analytically), the equations of motion
//! `M ü + B_tᵀλ_t + B_cᵀλ_c = F` reduce to (notes C eq. 3.4.6, with `ü = A q̈ + Ȧq̇`)
//!
//! ```text
//! AᵀMA q̈ = Aᵀ(F − M Ȧq̇ − B_cᵀ λ_c)
//! ```
//!
//! and the tree multipliers `λ_t` never appear. `AᵀMA` is never formed: [`reduced`] solves
//! it by the tree-exact `O(N)` block elimination (leaf → root, root → leaf), which is the
//! preconditioner that makes the Schur-complement PCG of the paper converge in one
//! iteration on a tree (docs/methods.md has the iteration counts of the alternatives).
//!
//! ## Cut rows: staggered stabilization on the reduced system
//!
//! `λ_c` comes from the exact-integral form of the staggered stabilization used by the
//! `staggered` method (see [`super::staggered`]): at each step, Newton iterations on
//! `λ_c` until the positions after the coordinate update satisfy
//! `Φ_c(X(τ + h)) = E(λ_c − λ_c⁰)`. Its matrix is the reduced counterpart of the staggered
//! `εI + h²BM⁻¹Bᵀ` (notes C §1.6 RECON):
//!
//! ```text
//! S = E + h² (B_c A)(AᵀMA)⁻¹(B_c A)ᵀ,
//! ```
//!
//! dense in general (`(AᵀMA)⁻¹` couples everything in a tree) but cheap to apply: one
//! tree-exact solve per product. It is solved by PCG, Jacobi-preconditioned; that is where
//! conjugate gradients are needed once the tree part is solved exactly: the loops couple
//! branches that the tree solve treats independently. `E` follows the staggered default
//! rule `E_r = 10⁻⁹ h² K_rr` (`K = B_c M⁻¹ B_cᵀ` at the start) or the user's ε.
//!
//! ## Time integration and drift
//!
//! One leapfrog sequence, as the `staggered` method's default (positions at τ, velocities
//! at τ − h/2), with the gyroscopic term by the implicit midpoint rule. The paper's two
//! sequences offset by h/2 exchanging ω let a heavy top on its tip fall (their difference
//! grows at the rate the top would fall without spin) and decorrelate on chaotic scenes;
//! see [`super::staggered`]. Each step:
//!
//! 1. one leaf → root sweep at τ: per body the joint blocks, the velocity-product term `κ`
//!    (`Ȧq̇ = Σ` of the transported `κ`) and the gyroscopic term `ω̄ × Jω̄` at an estimate of
//!    the synchronous velocity `ū = (u(τ − h/2) + u(τ + h/2))/2` (first the extrapolation
//!    `(3u(τ − h/2) − u(τ − 3h/2))/2`), which enter the tree right-hand side
//!    `Aᵀ(F − ω̄ × Jω̄ − M Ȧq̇)`, fused with the factorization of `AᵀMA` at τ and the
//!    backward half of the solve (`Ȧq̇` articulated-body style: a child hands its parent
//!    `z − Pκ`, [`reduced::Solver::backward_bias`], so no root → leaf pass forms `Ȧq̇`);
//! 2. the kick: the accelerations of the tree solve (and the cut-row response), applied to
//!    translation explicitly and to rotation by the midpoint rule per body
//!    (`midpoint_kick`, a 3×3 Newton iteration, no iteration when the estimate is
//!    consistent); the drift of the positions to τ + h (Euler parameters by the Cayley
//!    update);
//! 3. the tree correction of SHAKE: the new positions projected onto the tree joints by
//!    the M-orthogonal correction along `M⁻¹B_tᵀ(τ)` (one backward and one forward sweep
//!    with the factorization at τ), the velocities `u(τ + h/2)` corrected by the same
//!    displacement over h, then a last geometric projection root → leaf
//!    ([`tree_joints::project`](crate::kernels::tree_joints::project)) that takes the remaining `O(h⁴)` violation to round-off;
//! 4. the estimate `ū` updated from the result; steps 2–3 (with the backward half of the
//!    solve for the new right-hand side, the factorization kept) repeat until the
//!    gyroscopic impulse of the kick changes by less than 1e-14 relative, a fixed-point
//!    iteration that converges at the rate `h|ω|` times the part of the gyroscopic torque
//!    that the joints carry (2–4 iterations on the double pendulum and the spatial chain,
//!    7 on the heavy top at h·ω = 0.05, one on planar scenes and on free bodies, whose
//!    kick is exact whatever the estimate).
//!
//! The converged step is the implicit-midpoint gyroscopic kick of `staggered` with the tree
//! constraint forces that put the positions back on the joints: the two methods agree to
//! round-off on trees, a free body conserves its energy and |L| to round-off, and the
//! heavy top precesses as theory says. The tree constraints hold to round-off at every
//! output (`< 1e-10` over 10 s is tested) at `O(N)` cost per step. The output velocity at
//! τ is a half kick from `u(τ − h/2)` with the last kick's acceleration (rotation by the
//! same midpoint rule), and the start takes `ω(t₀ − h/2)` by the midpoint rule run back.
//!
//! ## Parallelism
//!
//! Joint blocks, forces and coordinate updates are per body; the recursions run sibling
//! branches in parallel ([`tree::Schedule`]), with rayon, when a level holds at least
//! [`tree::PAR_MIN`] bodies, and so do the per-body passes (the copy of the result with
//! the gyroscopic update, the extrapolation of `ū`) in chunks. A step without cut rows and
//! with one gyroscopic iteration makes four tree sweeps (leaf → root: forces, `κ`,
//! factorization and backward solve; root → leaf: forward solve, kick, drift and
//! geometric correction; leaf → root and root → leaf: the M-orthogonal correction) and
//! two per-body passes, over one [`reduced::Node`] per body.

mod loops;
pub mod reduced;
pub mod tree;

pub(crate) use loops::Loops;

use nalgebra::Vector3;

use super::common::{self, gyro, Index1};
use super::{Integrator, StartError, State, StepError, StepInfo};
use crate::contract::math::cayley_update;
use crate::contract::persist::{self, StateVisitor};
use crate::contract::system::{
    ConstraintEval, Layout, Need, Pose, RowJac, RowKind, System, Twist, Wrench,
};
use crate::kernels::tree_joints::{self, TreeJointKin};
use reduced::{free_kin, pcg, Factor, Node, PcgOps, Solver};
use tree::{Tree, NONE};

/// The leapfrog sequence (body order): positions at τ, velocities at τ − h/2.
#[derive(Clone, Debug)]
struct Seq {
    pose: Vec<Pose>,
    vel: Vec<Twist>,
}

/// Newton iterations per step before giving up.
const MAX_NEWTON: u32 = 25;

/// Iterations of the gyroscopic midpoint kick on `ω̄` per step (see the module doc); the
/// step is taken with the last iterate if they do not converge (counted in the stats).
const MAX_GYRO: u32 = 30;

/// The natural-partitioning integrator (see the module doc).
pub struct Natural {
    h: f64,
    tree: Tree,
    nodes: Vec<Node>,
    /// The body-level response to the cut forces, `−A(AᵀMA)⁻¹AᵀB_cᵀλ_c` per position
    /// (empty without cut rows).
    resp: Vec<Twist>,
    /// Accumulator of a response increment per position (empty without cut rows).
    dresp: Vec<Twist>,
    /// Positions at τ, velocities at τ − h/2.
    seq: Seq,
    /// The velocities at τ − 3h/2 (for the synchronous output velocity).
    vel_prev: Vec<Twist>,
    /// The step's estimate of the synchronous velocity `ū = (u(τ − h/2) + u(τ + h/2))/2`
    /// (gyroscopic term and `Ȧq̇`), per body.
    vs: Vec<Twist>,
    /// The tree correction of ω in the last iterate (`δω` of the SHAKE correction), per
    /// body: the midpoint kick evaluates `ω̄` with it.
    gc: Vec<Vector3<f64>>,
    trial: Seq,
    /// Keep `P` at every position in the step's factorization (the last step needed more
    /// than one gyroscopic iteration).
    keep_p: bool,
    tau: f64,
    t0: f64,
    half_steps: u64,
    // cut rows
    /// Regularization per cut row.
    e: Vec<f64>,
    /// The regularization of the current attempt.
    e_eff: Vec<f64>,
    lambda_guess: Vec<f64>,
    regularized_steps: u64,
    epsilon: f64,
    lambda: Vec<f64>,
    lambda_prev: Vec<f64>,
    lambda0: Vec<f64>,
    tau_lambda: f64,
    active: Vec<bool>,
    next_active: Vec<bool>,
    ce: ConstraintEval,
    ce_trial: ConstraintEval,
    // buffers
    applied: Vec<Wrench>,
    res: Vec<f64>,
    dl: Vec<f64>,
    diag: Vec<f64>,
    work: [Vec<f64>; 4],
    tol: f64,
    rtol: f64,
    /// Most PCG iterations per cut-row solve (`None`: `max(4 × rows, 50)`).
    pcg_limit: Option<u32>,

    // statistics
    steps: u64,
    gyro_total: u64,
    gyro_max: u32,
    gyro_unconverged: u64,
    lints: u64,
    newton_total: u64,
    newton_max: u32,
    pcg_total: u64,
    pcg_solves: u64,
    pcg_max: u32,
}

/// The cut-row operator `S = E + h² G (AᵀMA)⁻¹ Gᵀ` for [`pcg`], with its body-level
/// response accumulated in `dresp` (`Σ α A(AᵀMA)⁻¹AᵀB_cᵀ p`, per position).
struct CutOps<'a, 't> {
    solver: Solver<'t>,
    nodes: &'a mut [Node],
    dresp: &'a mut [Twist],
    layout: &'a Layout,
    rows: &'a [usize],
    jac: &'a [RowJac],
    pos: &'a [usize],
    active: &'a [bool],
    e: &'a [f64],
    diag: &'a [f64],
    h2: f64,
}

/// The null-space blocks of tree joint `joint` (layout index) at the poses `parent`
/// (identity for the ground) and `child`, from the system's kernel and geometry
/// ([`System::tree_joint`]) and the tree-joint kernels. `false` when the system does not
/// describe the joint. Does not allocate.
#[inline]
fn joint_blocks<S: System>(
    sys: &S,
    joint: usize,
    child_is_b: bool,
    parent: &Pose,
    child: &Pose,
    out: &mut TreeJointKin,
) -> bool {
    match sys.tree_joint(joint) {
        Some((kernel, g)) => {
            tree_joints::tree_joint(kernel, g, child_is_b, parent, child, out);
            true
        }
        None => false,
    }
}

/// Move `child` (the parent's pose fixed) back onto the position constraints of tree joint
/// `joint` ([`tree_joints::project`]). `false` when the system does not describe the joint.
#[inline]
fn project_child<S: System>(
    sys: &S,
    joint: usize,
    child_is_b: bool,
    parent: &Pose,
    child: &mut Pose,
) -> bool {
    match sys.tree_joint(joint) {
        Some((kernel, g)) => {
            tree_joints::project(kernel, g, child_is_b, parent, child);
            true
        }
        None => false,
    }
}

#[inline]
fn dot6(r: &[f64; 6], t: &Twist) -> f64 {
    r[0] * t.v.x + r[1] * t.v.y + r[2] * t.v.z + r[3] * t.w.x + r[4] * t.w.y + r[5] * t.w.z
}

#[inline]
fn add6(w: &mut Wrench, r: &[f64; 6], l: f64) {
    w.f += Vector3::new(r[0], r[1], r[2]) * l;
    w.t += Vector3::new(r[3], r[4], r[5]) * l;
}

/// `A (AᵀMA)⁻¹ Aᵀ B_cᵀ v` into `Node::acc` (one tree solve).
#[allow(clippy::too_many_arguments)]
fn cut_response(
    solver: &Solver<'_>,
    nodes: &mut [Node],
    layout: &Layout,
    rows: &[usize],
    jac: &[RowJac],
    pos: &[usize],
    active: &[bool],
    v: &[f64],
) {
    solver
        .tree
        .sched
        .nodes(nodes, &|_, n: &mut Node| n.f = Wrench::default());
    for (i, &r) in rows.iter().enumerate() {
        if !active[r] || v[i] == 0.0 {
            continue;
        }
        let (a, b) = layout.row_bodies(r);
        if let Some(a) = a {
            add6(&mut nodes[pos[a]].f, &jac[r].a, v[i]);
        }
        if let Some(b) = b {
            add6(&mut nodes[pos[b]].f, &jac[r].b, v[i]);
        }
    }
    solver.solve(nodes, true, false);
}

/// `(B_c u)_i` for per-position twists `u` (`u_of(p)`).
#[inline]
fn cut_row_times(
    layout: &Layout,
    r: usize,
    jac: &[RowJac],
    pos: &[usize],
    u_of: impl Fn(usize) -> Twist,
) -> f64 {
    let (a, b) = layout.row_bodies(r);
    a.map_or(0.0, |a| dot6(&jac[r].a, &u_of(pos[a])))
        + b.map_or(0.0, |b| dot6(&jac[r].b, &u_of(pos[b])))
}

impl PcgOps for CutOps<'_, '_> {
    fn apply(&mut self, p: &[f64], out: &mut [f64]) {
        cut_response(
            &self.solver,
            self.nodes,
            self.layout,
            self.rows,
            self.jac,
            self.pos,
            self.active,
            p,
        );
        for (i, &r) in self.rows.iter().enumerate() {
            out[i] = if self.active[r] {
                let nodes = &*self.nodes;
                self.e[i] * p[i]
                    + self.h2 * cut_row_times(self.layout, r, self.jac, self.pos, |q| nodes[q].acc)
            } else {
                p[i]
            };
        }
    }

    fn precond(&mut self, r: &[f64], z: &mut [f64]) {
        for i in 0..r.len() {
            z[i] = r[i] / self.diag[i];
        }
    }

    fn step(&mut self, alpha: f64) {
        for (d, n) in self.dresp.iter_mut().zip(self.nodes.iter()) {
            d.v += n.acc.v * alpha;
            d.w += n.acc.w * alpha;
        }
    }
}

impl Natural {
    /// The method for `sys` with step `h`, starting from `start`. `epsilon`: ε for the cut
    /// rows (`None`: the default rule); `tolerance`: relative tolerance of the cut-row PCG.
    pub fn new<S: System>(
        sys: &S,
        h: f64,
        epsilon: Option<f64>,
        tolerance: f64,
        start: &State,
    ) -> Result<Natural, StartError> {
        let layout = sys.layout();
        let nb = layout.bodies();
        let tree = Tree::new(layout);
        // The system must describe every tree joint.
        let mut probe = TreeJointKin::default();
        for l in &tree.links {
            if l.joint != NONE
                && !joint_blocks(
                    sys,
                    l.joint,
                    l.child_is_b,
                    &Pose::default(),
                    &Pose::default(),
                    &mut probe,
                )
            {
                return Err(StartError::Unsupported("natural_partitioning"));
            }
        }
        let mut nodes: Vec<Node> = tree
            .links
            .iter()
            .map(|l| {
                let mut n = Node::new(&layout.mass[l.body]);
                if l.joint == NONE {
                    n.kin = free_kin();
                }
                n
            })
            .collect();
        let m = tree.cut_rows.len();
        let mut s = Natural {
            h,
            nodes: Vec::new(),
            resp: vec![Twist::default(); if m > 0 { nb } else { 0 }],
            dresp: vec![Twist::default(); if m > 0 { nb } else { 0 }],
            seq: Seq {
                pose: start.pose.clone(),
                vel: start.twist.clone(),
            },
            vel_prev: start.twist.clone(),
            vs: start.twist.clone(),
            gc: vec![Vector3::zeros(); nb],
            trial: Seq {
                pose: start.pose.clone(),
                vel: start.twist.clone(),
            },
            keep_p: false,
            tau: start.t,
            t0: start.t,
            half_steps: 0,
            e: vec![0.0; m],
            e_eff: vec![0.0; m],
            lambda_guess: vec![0.0; m],
            regularized_steps: 0,
            epsilon: 0.0,
            lambda: vec![0.0; m],
            lambda_prev: vec![0.0; m],
            lambda0: vec![0.0; m],
            tau_lambda: start.t,
            active: start.active.clone(),
            next_active: start.active.clone(),
            // only evaluated when there are cut rows
            ce: ConstraintEval::new(if m > 0 { layout.rows } else { 0 }),
            ce_trial: ConstraintEval::new(if m > 0 { layout.rows } else { 0 }),
            applied: vec![Wrench::default(); nb],
            res: vec![0.0; m],
            dl: vec![0.0; m],
            diag: vec![1.0; m],
            work: [vec![0.0; m], vec![0.0; m], vec![0.0; m], vec![0.0; m]],
            tol: 0.0,
            rtol: tolerance,
            pcg_limit: None,

            steps: 0,
            gyro_total: 0,
            gyro_max: 0,
            gyro_unconverged: 0,
            lints: 0,
            newton_total: 0,
            newton_max: 0,
            pcg_total: 0,
            pcg_solves: 0,
            pcg_max: 0,
            tree,
        };
        std::mem::swap(&mut s.nodes, &mut nodes);
        let scale = start.pose.iter().fold(1.0f64, |a, p| a.max(p.r.norm()));
        s.tol = 1e-13 * scale;

        // Consistent start: project the initial state onto the tree.
        let t0 = start.t;
        let mut pose0 = start.pose.clone();
        let mut vel0 = start.twist.clone();
        s.project_positions(sys, &mut pose0);
        s.kinematics(sys, &pose0);
        s.project_velocities(&pose0, &mut vel0);

        // Accelerations at t0 with the consistent cut multipliers.
        s.free_accelerations(sys, t0, &pose0, &vel0, &vel0)?;
        let has_cut = s.tree.cut_rows.iter().any(|&r| s.active[r]);
        if !s.tree.cut_rows.is_empty() {
            sys.constraints(t0, &pose0, &vel0, Need::ALL, &mut s.ce);
            let mut q0 = vec![Wrench::default(); nb];
            let mut ap = vec![Wrench::default(); nb];
            sys.applied(t0, &pose0, &vel0, &mut ap);
            common::qbar(layout, &ap, &vel0, &mut q0);
            let mut lam_all = vec![0.0; layout.rows];
            if has_cut {
                Index1::new(layout)?.solve(layout, &s.ce, &q0, &s.active, &mut lam_all)?;
            }
            for (i, &r) in s.tree.cut_rows.iter().enumerate() {
                s.lambda[i] = if s.active[r] { lam_all[r] } else { 0.0 };
            }
            s.lambda0.copy_from_slice(&s.lambda);
            s.lambda_prev.copy_from_slice(&s.lambda);
            // E per row (staggered default rule) from K = B_c M⁻¹ B_cᵀ at the start.
            let rho = 1e-9;
            let kd: Vec<f64> = s
                .tree
                .cut_rows
                .iter()
                .map(|&r| k_diag(layout, &s.ce.jac[r], r))
                .collect();
            let kmax = kd.iter().copied().fold(0.0, f64::max);
            s.e = match epsilon {
                Some(eps) => s
                    .tree
                    .cut_rows
                    .iter()
                    .map(|&r| {
                        if layout.row_kind[r] == RowKind::Holonomic {
                            eps
                        } else {
                            eps * h
                        }
                    })
                    .collect(),
                None => {
                    let floor = rho * h * h * kmax * f64::EPSILON;
                    kd.iter()
                        .map(|k| (rho * h * h * k).max(floor).max(f64::MIN_POSITIVE))
                        .collect()
                }
            };
            s.epsilon = epsilon.unwrap_or_else(|| s.e.iter().copied().fold(0.0, f64::max));
            // response to λ⁰
            s.response(layout, &s.lambda.clone());
            for (r, n) in s.resp.iter_mut().zip(s.nodes.iter()) {
                *r = Twist {
                    v: -n.acc.v,
                    w: -n.acc.w,
                };
            }
        }
        // The sequence: positions at t0, velocities at t0 − h/2: translation by an explicit
        // half step back, rotation by the midpoint rule run back over h/2 with the torque
        // at t0 (so the kicks conserve the initial ωᵀJω of a free body, not that of an
        // explicit half step's ω). The synchronous estimate of the first step is the
        // velocity at t0.
        for i in 0..nb {
            let p = s.tree.pos[i];
            let n = &s.nodes[p];
            let r = s.resp.get(p).copied().unwrap_or_default();
            let a = Twist {
                v: n.a0.v + r.v,
                w: n.a0.w + r.w,
            };
            let j = &layout.mass[i].j;
            s.seq.vel[i] = Twist {
                v: vel0[i].v - a.v * (h / 2.0),
                w: midpoint_kick(j, -h / 2.0, &vel0[i].w, &a.w, &vel0[i].w, &Vector3::zeros()),
            };
        }
        s.vel_prev.copy_from_slice(&vel0);
        s.seq.pose.copy_from_slice(&pose0);
        s.vs.copy_from_slice(&vel0);
        Ok(s)
    }

    /// Caps the PCG iterations of each cut-row solve at `limit` (`None`: the default rule,
    /// `max(4 × cut rows, 50)`). A solve that stops there short of its tolerance ends the
    /// step with [`StepError::NoConvergence`] unless its residual is already below 1e-3.
    pub fn with_pcg_limit(mut self, limit: Option<u32>) -> Natural {
        self.pcg_limit = limit;
        self
    }

    /// The ε in use for the cut rows (the largest per-row value with the default rule).
    pub fn epsilon(&self) -> f64 {
        self.epsilon
    }

    /// The tree the method walks.
    pub fn tree(&self) -> &Tree {
        &self.tree
    }

    /// PCG on `AᵀMA x = b` at the current configuration, for a random right-hand side
    /// `b` (seeded), with preconditioner `pc`, relative tolerance `rtol`: the iteration
    /// counts behind the preconditioner choice (docs/methods.md). Allocates.
    pub fn measure_pcg<S: System>(
        &mut self,
        sys: &S,
        pc: reduced::Precond,
        rtol: f64,
        seed: u64,
    ) -> reduced::PcgStats {
        // the blocks at the current positions (the next step redoes them and the
        // factorization this overwrites)
        let pose = std::mem::take(&mut self.seq.pose);
        self.kinematics(sys, &pose);
        self.seq.pose = pose;
        let nc = self.tree.ncoord;
        let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let b: Vec<f64> = (0..nc)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        let mut x = vec![0.0; nc];
        let solver = Solver { tree: &self.tree };
        let max_iter = (10 * nc).max(100) as u32;
        // the operator overwrites the body forces of the next step: keep them
        let f: Vec<Wrench> = self.nodes.iter().map(|n| n.f).collect();
        let st = solver.pcg_reduced(&mut self.nodes, pc, &b, &mut x, rtol, max_iter);
        for (n, f) in self.nodes.iter_mut().zip(f) {
            n.f = f;
        }
        st
    }

    /// The body accelerations `ü = A q̈ + Ȧq̇` of the tree's reduced equations at
    /// `(t, pose, vel)` into `out` (body order): applied forces, gyroscopic term and
    /// velocity-product terms all at `vel`, joint blocks at `pose`, one factorization and
    /// one tree solve (`O(N)`). Without cut forces: the explicit Runge–Kutta methods
    /// ([`super::runge_kutta`]) take their stage derivatives from here. Does not allocate.
    pub(crate) fn tree_accelerations<S: System>(
        &mut self,
        sys: &S,
        t: f64,
        pose: &[Pose],
        vel: &[Twist],
        out: &mut [Twist],
    ) -> Result<(), StepError> {
        sys.applied(t, pose, vel, &mut self.applied);
        self.vs.copy_from_slice(vel);
        self.forces_backward(sys, pose, true, Factor::Make)?;
        self.free_forward();
        for (p, l) in self.tree.links.iter().enumerate() {
            out[l.body] = self.nodes[p].a0;
        }
        Ok(())
    }

    /// Put `(pose, vel)` back on the tree: the positions onto the joints root → leaf
    /// ([`tree_joints::project`]), then the velocities onto the null space `u = A q̇` at
    /// the projected positions. The identity on a consistent state, smooth near it. Does
    /// not allocate.
    pub(crate) fn tree_project<S: System>(
        &mut self,
        sys: &S,
        pose: &mut [Pose],
        vel: &mut [Twist],
    ) {
        self.project_positions(sys, pose);
        self.kinematics(sys, pose);
        self.project_velocities(pose, vel);
    }

    /// Set the smallest level size run in parallel (for measurements).
    pub fn set_par_min(&mut self, n: usize) {
        self.tree.sched.par_min = n.max(2);
    }

    /// Joint blocks `Node::kin` at the poses `pose` (per body, in parallel).
    fn kinematics<S: System>(&mut self, sys: &S, pose: &[Pose]) {
        let tree = &self.tree;
        let ground = Pose::default();
        tree.sched.nodes(&mut self.nodes, &|p, n: &mut Node| {
            let l = &tree.links[p];
            if l.joint == NONE {
                return;
            }
            let parent = if l.parent == NONE {
                &ground
            } else {
                &pose[tree.links[l.parent].body]
            };
            joint_blocks(
                sys,
                l.joint,
                l.child_is_b,
                parent,
                &pose[l.body],
                &mut n.kin,
            );
        });
    }

    /// Project `pose` onto the tree joints, root → leaf.
    fn project_positions<S: System>(&mut self, sys: &S, pose: &mut [Pose]) {
        let tree = &self.tree;
        {
            let src: &[Pose] = pose;
            tree.sched.nodes(&mut self.nodes, &|p, n: &mut Node| {
                n.pose = src[tree.links[p].body]
            });
        }
        tree.sched
            .levels(&mut self.nodes, false, &|start, br: &mut [Node], view| {
                for i in 0..br.len() {
                    let l = &tree.links[start + i];
                    if l.joint == NONE {
                        continue;
                    }
                    let parent = view
                        .parent(i, l.parent, br)
                        .map_or(Pose::default(), |p| p.pose);
                    project_child(sys, l.joint, l.child_is_b, &parent, &mut br[i].pose);
                }
            });
        for (p, l) in tree.links.iter().enumerate() {
            pose[l.body] = self.nodes[p].pose;
        }
    }

    /// Project `vel` onto the null space of the tree at the blocks `Node::kin` (built at
    /// `pose`): rates of the relative motion, then `u = A q̇` root → leaf.
    fn project_velocities(&mut self, pose: &[Pose], vel: &mut [Twist]) {
        let tree = &self.tree;
        {
            let src: &[Twist] = vel;
            let ident = nalgebra::Matrix3::identity();
            tree.sched
                .levels(&mut self.nodes, false, &|start, br: &mut [Node], view| {
                    for i in 0..br.len() {
                        let l = &tree.links[start + i];
                        let uc = src[l.body];
                        let up = view
                            .parent(i, l.parent, br)
                            .map_or(Twist::default(), |p| p.tw);
                        let rates = if l.joint == NONE {
                            [uc.v.x, uc.v.y, uc.v.z, uc.w.x, uc.w.y, uc.w.z]
                        } else {
                            // the rates of the unprojected relative motion
                            let (up_raw, cp) = if l.parent == NONE {
                                (Twist::default(), &ident)
                            } else {
                                let pb = tree.links[l.parent].body;
                                (src[pb], &pose[pb].c)
                            };
                            br[i].kin.rates(cp, &pose[l.body].c, &up_raw, &uc)
                        };
                        let n = &mut br[i];
                        n.tw = n.kin.forward(&up, &rates);
                    }
                });
        }
        for (p, l) in tree.links.iter().enumerate() {
            vel[l.body] = self.nodes[p].tw;
        }
    }

    /// Pass B (leaf → root): at each position the body force
    /// `Node::f = F − ω × Jω` (`F` in `self.applied`, gyroscopic term at the synchronous
    /// velocities `vs`) and the velocity-product term `κ` of its joint at `vs` (in
    /// `Node::a0`), at the poses `pose`, with (`with_kin`) the joint blocks `Node::kin` at
    /// those poses first; then the factorization of `AᵀMA` as `factor` says and the
    /// backward half of the free solve, all in one sweep ([`Solver::backward_bias`]).
    fn forces_backward<S: System>(
        &mut self,
        sys: &S,
        pose: &[Pose],
        with_kin: bool,
        factor: Factor,
    ) -> Result<(), StepError> {
        let tree = &self.tree;
        let applied = &self.applied;
        let vs = &self.vs;
        let layout = sys.layout();
        let ground = Pose::default();
        let pre = |node: &mut Node, p: usize| {
            let l = &tree.links[p];
            let b = l.body;
            node.a0 = if l.joint == NONE {
                Twist::default()
            } else {
                let parent = if l.parent == NONE {
                    &ground
                } else {
                    &pose[tree.links[l.parent].body]
                };
                let child = &pose[b];
                if with_kin {
                    joint_blocks(sys, l.joint, l.child_is_b, parent, child, &mut node.kin);
                }
                let up = if l.parent == NONE {
                    Twist::default()
                } else {
                    vs[tree.links[l.parent].body]
                };
                let uc = vs[b];
                let rates = node.kin.rates(&parent.c, &child.c, &up, &uc);
                node.kin.kappa(&parent.c, &child.c, &up, &uc, &rates)
            };
            node.f = Wrench {
                f: applied[b].f,
                t: applied[b].t - gyro(&layout.mass[b], &vs[b].w),
            };
        };
        let solver = Solver { tree };
        if let Some(p) = solver.backward_bias(&mut self.nodes, factor, &pre) {
            return Err(StepError::Singular {
                what: "reduced mass AᵀMA (natural partitioning)",
                row: self.tree.links[p].off,
            });
        }
        Ok(())
    }

    /// The forward half of the free solve (root → leaf, `y = X u̇_p + κ`): `Node::a0 ←`
    /// the accelerations without cut forces `Ȧq̇ + A x` (also in `Node::acc`).
    fn free_forward(&mut self) {
        let tree = &self.tree;
        tree.sched
            .levels(&mut self.nodes, false, &|start, br: &mut [Node], view| {
                for i in 0..br.len() {
                    let l = &tree.links[start + i];
                    let pacc = view.parent(i, l.parent, br).map(|p| p.acc);
                    let node = &mut br[i];
                    let mut y = node.a0;
                    if let Some(pa) = pacc {
                        let t = node.kin.transport(&pa);
                        y.v += t.v;
                        y.w += t.w;
                    }
                    reduced::fwd(node, &y);
                    node.a0 = node.acc;
                }
            });
    }

    /// The accelerations without cut forces into `Node::a0` (forces at `(pose, vl)`:
    /// `vl` the lagged velocities damping uses; gyroscopic term and `Ȧq̇` at the synchronous
    /// `vs`; joint blocks at `pose` already in `Node::kin`): passes A and B and the forward
    /// half of the solve.
    fn free_accelerations<S: System>(
        &mut self,
        sys: &S,
        t: f64,
        pose: &[Pose],
        vl: &[Twist],
        vs: &[Twist],
    ) -> Result<(), StepError> {
        sys.applied(t, pose, vl, &mut self.applied);
        self.vs.copy_from_slice(vs);
        self.forces_backward(sys, pose, false, Factor::Make)?;
        self.free_forward();
        Ok(())
    }

    /// `Node::acc = A(AᵀMA)⁻¹AᵀB_cᵀ v` at `Node::kin` (one tree solve), with `self.ce`'s
    /// Jacobian.
    fn response(&mut self, layout: &Layout, v: &[f64]) {
        let solver = Solver { tree: &self.tree };
        cut_response(
            &solver,
            &mut self.nodes,
            layout,
            &self.tree.cut_rows,
            &self.ce.jac,
            &self.tree.pos,
            &self.active,
            v,
        );
    }

    /// The coordinate update of the sequence by h into `self.trial`, with the constraint
    /// correction of SHAKE (see the module doc), in three sweeps:
    ///
    /// - C (root → leaf): optionally the forward half of the free solve (`solve`:
    ///   `a0 ← Ȧq̇ + A x`, from `y = X u̇_p + κ`); the kick with `a = a0 + resp` (velocities to τ + h/2:
    ///   translation explicit, rotation by the midpoint rule, [`midpoint_kick`]), the drift
    ///   (positions to τ + h, Cayley update); the geometric correction `δq_geo` that puts
    ///   each child back on its joint (the parent already corrected), and `M δq_geo`;
    /// - D (leaf → root): the backward half of `(AᵀMA)⁻¹AᵀM δq_geo` (factorization at τ);
    /// - E (root → leaf): its forward half, the M-orthogonal correction
    ///   `δq = δq_geo − A(AᵀMA)⁻¹AᵀM δq_geo` (along `M⁻¹Bᵀ(τ)`, the direction of the
    ///   constraint forces), applied to the position and, divided by h, to the velocity;
    ///   a last geometric projection (the remaining `O(h⁴)` violation, to round-off).
    ///
    /// The result stays in the nodes (`Node::pose`, `Node::tw`); [`Natural::gather`]
    /// copies it to `self.trial`.
    fn advance_pass<S: System>(&mut self, sys: &S, solve: bool) {
        let h = self.h;
        let tree = &self.tree;
        let src = &self.seq;
        let (vs, gc, resp) = (&self.vs, &self.gc, &self.resp);
        // The drift of body b with the kicked velocity v.
        let drift = |b: usize, v: &Twist| {
            let q = cayley_update(&src.pose[b].q, &v.w, h, false);
            Pose {
                r: src.pose[b].r + v.v * h,
                q,
                c: crate::contract::math::rotation(&q),
            }
        };
        // Sweep C.
        tree.sched
            .levels(&mut self.nodes, false, &|start, br: &mut [Node], view| {
                let ground = Pose::default();
                for i in 0..br.len() {
                    let l = &tree.links[start + i];
                    let (pacc, ppose) = match view.parent(i, l.parent, br) {
                        Some(p) => (p.acc, p.pose),
                        None => (Twist::default(), ground),
                    };
                    let node = &mut br[i];
                    if solve {
                        // y = X u̇_p + κ (the parent's acc is its total acceleration)
                        let mut y = node.a0;
                        if l.parent != NONE {
                            let t = node.kin.transport(&pacc);
                            y.v += t.v;
                            y.w += t.w;
                        }
                        reduced::fwd(node, &y);
                        node.a0 = node.acc;
                    }
                    let mut a = node.a0;
                    if let Some(r) = resp.get(start + i) {
                        a.v += r.v;
                        a.w += r.w;
                    }
                    let b = l.body;
                    let u = &src.vel[b];
                    let v = Twist {
                        v: u.v + a.v * h,
                        w: midpoint_kick(&node.j, h, &u.w, &a.w, &vs[b].w, &gc[b]),
                    };
                    let raw = drift(b, &v);
                    node.raw = v;
                    node.pose = raw;
                    if l.joint != NONE {
                        project_child(sys, l.joint, l.child_is_b, &ppose, &mut node.pose);
                    }
                    // δq_geo as a twist-like displacement (world translation, body rotation)
                    node.dq = displacement(&raw, &node.pose);
                    // the body force of sweep D
                    node.f = node.mass_mul(&node.dq);
                }
            });
        // Sweep D: backward half of (AᵀMA)⁻¹AᵀM δq_geo with the factorization at τ.
        let solver = Solver { tree };
        solver.backward_solve(&mut self.nodes, true, false);
        // Sweep E.
        tree.sched
            .levels(&mut self.nodes, false, &|start, br: &mut [Node], view| {
                let ground = Pose::default();
                for i in 0..br.len() {
                    let l = &tree.links[start + i];
                    let (pacc, ppose) = match view.parent(i, l.parent, br) {
                        Some(p) => (p.acc, p.pose),
                        None => (Twist::default(), ground),
                    };
                    let node = &mut br[i];
                    // node.acc ← A (AᵀMA)⁻¹AᵀM δq_geo (the null-space part of δq_geo)
                    let yv = if l.parent == NONE {
                        Twist::default()
                    } else {
                        node.kin.transport(&pacc)
                    };
                    reduced::fwd(node, &yv);
                    let d = Twist {
                        v: node.dq.v - node.acc.v,
                        w: node.dq.w - node.acc.w,
                    };
                    let raw = drift(l.body, &node.raw);
                    node.pose = common::rotate_body(&raw, d.v, d.w);
                    node.tw = Twist {
                        v: node.raw.v + d.v / h,
                        w: node.raw.w + d.w / h,
                    };
                    if l.joint != NONE {
                        project_child(sys, l.joint, l.child_is_b, &ppose, &mut node.pose);
                    }
                }
            });
    }

    /// Copy the result of [`Natural::advance_pass`] into `self.trial` (body order) and,
    /// with `layout`, update the gyroscopic estimates in the same per-body pass: the new
    /// `ū = (u + u⁺)/2` (into `self.vs`) and tree corrections of ω (into `self.gc`).
    /// Returns how much the gyroscopic impulse `h ω̄ × Jω̄` of the kick changes with them
    /// (per unit inertia, the largest over the bodies), relative to `1 + max |ω̄|` (0
    /// without `layout`). Runs in parallel chunks for large scenes.
    fn gather(&mut self, layout: Option<&Layout>) -> f64 {
        let h = self.h;
        let tree = &self.tree;
        let nodes = &self.nodes;
        let seq_vel = &self.seq.vel;
        // (err, max |ω̄|) of body b
        let one = |b: usize, p: &mut Pose, v: &mut Twist, vs: &mut Twist, gc: &mut Vector3<f64>| {
            let pos = tree.pos[b];
            let n = &nodes[pos];
            *p = n.pose;
            *v = n.tw;
            let Some(layout) = layout else {
                return (0.0, 0.0);
            };
            let u0 = &seq_vel[b];
            let ub = Twist {
                v: (u0.v + v.v) * 0.5,
                w: (u0.w + v.w) * 0.5,
            };
            let c = n.tw.w - n.raw.w;
            let m = &layout.mass[b];
            let g_new = gyro(m, &ub.w);
            let l = &tree.links[pos];
            // (the kick of a body without joints is exact whatever the estimate)
            let exact = l.joint == NONE && tree.children(pos).is_empty();
            let err = if exact {
                0.0
            } else {
                let dg = (g_new - gyro(m, &vs.w)).norm()
                    + (g_new - gyro(m, &(ub.w - (c - *gc) * 0.5))).norm();
                h * dg / (m.j.trace() / 3.0)
            };
            let wn = ub.w.norm();
            *vs = ub;
            *gc = c;
            (err, wn)
        };
        let max2 = |a: (f64, f64), b: (f64, f64)| (a.0.max(b.0), a.1.max(b.1));
        let trial = &mut self.trial;
        let (err, wmax) = if trial.pose.len() >= tree.sched.par_min {
            use rayon::prelude::*;
            (
                trial.pose.par_iter_mut(),
                trial.vel.par_iter_mut(),
                self.vs.par_iter_mut(),
                self.gc.par_iter_mut(),
            )
                .into_par_iter()
                .enumerate()
                .with_min_len(256)
                .map(|(b, (p, v, vs, gc))| one(b, p, v, vs, gc))
                .reduce(|| (0.0, 0.0), max2)
        } else {
            trial
                .pose
                .iter_mut()
                .zip(trial.vel.iter_mut())
                .zip(self.vs.iter_mut().zip(self.gc.iter_mut()))
                .enumerate()
                .map(|(b, ((p, v), (vs, gc)))| one(b, p, v, vs, gc))
                .fold((0.0, 0.0), max2)
        };
        err / (1.0 + wmax)
    }

    /// One step of the sequence at τ. Returns the PCG iterations made.
    fn advance<S: System>(&mut self, sys: &S) -> Result<u32, StepError> {
        let has_cut = self.tree.cut_rows.iter().any(|&r| self.active[r]);
        // Pass B: joint blocks at τ, the velocity-product terms and the gyroscopic term at
        // the synchronous estimate (applied forces with the lagged velocities), the
        // factorization and the backward half of the free solve, in one sweep.
        sys.applied(self.tau, &self.seq.pose, &self.seq.vel, &mut self.applied);
        let pose = std::mem::take(&mut self.seq.pose);
        // keep every P when the last step needed a second gyroscopic iteration (this one
        // likely will, and can then skip the factorization)
        let factor = if self.keep_p {
            Factor::MakeAndKeep
        } else {
            Factor::Make
        };
        let r = self.forces_backward(sys, &pose, true, factor);
        // whether the factorization in the nodes holds `P` at every position
        let mut p_kept = self.keep_p;
        self.seq.pose = pose;
        r?;
        if has_cut {
            sys.constraints(self.tau, &self.seq.pose, &self.vs, Need::JAC, &mut self.ce);
            // warm start λ(τ) ≈ 2λ(τ − h) − λ(τ − 2h)
            for (i, &r) in self.tree.cut_rows.iter().enumerate() {
                let (l1, l0) = (self.lambda[i], self.lambda_prev[i]);
                self.lambda_prev[i] = l1;
                self.lambda[i] = if self.active[r] { 2.0 * l1 - l0 } else { 0.0 };
            }
        } else {
            self.resp.iter_mut().for_each(|r| *r = Twist::default());
        }
        let mut pcg_iters = 0;
        let mut gyro_it = 0;
        let mut converged = false;
        while gyro_it < MAX_GYRO {
            if gyro_it > 0 {
                // the forces at the new estimate ū with the factorization at τ; if the
                // sweep above kept `P` only where branches start, the factorization is made
                // again (the same numbers: the joint blocks have not changed) and kept
                let factor = if p_kept {
                    Factor::Kept
                } else {
                    Factor::MakeAndKeep
                };
                p_kept = true;
                let pose = std::mem::take(&mut self.seq.pose);
                let r = self.forces_backward(sys, &pose, false, factor);
                self.seq.pose = pose;
                r?;
            }
            gyro_it += 1;
            if !has_cut {
                // Pass C: forward solve and coordinate update fused, then the correction.
                self.advance_pass(sys, true);
            } else {
                pcg_iters += self.cut_step(sys)?;
            }
            let err = self.gather(Some(sys.layout()));
            if err <= GYRO_TOL {
                converged = true;
                break;
            }
        }
        self.steps += 1;
        self.keep_p = gyro_it > 1;
        self.gyro_total += gyro_it as u64;
        self.gyro_max = self.gyro_max.max(gyro_it);
        if !converged {
            self.gyro_unconverged += 1;
        }
        std::mem::swap(&mut self.seq, &mut self.trial);
        // the estimate of ū for the next step: u(τ + h) ≈ (3u(τ + h/2) − u(τ − h/2))/2
        let (v1, v0) = (&self.seq.vel, &self.trial.vel);
        let extrapolate = |(b, v): (usize, &mut Twist)| {
            let (v1, v0) = (&v1[b], &v0[b]);
            *v = Twist {
                v: v1.v * 1.5 - v0.v * 0.5,
                w: v1.w * 1.5 - v0.w * 0.5,
            };
        };
        if self.vs.len() >= self.tree.sched.par_min {
            use rayon::prelude::*;
            self.vs
                .par_iter_mut()
                .enumerate()
                .with_min_len(512)
                .for_each(extrapolate);
        } else {
            self.vs.iter_mut().enumerate().for_each(extrapolate);
        }
        Ok(pcg_iters)
    }

    /// The coordinate update with the cut-row multipliers (forces of pass A solved by the
    /// backward half already): the forward half, then the staggered stabilization with
    /// the regularization raised where it does not converge. Returns the PCG iterations.
    fn cut_step<S: System>(&mut self, sys: &S) -> Result<u32, StepError> {
        self.free_forward();
        // Near a singular configuration (links that line up, lock-up) the default
        // regularization can be too small for the iteration to converge: retry with it
        // raised ×10³ at a time, as the staggered method does (each such step counted).
        self.lambda_guess.copy_from_slice(&self.lambda);
        let mut last = None;
        let mut done = None;
        for (attempt, scale) in [1.0, 1e3, 1e6, 1e9].into_iter().enumerate() {
            if attempt > 0 {
                self.lambda.copy_from_slice(&self.lambda_guess);
            }
            for (ee, e) in self.e_eff.iter_mut().zip(&self.e) {
                *ee = e * scale;
            }
            match self.lint(sys) {
                Ok(r) => {
                    if attempt > 0 {
                        self.regularized_steps += 1;
                    }
                    done = Some(r);
                    break;
                }
                Err(e @ StepError::NoConvergence { .. }) => last = Some(e),
                Err(e) => return Err(e),
            }
        }
        let Some((newton, iters)) = done else {
            return Err(last.expect("at least one attempt"));
        };
        self.tau_lambda = self.tau;
        self.lints += 1;
        self.newton_total += newton as u64;
        self.newton_max = self.newton_max.max(newton);
        Ok(iters)
    }

    /// The staggered stabilization of the cut rows at τ (exact-integral form, regularization
    /// `self.e_eff`): Newton iterations on `λ_c` until the positions after the coordinate
    /// update satisfy `Φ_c = E(λ_c − λ_c⁰)`, each correction from PCG on
    /// `S = E + h² (B_c A)(AᵀMA)⁻¹(B_c A)ᵀ`. Leaves the advanced sequence in `self.trial`.
    /// Returns (Newton iterations, PCG iterations).
    fn lint<S: System>(&mut self, sys: &S) -> Result<(u32, u32), StepError> {
        let layout = sys.layout();
        let h = self.h;
        let mut pcg_iters = 0;
        let lam = std::mem::take(&mut self.lambda);
        self.response(layout, &lam);
        self.lambda = lam;
        for (r, n) in self.resp.iter_mut().zip(self.nodes.iter()) {
            *r = Twist {
                v: -n.acc.v,
                w: -n.acc.w,
            };
        }
        // Jacobi preconditioner: diag(E + h² B_c M⁻¹ B_cᵀ)
        for (i, &r) in self.tree.cut_rows.iter().enumerate() {
            self.diag[i] = if self.active[r] {
                self.e_eff[i] + h * h * k_diag(layout, &self.ce.jac[r], r)
            } else {
                1.0
            };
        }
        let mut converged = false;
        let mut newton = 0;
        for it in 0..MAX_NEWTON {
            newton = it;
            self.advance_pass(sys, false);
            self.gather(None);
            sys.constraints(
                self.tau + h,
                &self.trial.pose,
                &self.trial.vel,
                Need::PHI,
                &mut self.ce_trial,
            );
            let mut worst: f64 = 0.0;
            for (i, &r) in self.tree.cut_rows.iter().enumerate() {
                if !self.active[r] {
                    self.res[i] = 0.0;
                    continue;
                }
                let phi = if layout.row_kind[r] == RowKind::Holonomic {
                    self.ce_trial.phi[r]
                } else {
                    let (a, b) = layout.row_bodies(r);
                    let bu = a.map_or(0.0, |a| dot6(&self.ce.jac[r].a, &self.trial.vel[a]))
                        + b.map_or(0.0, |b| dot6(&self.ce.jac[r].b, &self.trial.vel[b]));
                    h * 0.5 * (self.ce_trial.phi[r] + bu + self.ce.bias[r])
                };
                self.res[i] = phi - self.e_eff[i] * (self.lambda[i] - self.lambda0[i]);
                worst = worst.max(self.res[i].abs());
            }
            if worst <= self.tol {
                converged = true;
                break;
            }
            // Newton correction: S Δλ = res by PCG, accumulating the body response.
            self.dresp.iter_mut().for_each(|d| *d = Twist::default());
            let stats = {
                let mut ops = CutOps {
                    solver: Solver { tree: &self.tree },
                    nodes: &mut self.nodes,
                    dresp: &mut self.dresp,
                    layout,
                    rows: &self.tree.cut_rows,
                    jac: &self.ce.jac,
                    pos: &self.tree.pos,
                    active: &self.active,
                    e: &self.e_eff,
                    diag: &self.diag,
                    h2: h * h,
                };
                let max_it = self
                    .pcg_limit
                    .unwrap_or_else(|| (4 * self.res.len()).max(50) as u32);
                pcg(
                    &mut ops,
                    &self.res,
                    &mut self.dl,
                    &mut self.work,
                    self.rtol,
                    0.1 * self.tol,
                    max_it,
                )
            };
            pcg_iters += stats.iterations;
            self.pcg_total += stats.iterations as u64;
            self.pcg_solves += 1;
            self.pcg_max = self.pcg_max.max(stats.iterations);
            if !stats.converged && stats.relative_residual > 1e-3 {
                // Name the cut row whose Newton residual drives the solve.
                return Err(StepError::NoConvergence {
                    what: "cut-joint PCG (natural partitioning)",
                    iterations: stats.iterations,
                    residual: stats.relative_residual,
                    row: super::worst_entry(&self.res).map(|w| self.tree.cut_rows[w.0]),
                });
            }
            for i in 0..self.dl.len() {
                self.lambda[i] += self.dl[i];
            }
            for (r, d) in self.resp.iter_mut().zip(&self.dresp) {
                r.v -= d.v;
                r.w -= d.w;
            }
        }
        if !converged {
            let worst = super::worst_entry(&self.res);
            return Err(StepError::NoConvergence {
                what: "natural-partitioning cut-joint Newton iteration",
                iterations: MAX_NEWTON,
                residual: worst.map_or(0.0, |w| w.1),
                row: worst.map(|w| self.tree.cut_rows[w.0]),
            });
        }
        Ok((newton, pcg_iters))
    }

    fn check_locks<S: System>(&mut self, sys: &S) {
        self.next_active.copy_from_slice(&self.active);
        if sys
            .update_locks(&self.seq.pose, &self.vs, &mut self.next_active)
            .is_some()
        {
            for (i, &r) in self.tree.cut_rows.iter().enumerate() {
                if self.next_active[r] && !self.active[r] {
                    self.lambda[i] = 0.0;
                    self.lambda_prev[i] = 0.0;
                    self.lambda0[i] = 0.0;
                }
            }
            self.active.copy_from_slice(&self.next_active);
        }
    }
}

/// The small displacement taking pose `a` to pose `b`: world translation and body-frame
/// rotation vector (`b = a ⊕ d` to second order), the coordinates dual to a [`Twist`].
#[inline]
fn displacement(a: &Pose, b: &Pose) -> Twist {
    let dq = crate::contract::math::qmul(&crate::contract::math::qconj(&a.q), &b.q);
    let s = if dq.w < 0.0 { -2.0 } else { 2.0 };
    Twist {
        v: b.r - a.r,
        w: Vector3::new(dq.i, dq.j, dq.k) * s,
    }
}

/// Convergence of the gyroscopic iteration: the change of the kick's gyroscopic impulse
/// per unit inertia, relative to `1 + max |ω̄|` (see [`Natural::gyro_update`]).
const GYRO_TOL: f64 = 1e-14;

/// The rotational kick of one body by the implicit midpoint rule: `ω⁺` from
///
/// ```text
/// J(ω⁺ − ω)/h + ω̃ × Jω̃ = J a_ω + ω_e × Jω_e,   ω̃ = (ω + ω⁺ + c)/2,
/// ```
///
/// where `a_ω` is the angular acceleration of the tree solve, whose body forces carry the
/// gyroscopic term at the estimate `ω_e` (so the right-hand side is the applied plus
/// constraint torque), and `c` the tree correction of ω of the last iterate (so `ω̃` is the
/// midpoint of the corrected velocities). A 3×3 Newton iteration from the explicit
/// `ω + h a_ω`; when the estimate is consistent (`ω̃ = ω_e`) that is the solution and no
/// iteration is made. For a body without joints this is the exact midpoint rule whatever
/// the estimate.
#[inline]
fn midpoint_kick(
    j: &nalgebra::Matrix3<f64>,
    h: f64,
    w0: &Vector3<f64>,
    a: &Vector3<f64>,
    we: &Vector3<f64>,
    c: &Vector3<f64>,
) -> Vector3<f64> {
    // unknown: δ = (ω⁺ − ω)/h − a (zero when the estimate is consistent)
    let ge = we.cross(&(j * we));
    let scale = 1e-16 * (1.0 + w0.norm());
    let jn = j.norm();
    let mut d = Vector3::zeros();
    for _ in 0..8 {
        let wb = w0 + (a + d) * (h * 0.5) + c * 0.5;
        let jwb = j * wb;
        let f = j * d + wb.cross(&jwb) - ge;
        if h.abs() * f.norm() <= scale * jn {
            break;
        }
        let jac = j
            + (crate::contract::math::skew(&wb) * j - crate::contract::math::skew(&jwb))
                * (h * 0.5);
        let Some(inv) = jac.try_inverse() else { break };
        let dd = inv * f;
        d -= dd;
        if h.abs() * dd.norm() <= scale {
            break;
        }
    }
    w0 + (a + d) * h
}

/// Run `f` on a dedicated rayon pool of `threads` threads (the recursions' parallel
/// branches and per-body passes then use at most that many). For benchmarks and for
/// callers that want to bound the parallelism; building the pool allocates.
pub fn with_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    match rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
    {
        Ok(pool) => pool.install(f),
        Err(_) => f(),
    }
}

/// `K_rr = B_r M⁻¹ B_rᵀ` of one row.
fn k_diag(layout: &Layout, jac: &RowJac, r: usize) -> f64 {
    let (a, b) = layout.row_bodies(r);
    let side = |row: &[f64; 6], i: usize| {
        let m = &layout.mass[i];
        let v = Vector3::new(row[0], row[1], row[2]);
        let w = Vector3::new(row[3], row[4], row[5]);
        v.norm_squared() / m.m + w.dot(&(m.j_inv * w))
    };
    a.map_or(0.0, |a| side(&jac.a, a)) + b.map_or(0.0, |b| side(&jac.b, b))
}

impl<S: System> Integrator<S> for Natural {
    fn name(&self) -> &'static str {
        "natural_partitioning"
    }

    fn time(&self) -> f64 {
        self.tau
    }

    fn step_size(&self) -> f64 {
        self.h
    }

    fn step(&mut self, sys: &S) -> Result<StepInfo, StepError> {
        self.vel_prev.copy_from_slice(&self.seq.vel);
        let iterations = self.advance(sys)?;
        self.half_steps += 2;
        self.tau = self.t0 + self.half_steps as f64 * self.h / 2.0;
        self.check_locks(sys);
        Ok(StepInfo { iterations })
    }

    fn state(&self, sys: &S, out: &mut State) {
        let _ = sys;
        out.t = self.tau;
        out.pose.copy_from_slice(&self.seq.pose);
        // The velocities at t − h/2 and t − 3h/2, taken to t by a half kick of the last
        // kick's acceleration: translation explicitly, v₁ + (v₁ − v₀)/2; rotation by the
        // same implicit midpoint rule with the last kick's torque
        // `J(ω₁ − ω₀)/h + ω̄ × Jω̄` (the gyroscopic term then at the new ω). Second order,
        // and on a free body exactly energy and |L| conserving, as the step is.
        let layout = sys.layout();
        for (b, o) in out.twist.iter_mut().enumerate() {
            if self.half_steps == 0 {
                // before the first step `vel_prev` holds the initial velocity itself
                *o = self.vel_prev[b];
                continue;
            }
            let (v1, v0) = (&self.seq.vel[b], &self.vel_prev[b]);
            let a = (v1.w - v0.w) / self.h;
            let wb = (v0.w + v1.w) * 0.5;
            *o = Twist {
                v: v1.v * 1.5 - v0.v * 0.5,
                w: midpoint_kick(
                    &layout.mass[b].j,
                    self.h / 2.0,
                    &v1.w,
                    &a,
                    &wb,
                    &Vector3::zeros(),
                ),
            };
        }
        out.lambda.iter_mut().for_each(|l| *l = 0.0);
        let dt = self.tau - self.tau_lambda;
        for (i, &r) in self.tree.cut_rows.iter().enumerate() {
            let slope = (self.lambda[i] - self.lambda_prev[i]) / self.h;
            out.lambda[r] = if self.active[r] {
                self.lambda[i] + slope * dt
            } else {
                0.0
            };
        }
    }

    fn persist(&mut self, v: &mut dyn StateVisitor) -> bool {
        // as the staggered family: what the start derived from the initial state (ε and the
        // regularization per cut row, the tolerances), the time bookkeeping, both sequences,
        // the previous velocities, the synchronous estimate ū and the tree correction of ω
        // the next step starts from, whether the factorization keeps every P, the cut-row
        // multipliers with their history and warm starts, the response to them, the rows'
        // activity, the statistics, and every node's blocks (remade each step, carried anyway)
        persist::f64(v, "h", &mut self.h);
        persist::f64(v, "epsilon", &mut self.epsilon);
        v.f64s("e", &mut self.e);
        v.f64s("e_eff", &mut self.e_eff);
        v.f64s("lambda_guess", &mut self.lambda_guess);
        persist::u64(v, "regularized_steps", &mut self.regularized_steps);
        persist::f64(v, "tau", &mut self.tau);
        persist::f64(v, "t0", &mut self.t0);
        persist::u64(v, "half_steps", &mut self.half_steps);
        for seq in [&mut self.seq, &mut self.trial] {
            persist::poses(v, "seq.pose", &mut seq.pose);
            persist::twists(v, "seq.vel", &mut seq.vel);
        }
        persist::twists(v, "vel_prev", &mut self.vel_prev);
        persist::twists(v, "vs", &mut self.vs);
        let mut gc: Vec<f64> = self.gc.iter().flat_map(|g| g.iter().copied()).collect();
        v.f64s("gc", &mut gc);
        for (g, b) in self.gc.iter_mut().zip(gc.chunks_exact(3)) {
            g.copy_from_slice(b);
        }
        persist::bool(v, "keep_p", &mut self.keep_p);
        persist::twists(v, "resp", &mut self.resp);
        persist::twists(v, "dresp", &mut self.dresp);
        v.f64s("lambda", &mut self.lambda);
        v.f64s("lambda_prev", &mut self.lambda_prev);
        v.f64s("lambda0", &mut self.lambda0);
        persist::f64(v, "tau_lambda", &mut self.tau_lambda);
        v.bools("active", &mut self.active);
        v.bools("next_active", &mut self.next_active);
        persist::constraint_eval(v, &mut self.ce);
        persist::constraint_eval(v, &mut self.ce_trial);
        persist::wrenches(v, "applied", &mut self.applied);
        v.f64s("res", &mut self.res);
        v.f64s("dl", &mut self.dl);
        v.f64s("diag", &mut self.diag);
        for w in self.work.iter_mut() {
            v.f64s("work", w);
        }
        persist::f64(v, "tol", &mut self.tol);
        persist::f64(v, "rtol", &mut self.rtol);
        let mut limit = self.pcg_limit.is_some();
        persist::bool(v, "pcg_limit", &mut limit);
        let mut n = self.pcg_limit.unwrap_or(0);
        persist::u32(v, "pcg_limit", &mut n);
        self.pcg_limit = limit.then_some(n);
        persist::usize(v, "par_min", &mut self.tree.sched.par_min);
        persist::u64(v, "steps", &mut self.steps);
        persist::u64(v, "gyro_total", &mut self.gyro_total);
        persist::u32(v, "gyro_max", &mut self.gyro_max);
        persist::u64(v, "gyro_unconverged", &mut self.gyro_unconverged);
        persist::u64(v, "lints", &mut self.lints);
        persist::u64(v, "newton_total", &mut self.newton_total);
        persist::u32(v, "newton_max", &mut self.newton_max);
        persist::u64(v, "pcg_total", &mut self.pcg_total);
        persist::u64(v, "pcg_solves", &mut self.pcg_solves);
        persist::u32(v, "pcg_max", &mut self.pcg_max);
        for n in self.nodes.iter_mut() {
            n.persist(v);
        }
        true
    }

    fn active(&self) -> &[bool] {
        &self.active
    }

    fn stats(&self) -> Vec<(&'static str, f64)> {
        let mut v = vec![
            ("independent_coordinates", self.tree.ncoord as f64),
            ("cut_rows", self.tree.cut_rows.len() as f64),
            ("tree_levels", self.tree.sched.levels_len() as f64),
            (
                "gyro_iterations_mean",
                self.gyro_total as f64 / self.steps.max(1) as f64,
            ),
            ("gyro_iterations_max", self.gyro_max as f64),
            ("gyro_unconverged_steps", self.gyro_unconverged as f64),
        ];
        if !self.tree.cut_rows.is_empty() {
            v.push(("epsilon", self.epsilon));
            v.push((
                "newton_iterations_mean",
                self.newton_total as f64 / self.lints.max(1) as f64,
            ));
            v.push(("newton_iterations_max", self.newton_max as f64));
            v.push((
                "pcg_iterations_mean",
                self.pcg_total as f64 / self.pcg_solves.max(1) as f64,
            ));
            v.push(("pcg_iterations_max", self.pcg_max as f64));
            v.push(("regularized_steps", self.regularized_steps as f64));
        }
        v
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use nalgebra::{Matrix3, Quaternion};
    use proptest::prelude::*;

    use super::reduced::Precond;
    use super::*;
    use crate::contract::math::quat_array;
    use crate::contract::scene::{
        Attachment, Body, BodyRef, Joint, JointKind, MethodSpec, Origin, Scene, Simulate,
    };
    use crate::contract::system::JointKernel;
    use crate::interp::Interp;
    use crate::kernels::tree_joints::tests::{random_geom, rquat, rvec, KINDS};
    use crate::linalg::testutil::Rng;

    fn scene_kind(k: JointKernel) -> JointKind {
        match k {
            JointKernel::Spherical => JointKind::Spherical,
            JointKernel::Revolute => JointKind::Revolute,
            JointKernel::Prismatic => JointKind::Prismatic,
            JointKernel::Cylindrical => JointKind::Cylindrical,
            JointKernel::Universal => JointKind::Universal,
            JointKernel::Fixed => JointKind::Fixed,
            JointKernel::Planar => JointKind::Planar,
            other => unreachable!("{other:?} is not a tree kind"),
        }
    }

    /// A random forest of `n` bodies: body `i` hangs off the ground, an earlier body, or
    /// nothing (a free root), by a joint of a random tree-eligible kind with random
    /// attachments; `extra` joints between random bodies close loops. Random masses,
    /// inertias, poses (joints violated) and gravity.
    pub(crate) fn random_scene(rng: &mut Rng, n: usize, extra: usize) -> Scene {
        let mut bodies = Vec::new();
        for i in 0..n {
            let m = crate::linalg::testutil::random_mass(rng);
            bodies.push(Body {
                name: format!("b{i}"),
                mass: m.m,
                inertia: [
                    [m.j[(0, 0)], m.j[(0, 1)], m.j[(0, 2)]],
                    [m.j[(1, 0)], m.j[(1, 1)], m.j[(1, 2)]],
                    [m.j[(2, 0)], m.j[(2, 1)], m.j[(2, 2)]],
                ],
                position: rvec(rng, 1.0).into(),
                orientation: quat_array(&rquat(rng)),
                velocity: [0.0; 3],
                angular_velocity: [0.0; 3],
                origin: Origin::default(),
            });
        }
        let mut joints = Vec::new();
        let att = |body: BodyRef, g: &crate::kernels::joints::JointGeom, a: bool| Attachment {
            body,
            point: if a { g.pa } else { g.pb },
            frame: if a { g.qa } else { g.qb },
        };
        for i in 0..n {
            let r = rng.uniform();
            let parent = if i == 0 || r < 0.2 {
                BodyRef::Ground
            } else if r < 0.3 {
                continue; // free root
            } else {
                BodyRef::Body(rng.below(i))
            };
            let kind = KINDS[rng.below(KINDS.len())];
            let g = random_geom(rng);
            let (a, b) = if rng.uniform() < 0.5 {
                (att(parent, &g, true), att(BodyRef::Body(i), &g, false))
            } else {
                (att(BodyRef::Body(i), &g, true), att(parent, &g, false))
            };
            joints.push(Joint {
                name: format!("j{i}"),
                kind: scene_kind(kind),
                a,
                b,
                origin: Origin::default(),
            });
        }
        for e in 0..extra {
            let a = rng.below(n);
            let mut b = rng.below(n + 1);
            if b == a {
                b = n;
            }
            let g = random_geom(rng);
            let br = if b == n {
                BodyRef::Ground
            } else {
                BodyRef::Body(b)
            };
            joints.push(Joint {
                name: format!("x{e}"),
                kind: JointKind::Spherical,
                a: att(BodyRef::Body(a), &g, true),
                b: att(br, &g, false),
                origin: Origin::default(),
            });
        }
        Scene {
            name: "random".into(),
            gravity: Some(rvec(rng, 5.0).into()),
            bodies,
            joints,
            forces: Vec::new(),
            beams: Vec::new(),
            meshes: Vec::new(),
            contacts: Vec::new(),
            simulate: Simulate::default(),
            reference: None,
            params: Vec::new(),
        }
    }

    fn random_state(rng: &mut Rng, n: usize) -> (Vec<Pose>, Vec<Twist>) {
        let pose = (0..n)
            .map(|_| Pose::new(rvec(rng, 1.0), rquat(rng)))
            .collect();
        (pose, vec![Twist::default(); n])
    }

    fn natural(sys: &Interp) -> Natural {
        let st = State::initial(sys);
        Natural::new(sys, 1e-3, None, 1e-12, &st).expect("start")
    }

    /// A random tree of `n` bodies, its interpreter, the method, and a random state (in
    /// that order from `rng`) with the joint blocks at its poses.
    fn posed_tree(rng: &mut Rng, n: usize) -> (Interp, Natural, Vec<Pose>, Vec<Twist>) {
        let scene = random_scene(rng, n, 0);
        let sys = Interp::new(&scene).unwrap();
        let mut s = natural(&sys);
        let (pose, vel) = random_state(rng, n);
        s.kinematics(&sys, &pose);
        (sys, s, pose, vel)
    }

    /// `B A = 0` for every tree row over random trees at random (violated)
    /// configurations: the columns of `A` (one forward pass per independent coordinate)
    /// are annihilated by the kernels' Jacobian rows.
    fn check_ba(seed: u64, n: usize) {
        let mut rng = Rng::new(seed);
        let (sys, mut s, pose, vel) = posed_tree(&mut rng, n);
        let layout = sys.layout();
        let mut ce = ConstraintEval::new(layout.rows);
        sys.constraints(0.0, &pose, &vel, Need::JAC, &mut ce);
        let solver = Solver { tree: &s.tree };
        let mut worst: f64 = 0.0;
        for c in 0..s.tree.ncoord {
            let mut e = vec![0.0; s.tree.ncoord];
            e[c] = 1.0;
            solver.scatter(&mut s.nodes, &e);
            solver.forward(&mut s.nodes);
            let acc: Vec<Twist> = (0..n).map(|b| s.nodes[s.tree.pos[b]].acc).collect();
            for r in 0..layout.rows {
                if s.tree.cut_rows.contains(&r) {
                    continue;
                }
                let (a, b) = layout.row_bodies(r);
                let v = a.map_or(0.0, |a| dot6(&ce.jac[r].a, &acc[a]))
                    + b.map_or(0.0, |b| dot6(&ce.jac[r].b, &acc[b]));
                let scale = 1.0
                    + acc
                        .iter()
                        .map(|t| t.v.norm() + t.w.norm())
                        .fold(0.0, f64::max);
                worst = worst.max(v.abs() / scale);
            }
        }
        assert!(worst < 1e-13, "seed {seed}: max |B A| = {worst:e}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn ba_is_zero_on_random_trees(seed in 0u64..1_000_000, n in 1usize..12) {
            check_ba(seed, n);
        }
    }

    /// `P` is handed to the parent in a local and stored only where a branch starts
    /// (`Solver::up_handing`): factoring that way, factoring and keeping every `P`, and
    /// reusing the kept ones give the same bits, on random trees (branched ones included)
    /// with random forces and velocity-product terms.
    #[test]
    fn factor_modes_agree_bitwise() {
        for seed in 0..30u64 {
            let mut rng = Rng::new(7000 + seed);
            let n = 1 + rng.below(12);
            let (_sys, s, _, _) = posed_tree(&mut rng, n);
            let np = s.nodes.len();
            let inputs: Vec<(Wrench, Twist)> = (0..np)
                .map(|_| {
                    let mut v = || Vector3::new(rng.normal(), rng.normal(), rng.normal());
                    (Wrench { f: v(), t: v() }, Twist { v: v(), w: v() })
                })
                .collect();
            let pre = |node: &mut Node, p: usize| {
                node.f = inputs[p].0;
                node.a0 = inputs[p].1;
            };
            let solver = Solver { tree: &s.tree };
            let out = |nodes: &[Node]| -> Vec<[f64; 12]> {
                nodes
                    .iter()
                    .map(|n| {
                        let mut o = [0.0; 12];
                        o[..6].copy_from_slice(&n.hh);
                        o[6..].copy_from_slice(&[
                            n.f.f.x, n.f.f.y, n.f.f.z, n.f.t.x, n.f.t.y, n.f.t.z,
                        ]);
                        o
                    })
                    .collect()
            };
            let mut nodes = s.nodes.clone();
            assert!(solver
                .backward_bias(&mut nodes, Factor::Make, &pre)
                .is_none());
            let made = out(&nodes);
            let mut kept = s.nodes.clone();
            assert!(solver
                .backward_bias(&mut kept, Factor::MakeAndKeep, &pre)
                .is_none());
            assert_eq!(out(&kept), made, "seed {seed}: keep every P");
            assert!(solver
                .backward_bias(&mut kept, Factor::Kept, &pre)
                .is_none());
            assert_eq!(out(&kept), made, "seed {seed}: reuse the kept P");
        }
    }

    /// The accelerations of the reduced equations equal the index-1 solution of the full
    /// system (`common::Index1`, reference) on random trees at random configurations with
    /// random consistent velocities `u = A q̇`, to 1e-9 relative.
    #[test]
    fn reduced_accelerations_equal_index1() {
        for seed in 0..40u64 {
            let mut rng = Rng::new(1000 + seed);
            let n = 1 + rng.below(10);
            let (sys, mut s, pose, _) = posed_tree(&mut rng, n);
            let layout = sys.layout();
            // u = A q̇ for random q̇
            let solver = Solver { tree: &s.tree };
            let qd: Vec<f64> = (0..s.tree.ncoord).map(|_| rng.normal()).collect();
            solver.scatter(&mut s.nodes, &qd);
            solver.forward(&mut s.nodes);
            let vel: Vec<Twist> = (0..n).map(|b| s.nodes[s.tree.pos[b]].acc).collect();
            s.free_accelerations(&sys, 0.0, &pose, &vel, &vel).unwrap();
            // reference
            let mut ce = ConstraintEval::new(layout.rows);
            sys.constraints(0.0, &pose, &vel, Need::ALL, &mut ce);
            let mut ap = vec![Wrench::default(); n];
            sys.applied(0.0, &pose, &vel, &mut ap);
            let mut q = vec![Wrench::default(); n];
            common::qbar(layout, &ap, &vel, &mut q);
            let mut lam = vec![0.0; layout.rows];
            let active = vec![true; layout.rows];
            let rank = Index1::new(layout)
                .unwrap()
                .solve(layout, &ce, &q, &active, &mut lam)
                .unwrap();
            assert_eq!(rank, layout.rows, "seed {seed}: tree rows independent");
            let mut fl = vec![Wrench::default(); n];
            common::bt_lambda(layout, &ce, &lam, &active, &mut fl);
            let mut scale: f64 = 1.0;
            let mut err: f64 = 0.0;
            for b in 0..n {
                let want = common::accel(
                    &layout.mass[b],
                    &Wrench {
                        f: q[b].f - fl[b].f,
                        t: q[b].t - fl[b].t,
                    },
                );
                let got = s.nodes[s.tree.pos[b]].a0;
                scale = scale.max(want.v.norm()).max(want.w.norm());
                err = err
                    .max((got.v - want.v).norm())
                    .max((got.w - want.w).norm());
            }
            eprintln!(
                "seed {seed} (n = {n}, {} coordinates): |Δü| = {err:.2e}, |ü| = {scale:.2e}",
                s.tree.ncoord
            );
            assert!(
                err < 1e-9 * scale,
                "seed {seed} (n = {n}): |Δü| = {err:e}, scale {scale:e}"
            );
        }
    }

    /// PCG on AᵀMA: the tree-exact preconditioner converges in one iteration; plain CG
    /// and block-Jacobi take many more, growing with the chain length.
    #[test]
    fn tree_exact_preconditioner_converges_in_one_iteration() {
        let mut rng = Rng::new(3);
        let (_sys, mut s, _, _) = posed_tree(&mut rng, 12);
        let nc = s.tree.ncoord;
        let b: Vec<f64> = (0..nc).map(|_| rng.normal()).collect();
        let solver = Solver { tree: &s.tree };
        let mut x = vec![0.0; nc];
        let st = solver.pcg_reduced(&mut s.nodes, Precond::TreeExact, &b, &mut x, 1e-12, 50);
        assert!(st.converged && st.iterations == 1, "{st:?}");
        let mut x2 = vec![0.0; nc];
        let st2 = solver.pcg_reduced(&mut s.nodes, Precond::Identity, &b, &mut x2, 1e-12, 500);
        eprintln!("tree-exact {st:?}, identity {st2:?}");
        assert!(st2.iterations > 1, "{st2:?}");
        for i in 0..nc {
            assert!(
                (x[i] - x2[i]).abs() < 1e-6 * (1.0 + x[i].abs()),
                "{i}: {} vs {}",
                x[i],
                x2[i]
            );
        }
    }

    /// Integration: a random tree without loops runs 2000 steps with the tree joints at
    /// round-off, and its energy (gravity only) stays within 1e-3 relative.
    #[test]
    fn random_tree_keeps_joints_at_round_off() {
        for seed in [11u64, 12, 13] {
            let mut rng = Rng::new(seed);
            let scene = random_scene(&mut rng, 8, 0);
            let mut sys = Interp::new(&scene).unwrap();
            // assemble the initial state onto the tree
            let st0 = State::initial(&sys);
            let s0 = natural(&sys);
            let _ = s0;
            let mut pose = st0.pose.clone();
            let mut s = natural(&sys);
            s.project_positions(&sys, &mut pose);
            let vel = vec![Twist::default(); pose.len()];
            sys.set_initial_state(&pose, &vel);
            let st = State::initial(&sys);
            let mut it = Natural::new(&sys, 1e-3, None, 1e-12, &st).unwrap();
            let mut out = State::initial(&sys);
            let layout = sys.layout().clone();
            let mut ce = ConstraintEval::new(layout.rows);
            let e0 = crate::driver::energy::kinetic_energy(&layout, &st.twist)
                + sys.potential_energy(0.0, &st.pose);
            let mut worst: f64 = 0.0;
            let mut drift: f64 = 0.0;
            let mut emax: f64 = 1e-3;
            for _ in 0..2000 {
                it.step(&sys).unwrap();
                Integrator::<Interp>::state(&it, &sys, &mut out);
                sys.constraints(out.t, &out.pose, &out.twist, Need::PHI, &mut ce);
                worst = ce.phi.iter().fold(worst, |a, p| a.max(p.abs()));
                let ke = crate::driver::energy::kinetic_energy(&layout, &out.twist);
                let e = ke + sys.potential_energy(out.t, &out.pose);
                emax = emax.max(ke);
                drift = drift.max((e - e0).abs());
            }
            eprintln!("seed {seed}: max |Φ| {worst:.2e}, energy drift {drift:.2e}, max kinetic {emax:.2e}");
            assert!(worst < 1e-12, "seed {seed}: tree violation {worst:e}");
            assert!(
                drift < 1e-3 * emax,
                "seed {seed}: energy drift {drift:e} of {emax:e}"
            );
        }
        let _ = (
            Matrix3::<f64>::zeros(),
            Quaternion::<f64>::identity(),
            MethodSpec::CoordinatePartitioning,
        );
    }
}
