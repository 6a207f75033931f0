//! Joint kernels: constraint values, Jacobian rows, bias and acceleration right-hand
//! side for every [`JointKind`](crate::contract::scene::JointKind), built from a handful of tested primitives.
//!
//! # Conventions
//!
//! - Body coordinates as in [`crate::contract::system`]: per body the mass-centre position `r`
//!   (world), orientation `C = rotation(q)` (body → world), velocity `u̇ = (v, ω)` with `v`
//!   in world and `ω` in **body** components. Jacobian blocks ([`RowJac`]) are written
//!   against `(v, ω_body)`.
//! - Ground is passed as an identity pose with zero twist; its block is computed like any
//!   other and never read.
//! - A joint's geometry is a [`JointGeom`]: the attachment points `pa`, `pb` (body
//!   components relative to the mass centre; world for ground) and the joint-frame axes
//!   `fa = [xa, ya, za]`, `fb = [xb, yb, zb]` in body components (the columns of the
//!   rotation of `Attachment::frame`). Below, `xa, ya, za, xb, yb, zb` and `pa, pb` denote
//!   the world vectors, `d = pb − pa`.
//! - Output per row, exactly as documented on [`crate::contract::system::ConstraintEval`]:
//!   holonomic rows: `phi = Φ`, `jac = B`, `bias = ∂Φ/∂t`, `gamma = c` with
//!   `B u̇' = c ⇔ Φ̈ = 0`, i.e. `Φ̈ = B u̇' − gamma` (notes A eq. 6, corrected);
//!   nonholonomic rows (last in a joint): `phi = B u̇ + b`, `bias = b`,
//!   `gamma = −(Ḃu̇ + ḃ)`, i.e. `Φ̇ = B u̇' − gamma`.
//!
//! # Rows of each joint kind
//!
//! | kind | rows (in order) |
//! |---|---|
//! | spherical | `pa − pb` (x, y, z world) |
//! | revolute | `pa − pb` (3), `za·xb`, `za·yb` |
//! | prismatic | `za·xb`, `za·yb`, `xa·yb`, `xa·d`, `ya·d` |
//! | cylindrical | `za·xb`, `za·yb`, `xa·d`, `ya·d` |
//! | universal | `pa − pb` (3), `za·zb` |
//! | fixed | `pa − pb` (3), `za·xb`, `za·yb`, `xa·yb` |
//! | planar | `za·d`, `za·xb`, `za·yb` |
//! | distance | `(d·d − L²)/(2L)` |
//! | drive_angle | `sin(θ − f(t)) = (ya·xb) cos f − (xa·xb) sin f` |
//! | drive_displacement | `za·d − f(t)` |
//! | rolling | `zb·(pa − pb) − R`; then nonholonomic `xb·v_c`, `yb·v_c` |
//! | point_velocity | nonholonomic `v_p − v(t)` (x, y, z world) |
//! | curve | `yb·(pa − pb) − f(xb·(pa − pb))` |
//!
//! Notes on the choices:
//! - The point rows are `pa − pb` so that side a (the parent in a tree) has the block
//!   `[+I, −C_a ρ̃_a]` and side b (the child) `[−I, C_b ρ̃_b]`, exactly the spherical-joint
//!   blocks of notes C §1.4 (natural partitioning uses the child's `−I`).
//! - The "dot-1" rows `za·xb = za·yb = 0` keep `zb ∥ za`; `xa·yb = 0` locks the rotation
//!   about it (satisfied at θ = 0; the configuration θ = π also satisfies it). The "dot-2"
//!   rows `xa·d = ya·d = 0` keep `pb` on the line through `pa` along `za`.
//! - Distance is scaled as `(|d|² − L²)/(2L)`: it is polynomial (no square root, so no
//!   singularity at `d = 0` and cheap exact derivatives), and near the solution it equals
//!   `|d| − L` to first order, so its value is a length in metres and its Jacobian has the
//!   magnitude of a unit direction like the other position rows. This keeps `B M⁻¹ Bᵀ`
//!   well scaled and makes the reported violation a length.
//! - drive_angle: θ is the angle from `xa` to `xb` about `za`, so `cos θ = xa·xb` and
//!   `sin θ = ya·xb` when `zb ∥ za`; `sin(θ − f)` is expanded without forming θ (smooth,
//!   no branch cut).
//! - rolling: a sphere of radius `R = param` centred at `pa` on body a rolls on the plane
//!   through `pb` with normal `zb`. The nonholonomic rows say that the material point of
//!   a at the contact point `c = pa − R zb` has no velocity along `xb`, `yb`:
//!   `v_c = v_a + ω_a × (C_a ρ_a − R zb)`. **Side b must be ground** (the plane's axes are
//!   taken as constant in the velocity terms); the holonomic row is valid for any b.
//! - point_velocity: the material point `pa` of body a follows the world velocity
//!   `v(t)`: `v_a + ω_a × C_a ρ_a − v(t) = 0`. **Side b must be ground.**
//! - curve: `pa` stays on the curve `y = f(x)` in the plane of b's joint frame (x along
//!   `xb`, y along `yb`, measured from `pb`). Valid for any b.
//!
//! # Building blocks
//!
//! [`Side`] holds a body's pose and twist with `ω` in world components; [`Side::axis`]
//! and [`Side::point`] give the kinematics of a body-fixed direction or point ([`VecKin`],
//! [`PointKin`]). The primitives [`point_rows`], [`dot1`], [`dot2`], [`dot2_b`],
//! [`distance`] and [`material_velocity`] return [`RowJet`]s: a scalar row with its
//! Jacobian (ω part in **world** components until written out), its partial time
//! derivative, its total first derivative along the current motion and the
//! velocity-product part of its second derivative. [`RowJet::mul`], [`RowJet::compose`]
//! and [`RowJet::time`] combine rows with time functions by the product and chain rules.
//! [`write_rows`] converts the ω blocks to body components and stores what [`Need`] asks.
//!
//! The kernels are plain functions over `const`-constructible geometry, so generated code
//! can emit one `const JointGeom` per joint and call the same functions; the interpreter
//! dispatches to them through a `match` on the kind. No kernel allocates.

