//! Geometry used by lowering: rotations, joint frames, inertia formulas.

use mbdc_runtime::scene::{Mat3, Quat, Vec3};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// `Vec3` → nalgebra.
pub fn v(a: Vec3) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

/// nalgebra → `Vec3`.
pub fn a(v: &Vector3<f64>) -> Vec3 {
    [v.x, v.y, v.z]
}

/// `Mat3` (row-major) → nalgebra.
pub fn m(a: &Mat3) -> Matrix3<f64> {
    Matrix3::new(
        a[0][0], a[0][1], a[0][2], a[1][0], a[1][1], a[1][2], a[2][0], a[2][1], a[2][2],
    )
}

/// nalgebra → `Mat3` (row-major).
pub fn mat(m: &Matrix3<f64>) -> Mat3 {
    [
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
    ]
}

/// The identity quaternion.
pub const IDENTITY: Quat = [1.0, 0.0, 0.0, 0.0];

/// Rotation matrix (body → world) of a `[w, x, y, z]` quaternion (normalised first).
pub fn rot(q: Quat) -> Matrix3<f64> {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let q = if n > 0.0 {
        Quaternion::new(q[0] / n, q[1] / n, q[2] / n, q[3] / n)
    } else {
        Quaternion::identity()
    };
    mbdc_runtime::math::rotation(&q)
}

/// Quaternion `[w, x, y, z]` of a rotation matrix (assumed orthonormal, det +1), with
/// w ≥ 0 for determinism.
pub fn quat_of(r: &Matrix3<f64>) -> Quat {
    let uq = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r));
    let q = uq.quaternion();
    let mut out = [q.w, q.i, q.j, q.k];
    if out[0] < 0.0 {
        out.iter_mut().for_each(|c| *c = -*c);
    }
    out
}

/// Rotation by `angle` about `axis` (normalised; must be non-zero).
pub fn axis_angle(axis: Vector3<f64>, angle: f64) -> Quat {
    let n = axis.norm();
    let u = axis / n;
    let (s, c) = (0.5 * angle).sin_cos();
    let mut q = [c, s * u.x, s * u.y, s * u.z];
    if q[0] < 0.0 {
        q.iter_mut().for_each(|x| *x = -*x);
    }
    q
}

/// Rotation matrix of rotations about the fixed x, then y, then z axes: `Rz(c) Ry(b) Rx(a)`.
pub fn euler_xyz(ax: f64, by: f64, cz: f64) -> Matrix3<f64> {
    let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), ax);
    let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), by);
    let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), cz);
    (rz * ry * rx).into_inner()
}

/// Whether `r` is a rotation (orthonormal within `tol`, determinant +1).
pub fn is_rotation(r: &Matrix3<f64>, tol: f64) -> bool {
    let e = r.transpose() * r - Matrix3::identity();
    e.iter().all(|x| x.abs() <= tol) && (r.determinant() - 1.0).abs() <= tol
}

/// A right-handed orthonormal frame (columns x, y, z) whose z is `z` (non-zero), with x
/// the world axis least parallel to z (ties to the first of x, y, z) orthogonalised.
pub fn frame_with_z(z: Vector3<f64>) -> Matrix3<f64> {
    let z = z.normalize();
    let mut k = 0;
    for i in 1..3 {
        if z[i].abs() < z[k].abs() - 1e-12 {
            k = i;
        }
    }
    let e = Vector3::ith(k, 1.0);
    let x = (e - z * z.dot(&e)).normalize();
    let y = z.cross(&x);
    Matrix3::from_columns(&[x, y, z])
}

/// A right-handed frame with z = `z` and x = `x` (both unit, perpendicular).
pub fn frame_zx(z: Vector3<f64>, x: Vector3<f64>) -> Matrix3<f64> {
    let z = z.normalize();
    let x = (x - z * z.dot(&x)).normalize();
    Matrix3::from_columns(&[x, z.cross(&x), z])
}

/// Inertia of a solid cylinder (rod) of mass `m`, length `l`, radius `r` about its centre,
/// with its axis along body axis `axis` (0 = x, 1 = y, 2 = z):
/// `I_axis = m r²/2`, `I_perp = m (3 r² + l²)/12`.
pub fn rod_inertia(m: f64, l: f64, r: f64, axis: usize) -> Mat3 {
    let ia = m * r * r / 2.0;
    let ip = m * (3.0 * r * r + l * l) / 12.0;
    let mut d = [ip; 3];
    d[axis.min(2)] = ia;
    diag(d)
}

/// Inertia of a solid box with edges `s` along x, y, z: `Ixx = m (b² + c²)/12`, ...
pub fn box_inertia(m: f64, s: Vec3) -> Mat3 {
    let (x2, y2, z2) = (s[0] * s[0], s[1] * s[1], s[2] * s[2]);
    diag([
        m * (y2 + z2) / 12.0,
        m * (x2 + z2) / 12.0,
        m * (x2 + y2) / 12.0,
    ])
}

