//! What generated code links to: the split of a scene into **structure** (what the code is
//! specialized on) and **numbers** (data loaded at start-up), and the trait a generated
//! model implements.
//!
//! ## Structure and numbers
//!
//! The interpreter's plan ([`Interp::joint_entries`], [`Interp::terms`], [`Interp::locks`])
//! is the single source of truth for what a scene evaluates, in which order. [`Plan::new`]
//! builds it and splits it into
//! - a [`Spec`]: which kernels and force terms, with which bodies and rows, the shapes of
//!   the time functions ([`FnShape`]), the meshes' element kernels ([`MeshBlock`]) and the
//!   beams' element variants ([`BeamVariant`]) — everything the generated code is written
//!   for;
//! - [`PlanData`]: every number (joint and force geometry, constants and tables of the time
//!   functions, lock angles, gravity, the initial state, the layout with names and masses).
//!
//! Generated code is emitted from a [`Spec`] only, so two scenes with equal specs run on the
//! same compiled code with their own data: a parameter override that changes numbers needs no
//! rebuild. [`Spec::key`] hashes the spec (with [`FORMAT`] and the runtime version); the
//! generated code embeds the key it was written for, and [`Plan::new`] on a scene with
//! another key is refused ([`CompiledError::Structure`]).
//!
//! What counts as structure follows the interpreter's own decisions: a force whose value is
//! identically zero, or a spring with zero stiffness and damping, is not a term at all, so
//! making a number zero (or non-zero) can change the structure.
//!
//! Two [`Mode`]s:
//! - [`Mode::Unrolled`] (small scenes): the spec lists every row group and term with its
//!   bodies, rows and constant offsets, so the code is straight-line with constant indices
//!   and fixed-size arrays;
//! - [`Mode::Tables`] (large scenes): the spec lists only the distinct kinds
//!   ([`JointCombo`], [`TermCombo`]) and function shapes; bodies, rows and offsets are data
//!   ([`JointRow`], [`TermRow`]) and the code loops over them. The source size and the key do
//!   not depend on the number of bodies.
//!
//! ## Time functions
//!
//! A [`Fn1`] tree becomes an [`FnShape`] (the tree with its constants replaced by slots
//! `c[k]`, tables by `tb[k]`) and its numbers. Generated code evaluates a shape with the same
//! [`Jet2`](crate::kernels::fn1::Jet2) operations in the same order as [`crate::kernels::fn1::eval`], so the
//! results are bit-identical to the interpreter's.

use serde::Serialize;

use crate::contract::scene::{ElementKind, Fn1, ForceFrame, Scene, UnaryFn};
use crate::contract::system::{JointKernel, Pose, System, Twist};
use crate::interp::{Interp, InterpError, Lock, Term};
use crate::kernels::contact::{BoxPlane, SpherePlane, SphereSphere};
use crate::kernels::forces::{RotSpringGeom, SpringGeom};
use crate::kernels::joints::JointGeom;

/// Version of the contract between generated code and this module; part of every key.
pub const FORMAT: u32 = 1;

/// How generated code is laid out (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Mode {
    /// Straight-line code per row group and term, constant indices.
    Unrolled,
    /// Loops over per-item tables, one `match` arm per distinct kind.
    Tables,
}

/// A time function with its numbers replaced by slots (relative to the function's first
/// constant and first table).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[allow(missing_docs)]
pub enum FnShape {
    /// `c[slot]`.
    Const(usize),
    /// The variable.
    Var,
    Add(Box<FnShape>, Box<FnShape>),
    Sub(Box<FnShape>, Box<FnShape>),
    Mul(Box<FnShape>, Box<FnShape>),
    Div(Box<FnShape>, Box<FnShape>),
    Neg(Box<FnShape>),
    /// Exponent in `c[slot]`.
    Powf(Box<FnShape>, usize),
    Unary(UnaryFn, Box<FnShape>),
    Min(Box<FnShape>, Box<FnShape>),
    Max(Box<FnShape>, Box<FnShape>),
    /// `x0, x1` in `c[slot], c[slot + 1]`.
    Smoothstep(Box<FnShape>, usize),
    /// The points in `tb[slot]`.
    Table(Box<FnShape>, usize),
    /// `m` in `c[slot]`.
    JacobiSn(Box<FnShape>, usize),
    /// `m` in `c[slot]`.
    JacobiCn(Box<FnShape>, usize),
    /// `m` in `c[slot]`.
    JacobiDn(Box<FnShape>, usize),
}