pub use crate::contract::joint_geom::JointGeom;
use crate::contract::math::vec3;
use crate::contract::system::{ConstraintEval, Need, Pose, RowJac, Twist};
use crate::kernels::fn1::Jet2;
use nalgebra::{Matrix3, Vector3};

/// The row slices of one joint in a [`ConstraintEval`].
#[derive(Debug)]
pub struct JointOut<'a> {
    /// Values.
    pub phi: &'a mut [f64],
    /// Jacobian rows.
    pub jac: &'a mut [RowJac],
    /// Bias (`∂Φ/∂t`, or `b` for nonholonomic rows).
    pub bias: &'a mut [f64],
    /// Acceleration right-hand side.
    pub gamma: &'a mut [f64],
}

impl<'a> JointOut<'a> {
    /// Borrow rows `first .. first + rows` of `ev`.
    #[inline]
    pub fn new(ev: &'a mut ConstraintEval, first: usize, rows: usize) -> JointOut<'a> {
        let r = first..first + rows;
        JointOut {
            phi: &mut ev.phi[r.clone()],
            jac: &mut ev.jac[r.clone()],
            bias: &mut ev.bias[r.clone()],
            gamma: &mut ev.gamma[r],
        }
    }
}

/// A body's state as used by the primitives: position, rotation, velocity and angular
/// velocity in **world** components (`ω_w = C ω`).
#[derive(Clone, Copy, Debug)]
pub struct Side {
    /// Mass-centre position, world.
    pub r: Vector3<f64>,
    /// Rotation body → world.
    pub c: Matrix3<f64>,
    /// Mass-centre velocity, world.
    pub v: Vector3<f64>,
    /// Angular velocity, world components.
    pub w: Vector3<f64>,
}

/// Kinematics of a body-fixed direction `e = C a`: value, rate `ė = ω × e` and the
/// velocity-product part of its second derivative `ω × (ω × e)` (the full second
/// derivative adds `ω̇ × e`, which belongs to `B u̇'`).
#[derive(Clone, Copy, Debug)]
pub struct VecKin {
    /// `e` (world).
    pub e: Vector3<f64>,
    /// `ė`.
    pub ed: Vector3<f64>,
    /// `ω × (ω × e)`.
    pub edd: Vector3<f64>,
}

/// Kinematics of a body-fixed point `p = r + s`, `s = C ρ`.
#[derive(Clone, Copy, Debug)]
pub struct PointKin {
    /// `p` (world).
    pub p: Vector3<f64>,
    /// Lever `s = C ρ` from the mass centre (world).
    pub s: Vector3<f64>,
    /// `ṗ = v + ω × s`.
    pub pd: Vector3<f64>,
    /// Velocity-product part of `p̈`: `ω × (ω × s)`.
    pub pdd: Vector3<f64>,
}

impl Side {
    /// From a pose and a twist (ω converted to world components).
    #[inline]
    pub fn new(p: &Pose, t: &Twist) -> Side {
        Side {
            r: p.r,
            c: p.c,
            v: t.v,
            w: p.c * t.w,
        }
    }

