//! The `Scene`: plain data, in SI units, that says exactly what is simulated.
//!
//! A `Scene` is produced by `mbdc_compiler::lower` from a `.mbd` file (or built by
//! hand in Rust) and consumed by the interpreter, the code generator and the
//! integrators. It is the single source of truth: nothing else carries physics.
//!
//! Conventions (used everywhere in the runtime):
//! - Vectors are `[f64; 3]`, quaternions `[w, x, y, z]` (Hamilton, unit, scalar first)
//!   mapping body components to world components.
//! - A body's reference point is its mass centre; body-frame points are relative to it.
//! - Angular velocity is stored in **body** components (as in the papers); translational
//!   velocity in world components.
//! - All quantities are SI: m, kg, s, N, rad.
//! - `Origin` tags let a front end map an item back to its source text. The runtime
//!   treats them as opaque numbers.

use serde::{Deserialize, Serialize};

/// A 3-vector in SI units.
pub type Vec3 = [f64; 3];
/// A unit quaternion `[w, x, y, z]` (body → world).
pub type Quat = [f64; 4];
/// A 3×3 matrix, row-major.
pub type Mat3 = [[f64; 3]; 3];

/// Where an item came from in the source text: file index and byte range.
/// Opaque to the runtime; front ends use it to point diagnostics at the text.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Origin {
    /// Index of the file in the front end's file table.
    pub file: u32,
    /// Start byte offset.
    pub start: u32,
    /// End byte offset (exclusive).
    pub end: u32,
}

/// A complete, validated scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    /// Model name (used for output folders and generated crate names).
    pub name: String,
    /// Uniform gravitational acceleration in world components, if the scene has gravity.
    pub gravity: Option<Vec3>,
    /// Rigid bodies. Index into this vector is the body index.
    pub bodies: Vec<Body>,
    /// Joints and other kinematic constraints (holonomic, rheonomic, nonholonomic).
    pub joints: Vec<Joint>,
    /// Applied forces, springs and dampers.
    pub forces: Vec<Force>,
    /// Flexible beams.
    pub beams: Vec<Beam>,
    /// Finite-element meshes.
    pub meshes: Vec<Mesh>,
    /// Contact pairs.
    pub contacts: Vec<Contact>,
    /// Simulation settings.
    pub simulate: Simulate,
    /// Optional reference solution used by accuracy reports.
    pub reference: Option<Reference>,
    /// The parameters the scene was lowered with (name, value in SI, unit text for display).
    /// Informational: their effect is already folded into the data above.
    pub params: Vec<ParamValue>,
}

/// A parameter value as used when lowering.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamValue {
    /// Parameter name.
    pub name: String,
    /// Value in SI units (scalars only; vector params are recorded component-wise as `name.x` etc.).
    pub value: f64,
    /// Overridden on the command line.
    pub overridden: bool,
}

/// Identifies a body or the ground in a joint or force.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum BodyRef {
    /// The fixed inertial frame.
    Ground,
    /// A body by index into `Scene::bodies`.
    Body(usize),
}

impl BodyRef {
    /// The body index, or `None` for ground.
    pub fn index(self) -> Option<usize> {
        match self {
            BodyRef::Ground => None,
            BodyRef::Body(i) => Some(i),
        }
    }
}

/// A rigid body.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Body {
    /// Unique name (indexed names are written `link[3]`, component members `arm.upper`).
    pub name: String,
    /// Mass in kg (> 0).
    pub mass: f64,
    /// Inertia tensor about the mass centre in body components, kg·m² (symmetric, positive definite).
    pub inertia: Mat3,
    /// Initial mass-centre position, world components.
    pub position: Vec3,
    /// Initial orientation, body → world.
    pub orientation: Quat,
    /// Initial mass-centre velocity, world components.
    pub velocity: Vec3,
    /// Initial angular velocity, **body** components.
    pub angular_velocity: Vec3,
    /// Source location.
    pub origin: Origin,
}

/// An attachment of a joint or force to a body: a point and a frame, in body components
/// relative to the mass centre (world components for ground).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Attachment {
    /// The body.
    pub body: BodyRef,
    /// Point, body components relative to the mass centre (world for ground), m.
    pub point: Vec3,
    /// Orientation of the joint frame relative to the body frame. The joint frame's z axis
    /// is the joint axis (hinge axis, slide direction, plane normal); x and y complete it.
    pub frame: Quat,
}

/// A kinematic constraint between two bodies (or a body and ground).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Joint {
    /// Unique name.
    pub name: String,
    /// What the joint constrains.
    pub kind: JointKind,
    /// First attachment (the "parent" side in a tree, when it matters).
    pub a: Attachment,
    /// Second attachment.
    pub b: Attachment,
    /// Source location.
    pub origin: Origin,
}

