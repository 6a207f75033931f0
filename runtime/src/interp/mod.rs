//! The interpreter: a [`System`] built at run time from a [`Scene`].
//!
//! [`Interp::new`] validates the scene for the rigid-body runtime and builds, once:
//! - the [`Layout`]: bodies in scene order with their [`MassProps`]; the scene's joints in
//!   scene order (rows numbered consecutively, nonholonomic rows last within a joint);
//!   then one 1-row joint per rotational-spring lock (`"<force>.lock"`, kind `"lock"`,
//!   `starts_inactive = true`);
//! - per joint, its [`JointGeom`] and kind (time functions kept as [`Fn1`] trees and
//!   evaluated as jets when needed);
//! - the list of **active** force terms only: gravity (if the scene has a non-zero
//!   gravity vector), point forces and torques on bodies, springs with non-zero stiffness
//!   or damping, contacts. Nothing else is evaluated in [`System::applied`].
//!
//! [`System::has_velocity_forces`] is true only with dampers, contact damping or friction;
//! [`System::has_state_forces`] is false when the only forces are gravity, world-frame
//! forces at mass centres and body-frame torques.
//!
//! Every [`System`] method then loops over these prebuilt lists without allocating,
//! calling the same kernels ([`crate::kernels::joints`], [`crate::kernels::forces`], [`crate::kernels::contact`]) that
//! generated code calls.
//!
//! Locks: a [`ForceKind::RotationalSpring`] with a `lock_angle` adds the row
//! `sin(θ − θ_lock)` ([`joints::drive_angle`] with a constant angle) on the spring's joint
//! frames. [`System::update_locks`] activates it when the continuous joint angle θ
//! ([`forces::joint_angle`]) has reached the lock angle coming from its initial value θ₀:
//! `(θ − θ_lock)(θ₀ − θ_lock) ≤ 0` (θ₀ = 0 when the joint frames coincide initially).
//! Locks never release.
//!
//! Flexible beams: their nodes are bodies and their clamps and pins joints
//! ([`crate::analysis::beam_model`]); the element forces are the integrator's.
//!
//! Finite-element meshes: flattened by [`crate::analysis::mesh_model`] into the layout's
//! `meshes`; their nodes are not bodies, the integrator advances them. A body that carries
//! tied mesh nodes (`tie SET, BODY`) is built as the body with those nodes' inertia, its
//! reference point at their joint mass centre ([`crate::analysis::tie_model`]).
//!
//! Not simulated (clear errors from [`Interp::new`]): box–box, sphere–box and plane–plane
//! contact, bodies with singular or indefinite inertia.

use crate::analysis::{beam_model, input_limits, mesh_model, tie_model};
use crate::contract::math::{quat, rotation, vec3};
use crate::contract::scene::{
    Attachment, BodyRef, Fn1, ForceFrame, ForceKind, JointKind, Scene, Shape,
};
use crate::contract::system::{
    BeamLayout, ConstraintEval, JointKernel, JointLayout, Layout, MassProps, Need, Pose, RowKind,
    System, Twist, Wrench,
};
use crate::kernels::contact::{
    self, BoxPlane, ContactLaw, SpherePlane, SphereSphere, FRICTION_REG_SPEED,
};
use crate::kernels::fn1::{self, Jet2};
use crate::kernels::forces::{self, add_wrench, RotSpringGeom, SpringGeom};
use crate::kernels::joints::{self, JointGeom, JointOut};
use nalgebra::{Matrix3, Vector3};

/// Why a scene cannot be interpreted. Every variant names the offending item.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InterpError {
    /// A flexible beam cannot be made into bodies and elements.
    #[error("beam '{name}': {reason}")]
    Beam {
        /// The beam's name.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// A finite-element mesh cannot be simulated (a degenerate element, a node without
    /// mass, a load on a set without faces).
    #[error("mesh '{name}': {reason}")]
    Mesh {
        /// The mesh's name.
        name: String,
        /// What is wrong, with the element, its nodes and location where one is at fault.
        reason: String,
    },
    /// An item is invalid or unsupported.
    #[error("{item} '{name}': {reason}")]
    Invalid {
        /// Kind of item: "body", "joint", "force", "contact", "scene".
        item: &'static str,
        /// Its name.
        name: String,
        /// What is wrong and, where possible, how to fix it.
        reason: String,
    },
}

fn invalid(item: &'static str, name: &str, reason: impl Into<String>) -> InterpError {
    InterpError::Invalid {
        item,
        name: name.to_string(),
        reason: reason.into(),
    }
}

/// One row group of the interpreter's plan: a scene joint or a lock row.
#[derive(Clone, Debug, PartialEq)]
pub struct JointEntry {
    /// Which kernel evaluates the rows.
    pub kernel: JointKernel,
    /// The kernel's time functions ([`JointKernel::time_functions`] of them): the prescribed
    /// angle or displacement of a driver, the three components of a point velocity, the
    /// curve `y = f(x)`; empty for the other kernels.
    pub fns: Vec<Fn1>,
    /// The angle of a lock row ([`JointKernel::Lock`]), rad; 0 for the other kernels.
    pub lock_angle: f64,
    /// Geometry passed to the kernel.
    pub geom: JointGeom,
    /// Body of side a (`None`: ground).
    pub a: Option<usize>,
    /// Body of side b (`None`: ground).
    pub b: Option<usize>,
    /// First global row.
    pub first: usize,
    /// Number of rows.
    pub rows: usize,
}