    /// A body-fixed direction given in body components.
    #[inline]
    pub fn axis(&self, a: &[f64; 3]) -> VecKin {
        let e = self.c * vec3(a);
        let ed = self.w.cross(&e);
        VecKin {
            e,
            ed,
            edd: self.w.cross(&ed),
        }
    }

    /// A body-fixed point given in body components relative to the mass centre.
    #[inline]
    pub fn point(&self, rho: &[f64; 3]) -> PointKin {
        let s = self.c * vec3(rho);
        let ws = self.w.cross(&s);
        PointKin {
            p: self.r + s,
            s,
            pd: self.v + ws,
            pdd: self.w.cross(&ws),
        }
    }
}

/// One scalar constraint row along the current motion.
///
/// For a holonomic row `Φ(q, t)`: `v = Φ`; `va, wa, vb, wb` = `∂Φ̇/∂(v_a, ω_a, v_b, ω_b)`
/// with the ω parts in **world** components; `pt = ∂Φ/∂t`; `d1 = Φ̇ = B u̇ + pt`;
/// `d2 = Φ̈ − B u̇'` (so `gamma = −d2`).
///
/// For a nonholonomic row `Φ = B u̇ + b`: `v = Φ`, the Jacobian is `B`, `pt = b`,
/// `d2 = Ḃu̇ + ḃ` (so again `gamma = −d2`); `d1` is unused (0).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RowJet {
    /// Value.
    pub v: f64,
    /// Gradient with respect to `v_a` (world).
    pub va: Vector3<f64>,
    /// Gradient with respect to `ω_a` in world components.
    pub wa: Vector3<f64>,
    /// Gradient with respect to `v_b`.
    pub vb: Vector3<f64>,
    /// Gradient with respect to `ω_b` in world components.
    pub wb: Vector3<f64>,
    /// Partial time derivative (bias).
    pub pt: f64,
    /// Total first time derivative along the motion.
    pub d1: f64,
    /// Velocity-product part of the second time derivative (`−gamma`).
    pub d2: f64,
}

impl RowJet {
    /// A function of time only: value `f`, `pt = d1 = ḟ`, `d2 = f̈`, no Jacobian.
    #[inline]
    pub fn time(f: Jet2) -> RowJet {
        RowJet {
            v: f.v,
            pt: f.d1,
            d1: f.d1,
            d2: f.d2,
            ..RowJet::default()
        }
    }

    /// `self + b`.
    #[inline]
    pub fn add(&self, b: &RowJet) -> RowJet {
        RowJet {
            v: self.v + b.v,
            va: self.va + b.va,
            wa: self.wa + b.wa,
            vb: self.vb + b.vb,
            wb: self.wb + b.wb,
            pt: self.pt + b.pt,
            d1: self.d1 + b.d1,
            d2: self.d2 + b.d2,
        }
    }

    /// `self − b`.
    #[inline]
    pub fn sub(&self, b: &RowJet) -> RowJet {
        self.add(&b.scale(-1.0))
    }

    /// `k · self` for a constant `k`.
    #[inline]
    pub fn scale(&self, k: f64) -> RowJet {
        RowJet {
            v: k * self.v,
            va: k * self.va,
            wa: k * self.wa,
            vb: k * self.vb,
            wb: k * self.wb,
            pt: k * self.pt,
            d1: k * self.d1,
            d2: k * self.d2,
        }
    }