/// Inertia of a solid sphere: `2/5 m r²` about each axis.
pub fn sphere_inertia(m: f64, r: f64) -> Mat3 {
    let i = 0.4 * m * r * r;
    diag([i, i, i])
}

/// A diagonal matrix.
pub fn diag(d: Vec3) -> Mat3 {
    [[d[0], 0.0, 0.0], [0.0, d[1], 0.0], [0.0, 0.0, d[2]]]
}

/// What is wrong with an inertia tensor.
#[derive(Clone, Debug, PartialEq)]
pub enum InertiaProblem {
    /// Not finite.
    NotFinite,
    /// `I[i][j] != I[j][i]`.
    NotSymmetric(usize, usize),
    /// A principal moment is not positive.
    NotPositiveDefinite([f64; 3]),
    /// A principal moment exceeds the sum of the other two.
    Triangle([f64; 3]),
}

#[allow(clippy::needless_range_loop)]
/// Checks symmetry (relative 1e-9), positive definiteness and the triangle inequality
/// (relative 1e-9) of an inertia tensor. Returns the principal moments.
pub fn check_inertia(i: &Mat3) -> Result<[f64; 3], InertiaProblem> {
    if i.iter().flatten().any(|x| !x.is_finite()) {
        return Err(InertiaProblem::NotFinite);
    }
    let scale = i.iter().flatten().fold(0.0f64, |s, x| s.max(x.abs()));
    for r in 0..3 {
        for c in r + 1..3 {
            if (i[r][c] - i[c][r]).abs() > 1e-9 * scale {
                return Err(InertiaProblem::NotSymmetric(r, c));
            }
        }
    }
    let mm = m(i);
    let sym = (mm + mm.transpose()) * 0.5;
    let eig = sym.symmetric_eigenvalues();
    let mut p = [eig[0], eig[1], eig[2]];
    p.sort_by(|a, b| a.total_cmp(b));
    if p[0] <= 1e-12 * scale.max(f64::MIN_POSITIVE) || p[0] <= 0.0 {
        return Err(InertiaProblem::NotPositiveDefinite(p));
    }
    if p[2] > (p[0] + p[1]) * (1.0 + 1e-9) {
        return Err(InertiaProblem::Triangle(p));
    }
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inertia_formulas() {
        let r = rod_inertia(2.0, 1.0, 0.1, 2);
        assert!((r[2][2] - 2.0 * 0.01 / 2.0).abs() < 1e-15);
        assert!((r[0][0] - 2.0 * (0.03 + 1.0) / 12.0).abs() < 1e-15);
        assert_eq!(r[0][0], r[1][1]);
        let r = rod_inertia(1.0, 1.0, 0.0, 0);
        assert_eq!(r[0][0], 0.0);
        let b = box_inertia(12.0, [1.0, 2.0, 3.0]);
        assert_eq!(b[0][0], 13.0);
        assert_eq!(b[1][1], 10.0);
        assert_eq!(b[2][2], 5.0);
        let s = sphere_inertia(5.0, 2.0);
        assert_eq!(s[1][1], 8.0);
        assert!(check_inertia(&diag([1.0, 2.0, 3.0])).is_ok());
        assert!(matches!(
            check_inertia(&diag([1.0, 1.0, 3.0])),
            Err(InertiaProblem::Triangle(_))
        ));
        assert!(matches!(
            check_inertia(&diag([1.0, 0.0, 1.0])),
            Err(InertiaProblem::NotPositiveDefinite(_))
        ));
        assert!(matches!(
            check_inertia(&[[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
            Err(InertiaProblem::NotSymmetric(0, 1))
        ));
        assert!(check_inertia(&rod_inertia(1.0, 1.0, 0.01, 2)).is_ok());
    }

    #[test]
    fn frames() {
        for z in [
            Vector3::new(0.0, 0.0, 1.0),
            Vector3::new(1.0, 2.0, -3.0),
            Vector3::new(0.0, -1.0, 0.0),
        ] {
            let f = frame_with_z(z);
            assert!(is_rotation(&f, 1e-12));
            assert!((f.column(2) - z.normalize()).norm() < 1e-12);
        }
        let f = frame_with_z(Vector3::z());
        assert!((f.column(0) - Vector3::x()).norm() < 1e-12);
        let q = quat_of(&euler_xyz(0.3, -0.2, 1.1));
        assert!((rot(q) - euler_xyz(0.3, -0.2, 1.1)).norm() < 1e-12);
        let q = axis_angle(Vector3::y(), std::f64::consts::FRAC_PI_2);
        let r = rot(q);
        assert!((r * Vector3::z() - Vector3::x()).norm() < 1e-12);
    }
}
