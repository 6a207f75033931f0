//! Applied-force kernels: gravity, point forces and torques, translational and rotational
//! spring–dampers, and their potential energies. Contact is in [`crate::kernels::contact`].
//!
//! Every kernel returns [`Wrench`]es in the runtime's convention: the force acts at the
//! mass centre in **world** components, the torque about the mass centre in **body**
//! components. A force `F` (world) applied at a body point with lever `s = C ρ` gives the
//! wrench `(F, Cᵀ(s × F)) = (F, ρ × CᵀF)`.
//!
//! - Gravity: `F = m g`; potential `V = −m g·r`.
//! - Translational spring–damper between points `pa`, `pb` (world), `d = pb − pa`,
//!   `ℓ = |d|`, `e = d/ℓ`, `ℓ̇ = e·(ṗb − ṗa)`: tension `f = k (ℓ − ℓ0) + c ℓ̇` pulls the ends
//!   together when positive: `+f e` on a at `pa`, `−f e` on b at `pb`. Potential
//!   `½ k (ℓ − ℓ0)²`. Zero length (`ℓ ≤ 1e-12 (1 + ℓ0)`): the direction is undefined; the
//!   spring force is taken as its limit `k d` when `ℓ0 = 0` and as zero otherwise, and
//!   the damper is off (a measure-zero event).
//! - Rotational spring–damper about a revolute or cylindrical joint's z axis: with the
//!   joint frames `q_ja = q_a ⊗ f_a`, `q_jb = q_b ⊗ f_b` and the relative rotation
//!   `q_rel = q_ja* ⊗ q_jb = (w, x, y, z)`, the continuous angle is
//!   `θ = 2 atan2(s z, s w) ∈ (−2π, 2π]`, where `s = ±1` is the sign of `w` at the initial
//!   state ([`joint_angle_sign`]), so `θ = 0` when the frames coincide and θ runs
//!   continuously through ±π up to a full turn. Its rate, exactly,
//!   `θ̇ = 2 (w ż − z ẇ)/(w² + z²) = g_b·Ω_b − g_a·Ω_a` with `Ω_{a,b}` the angular
//!   velocities in joint-frame components and
//!   `g_b = (zx − wy, wx + zy, w² + z²)/(w² + z²)`,
//!   `g_a = (wy + zx, zy − wx, w² + z²)/(w² + z²)` (both `(0, 0, 1)` when the axes are
//!   aligned). The torque `τ = −k (θ − θ0) − c θ̇` is applied as the generalized force of
//!   θ: `τ F_b g_b` on b and `−τ F_a g_a` on a (body components; `F` = joint → body
//!   rotation). This is the exact gradient of the potential `½ k (θ − θ0)²`, so energy is
//!   conserved even when the joint axes are not perfectly aligned.

use crate::contract::math::{qconj, qmul, quat, rotation, vec3};
use crate::contract::system::{Pose, Twist, Wrench};
use crate::kernels::joints::JointGeom;
use nalgebra::{Quaternion, Vector3};

/// `out += w`.
#[inline]
pub fn add_wrench(out: &mut Wrench, w: &Wrench) {
    out.f += w.f;
    out.t += w.t;
}

/// Gravity on a body of mass `m`: `(m g, 0)`.
#[inline]
pub fn gravity(m: f64, g: &Vector3<f64>) -> Wrench {
    Wrench {
        f: m * g,
        t: Vector3::zeros(),
    }
}

/// Potential energy of gravity: `−m g·r`.
#[inline]
pub fn gravity_energy(m: f64, g: &Vector3<f64>, pose: &Pose) -> f64 {
    -m * g.dot(&pose.r)
}

/// A force `f` in **world** components applied at the body point `rho` (body components
/// relative to the mass centre).
#[inline]
pub fn point_force_world(pose: &Pose, rho: &[f64; 3], f: &Vector3<f64>) -> Wrench {
    Wrench {
        f: *f,
        t: vec3(rho).cross(&pose.c.tr_mul(f)),
    }
}

/// A force `f` in **body** components applied at the body point `rho`.
#[inline]
pub fn point_force_body(pose: &Pose, rho: &[f64; 3], f: &Vector3<f64>) -> Wrench {
    Wrench {
        f: pose.c * f,
        t: vec3(rho).cross(f),
    }
}

/// A pure torque given in **world** components.
#[inline]
pub fn torque_world(pose: &Pose, t: &Vector3<f64>) -> Wrench {
    Wrench {
        f: Vector3::zeros(),
        t: pose.c.tr_mul(t),
    }
}

