//! Penalty contact: sphere–plane, sphere–sphere and box–plane (box corners), with a
//! linear spring–damper normal law that never pulls and regularized Coulomb friction.
//!
//! # Point-contact law ([`point_contact`])
//!
//! At a contact point `x` (world) with unit normal `n` pointing from shape b towards
//! shape a and penetration depth `δ > 0`:
//!
//! ```text
//! v_rel = (v_a + ω_a × (x − r_a)) − (v_b + ω_b × (x − r_b))     material-point velocities
//! v_n   = n·v_rel                (> 0: separating)
//! f_n   = max(0, k δ − c v_n)    (no pulling force)
//! v_t   = v_rel − v_n n
//! F_t   = −μ f_n v_t / √(|v_t|² + v_s²)   (regularized Coulomb, |F_t| < μ f_n)
//! F     = f_n n + F_t            on a at x;  −F on b at x
//! ```
//!
//! `v_s` ([`ContactLaw::reg_speed`], default [`FRICTION_REG_SPEED`]) is the regularization
//! speed: below it friction behaves like a viscous damper of coefficient `μ f_n / v_s`, so
//! an explicit integrator needs `h ≲ 2 m v_s / (μ f_n)`. Stored elastic energy is
//! `½ k δ²` per active point (the damper and friction are dissipative).
//!
//! # Geometry
//!
//! - Sphere (side a, centre `c`, radius `R`) – plane (side b, through `p0`, normal `n`):
//!   `δ = R − n·(c − p0)`, contact point = projection of the centre on the plane.
//! - Sphere–sphere: `n = (c_a − c_b)/|c_a − c_b|`, `δ = R_a + R_b − |c_a − c_b|`, contact
//!   point midway through the overlap, `x = c_b + (R_b − δ/2) n`. Coincident centres give
//!   no force (no defined normal).
//! - Box (side a, centre and axes of its attachment frame, half extents `h`) – plane: each
//!   of the 8 corners below the plane is a point contact with `δ = −n·(corner − p0)` at the
//!   corner; the stiffness and damping apply per corner.
//!
//! Normals and shapes are body-fixed: the plane's normal and point, the box axes and the
//! sphere centres are given in body components (world for ground).

use crate::contract::math::vec3;
use crate::contract::system::{Pose, Twist, Wrench};
use crate::kernels::forces::add_wrench;
use nalgebra::Vector3;

/// Default friction regularization speed, m/s.
pub const FRICTION_REG_SPEED: f64 = 1e-2;

/// The contact law's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactLaw {
    /// Normal penalty stiffness `k`, N/m.
    pub stiffness: f64,
    /// Normal damping `c`, N·s/m.
    pub damping: f64,
    /// Coulomb coefficient `μ`.
    pub friction: f64,
    /// Friction regularization speed `v_s`, m/s (> 0).
    pub reg_speed: f64,
}

/// A sphere on side a against a plane on side b.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpherePlane {
    /// Sphere centre, body-a components relative to a's mass centre.
    pub centre: [f64; 3],
    /// Sphere radius, m.
    pub radius: f64,
    /// A point of the plane, body-b components.
    pub point: [f64; 3],
    /// Unit plane normal (pointing into the half-space where the sphere belongs), body-b
    /// components.
    pub normal: [f64; 3],
    /// Contact law.
    pub law: ContactLaw,
}

/// Two spheres, one on each side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereSphere {
    /// Centre of sphere a, body-a components.
    pub centre_a: [f64; 3],
    /// Radius of sphere a.
    pub radius_a: f64,
    /// Centre of sphere b, body-b components.
    pub centre_b: [f64; 3],
    /// Radius of sphere b.
    pub radius_b: f64,
    /// Contact law.
    pub law: ContactLaw,
}

/// A box on side a against a plane on side b.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxPlane {
    /// Box centre, body-a components.
    pub centre: [f64; 3],
    /// Box axes `[x, y, z]` (unit, orthogonal) in body-a components.
    pub axes: [[f64; 3]; 3],
    /// Half extents along the box axes, m.
    pub half: [f64; 3],
    /// A point of the plane, body-b components.
    pub point: [f64; 3],
    /// Unit plane normal, body-b components.
    pub normal: [f64; 3],
    /// Contact law.
    pub law: ContactLaw,
}