/// The numbers of one or more time functions: constants and tables, in slot order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FnData {
    /// Constants.
    pub c: Vec<f64>,
    /// Tables.
    pub tb: Vec<Vec<[f64; 2]>>,
}

impl FnData {
    /// Append the numbers of `f` and return its shape, with slots relative to the lengths of
    /// `self.c` and `self.tb` before the call.
    pub fn push(&mut self, f: &Fn1) -> FnShape {
        let (c0, t0) = (self.c.len(), self.tb.len());
        self.walk(f, c0, t0)
    }

    fn walk(&mut self, f: &Fn1, c0: usize, t0: usize) -> FnShape {
        let two = |s: &mut Self, a: &Fn1, b: &Fn1| {
            let a = s.walk(a, c0, t0);
            let b = s.walk(b, c0, t0);
            (Box::new(a), Box::new(b))
        };
        match f {
            Fn1::Const(x) => {
                self.c.push(*x);
                FnShape::Const(self.c.len() - 1 - c0)
            }
            Fn1::Var => FnShape::Var,
            Fn1::Add(a, b) => {
                let (a, b) = two(self, a, b);
                FnShape::Add(a, b)
            }
            Fn1::Sub(a, b) => {
                let (a, b) = two(self, a, b);
                FnShape::Sub(a, b)
            }
            Fn1::Mul(a, b) => {
                let (a, b) = two(self, a, b);
                FnShape::Mul(a, b)
            }
            Fn1::Div(a, b) => {
                let (a, b) = two(self, a, b);
                FnShape::Div(a, b)
            }
            Fn1::Min(a, b) => {
                let (a, b) = two(self, a, b);
                FnShape::Min(a, b)
            }
            Fn1::Max(a, b) => {
                let (a, b) = two(self, a, b);
                FnShape::Max(a, b)
            }
            Fn1::Neg(a) => FnShape::Neg(Box::new(self.walk(a, c0, t0))),
            Fn1::Unary(u, a) => FnShape::Unary(*u, Box::new(self.walk(a, c0, t0))),
            Fn1::Powf(a, n) => {
                let a = Box::new(self.walk(a, c0, t0));
                self.c.push(*n);
                FnShape::Powf(a, self.c.len() - 1 - c0)
            }
            Fn1::Smoothstep(a, x0, x1) => {
                let a = Box::new(self.walk(a, c0, t0));
                self.c.push(*x0);
                self.c.push(*x1);
                FnShape::Smoothstep(a, self.c.len() - 2 - c0)
            }
            Fn1::Table(a, t) => {
                let a = Box::new(self.walk(a, c0, t0));
                self.tb.push(t.clone());
                FnShape::Table(a, self.tb.len() - 1 - t0)
            }
            Fn1::JacobiSn(a, m) | Fn1::JacobiCn(a, m) | Fn1::JacobiDn(a, m) => {
                let a = Box::new(self.walk(a, c0, t0));
                self.c.push(*m);
                let s = self.c.len() - 1 - c0;
                match f {
                    Fn1::JacobiSn(..) => FnShape::JacobiSn(a, s),
                    Fn1::JacobiCn(..) => FnShape::JacobiCn(a, s),
                    _ => FnShape::JacobiDn(a, s),
                }
            }
        }
    }
}

impl FnShape {
    /// Number of constants and tables of the shape (the numbers [`FnData::push`] appends).
    pub fn counts(&self) -> (usize, usize) {
        let (mut c, mut t) = (0, 0);
        self.count(&mut c, &mut t);
        (c, t)
    }

