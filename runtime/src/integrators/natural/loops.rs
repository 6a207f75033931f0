//! Closed loops for the explicit Runge–Kutta methods ([`crate::integrators::runge_kutta`]):
//! the cut rows' index-1 multipliers at every stage, and the projection of a state onto
//! every joint, tree and cut, after every step.
//!
//! ## The stage derivative
//!
//! With the tree's free accelerations `a₀ = A q̈₀ + Ȧq̇` ([`Natural::tree_accelerations`])
//! and the body-level response to cut forces `R λ = A(AᵀMA)⁻¹AᵀB_cᵀλ` (one tree solve), the
//! accelerations are `ü = a₀ − R λ`, and the cut rows' acceleration equations
//! `B_c ü = γ_c` give the multipliers from the `m × m` system
//!
//! ```text
//! G λ = B_c a₀ − γ_c,    G = (B_c A)(AᵀMA)⁻¹(B_c A)ᵀ,
//! ```
//!
//! the reduced form of the index-1 system `B M⁻¹Bᵀλ = B M⁻¹Q̄ − γ`: `G` is formed column by
//! column, one tree solve per cut row, scaled to `Ĝ = S G S` with
//! `S = diag(B M⁻¹Bᵀ)^(−1/2)` (so `Ĝ_ii ≤ 1` is the share of row `i` the tree's motions
//! reach), and solved as the Tikhonov-regularized least-squares problem
//! `(Ĝ² + δ²I) z = Ĝ S r`, `λ = S z`, `δ = 10⁻⁷` ([`Loops::matrix`]). Where `Ĝ` is well
//! conditioned that is `G⁻¹` to a relative `δ²/σ²` (`10⁻¹⁰` at `σ = 10⁻²`); where it is
//! singular it filters the directions with `σ ≲ δ` smoothly out: rows the tree's motions
//! cannot violate (the out-of-plane rows of a planar loop closed by revolutes in space),
//! dependent cut rows, and singular positions (a parallelogram's or a toggle's aligned
//! links, where a row the tree could violate becomes one it cannot). There the index-1
//! multiplier is `0/0` and its computed value is the state's error divided by `σ`: a rank
//! decision would make the accelerations jump, the plain solve (or a regularization
//! linear in `δ`, which biases every force by `δ`) lets that error through, and an
//! error-controlled method crawls into the singular position and leaves it on the wrong
//! branch (docs/methods.md, "Closed loops under the explicit methods", has the runs). The
//! right-hand side, evaluated at the stage state projected onto every joint (below), is
//! then an ordinary differential equation on the tree coordinates whose flow keeps every
//! joint. A stage costs about `2m + 4` tree solves and two `m × m` products and
//! factorizations (the projection's and the accelerations'): `O(m N + m³)`.
//!
//! ## The projection
//!
//! After each step (and at each output inside one) the state is put back on the joints:
//! positions onto the tree joints root → leaf, then Newton on the holonomic cut rows in
//! the tree's coordinates, `δu = −R μ` with `G μ = Φ_c` (the `M`-orthogonal correction that
//! keeps the tree joints to first order, the next geometric tree projection taking the
//! rest), until `|Φ_c|` is at round-off; then the velocities onto the tree's null space and
//! onto the cut rows' velocity equations `B_c u + b_c = 0` by one such correction (linear:
//! exact in one). The step's result is within its local error `O(h^{p+1})` of the manifold,
//! so the projection moves it by as much and the method keeps its order
//! (Hairer–Lubich–Wanner, *Geometric Numerical Integration*, §IV.4).

use nalgebra::DMatrix;

use super::reduced::Solver;
use super::{cut_response, cut_row_times, k_diag, Natural};
use crate::contract::persist::{self, StateVisitor};
use crate::contract::system::{ConstraintEval, Layout, Need, Pose, RowJac, RowKind, System, Twist};
use crate::integrators::common::rotate_body;
use crate::integrators::StepError;
use crate::linalg::{DenseCholesky, DEFAULT_PIVOT_TOL};

/// The Tikhonov regularization `δ` of the scaled cut-row matrix (see the module doc): the
/// multipliers' error it makes is `δ²/σ²` relative where the scaled `G` has no singular
/// value below `σ`.
const REGULARIZATION: f64 = 1e-7;

/// Newton iterations of the position projection before the step is reported unconverged.
const MAX_PROJECTION: u32 = 12;

/// Which rows enter a cut-row matrix.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Rows {
    /// Every active cut row (accelerations, velocities).
    All,
    /// The holonomic ones (positions).
    Holonomic,
}

