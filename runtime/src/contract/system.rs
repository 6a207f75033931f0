//! The `System` trait: the contract between a scene (interpreted from a [`Scene`] or
//! generated as specialized Rust) and the numerics (integrators, solvers, writers).
//!
//! A system is a set of rigid bodies with constant mass properties, a set of applied
//! force elements, and a set of constraint rows grouped by joint. Everything that does
//! not change during a run (sizes, masses, which bodies each row touches) is in the
//! [`Layout`], built once. Everything that changes is evaluated by the trait methods into
//! caller-owned, preallocated buffers, so that no allocation happens inside a time step.
//!
//! Coordinates (notes A §1.7, C §0): per body, the mass-centre position `r` and velocity
//! `v` in world components, the orientation quaternion `q` (body → world), and the
//! angular velocity `ω` in **body** components. The generalized velocity of body `i` is
//! `u̇ᵢ = (vᵢ, ωᵢ)` (6 numbers) and constraint Jacobian rows are written against it.
//!
//! Sign convention (notes A §0, C §0): `M u̇' + Bᵀλ = F`, with `λ = Φ/ε` for penalty forms.
//!
//! [`Scene`]: crate::contract::scene::Scene

use nalgebra::{Matrix3, Quaternion, Vector3};

pub use crate::contract::joint_geom::JointGeom;
pub use crate::contract::joint_kernel::JointKernel;

/// Position and orientation of a body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Mass-centre position, world components.
    pub r: Vector3<f64>,
    /// Orientation, unit quaternion body → world (`w, i, j, k`).
    pub q: Quaternion<f64>,
    /// Rotation matrix body → world, kept equal to `rotation(q)` by [`Pose::new`] and
    /// [`Pose::set_q`]. Cached because every kernel needs it.
    pub c: Matrix3<f64>,
}

impl Pose {
    /// A pose from position and quaternion (normalised here).
    pub fn new(r: Vector3<f64>, q: Quaternion<f64>) -> Pose {
        let mut p = Pose {
            r,
            q,
            c: Matrix3::identity(),
        };
        p.set_q(q);
        p
    }

    /// Set the orientation (normalised) and refresh the rotation matrix.
    #[inline]
    pub fn set_q(&mut self, q: Quaternion<f64>) {
        let n = q.norm();
        self.q = q / n;
        self.c = crate::contract::math::rotation(&self.q);
    }

    /// A world point from a body-frame point (relative to the mass centre).
    #[inline]
    pub fn point(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.r + self.c * p
    }
}

impl Default for Pose {
    fn default() -> Self {
        Pose {
            r: Vector3::zeros(),
            q: Quaternion::identity(),
            c: Matrix3::identity(),
        }
    }
}

/// Velocity of a body.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Twist {
    /// Mass-centre velocity, world components.
    pub v: Vector3<f64>,
    /// Angular velocity, body components.
    pub w: Vector3<f64>,
}

/// A generalized force on a body.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Wrench {
    /// Force at the mass centre, world components.
    pub f: Vector3<f64>,
    /// Torque about the mass centre, body components.
    pub t: Vector3<f64>,
}

/// Constant mass properties of one body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassProps {
    /// Mass.
    pub m: f64,
    /// Inertia tensor about the mass centre, body components.
    pub j: Matrix3<f64>,
    /// Its inverse, computed once.
    pub j_inv: Matrix3<f64>,
}

impl MassProps {
    /// Mass properties from mass and inertia; `None` if the inertia is singular.
    pub fn new(m: f64, j: Matrix3<f64>) -> Option<MassProps> {
        let j_inv = j.try_inverse()?;
        Some(MassProps { m, j, j_inv })
    }
}

/// Whether a constraint row is enforced at position or velocity level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowKind {
    /// `Φ(q, t) = 0`; the Jacobian is `∂Φ/∂q` mapped to `(v, ω)`.
    Holonomic,
    /// `Φ(q, u̇, t) = B(q) u̇ + b(q, t) = 0`.
    Nonholonomic,
}

/// Static description of one joint's rows.
#[derive(Clone, Debug, PartialEq)]
pub struct JointLayout {
    /// Joint name (for reports).
    pub name: String,
    /// Joint kind keyword (for reports).
    pub kind: &'static str,
    /// Body index of side a, `None` for ground.
    pub a: Option<usize>,
    /// Body index of side b, `None` for ground.
    pub b: Option<usize>,
    /// First row of this joint in the global row numbering.
    pub first_row: usize,
    /// Number of rows.
    pub rows: usize,
    /// Number of trailing nonholonomic rows.
    pub nonholonomic: usize,
    /// Rows start inactive (a lock that engages during the run).
    pub starts_inactive: bool,
}

