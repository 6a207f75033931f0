//! Subcycling: the flexible beams' nodes advanced with their own step `h/N` inside each step
//! `h` of the rigid bodies (`beam_substeps N` of `staggered`; docs/methods.md, "Beams:
//! subcycling"). A multi-rate form of the staggered scheme, so that one stiff beam does not
//! make every rigid body and joint take the beam's step.
//!
//! **Partition.** The beams' nodes are the *fast* bodies, every other body is *slow*. A
//! *fast joint* is one that touches a fast body: the beams' own clamps and pins (`fixed` and
//! `spherical` rows, evaluated here by the joint kernels themselves, not through the
//! system, so a substep never evaluates the rigid joints).
//!
//! **One step from τ to τ + h** (the caller, [`super::staggered`], does 1 and 3):
//! 1. the staggered step of the whole system at step h: forces at τ (the beams' elastic
//!    forces included), the LINT solved for every row with the coordinate update of every
//!    body. The slow bodies keep its result: their positions at τ + h and velocities at
//!    τ + h/2. The fast rows' multipliers of this solve are the beams' forces on the slow
//!    bodies: with the node's predicted motion tied to the body's, they carry the element
//!    forces at τ and the node's inertia, as if the node were lumped into the body;
//! 2. [`Subcycle::run`]: N substeps of the fast bodies from the positions at τ and their own
//!    half-step velocities at τ − h/(2N). The slow bodies move along the parabola through
//!    their positions at τ − h, τ and τ + h (`Subcycle::place_slow`), so the fast joints
//!    see them at every substep's time; within a substep the fast joints' multipliers are
//!    solved by the same exact LINT, with the slow bodies prescribed (infinite mass).
//!    Prescribed sides make the fast joints independent except through a shared fast body:
//!    each group of joints so linked (a *component*: one clamp, or one pin) is a small
//!    dense matrix `E + (h/N)² B M⁻¹ Bᵀ`, Cholesky-factored per substep. The elements are
//!    evaluated after every substep;
//! 3. the fast bodies' positions and velocities replace the step's prediction.
//!
//! With N = 1 this is not used: the step is the staggered method's unchanged.
//!
//! **Cost.** A substep evaluates the applied forces of the system (it has no per-body
//! evaluation), the elements and the fast joints; it does not evaluate the rigid joints nor
//! factor their matrix.
//!
//! **Stability.** The substep must be below the beam's limit; the step h below the limit
//! of each body's coupling to the elements clamped or pinned to it
//! ([`super::beam_coupling_limit`]). And the beam needs some stiffness-proportional
//! damping: without it, its highest modes grew on models/arm_probe.mbd (the body takes the
//! beam's force at the knots only, and those modes are far above the rigid step's
//! resolution); with a damping ratio of 0.07 at its highest element mode the run was
//! stable and within 6 µm of the uniform-step answer, with 0.014 it blew up at 0.3 s. A
//! run is refused below [`MIN_DAMPING_RATIO`]. All three are checked before the run.
//!
//! Does not allocate in a step.

use crate::contract::joint_geom::JointGeom;
use crate::contract::joint_kernel::JointKernel;
use crate::contract::persist::{self, StateVisitor};
use crate::contract::system::{
    ConstraintEval, Layout, MassProps, Need, Pose, RowKind, System, Twist, Wrench,
};
use crate::integrators::beam_forces::BeamForces;
use crate::integrators::common::{accel, add6};
use crate::integrators::StepError;
use crate::kernels::joints::{self, JointOut};

/// The least damping ratio `βω/2` a subcycled beam must have at its highest element mode
/// ω (see the module doc): 0.1, against the 0.07 measured stable and 0.014 unstable.
pub const MIN_DAMPING_RATIO: f64 = 0.1;

/// Newton iterations of a substep's LINT before it fails.
const MAX_NEWTON: u32 = 25;

/// A joint that touches a fast body.
#[derive(Clone, Copy, Debug)]
struct FastJoint {
    kernel: JointKernel,
    geom: JointGeom,
    a: Option<usize>,
    b: Option<usize>,
    first_row: usize,
    rows: usize,
}