    /// `self − k` for a constant `k` (value shift only).
    #[inline]
    pub fn offset(mut self, k: f64) -> RowJet {
        self.v -= k;
        self
    }

    /// The product `self · b` (product rule; `d2 = a'' b + 2 a' b' + a b''`).
    #[inline]
    pub fn mul(&self, b: &RowJet) -> RowJet {
        let a = self;
        RowJet {
            v: a.v * b.v,
            va: b.v * a.va + a.v * b.va,
            wa: b.v * a.wa + a.v * b.wa,
            vb: b.v * a.vb + a.v * b.vb,
            wb: b.v * a.wb + a.v * b.wb,
            pt: b.v * a.pt + a.v * b.pt,
            d1: b.v * a.d1 + a.v * b.d1,
            d2: b.v * a.d2 + 2.0 * a.d1 * b.d1 + a.v * b.d2,
        }
    }

    /// `g(self)` where `g = (g, g', g'')` is evaluated at `self.v` (chain rule:
    /// `d2 = g' a.d2 + g'' a.d1²`).
    #[inline]
    pub fn compose(&self, g: Jet2) -> RowJet {
        let a = self;
        RowJet {
            v: g.v,
            va: g.d1 * a.va,
            wa: g.d1 * a.wa,
            vb: g.d1 * a.vb,
            wb: g.d1 * a.wb,
            pt: g.d1 * a.pt,
            d1: g.d1 * a.d1,
            d2: g.d1 * a.d2 + g.d2 * a.d1 * a.d1,
        }
    }

    /// Exchange the roles of sides a and b.
    #[inline]
    pub fn swap(mut self) -> RowJet {
        std::mem::swap(&mut self.va, &mut self.vb);
        std::mem::swap(&mut self.wa, &mut self.wb);
        self
    }
}

/// Point coincidence `Φ = pa − pb` (3 rows, world x, y, z).
///
/// `B_a = [I, −C_a ρ̃_a]`, `B_b = [−I, C_b ρ̃_b]`, `Φ̈ − B u̇' = ω_a×(ω_a×s_a) − ω_b×(ω_b×s_b)`.
#[inline]
pub fn point_rows(pa: &PointKin, pb: &PointKin) -> [RowJet; 3] {
    let mut out = [RowJet::default(); 3];
    for (k, row) in out.iter_mut().enumerate() {
        let e = Vector3::ith(k, 1.0);
        *row = RowJet {
            v: pa.p[k] - pb.p[k],
            va: e,
            wa: pa.s.cross(&e),
            vb: -e,
            wb: e.cross(&pb.s),
            pt: 0.0,
            d1: pa.pd[k] - pb.pd[k],
            d2: pa.pdd[k] - pb.pdd[k],
        };
    }
    out
}

/// "Dot-1": perpendicularity of two body-fixed directions, `Φ = ea·eb` (`ea` on side a,
/// `eb` on side b). `∂Φ̇/∂ω_a = ea × eb`, `∂Φ̇/∂ω_b = eb × ea` (world),
/// `Φ̈ − B u̇' = ëa·eb + 2 ėa·ėb + ea·ëb` (velocity-product parts).
#[inline]
pub fn dot1(ea: &VecKin, eb: &VecKin) -> RowJet {
    let x = ea.e.cross(&eb.e);
    RowJet {
        v: ea.e.dot(&eb.e),
        va: Vector3::zeros(),
        wa: x,
        vb: Vector3::zeros(),
        wb: -x,
        pt: 0.0,
        d1: ea.ed.dot(&eb.e) + ea.e.dot(&eb.ed),
        d2: ea.edd.dot(&eb.e) + 2.0 * ea.ed.dot(&eb.ed) + ea.e.dot(&eb.edd),
    }
}

