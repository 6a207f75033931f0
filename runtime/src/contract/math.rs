//! Rotation math: quaternions (Hamilton, scalar first, body → world), rotation matrices,
//! skew matrices, and the Euler-parameter midpoint (Cayley) update of notes A §1.9.
//!
//! Conventions (as in [`crate::contract::scene`]):
//! - A quaternion `q = [w, x, y, z]` maps body components to world components:
//!   `v_world = q ⊗ (0, v_body) ⊗ q*` = [`rotation`]`(q) · v_body`.
//! - Angular velocity `ω` is in **body** components; the kinematics are
//!   `q̇ = ½ q ⊗ (0, ω) = ½ Ω(ω) q` (notes A eq. 44, C §0), with
//!   `Ω(ω) = [[0, −ωᵀ], [ω, −ω̃]]` ([`omega_matrix`]); the papers' `A(ω) = ½ Ω(ω)`.
//! - `Ċ = C ω̃` for `C = rotation(q)`.
//!
//! nalgebra's `Quaternion::new(w, i, j, k)` stores the scalar part as `w` and the vector
//! part as `(i, j, k)`; its `*` operator is the Hamilton product. The array helpers
//! ([`quat`], [`quat_array`]) convert from and to the scene's `[w, x, y, z]` layout.

use nalgebra::{Matrix3, Matrix4, Quaternion, Vector3, Vector4};

/// Rotation matrix (body → world) of a unit quaternion. This is `Rᵀ` in the papers'
/// notation (their `R` maps world to body components; notes C §0).
#[inline]
pub fn rotation(q: &Quaternion<f64>) -> Matrix3<f64> {
    let (w, x, y, z) = (q.w, q.i, q.j, q.k);
    Matrix3::new(
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        1.0 - 2.0 * (x * x + y * y),
    )
}

/// Rotation matrix (body → world) of a quaternion given as a `[w, x, y, z]` array
/// (assumed unit; not normalised here).
#[inline]
pub fn rotation_array(q: &[f64; 4]) -> Matrix3<f64> {
    rotation(&quat(*q))
}

/// The skew (cross-product) matrix `ã` with `ã b = a × b`.
#[inline]
pub fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// A quaternion from the scene's `[w, x, y, z]` array.
#[inline]
pub fn quat(a: [f64; 4]) -> Quaternion<f64> {
    Quaternion::new(a[0], a[1], a[2], a[3])
}

/// The scene's `[w, x, y, z]` array of a quaternion.
#[inline]
pub fn quat_array(q: &Quaternion<f64>) -> [f64; 4] {
    [q.w, q.i, q.j, q.k]
}