/// The joint library. Row counts are the number of scalar constraint equations.
///
/// Frame conventions: `za`, `xa`, `ya` are the joint-frame axes of attachment `a` in world
/// components, `pa` its point in world components (likewise for `b`), `d = pb − pa`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum JointKind {
    /// `pb = pa` (3 rows).
    Spherical,
    /// Spherical + `za ∥ zb` (5 rows): rotation about the common z axis only.
    Revolute,
    /// Translation along `za` only, no relative rotation (5 rows).
    Prismatic,
    /// Translation along and rotation about `za` (4 rows).
    Cylindrical,
    /// Spherical + `za ⟂ zb` (4 rows): the cross axes are `za` (on a) and `zb` (on b).
    Universal,
    /// No relative motion (6 rows).
    Fixed,
    /// `pb` stays in the plane through `pa` normal to `za`, `zb ∥ za` (3 rows).
    Planar,
    /// `|pb − pa| = length` (1 row).
    Distance {
        /// Distance in m (> 0).
        length: f64,
    },
    /// Prescribed relative rotation angle about the z axis of a revolute or cylindrical
    /// joint: `sin(θ − f(t)) = 0` with θ measured from `xa` to `xb` about `za` (1 row,
    /// rheonomic). The attachments are copied from the driven joint.
    DriveAngle {
        /// Index of the driven joint in `Scene::joints`.
        joint: usize,
        /// Prescribed angle in rad as a function of time.
        angle: Fn1,
    },
    /// Prescribed relative displacement along `za` of a prismatic or cylindrical joint:
    /// `za · d − f(t) = 0` (1 row, rheonomic).
    DriveDisplacement {
        /// Index of the driven joint in `Scene::joints`.
        joint: usize,
        /// Prescribed displacement in m as a function of time.
        displacement: Fn1,
    },
    /// A sphere fixed to body `a` (centre at `a.point`) rolls without slipping on the plane
    /// through `b.point` (ground) with normal `b` frame z. One holonomic row (contact:
    /// `n · (c − p0) − radius = 0`) and two nonholonomic rows (no slip of the contact point
    /// along the plane's x and y axes).
    Rolling {
        /// Sphere radius, m.
        radius: f64,
    },
    /// The material point `a.point` of body `a` moves with the prescribed world velocity
    /// `v(t)` (3 nonholonomic rows: `ṙ + ω × ρ − v(t) = 0`). `b` is ground.
    PointVelocity {
        /// Prescribed velocity, world components, m/s.
        velocity: [Fn1; 3],
    },
    /// The point `a.point` of body `a` stays on the world-plane curve `y = f(x)` (in the
    /// frame of `b`, ground: x along b's x axis, y along b's y axis) (1 holonomic row).
    Curve {
        /// The curve `y = f(x)`, m → m.
        curve: Fn1,
    },
}

impl JointKind {
    /// Number of scalar constraint rows.
    pub fn rows(&self) -> usize {
        match self {
            JointKind::Spherical => 3,
            JointKind::Revolute => 5,
            JointKind::Prismatic => 5,
            JointKind::Cylindrical => 4,
            JointKind::Universal => 4,
            JointKind::Fixed => 6,
            JointKind::Planar => 3,
            JointKind::Distance { .. } => 1,
            JointKind::DriveAngle { .. } => 1,
            JointKind::DriveDisplacement { .. } => 1,
            JointKind::Rolling { .. } => 3,
            JointKind::PointVelocity { .. } => 3,
            JointKind::Curve { .. } => 1,
        }
    }

    /// Number of nonholonomic (velocity-level) rows; they come last in the joint's rows.
    pub fn nonholonomic_rows(&self) -> usize {
        match self {
            JointKind::Rolling { .. } => 2,
            JointKind::PointVelocity { .. } => 3,
            _ => 0,
        }
    }

    /// Whether the constraint depends explicitly on time.
    pub fn is_rheonomic(&self) -> bool {
        matches!(
            self,
            JointKind::DriveAngle { .. }
                | JointKind::DriveDisplacement { .. }
                | JointKind::PointVelocity { .. }
        )
    }

    /// Short lowercase name as written in `.mbd` files.
    pub fn keyword(&self) -> &'static str {
        match self {
            JointKind::Spherical => "spherical",
            JointKind::Revolute => "revolute",
            JointKind::Prismatic => "prismatic",
            JointKind::Cylindrical => "cylindrical",
            JointKind::Universal => "universal",
            JointKind::Fixed => "fixed",
            JointKind::Planar => "planar",
            JointKind::Distance { .. } => "distance",
            JointKind::DriveAngle { .. } => "drive_angle",
            JointKind::DriveDisplacement { .. } => "drive_displacement",
            JointKind::Rolling { .. } => "rolling",
            JointKind::PointVelocity { .. } => "point_velocity",
            JointKind::Curve { .. } => "curve",
        }
    }
}

/// Frame in which a force or torque vector is given.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ForceFrame {
    /// World components.
    World,
    /// Body components (follows the body).
    Body,
}

/// An applied force element.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Force {
    /// Unique name.
    pub name: String,
    /// What it is.
    pub kind: ForceKind,
    /// Source location.
    pub origin: Origin,
}

/// Force elements.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ForceKind {
    /// A force `value(t)` (N) applied at `at.point` of `at.body`.
    Point {
        /// Body and point of application.
        at: Attachment,
        /// Force components as functions of time, N.
        value: [Fn1; 3],
        /// Frame of the components.
        frame: ForceFrame,
    },
    /// A pure torque `value(t)` (N·m) on a body.
    Torque {
        /// The body.
        body: BodyRef,
        /// Torque components as functions of time, N·m.
        value: [Fn1; 3],
        /// Frame of the components.
        frame: ForceFrame,
    },
    /// Translational spring–damper along the line between two points:
    /// `f = k (ℓ − ℓ0) + c ℓ̇` pulling the points together when positive.
    Spring {
        /// First end.
        a: Attachment,
        /// Second end.
        b: Attachment,
        /// Stiffness, N/m (≥ 0).
        stiffness: f64,
        /// Rest length, m (≥ 0).
        rest_length: f64,
        /// Damping, N·s/m (≥ 0).
        damping: f64,
    },
    /// Rotational spring–damper about the z axis of joint `joint` (revolute or
    /// cylindrical): torque `−k (θ − θ0) − c θ̇` on body b, reaction on body a.
    /// θ is measured continuously in (−2π, 2π) from the joint frames.
    RotationalSpring {
        /// Index of the joint whose axis and frames are used.
        joint: usize,
        /// Stiffness, N·m/rad (≥ 0).
        stiffness: f64,
        /// Rest angle, rad.
        rest_angle: f64,
        /// Damping, N·m·s/rad (≥ 0).
        damping: f64,
        /// Lock angle: once θ reaches it (moving towards it), the joint locks at that angle
        /// (a constraint row is added). `None`: never locks.
        lock_angle: Option<f64>,
    },
}