/// An active applied-force term, evaluated in [`System::applied`] in plan order.
#[derive(Clone, Debug, PartialEq)]
pub enum Term {
    /// A force at a body point ([`forces::point_force_world`] / [`forces::point_force_body`]).
    Point {
        /// The body.
        body: usize,
        /// Point of application, body components relative to the mass centre.
        rho: [f64; 3],
        /// Force components as functions of time.
        value: Box<[Fn1; 3]>,
        /// Frame of the components.
        frame: ForceFrame,
    },
    /// A pure torque ([`forces::torque_world`] / [`forces::torque_body`]).
    Torque {
        /// The body.
        body: usize,
        /// Torque components as functions of time.
        value: Box<[Fn1; 3]>,
        /// Frame of the components.
        frame: ForceFrame,
    },
    /// A translational spring–damper ([`forces::spring`]).
    Spring {
        /// Side a (`None`: ground).
        a: Option<usize>,
        /// Side b.
        b: Option<usize>,
        /// Geometry and constants.
        g: SpringGeom,
    },
    /// A rotational spring–damper ([`forces::rotational_spring`]).
    RotSpring {
        /// Side a.
        a: Option<usize>,
        /// Side b.
        b: Option<usize>,
        /// Geometry and constants.
        g: RotSpringGeom,
    },
    /// Sphere–plane contact ([`contact::sphere_plane`]).
    SpherePlane {
        /// The sphere's side.
        a: Option<usize>,
        /// The plane's side.
        b: Option<usize>,
        /// Geometry and law.
        g: SpherePlane,
    },
    /// Sphere–sphere contact ([`contact::sphere_sphere`]).
    SphereSphere {
        /// Side a.
        a: Option<usize>,
        /// Side b.
        b: Option<usize>,
        /// Geometry and law.
        g: SphereSphere,
    },
    /// Box–plane contact ([`contact::box_plane`]).
    BoxPlane {
        /// The box's side.
        a: Option<usize>,
        /// The plane's side.
        b: Option<usize>,
        /// Geometry and law.
        g: BoxPlane,
    },
}

/// A lock of a rotational spring: its row engages once the joint angle reaches `angle`.
#[derive(Clone, Debug, PartialEq)]
pub struct Lock {
    /// Layout joint index of the lock row.
    pub joint: usize,
    /// Global row.
    pub row: usize,
    /// The spring's joint geometry.
    pub geom: JointGeom,
    /// Side a.
    pub a: Option<usize>,
    /// Side b.
    pub b: Option<usize>,
    /// Sign of the joint angle ([`forces::joint_angle_sign`]).
    pub sign: f64,
    /// Lock angle, rad.
    pub angle: f64,
    /// Joint angle at the start, rad.
    pub theta0: f64,
}

/// A [`System`] interpreted from a [`Scene`] (see the module doc).
#[derive(Clone, Debug)]
pub struct Interp {
    name: String,
    layout: Layout,
    pose0: Vec<Pose>,
    twist0: Vec<Twist>,
    joints: Vec<JointEntry>,
    gravity: Option<Vector3<f64>>,
    terms: Vec<Term>,
    locks: Vec<Lock>,
    velocity_forces: bool,
    state_forces: bool,
    ground_pose: Pose,
    ground_twist: Twist,
}