/// A pure torque given in **body** components.
#[inline]
pub fn torque_body(t: &Vector3<f64>) -> Wrench {
    Wrench {
        f: Vector3::zeros(),
        t: *t,
    }
}

/// A translational spring–damper, constructible in a `const`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringGeom {
    /// End on side a: body-a components relative to its mass centre (world for ground).
    pub pa: [f64; 3],
    /// End on side b.
    pub pb: [f64; 3],
    /// Stiffness `k`, N/m.
    pub stiffness: f64,
    /// Rest length `ℓ0`, m.
    pub rest_length: f64,
    /// Damping `c`, N·s/m.
    pub damping: f64,
}

/// Length, rate of length change and tension of a translational spring (see the module
/// doc), plus the world end points and the unit direction `e` (zero at zero length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringState {
    /// Length `ℓ`.
    pub length: f64,
    /// `ℓ̇`.
    pub rate: f64,
    /// Force vector acting on side a (world); `−force` acts on b.
    pub force: Vector3<f64>,
    /// Lever of the end on a from a's mass centre (world).
    pub sa: Vector3<f64>,
    /// Lever of the end on b from b's mass centre (world).
    pub sb: Vector3<f64>,
}

/// Evaluate a translational spring–damper.
#[inline]
pub fn spring_state(g: &SpringGeom, pa: &Pose, pb: &Pose, ta: &Twist, tb: &Twist) -> SpringState {
    let sa = pa.c * vec3(&g.pa);
    let sb = pb.c * vec3(&g.pb);
    let d = (pb.r + sb) - (pa.r + sa);
    let l = d.norm();
    let va = ta.v + (pa.c * ta.w).cross(&sa);
    let vb = tb.v + (pb.c * tb.w).cross(&sb);
    let dd = vb - va;
    if l <= 1e-12 * (1.0 + g.rest_length) {
        let force = if g.rest_length == 0.0 {
            g.stiffness * d
        } else {
            Vector3::zeros()
        };
        return SpringState {
            length: l,
            rate: 0.0,
            force,
            sa,
            sb,
        };
    }
    let e = d / l;
    let rate = e.dot(&dd);
    let f = g.stiffness * (l - g.rest_length) + g.damping * rate;
    SpringState {
        length: l,
        rate,
        force: f * e,
        sa,
        sb,
    }
}

/// Wrenches of a translational spring–damper on sides a and b.
#[inline]
pub fn spring(g: &SpringGeom, pa: &Pose, pb: &Pose, ta: &Twist, tb: &Twist) -> (Wrench, Wrench) {
    let s = spring_state(g, pa, pb, ta, tb);
    (
        Wrench {
            f: s.force,
            t: pa.c.tr_mul(&s.sa.cross(&s.force)),
        },
        Wrench {
            f: -s.force,
            t: pb.c.tr_mul(&s.sb.cross(&(-s.force))),
        },
    )
}

/// Potential energy `½ k (ℓ − ℓ0)²` of a translational spring.
#[inline]
pub fn spring_energy(g: &SpringGeom, pa: &Pose, pb: &Pose) -> f64 {
    let d = pb.point(&vec3(&g.pb)) - pa.point(&vec3(&g.pa));
    let x = d.norm() - g.rest_length;
    0.5 * g.stiffness * x * x
}

/// A rotational spring–damper about a joint's z axis, constructible in a `const`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RotSpringGeom {
    /// The joint's geometry (frames `qa`, `qb` and axes are used).
    pub joint: JointGeom,
    /// Stiffness `k`, N·m/rad.
    pub stiffness: f64,
    /// Rest angle `θ0`, rad.
    pub rest_angle: f64,
    /// Damping `c`, N·m·s/rad.
    pub damping: f64,
    /// Sign `s` of `w` of the relative rotation at the initial state ([`joint_angle_sign`]).
    pub sign: f64,
}

/// The relative rotation `q_rel = (q_a ⊗ f_a)* ⊗ (q_b ⊗ f_b)` of the joint frames (joint
/// frame b → joint frame a).
#[inline]
pub fn relative_rotation(g: &JointGeom, pa: &Pose, pb: &Pose) -> Quaternion<f64> {
    let ja = qmul(&pa.q, &quat(g.qa));
    let jb = qmul(&pb.q, &quat(g.qb));
    qmul(&qconj(&ja), &jb)
}