/// A function of one scalar variable (time `t` in s, or a coordinate `x` in m), in SI
/// units, as an expression tree. Evaluated with its first two derivatives by
/// [`crate::kernels::fn1`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Fn1 {
    /// A constant.
    Const(f64),
    /// The variable itself.
    Var,
    /// `a + b`.
    Add(Box<Fn1>, Box<Fn1>),
    /// `a − b`.
    Sub(Box<Fn1>, Box<Fn1>),
    /// `a · b`.
    Mul(Box<Fn1>, Box<Fn1>),
    /// `a / b`.
    Div(Box<Fn1>, Box<Fn1>),
    /// `−a`.
    Neg(Box<Fn1>),
    /// `a ^ n` for a constant exponent.
    Powf(Box<Fn1>, f64),
    /// A unary function.
    Unary(UnaryFn, Box<Fn1>),
    /// `min(a, b)`.
    Min(Box<Fn1>, Box<Fn1>),
    /// `max(a, b)`.
    Max(Box<Fn1>, Box<Fn1>),
    /// `smoothstep(a, x0, x1)`: 0 for a ≤ x0, 1 for a ≥ x1, cubic `3s² − 2s³` between.
    Smoothstep(Box<Fn1>, f64, f64),
    /// Piecewise-linear table `(x_i, y_i)` evaluated at `a`, constant beyond the ends.
    Table(Box<Fn1>, Vec<[f64; 2]>),
    /// Jacobi elliptic function `sn(a | m)` (parameter m = k²), for reference solutions.
    JacobiSn(Box<Fn1>, f64),
    /// Jacobi `cn(a | m)`.
    JacobiCn(Box<Fn1>, f64),
    /// Jacobi `dn(a | m)`.
    JacobiDn(Box<Fn1>, f64),
}

/// Unary functions available in `Fn1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum UnaryFn {
    /// sine
    Sin,
    /// cosine
    Cos,
    /// tangent
    Tan,
    /// arcsine
    Asin,
    /// arccosine
    Acos,
    /// arctangent
    Atan,
    /// square root
    Sqrt,
    /// exponential
    Exp,
    /// natural logarithm
    Ln,
    /// absolute value
    Abs,
    /// Heaviside step: 0 for x < 0, 1 for x ≥ 0.
    Step,
    /// `max(0, x)`.
    Ramp,
    /// hyperbolic tangent
    Tanh,
}

/// Beam cross-section properties (already combined with the material).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Section {
    /// Axial stiffness EA, N.
    pub ea: f64,
    /// Shear stiffness GA₂, N.
    pub ga2: f64,
    /// Shear stiffness GA₃, N.
    pub ga3: f64,
    /// Bending stiffness EI₂, N·m².
    pub ei2: f64,
    /// Bending stiffness EI₃, N·m².
    pub ei3: f64,
    /// Torsional stiffness GJ, N·m².
    pub gj: f64,
    /// Mass per length ρA, kg/m.
    pub rho_a: f64,
    /// Rotary inertia per length ρI (polar, about the axis), kg·m.
    pub rho_i: f64,
}

/// A flexible beam: a polyline of nodes with `elements` elements.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Beam {
    /// Unique name.
    pub name: String,
    /// Node positions (world, m) of the initial, undeformed centreline. `elements + 1` nodes.
    pub nodes: Vec<Vec3>,
    /// A vector in the plane of the section's local axis 2 (world), used to orient sections.
    pub up: Vec3,
    /// Section properties.
    pub section: Section,
    /// Attachments of beam nodes to bodies (or ground).
    pub attachments: Vec<BeamAttachment>,
    /// Stiffness-proportional damping coefficient β, s (0: undamped): the section resultants
    /// get `β` times the stiffness times the strain rate.
    #[serde(default)]
    pub damping: f64,
    /// Factor on the nodes' rotary inertia (≥ 1; 1: the section's own). Raising it lowers the
    /// beam's shear/rotary-inertia frequencies, and so raises its explicit step limit.
    #[serde(default = "one")]
    pub rotary_inertia_scale: f64,
    /// Initial velocity of the first node (world, m/s); the beam starts in the rigid motion
    /// of this and [`Beam::angular_velocity`].
    #[serde(default)]
    pub velocity: Vec3,
    /// Initial angular velocity of the whole beam (world, rad/s), a rigid rotation about its
    /// first node: node `k` starts with `velocity + ω × (x_k − x_0)` and angular velocity ω.
    #[serde(default)]
    pub angular_velocity: Vec3,
    /// Source location.
    pub origin: Origin,
}

fn one() -> f64 {
    1.0
}

/// How a beam node is attached.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BeamAttachment {
    /// Node index in the beam.
    pub node: usize,
    /// The body (point in body components) it is attached to.
    pub to: Attachment,
    /// Whether rotations are tied too (clamped, `fixed`) or only positions (`spherical`).
    pub clamped: bool,
}

/// Element kinds for meshes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ElementKind {
    /// 2-node bar (truss).
    Bar2,
    /// 3-node triangle, plane stress.
    Tri3PlaneStress,
    /// 3-node triangle, plane strain.
    Tri3PlaneStrain,
    /// 4-node quadrilateral, plane stress.
    Quad4PlaneStress,
    /// 4-node quadrilateral, plane strain.
    Quad4PlaneStrain,
    /// 4-node tetrahedron.
    Tet4,
    /// 8-node hexahedron.
    Hex8,
}