/// "Dot-2": perpendicularity of a direction `ea` fixed to side a and the separation
/// `d = pb − pa`: `Φ = ea·d`. `∂/∂v_a = −ea`, `∂/∂v_b = ea`, `∂/∂ω_a = ea × (d + s_a)`,
/// `∂/∂ω_b = s_b × ea` (world), `Φ̈ − B u̇' = ëa·d + 2 ėa·ḋ + ea·(ω_b×(ω_b×s_b) − ω_a×(ω_a×s_a))`.
#[inline]
pub fn dot2(ea: &VecKin, pa: &PointKin, pb: &PointKin) -> RowJet {
    let d = pb.p - pa.p;
    let dd = pb.pd - pa.pd;
    let ddd = pb.pdd - pa.pdd;
    RowJet {
        v: ea.e.dot(&d),
        va: -ea.e,
        wa: ea.e.cross(&(d + pa.s)),
        vb: ea.e,
        wb: pb.s.cross(&ea.e),
        pt: 0.0,
        d1: ea.ed.dot(&d) + ea.e.dot(&dd),
        d2: ea.edd.dot(&d) + 2.0 * ea.ed.dot(&dd) + ea.e.dot(&ddd),
    }
}

/// Dot-2 with the direction on side b: `Φ = eb·(pa − pb)` ([`dot2`] with the sides
/// exchanged).
#[inline]
pub fn dot2_b(eb: &VecKin, pa: &PointKin, pb: &PointKin) -> RowJet {
    dot2(eb, pb, pa).swap()
}

/// Distance `Φ = (d·d − L²)/(2L)`, `d = pb − pa` (see the module doc for the scaling).
/// `∂/∂v_b = d/L = −∂/∂v_a`, `∂/∂ω_a = (d × s_a)/L`, `∂/∂ω_b = (s_b × d)/L`,
/// `Φ̈ − B u̇' = (ḋ·ḋ + d·(ω_b×(ω_b×s_b) − ω_a×(ω_a×s_a)))/L`.
#[inline]
pub fn distance(pa: &PointKin, pb: &PointKin, l: f64) -> RowJet {
    let d = pb.p - pa.p;
    let dd = pb.pd - pa.pd;
    let ddd = pb.pdd - pa.pdd;
    let il = 1.0 / l;
    RowJet {
        v: 0.5 * (d.norm_squared() - l * l) * il,
        va: -il * d,
        wa: il * d.cross(&pa.s),
        vb: il * d,
        wb: il * pb.s.cross(&d),
        pt: 0.0,
        d1: il * d.dot(&dd),
        d2: il * (dd.norm_squared() + d.dot(&ddd)),
    }
}

/// Nonholonomic "material point velocity" row of side a along a **constant** world
/// direction `e`: `Φ = e·(v_a + ω_a × lever) + b` where `lever` is the offset from the mass
/// centre of the material point whose velocity is constrained, and `lever_rate` its time
/// derivative at fixed `(v, ω_body)` (for a body-fixed point, `ω × lever`; for the
/// contact point of a rolling sphere, `ω × s` of the centre). `b = (b, ḃ)` is the
/// explicit time term. Returns `v = Φ`, `B = [e, lever × e]`, `pt = b`,
/// `d2 = Ḃu̇ + ḃ = e·(ω_a × lever_rate) + ḃ`.
#[inline]
pub fn material_velocity(
    e: &Vector3<f64>,
    a: &Side,
    lever: &Vector3<f64>,
    lever_rate: &Vector3<f64>,
    b: Jet2,
) -> RowJet {
    RowJet {
        v: e.dot(&(a.v + a.w.cross(lever))) + b.v,
        va: *e,
        wa: lever.cross(e),
        vb: Vector3::zeros(),
        wb: Vector3::zeros(),
        pt: b.v,
        d1: 0.0,
        d2: e.dot(&a.w.cross(lever_rate)) + b.d1,
    }
}

/// Store rows into a joint's slices: `phi = v` (if `need.phi`), `jac` with the ω parts
/// mapped to body components `Cᵀ w` and `bias = pt` (if `need.jac`), `gamma = −d2` (if
/// `need.gamma`).
#[inline]
pub fn write_rows(rows: &[RowJet], a: &Side, b: &Side, need: Need, out: JointOut<'_>) {
    for (i, r) in rows.iter().enumerate() {
        if need.phi {
            out.phi[i] = r.v;
        }
        if need.jac {
            let wa = a.c.tr_mul(&r.wa);
            let wb = b.c.tr_mul(&r.wb);
            out.jac[i] = RowJac {
                a: [r.va.x, r.va.y, r.va.z, wa.x, wa.y, wa.z],
                b: [r.vb.x, r.vb.y, r.vb.z, wb.x, wb.y, wb.z],
            };
            out.bias[i] = r.pt;
        }
        if need.gamma {
            out.gamma[i] = -r.d2;
        }
    }
}