/// Wrenches on a and b of one point contact (see the module doc). Returns zero wrenches
/// when `depth ≤ 0`.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn point_contact(
    law: &ContactLaw,
    n: &Vector3<f64>,
    depth: f64,
    x: &Vector3<f64>,
    pa: &Pose,
    ta: &Twist,
    pb: &Pose,
    tb: &Twist,
) -> (Wrench, Wrench) {
    if depth <= 0.0 {
        return (Wrench::default(), Wrench::default());
    }
    let la = x - pa.r;
    let lb = x - pb.r;
    let va = ta.v + (pa.c * ta.w).cross(&la);
    let vb = tb.v + (pb.c * tb.w).cross(&lb);
    let vrel = va - vb;
    let vn = n.dot(&vrel);
    let fnorm = (law.stiffness * depth - law.damping * vn).max(0.0);
    let mut f = fnorm * n;
    if law.friction != 0.0 && fnorm > 0.0 {
        let vt = vrel - vn * n;
        let s = (vt.norm_squared() + law.reg_speed * law.reg_speed).sqrt();
        f -= (law.friction * fnorm / s) * vt;
    }
    (
        Wrench {
            f,
            t: pa.c.tr_mul(&la.cross(&f)),
        },
        Wrench {
            f: -f,
            t: pb.c.tr_mul(&lb.cross(&(-f))),
        },
    )
}

/// Plane point and unit normal in world components.
#[inline]
fn plane(pose: &Pose, point: &[f64; 3], normal: &[f64; 3]) -> (Vector3<f64>, Vector3<f64>) {
    let n = pose.c * vec3(normal);
    (pose.point(&vec3(point)), n / n.norm())
}

/// Sphere–plane contact wrenches.
#[inline]
pub fn sphere_plane(
    g: &SpherePlane,
    pa: &Pose,
    ta: &Twist,
    pb: &Pose,
    tb: &Twist,
) -> (Wrench, Wrench) {
    let c = pa.point(&vec3(&g.centre));
    let (p0, n) = plane(pb, &g.point, &g.normal);
    let h = n.dot(&(c - p0));
    let depth = g.radius - h;
    point_contact(&g.law, &n, depth, &(c - h * n), pa, ta, pb, tb)
}

/// Sphere–plane elastic energy `½ k δ²`.
#[inline]
pub fn sphere_plane_energy(g: &SpherePlane, pa: &Pose, pb: &Pose) -> f64 {
    let c = pa.point(&vec3(&g.centre));
    let (p0, n) = plane(pb, &g.point, &g.normal);
    let depth = (g.radius - n.dot(&(c - p0))).max(0.0);
    0.5 * g.law.stiffness * depth * depth
}

/// Sphere–sphere contact wrenches.
#[inline]
pub fn sphere_sphere(
    g: &SphereSphere,
    pa: &Pose,
    ta: &Twist,
    pb: &Pose,
    tb: &Twist,
) -> (Wrench, Wrench) {
    let ca = pa.point(&vec3(&g.centre_a));
    let cb = pb.point(&vec3(&g.centre_b));
    let d = ca - cb;
    let dist = d.norm();
    let depth = g.radius_a + g.radius_b - dist;
    if depth <= 0.0 || dist == 0.0 {
        return (Wrench::default(), Wrench::default());
    }
    let n = d / dist;
    let x = cb + (g.radius_b - 0.5 * depth) * n;
    point_contact(&g.law, &n, depth, &x, pa, ta, pb, tb)
}

/// Sphere–sphere elastic energy.
#[inline]
pub fn sphere_sphere_energy(g: &SphereSphere, pa: &Pose, pb: &Pose) -> f64 {
    let d = pa.point(&vec3(&g.centre_a)) - pb.point(&vec3(&g.centre_b));
    let depth = (g.radius_a + g.radius_b - d.norm()).max(0.0);
    0.5 * g.law.stiffness * depth * depth
}

/// World corner `i` (0..8) of the box; bit k of `i` selects the sign along axis k.
#[inline]
fn corner(g: &BoxPlane, pa: &Pose, i: usize) -> Vector3<f64> {
    let mut p = vec3(&g.centre);
    for k in 0..3 {
        let s = if i & (1 << k) != 0 {
            g.half[k]
        } else {
            -g.half[k]
        };
        p += s * vec3(&g.axes[k]);
    }
    pa.point(&p)
}