impl ElementKind {
    /// Nodes per element.
    pub fn nodes(self) -> usize {
        match self {
            ElementKind::Bar2 => 2,
            ElementKind::Tri3PlaneStress | ElementKind::Tri3PlaneStrain => 3,
            ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain | ElementKind::Tet4 => 4,
            ElementKind::Hex8 => 8,
        }
    }
    /// Spatial dimension of the element's displacement field.
    pub fn dim(self) -> usize {
        match self {
            ElementKind::Bar2 | ElementKind::Tet4 | ElementKind::Hex8 => 3,
            _ => 2,
        }
    }

    /// Local faces (3-D elements), edges (2-D elements) or end points (bars) as local node
    /// indices, ordered so that the normal points outward for a positively oriented
    /// element (counter-clockwise 2-D nodes; hex8 bottom face 0-1-2-3 counter-clockwise seen
    /// from above, top 4-5-6-7). [`NodeSet::faces`] refers to them by index in this list.
    pub fn faces(self) -> &'static [&'static [usize]] {
        match self {
            ElementKind::Bar2 => &[&[0], &[1]],
            ElementKind::Tri3PlaneStress | ElementKind::Tri3PlaneStrain => {
                &[&[0, 1], &[1, 2], &[2, 0]]
            }
            ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain => {
                &[&[0, 1], &[1, 2], &[2, 3], &[3, 0]]
            }
            ElementKind::Tet4 => &[&[0, 2, 1], &[0, 1, 3], &[1, 2, 3], &[0, 3, 2]],
            ElementKind::Hex8 => &[
                &[0, 3, 2, 1],
                &[4, 5, 6, 7],
                &[0, 1, 5, 4],
                &[1, 2, 6, 5],
                &[2, 3, 7, 6],
                &[3, 0, 4, 7],
            ],
        }
    }
}

/// An isotropic linear-elastic material, optionally elastoplastic (J2) for meshes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Young's modulus, Pa.
    pub e: f64,
    /// Poisson's ratio.
    pub nu: f64,
    /// Density, kg/m³.
    pub rho: f64,
    /// J2 (von Mises) plasticity with linear isotropic hardening (`plastic { ... }`);
    /// `None`: elastic. Meshes only (beams are elastic and refuse it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plastic: Option<Plasticity>,
}

/// J2 (von Mises) plasticity with linear isotropic hardening: the yield stress grows with
/// the equivalent plastic strain `ε̄ᵖ` as `σ_y(ε̄ᵖ) = σ_y0 + H ε̄ᵖ`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plasticity {
    /// Initial (uniaxial) yield stress `σ_y0`, Pa (> 0).
    pub yield_stress: f64,
    /// Linear isotropic hardening modulus `H`, Pa (≥ 0; 0 = perfectly plastic).
    pub hardening: f64,
}

/// A finite-element mesh with its boundary conditions and loads.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    /// Unique name.
    pub name: String,
    /// Element kind.
    pub kind: ElementKind,
    /// Material.
    pub material: Material,
    /// Thickness for 2-D elements (m) or cross-section area for bars (m²).
    pub thickness: f64,
    /// Node coordinates (world, m); 2-D meshes use z = 0.
    pub nodes: Vec<Vec3>,
    /// Element connectivity (node indices), `kind.nodes()` per element.
    pub elements: Vec<Vec<usize>>,
    /// Named node sets (sorted, unique node indices).
    pub node_sets: Vec<NodeSet>,
    /// Boundary conditions and loads, applied in order.
    pub conditions: Vec<MeshCondition>,
    /// Quadrature and strain measure of the elements (`integration`, `hourglass`,
    /// `strain`); absent in older scene files: full integration, small strain.
    #[serde(default)]
    pub formulation: MeshFormulation,
    /// Source location.
    pub origin: Origin,
}

/// How the elements of a mesh are evaluated: their quadrature and their strain measure.
/// Plain data; the runtime maps it to the kernels' options.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshFormulation {
    /// Quadrature (hex8 and quad4; the other kinds have one, exact, rule).
    pub integration: MeshIntegration,
    /// Strain measure and stress law.
    pub kinematics: MeshKinematics,
}

/// Quadrature of hex8 and quad4 elements.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum MeshIntegration {
    /// Full Gauss quadrature (2×2×2, 2×2).
    #[default]
    Full,
    /// Full quadrature with the B-bar (mean dilatation) volumetric strain, against
    /// volumetric locking as ν → 0.5.
    Bbar,
    /// One point (Flanagan–Belytschko uniform strain) with hourglass control.
    Reduced {
        /// The hourglass control.
        hourglass: HourglassControl,
    },
}

/// Flanagan–Belytschko hourglass control of one-point elements.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum HourglassControl {
    /// Forces proportional to the hourglass velocities (dissipative).
    Viscous {
        /// Dimensionless coefficient in (0, 1].
        coefficient: f64,
    },
    /// Forces proportional to the hourglass displacements (stores energy).
    Stiffness {
        /// Dimensionless coefficient in (0, 1].
        coefficient: f64,
    },
}

impl Default for HourglassControl {
    /// Viscous, 0.1 (the middle of the usual 0.05–0.15).
    fn default() -> Self {
        HourglassControl::Viscous { coefficient: 0.1 }
    }
}

/// Strain measure and stress law of a mesh's elements.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum MeshKinematics {
    /// Small strain, linear elastic (`strain small`).
    #[default]
    Small,
    /// Green–Lagrange strain, St Venant–Kirchhoff, total Lagrangian (`strain green`):
    /// exact under large rigid rotations.
    Green,
}

/// A named set of nodes (and the element faces/edges they bound, for tractions).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeSet {
    /// Name.
    pub name: String,
    /// Node indices, sorted and unique.
    pub nodes: Vec<usize>,
    /// Element faces (2-D: edges) whose nodes all lie in the set: (element, local face index).
    pub faces: Vec<(usize, usize)>,
}