/// Spherical joint (3 rows): `pa − pb`.
pub fn spherical(
    g: &JointGeom,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let rows = point_rows(&a.point(&g.pa), &b.point(&g.pb));
    write_rows(&rows, &a, &b, need, out);
}

/// Revolute joint (5 rows): `pa − pb` (3), `za·xb`, `za·yb`.
pub fn revolute(
    g: &JointGeom,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let [p0, p1, p2] = point_rows(&a.point(&g.pa), &b.point(&g.pb));
    let za = a.axis(&g.fa[2]);
    let rows = [
        p0,
        p1,
        p2,
        dot1(&za, &b.axis(&g.fb[0])),
        dot1(&za, &b.axis(&g.fb[1])),
    ];
    write_rows(&rows, &a, &b, need, out);
}

/// Prismatic joint (5 rows): `za·xb`, `za·yb`, `xa·yb`, `xa·d`, `ya·d`.
pub fn prismatic(
    g: &JointGeom,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let (xa, ya, za) = (a.axis(&g.fa[0]), a.axis(&g.fa[1]), a.axis(&g.fa[2]));
    let (xb, yb) = (b.axis(&g.fb[0]), b.axis(&g.fb[1]));
    let (qa, qb) = (a.point(&g.pa), b.point(&g.pb));
    let rows = [
        dot1(&za, &xb),
        dot1(&za, &yb),
        dot1(&xa, &yb),
        dot2(&xa, &qa, &qb),
        dot2(&ya, &qa, &qb),
    ];
    write_rows(&rows, &a, &b, need, out);
}

/// Cylindrical joint (4 rows): `za·xb`, `za·yb`, `xa·d`, `ya·d`.
pub fn cylindrical(
    g: &JointGeom,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let (xa, ya, za) = (a.axis(&g.fa[0]), a.axis(&g.fa[1]), a.axis(&g.fa[2]));
    let (xb, yb) = (b.axis(&g.fb[0]), b.axis(&g.fb[1]));
    let (qa, qb) = (a.point(&g.pa), b.point(&g.pb));
    let rows = [
        dot1(&za, &xb),
        dot1(&za, &yb),
        dot2(&xa, &qa, &qb),
        dot2(&ya, &qa, &qb),
    ];
    write_rows(&rows, &a, &b, need, out);
}

/// Universal joint (4 rows): `pa − pb` (3), `za·zb`.
pub fn universal(
    g: &JointGeom,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let [p0, p1, p2] = point_rows(&a.point(&g.pa), &b.point(&g.pb));
    let rows = [p0, p1, p2, dot1(&a.axis(&g.fa[2]), &b.axis(&g.fb[2]))];
    write_rows(&rows, &a, &b, need, out);
}

/// Fixed joint (6 rows): `pa − pb` (3), `za·xb`, `za·yb`, `xa·yb`.
pub fn fixed(
    g: &JointGeom,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let [p0, p1, p2] = point_rows(&a.point(&g.pa), &b.point(&g.pb));
    let (xa, za) = (a.axis(&g.fa[0]), a.axis(&g.fa[2]));
    let (xb, yb) = (b.axis(&g.fb[0]), b.axis(&g.fb[1]));
    let rows = [p0, p1, p2, dot1(&za, &xb), dot1(&za, &yb), dot1(&xa, &yb)];
    write_rows(&rows, &a, &b, need, out);
}

/// Planar joint (3 rows): `za·d`, `za·xb`, `za·yb`.
pub fn planar(
    g: &JointGeom,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let za = a.axis(&g.fa[2]);
    let (xb, yb) = (b.axis(&g.fb[0]), b.axis(&g.fb[1]));
    let rows = [
        dot2(&za, &a.point(&g.pa), &b.point(&g.pb)),
        dot1(&za, &xb),
        dot1(&za, &yb),
    ];
    write_rows(&rows, &a, &b, need, out);
}

/// Distance joint (1 row): `(d·d − L²)/(2L)` with `L = g.param`.
pub fn distance_joint(
    g: &JointGeom,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let rows = [distance(&a.point(&g.pa), &b.point(&g.pb), g.param)];
    write_rows(&rows, &a, &b, need, out);
}