/// Fast joints linked through shared fast bodies, with their dense LINT matrix.
#[derive(Clone, Debug)]
struct Component {
    /// The layout rows of its joints, in order.
    rows: Vec<usize>,
    /// Where its `rows.len()²` matrix starts in [`Subcycle::mat`].
    at: usize,
}

/// The substep machinery of a staggered integrator with `beam_substeps` > 1.
#[derive(Clone, Debug)]
pub struct Subcycle {
    n: u32,
    /// Per body: a beam node.
    fast: Vec<bool>,
    fast_bodies: Vec<usize>,
    slow_bodies: Vec<usize>,
    joints: Vec<FastJoint>,
    comps: Vec<Component>,
    /// Packed dense matrices of the components (Cholesky factors after factoring).
    mat: Vec<f64>,
    /// Per layout row: the substep multipliers (fast rows) and those of the substep before.
    lambda: Vec<f64>,
    lambda_prev: Vec<f64>,
    /// Per layout row: the substeps' regularization.
    e: Vec<f64>,
    ce: ConstraintEval,
    ce_trial: ConstraintEval,
    /// Working configuration of every body at the substep's time.
    pose: Vec<Pose>,
    vel: Vec<Twist>,
    /// Every body's position at the step's start.
    start: Vec<Pose>,
    /// Per body: its velocity before the step's kick (at τ − h/2; slow bodies' path).
    vel_before: Vec<Twist>,

    /// Per fast body: its mean velocity over the last step (the secant of its positions
    /// at the step's ends; the rotation's by the inverse Cayley map): the velocity at
    /// τ − h/2 the whole-system solve gives it, in step with the slow bodies' half-step
    /// velocities (indexed like `fast_bodies`).
    secant: Vec<Twist>,
    applied: Vec<Wrench>,
    flam: Vec<Wrench>,
    /// The fast bodies' trial configuration (indexed like `fast_bodies`).
    trial_pose: Vec<Pose>,
    trial_vel: Vec<Twist>,
    /// The fast bodies' velocities one substep before the last (synchronized output).
    vel_before_last: Vec<Twist>,
    res: Vec<f64>,
    tol: f64,
    substeps: u64,
    iterations: u64,
    max_iterations: u32,
}

/// What the staggered integrator hands a substep: its coordinate update of one body over a
/// step (mass, net force `Q̄ − Bᵀλ` split as `(Q̄, Bᵀλ)`, position, velocity, step).
pub type Kick<'k> = &'k dyn Fn(&MassProps, &Wrench, &Wrench, &Pose, &Twist, f64) -> (Pose, Twist);