/// A vector from a `[f64; 3]` array.
#[inline]
pub fn vec3(a: &[f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

/// The Hamilton product `a ⊗ b`:
/// `(a_w b_w − a_v·b_v, a_w b_v + b_w a_v + a_v × b_v)`.
#[inline]
pub fn qmul(a: &Quaternion<f64>, b: &Quaternion<f64>) -> Quaternion<f64> {
    Quaternion::new(
        a.w * b.w - a.i * b.i - a.j * b.j - a.k * b.k,
        a.w * b.i + a.i * b.w + a.j * b.k - a.k * b.j,
        a.w * b.j - a.i * b.k + a.j * b.w + a.k * b.i,
        a.w * b.k + a.i * b.j - a.j * b.i + a.k * b.w,
    )
}

/// The conjugate `q* = (w, −x, −y, −z)` (the inverse of a unit quaternion).
#[inline]
pub fn qconj(q: &Quaternion<f64>) -> Quaternion<f64> {
    Quaternion::new(q.w, -q.i, -q.j, -q.k)
}

/// Rotate a vector by a unit quaternion: the vector part of `q ⊗ (0, v) ⊗ q*`, computed
/// as `v + 2w (u × v) + 2 u × (u × v)` with `u` the vector part of `q`.
#[inline]
pub fn rotate(q: &Quaternion<f64>, v: &Vector3<f64>) -> Vector3<f64> {
    let u = Vector3::new(q.i, q.j, q.k);
    let t = 2.0 * u.cross(v);
    v + q.w * t + u.cross(&t)
}

/// Rotate a vector by the inverse of a unit quaternion (world → body): `q* ⊗ (0, v) ⊗ q`.
#[inline]
pub fn rotate_inv(q: &Quaternion<f64>, v: &Vector3<f64>) -> Vector3<f64> {
    rotate(&qconj(q), v)
}

/// The unit quaternion of a rotation by `angle` (rad, right-handed) about `axis` (any
/// length; normalised here). A zero axis gives the identity.
pub fn axis_angle(axis: &Vector3<f64>, angle: f64) -> Quaternion<f64> {
    let n = axis.norm();
    if n == 0.0 || !n.is_finite() {
        return Quaternion::identity();
    }
    let (s, c) = (0.5 * angle).sin_cos();
    let u = axis * (s / n);
    Quaternion::new(c, u.x, u.y, u.z)
}

/// Axis (unit) and angle in `[0, π]` of a unit quaternion. The identity gives the axis
/// `(1, 0, 0)` and angle 0. `q` and `−q` give the same result.
pub fn to_axis_angle(q: &Quaternion<f64>) -> (Vector3<f64>, f64) {
    let u = Vector3::new(q.i, q.j, q.k);
    let s = u.norm();
    if s == 0.0 {
        return (Vector3::x(), 0.0);
    }
    let w = q.w;
    let (axis, w) = if w < 0.0 { (-u / s, -w) } else { (u / s, w) };
    (axis, 2.0 * s.atan2(w))
}

/// The unit quaternion of a rotation matrix (Shepperd's method, numerically stable for
/// every rotation). The result has `w ≥ 0`.
pub fn quat_from_rotation(c: &Matrix3<f64>) -> Quaternion<f64> {
    let tr = c[(0, 0)] + c[(1, 1)] + c[(2, 2)];
    let q = if tr >= c[(0, 0)] && tr >= c[(1, 1)] && tr >= c[(2, 2)] {
        let w = 0.5 * (1.0 + tr).max(0.0).sqrt();
        let f = 0.25 / w;
        Quaternion::new(
            w,
            (c[(2, 1)] - c[(1, 2)]) * f,
            (c[(0, 2)] - c[(2, 0)]) * f,
            (c[(1, 0)] - c[(0, 1)]) * f,
        )
    } else if c[(0, 0)] >= c[(1, 1)] && c[(0, 0)] >= c[(2, 2)] {
        let x = 0.5 * (1.0 + 2.0 * c[(0, 0)] - tr).max(0.0).sqrt();
        let f = 0.25 / x;
        Quaternion::new(
            (c[(2, 1)] - c[(1, 2)]) * f,
            x,
            (c[(0, 1)] + c[(1, 0)]) * f,
            (c[(0, 2)] + c[(2, 0)]) * f,
        )
    } else if c[(1, 1)] >= c[(2, 2)] {
        let y = 0.5 * (1.0 + 2.0 * c[(1, 1)] - tr).max(0.0).sqrt();
        let f = 0.25 / y;
        Quaternion::new(
            (c[(0, 2)] - c[(2, 0)]) * f,
            (c[(0, 1)] + c[(1, 0)]) * f,
            y,
            (c[(1, 2)] + c[(2, 1)]) * f,
        )
    } else {
        let z = 0.5 * (1.0 + 2.0 * c[(2, 2)] - tr).max(0.0).sqrt();
        let f = 0.25 / z;
        Quaternion::new(
            (c[(1, 0)] - c[(0, 1)]) * f,
            (c[(0, 2)] + c[(2, 0)]) * f,
            (c[(1, 2)] + c[(2, 1)]) * f,
            z,
        )
    };
    let q = q / q.norm();
    if q.w < 0.0 {
        -q
    } else {
        q
    }
}

/// The 4×4 matrix `Ω(ω)` of notes C §0 (un-halved; the companion paper's `A(ω) = ½Ω`),
/// acting on `(w, x, y, z)`: `Ω(ω) q = q ⊗ (0, ω)`.
///
/// ```text
/// Ω(ω) = [ 0   −ω1  −ω2  −ω3 ]
///        [ ω1   0    ω3  −ω2 ]
///        [ ω2  −ω3   0    ω1 ]
///        [ ω3   ω2  −ω1   0  ]
/// ```
pub fn omega_matrix(w: &Vector3<f64>) -> Matrix4<f64> {
    Matrix4::new(
        0.0, -w.x, -w.y, -w.z, //
        w.x, 0.0, w.z, -w.y, //
        w.y, -w.z, 0.0, w.x, //
        w.z, w.y, -w.x, 0.0,
    )
}

/// `q` as the 4-vector `(w, x, y, z)` (for use with [`omega_matrix`]).
#[inline]
pub fn quat_to_vec4(q: &Quaternion<f64>) -> Vector4<f64> {
    Vector4::new(q.w, q.i, q.j, q.k)
}

/// The quaternion rate `q̇ = ½ q ⊗ (0, ω)` for body-frame `ω`.
#[inline]
pub fn quat_rate(q: &Quaternion<f64>, w: &Vector3<f64>) -> Quaternion<f64> {
    qmul(q, &Quaternion::new(0.0, w.x, w.y, w.z)) * 0.5
}

/// The Euler-parameter midpoint update (notes A §1.9 eq. 54, C §3.4 eqs. 19–20):
///
/// ```text
/// q̃     = (I + (h/2) A(ω)) q / Δ,   A(ω) = ½ Ω(ω)   (so q̃ = q ⊗ (1, hω/4) / Δ)
/// q_new = 2 q̃ − q,  then normalised
/// ```
///
/// - `paper_literal = false` (default, **corrected**): `Δ = 1 + h²|ω|²/16`, the exact
///   solution of the implicit midpoint relation `q̃ = q + (h/2) A(ω) q̃` because
///   `A² = −|ω|²/4 I`. The map is then a Cayley transform: `q_new = q ⊗ (1 − a², 2a ω̂)/(1 + a²)`
///   with `a = h|ω|/4`; it preserves `|q|` exactly and rotates by `4·atan(h|ω|/4)` per step
///   about the body axis `ω`.
/// - `paper_literal = true`: `Δ = 1 + h²|ω|²/4` as printed in the papers (inconsistent
///   with the `h/2` numerator; `|q|` shrinks and the normalisation does the real work).
///   For reproducing the papers' figures only.
///
/// `ω` is the body-frame angular velocity at the midpoint of the step, `h` the step.
#[inline]
pub fn cayley_update(
    q: &Quaternion<f64>,
    w: &Vector3<f64>,
    h: f64,
    paper_literal: bool,
) -> Quaternion<f64> {
    let w2 = w.norm_squared();
    let delta = if paper_literal {
        1.0 + h * h * w2 / 4.0
    } else {
        1.0 + h * h * w2 / 16.0
    };
    let a = w * (0.25 * h);
    // q̃ = q ⊗ (1, hω/4) / Δ
    let qt = qmul(q, &Quaternion::new(1.0, a.x, a.y, a.z)) / delta;
    let qn = qt * 2.0 - q;
    let n = qn.norm();
    qn / n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rq(s: u64) -> Quaternion<f64> {
        // deterministic pseudo-random unit quaternion
        let mut x = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut next = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((x >> 11) as f64) / ((1u64 << 53) as f64) * 2.0 - 1.0
        };
        let q = Quaternion::new(next(), next(), next(), next());
        q / q.norm()
    }

    #[test]
    fn rotation_matches_sandwich_product() {
        for s in 0..50 {
            let q = rq(s);
            let v = Vector3::new(0.3 + s as f64 * 0.1, -1.2, 2.5);
            let qv = qmul(&qmul(&q, &Quaternion::new(0.0, v.x, v.y, v.z)), &qconj(&q));
            let c = rotation(&q) * v;
            let r = rotate(&q, &v);
            for i in 0..3 {
                assert!((qv.vector()[i] - c[i]).abs() < 1e-14);
                assert!((r[i] - c[i]).abs() < 1e-14);
            }
            assert!(qv.w.abs() < 1e-14);
            // inverse rotation
            let back = rotate_inv(&q, &c);
            assert!((back - v).norm() < 1e-14);
            // C is orthonormal with det 1
            let m = rotation(&q);
            assert!((m.transpose() * m - Matrix3::identity()).norm() < 1e-14);
            assert!((m.determinant() - 1.0).abs() < 1e-14);
        }
    }

    #[test]
    fn qmul_matches_nalgebra_and_composes_rotations() {
        for s in 0..20 {
            let (a, b) = (rq(s), rq(s + 100));
            let p = qmul(&a, &b);
            let n = a * b;
            assert!((p - n).norm() < 1e-15);
            assert!((rotation(&p) - rotation(&a) * rotation(&b)).norm() < 1e-14);
        }
    }

    #[test]
    fn axis_angle_roundtrip_and_rotation_direction() {
        // 90° about z maps x to y (right-handed).
        let q = axis_angle(&Vector3::z(), std::f64::consts::FRAC_PI_2);
        let v = rotate(&q, &Vector3::x());
        assert!((v - Vector3::y()).norm() < 1e-15);
        for s in 0..20 {
            let axis = Vector3::new(1.0, -2.0 + s as f64 * 0.3, 0.5).normalize();
            let ang = 0.1 + 0.15 * s as f64;
            let q = axis_angle(&axis, ang);
            let (a2, ang2) = to_axis_angle(&q);
            assert!((a2 - axis).norm() < 1e-13, "{s}");
            assert!((ang2 - ang).abs() < 1e-13);
            let qm = quat_from_rotation(&rotation(&q));
            assert!((qm - q).norm() < 1e-14 || (qm + q).norm() < 1e-14);
        }
        assert_eq!(axis_angle(&Vector3::zeros(), 1.0), Quaternion::identity());
    }

    #[test]
    fn quat_from_rotation_all_branches() {
        for s in 0..200 {
            let q = rq(s);
            let q2 = quat_from_rotation(&rotation(&q));
            assert!((q2 - q).norm() < 1e-13 || (q2 + q).norm() < 1e-13, "{s}");
        }
        // 180° rotations exercise the non-trace branches
        for axis in [Vector3::x(), Vector3::y(), Vector3::z()] {
            let q = axis_angle(&axis, std::f64::consts::PI);
            let q2 = quat_from_rotation(&rotation(&q));
            assert!((q2 - q).norm() < 1e-13 || (q2 + q).norm() < 1e-13);
        }
    }

    #[test]
    fn omega_matrix_is_right_multiplication_and_rate_gives_cdot() {
        for s in 0..20 {
            let q = rq(s);
            let w = Vector3::new(0.4, -1.1, 2.0 + s as f64 * 0.1);
            let a = omega_matrix(&w) * quat_to_vec4(&q);
            let b = qmul(&q, &Quaternion::new(0.0, w.x, w.y, w.z));
            assert!((a - quat_to_vec4(&b)).norm() < 1e-14);
            // Ω² = −|ω|² I
            let o = omega_matrix(&w);
            assert!((o * o + Matrix4::identity() * w.norm_squared()).norm() < 1e-13);
            // Ċ = C ω̃: finite difference of rotation along q̇
            let dt = 1e-6;
            let qd = quat_rate(&q, &w);
            let cp = rotation(&(q + qd * dt));
            let cm = rotation(&(q - qd * dt));
            let cdot = (cp - cm) / (2.0 * dt);
            assert!((cdot - rotation(&q) * skew(&w)).norm() < 1e-8);
        }
    }

    #[test]
    fn cayley_preserves_norm_exactly_and_rotates_by_4_atan() {
        for s in 0..50 {
            let mut q = rq(s);
            let w = Vector3::new(3.0, -7.0 + s as f64, 1.5);
            // h|ω| up to ~3.8 (rotation per step below π so the angle is unambiguous)
            let h = (0.02 + 0.075 * s as f64) / w.norm();
            let q0 = q;
            // Without the final normalisation the corrected map preserves |q|.
            let w2 = w.norm_squared();
            let a = w * (0.25 * h);
            let qt = qmul(&q, &Quaternion::new(1.0, a.x, a.y, a.z)) / (1.0 + h * h * w2 / 16.0);
            let raw = qt * 2.0 - q;
            assert!((raw.norm() - 1.0).abs() < 1e-15, "{}", raw.norm() - 1.0);
            q = cayley_update(&q, &w, h, false);
            assert!((q.norm() - 1.0).abs() < 1e-15);
            // relative rotation q0* ⊗ q is about the body axis ω by 4 atan(h|ω|/4)
            let rel = qmul(&qconj(&q0), &q);
            let (axis, ang) = to_axis_angle(&rel);
            let expect = 4.0 * (h * w.norm() / 4.0).atan();
            assert!((ang - expect).abs() < 1e-13, "{ang} {expect}");
            assert!((axis - w.normalize()).norm() < 1e-12);
        }
    }

    #[test]
    fn cayley_paper_literal_shrinks_before_normalisation_and_is_second_order() {
        let q = rq(7);
        let w = Vector3::new(1.0, 2.0, -0.5);
        let h = 0.1;
        let w2 = w.norm_squared();
        let a = w * (0.25 * h);
        let qt = qmul(&q, &Quaternion::new(1.0, a.x, a.y, a.z)) / (1.0 + h * h * w2 / 4.0);
        let raw = qt * 2.0 - q;
        assert!(raw.norm() < 0.999);
        let qp = cayley_update(&q, &w, h, true);
        assert!((qp.norm() - 1.0).abs() < 1e-15);
        // Both variants approximate exp(hΩ/2) q to second order (local error O(h³)).
        let exact = |h: f64| qmul(&q, &axis_angle(&w, w.norm() * h));
        for lit in [false, true] {
            let e1 = (cayley_update(&q, &w, 0.02, lit) - exact(0.02)).norm();
            let e2 = (cayley_update(&q, &w, 0.01, lit) - exact(0.01)).norm();
            let order = (e1 / e2).log2();
            assert!(
                order > 2.8 && order < 3.2,
                "local order {order} (literal={lit})"
            );
        }
    }
}