/// The row `sin(θ − f)` with θ from `xa` to `xb` about `za`, expanded as
/// `(ya·xb) cos f − (xa·xb) sin f`; `f` is a time jet `(f, ḟ, f̈)`.
#[inline]
pub fn angle_row(g: &JointGeom, a: &Side, b: &Side, f: Jet2) -> RowJet {
    let xb = b.axis(&g.fb[0]);
    let s = dot1(&a.axis(&g.fa[1]), &xb);
    let k = dot1(&a.axis(&g.fa[0]), &xb);
    s.mul(&RowJet::time(f.cos()))
        .sub(&k.mul(&RowJet::time(f.sin())))
}

/// Angle driver (1 row, rheonomic): `sin(θ − f(t))`, `f = (f(t), ḟ(t), f̈(t))`. Also
/// used for joint locks with a constant `f = θ_lock`.
#[allow(clippy::too_many_arguments)]
pub fn drive_angle(
    g: &JointGeom,
    f: Jet2,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    write_rows(&[angle_row(g, &a, &b, f)], &a, &b, need, out);
}

/// Displacement driver (1 row, rheonomic): `za·d − f(t)`.
#[allow(clippy::too_many_arguments)]
pub fn drive_displacement(
    g: &JointGeom,
    f: Jet2,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let za = a.axis(&g.fa[2]);
    let row = dot2(&za, &a.point(&g.pa), &b.point(&g.pb)).sub(&RowJet::time(f));
    write_rows(&[row], &a, &b, need, out);
}

/// Rolling sphere on a ground plane (3 rows): `zb·(pa − pb) − R` (holonomic), then the
/// nonholonomic no-slip rows `xb·v_c`, `yb·v_c` with `v_c = v_a + ω_a × (C_a ρ_a − R zb)`.
/// `R = g.param`; side b must be ground.
pub fn rolling(
    g: &JointGeom,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let r = g.param;
    let (qa, qb) = (a.point(&g.pa), b.point(&g.pb));
    let n = b.axis(&g.fb[2]);
    let contact = dot2_b(&n, &qa, &qb).offset(r);
    let lever = qa.s - r * n.e;
    let rate = a.w.cross(&qa.s);
    let zero = Jet2::constant(0.0);
    let sx = material_velocity(&b.axis(&g.fb[0]).e, &a, &lever, &rate, zero);
    let sy = material_velocity(&b.axis(&g.fb[1]).e, &a, &lever, &rate, zero);
    write_rows(&[contact, sx, sy], &a, &b, need, out);
}

/// Prescribed point velocity (3 nonholonomic rows): `v_a + ω_a × C_a ρ_a − v(t)` (world
/// x, y, z), `v = [(v_k, v̇_k, ·)]`. Side b must be ground.
#[allow(clippy::too_many_arguments)]
pub fn point_velocity(
    g: &JointGeom,
    v: [Jet2; 3],
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let q = a.point(&g.pa);
    let rate = a.w.cross(&q.s);
    let mut rows = [RowJet::default(); 3];
    for (k, row) in rows.iter_mut().enumerate() {
        *row = material_velocity(&Vector3::ith(k, 1.0), &a, &q.s, &rate, -v[k]);
    }
    write_rows(&rows, &a, &b, need, out);
}