/// Box–plane contact wrenches (sum over the corners below the plane).
#[inline]
pub fn box_plane(g: &BoxPlane, pa: &Pose, ta: &Twist, pb: &Pose, tb: &Twist) -> (Wrench, Wrench) {
    let (p0, n) = plane(pb, &g.point, &g.normal);
    let mut wa = Wrench::default();
    let mut wb = Wrench::default();
    for i in 0..8 {
        let x = corner(g, pa, i);
        let depth = -n.dot(&(x - p0));
        if depth > 0.0 {
            let (a, b) = point_contact(&g.law, &n, depth, &x, pa, ta, pb, tb);
            add_wrench(&mut wa, &a);
            add_wrench(&mut wb, &b);
        }
    }
    (wa, wb)
}

/// Box–plane elastic energy (sum over corners).
#[inline]
pub fn box_plane_energy(g: &BoxPlane, pa: &Pose, pb: &Pose) -> f64 {
    let (p0, n) = plane(pb, &g.point, &g.normal);
    (0..8)
        .map(|i| {
            let depth = (-n.dot(&(corner(g, pa, i) - p0))).max(0.0);
            0.5 * g.law.stiffness * depth * depth
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::math::axis_angle;

    const LAW: ContactLaw = ContactLaw {
        stiffness: 1e4,
        damping: 10.0,
        friction: 0.5,
        reg_speed: FRICTION_REG_SPEED,
    };

    fn ground_plane() -> ([f64; 3], [f64; 3]) {
        ([0.0; 3], [0.0, 0.0, 1.0])
    }

    #[test]
    fn sphere_resting_on_plane() {
        let (point, normal) = ground_plane();
        let g = SpherePlane {
            centre: [0.0; 3],
            radius: 0.5,
            point,
            normal,
            law: LAW,
        };
        let pa = Pose::new(Vector3::new(1.0, 2.0, 0.49), axis_angle(&Vector3::x(), 0.3));
        let (wa, wb) = sphere_plane(
            &g,
            &pa,
            &Twist::default(),
            &Pose::default(),
            &Twist::default(),
        );
        assert!((wa.f - Vector3::new(0.0, 0.0, 100.0)).norm() < 1e-9);
        assert!(wa.t.norm() < 1e-12); // force through the centre
        assert!((wa.f + wb.f).norm() < 1e-12);
        assert!((sphere_plane_energy(&g, &pa, &Pose::default()) - 0.5).abs() < 1e-9);
        // above the plane: nothing
        let up = Pose::new(Vector3::new(0.0, 0.0, 0.6), pa.q);
        let (wa, _) = sphere_plane(
            &g,
            &up,
            &Twist::default(),
            &Pose::default(),
            &Twist::default(),
        );
        assert_eq!(wa.f, Vector3::zeros());
    }

    #[test]
    fn no_pulling_and_friction_bounded_and_opposing() {
        let (point, normal) = ground_plane();
        let g = SpherePlane {
            centre: [0.0; 3],
            radius: 0.5,
            point,
            normal,
            law: LAW,
        };
        let pa = Pose::new(
            Vector3::new(0.0, 0.0, 0.499),
            nalgebra::Quaternion::identity(),
        );
        // separating fast: damping would pull, the law clamps to zero
        let t = Twist {
            v: Vector3::new(0.0, 0.0, 5.0),
            w: Vector3::zeros(),
        };
        let (wa, _) = sphere_plane(&g, &pa, &t, &Pose::default(), &Twist::default());
        assert_eq!(wa.f, Vector3::zeros());
        // sliding along +x: friction along −x, below μ f_n
        let t = Twist {
            v: Vector3::new(2.0, 0.0, 0.0),
            w: Vector3::zeros(),
        };
        let (wa, _) = sphere_plane(&g, &pa, &t, &Pose::default(), &Twist::default());
        assert!(wa.f.x < 0.0 && wa.f.x.abs() <= LAW.friction * wa.f.z);
        assert!((wa.f.x.abs() - LAW.friction * wa.f.z).abs() < 1e-4 * wa.f.z);
        // the friction force at the contact point exerts a torque about the centre
        let tw = pa.c * wa.t;
        assert!(tw.y > 0.0); // (−R ẑ) × (−F x̂) = +R F ŷ: spins the ball towards rolling
                             // rolling without slip: contact point at rest, no friction
        let w = Vector3::new(0.0, 4.0, 0.0);
        let t = Twist {
            v: w.cross(&Vector3::new(0.0, 0.0, 0.499)),
            w,
        };
        let (wa, _) = sphere_plane(&g, &pa, &t, &Pose::default(), &Twist::default());
        assert!(wa.f.x.abs() < 1e-9 && wa.f.y.abs() < 1e-9);
    }

    #[test]
    fn sphere_sphere_symmetric() {
        let g = SphereSphere {
            centre_a: [0.0; 3],
            radius_a: 0.3,
            centre_b: [0.0; 3],
            radius_b: 0.2,
            law: LAW,
        };
        let pa = Pose::new(
            Vector3::new(0.45, 0.0, 0.0),
            nalgebra::Quaternion::identity(),
        );
        let pb = Pose::default();
        let (wa, wb) = sphere_sphere(&g, &pa, &Twist::default(), &pb, &Twist::default());
        assert!((wa.f - Vector3::new(500.0, 0.0, 0.0)).norm() < 1e-9);
        assert!((wa.f + wb.f).norm() < 1e-12);
        assert!((sphere_sphere_energy(&g, &pa, &pb) - 12.5).abs() < 1e-9);
        let (wa, _) = sphere_sphere(&g, &pb, &Twist::default(), &pb, &Twist::default());
        assert_eq!(wa.f, Vector3::zeros());
    }

    #[test]
    fn box_on_plane_corners() {
        let (point, normal) = ground_plane();
        let g = BoxPlane {
            centre: [0.0; 3],
            axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            half: [0.5, 0.3, 0.1],
            point,
            normal,
            law: ContactLaw {
                damping: 0.0,
                friction: 0.0,
                ..LAW
            },
        };
        // flat, 1 mm into the plane: four corners, total 4 k δ, no torque
        let pa = Pose::new(
            Vector3::new(0.0, 0.0, 0.099),
            nalgebra::Quaternion::identity(),
        );
        let (wa, _) = box_plane(
            &g,
            &pa,
            &Twist::default(),
            &Pose::default(),
            &Twist::default(),
        );
        assert!((wa.f.z - 4.0 * 1e4 * 1e-3).abs() < 1e-8);
        assert!(wa.t.norm() < 1e-9);
        assert!(
            (box_plane_energy(&g, &pa, &Pose::default()) - 4.0 * 0.5 * 1e4 * 1e-6).abs() < 1e-12
        );
        // tilted about y: only the low edge touches, torque about y
        let pa = Pose::new(Vector3::new(0.0, 0.0, 0.1), axis_angle(&Vector3::y(), 0.01));
        let (wa, _) = box_plane(
            &g,
            &pa,
            &Twist::default(),
            &Pose::default(),
            &Twist::default(),
        );
        assert!(wa.f.z > 0.0);
        assert!((pa.c * wa.t).y.abs() > 1e-3);
    }

    #[test]
    fn elastic_force_is_minus_gradient_of_energy() {
        let (point, normal) = ground_plane();
        let law = ContactLaw {
            damping: 0.0,
            friction: 0.0,
            ..LAW
        };
        let g = BoxPlane {
            centre: [0.1, 0.0, 0.0],
            axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            half: [0.5, 0.3, 0.1],
            point,
            normal,
            law,
        };
        let q = axis_angle(&Vector3::new(1.0, 0.5, 0.0), 0.05);
        let pa = Pose::new(Vector3::new(0.0, 0.0, 0.12), q);
        let tw = Twist {
            v: Vector3::new(0.1, 0.2, -0.3),
            w: Vector3::new(0.5, -0.4, 0.3),
        };
        let h = 1e-6;
        let step = |s: f64| {
            Pose::new(
                pa.r + tw.v * s,
                pa.q + crate::contract::math::quat_rate(&pa.q, &tw.w) * s,
            )
        };
        let z = Twist::default();
        let dv = (box_plane_energy(&g, &step(h), &Pose::default())
            - box_plane_energy(&g, &step(-h), &Pose::default()))
            / (2.0 * h);
        let (wa, _) = box_plane(&g, &pa, &z, &Pose::default(), &z);
        let p = wa.f.dot(&tw.v) + wa.t.dot(&tw.w);
        assert!(
            (dv + p).abs() < 1e-5 * (1.0 + dv.abs()),
            "dV/dt {dv} vs −P {}",
            -p
        );
        assert!(dv.abs() > 1.0);
    }
}