    fn count(&self, c: &mut usize, t: &mut usize) {
        match self {
            FnShape::Const(_) => *c += 1,
            FnShape::Var => {}
            FnShape::Add(a, b)
            | FnShape::Sub(a, b)
            | FnShape::Mul(a, b)
            | FnShape::Div(a, b)
            | FnShape::Min(a, b)
            | FnShape::Max(a, b) => {
                a.count(c, t);
                b.count(c, t);
            }
            FnShape::Neg(a) | FnShape::Unary(_, a) => a.count(c, t),
            FnShape::Powf(a, _)
            | FnShape::JacobiSn(a, _)
            | FnShape::JacobiCn(a, _)
            | FnShape::JacobiDn(a, _) => {
                a.count(c, t);
                *c += 1;
            }
            FnShape::Smoothstep(a, _) => {
                a.count(c, t);
                *c += 2;
            }
            FnShape::Table(a, _) => {
                a.count(c, t);
                *t += 1;
            }
        }
    }

    /// Whether the shape uses tables.
    pub fn uses_tables(&self) -> bool {
        match self {
            FnShape::Table(..) => true,
            FnShape::Const(_) | FnShape::Var => false,
            FnShape::Add(a, b)
            | FnShape::Sub(a, b)
            | FnShape::Mul(a, b)
            | FnShape::Div(a, b)
            | FnShape::Min(a, b)
            | FnShape::Max(a, b) => a.uses_tables() || b.uses_tables(),
            FnShape::Neg(a)
            | FnShape::Powf(a, _)
            | FnShape::Unary(_, a)
            | FnShape::Smoothstep(a, _)
            | FnShape::JacobiSn(a, _)
            | FnShape::JacobiCn(a, _)
            | FnShape::JacobiDn(a, _) => a.uses_tables(),
        }
    }
}

/// A joint kind with the shapes of its time functions (indices into [`Spec::shapes`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct JointCombo {
    /// The kernel.
    pub kernel: JointKernel,
    /// Shapes of its functions: none, one (drivers, curve) or three (point velocity).
    pub fns: Vec<usize>,
}

/// The kind of an applied-force term.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[allow(missing_docs)]
pub enum TermKind {
    Point,
    Torque,
    Spring,
    RotSpring,
    SpherePlane,
    SphereSphere,
    BoxPlane,
}

/// A force-term kind with its frame and the shapes of its time functions.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct TermCombo {
    /// The kind.
    pub kind: TermKind,
    /// Frame of point forces and torques.
    pub frame: Option<ForceFrame>,
    /// Shapes of its three components (point forces and torques).
    pub fns: Vec<usize>,
}

/// One row group in [`Mode::Unrolled`]: everything constant about it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct UJoint {
    /// Index into [`Spec::joints`].
    pub combo: usize,
    /// Side a.
    pub a: Option<usize>,
    /// Side b.
    pub b: Option<usize>,
    /// First row.
    pub first: usize,
    /// Rows.
    pub rows: usize,
    /// Offset of its constants in the constant table.
    pub c: usize,
    /// Offset of its tables.
    pub tb: usize,
}

/// One force term in [`Mode::Unrolled`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct UTerm {
    /// Index into [`Spec::terms`].
    pub combo: usize,
    /// Side a (the body, for point forces and torques).
    pub a: Option<usize>,
    /// Side b.
    pub b: Option<usize>,
    /// Index among the terms of its kind (into the per-kind geometry table).
    pub index: usize,
    /// Offset of its constants.
    pub c: usize,
    /// Offset of its tables.
    pub tb: usize,
}

/// One lock in [`Mode::Unrolled`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ULock {
    /// Layout joint index of the lock row.
    pub joint: usize,
    /// Global row.
    pub row: usize,
    /// Side a.
    pub a: Option<usize>,
    /// Side b.
    pub b: Option<usize>,
}

