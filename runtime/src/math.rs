//! Rotation math: quaternions (Hamilton, scalar first, body → world), rotation matrices,
//! skew matrices, and the Euler-parameter midpoint (Cayley) update of notes A §1.9.

use nalgebra::{Matrix3, Quaternion, Vector3};

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

/// The skew (cross-product) matrix `ã` with `ã b = a × b`.
#[inline]
pub fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}