/// Buffers and statistics of the cut rows under an explicit method (see the module doc).
pub(crate) struct Loops {
    ce: ConstraintEval,
    /// `Ĝ = S G S`, `S = diag(B M⁻¹Bᵀ)^(−1/2)` over the rows taken.
    g: DMatrix<f64>,
    /// `Ĝ² + δ²I`, factored.
    h: DMatrix<f64>,
    /// `S`.
    scale: Vec<f64>,
    tmp: Vec<f64>,
    chol: DenseCholesky,
    rhs: Vec<f64>,
    unit: Vec<f64>,
    /// Rows the tree's motions could not violate in the last matrix (see
    /// [`Loops::matrix`]): their multipliers are reported as zero.
    void: Vec<bool>,
    /// The multipliers of the last [`Loops::accelerations`] (cut-row order).
    lambda: Vec<f64>,
    /// The position tolerance of the projection (`Φ` units: metres, radians).
    tol: f64,
    /// Newton iterations of the position projections, and the largest `|Φ_c|` found
    /// before one (the step's drift off the loops).
    pub(crate) projection_iterations: u64,
    pub(crate) drift_max: f64,
    /// The most void rows in one matrix (see [`Loops::matrix`]).
    pub(crate) void_max: usize,
    /// The void rows of the first matrix (`None` before it): more later means the
    /// motion passed a singular position.
    pub(crate) void_start: Option<usize>,
}

impl Loops {
    /// Buffers for the cut rows of `nat` (`None` without cut rows). `scale`: the scene's
    /// length scale for the position tolerance (`10⁻¹³·scale`).
    pub(crate) fn new(nat: &Natural, layout: &Layout, scale: f64) -> Option<Loops> {
        let m = nat.tree.cut_rows.len();
        (m > 0).then(|| Loops {
            ce: ConstraintEval::new(layout.rows),
            g: DMatrix::zeros(m, m),
            h: DMatrix::zeros(m, m),
            scale: vec![1.0; m],
            tmp: vec![0.0; m],
            chol: DenseCholesky::new(m),
            rhs: vec![0.0; m],
            unit: vec![0.0; m],
            void: vec![false; m],
            lambda: vec![0.0; m],
            tol: 1e-13 * scale.max(1.0),
            projection_iterations: 0,
            drift_max: 0.0,
            void_max: 0,
            void_start: None,
        })
    }

    /// Save or load (for a checkpoint) the statistics; the buffers are remade at every
    /// evaluation.
    pub(crate) fn persist(&mut self, v: &mut dyn StateVisitor) {
        persist::u64(
            v,
            "loop_projection_iterations",
            &mut self.projection_iterations,
        );
        persist::f64(v, "loop_drift_max", &mut self.drift_max);
        let mut r = self.void_max as u64;
        persist::u64(v, "loop_void_max", &mut r);
        self.void_max = r as usize;
        let mut s = self.void_start.map_or(u64::MAX, |s| s as u64);
        persist::u64(v, "loop_void_start", &mut s);
        self.void_start = (s != u64::MAX).then_some(s as usize);
    }

    /// Scatter the multipliers of the last [`Loops::accelerations`] into `lambda` (one
    /// per layout row; the tree rows' stay as they are).
    pub(crate) fn multipliers(&self, nat: &Natural, lambda: &mut [f64]) {
        for ((&r, l), v) in nat.tree.cut_rows.iter().zip(&self.lambda).zip(&self.void) {
            lambda[r] = if *v { 0.0 } else { *l };
        }
    }