/// The per-item structure of a [`Mode::Unrolled`] spec.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Unrolled {
    /// Bodies.
    pub bodies: usize,
    /// Constraint rows.
    pub rows: usize,
    /// Row groups in row order.
    pub joints: Vec<UJoint>,
    /// Force terms in evaluation order.
    pub terms: Vec<UTerm>,
    /// Locks.
    pub locks: Vec<ULock>,
    /// Number of time-function constants.
    pub consts: usize,
    /// Number of time-function tables.
    pub tables: usize,
    /// Number of terms of each [`TermKind`] (in the enum's order).
    pub per_kind: [usize; 7],
}

/// What generated code is specialized on (see the module doc).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Spec {
    /// The layout of the code.
    pub mode: Mode,
    /// Whether the scene has (non-zero) gravity.
    pub gravity: bool,
    /// Distinct time-function shapes, in order of first appearance.
    pub shapes: Vec<FnShape>,
    /// Distinct joint kinds, in order of first appearance.
    pub joints: Vec<JointCombo>,
    /// Distinct force-term kinds, in order of first appearance.
    pub terms: Vec<TermCombo>,
    /// Whether there are locks.
    pub locks: bool,
    /// Per item structure ([`Mode::Unrolled`] only).
    pub unrolled: Option<Unrolled>,
    /// The meshes' element blocks in layout order: which element kernel (kind and
    /// quadrature variant), elastic or plastic, each block runs (its constants are data). Empty without meshes, and then
    /// left out of the key's JSON, so that rigid scenes keep their keys.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub meshes: Vec<MeshBlock>,
    /// The beams' element variants, each once in order of first appearance: which element
    /// function (undamped, damped) generated code names (the section constants and the
    /// damping coefficient are data). Empty without beams, and then left out of the key's
    /// JSON, so that scenes without beams keep their keys.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub beams: Vec<BeamVariant>,
}

/// One element variant of the beams: the kernel generated code names for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct BeamVariant {
    /// Whether the beams of this variant have stiffness-proportional damping.
    pub damped: bool,
}

impl BeamVariant {
    /// The constructor of its entry in `BeamKernels` (`elastic`, `damped`).
    pub fn constructor(&self) -> &'static str {
        if self.damped {
            "damped"
        } else {
            "elastic"
        }
    }
}

/// The structure of one element block of a mesh: the kernel generated code names for it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct MeshBlock {
    /// Element kind (with the plane mode of 2-D kinds).
    pub kind: ElementKind,
    /// Whether the block runs the one-point variant of the kind's kernel (reduced hex8 and
    /// quad4, [`crate::kernels::solid::reduced`]).
    pub reduced: bool,
    /// Whether the material is elastoplastic (the block runs the plastic loop).
    pub plastic: bool,
}

impl MeshBlock {
    /// The name of the block's kernel type in `mbdc_runtime::solid` (`Hex8`, `Hex8Reduced`,
    /// …).
    pub fn kernel(&self) -> &'static str {
        crate::kernels::solid::kernel_name(self.kind, self.reduced)
    }
}

impl Spec {
    /// The key of the spec: FNV-1a of its canonical JSON, [`FORMAT`] and the runtime
    /// version.
    pub fn key(&self) -> u64 {
        let json = serde_json::to_string(self).unwrap_or_default();
        let mut h = Fnv::new();
        h.write(json.as_bytes());
        h.write(&FORMAT.to_le_bytes());
        h.write(env!("CARGO_PKG_VERSION").as_bytes());
        h.finish()
    }

    /// Whether any row group or term has the given kernel / kind.
    pub fn has_kernel(&self, k: JointKernel) -> bool {
        self.joints.iter().any(|c| c.kernel == k)
    }

    /// Whether any term has the given kind.
    pub fn has_term(&self, k: TermKind) -> bool {
        self.terms.iter().any(|c| c.kind == k)
    }
}

pub use crate::contract::fnv::Fnv;