impl Subcycle {
    /// The partition of `sys` for `n` substeps. `e` is the staggered step's regularization
    /// per row; `scale_e` whether it follows the step (the default rule, `∝ h²`: the
    /// substeps use `e/n²`) or is the user's ε (used as is). `tol` is the Newton tolerance.
    /// Refuses a fast joint that is not a `fixed` or `spherical` holonomic joint (the beams'
    /// clamps and pins), naming it.
    pub fn new<S: System>(
        sys: &S,
        n: u32,
        e: &[f64],
        scale_e: bool,
        tol: f64,
    ) -> Result<Subcycle, String> {
        let layout = sys.layout();
        let nb = layout.bodies();
        let mut fast = vec![false; nb];
        for b in &layout.beams.beams {
            for k in 0..=b.elements {
                fast[b.first_body + k] = true;
            }
        }
        let mut joints = Vec::new();
        for (ji, j) in layout.joints.iter().enumerate() {
            let touches = j.a.into_iter().chain(j.b).any(|b| fast[b]);
            if !touches {
                continue;
            }
            let name = &j.name;
            let (kernel, geom) = sys
                .tree_joint(ji)
                .filter(|(k, _)| matches!(k, JointKernel::Fixed | JointKernel::Spherical))
                .ok_or_else(|| {
                    format!("joint '{name}' acts on a beam node and is not a beam's clamp or pin: `beam_substeps` advances beams whose nodes are held only by their own `clamp` and `pin`")
                })?;
            if (j.first_row..j.first_row + j.rows).any(|r| layout.row_kind[r] != RowKind::Holonomic)
            {
                return Err(format!(
                    "joint '{name}' acts on a beam node with velocity rows: `beam_substeps` needs holonomic attachments"
                ));
            }
            joints.push(FastJoint {
                kernel,
                geom: *geom,
                a: j.a,
                b: j.b,
                first_row: j.first_row,
                rows: j.rows,
            });
        }
        // components: joints linked through a shared fast body (union–find on joints)
        let mut parent: Vec<usize> = (0..joints.len()).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        let mut owner: Vec<Option<usize>> = vec![None; nb];
        for (k, j) in joints.iter().enumerate() {
            for b in j.a.into_iter().chain(j.b).filter(|&b| fast[b]) {
                match owner[b] {
                    None => owner[b] = Some(k),
                    Some(o) => {
                        let (x, y) = (root(&mut parent, o), root(&mut parent, k));
                        parent[x] = y;
                    }
                }
            }
        }
        let mut comps: Vec<Component> = Vec::new();
        let mut comp_of_root = vec![usize::MAX; joints.len()];
        for k in 0..joints.len() {
            let r = root(&mut parent, k);
            if comp_of_root[r] == usize::MAX {
                comp_of_root[r] = comps.len();
                comps.push(Component {
                    rows: Vec::new(),
                    at: 0,
                });
            }
            let j = joints[k];
            comps[comp_of_root[r]]
                .rows
                .extend(j.first_row..j.first_row + j.rows);
        }
        let mut at = 0;
        for c in &mut comps {
            c.at = at;
            at += c.rows.len() * c.rows.len();
        }
        let m = layout.rows;
        let scale = if scale_e {
            1.0 / (n as f64 * n as f64)
        } else {
            1.0
        };
        let fast_bodies: Vec<usize> = (0..nb).filter(|&b| fast[b]).collect();
        let nf = fast_bodies.len();
        Ok(Subcycle {
            n,
            slow_bodies: (0..nb).filter(|&b| !fast[b]).collect(),
            fast,
            fast_bodies,
            joints,
            comps,
            mat: vec![0.0; at],
            lambda: vec![0.0; m],
            lambda_prev: vec![0.0; m],
            e: e.iter().map(|e| e * scale).collect(),
            ce: ConstraintEval::new(m),
            ce_trial: ConstraintEval::new(m),
            pose: vec![Pose::default(); nb],
            vel: vec![Twist::default(); nb],
            start: vec![Pose::default(); nb],
            vel_before: vec![Twist::default(); nb],
            secant: vec![Twist::default(); nf],
            applied: vec![Wrench::default(); nb],
            flam: vec![Wrench::default(); nb],
            trial_pose: vec![Pose::default(); nf],
            trial_vel: vec![Twist::default(); nf],
            vel_before_last: vec![Twist::default(); nf],
            res: vec![0.0; m],
            tol,
            substeps: 0,
            iterations: 0,
            max_iterations: 0,
        })
    }

    /// Substeps per step.
    pub fn substeps(&self) -> u32 {
        self.n
    }

    /// Whether body `b` is a beam node (advanced by the substeps).
    pub fn is_fast(&self, b: usize) -> bool {
        self.fast[b]
    }

    /// The fast bodies (beam nodes).
    pub fn fast_bodies(&self) -> &[usize] {
        &self.fast_bodies
    }

    /// Start: the multipliers of the first staggered solve, and the fast bodies'
    /// velocities half a step back as the whole-system start made them (their first
    /// secant velocities).
    pub fn start(&mut self, lambda: &[f64], vel: &[Twist]) {
        self.lambda.copy_from_slice(lambda);
        self.lambda_prev.copy_from_slice(lambda);
        for (s, &b) in self.secant.iter_mut().zip(&self.fast_bodies) {
            *s = vel[b];
        }
    }

    /// Remember the configuration at the step's start τ (before the whole-system solve
    /// overwrites it): the positions and the fast bodies' half-substep velocities; then
    /// give the fast bodies in `vel` their secant velocities of the last step for the
    /// whole-system solve. Their own half-substep velocity at τ − h/(2N) is ahead of the
    /// slow bodies' at τ − h/2 by half a step of the motion: in that solve the clamp's
    /// multiplier would then carry only half the node's inertia to the body.
    pub fn begin(&mut self, pose: &[Pose], vel: &mut [Twist]) {
        self.start.copy_from_slice(pose);
        self.pose.copy_from_slice(pose);
        self.vel.copy_from_slice(vel);
        for (s, &b) in self.secant.iter().zip(&self.fast_bodies) {
            vel[b] = *s;
        }
    }