    /// A stage derivative's state and accelerations: `(pose, vel)` projected onto every
    /// joint in place ([`Loops::project`]), then the accelerations there
    /// ([`Loops::accelerations`]) into `out` (see the module doc: the right-hand side is
    /// `f(P(y))`). Does not allocate.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn stage<S: System>(
        &mut self,
        nat: &mut Natural,
        sys: &S,
        t: f64,
        pose: &mut [Pose],
        vel: &mut [Twist],
        out: &mut [Twist],
    ) -> Result<(), StepError> {
        let factored = self.project(nat, sys, t, pose, vel, false)?;
        self.accelerations(nat, sys, t, pose, vel, out, factored)
    }

    /// The body accelerations at `(t, pose, vel)` with the cut rows' index-1 multipliers
    /// (see the module doc) into `out` (body order); `factored`: `G` is factored at these
    /// positions already. Does not allocate.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn accelerations<S: System>(
        &mut self,
        nat: &mut Natural,
        sys: &S,
        t: f64,
        pose: &[Pose],
        vel: &[Twist],
        out: &mut [Twist],
        factored: bool,
    ) -> Result<(), StepError> {
        // (the same joint blocks and factorization of AᵀMA as the projection's last: `G`'s
        // factorization stays valid)
        nat.tree_accelerations(sys, t, pose, vel, out)?;
        let need = Need {
            phi: false,
            jac: true,
            gamma: true,
        };
        sys.constraints(t, pose, vel, need, &mut self.ce);
        let layout = sys.layout();
        if !factored {
            self.matrix(nat, layout, Rows::All)?;
        }
        for (i, &r) in nat.tree.cut_rows.iter().enumerate() {
            self.rhs[i] = if nat.active[r] {
                cut_row_times(layout, r, &self.ce.jac, &nat.tree.pos, |q| nat.nodes[q].a0)
                    - self.ce.gamma[r]
            } else {
                0.0
            };
        }
        self.solve();
        self.lambda.copy_from_slice(&self.rhs);
        respond(nat, layout, &self.ce.jac, &self.lambda);
        for (p, l) in nat.tree.links.iter().enumerate() {
            let n = &nat.nodes[p];
            out[l.body] = Twist {
                v: n.a0.v - n.acc.v,
                w: n.a0.w - n.acc.w,
            };
        }
        Ok(())
    }

    /// Put `(pose, vel)` at time `t` back on every joint (see the module doc); `step_end`:
    /// the state is a step's result (its drift and iterations go to the statistics).
    /// Returns whether `G` over all rows is factored at the final positions. Does not
    /// allocate. Errors: the position Newton iteration does not reach round-off (a
    /// singular configuration, or a state far off the loops), naming the worst row.
    pub(crate) fn project<S: System>(
        &mut self,
        nat: &mut Natural,
        sys: &S,
        t: f64,
        pose: &mut [Pose],
        vel: &mut [Twist],
        step_end: bool,
    ) -> Result<bool, StepError> {
        let layout = sys.layout();
        let holonomic = nat
            .tree
            .cut_rows
            .iter()
            .any(|&r| nat.active[r] && layout.row_kind[r] == RowKind::Holonomic);
        let mut it = 0;
        let mut last = f64::INFINITY;
        loop {
            nat.project_positions(sys, pose);
            if !holonomic {
                break;
            }
            let need = Need {
                phi: true,
                jac: true,
                gamma: false,
            };
            sys.constraints(t, pose, vel, need, &mut self.ce);
            let (mut worst, mut res) = (0, 0.0f64);
            for (i, &r) in nat.tree.cut_rows.iter().enumerate() {
                let take = nat.active[r] && layout.row_kind[r] == RowKind::Holonomic;
                self.rhs[i] = if take { self.ce.phi[r] } else { 0.0 };
                if self.rhs[i].abs() > res {
                    (worst, res) = (r, self.rhs[i].abs());
                }
            }
            if it == 0 && step_end {
                self.drift_max = self.drift_max.max(res);
            }
            // converged, or at round-off (no longer halving, below 10³ × the tolerance)
            if res <= self.tol || (res > 0.5 * last && res <= 1e3 * self.tol) {
                break;
            }
            last = res;
            if it == MAX_PROJECTION {
                return Err(StepError::NoConvergence {
                    what:
                        "the projection onto the closed loops (Newton on the cut joints' positions)",
                    iterations: it,
                    residual: res,
                    row: Some(worst),
                });
            }
            it += 1;
            nat.kinematics(sys, pose);
            factor_tree(nat)?;
            self.matrix(nat, layout, Rows::Holonomic)?;
            self.solve();
            respond(nat, layout, &self.ce.jac, &self.rhs);
            for (p, l) in nat.tree.links.iter().enumerate() {
                let d = &nat.nodes[p].acc;
                pose[l.body] = rotate_body(&pose[l.body], -d.v, -d.w);
            }
        }
        if step_end {
            self.projection_iterations += it as u64;
        }
        nat.kinematics(sys, pose);
        nat.project_velocities(pose, vel);
        if !nat.tree.cut_rows.iter().any(|&r| nat.active[r]) {
            return Ok(false);
        }
        sys.constraints(t, pose, vel, Need::JAC, &mut self.ce);
        factor_tree(nat)?;
        self.matrix(nat, layout, Rows::All)?;
        let tree = &nat.tree;
        for (i, &r) in tree.cut_rows.iter().enumerate() {
            self.rhs[i] = if nat.active[r] {
                cut_row_times(layout, r, &self.ce.jac, &tree.pos, |q| {
                    vel[tree.links[q].body]
                }) + self.ce.bias[r]
            } else {
                0.0
            };
        }
        self.solve();
        respond(nat, layout, &self.ce.jac, &self.rhs);
        for (p, l) in nat.tree.links.iter().enumerate() {
            let d = &nat.nodes[p].acc;
            vel[l.body].v -= d.v;
            vel[l.body].w -= d.w;
        }
        Ok(true)
    }

    /// `G x = rhs` in place, regularized (see [`Loops::matrix`]):
    /// `x = S (Ĝ² + δ²I)⁻¹ Ĝ S rhs`.
    fn solve(&mut self) {
        for (r, s) in self.rhs.iter_mut().zip(&self.scale) {
            *r *= s;
        }
        let m = self.rhs.len();
        for i in 0..m {
            self.tmp[i] = (0..m).map(|k| self.g[(i, k)] * self.rhs[k]).sum();
        }
        self.chol.solve_in_place(&mut self.tmp);
        for ((r, t), s) in self.rhs.iter_mut().zip(self.tmp.iter()).zip(&self.scale) {
            *r = t * s;
        }
    }

    /// Form `G` over `rows` (the others an identity block) at the factorization and joint
    /// blocks in the nodes and the Jacobian in `self.ce`, and factor it.
    ///
    /// The factored matrix is `Ĝ² + δ²I` (see the module doc), which never meets a zero
    /// pivot; dependent rows share their force. A row whose `Ĝ_ii` is at most
    /// [`DEFAULT_PIVOT_TOL`] is *void* here: the tree's motions cannot violate it (`Ĝ_ii`
    /// is the squared cosine, in the metric of `M`, between the row's constraint force and
    /// the tree's motions). Its
    /// multiplier moves nothing and is not determined: it is reported as zero
    /// ([`Loops::multipliers`]), but the dynamics keep it, so that they stay smooth as a
    /// row becomes void at a singular position.
    fn matrix(&mut self, nat: &mut Natural, layout: &Layout, rows: Rows) -> Result<(), StepError> {
        let Natural {
            tree,
            nodes,
            active,
            ..
        } = nat;
        let take =
            |r: usize| active[r] && (rows == Rows::All || layout.row_kind[r] == RowKind::Holonomic);
        let solver = Solver { tree };
        let m = tree.cut_rows.len();
        for k in 0..m {
            let rk = tree.cut_rows[k];
            if !take(rk) {
                for i in 0..m {
                    self.g[(i, k)] = if i == k { 1.0 } else { 0.0 };
                }
                continue;
            }
            self.unit.iter_mut().for_each(|u| *u = 0.0);
            self.unit[k] = 1.0;
            cut_response(
                &solver,
                nodes,
                layout,
                &tree.cut_rows,
                &self.ce.jac,
                &tree.pos,
                active,
                &self.unit,
            );
            for (i, &ri) in tree.cut_rows.iter().enumerate() {
                self.g[(i, k)] = if take(ri) {
                    cut_row_times(layout, ri, &self.ce.jac, &tree.pos, |q| nodes[q].acc)
                } else if i == k {
                    1.0
                } else {
                    0.0
                };
            }
        }
        // Ĝ = S G S with S = diag(B M⁻¹Bᵀ)^(−1/2): Ĝ_ii ≤ 1 is the reach of row i
        let mut void = 0;
        for i in 0..m {
            let r = tree.cut_rows[i];
            self.scale[i] = if take(r) {
                1.0 / k_diag(layout, &self.ce.jac[r], r).sqrt()
            } else {
                1.0
            };
        }
        for k in 0..m {
            for i in 0..m {
                self.g[(i, k)] *= self.scale[i] * self.scale[k];
            }
        }
        for i in 0..m {
            self.void[i] = take(tree.cut_rows[i]) && self.g[(i, i)] <= DEFAULT_PIVOT_TOL;
            void += self.void[i] as usize;
        }
        // H = Ĝ² + δ²I (Ĝ symmetric)
        self.g.mul_to(&self.g, &mut self.h);
        for i in 0..m {
            self.h[(i, i)] += REGULARIZATION * REGULARIZATION;
        }
        self.chol.factor(&self.h).map_err(|e| StepError::Linalg {
            what: "the cut-joint matrix G = (B_c A)(AᵀMA)⁻¹(B_c A)ᵀ of an explicit method",
            message: e.to_string(),
        })?;
        self.void_max = self.void_max.max(void);
        self.void_start.get_or_insert(void);
        Ok(())
    }
}

/// `Node::acc = R v = A(AᵀMA)⁻¹AᵀB_cᵀ v` per position, with the factorization in the nodes
/// and the cut rows' Jacobian `jac` (one tree solve).
fn respond(nat: &mut Natural, layout: &Layout, jac: &[RowJac], v: &[f64]) {
    let Natural {
        tree,
        nodes,
        active,
        ..
    } = nat;
    let solver = Solver { tree };
    cut_response(
        &solver,
        nodes,
        layout,
        &tree.cut_rows,
        jac,
        &tree.pos,
        active,
        v,
    );
}

/// Factor `AᵀMA` at the joint blocks in the nodes.
fn factor_tree(nat: &mut Natural) -> Result<(), StepError> {
    let solver = Solver { tree: &nat.tree };
    match solver.factor(&mut nat.nodes) {
        Some(p) => Err(StepError::Singular {
            what: "reduced mass AᵀMA (natural partitioning)",
            row: nat.tree.links[p].off,
        }),
        None => Ok(()),
    }
}