/// Boundary conditions and loads on a mesh node set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum MeshCondition {
    /// All displacement components fixed on the set.
    Fixed {
        /// Node set index.
        set: usize,
    },
    /// Prescribed displacement `u(t)` on the set (components `None` are free).
    Displacement {
        /// Node set index.
        set: usize,
        /// Components, m.
        value: [Option<Fn1>; 3],
    },
    /// Force per node, N.
    NodalLoad {
        /// Node set index.
        set: usize,
        /// Components, N.
        value: [Fn1; 3],
    },
    /// Surface traction on the set's faces (2-D: force per area of edge × thickness), Pa.
    Traction {
        /// Node set index.
        set: usize,
        /// Components, Pa.
        value: [Fn1; 3],
    },
    /// Body force per volume over the whole mesh, N/m³.
    BodyForce {
        /// Components, N/m³.
        value: Vec3,
    },
    /// Winkler elastic foundation on the set's faces, N/m³ (force per area per displacement).
    Foundation {
        /// Node set index.
        set: usize,
        /// Modulus, N/m³.
        modulus: f64,
    },
    /// The set's nodes move rigidly with a body (`tie SET, BODY`): their offsets from the
    /// body's mass centre stay fixed in the body's axes as they are at t = 0, their mass
    /// moves to the body, and the mesh's net force on them acts on the body.
    Tie {
        /// Node set index.
        set: usize,
        /// Body index in `Scene::bodies`.
        body: usize,
    },
    /// The set is glued to a node set of another mesh along a common interface whose nodes
    /// need not match (`glue SET, MESH.SET { traction ... }`): the interface traction is
    /// written in a few parameters (reduced Lagrange multipliers, Farhat–Géradin; notes E
    /// §3) and the two displacement traces are equal in its weak sense.
    Glue {
        /// Node set index (this mesh).
        set: usize,
        /// The other mesh's index in `Scene::meshes`.
        mesh: usize,
        /// The node set index in the other mesh.
        other_set: usize,
        /// How the interface traction is approximated.
        traction: GlueTraction,
    },
}

/// The interface traction of a glue (`traction polynomial(degree: P)` or
/// `traction bessel(points: N)`; docs/methods.md "Meshes: glued by reduced multipliers").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GlueTraction {
    /// A polynomial of the given degree in the interface abscissa (RLM §3): `degree + 1`
    /// parameters per direction.
    Polynomial {
        /// Highest power (0: a constant traction).
        degree: u32,
    },
    /// Piecewise cubic with Bessel slopes through `points` equally spaced traction
    /// locations (RLM §4): `points` parameters per direction.
    Bessel {
        /// Number of traction locations (≥ 1).
        points: u32,
    },
}

impl Default for GlueTraction {
    fn default() -> Self {
        GlueTraction::Bessel { points: 5 }
    }
}

/// Contact geometry attached to a body.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Shape {
    /// Sphere of the given radius centred at the attachment point.
    Sphere {
        /// Radius, m.
        radius: f64,
    },
    /// Box with the given half extents, in the attachment frame.
    Box {
        /// Half extents, m.
        half_extents: Vec3,
    },
    /// Infinite plane through the attachment point with normal = attachment frame z.
    Plane,
}

/// A penalty contact pair.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    /// Unique name.
    pub name: String,
    /// First shape and where it sits.
    pub a: (Attachment, Shape),
    /// Second shape and where it sits.
    pub b: (Attachment, Shape),
    /// Normal penalty stiffness, N/m.
    pub stiffness: f64,
    /// Normal damping, N·s/m.
    pub damping: f64,
    /// Coulomb friction coefficient.
    pub friction: f64,
    /// Source location.
    pub origin: Origin,
}

/// Simulation settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Simulate {
    /// End time, s.
    pub duration: f64,
    /// Time step, s.
    pub step: f64,
    /// Integration method and its options.
    pub method: MethodSpec,
    /// How the finite-element meshes are analysed (absent in scenes written before it
    /// existed: the explicit central difference).
    #[serde(default)]
    pub mesh_method: MeshMethod,
    /// The linear solver of the implicit mesh analyses (absent: the direct factorization).
    #[serde(default, skip_serializing_if = "MeshSolver::is_direct")]
    pub mesh_solver: MeshSolver,
    /// Output settings.
    pub output: OutputSpec,
}

/// The linear solver of the implicit mesh analyses (`simulate { solver NAME { ... } }`;
/// docs/methods.md, "Meshes: FETI").
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MeshSolver {
    /// faer's sparse Cholesky of the assembled matrix, factored once.
    #[default]
    Direct,
    /// Finite Element Tearing and Interconnecting (Farhat–Roux, shared/notes/E §2): the
    /// meshes torn into subdomains, each factored on its own, glued by Lagrange multipliers
    /// found by preconditioned conjugate projected gradients.
    Feti(FetiOptions),
}

impl MeshSolver {
    /// Whether it is the direct factorization (the default).
    pub fn is_direct(&self) -> bool {
        matches!(self, MeshSolver::Direct)
    }

    /// The name as written in `.mbd` files.
    pub fn name(&self) -> &'static str {
        match self {
            MeshSolver::Direct => "direct",
            MeshSolver::Feti(_) => "feti",
        }
    }
}

/// Options of `solver feti { ... }`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FetiOptions {
    /// Number of subdomains (≥ 1; `subdomains P`).
    pub subdomains: u32,
    /// The interface preconditioner (`preconditioner dirichlet | lumped | none`).
    pub preconditioner: FetiPreconditioner,
    /// Stop when the projected interface residual `‖P r‖` has fallen by this factor from
    /// its start (`tolerance`).
    pub tolerance: f64,
    /// Refuse a solve that has not converged after this many iterations
    /// (`max_iterations`).
    pub max_iterations: u32,
}