/// Static layout of a system: sizes, masses and the constraint row structure.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// Body names.
    pub body_names: Vec<String>,
    /// Mass properties per body.
    pub mass: Vec<MassProps>,
    /// Joints (constraint row groups) in row order. Locks of rotational springs appear as
    /// extra 1-row joints after the scene's joints.
    pub joints: Vec<JointLayout>,
    /// Total constraint rows.
    pub rows: usize,
    /// Per row: the joint index it belongs to.
    pub row_joint: Vec<usize>,
    /// Per row: holonomic or nonholonomic.
    pub row_kind: Vec<RowKind>,
    /// The flexible beams whose nodes are among the bodies (empty for a rigid scene).
    pub beams: BeamLayout,
    /// The finite-element meshes (empty for a scene without meshes). Shared: it can be
    /// large, and the layout is copied (output writer, integrators).
    pub meshes: std::sync::Arc<super::mesh_layout::MeshLayout>,
}

/// The flexible beams of a system (notes B). Each beam node is one of the layout's bodies,
/// carrying its lumped share of the elements' mass and rotary inertia; what the integrator
/// adds is the elements' internal forces between consecutive nodes. Built once from a
/// scene by [`crate::analysis::beam_model`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BeamLayout {
    /// The beams, in scene order.
    pub beams: Vec<BeamInfo>,
    /// The elements of every beam, beam after beam, each beam's from its start.
    pub elements: Vec<BeamElementLayout>,
}

impl BeamLayout {
    /// Whether the system has no beam.
    pub fn is_empty(&self) -> bool {
        self.beams.is_empty()
    }
}

/// One beam of a [`BeamLayout`].
#[derive(Clone, Debug, PartialEq)]
pub struct BeamInfo {
    /// The beam's name.
    pub name: String,
    /// Its first element in [`BeamLayout::elements`].
    pub first_element: usize,
    /// Its number of elements (its nodes are one more).
    pub elements: usize,
    /// The body index of its first node; node `k` is body `first_body + k`.
    pub first_body: usize,
    /// Section properties (with the material), as the scene gives them.
    pub section: crate::contract::scene::Section,
    /// Stiffness-proportional damping coefficient β (s): damping resultants
    /// `β·diag(EA, GA₂, GA₃)·γ̇` and `β·diag(GJ, EI₂, EI₃)·κ̇`; 0 for none.
    pub damping: f64,
    /// Factor applied to the nodes' rotary inertia (1: the section's own).
    pub rotary_inertia_scale: f64,
}

/// One element of a [`BeamLayout`]: the beam it belongs to and its two node bodies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BeamElementLayout {
    /// Index into [`BeamLayout::beams`].
    pub beam: usize,
    /// Body indices of its nodes (start, end).
    pub nodes: [usize; 2],
}

impl Layout {
    /// Number of bodies.
    pub fn bodies(&self) -> usize {
        self.mass.len()
    }

    /// Bodies touched by row `r` (side a, side b); `None` for ground.
    #[inline]
    pub fn row_bodies(&self, r: usize) -> (Option<usize>, Option<usize>) {
        let j = &self.joints[self.row_joint[r]];
        (j.a, j.b)
    }
}

/// One constraint row's Jacobian: the blocks acting on side a's and side b's `(v, ω)`.
/// A ground side's block is never read.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RowJac {
    /// Block for body a: `[∂/∂v (3), ∂/∂ω (3)]`.
    pub a: [f64; 6],
    /// Block for body b.
    pub b: [f64; 6],
}

/// Which outputs of [`System::constraints`] a caller needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Need {
    /// Constraint values `phi`.
    pub phi: bool,
    /// Jacobian rows `jac` and the explicit time/velocity bias `bias`.
    pub jac: bool,
    /// Acceleration right-hand side `gamma` (needs the twists).
    pub gamma: bool,
}

impl Need {
    /// Everything.
    pub const ALL: Need = Need {
        phi: true,
        jac: true,
        gamma: true,
    };
    /// Values only.
    pub const PHI: Need = Need {
        phi: true,
        jac: false,
        gamma: false,
    };
    /// Jacobian and bias only.
    pub const JAC: Need = Need {
        phi: false,
        jac: true,
        gamma: false,
    };
}

/// Buffers filled by [`System::constraints`], one entry per row. Allocated once with
/// [`ConstraintEval::new`].
///
/// For a holonomic row `Φ(q, t)`: `phi = Φ`, `jac = B = ∂Φ/∂(v, ω)`, `bias = ∂Φ/∂t`, and
/// `gamma = c` such that `B u̇' = c ⇔ Φ̈ = 0`, i.e. `c = −(Ḃu̇ + 2∂Ḃ/∂t… + Φ_tt)` (notes A eq. 6).
///
/// For a nonholonomic row `Φ = B(q) u̇ + b(q, t)`: `phi = Φ` (a velocity residual),
/// `jac = B`, `bias = b`, and `gamma = c` such that `B u̇' = c ⇔ Φ̇ = 0`.
///
/// In both cases the velocity-level residual is `B u̇ + bias`.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstraintEval {
    /// Values.
    pub phi: Vec<f64>,
    /// Jacobian rows.
    pub jac: Vec<RowJac>,
    /// Explicit bias (see above).
    pub bias: Vec<f64>,
    /// Acceleration right-hand side.
    pub gamma: Vec<f64>,
}