/// One row group's data ([`Mode::Tables`] reads all of it; [`Mode::Unrolled`] only `geom`
/// and `lock_angle`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointRow {
    /// Index into [`Spec::joints`].
    pub combo: usize,
    /// Side a.
    pub a: Option<usize>,
    /// Side b.
    pub b: Option<usize>,
    /// First row.
    pub first: usize,
    /// Rows.
    pub rows: usize,
    /// Kernel geometry.
    pub geom: JointGeom,
    /// Offset of its constants in [`FnData::c`].
    pub c: usize,
    /// Offset of its tables in [`FnData::tb`].
    pub tb: usize,
    /// The lock angle of a lock row (0 otherwise).
    pub lock_angle: f64,
}

/// One force term's data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TermRow {
    /// Index into [`Spec::terms`].
    pub combo: usize,
    /// Side a (the body of a point force or torque).
    pub a: Option<usize>,
    /// Side b.
    pub b: Option<usize>,
    /// Index into the geometry table of its kind.
    pub index: usize,
    /// Offset of its constants.
    pub c: usize,
    /// Offset of its tables.
    pub tb: usize,
}

/// Every number of a scene, grouped for generated code (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct PlanData {
    /// Gravity (zero when the scene has none).
    pub gravity: [f64; 3],
    /// Row groups in row order.
    pub joints: Vec<JointRow>,
    /// Force terms in evaluation order.
    pub terms: Vec<TermRow>,
    /// Points of application of point forces (body components).
    pub point_rho: Vec<[f64; 3]>,
    /// Translational springs.
    pub springs: Vec<SpringGeom>,
    /// Rotational springs.
    pub rot_springs: Vec<RotSpringGeom>,
    /// Sphere–plane contacts.
    pub sphere_planes: Vec<SpherePlane>,
    /// Sphere–sphere contacts.
    pub sphere_spheres: Vec<SphereSphere>,
    /// Box–plane contacts.
    pub box_planes: Vec<BoxPlane>,
    /// Locks.
    pub locks: Vec<Lock>,
    /// Numbers of the time functions.
    pub fns: FnData,
}

/// Why a scene cannot run on compiled code.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CompiledError {
    /// The scene is not valid for the rigid-body runtime.
    #[error(transparent)]
    Interp(#[from] InterpError),
    /// The scene's structure differs from the one the code was generated for.
    #[error("this program was generated for another scene structure (key {expected:016x}, the scene has {found:016x}): regenerate it (mbdc run does this by itself)")]
    Structure {
        /// The key the code was generated for.
        expected: u64,
        /// The key of the scene given.
        found: u64,
    },
    /// The scene data could not be read.
    #[error("reading the scene data: {0}")]
    Data(String),
}

/// A scene split into spec and data (see the module doc).
#[derive(Clone, Debug)]
pub struct Plan {
    /// The interpreter built for the scene (layout, initial state, validation).
    pub interp: Interp,
    /// The structure.
    pub spec: Spec,
    /// The numbers.
    pub data: PlanData,
}

fn intern<T: PartialEq>(list: &mut Vec<T>, x: T) -> usize {
    match list.iter().position(|y| *y == x) {
        Some(i) => i,
        None => {
            list.push(x);
            list.len() - 1
        }
    }
}