impl Default for FetiOptions {
    fn default() -> Self {
        FetiOptions {
            subdomains: 4,
            preconditioner: FetiPreconditioner::Dirichlet,
            tolerance: 1e-10,
            max_iterations: 1000,
        }
    }
}

/// The FETI interface preconditioner.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FetiPreconditioner {
    /// `Σ B̃ₛ Sₛ B̃ₛᵀ` with each subdomain's interface Schur complement (one more
    /// factorization per subdomain, of its interior): iteration counts nearly independent
    /// of the number of subdomains.
    #[default]
    Dirichlet,
    /// `Σ B̃ₛ Kₛ B̃ₛᵀ` restricted to the interface (the papers' `Σ K_j^I`): no factorization,
    /// cheaper per iteration, more iterations.
    Lumped,
    /// No preconditioner.
    None,
}

impl FetiPreconditioner {
    /// The name as written in `.mbd` files.
    pub fn name(self) -> &'static str {
        match self {
            FetiPreconditioner::Dirichlet => "dirichlet",
            FetiPreconditioner::Lumped => "lumped",
            FetiPreconditioner::None => "none",
        }
    }
}

/// How the finite-element meshes of a scene are analysed (`simulate { mesh_method NAME }`;
/// docs/methods.md, "Meshes: implicit analyses").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MeshMethod {
    /// Explicit central difference (lumped mass, no linear solve, conditionally stable).
    #[default]
    CentralDifference,
    /// Implicit Newmark average acceleration (the trapezoidal rule): `K + (4/h²) M`
    /// factored once, unconditionally stable; linear elastic, small strain.
    Newmark,
    /// Linear static: `K u(t) = f(t)` solved at every step time (loads and prescribed
    /// displacements as functions of t), no inertia; linear elastic, small strain.
    Static,
}

impl MeshMethod {
    /// The name as written in `.mbd` files.
    pub fn name(self) -> &'static str {
        match self {
            MeshMethod::CentralDifference => "central_difference",
            MeshMethod::Newmark => "newmark",
            MeshMethod::Static => "static",
        }
    }

    /// All names, in documentation order.
    pub const NAMES: [&'static str; 3] = ["central_difference", "newmark", "static"];

    /// Whether it solves with the assembled stiffness (Newmark, static).
    pub fn is_implicit(self) -> bool {
        self != MeshMethod::CentralDifference
    }
}

impl Default for Simulate {
    fn default() -> Self {
        Simulate {
            duration: 1.0,
            step: 1e-3,
            method: MethodSpec::Staggered(StaggeredOptions::default()),
            mesh_method: MeshMethod::default(),
            mesh_solver: MeshSolver::default(),
            output: OutputSpec::default(),
        }
    }
}

/// Output settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutputSpec {
    /// Write a frame every this many steps (≥ 1).
    pub every: u32,
    /// Write body states (`bodies.csv`).
    pub bodies: bool,
    /// Write energy and momentum (`energy.csv`).
    pub energy: bool,
    /// Write constraint violations and multipliers (`constraints.csv`).
    pub constraints: bool,
    /// Which files hold the bodies', beams' and meshes' frames (absent in scenes written
    /// before it existed: the default).
    #[serde(default)]
    pub format: OutputFormat,
    /// Partitions writing `results.exo` (0: chosen from the frame's size and the machine).
    #[serde(default)]
    pub partitions: u32,
    /// When to write checkpoints (`checkpoint_every`, `checkpoint_seconds`,
    /// `keep_checkpoints`); the command line's options override each one. Left out of the
    /// restart identity's scene hash, so a run may change its cadence between restarts.
    #[serde(default, skip_serializing_if = "CheckpointOptions::is_none")]
    pub checkpoint: CheckpointOptions,
}

/// When a run writes checkpoints (`simulate { output { checkpoint_every N;
/// checkpoint_seconds T; keep_checkpoints K } }`; `--checkpoint-every`,
/// `--checkpoint-seconds`, `--keep-checkpoints` on the command line). No checkpoints unless
/// one of the two intervals is given.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CheckpointOptions {
    /// A checkpoint at the first output frame at least this many steps after the last.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub every_steps: Option<u64>,
    /// A checkpoint at the first output frame at least this many seconds of wall time after
    /// the last.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub every_seconds: Option<f64>,
    /// How many of the newest checkpoints to keep (default 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub keep: Option<u32>,
}

impl CheckpointOptions {
    /// No checkpoint options given.
    pub const NONE: CheckpointOptions = CheckpointOptions {
        every_steps: None,
        every_seconds: None,
        keep: None,
    };

    /// Whether no option is given.
    pub fn is_none(&self) -> bool {
        *self == CheckpointOptions::NONE
    }
}

/// The output format of a run (`simulate { output { format NAME } }`, `--format NAME`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutputFormat {
    /// The CSV files, and for beams and meshes a ParaView series of one `.vtp`/`.vtu` file
    /// per frame with its `.pvd` index (the default).
    #[default]
    Vtk,
    /// The CSV files only (no per-frame VTK files).
    Csv,
    /// One Exodus II file `results.exo` (bodies, beams and meshes, every frame) and its
    /// manifest, with the small CSV files (`bodies.csv`, `energy.csv`, `constraints.csv`,
    /// `mesh_energy.csv`); no `beams.csv` and no per-frame VTK files.
    Exodus,
}

impl OutputFormat {
    /// The names, as the language and the command line spell them.
    pub const NAMES: [&'static str; 3] = ["csv", "vtk", "exodus"];

    /// The format of a name.
    pub fn from_name(name: &str) -> Option<OutputFormat> {
        match name {
            "csv" => Some(OutputFormat::Csv),
            "vtk" => Some(OutputFormat::Vtk),
            "exodus" => Some(OutputFormat::Exodus),
            _ => None,
        }
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            OutputFormat::Csv => "csv",
            OutputFormat::Vtk => "vtk",
            OutputFormat::Exodus => "exodus",
        }
    }
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            every: 1,
            bodies: true,
            energy: true,
            constraints: true,
            format: OutputFormat::Vtk,
            partitions: 0,
            checkpoint: CheckpointOptions::NONE,
        }
    }
}