    /// The N substeps from τ to τ + `h` (see the module doc). `pose`/`vel` hold the
    /// whole-system step's result: the slow bodies' are kept (and define their path), the
    /// fast bodies' are overwritten by the substeps'. `lambda0` are the start multipliers
    /// (the staggered law `E(λ − λ⁰) = Φ`), `active` the rows in force.
    #[allow(clippy::too_many_arguments)]
    pub fn run<S: System>(
        &mut self,
        sys: &S,
        tau: f64,
        h: f64,
        kick: Kick<'_>,
        beams: &mut BeamForces,
        lambda0: &[f64],
        active: &[bool],
        pose: &mut [Pose],
        vel: &mut [Twist],
    ) -> Result<(), StepError> {
        let n = self.n;
        let hs = h / n as f64;
        for &b in &self.slow_bodies {
            self.vel_before[b] = self.vel[b];
            self.vel[b] = vel[b];
        }
        for k in 0..n {
            let t = tau + k as f64 * hs;
            if k + 1 == n {
                for (i, &b) in self.fast_bodies.iter().enumerate() {
                    self.vel_before_last[i] = self.vel[b];
                }
            }
            self.substep(sys, t, hs, k, h, kick, beams, lambda0, active, pose)?;
        }
        for (i, &b) in self.fast_bodies.iter().enumerate() {
            pose[b] = self.pose[b];
            vel[b] = self.vel[b];
            self.secant[i] = secant(&self.start[b], &pose[b], h);
        }
        Ok(())
    }

    /// The slow bodies at `s` × the step into it: on the parabola through their positions
    /// at τ − h, τ and τ + h (the leapfrog's, whose velocities `v⁻` before and `v⁺` after
    /// the kick at τ are the secants): `r(τ + sh) = r + sh(v⁺ + v⁻)/2 + s²h(v⁺ − v⁻)/2`,
    /// and the rotation likewise on the rotation vectors, in body axes at τ, of the
    /// Cayley steps back and forth (`4 atan(h|ω|/4) ω̂`). The leapfrog's own path (the
    /// straight chord at constant velocity) cuts inside a curved path by `(ωh)²R/8`, and
    /// its velocity jumps at every knot: a stiff beam clamped to such a body was kicked
    /// at the rigid step's rate, and the body, which samples the beam's force at the
    /// knots only, saw a biased force (the arm of models/arm_probe.mbd was 4 cm off the
    /// uniform-step answer at 16 substeps, 6 µm on the parabola).
    fn place_slow(&mut self, end: &[Pose], s: f64, h: f64) {
        use crate::contract::math::{axis_angle, qmul};
        for &b in &self.slow_bodies {
            self.pose[b] = if s == 1.0 {
                end[b]
            } else {
                let (p, v0, v1) = (&self.start[b], &self.vel_before[b], &self.vel[b]);
                let ahead = cayley_turn(&v1.w, h);
                // `s² − s`: zero at both knots, the parabola's departure from the chord
                let bend = 0.5 * (s * s - s);
                let r = p.r + v1.v * (s * h) + (v1.v - v0.v) * (bend * h);
                let theta = ahead * s + (ahead - cayley_turn(&v0.w, h)) * bend;
                let q = qmul(&p.q, &axis_angle(&theta, theta.norm()));
                Pose {
                    r,
                    q,
                    c: crate::contract::math::rotation(&q),
                }
            };
        }
    }