impl Plan {
    /// Build the plan of `scene` for code laid out in `mode`.
    pub fn new(scene: &Scene, mode: Mode) -> Result<Plan, InterpError> {
        let interp = Interp::new(scene)?;
        let mut shapes: Vec<FnShape> = Vec::new();
        let mut jc: Vec<JointCombo> = Vec::new();
        let mut tc: Vec<TermCombo> = Vec::new();
        let mut fns = FnData::default();
        let mut shape = |fns: &mut FnData, f: &Fn1| {
            let s = fns.push(f);
            intern(&mut shapes, s)
        };

        let mut joints = Vec::with_capacity(interp.joint_entries().len());
        let mut uj = Vec::new();
        for e in interp.joint_entries() {
            let (c, tb) = (fns.c.len(), fns.tb.len());
            let kernel = e.kernel;
            let lock_angle = e.lock_angle;
            let fs: Vec<usize> = e.fns.iter().map(|f| shape(&mut fns, f)).collect();
            let combo = intern(&mut jc, JointCombo { kernel, fns: fs });
            joints.push(JointRow {
                combo,
                a: e.a,
                b: e.b,
                first: e.first,
                rows: e.rows,
                geom: e.geom,
                c,
                tb,
                lock_angle,
            });
            uj.push(UJoint {
                combo,
                a: e.a,
                b: e.b,
                first: e.first,
                rows: e.rows,
                c,
                tb,
            });
        }

        let mut data = PlanData {
            gravity: interp.gravity().map_or([0.0; 3], |g| [g.x, g.y, g.z]),
            joints,
            terms: Vec::new(),
            point_rho: Vec::new(),
            springs: Vec::new(),
            rot_springs: Vec::new(),
            sphere_planes: Vec::new(),
            sphere_spheres: Vec::new(),
            box_planes: Vec::new(),
            locks: interp.locks().to_vec(),
            fns: FnData::default(),
        };
        let mut ut = Vec::new();
        let mut per_kind = [0usize; 7];
        for t in interp.terms() {
            let (c, tb) = (fns.c.len(), fns.tb.len());
            let (kind, frame, fs, a, b, index) = match t {
                Term::Point {
                    body,
                    rho,
                    value,
                    frame,
                } => {
                    data.point_rho.push(*rho);
                    let fs = value.iter().map(|f| shape(&mut fns, f)).collect();
                    (
                        TermKind::Point,
                        Some(*frame),
                        fs,
                        Some(*body),
                        None,
                        data.point_rho.len() - 1,
                    )
                }
                Term::Torque { body, value, frame } => {
                    let fs = value.iter().map(|f| shape(&mut fns, f)).collect();
                    (
                        TermKind::Torque,
                        Some(*frame),
                        fs,
                        Some(*body),
                        None,
                        per_kind[1],
                    )
                }
                Term::Spring { a, b, g } => {
                    data.springs.push(*g);
                    let i = data.springs.len() - 1;
                    (TermKind::Spring, None, vec![], *a, *b, i)
                }
                Term::RotSpring { a, b, g } => {
                    data.rot_springs.push(*g);
                    let i = data.rot_springs.len() - 1;
                    (TermKind::RotSpring, None, vec![], *a, *b, i)
                }
                Term::SpherePlane { a, b, g } => {
                    data.sphere_planes.push(*g);
                    let i = data.sphere_planes.len() - 1;
                    (TermKind::SpherePlane, None, vec![], *a, *b, i)
                }
                Term::SphereSphere { a, b, g } => {
                    data.sphere_spheres.push(*g);
                    let i = data.sphere_spheres.len() - 1;
                    (TermKind::SphereSphere, None, vec![], *a, *b, i)
                }
                Term::BoxPlane { a, b, g } => {
                    data.box_planes.push(*g);
                    let i = data.box_planes.len() - 1;
                    (TermKind::BoxPlane, None, vec![], *a, *b, i)
                }
            };
            per_kind[kind as usize] += 1;
            let combo = intern(
                &mut tc,
                TermCombo {
                    kind,
                    frame,
                    fns: fs,
                },
            );
            data.terms.push(TermRow {
                combo,
                a,
                b,
                index,
                c,
                tb,
            });
            ut.push(UTerm {
                combo,
                a,
                b,
                index,
                c,
                tb,
            });
        }
        data.fns = fns;
        let locks: Vec<ULock> = interp
            .locks()
            .iter()
            .map(|l| ULock {
                joint: l.joint,
                row: l.row,
                a: l.a,
                b: l.b,
            })
            .collect();
        let unrolled = (mode == Mode::Unrolled).then(|| Unrolled {
            bodies: interp.layout().bodies(),
            rows: interp.layout().rows,
            joints: uj,
            terms: ut,
            locks: locks.clone(),
            consts: data.fns.c.len(),
            tables: data.fns.tb.len(),
            per_kind,
        });
        let spec = Spec {
            mode,
            gravity: interp.gravity().is_some(),
            shapes,
            joints: jc,
            terms: tc,
            locks: !locks.is_empty(),
            unrolled,
            meshes: interp
                .layout()
                .meshes
                .blocks
                .iter()
                .map(|b| MeshBlock {
                    kind: b.kind,
                    reduced: crate::integrators::mesh_kernels::block_reduced(b),
                    plastic: b.material.plastic.is_some(),
                })
                .collect(),
            beams: crate::integrators::beam_kernels::BeamKernels::interpreted(
                &interp.layout().beams,
            )
            .kernels()
            .iter()
            .map(|k| BeamVariant { damped: k.damped })
            .collect(),
        };
        Ok(Plan { interp, spec, data })
    }