/// Options of the staggered explicit–implicit method.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StaggeredOptions {
    /// Penalty/regularization parameter ε (m/N). `None`: the documented default rule.
    pub epsilon: Option<f64>,
    /// Use the conventional single-stage update (C3 eq. 41) instead of the two-stage one.
    pub single_stage: bool,
    /// Reproduce the printed formulas (Δ = 1 + h²|ω|²/4, λ right-hand side h/4) instead of
    /// the corrected ones. For reproducing the papers' figures only.
    pub paper_literal: bool,
    /// How the regularized λ equation `ε λ̇ = Φ̇` is discretized.
    pub lint: LintForm,
    /// How the gyroscopic term `ω × Jω` is evaluated in the two-stage update.
    #[serde(default)]
    pub gyroscopic: Gyroscopic,
    /// Which factorization of the iteration matrix `E + h²BM⁻¹Bᵀ` the method uses.
    #[serde(default)]
    pub factorization: Factorization,
    /// Dynamic relaxation: march to a static equilibrium instead of following the motion.
    #[serde(default)]
    pub relaxation: Relaxation,
    /// Substeps of the flexible beams' nodes per step of the rigid bodies (subcycling,
    /// docs/methods.md "Beams: subcycling"); 1: every body takes the step.
    #[serde(default = "one_substep", skip_serializing_if = "is_one_substep")]
    pub beam_substeps: u32,
}

fn one_substep() -> u32 {
    1
}

fn is_one_substep(n: &u32) -> bool {
    *n == 1
}

/// Dynamic relaxation for static solutions (see docs/methods.md, "Beams").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Relaxation {
    /// Follow the motion (a dynamic run).
    #[default]
    None,
    /// Kinetic damping (Cundall): every time the total kinetic energy passes a peak, all
    /// velocities are set to zero. The run then converges to a static equilibrium under the
    /// loads at the end time; its intermediate frames are not a motion.
    Kinetic,
}

/// The factorization of the staggered method's iteration matrix `E + h²BM⁻¹Bᵀ` (one row per
/// constraint row; see docs/methods.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Factorization {
    /// Dense below 40 rows or above density 0.3, sparse otherwise (the measured crossover).
    #[default]
    Auto,
    /// Always dense (`8 m²` bytes and `m³/3` operations per factorization for `m` rows):
    /// the classic Lagrange-multiplier path, for comparisons. Refused above
    /// [`crate::analysis::input_limits::MAX_DENSE_UNKNOWNS`] rows.
    Dense,
    /// Always sparse (supernodal Cholesky with a fill-reducing ordering).
    Sparse,
}

/// Evaluation of the gyroscopic term in the staggered update (see docs/methods.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Gyroscopic {
    /// One leapfrog sequence with the implicit midpoint rule for the rotational kick,
    /// `J(ω⁺ − ω)/h + ω̄ × Jω̄ = τ`, solved per body: conserves a free body's energy and angular
    /// momentum exactly.
    #[default]
    Midpoint,
    /// The paper's two-stage scheme: two leapfrog sequences offset by h/2, each taking ω from
    /// the other (C3 §IV.B). Their difference grows on gyroscopically stabilized constrained
    /// systems (a heavy top), and on chaotic ones the two sequences decorrelate.
    Synchronous,
    /// One sequence with the lagged ω^{n−1/2}: the conventional update (C3 eq. 41).
    Lagged,
}

/// Discretization of the staggered method's λ equation (see docs/methods.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum LintForm {
    /// Its exact integral `ε(λ − λ⁰) = Φ`, imposed implicitly at the positions the next
    /// coordinate update produces (iteration matrix `εI + h²BM⁻¹Bᵀ`). No drift.
    #[default]
    Exact,
    /// The paper's half-step midpoint rule (C3 eq. 34, with the corrected h/8).
    Midpoint,
}

impl Default for StaggeredOptions {
    fn default() -> Self {
        StaggeredOptions {
            epsilon: None,
            single_stage: false,
            paper_literal: false,
            lint: LintForm::Exact,
            gyroscopic: Gyroscopic::Midpoint,
            factorization: Factorization::Auto,
            relaxation: Relaxation::None,
            beam_substeps: 1,
        }
    }
}