/// Point on a plane curve (1 row): `y − f(x)` with `x = xb·(pa − pb)`,
/// `y = yb·(pa − pb)`. `f` returns `(f(x), f'(x), f''(x))`.
#[allow(clippy::too_many_arguments)]
pub fn curve<F: Fn(f64) -> Jet2>(
    g: &JointGeom,
    f: F,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
    need: Need,
    out: JointOut<'_>,
) {
    let (a, b) = (Side::new(pa, ta), Side::new(pb, tb));
    let (qa, qb) = (a.point(&g.pa), b.point(&g.pb));
    let x = dot2_b(&b.axis(&g.fb[0]), &qa, &qb);
    let y = dot2_b(&b.axis(&g.fb[1]), &qa, &qb);
    let row = y.sub(&x.compose(f(x.v)));
    write_rows(&[row], &a, &b, need, out);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::math::{axis_angle, quat_array};
    use crate::contract::scene::{Attachment, BodyRef};
    use nalgebra::Quaternion;

    fn att(body: BodyRef, point: [f64; 3], frame: Quaternion<f64>) -> Attachment {
        Attachment {
            body,
            point,
            frame: quat_array(&frame),
        }
    }

    #[test]
    fn geometry_axes_are_frame_columns() {
        let f = axis_angle(&Vector3::new(0.0, 1.0, 0.0), std::f64::consts::FRAC_PI_2);
        let g = JointGeom::new(
            &att(BodyRef::Body(0), [1.0, 2.0, 3.0], f),
            &att(BodyRef::Ground, [0.0; 3], Quaternion::identity()),
            0.5,
        );
        // 90° about y maps x → −z, y → y, z → +x (the joint axes in body components).
        let want = [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]];
        for (axis, w) in g.fa.iter().zip(&want) {
            for (x, y) in axis.iter().zip(w) {
                assert!((x - y).abs() < 1e-15, "axes {:?}", g.fa);
            }
        }
        assert_eq!(g.fb, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        assert_eq!(g.param, 0.5);
    }

    #[test]
    fn const_geometry_compiles() {
        const G: JointGeom = JointGeom {
            pa: [0.0, 0.0, 0.5],
            pb: [0.0; 3],
            fa: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            fb: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            qa: [1.0, 0.0, 0.0, 0.0],
            qb: [1.0, 0.0, 0.0, 0.0],
            param: 0.0,
        };
        static S: JointGeom = G;
        let mut ev = ConstraintEval::new(3);
        let p = Pose::default();
        let t = Twist::default();
        spherical(&S, &p, &p, &t, &t, Need::ALL, JointOut::new(&mut ev, 0, 3));
        assert_eq!(ev.phi, vec![0.0, 0.0, 0.5]);
        // parent block +I, child block −I in v (notes C §1.4)
        assert_eq!(&ev.jac[0].a[..3], &[1.0, 0.0, 0.0]);
        assert_eq!(&ev.jac[0].b[..3], &[-1.0, 0.0, 0.0]);
    }

    #[test]
    fn spherical_blocks_match_notes_c() {
        // Child block [−I, C ρ̃] for ω in body components (notes C §1.4).
        let q = axis_angle(&Vector3::new(1.0, 2.0, 3.0), 0.7);
        let pose = Pose::new(Vector3::new(0.1, 0.2, 0.3), q);
        let rho = [0.3, -0.2, 0.5];
        let g = JointGeom::new(
            &att(BodyRef::Ground, [0.0; 3], Quaternion::identity()),
            &att(BodyRef::Body(0), rho, Quaternion::identity()),
            0.0,
        );
        let mut ev = ConstraintEval::new(3);
        let t = Twist::default();
        spherical(
            &g,
            &Pose::default(),
            &pose,
            &t,
            &t,
            Need::ALL,
            JointOut::new(&mut ev, 0, 3),
        );
        let m = pose.c * crate::contract::math::skew(&vec3(&rho));
        for k in 0..3 {
            for j in 0..3 {
                assert!((ev.jac[k].b[3 + j] - m[(k, j)]).abs() < 1e-15);
                assert_eq!(ev.jac[k].b[j], if j == k { -1.0 } else { 0.0 });
            }
        }
    }

    #[test]
    fn rowjet_product_and_chain_rules() {
        // Two time-only rows: check against Jet2 arithmetic.
        let a = Jet2::new(1.5, 0.3, -0.7);
        let b = Jet2::new(-0.4, 2.0, 0.25);
        let p = RowJet::time(a).mul(&RowJet::time(b));
        let q = a * b;
        assert!(
            (p.v - q.v).abs() < 1e-15 && (p.d1 - q.d1).abs() < 1e-15 && (p.d2 - q.d2).abs() < 1e-15
        );
        assert!((p.pt - q.d1).abs() < 1e-15);
        let c = RowJet::time(a).compose(Jet2::new(a.v.sin(), a.v.cos(), -a.v.sin()));
        let s = a.sin();
        assert!((c.d1 - s.d1).abs() < 1e-15 && (c.d2 - s.d2).abs() < 1e-15);
    }
}
