//! Kinetic energy and momenta of a set of rigid bodies.
//!
//! With `v` the mass-centre velocity (world), `ω` the angular velocity (body components),
//! `J` the body-frame inertia about the mass centre and `C` the rotation body → world:
//!
//! ```text
//! T = Σ ½ m |v|² + ½ ωᵀ J ω
//! p = Σ m v                                   (world)
//! L = Σ r × m v + C J ω                       (about the world origin, world components)
//! ```
//!
//! and, for the meshes' nodes ([`mesh_momenta`]), `Σ m v` and `Σ x × m v`.

use crate::contract::mesh_layout::MeshLayout;
use crate::contract::system::{Layout, Pose, Twist};
use crate::integrators::MeshState;
use nalgebra::Vector3;

/// Kinetic energy `Σ ½ m |v|² + ½ ωᵀ J ω`, J.
pub fn kinetic_energy(layout: &Layout, twist: &[Twist]) -> f64 {
    layout
        .mass
        .iter()
        .zip(twist)
        .map(|(m, t)| 0.5 * (m.m * t.v.norm_squared() + t.w.dot(&(m.j * t.w))))
        .sum()
}

/// Linear momentum `Σ m v`, world components, kg·m/s.
pub fn linear_momentum(layout: &Layout, twist: &[Twist]) -> Vector3<f64> {
    layout
        .mass
        .iter()
        .zip(twist)
        .fold(Vector3::zeros(), |acc, (m, t)| acc + m.m * t.v)
}

/// Angular momentum about the world origin `Σ r × m v + C J ω`, world components,
/// kg·m²/s.
pub fn angular_momentum(layout: &Layout, pose: &[Pose], twist: &[Twist]) -> Vector3<f64> {
    layout
        .mass
        .iter()
        .zip(pose.iter().zip(twist))
        .fold(Vector3::zeros(), |acc, (m, (p, t))| {
            acc + p.r.cross(&(m.m * t.v)) + p.c * (m.j * t.w)
        })
}

/// Linear momentum `Σ m v` (world) and angular momentum about the world origin
/// `Σ (x₀ + u) × m v` of the meshes' nodes with their lumped masses (a tied node has no mass
/// in the mesh: its momentum is its body's). Zero for an empty state.
pub fn mesh_momenta(meshes: &MeshLayout, st: &MeshState) -> (Vector3<f64>, Vector3<f64>) {
    let (mut p, mut l) = (Vector3::zeros(), Vector3::zeros());
    if st.u.len() != meshes.nodes() || st.v.len() != meshes.nodes() {
        return (p, l);
    }
    for (((x0, u), v), &m) in meshes.x0.iter().zip(&st.u).zip(&st.v).zip(&meshes.mass) {
        let mv = Vector3::from(*v) * m;
        let x = Vector3::new(x0[0] + u[0], x0[1] + u[1], x0[2] + u[2]);
        p += mv;
        l += x.cross(&mv);
    }
    (p, l)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::math::axis_angle;
    use crate::contract::system::MassProps;
    use nalgebra::Matrix3;

    fn layout() -> Layout {
        let j = Matrix3::new(2.0, 0.1, 0.0, 0.1, 3.0, 0.2, 0.0, 0.2, 4.0);
        Layout {
            body_names: vec!["a".into(), "b".into()],
            mass: vec![
                MassProps::new(2.0, j).unwrap(),
                MassProps::new(1.0, Matrix3::identity()).unwrap(),
            ],
            joints: vec![],
            rows: 0,
            row_joint: vec![],
            row_kind: vec![],
            beams: Default::default(),
            meshes: Default::default(),
        }
    }

    #[test]
    fn values() {
        let l = layout();
        let pose = [
            Pose::new(
                Vector3::new(1.0, 0.0, 0.0),
                axis_angle(&Vector3::z(), std::f64::consts::FRAC_PI_2),
            ),
            Pose::default(),
        ];
        let tw = [
            Twist {
                v: Vector3::new(0.0, 3.0, 0.0),
                w: Vector3::new(1.0, 0.0, 0.0),
            },
            Twist {
                v: Vector3::new(1.0, 0.0, 0.0),
                w: Vector3::new(0.0, 0.0, 2.0),
            },
        ];
        // T = ½·2·9 + ½·2 (ωᵀJω = J11) + ½·1·1 + ½·4
        assert!((kinetic_energy(&l, &tw) - (9.0 + 1.0 + 0.5 + 2.0)).abs() < 1e-15);
        assert_eq!(linear_momentum(&l, &tw), Vector3::new(1.0, 6.0, 0.0));
        // body a: r × m v = (1,0,0) × (0,6,0) = (0,0,6); C J ω = Rz(90°)(2, 0.1, 0) = (−0.1, 2, 0)
        // body b: (0, 0, 2)
        let lm = angular_momentum(&l, &pose, &tw);
        assert!((lm - Vector3::new(-0.1, 2.0, 8.0)).norm() < 1e-14, "{lm}");
    }

    #[test]
    fn angular_momentum_is_independent_of_the_spin_representation() {
        // a body spinning about its own axis: L = C J ω regardless of orientation, and
        // T is invariant under a change of orientation at fixed body-frame ω.
        let l = layout();
        let tw = [
            Twist {
                v: Vector3::zeros(),
                w: Vector3::new(0.3, -0.2, 0.5),
            },
            Twist::default(),
        ];
        let t0 = kinetic_energy(&l, &tw);
        for k in 0..5 {
            let q = axis_angle(&Vector3::new(1.0, k as f64, 2.0), 0.4 * k as f64);
            let pose = [Pose::new(Vector3::zeros(), q), Pose::default()];
            let lm = angular_momentum(&l, &pose, &tw);
            assert!((lm.norm() - (l.mass[0].j * tw[0].w).norm()).abs() < 1e-14);
            assert_eq!(kinetic_energy(&l, &tw), t0);
        }
    }
}
