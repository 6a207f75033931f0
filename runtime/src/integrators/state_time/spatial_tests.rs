//! Unit tests of the spatial state-time window on hand-built models (no `System`): the
//! equation count, the analytic Jacobian against finite differences, and polynomial
//! exactness (notes F §5, "suggested validation checks", in three dimensions).

use super::scope::Joint;
use super::spatial::{Body, Spatial};
use super::spatial_window::{BodyStart, Load, SpatialWindow};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// Two bars on spherical joints (ground–bar 1, bar 1–bar 2), tilted out of every
/// coordinate plane, with a full inertia tensor on bar 2.
fn two_bars() -> (Spatial, Vec<BodyStart>) {
    let j2 = Matrix3::new(0.09, 0.01, -0.02, 0.01, 0.08, 0.015, -0.02, 0.015, 0.02);
    let model = Spatial {
        bodies: vec![
            Body {
                name: "bar1".into(),
                m: 1.0,
                j: Matrix3::from_diagonal(&Vector3::new(0.08, 0.08, 0.001)),
            },
            Body {
                name: "bar2".into(),
                m: 0.7,
                j: j2,
            },
        ],
        joints: vec![
            Joint {
                name: "shoulder".into(),
                a: None,
                b: Some(0),
                pa: Vector3::zeros(),
                pb: Vector3::new(0.0, 0.0, 0.5),
                first_row: 0,
                rows: 3,
            },
            Joint {
                name: "elbow".into(),
                a: Some(0),
                b: Some(1),
                pa: Vector3::new(0.0, 0.0, -0.5),
                pb: Vector3::new(-0.4, 0.1, 0.0),
                first_row: 3,
                rows: 3,
            },
        ],
    };
    let c1 = *Rotation3::from_euler_angles(0.3, -0.5, 0.2).matrix();
    let c2 = *Rotation3::from_euler_angles(-0.2, 0.4, 1.1).matrix();
    let start = vec![
        BodyStart {
            x: Vector3::new(0.2, -0.1, -0.4),
            v: Vector3::new(0.3, 0.2, -0.1),
            c: c1,
            w: Vector3::new(0.5, -1.0, 2.0),
        },
        BodyStart {
            x: Vector3::new(0.6, 0.1, -0.9),
            v: Vector3::new(-0.2, 0.4, 0.1),
            c: c2,
            w: Vector3::new(-0.7, 0.3, 1.5),
        },
    ];
    (model, start)
}

/// Gravity and a time-dependent torque on bar 2.
fn loads(t: f64, out: &mut [Load]) {
    out[0] = Load {
        f: Vector3::new(0.0, 0.0, -9.81),
        t: Vector3::zeros(),
    };
    out[1] = Load {
        f: Vector3::new(0.0, 0.0, -0.7 * 9.81),
        t: Vector3::new(0.3 * t, -0.2, 0.1),
    };
}

#[test]
fn equation_count_is_30_e_bodies_plus_3_e_plus_1_joints() {
    let (model, start) = two_bars();
    let w = SpatialWindow::new(&model, 8, 0.05, 0.0, start, loads);
    assert_eq!(w.u.len(), 30 * 8 * 2 + 3 * 9 * 2);
}

#[test]
fn analytic_jacobian_matches_finite_differences() {
    let (model, start) = two_bars();
    let w = SpatialWindow::new(&model, 2, 0.2, 0.0, start, loads);
    super::tests::assert_jacobian_matches_finite_differences(&w);
}

/// A free body under a constant force moves on a parabola, and a torque-free body spinning
/// about a principal axis turns at a constant rate: the quadratic interpolants represent
/// both exactly, so `x` and `q` must be exact at every node (the cosines only
/// approximately), and the momentum-consistent end velocities exact too.
#[test]
fn free_body_polynomial_motion_is_exact_at_the_nodes() {
    let model = Spatial {
        bodies: vec![Body {
            name: "free".into(),
            m: 2.0,
            j: Matrix3::from_diagonal(&Vector3::new(0.3, 0.2, 0.1)),
        }],
        joints: vec![],
    };
    let c0 = *Rotation3::from_euler_angles(0.4, 0.1, -0.3).matrix();
    let w0 = Vector3::new(0.0, 2.0, 0.0);
    let start = vec![BodyStart {
        x: Vector3::new(0.1, -0.2, 0.3),
        v: Vector3::new(1.5, 0.5, -1.0),
        c: c0,
        w: w0,
    }];
    let f = Vector3::new(0.8, -3.0, 1.2);
    let mut w = SpatialWindow::new(&model, 5, 0.1, 0.0, start, move |_, out| {
        out[0] = Load {
            f,
            t: Vector3::zeros(),
        }
    });
    for j in 1..=10 {
        w.set_kin(j, 0, &Vector3::zeros(), &start_x(), &c0);
    }
    let stats = w.newton(1e-13, 20).expect("converges");
    assert!(stats.iterations <= 6, "{stats:?}");
    for e in 0..5 {
        for tau in [0.5, 1.0] {
            let t = (e as f64 + tau) * 0.1;
            let (x, c, _, wq) = w.body_at(e, tau, 0);
            let exact = Vector3::new(0.1, -0.2, 0.3)
                + Vector3::new(1.5, 0.5, -1.0) * t
                + f / 2.0 * (0.5 * t * t);
            assert!((x - exact).amax() < 1e-12, "x at {t}: {x} vs {exact}");
            assert!((wq - w0).amax() < 1e-11, "ω at {t}: {wq}");
            let turned = c0 * Rotation3::from_axis_angle(&Vector3::y_axis(), 2.0 * t).matrix();
            assert!((c - turned).amax() < 1e-3, "C at {t}: {c} vs {turned}");
        }
        let (we, ve) = w.end_velocity(e, 0);
        let t = (e + 1) as f64 * 0.1;
        assert!((we - w0).amax() < 1e-11, "end ω {we}");
        let v = Vector3::new(1.5, 0.5, -1.0) + f / 2.0 * t;
        assert!((ve - v).amax() < 1e-12, "end v {ve} vs {v}");
    }
    assert!(
        w.orthogonality_drift() < 1e-3,
        "{}",
        w.orthogonality_drift()
    );
}

fn start_x() -> Vector3<f64> {
    Vector3::new(0.1, -0.2, 0.3)
}

/// A joint between ground and ground acts on no body: the window reports the singular
/// Newton matrix naming the joint.
#[test]
fn a_singular_newton_matrix_is_a_reported_failure() {
    let (mut model, start) = two_bars();
    model.joints.push(Joint {
        name: "idle".into(),
        a: None,
        b: None,
        pa: Vector3::zeros(),
        pb: Vector3::zeros(),
        first_row: 6,
        rows: 3,
    });
    let mut w = SpatialWindow::new(&model, 3, 0.05, 0.0, start, loads);
    let failure = w
        .newton(1e-12, 20)
        .expect_err("a singular window must fail");
    let why = failure.linear.expect("the linear solve's reason");
    assert!(
        why.contains("singular") && why.contains("joint 'idle'"),
        "{why}"
    );
}