impl ConstraintEval {
    /// Buffers for `rows` rows, zeroed.
    pub fn new(rows: usize) -> ConstraintEval {
        ConstraintEval {
            phi: vec![0.0; rows],
            jac: vec![RowJac::default(); rows],
            bias: vec![0.0; rows],
            gamma: vec![0.0; rows],
        }
    }
}

/// A multibody system the integrators can advance.
///
/// Implemented by [`crate::interp::Interp`] (from a `Scene`, at run time) and by generated
/// code (specialized at compile time). Both must give identical results for the same scene.
///
/// Implementations must not allocate in any method called during a time step.
pub trait System: Sync {
    /// The constant layout.
    fn layout(&self) -> &Layout;

    /// Initial state (poses and twists) as given in the scene.
    fn initial_state(&self, pose: &mut [Pose], twist: &mut [Twist]);

    /// Applied generalized forces at time `t`: gravity, point forces and torques, springs,
    /// dampers, contact. Excludes constraint forces and the gyroscopic term `ω × Jω`
    /// (integrators add that). `out` has one entry per body and is overwritten.
    fn applied(&self, t: f64, pose: &[Pose], twist: &[Twist], out: &mut [Wrench]);

    /// Evaluate the constraint rows at time `t`. Inactive rows (see [`Layout`]) are
    /// evaluated like the others; integrators mask them.
    fn constraints(
        &self,
        t: f64,
        pose: &[Pose],
        twist: &[Twist],
        need: Need,
        out: &mut ConstraintEval,
    );

    /// Potential energy of the conservative forces (gravity, springs), J.
    fn potential_energy(&self, t: f64, pose: &[Pose]) -> f64;

    /// Update the activity of lock rows after a step. `active` has one entry per row.
    /// Returns the index of a joint that changed, if any. The default has no locks.
    fn update_locks(
        &self,
        _pose: &[Pose],
        _twist: &[Twist],
        _active: &mut [bool],
    ) -> Option<usize> {
        None
    }

    /// Whether `applied` depends on the twists (dampers). Integrators use this to decide
    /// which velocity to pass (notes A §1.9: lagged velocity for damping).
    fn has_velocity_forces(&self) -> bool {
        true
    }

    /// Whether `applied` depends on the state at all (springs, dampers, contact, forces
    /// given in body axes). Implicit methods skip the force tangent when it does not.
    fn has_state_forces(&self) -> bool {
        true
    }

    /// Natural partitioning (notes C §1; `integrators::natural`): the kernel and geometry of
    /// layout joint `joint` when it is one of the tree-eligible kinds
    /// ([`JointKernel::is_tree`]: spherical, revolute, prismatic, cylindrical, universal,
    /// fixed, planar), `None` otherwise. The geometry must be the one the joint's
    /// constraint rows use: the method computes the joint's null-space blocks and position
    /// projection from it with the tree-joint kernels. Default: `None` for every joint,
    /// which makes `natural_partitioning` unavailable.
    fn tree_joint(&self, _joint: usize) -> Option<(JointKernel, &JointGeom)> {
        None
    }

    /// The meshes' element loops chosen by generated code: a
    /// `mbdc_runtime::integrators::mesh_kernels::BlockKernels` (one monomorphized loop per
    /// block of [`Layout::meshes`], in block order), behind [`std::any::Any`] because this
    /// contract sits below the integrators that define it. The table cannot move down to
    /// this floor: each entry is a `fn(BlockArgs)`, and `BlockArgs` carries the integrators'
    /// assembler and the solid kernels' options, materials and plastic responses, none of
    /// which this floor may name. Its one reader, `integrators::make`, downcasts it and
    /// refuses a run when it is anything else. Default: `None`, and the integrators choose
    /// each block's loop from its kind at run time (the interpreter). Generated code
    /// overrides it only for scenes with meshes.
    fn mesh_kernels(&self) -> Option<&dyn std::any::Any> {
        None
    }

    /// The beams' element variants chosen by generated code: a
    /// `mbdc_runtime::integrators::beam_kernels::BeamKernels` (each variant its beams use,
    /// monomorphized: undamped, damped), behind [`std::any::Any`] for the reason
    /// [`System::mesh_kernels`] gives (an entry is a function of the element kernel's
    /// types, which this floor may not name). Its one reader, `BeamKernels::of_system`,
    /// downcasts it and refuses a run when it is anything else. Default: `None`, and the
    /// integrators choose each beam's variant from its damping at run time (the
    /// interpreter). Generated code overrides it only for scenes with beams.
    fn beam_kernels(&self) -> Option<&dyn std::any::Any> {
        None
    }

    /// The ranks of the distributed run that this system is one rank's part of (`mbdc run
    /// --mpi`): the mesh methods that run across ranks take their engine from here.
    /// Default: `None`, a run in one process.
    fn ranks(&self) -> Option<std::sync::Arc<dyn super::ranks::Ranks>> {
        None
    }
}