fn finite3(v: &[f64; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn check_body_ref(
    item: &'static str,
    name: &str,
    r: BodyRef,
    n: usize,
) -> Result<Option<usize>, InterpError> {
    match r {
        BodyRef::Ground => Ok(None),
        BodyRef::Body(i) if i < n => Ok(Some(i)),
        BodyRef::Body(i) => Err(invalid(
            item,
            name,
            format!("refers to body index {i}, but the scene has {n} bodies"),
        )),
    }
}

/// A scene with beams: its own joints, forces and contacts name its own bodies and joints
/// only. The expansion appends the beams' nodes as bodies and their attachments as joints,
/// which the file cannot name; an index among them (a scene read from JSON) would pass the
/// check of the expanded scene and break everything that reads the scene as it is.
fn check_own_refs(scene: &Scene) -> Result<(), InterpError> {
    use crate::contract::scene::ForceKind;
    let (n, nj) = (scene.bodies.len(), scene.joints.len());
    for j in &scene.joints {
        check_body_ref("joint", &j.name, j.a.body, n)?;
        check_body_ref("joint", &j.name, j.b.body, n)?;
    }
    for f in &scene.forces {
        match &f.kind {
            ForceKind::Point { at, .. } => {
                check_body_ref("force", &f.name, at.body, n)?;
            }
            ForceKind::Torque { body, .. } => {
                check_body_ref("force", &f.name, *body, n)?;
            }
            ForceKind::Spring { a, b, .. } => {
                check_body_ref("force", &f.name, a.body, n)?;
                check_body_ref("force", &f.name, b.body, n)?;
            }
            ForceKind::RotationalSpring { joint, .. } if *joint >= nj => {
                return Err(invalid(
                    "force",
                    &f.name,
                    format!("refers to joint index {joint}, but the scene has {nj} joints"),
                ));
            }
            _ => {}
        }
    }
    for c in &scene.contacts {
        check_body_ref("contact", &c.name, c.a.0.body, n)?;
        check_body_ref("contact", &c.name, c.b.0.body, n)?;
    }
    Ok(())
}

fn check_attachment(
    item: &'static str,
    name: &str,
    a: &Attachment,
    n: usize,
) -> Result<Option<usize>, InterpError> {
    let b = check_body_ref(item, name, a.body, n)?;
    if !finite3(&a.point) {
        return Err(invalid(
            item,
            name,
            format!("attachment point {:?} is not finite", a.point),
        ));
    }
    let qn = a.frame.iter().map(|x| x * x).sum::<f64>().sqrt();
    if !(qn.is_finite() && qn > 0.0) {
        return Err(invalid(
            item,
            name,
            format!("attachment frame {:?} is not a valid quaternion", a.frame),
        ));
    }
    Ok(b)
}

fn check_fn(item: &'static str, name: &str, f: &Fn1) -> Result<(), InterpError> {
    fn1::validate(f).map_err(|e| invalid(item, name, e))
}

fn check_nonneg(item: &'static str, name: &str, what: &str, x: f64) -> Result<(), InterpError> {
    if x.is_finite() && x >= 0.0 {
        Ok(())
    } else {
        Err(invalid(
            item,
            name,
            format!("{what} must be finite and ≥ 0, got {x}"),
        ))
    }
}

/// Axes `[x, y, z]` of an attachment's frame in body components (columns of its
/// rotation); a shape's plane normal is its z axis, a box's edges follow all three.
fn frame_axes(a: &Attachment) -> [[f64; 3]; 3] {
    let n = a.frame.iter().map(|x| x * x).sum::<f64>().sqrt();
    let c = rotation(&(quat(a.frame) / n));
    let col = |j: usize| [c[(0, j)], c[(1, j)], c[(2, j)]];
    [col(0), col(1), col(2)]
}

/// Whether `j_inv` is a usable inverse of `j`: finite, and `j · j_inv` within 10⁻⁶ of the
/// identity (an inverse computed through an overflowing or underflowing determinant is not).
fn inverse_ok(j: &Matrix3<f64>, j_inv: &Matrix3<f64>) -> bool {
    j_inv.iter().all(|x| x.is_finite())
        && (j * j_inv - Matrix3::identity())
            .iter()
            .all(|x| x.abs() <= 1e-6)
}

/// The checks on the scene as a whole, before anything is built: sizes against
/// [`limits`], the simulation settings, the reference solution.
fn check_scene(scene: &Scene) -> Result<(), InterpError> {
    let scene_err = |reason: String| invalid("scene", &scene.name, reason);
    for (what, n, max) in [
        ("bodies", scene.bodies.len(), input_limits::MAX_BODIES),
        ("joints", scene.joints.len(), input_limits::MAX_JOINTS),
        (
            "force elements",
            scene.forces.len(),
            input_limits::MAX_FORCES,
        ),
        ("contacts", scene.contacts.len(), input_limits::MAX_CONTACTS),
    ] {
        if n > max {
            return Err(scene_err(format!(
                "{n} {what}, more than the limit of {max}"
            )));
        }
    }
    let sim = &scene.simulate;
    input_limits::check_run(sim.step, sim.duration)
        .map_err(|e| scene_err(format!("simulate: {e}")))?;
    input_limits::check_method(&sim.method).map_err(|e| scene_err(format!("simulate: {e}")))?;
    if let Some(r) = &scene.reference {
        let nb = scene.bodies.len();
        for b in &r.bodies {
            if b.body >= nb {
                return Err(scene_err(format!(
                    "the reference refers to body index {}, but the scene has {nb} bodies",
                    b.body
                )));
            }
            let name = &scene.bodies[b.body].name;
            let fns = b
                .position
                .iter()
                .flatten()
                .chain(b.orientation.iter().flatten());
            for f in fns {
                fn1::validate(f)
                    .map_err(|e| invalid("body", name, format!("reference trajectory: {e}")))?;
            }
        }
    }
    Ok(())
}

impl Interp {
    /// Build the interpreter for `scene` (see the module doc for what is checked).
    ///
    /// Beams are first made bodies and joints ([`beam_model::expand`]): their nodes follow
    /// the scene's bodies, their clamps and pins its joints, and the [`Layout`]'s `beams`
    /// lists the elements, whose forces the integrator adds.
    pub fn new(scene: &Scene) -> Result<Interp, InterpError> {
        let mesh_err = |e: mesh_model::MeshError| InterpError::Mesh {
            name: e.mesh,
            reason: e.reason,
        };
        let mut meshes = mesh_model::build(&scene.meshes).map_err(mesh_err)?;
        meshes.method = scene.simulate.mesh_method;
        meshes.solver = scene.simulate.mesh_solver;
        // Bodies that carry tied mesh nodes become the bodies with those nodes' inertia.
        let composite = tie_model::apply(scene, &mut meshes).map_err(mesh_err)?;
        let scene = composite.as_ref().unwrap_or(scene);
        let meshes = std::sync::Arc::new(meshes);
        if scene.beams.is_empty() {
            return Interp::build(scene, BeamLayout::default(), meshes);
        }
        check_own_refs(scene)?;
        let ex = beam_model::expand(scene).map_err(|e| InterpError::Beam {
            name: e.beam,
            reason: e.reason,
        })?;
        Interp::build(&ex.scene, ex.beams, meshes)
    }

    /// [`Interp::new`] for a scene without beams, with the beams' and meshes' layouts to
    /// record.
    fn build(
        scene: &Scene,
        beams: BeamLayout,
        meshes: std::sync::Arc<crate::contract::mesh_layout::MeshLayout>,
    ) -> Result<Interp, InterpError> {
        check_scene(scene)?;
        let nb = scene.bodies.len();

        // Bodies.
        let mut mass = Vec::with_capacity(nb);
        let mut pose0 = Vec::with_capacity(nb);
        let mut twist0 = Vec::with_capacity(nb);
        for b in &scene.bodies {
            let name = &b.name;
            if !(b.mass.is_finite() && b.mass > 0.0 && (1.0 / b.mass).is_finite()) {
                return Err(invalid(
                    "body",
                    name,
                    format!("mass must be positive and finite, got {}", b.mass),
                ));
            }
            let j = Matrix3::from_fn(|r, c| b.inertia[r][c]);
            if j.iter().any(|x| !x.is_finite()) {
                return Err(invalid(
                    "body",
                    name,
                    "inertia tensor has non-finite entries",
                ));
            }
            let asym = (j - j.transpose()).abs().max();
            if asym > 1e-9 * j.abs().max() {
                return Err(invalid("body", name, "inertia tensor is not symmetric"));
            }
            let props = MassProps::new(b.mass, j).ok_or_else(|| {
                invalid(
                    "body",
                    name,
                    "inertia tensor is singular; give every axis a positive moment of inertia",
                )
            })?;
            if j.cholesky().is_none() {
                return Err(invalid(
                    "body",
                    name,
                    "inertia tensor is not positive definite",
                ));
            }
            if !inverse_ok(&j, &props.j_inv) {
                return Err(invalid(
                    "body",
                    name,
                    format!(
                        "inertia tensor cannot be inverted in floating point (moments from {:e} to {:e} kg·m²)",
                        j.diagonal().min(),
                        j.diagonal().max()
                    ),
                ));
            }
            mass.push(props);
            let qn = b.orientation.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !(qn.is_finite() && qn > 0.0) {
                return Err(invalid(
                    "body",
                    name,
                    "orientation is not a valid quaternion",
                ));
            }
            if !(finite3(&b.position) && finite3(&b.velocity) && finite3(&b.angular_velocity)) {
                return Err(invalid(
                    "body",
                    name,
                    "initial position or velocity is not finite",
                ));
            }
            pose0.push(Pose::new(vec3(&b.position), quat(b.orientation)));
            twist0.push(Twist {
                v: vec3(&b.velocity),
                w: vec3(&b.angular_velocity),
            });
        }
        let ground_pose = Pose::default();
        let ground_twist = Twist::default();
        let pose_of = |b: Option<usize>| b.map_or(&ground_pose, |i| &pose0[i]);

        // Joints.
        let mut joints = Vec::with_capacity(scene.joints.len());
        let mut jl = Vec::new();
        let mut row = 0;
        for j in &scene.joints {
            let name = &j.name;
            let a = check_attachment("joint", name, &j.a, nb)?;
            let b = check_attachment("joint", name, &j.b, nb)?;
            if a == b {
                let what = a.map_or("the ground".to_string(), |i| {
                    format!("body '{}'", scene.bodies[i].name)
                });
                return Err(invalid("joint", name, format!("connects {what} to itself")));
            }
            let driven = |idx: usize, ok: &[&str], what: &str| -> Result<(), InterpError> {
                let Some(d) = scene.joints.get(idx) else {
                    return Err(invalid(
                        "joint",
                        name,
                        format!("drives joint index {idx}, which does not exist"),
                    ));
                };
                if ok.contains(&d.kind.keyword()) {
                    Ok(())
                } else {
                    Err(invalid(
                        "joint",
                        name,
                        format!(
                            "{what} drives joint '{}', a {} joint; expected {}",
                            d.name,
                            d.kind.keyword(),
                            ok.join(" or ")
                        ),
                    ))
                }
            };
            let ground_b = |what: &str| -> Result<(), InterpError> {
                if b.is_some() {
                    Err(invalid(
                        "joint",
                        name,
                        format!("{what}: the second attachment must be the ground"),
                    ))
                } else {
                    Ok(())
                }
            };
            let mut param = 0.0;
            let mut fns = Vec::new();
            match &j.kind {
                JointKind::Distance { length } => {
                    if !(length.is_finite() && *length > 0.0) {
                        return Err(invalid(
                            "joint",
                            name,
                            format!("distance length must be positive, got {length}"),
                        ));
                    }
                    param = *length;
                }
                JointKind::DriveAngle { joint, angle } => {
                    driven(*joint, &["revolute", "cylindrical"], "angle driver")?;
                    check_fn("joint", name, angle)?;
                    fns.push(angle.clone());
                }
                JointKind::DriveDisplacement {
                    joint,
                    displacement,
                } => {
                    driven(*joint, &["prismatic", "cylindrical"], "displacement driver")?;
                    check_fn("joint", name, displacement)?;
                    fns.push(displacement.clone());
                }
                JointKind::Rolling { radius } => {
                    if !(radius.is_finite() && *radius > 0.0) {
                        return Err(invalid(
                            "joint",
                            name,
                            format!("rolling radius must be positive, got {radius}"),
                        ));
                    }
                    ground_b("rolling (the plane)")?;
                    param = *radius;
                }
                JointKind::PointVelocity { velocity } => {
                    ground_b("point velocity")?;
                    for f in velocity {
                        check_fn("joint", name, f)?;
                    }
                    fns.extend(velocity.iter().cloned());
                }
                JointKind::Curve { curve } => {
                    check_fn("joint", name, curve)?;
                    fns.push(curve.clone());
                }
                JointKind::Spherical
                | JointKind::Revolute
                | JointKind::Prismatic
                | JointKind::Cylindrical
                | JointKind::Universal
                | JointKind::Fixed
                | JointKind::Planar => {}
            }
            let kernel = JointKernel::of(&j.kind);
            debug_assert_eq!(fns.len(), kernel.time_functions());

            let rows = j.kind.rows();
            let nh = j.kind.nonholonomic_rows();
            joints.push(JointEntry {
                kernel,
                fns,
                lock_angle: 0.0,
                geom: JointGeom::new(&j.a, &j.b, param),
                a,
                b,
                first: row,
                rows,
            });
            jl.push(JointLayout {
                name: name.clone(),
                kind: j.kind.keyword(),
                a,
                b,
                first_row: row,
                rows,
                nonholonomic: nh,
                starts_inactive: false,
            });
            row += rows;
        }

        // Forces.
        let gravity = scene
            .gravity
            .filter(|g| g.iter().any(|c| *c != 0.0))
            .map(|g| vec3(&g));
        if let Some(g) = gravity {
            if !g.iter().all(|x| x.is_finite()) {
                return Err(invalid("scene", &scene.name, "gravity is not finite"));
            }
        }
        let mut terms = Vec::new();
        let mut locks = Vec::new();
        let mut velocity_forces = false;
        for f in &scene.forces {
            let name = &f.name;
            match &f.kind {
                ForceKind::Point { at, value, frame } => {
                    let body = check_attachment("force", name, at, nb)?;
                    for v in value {
                        check_fn("force", name, v)?;
                    }
                    if let Some(body) = body {
                        if value
                            .iter()
                            .any(|v| !matches!(v, Fn1::Const(c) if *c == 0.0))
                        {
                            terms.push(Term::Point {
                                body,
                                rho: at.point,
                                value: Box::new(value.clone()),
                                frame: *frame,
                            });
                        }
                    }
                }
                ForceKind::Torque { body, value, frame } => {
                    let body = check_body_ref("force", name, *body, nb)?;
                    for v in value {
                        check_fn("force", name, v)?;
                    }
                    if let Some(body) = body {
                        if value
                            .iter()
                            .any(|v| !matches!(v, Fn1::Const(c) if *c == 0.0))
                        {
                            terms.push(Term::Torque {
                                body,
                                value: Box::new(value.clone()),
                                frame: *frame,
                            });
                        }
                    }
                }
                ForceKind::Spring {
                    a,
                    b,
                    stiffness,
                    rest_length,
                    damping,
                } => {
                    let ia = check_attachment("force", name, a, nb)?;
                    let ib = check_attachment("force", name, b, nb)?;
                    check_nonneg("force", name, "stiffness", *stiffness)?;
                    check_nonneg("force", name, "rest length", *rest_length)?;
                    check_nonneg("force", name, "damping", *damping)?;
                    if (*stiffness != 0.0 || *damping != 0.0) && ia != ib {
                        velocity_forces |= *damping != 0.0;
                        let g = SpringGeom {
                            pa: a.point,
                            pb: b.point,
                            stiffness: *stiffness,
                            rest_length: *rest_length,
                            damping: *damping,
                        };
                        terms.push(Term::Spring { a: ia, b: ib, g });
                    }
                }
                ForceKind::RotationalSpring {
                    joint,
                    stiffness,
                    rest_angle,
                    damping,
                    lock_angle,
                } => {
                    let Some(j) = scene.joints.get(*joint) else {
                        return Err(invalid(
                            "force",
                            name,
                            format!("refers to joint index {joint}, which does not exist"),
                        ));
                    };
                    if !matches!(j.kind, JointKind::Revolute | JointKind::Cylindrical) {
                        return Err(invalid(
                            "force",
                            name,
                            format!(
                                "rotational spring on joint '{}', a {} joint; expected revolute or cylindrical",
                                j.name,
                                j.kind.keyword()
                            ),
                        ));
                    }
                    check_nonneg("force", name, "stiffness", *stiffness)?;
                    check_nonneg("force", name, "damping", *damping)?;
                    if !rest_angle.is_finite() {
                        return Err(invalid("force", name, "rest angle is not finite"));
                    }
                    let e = &joints[*joint];
                    let geom = e.geom;
                    let sign = forces::joint_angle_sign(&geom, pose_of(e.a), pose_of(e.b));
                    if *stiffness != 0.0 || *damping != 0.0 {
                        velocity_forces |= *damping != 0.0;
                        let g = RotSpringGeom {
                            joint: geom,
                            stiffness: *stiffness,
                            rest_angle: *rest_angle,
                            damping: *damping,
                            sign,
                        };
                        terms.push(Term::RotSpring { a: e.a, b: e.b, g });
                    }
                    if let Some(angle) = lock_angle {
                        if !angle.is_finite() {
                            return Err(invalid("force", name, "lock angle is not finite"));
                        }
                        let theta0 = forces::joint_angle(&geom, sign, pose_of(e.a), pose_of(e.b));
                        locks.push(Lock {
                            joint: 0,
                            row: 0,
                            geom,
                            a: e.a,
                            b: e.b,
                            sign,
                            angle: *angle,
                            theta0,
                        });
                        jl.push(JointLayout {
                            name: format!("{name}.lock"),
                            kind: "lock",
                            a: e.a,
                            b: e.b,
                            first_row: 0,
                            rows: 1,
                            nonholonomic: 0,
                            starts_inactive: true,
                        });
                    }
                }
            }
        }
        // Lock rows come after all scene joints, in force order.
        let first_lock = scene.joints.len();
        for (k, l) in locks.iter_mut().enumerate() {
            l.joint = first_lock + k;
            l.row = row;
            jl[l.joint].first_row = row;
            joints.push(JointEntry {
                kernel: JointKernel::Lock,
                fns: Vec::new(),
                lock_angle: l.angle,
                geom: l.geom,
                a: l.a,
                b: l.b,
                first: row,
                rows: 1,
            });
            row += 1;
        }

        // Contacts.
        for c in &scene.contacts {
            let name = &c.name;
            let ia = check_attachment("contact", name, &c.a.0, nb)?;
            let ib = check_attachment("contact", name, &c.b.0, nb)?;
            if ia == ib {
                return Err(invalid(
                    "contact",
                    name,
                    "both shapes are on the same body (or both on the ground)",
                ));
            }
            check_nonneg("contact", name, "stiffness", c.stiffness)?;
            check_nonneg("contact", name, "damping", c.damping)?;
            check_nonneg("contact", name, "friction coefficient", c.friction)?;
            for (_, s) in [&c.a, &c.b] {
                match s {
                    Shape::Sphere { radius } if !(radius.is_finite() && *radius > 0.0) => {
                        return Err(invalid(
                            "contact",
                            name,
                            format!("sphere radius must be positive, got {radius}"),
                        ));
                    }
                    Shape::Box { half_extents }
                        if !half_extents.iter().all(|h| h.is_finite() && *h > 0.0) =>
                    {
                        return Err(invalid(
                            "contact",
                            name,
                            format!("box half extents must be positive, got {half_extents:?}"),
                        ));
                    }
                    _ => {}
                }
            }
            velocity_forces |= c.damping != 0.0 || c.friction != 0.0;
            let law = ContactLaw {
                stiffness: c.stiffness,
                damping: c.damping,
                friction: c.friction,
                reg_speed: FRICTION_REG_SPEED,
            };
            // Order the pair so that the sphere/box is side a and the plane side b.
            let ((aa, sa, ja), (ab, sb, jb)) = match (&c.a.1, &c.b.1) {
                (Shape::Plane, Shape::Sphere { .. } | Shape::Box { .. }) => {
                    ((&c.b.0, c.b.1, ib), (&c.a.0, c.a.1, ia))
                }
                _ => ((&c.a.0, c.a.1, ia), (&c.b.0, c.b.1, ib)),
            };
            let normal = frame_axes(ab)[2];
            let term = match (sa, sb) {
                (Shape::Sphere { radius }, Shape::Plane) => Term::SpherePlane {
                    a: ja,
                    b: jb,
                    g: SpherePlane {
                        centre: aa.point,
                        radius,
                        point: ab.point,
                        normal,
                        law,
                    },
                },
                (Shape::Sphere { radius: ra }, Shape::Sphere { radius: rb }) => {
                    Term::SphereSphere {
                        a: ja,
                        b: jb,
                        g: SphereSphere {
                            centre_a: aa.point,
                            radius_a: ra,
                            centre_b: ab.point,
                            radius_b: rb,
                            law,
                        },
                    }
                }
                (Shape::Box { half_extents }, Shape::Plane) => Term::BoxPlane {
                    a: ja,
                    b: jb,
                    g: BoxPlane {
                        centre: aa.point,
                        axes: frame_axes(aa),
                        half: half_extents,
                        point: ab.point,
                        normal,
                        law,
                    },
                },
                (x, y) => {
                    let n = |s: &Shape| match s {
                        Shape::Sphere { .. } => "sphere",
                        Shape::Box { .. } => "box",
                        Shape::Plane => "plane",
                    };
                    return Err(invalid(
                        "contact",
                        name,
                        format!(
                            "{}–{} contact is not supported (supported: sphere–plane, sphere–sphere, box–plane)",
                            n(&x),
                            n(&y)
                        ),
                    ));
                }
            };
            if c.stiffness != 0.0 || c.damping != 0.0 {
                terms.push(term);
            }
        }

        let mut row_joint = Vec::with_capacity(row);
        let mut row_kind = Vec::with_capacity(row);
        for (i, j) in jl.iter().enumerate() {
            for k in 0..j.rows {
                row_joint.push(i);
                row_kind.push(if k >= j.rows - j.nonholonomic {
                    RowKind::Nonholonomic
                } else {
                    RowKind::Holonomic
                });
            }
        }
        let layout = Layout {
            body_names: scene.bodies.iter().map(|b| b.name.clone()).collect(),
            mass,
            joints: jl,
            rows: row,
            row_joint,
            row_kind,
            beams,
            meshes,
        };
        // `applied` depends on the state unless every term is a world-frame force at the
        // mass centre or a body-frame torque (gravity never does).
        let state_forces = terms.iter().any(|t| match t {
            Term::Point { rho, frame, .. } => {
                *frame == ForceFrame::Body || rho.iter().any(|x| *x != 0.0)
            }
            Term::Torque { frame, .. } => *frame == ForceFrame::World,
            _ => true,
        });
        Ok(Interp {
            name: scene.name.clone(),
            layout,
            pose0,
            twist0,
            joints,
            gravity,
            terms,
            locks,
            velocity_forces,
            state_forces,
            ground_pose,
            ground_twist,
        })
    }

    /// Replace the initial state (e.g. by an assembled one, [`crate::driver::assemble`]).
    ///
    /// # Panics
    /// If the slices do not have one entry per body.
    pub fn set_initial_state(&mut self, pose: &[Pose], twist: &[Twist]) {
        self.pose0.copy_from_slice(pose);
        self.twist0.copy_from_slice(twist);
    }

    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Number of active applied-force terms (gravity not counted). Terms for effects the
    /// scene does not use are never built, so this is 0 for e.g. a pendulum.
    pub fn force_terms(&self) -> usize {
        self.terms.len()
    }

    /// The gravity vector, if the scene has non-zero gravity.
    pub fn gravity(&self) -> Option<Vector3<f64>> {
        self.gravity
    }

    /// The row groups in row order (scene joints, then lock rows): what
    /// [`System::constraints`] evaluates. Generated code is specialized on this plan
    /// ([`crate::compiled`]).
    pub fn joint_entries(&self) -> &[JointEntry] {
        &self.joints
    }

    /// The active applied-force terms, in the order [`System::applied`] adds them (after
    /// gravity).
    pub fn terms(&self) -> &[Term] {
        &self.terms
    }

    /// The locks, in lock-row order.
    pub fn locks(&self) -> &[Lock] {
        &self.locks
    }

    /// The initial poses and twists (as given, or as set by [`Interp::set_initial_state`]).
    pub fn initial(&self) -> (&[Pose], &[Twist]) {
        (&self.pose0, &self.twist0)
    }

    /// The continuous joint angle θ of each lock (in lock order, matching the lock joints
    /// after the scene's joints in the layout), written into `out` (one entry per lock).
    pub fn lock_angles(&self, pose: &[Pose], out: &mut [f64]) {
        for (l, o) in self.locks.iter().zip(out.iter_mut()) {
            *o = forces::joint_angle(&l.geom, l.sign, self.pose(l.a, pose), self.pose(l.b, pose));
        }
    }

    #[inline]
    fn pose<'a>(&'a self, b: Option<usize>, pose: &'a [Pose]) -> &'a Pose {
        match b {
            Some(i) => &pose[i],
            None => &self.ground_pose,
        }
    }

    #[inline]
    fn twist<'a>(&'a self, b: Option<usize>, twist: &'a [Twist]) -> &'a Twist {
        match b {
            Some(i) => &twist[i],
            None => &self.ground_twist,
        }
    }

    #[inline]
    fn add_pair(out: &mut [Wrench], a: Option<usize>, b: Option<usize>, w: (Wrench, Wrench)) {
        if let Some(i) = a {
            add_wrench(&mut out[i], &w.0);
        }
        if let Some(i) = b {
            add_wrench(&mut out[i], &w.1);
        }
    }
}

#[inline]
fn eval3(f: &[Fn1; 3], t: f64) -> Vector3<f64> {
    Vector3::new(
        fn1::value(&f[0], t),
        fn1::value(&f[1], t),
        fn1::value(&f[2], t),
    )
}

impl System for Interp {
    fn layout(&self) -> &Layout {
        &self.layout
    }

    fn initial_state(&self, pose: &mut [Pose], twist: &mut [Twist]) {
        pose.copy_from_slice(&self.pose0);
        twist.copy_from_slice(&self.twist0);
    }

    fn applied(&self, t: f64, pose: &[Pose], twist: &[Twist], out: &mut [Wrench]) {
        match self.gravity {
            Some(g) => {
                for (o, m) in out.iter_mut().zip(&self.layout.mass) {
                    *o = forces::gravity(m.m, &g);
                }
            }
            None => out.iter_mut().for_each(|o| *o = Wrench::default()),
        }
        for term in &self.terms {
            match term {
                Term::Point {
                    body,
                    rho,
                    value,
                    frame,
                } => {
                    let f = eval3(value, t);
                    let w = match frame {
                        ForceFrame::World => forces::point_force_world(&pose[*body], rho, &f),
                        ForceFrame::Body => forces::point_force_body(&pose[*body], rho, &f),
                    };
                    add_wrench(&mut out[*body], &w);
                }
                Term::Torque { body, value, frame } => {
                    let v = eval3(value, t);
                    let w = match frame {
                        ForceFrame::World => forces::torque_world(&pose[*body], &v),
                        ForceFrame::Body => forces::torque_body(&v),
                    };
                    add_wrench(&mut out[*body], &w);
                }
                Term::Spring { a, b, g } => {
                    let (pa, pb) = (self.pose(*a, pose), self.pose(*b, pose));
                    let (ta, tb) = (self.twist(*a, twist), self.twist(*b, twist));
                    Self::add_pair(out, *a, *b, forces::spring(g, pa, pb, ta, tb));
                }
                Term::RotSpring { a, b, g } => {
                    let (pa, pb) = (self.pose(*a, pose), self.pose(*b, pose));
                    let (ta, tb) = (self.twist(*a, twist), self.twist(*b, twist));
                    Self::add_pair(out, *a, *b, forces::rotational_spring(g, pa, pb, ta, tb));
                }
                Term::SpherePlane { a, b, g } => {
                    let (pa, pb) = (self.pose(*a, pose), self.pose(*b, pose));
                    let (ta, tb) = (self.twist(*a, twist), self.twist(*b, twist));
                    Self::add_pair(out, *a, *b, contact::sphere_plane(g, pa, ta, pb, tb));
                }
                Term::SphereSphere { a, b, g } => {
                    let (pa, pb) = (self.pose(*a, pose), self.pose(*b, pose));
                    let (ta, tb) = (self.twist(*a, twist), self.twist(*b, twist));
                    Self::add_pair(out, *a, *b, contact::sphere_sphere(g, pa, ta, pb, tb));
                }
                Term::BoxPlane { a, b, g } => {
                    let (pa, pb) = (self.pose(*a, pose), self.pose(*b, pose));
                    let (ta, tb) = (self.twist(*a, twist), self.twist(*b, twist));
                    Self::add_pair(out, *a, *b, contact::box_plane(g, pa, ta, pb, tb));
                }
            }
        }
    }

    fn constraints(
        &self,
        t: f64,
        pose: &[Pose],
        twist: &[Twist],
        need: Need,
        out: &mut ConstraintEval,
    ) {
        for j in &self.joints {
            let (pa, pb) = (self.pose(j.a, pose), self.pose(j.b, pose));
            let (ta, tb) = (self.twist(j.a, twist), self.twist(j.b, twist));
            let g = &j.geom;
            let o = JointOut::new(out, j.first, j.rows);
            match j.kernel {
                JointKernel::Spherical => joints::spherical(g, pa, pb, ta, tb, need, o),
                JointKernel::Revolute => joints::revolute(g, pa, pb, ta, tb, need, o),
                JointKernel::Prismatic => joints::prismatic(g, pa, pb, ta, tb, need, o),
                JointKernel::Cylindrical => joints::cylindrical(g, pa, pb, ta, tb, need, o),
                JointKernel::Universal => joints::universal(g, pa, pb, ta, tb, need, o),
                JointKernel::Fixed => joints::fixed(g, pa, pb, ta, tb, need, o),
                JointKernel::Planar => joints::planar(g, pa, pb, ta, tb, need, o),
                JointKernel::Distance => joints::distance_joint(g, pa, pb, ta, tb, need, o),
                JointKernel::DriveAngle => {
                    joints::drive_angle(g, fn1::eval(&j.fns[0], t), pa, pb, ta, tb, need, o)
                }
                JointKernel::DriveDisplacement => {
                    joints::drive_displacement(g, fn1::eval(&j.fns[0], t), pa, pb, ta, tb, need, o)
                }
                JointKernel::Rolling => joints::rolling(g, pa, pb, ta, tb, need, o),
                JointKernel::PointVelocity => {
                    let v = [
                        fn1::eval(&j.fns[0], t),
                        fn1::eval(&j.fns[1], t),
                        fn1::eval(&j.fns[2], t),
                    ];
                    joints::point_velocity(g, v, pa, pb, ta, tb, need, o)
                }
                JointKernel::Curve => {
                    joints::curve(g, |x| fn1::eval(&j.fns[0], x), pa, pb, ta, tb, need, o)
                }
                JointKernel::Lock => {
                    joints::drive_angle(g, Jet2::constant(j.lock_angle), pa, pb, ta, tb, need, o)
                }
            }
        }
    }

    fn potential_energy(&self, _t: f64, pose: &[Pose]) -> f64 {
        let mut e = 0.0;
        if let Some(g) = self.gravity {
            for (p, m) in pose.iter().zip(&self.layout.mass) {
                e += forces::gravity_energy(m.m, &g, p);
            }
        }
        for term in &self.terms {
            e += match term {
                Term::Point { .. } | Term::Torque { .. } => 0.0,
                Term::Spring { a, b, g } => {
                    forces::spring_energy(g, self.pose(*a, pose), self.pose(*b, pose))
                }
                Term::RotSpring { a, b, g } => {
                    forces::rotational_spring_energy(g, self.pose(*a, pose), self.pose(*b, pose))
                }
                Term::SpherePlane { a, b, g } => {
                    contact::sphere_plane_energy(g, self.pose(*a, pose), self.pose(*b, pose))
                }
                Term::SphereSphere { a, b, g } => {
                    contact::sphere_sphere_energy(g, self.pose(*a, pose), self.pose(*b, pose))
                }
                Term::BoxPlane { a, b, g } => {
                    contact::box_plane_energy(g, self.pose(*a, pose), self.pose(*b, pose))
                }
            };
        }
        e
    }

    fn tree_joint(&self, joint: usize) -> Option<(JointKernel, &JointGeom)> {
        let j = self.joints.get(joint)?;
        j.kernel.is_tree().then_some((j.kernel, &j.geom))
    }

    fn update_locks(&self, pose: &[Pose], _twist: &[Twist], active: &mut [bool]) -> Option<usize> {
        let mut changed = None;
        for l in &self.locks {
            if active[l.row] {
                continue;
            }
            let th =
                forces::joint_angle(&l.geom, l.sign, self.pose(l.a, pose), self.pose(l.b, pose));
            if (th - l.angle) * (l.theta0 - l.angle) <= 0.0 {
                active[l.row] = true;
                changed.get_or_insert(l.joint);
            }
        }
        changed
    }

    fn has_velocity_forces(&self) -> bool {
        self.velocity_forces
    }

    fn has_state_forces(&self) -> bool {
        self.state_forces
    }
}

/// The identity quaternion, for building scenes by hand.
pub const IDENTITY: [f64; 4] = [1.0, 0.0, 0.0, 0.0];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::scene::{Body, Force, Joint, Origin, Simulate};

    fn body(name: &str) -> Body {
        Body {
            name: name.into(),
            mass: 1.0,
            inertia: [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]],
            position: [0.0; 3],
            orientation: IDENTITY,
            velocity: [0.0; 3],
            angular_velocity: [0.0; 3],
            origin: Origin::default(),
        }
    }

    fn scene(bodies: Vec<Body>) -> Scene {
        Scene {
            name: "t".into(),
            gravity: None,
            bodies,
            joints: vec![],
            forces: vec![],
            beams: vec![],
            meshes: vec![],
            contacts: vec![],
            simulate: Simulate::default(),
            reference: None,
            params: vec![],
        }
    }

    fn att(body: BodyRef) -> Attachment {
        Attachment {
            body,
            point: [0.0; 3],
            frame: IDENTITY,
        }
    }

    #[test]
    fn invalid_items_are_named() {
        let mut s = scene(vec![body("b")]);
        s.bodies[0].inertia[2][2] = 0.0;
        let e = Interp::new(&s).unwrap_err().to_string();
        assert!(e.contains("body 'b'") && e.contains("singular"), "{e}");
        let mut s = scene(vec![body("b")]);
        s.joints.push(Joint {
            name: "j".into(),
            kind: JointKind::Rolling { radius: 0.1 },
            a: att(BodyRef::Ground),
            b: att(BodyRef::Body(0)),
            origin: Origin::default(),
        });
        let e = Interp::new(&s).unwrap_err().to_string();
        assert!(e.contains("joint 'j'") && e.contains("ground"), "{e}");
        let mut s = scene(vec![body("b")]);
        s.forces.push(Force {
            name: "rs".into(),
            kind: ForceKind::RotationalSpring {
                joint: 3,
                stiffness: 1.0,
                rest_angle: 0.0,
                damping: 0.0,
                lock_angle: None,
            },
            origin: Origin::default(),
        });
        let e = Interp::new(&s).unwrap_err().to_string();
        assert!(e.contains("force 'rs'"), "{e}");
    }

    #[test]
    fn spherical_rows() {
        let mut s = scene(vec![body("b")]);
        s.joints.push(Joint {
            name: "j".into(),
            kind: JointKind::Spherical,
            a: att(BodyRef::Ground),
            b: att(BodyRef::Body(0)),
            origin: Origin::default(),
        });
        let i = Interp::new(&s).unwrap();
        assert_eq!(i.layout().rows, 3);
        assert_eq!(i.layout().row_kind, vec![RowKind::Holonomic; 3]);
        assert_eq!(i.layout().joints[0].kind, "spherical");
    }
}