    /// Build the plan and check that its key is `expected` (the key generated code was
    /// written for).
    pub fn checked(scene: &Scene, mode: Mode, expected: u64) -> Result<Plan, CompiledError> {
        let plan = Plan::new(scene, mode)?;
        let found = plan.spec.key();
        if found != expected {
            return Err(CompiledError::Structure { expected, found });
        }
        Ok(plan)
    }

    /// The key of the spec ([`Spec::key`]).
    pub fn key(&self) -> u64 {
        self.spec.key()
    }
}

/// Read a scene from its JSON (as embedded in generated code or written by `mbdc run`).
pub fn scene_from_json(json: &str) -> Result<Scene, CompiledError> {
    serde_json::from_str(json).map_err(|e| CompiledError::Data(e.to_string()))
}

/// A generated model: a [`System`] that can be built from any scene with the structure it
/// was generated for. Implemented by generated code; used by [`crate::app`].
pub trait CompiledModel: System + Sized {
    /// The scene's name.
    const NAME: &'static str;
    /// The [`Spec::key`] the code was generated for.
    const KEY: u64;
    /// The code's [`Mode`].
    const MODE: Mode;

    /// The model with the numbers of `scene` (checked against [`CompiledModel::KEY`]).
    fn from_scene(scene: &Scene) -> Result<Self, CompiledError>;

    /// The scene the code was generated from.
    fn default_scene() -> Result<Scene, CompiledError>;

    /// Replace the initial state (e.g. by an assembled one).
    fn set_initial_state(&mut self, pose: &[Pose], twist: &[Twist]);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::fn1;

    #[test]
    fn shapes_and_slots() {
        let t = || Box::new(Fn1::Var);
        let f = Fn1::Add(
            Box::new(Fn1::Mul(Box::new(Fn1::Const(2.0)), t())),
            Box::new(Fn1::Smoothstep(t(), 0.5, 1.5)),
        );
        let mut d = FnData::default();
        d.c.push(9.0);
        let s = d.push(&f);
        assert_eq!(d.c, vec![9.0, 2.0, 0.5, 1.5]);
        assert_eq!(
            s,
            FnShape::Add(
                Box::new(FnShape::Mul(
                    Box::new(FnShape::Const(0)),
                    Box::new(FnShape::Var)
                )),
                Box::new(FnShape::Smoothstep(Box::new(FnShape::Var), 1))
            )
        );
        // same shape, other numbers
        let g = Fn1::Add(
            Box::new(Fn1::Mul(Box::new(Fn1::Const(3.0)), t())),
            Box::new(Fn1::Smoothstep(t(), 0.0, 2.0)),
        );
        assert_eq!(FnData::default().push(&g), s);
        assert_eq!(s.counts(), (3, 0));
        // 2·1 + smoothstep at the middle of [0.5, 1.5], which is ½
        assert!((fn1::eval(&f, 1.0).v - 2.5).abs() < 1e-15);
    }

    #[test]
    fn keys_are_stable_and_depend_on_structure_only() {
        let mut h = Fnv::new();
        h.write(b"a");
        assert_eq!(h.finish(), 0xaf63dc4c8601ec8c);
    }
}