/// The sign `s = ±1` of `w` of the relative rotation at the given (initial) poses; `+1`
/// when `w = 0`.
#[inline]
pub fn joint_angle_sign(g: &JointGeom, pa: &Pose, pb: &Pose) -> f64 {
    if relative_rotation(g, pa, pb).w < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// The continuous joint angle `θ = 2 atan2(s z, s w) ∈ (−2π, 2π]` about the z axis.
#[inline]
pub fn joint_angle(g: &JointGeom, sign: f64, pa: &Pose, pb: &Pose) -> f64 {
    let q = relative_rotation(g, pa, pb);
    2.0 * (sign * q.k).atan2(sign * q.w)
}

/// Angle, rate and the two rate gradients of a joint angle: `θ`, `θ̇`, `∂θ̇/∂ω_a`,
/// `∂θ̇/∂ω_b` (body components). The gradients are zero when `w² + z² = 0` (the axes are
/// anti-parallel; θ is undefined there).
#[inline]
pub fn joint_angle_rate(
    g: &JointGeom,
    sign: f64,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
) -> (f64, f64, Vector3<f64>, Vector3<f64>) {
    let q = relative_rotation(g, pa, pb);
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    let theta = 2.0 * (sign * z).atan2(sign * w);
    let n = w * w + z * z;
    if n <= 1e-300 {
        return (theta, 0.0, Vector3::zeros(), Vector3::zeros());
    }
    let gb = Vector3::new(z * x - w * y, w * x + z * y, n) / n;
    let ga = Vector3::new(w * y + z * x, z * y - w * x, n) / n;
    // ∂θ̇/∂ω = F g (F: joint → body rotation)
    let fa = rotation(&quat(g.qa));
    let fb = rotation(&quat(g.qb));
    let da = -(fa * ga);
    let db = fb * gb;
    (theta, da.dot(&ta.w) + db.dot(&tb.w), da, db)
}

/// Wrenches of a rotational spring–damper on sides a and b (pure torques).
#[inline]
pub fn rotational_spring(
    g: &RotSpringGeom,
    pa: &Pose,
    pb: &Pose,
    ta: &Twist,
    tb: &Twist,
) -> (Wrench, Wrench) {
    let (theta, rate, da, db) = joint_angle_rate(&g.joint, g.sign, pa, pb, ta, tb);
    let tau = -g.stiffness * (theta - g.rest_angle) - g.damping * rate;
    (
        Wrench {
            f: Vector3::zeros(),
            t: tau * da,
        },
        Wrench {
            f: Vector3::zeros(),
            t: tau * db,
        },
    )
}

/// Potential energy `½ k (θ − θ0)²` of a rotational spring.
#[inline]
pub fn rotational_spring_energy(g: &RotSpringGeom, pa: &Pose, pb: &Pose) -> f64 {
    let x = joint_angle(&g.joint, g.sign, pa, pb) - g.rest_angle;
    0.5 * g.stiffness * x * x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::math::{axis_angle, quat_array, quat_rate};
    use crate::contract::scene::{Attachment, BodyRef};

    /// Power of a wrench on a twist: `F·v + t·ω` (both ω and t in body components).
    fn power(w: &Wrench, t: &Twist) -> f64 {
        w.f.dot(&t.v) + w.t.dot(&t.w)
    }

    /// Pose after time `h` of constant twist (midpoint rule for q: error O(h³), enough for
    /// the central differences below).
    fn advance(p: &Pose, t: &Twist, h: f64) -> Pose {
        let qm = p.q + quat_rate(&p.q, &t.w) * (0.5 * h);
        Pose::new(p.r + t.v * h, p.q + quat_rate(&qm, &t.w) * h)
    }

    fn states() -> Vec<(Pose, Pose, Twist, Twist)> {
        (0..12)
            .map(|i| {
                let f = i as f64;
                (
                    Pose::new(
                        Vector3::new(0.1 * f, -0.3, 0.2),
                        axis_angle(&Vector3::new(1.0, f, 2.0), 0.3 + f),
                    ),
                    Pose::new(
                        Vector3::new(-0.4, 0.5, 0.1 * f),
                        axis_angle(&Vector3::new(f, 1.0, -1.0), 1.1 - f),
                    ),
                    Twist {
                        v: Vector3::new(0.3, -0.2, 0.5 * f),
                        w: Vector3::new(1.0, -0.5 * f, 0.7),
                    },
                    Twist {
                        v: Vector3::new(-0.1 * f, 0.4, 0.2),
                        w: Vector3::new(0.2 * f, 0.9, -1.3),
                    },
                )
            })
            .collect()
    }

    #[test]
    fn point_force_and_torque_wrenches() {
        let pose = Pose::new(
            Vector3::new(1.0, 2.0, 3.0),
            axis_angle(&Vector3::z(), std::f64::consts::FRAC_PI_2),
        );
        // force +x world at body point (1,0,0) → world lever (0,1,0): torque (0,1,0)×(1,0,0) = (0,0,−1) world
        let w = point_force_world(&pose, &[1.0, 0.0, 0.0], &Vector3::x());
        assert!((w.f - Vector3::x()).norm() < 1e-15);
        assert!((pose.c * w.t - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-15);
        let wb = point_force_body(&pose, &[1.0, 0.0, 0.0], &pose.c.tr_mul(&Vector3::x()));
        assert!((wb.f - w.f).norm() < 1e-15 && (wb.t - w.t).norm() < 1e-15);
        let t = torque_world(&pose, &Vector3::new(0.0, 0.0, 2.0));
        assert!((t.t - Vector3::new(0.0, 0.0, 2.0)).norm() < 1e-15);
        assert_eq!(torque_body(&Vector3::x()).t, Vector3::x());
        assert_eq!(
            gravity(2.0, &Vector3::new(0.0, 0.0, -9.81)).f,
            Vector3::new(0.0, 0.0, -19.62)
        );
    }

    #[test]
    fn spring_force_is_minus_gradient_of_energy_and_damper_dissipates() {
        for (pa, pb, ta, tb) in states() {
            let g = SpringGeom {
                pa: [0.1, 0.2, -0.3],
                pb: [0.0, -0.4, 0.2],
                stiffness: 30.0,
                rest_length: 0.5,
                damping: 0.0,
            };
            // dV/dt along the motion = −(power of the spring forces)
            let h = 1e-5;
            let vp = spring_energy(&g, &advance(&pa, &ta, h), &advance(&pb, &tb, h));
            let vm = spring_energy(&g, &advance(&pa, &ta, -h), &advance(&pb, &tb, -h));
            let dv = (vp - vm) / (2.0 * h);
            let (wa, wb) = spring(&g, &pa, &pb, &ta, &tb);
            let p = power(&wa, &ta) + power(&wb, &tb);
            assert!(
                (dv + p).abs() < 1e-6 * (1.0 + dv.abs()),
                "dV/dt {dv} vs −P {}",
                -p
            );
            // equal and opposite forces, zero net moment about the origin
            assert!((wa.f + wb.f).norm() < 1e-13);
            let ma = pa.r.cross(&wa.f) + pa.c * wa.t;
            let mb = pb.r.cross(&wb.f) + pb.c * wb.t;
            assert!((ma + mb).norm() < 1e-12);
            // damper alone dissipates
            let gd = SpringGeom {
                stiffness: 0.0,
                damping: 4.0,
                ..g
            };
            let (da, db) = spring(&gd, &pa, &pb, &ta, &tb);
            assert!(power(&da, &ta) + power(&db, &tb) <= 1e-14);
        }
    }

    #[test]
    fn spring_zero_length_is_finite() {
        let p = Pose::default();
        let t = Twist {
            v: Vector3::x(),
            w: Vector3::zeros(),
        };
        let g = SpringGeom {
            pa: [0.0; 3],
            pb: [0.0; 3],
            stiffness: 10.0,
            rest_length: 0.0,
            damping: 1.0,
        };
        let (a, b) = spring(&g, &p, &p, &t, &Twist::default());
        assert!(a.f.iter().chain(b.f.iter()).all(|x| x.is_finite()));
        let g = SpringGeom {
            rest_length: 1.0,
            ..g
        };
        let (a, _) = spring(&g, &p, &p, &t, &Twist::default());
        assert_eq!(a.f, Vector3::zeros());
        assert_eq!(spring_energy(&g, &p, &p), 5.0);
    }

    fn joint(fa: Quaternion<f64>, fb: Quaternion<f64>) -> JointGeom {
        JointGeom::new(
            &Attachment {
                body: BodyRef::Body(0),
                point: [0.0; 3],
                frame: quat_array(&fa),
            },
            &Attachment {
                body: BodyRef::Body(1),
                point: [0.0; 3],
                frame: quat_array(&fb),
            },
            0.0,
        )
    }

    #[test]
    fn joint_angle_is_continuous_through_pi_and_zero_at_coincidence() {
        let fa = axis_angle(&Vector3::new(1.0, 2.0, 0.5), 0.9);
        let fb = axis_angle(&Vector3::new(-1.0, 0.2, 0.5), 2.1);
        let g = joint(fa, fb);
        let qa = axis_angle(&Vector3::new(0.3, 1.0, -1.0), 1.3);
        let pa = Pose::new(Vector3::zeros(), qa);
        // body b placed so that the joint frames coincide, then rotated about the joint z
        let z_world = crate::contract::math::rotate(&qmul(&qa, &fa), &Vector3::z());
        let q0 = qmul(&qmul(&qa, &fa), &qconj(&fb));
        let pb0 = Pose::new(Vector3::zeros(), q0);
        let s = joint_angle_sign(&g, &pa, &pb0);
        assert!(joint_angle(&g, s, &pa, &pb0).abs() < 1e-14);
        // also with the sign-flipped (same rotation) body quaternion
        let pb0n = Pose { q: -pb0.q, ..pb0 };
        let sn = joint_angle_sign(&g, &pa, &pb0n);
        assert_eq!(sn, -s);
        assert!(joint_angle(&g, sn, &pa, &pb0n).abs() < 1e-14);
        for i in -70..=70 {
            let th = i as f64 * 0.09; // −6.3 .. 6.3
            let pb = Pose::new(Vector3::zeros(), qmul(&axis_angle(&z_world, th), &q0));
            let got = joint_angle(&g, s, &pa, &pb);
            if th.abs() < 2.0 * std::f64::consts::PI {
                assert!((got - th).abs() < 1e-12, "θ {th}: got {got}");
            }
        }
    }

    #[test]
    fn rotational_spring_rate_and_conservation() {
        let g = joint(
            axis_angle(&Vector3::new(1.0, 0.0, 0.3), 0.4),
            axis_angle(&Vector3::new(0.0, 1.0, 0.3), -0.7),
        );
        for (pa, pb, ta, tb) in states() {
            let rs = RotSpringGeom {
                joint: g,
                stiffness: 7.0,
                rest_angle: 0.3,
                damping: 0.0,
                sign: joint_angle_sign(&g, &pa, &pb),
            };
            let h = 1e-5;
            let (pap, pbp) = (advance(&pa, &ta, h), advance(&pb, &tb, h));
            let (pam, pbm) = (advance(&pa, &ta, -h), advance(&pb, &tb, -h));
            let (_, rate, _, _) = joint_angle_rate(&g, rs.sign, &pa, &pb, &ta, &tb);
            let fd = (joint_angle(&g, rs.sign, &pap, &pbp) - joint_angle(&g, rs.sign, &pam, &pbm))
                / (2.0 * h);
            assert!(
                (fd - rate).abs() < 1e-6 * (1.0 + rate.abs()),
                "θ̇ {rate} vs fd {fd}"
            );
            let dv = (rotational_spring_energy(&rs, &pap, &pbp)
                - rotational_spring_energy(&rs, &pam, &pbm))
                / (2.0 * h);
            let (wa, wb) = rotational_spring(&rs, &pa, &pb, &ta, &tb);
            let p = power(&wa, &ta) + power(&wb, &tb);
            assert!(
                (dv + p).abs() < 1e-6 * (1.0 + dv.abs()),
                "dV/dt {dv} vs −P {}",
                -p
            );
            // pure torques, equal and opposite in world when the axes are aligned is not
            // required here; the damper alone dissipates:
            let rd = RotSpringGeom {
                stiffness: 0.0,
                damping: 2.0,
                ..rs
            };
            let (da, db) = rotational_spring(&rd, &pa, &pb, &ta, &tb);
            assert!(power(&da, &ta) + power(&db, &tb) <= 1e-14);
        }
    }

    #[test]
    fn rotational_spring_aligned_axes_gives_opposite_axial_torques() {
        let g = joint(Quaternion::identity(), Quaternion::identity());
        let pa = Pose::default();
        let pb = Pose::new(Vector3::zeros(), axis_angle(&Vector3::z(), 0.5));
        let rs = RotSpringGeom {
            joint: g,
            stiffness: 2.0,
            rest_angle: 0.0,
            damping: 0.0,
            sign: 1.0,
        };
        let (wa, wb) = rotational_spring(&rs, &pa, &pb, &Twist::default(), &Twist::default());
        // torque on b: −k θ about z (world = body here up to rotation about z)
        assert!((pb.c * wb.t - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-14);
        assert!((pa.c * wa.t - Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-14);
    }
}