/// Integration methods and their options.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum MethodSpec {
    /// Two-stage staggered explicit–implicit (CINT/LINT) with staggered stabilization.
    Staggered(StaggeredOptions),
    /// Index-1 formulation with Baumgarte stabilization `Φ̈ + 2αΦ̇ + β²Φ = 0`.
    Baumgarte {
        /// α, 1/s.
        alpha: f64,
        /// β, 1/s.
        beta: f64,
    },
    /// Penalty formulation `λ = Φ/ε`.
    Penalty {
        /// ε, m/N. `None`: default rule.
        epsilon: Option<f64>,
    },
    /// Coordinate partitioning onto independent velocities (eqs. 14–19).
    CoordinatePartitioning,
    /// Simultaneous implicit trapezoidal rule with Newton iterations (eqs. 8–13).
    ImplicitTrapezoid {
        /// Newton tolerance on the constraint residual (relative).
        tolerance: f64,
        /// Maximum Newton iterations per step.
        max_iterations: u32,
    },
    /// Natural partitioning: tree null space, Schur-complement PCG, cut joints by staggered
    /// stabilization.
    NaturalPartitioning {
        /// ε for cut joints, m/N. `None`: default rule.
        epsilon: Option<f64>,
        /// PCG relative tolerance.
        tolerance: f64,
        /// Most PCG iterations per cut-row solve. `None`: the default rule,
        /// `max(4 × cut rows, 50)`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_iterations: Option<u32>,
    },
    /// Classical fourth-order Runge–Kutta on the tree coordinates of natural partitioning,
    /// fixed step; closed loops and drivers by their index-1 multipliers.
    RungeKutta4,
    /// Dormand–Prince 5(4) on the tree coordinates, error-controlled (PI controller), with
    /// dense output at the output times; `step` is the first and the largest internal step
    /// (closed loops as for [`MethodSpec::RungeKutta4`]).
    DormandPrince {
        /// Absolute and relative tolerance of the embedded error estimate.
        tolerance: f64,
    },
    /// Dormand–Prince 8(5,3) (Hairer's DOP853) on the tree coordinates: eighth order,
    /// error-controlled by its combined fifth- and third-order estimates, with seventh-order
    /// dense output at the output times; `step` is the first and the largest internal step
    /// (closed loops as for [`MethodSpec::RungeKutta4`]).
    DormandPrince853 {
        /// Absolute and relative tolerance of the combined error estimate.
        tolerance: f64,
    },
    /// State-time formulation (time elements, Newton on the trajectory).
    StateTime {
        /// Time steps per time element.
        steps_per_element: u32,
        /// Time elements per window: the memory of a window solve grows with it, the
        /// run's length does not.
        #[serde(default = "default_state_time_window")]
        window: u32,
    },
}

/// Time elements per `state_time` window unless the model says otherwise.
pub const DEFAULT_STATE_TIME_WINDOW: u32 = 64;

fn default_state_time_window() -> u32 {
    DEFAULT_STATE_TIME_WINDOW
}

impl MethodSpec {
    /// The method's name as written in `.mbd` files and on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            MethodSpec::Staggered(_) => "staggered",
            MethodSpec::Baumgarte { .. } => "baumgarte",
            MethodSpec::Penalty { .. } => "penalty",
            MethodSpec::CoordinatePartitioning => "coordinate_partitioning",
            MethodSpec::ImplicitTrapezoid { .. } => "implicit_trapezoid",
            MethodSpec::NaturalPartitioning { .. } => "natural_partitioning",
            MethodSpec::RungeKutta4 => "rk4",
            MethodSpec::DormandPrince { .. } => "dopri5",
            MethodSpec::DormandPrince853 { .. } => "dop853",
            MethodSpec::StateTime { .. } => "state_time",
        }
    }

    /// All method names, in documentation order.
    pub const NAMES: [&'static str; 10] = [
        "staggered",
        "baumgarte",
        "penalty",
        "coordinate_partitioning",
        "implicit_trapezoid",
        "natural_partitioning",
        "rk4",
        "dopri5",
        "dop853",
        "state_time",
    ];

    /// The method with the given name and its default options.
    pub fn default_for(name: &str) -> Option<MethodSpec> {
        Some(match name {
            "staggered" => MethodSpec::Staggered(StaggeredOptions::default()),
            "baumgarte" => MethodSpec::Baumgarte {
                alpha: 10.0,
                beta: 10.0,
            },
            "penalty" => MethodSpec::Penalty { epsilon: None },
            "coordinate_partitioning" => MethodSpec::CoordinatePartitioning,
            "implicit_trapezoid" => MethodSpec::ImplicitTrapezoid {
                tolerance: 1e-10,
                max_iterations: 20,
            },
            "natural_partitioning" => MethodSpec::NaturalPartitioning {
                epsilon: None,
                tolerance: 1e-12,
                max_iterations: None,
            },
            "rk4" => MethodSpec::RungeKutta4,
            "dopri5" => MethodSpec::DormandPrince { tolerance: 1e-9 },
            "dop853" => MethodSpec::DormandPrince853 { tolerance: 1e-9 },
            "state_time" => MethodSpec::StateTime {
                steps_per_element: 4,
                window: DEFAULT_STATE_TIME_WINDOW,
            },
            _ => return None,
        })
    }
}

/// A reference solution for accuracy reports.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Reference {
    /// Analytic body trajectories.
    pub bodies: Vec<BodyReference>,
    /// Tabulated reference (CSV with the columns of `bodies.csv`), path relative to the model file.
    pub table: Option<String>,
}

/// The analytic reference trajectory of one body.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BodyReference {
    /// Body index.
    pub body: usize,
    /// Mass-centre position as functions of time (world, m).
    pub position: Option<[Fn1; 3]>,
    /// Orientation quaternion `[w, x, y, z]` as functions of time (normalised on use).
    pub orientation: Option<[Fn1; 4]>,
}

impl Fn1 {
    /// Whether the function is a constant (does not depend on its variable).
    pub fn is_const(&self) -> bool {
        match self {
            Fn1::Const(_) => true,
            Fn1::Var => false,
            Fn1::Add(a, b) | Fn1::Sub(a, b) | Fn1::Mul(a, b) | Fn1::Div(a, b) => {
                a.is_const() && b.is_const()
            }
            Fn1::Min(a, b) | Fn1::Max(a, b) => a.is_const() && b.is_const(),
            Fn1::Neg(a) | Fn1::Powf(a, _) | Fn1::Unary(_, a) => a.is_const(),
            Fn1::Smoothstep(a, ..) | Fn1::Table(a, _) => a.is_const(),
            Fn1::JacobiSn(a, _) | Fn1::JacobiCn(a, _) | Fn1::JacobiDn(a, _) => a.is_const(),
        }
    }
}

impl Scene {
    /// Index of the body with the given name.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Index of the joint with the given name.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Total number of constraint rows.
    pub fn constraint_rows(&self) -> usize {
        self.joints.iter().map(|j| j.kind.rows()).sum()
    }
}