    /// Evaluate the fast joints at `pose` into `ce` (`need`).
    fn eval_joints(
        joints: &[FastJoint],
        pose: &[Pose],
        vel: &[Twist],
        need: Need,
        ce: &mut ConstraintEval,
    ) {
        let ground = Pose::default();
        let still = Twist::default();
        for j in joints {
            let pa = j.a.map_or(&ground, |b| &pose[b]);
            let pb = j.b.map_or(&ground, |b| &pose[b]);
            let ta = j.a.map_or(&still, |b| &vel[b]);
            let tb = j.b.map_or(&still, |b| &vel[b]);
            let out = JointOut::new(ce, j.first_row, j.rows);
            match j.kernel {
                JointKernel::Fixed => joints::fixed(&j.geom, pa, pb, ta, tb, need, out),
                _ => joints::spherical(&j.geom, pa, pb, ta, tb, need, out),
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn substep<S: System>(
        &mut self,
        sys: &S,
        t: f64,
        hs: f64,
        k: u32,
        h: f64,
        kick: Kick<'_>,
        beams: &mut BeamForces,
        lambda0: &[f64],
        active: &[bool],
        end: &[Pose],
    ) -> Result<(), StepError> {
        let layout = sys.layout();
        let n = self.n as f64;
        // the forces on the fast bodies at t (the working array holds the slow bodies at
        // t: the start's positions from `begin`, then the last substep's placement)
        sys.applied(t, &self.pose, &self.vel, &mut self.applied);
        beams.add_to(&mut self.applied);
        Self::eval_joints(&self.joints, &self.pose, &self.vel, Need::ALL, &mut self.ce);
        self.factor(layout, hs, active)?;
        // warm start: λ(t) ≈ 2λ(t − hs) − λ(t − 2hs)
        for j in &self.joints {
            for r in j.first_row..j.first_row + j.rows {
                let (l1, l0) = (self.lambda[r], self.lambda_prev[r]);
                self.lambda_prev[r] = l1;
                self.lambda[r] = if active[r] { 2.0 * l1 - l0 } else { 0.0 };
            }
        }
        // the slow bodies at t + hs, where the trial is compared with them
        self.place_slow(end, (k + 1) as f64 / n, h);
        let extent = self
            .fast_bodies
            .iter()
            .fold(0.0f64, |a, &b| a.max(self.pose[b].r.norm()));
        let tol = self.tol * (1.0 + extent);
        let mut prev = f64::INFINITY;
        let mut converged = None;
        for it in 0..MAX_NEWTON {
            // Bᵀλ on the fast bodies, their trial update
            for &b in &self.fast_bodies {
                self.flam[b] = Wrench::default();
            }
            for j in &self.joints {
                for r in j.first_row..j.first_row + j.rows {
                    let (l, row) = (self.lambda[r], &self.ce.jac[r]);
                    for (side, blk) in [(j.a, &row.a), (j.b, &row.b)] {
                        if let Some(b) = side.filter(|&b| self.fast[b]) {
                            add6(&mut self.flam[b], blk, l);
                        }
                    }
                }
            }
            for (i, &b) in self.fast_bodies.iter().enumerate() {
                (self.trial_pose[i], self.trial_vel[i]) = kick(
                    &layout.mass[b],
                    &self.applied[b],
                    &self.flam[b],
                    &self.pose[b],
                    &self.vel[b],
                    hs,
                );
            }
            // Φ at the trial: the fast bodies' trial poses in the working array for the
            // evaluation, then back
            for (i, &b) in self.fast_bodies.iter().enumerate() {
                std::mem::swap(&mut self.pose[b], &mut self.trial_pose[i]);
            }
            Self::eval_joints(
                &self.joints,
                &self.pose,
                &self.vel,
                Need::PHI,
                &mut self.ce_trial,
            );
            for (i, &b) in self.fast_bodies.iter().enumerate() {
                std::mem::swap(&mut self.pose[b], &mut self.trial_pose[i]);
            }
            let mut worst: f64 = 0.0;
            for j in &self.joints {
                for r in j.first_row..j.first_row + j.rows {
                    self.res[r] = if active[r] {
                        self.ce_trial.phi[r] - self.e[r] * (self.lambda[r] - lambda0[r])
                    } else {
                        0.0
                    };
                    worst = worst.max(self.res[r].abs());
                }
            }
            if !worst.is_finite() {
                break;
            }
            if worst <= tol || (it >= 2 && worst <= 1e3 * tol && worst >= 0.5 * prev) {
                converged = Some(it);
                break;
            }
            prev = worst;
            self.solve_update();
        }
        let Some(it) = converged else {
            let worst = self
                .joints
                .iter()
                .flat_map(|j| j.first_row..j.first_row + j.rows)
                .map(|r| (r, self.res[r]))
                .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
            return Err(StepError::NoConvergence {
                what: "beam substep LINT Newton iteration",
                iterations: MAX_NEWTON,
                residual: worst.map_or(f64::NAN, |w| w.1),
                row: worst.map(|w| w.0),
            });
        };
        self.substeps += 1;
        self.iterations += it as u64;
        self.max_iterations = self.max_iterations.max(it);
        for (i, &b) in self.fast_bodies.iter().enumerate() {
            self.pose[b] = self.trial_pose[i];
            self.vel[b] = self.trial_vel[i];
        }
        // the elements at the new positions; their forces act in the next substep
        beams.update(&self.pose, &self.vel)
    }

    /// Assemble and factor every component's `E + hs² B M⁻¹ Bᵀ` (fast sides only).
    fn factor(&mut self, layout: &Layout, hs: f64, active: &[bool]) -> Result<(), StepError> {
        let h2 = hs * hs;
        for c in &self.comps {
            let nr = c.rows.len();
            let a = &mut self.mat[c.at..c.at + nr * nr];
            for (i, &r) in c.rows.iter().enumerate() {
                for (jx, &s) in c.rows.iter().enumerate().take(i + 1) {
                    let mut v = 0.0;
                    if active[r] && active[s] {
                        let (ra, rb) = layout.row_bodies(r);
                        let (sa, sb) = layout.row_bodies(s);
                        let (jr, js) = (&self.ce.jac[r], &self.ce.jac[s]);
                        for (br, blk_r) in [(ra, &jr.a), (rb, &jr.b)] {
                            let Some(br) = br.filter(|&b| self.fast[b]) else {
                                continue;
                            };
                            let w = minv6(&layout.mass[br], blk_r);
                            for (bs, blk_s) in [(sa, &js.a), (sb, &js.b)] {
                                if bs == Some(br) {
                                    v += blk_s.iter().zip(&w).map(|(x, y)| x * y).sum::<f64>();
                                }
                            }
                        }
                        v *= h2;
                    }
                    if i == jx {
                        v += if active[r] { self.e[r] } else { 1.0 };
                    }
                    a[i * nr + jx] = v;
                    a[jx * nr + i] = v;
                }
            }
            // Cholesky in place (lower triangle)
            for i in 0..nr {
                for jx in 0..=i {
                    let mut s = a[i * nr + jx];
                    for p in 0..jx {
                        s -= a[i * nr + p] * a[jx * nr + p];
                    }
                    if i == jx {
                        if !(s > 0.0 && s.is_finite()) {
                            return Err(StepError::Singular {
                                what: "beam substep LINT (εI + h²BM⁻¹Bᵀ of a clamp or pin)",
                                row: c.rows[i],
                            });
                        }
                        a[i * nr + i] = s.sqrt();
                    } else {
                        a[i * nr + jx] = s / a[jx * nr + jx];
                    }
                }
            }
        }
        Ok(())
    }

    /// `λ += A⁻¹ res` per component, with the factors of [`Self::factor`].
    fn solve_update(&mut self) {
        for c in &self.comps {
            let nr = c.rows.len();
            let a = &self.mat[c.at..c.at + nr * nr];
            // forward: L y = res (y in place of res)
            for i in 0..nr {
                let mut s = self.res[c.rows[i]];
                for p in 0..i {
                    s -= a[i * nr + p] * self.res[c.rows[p]];
                }
                self.res[c.rows[i]] = s / a[i * nr + i];
            }
            // backward: Lᵀ x = y
            for i in (0..nr).rev() {
                let mut s = self.res[c.rows[i]];
                for p in i + 1..nr {
                    s -= a[p * nr + i] * self.res[c.rows[p]];
                }
                self.res[c.rows[i]] = s / a[i * nr + i];
            }
            for &r in &c.rows {
                self.lambda[r] += self.res[r];
            }
        }
    }

    /// The fast body's velocity one substep before the last (for the synchronized
    /// velocity at the step's end), by its index among [`Self::fast_bodies`].
    pub fn vel_before_last(&self, i: usize) -> &Twist {
        &self.vel_before_last[i]
    }

    /// Save or load what a substep leaves for the next.
    pub fn persist(&mut self, v: &mut dyn StateVisitor) {
        v.f64s("sub.lambda", &mut self.lambda);
        v.f64s("sub.lambda_prev", &mut self.lambda_prev);
        persist::twists(v, "sub.secant", &mut self.secant);
        // the regularization follows the whole step's, which the start computed from the
        // state it was given: a restart from a later state must take the saved one
        v.f64s("sub.e", &mut self.e);
        persist::twists(v, "sub.vel_before_last", &mut self.vel_before_last);
        persist::u64(v, "sub.substeps", &mut self.substeps);
        persist::u64(v, "sub.iterations", &mut self.iterations);
        persist::u32(v, "sub.max_iterations", &mut self.max_iterations);
    }

    /// Statistics: substeps made, their mean and largest Newton iterations.
    pub fn stats(&self) -> [(&'static str, f64); 3] {
        [
            ("beam_substeps", self.n as f64),
            (
                "substep_newton_iterations_mean",
                self.iterations as f64 / self.substeps.max(1) as f64,
            ),
            ("substep_newton_iterations_max", self.max_iterations as f64),
        ]
    }
}

/// The rotation vector of the Cayley update over `h` with the angular velocity `w`:
/// angle `4 atan(h|w|/4)` about `w`.
fn cayley_turn(w: &nalgebra::Vector3<f64>, h: f64) -> nalgebra::Vector3<f64> {
    let n = w.norm();
    if n == 0.0 {
        nalgebra::Vector3::zeros()
    } else {
        w * (4.0 * (h * n / 4.0).atan() / n)
    }
}

/// The constant velocity that takes a body from `p0` to `p1` in `h` by the coordinate
/// update (`r + h v`, the Cayley rotation with `Δ = 1 + h²|ω|²/16`): the inverse of that
/// update. With `dq = q₀⁻¹q₁ = (w, v)`, `w ≥ 0`, the Cayley rotation has `tan(φ/2) = h|ω|/4`,
/// so `ω = (4/h) v/(1 + w)` (body components).
fn secant(p0: &Pose, p1: &Pose, h: f64) -> Twist {
    let dq = crate::contract::math::qmul(&p0.q.conjugate(), &p1.q);
    let (w, v) = if dq.w < 0.0 {
        (-dq.w, -dq.imag())
    } else {
        (dq.w, dq.imag())
    };
    Twist {
        v: (p1.r - p0.r) / h,
        w: v * (4.0 / (h * (1.0 + w))),
    }
}

/// `M⁻¹` applied to a Jacobian block `[v (3), ω (3)]` (body components for ω).
#[inline]
fn minv6(m: &MassProps, blk: &[f64; 6]) -> [f64; 6] {
    let a = accel(
        m,
        &Wrench {
            f: nalgebra::Vector3::new(blk[0], blk[1], blk[2]),
            t: nalgebra::Vector3::new(blk[3], blk[4], blk[5]),
        },
    );
    [a.v.x, a.v.y, a.v.z, a.w.x, a.w.y, a.w.z]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::math::{axis_angle, cayley_update, rotation};
    use nalgebra::Vector3;

    /// `secant` inverts the coordinate update: the velocity it gives takes `p0` to `p1` by
    /// `r + h v` and the Cayley rotation, to round-off, for turns up to near a half turn.
    #[test]
    fn secant_inverts_the_coordinate_update() {
        let q0 = axis_angle(&Vector3::new(0.3, -1.0, 0.4), 0.7);
        let p0 = Pose {
            r: Vector3::new(1.0, 2.0, -0.5),
            q: q0,
            c: rotation(&q0),
        };
        for (w, h) in [
            (Vector3::new(0.1, 0.2, -0.3), 1e-3),
            (Vector3::new(40.0, -10.0, 25.0), 0.05),
            (Vector3::new(0.0, 0.0, 0.0), 0.01),
        ] {
            let v = Vector3::new(0.5, -3.0, 2.0);
            let q1 = cayley_update(&p0.q, &w, h, false);
            let p1 = Pose {
                r: p0.r + v * h,
                q: q1,
                c: rotation(&q1),
            };
            let s = secant(&p0, &p1, h);
            assert!((s.v - v).norm() < 1e-12 * (1.0 + v.norm()), "{:?}", s.v);
            assert!(
                (s.w - w).norm() < 1e-10 * (1.0 + w.norm()),
                "{:?} against {w:?}",
                s.w
            );
            // and the Cayley rotation vector is the update's own turn
            let t = cayley_turn(&w, h);
            assert!((t.norm() - 4.0 * (h * w.norm() / 4.0).atan()).abs() < 1e-15);
        }
    }
}
