//! Unit tests of the state-time window on hand-built planar models (no `System`): the
//! equation count of notes F §1.9, the analytic Jacobian against finite differences, and
//! polynomial exactness (notes F §5, "suggested validation checks").

use super::newton::{self, Discretization};
use super::planar::{Body, Planar, Plane};
use super::scope::Joint;
use super::window::{BodyStart, Window};
use nalgebra::Vector3;

/// The planar double pendulum of notes F §2.1 in the x–y plane (q from the downward
/// vertical, rods with I = m l²/12), and its start data.
fn double_pendulum() -> (Planar, Vec<BodyStart>, Vec<[[f64; 2]; 2]>) {
    let (m1, l1, q1, w1) = (1.0, 0.8, 1.0f64, 1.0);
    let (m2, l2, q2, w2) = (0.5, 1.0, 1.2f64, -1.0);
    let model = Planar {
        plane: Plane::new(Vector3::z()),
        bodies: vec![
            Body {
                name: "rod1".into(),
                m: m1,
                jn: m1 * l1 * l1 / 12.0,
            },
            Body {
                name: "rod2".into(),
                m: m2,
                jn: m2 * l2 * l2 / 12.0,
            },
        ],
        joints: vec![
            Joint {
                name: "pivot".into(),
                a: None,
                b: Some(0),
                pa: Vector3::zeros(),
                pb: Vector3::zeros(),
                first_row: 0,
                rows: 3,
            },
            Joint {
                name: "elbow".into(),
                a: Some(0),
                b: Some(1),
                pa: Vector3::zeros(),
                pb: Vector3::zeros(),
                first_row: 3,
                rows: 3,
            },
        ],
    };
    let dir = |q: f64| [q.sin(), -q.cos()];
    let (d1, d2) = (dir(q1), dir(q2));
    let c1 = [d1[0] * l1 / 2.0, d1[1] * l1 / 2.0];
    let c2 = [
        2.0 * c1[0] + d2[0] * l2 / 2.0,
        2.0 * c1[1] + d2[1] * l2 / 2.0,
    ];
    let v1 = [-w1 * c1[1], w1 * c1[0]];
    let v2 = [
        2.0 * v1[0] - w2 * d2[1] * l2 / 2.0,
        2.0 * v1[1] + w2 * d2[0] * l2 / 2.0,
    ];
    let start = vec![
        BodyStart {
            x: c1,
            v: v1,
            w: w1,
        },
        BodyStart {
            x: c2,
            v: v2,
            w: w2,
        },
    ];
    let half = |d: [f64; 2], l: f64, s: f64| [s * d[0] * l / 2.0, s * d[1] * l / 2.0];
    let offsets = vec![
        [[0.0, 0.0], half(d1, l1, -1.0)],
        [half(d1, l1, 1.0), half(d2, l2, -1.0)],
    ];
    (model, start, offsets)
}

fn gravity(masses: [f64; 2]) -> impl FnMut(f64, &mut [[f64; 3]]) {
    move |_, out| {
        for (o, m) in out.iter_mut().zip(masses) {
            *o = [0.0, -2.0 * m, 0.0];
        }
    }
}

#[test]
fn double_pendulum_has_1540_equations_at_64_elements() {
    let (model, start, offsets) = double_pendulum();
    let w = Window::new(
        &model,
        64,
        5.0 / 64.0,
        0.0,
        start,
        &offsets,
        gravity([1.0, 0.5]),
    );
    assert_eq!(w.unknowns(), 1540);
    assert_eq!(w.unknowns(), 24 * 64 + 4);
}

/// The analytic Jacobian of `d` against central differences of its residual at a smooth,
/// non-trivial iterate (`uᵢ = 0.3 + 0.7 sin(0.37 i)`), entry by entry to 1e-7 relative.
pub(super) fn assert_jacobian_matches_finite_differences<D: Discretization>(d: &D) {
    let n = d.unknowns();
    let u0: Vec<f64> = (0..n)
        .map(|i| 0.3 + 0.7 * ((i as f64) * 0.37).sin())
        .collect();
    let mut jac = vec![vec![0.0; n]; n];
    for (r, c, v) in newton::jacobian_entries(d, &u0) {
        jac[r][c] += v;
    }
    let eps = 1e-6;
    let mut u = u0.clone();
    for c in 0..n {
        u.copy_from_slice(&u0);
        u[c] += eps;
        let rp = newton::residual(d, &u);
        u[c] -= 2.0 * eps;
        let rm = newton::residual(d, &u);
        for r in 0..n {
            let fd = (rp[r] - rm[r]) / (2.0 * eps);
            assert!(
                (fd - jac[r][c]).abs() < 1e-7 * (1.0 + fd.abs()),
                "∂r{r}/∂u{c}: analytic {} vs finite difference {fd}",
                jac[r][c]
            );
        }
    }
}

#[test]
fn analytic_jacobian_matches_finite_differences() {
    let (model, start, offsets) = double_pendulum();
    let w = Window::new(&model, 3, 0.2, 0.0, start, &offsets, gravity([1.0, 0.5]));
    assert_jacobian_matches_finite_differences(&w);
}

/// A free body under a constant force moves on a parabola and a torque-free one turns at
/// a constant rate; the quadratic interpolants represent both exactly, so the solution
/// must be exact at every node (q, x, y; c and s are only approximate).
#[test]
fn free_body_polynomial_motion_is_exact_at_the_nodes() {
    let model = Planar {
        plane: Plane::new(Vector3::z()),
        bodies: vec![Body {
            name: "free".into(),
            m: 2.0,
            jn: 0.3,
        }],
        joints: vec![],
    };
    let start = vec![BodyStart {
        x: [0.1, -0.2],
        v: [1.5, 0.5],
        w: 2.0,
    }];
    let (fx, fy) = (0.8, -3.0);
    let mut w = Window::new(&model, 5, 0.25, 0.0, start, &[], move |_, out| {
        out[0] = [fx, fy, 0.0]
    });
    for j in 1..=10 {
        w.set_kin(j, 0, [0.0, 0.0, 0.0, 1.0, 0.0]);
    }
    let stats = w.newton(1e-13, 20).expect("converges");
    assert!(stats.iterations <= 6, "{stats:?}");
    for e in 0..5 {
        for tau in [0.5, 1.0] {
            let t = (e as f64 + tau) * 0.25;
            let (v, _) = w.body_at(e, tau, 0);
            let x = 0.1 + 1.5 * t + 0.5 * fx / 2.0 * t * t;
            let y = -0.2 + 0.5 * t + 0.5 * fy / 2.0 * t * t;
            assert!((v[0] - 2.0 * t).abs() < 1e-12, "q at {t}: {}", v[0]);
            assert!((v[1] - x).abs() < 1e-12, "x at {t}: {} vs {x}", v[1]);
            assert!((v[2] - y).abs() < 1e-12, "y at {t}: {} vs {y}", v[2]);
            assert!((v[3] - (2.0 * t).cos()).abs() < 2e-2, "c at {t}: {}", v[3]);
        }
    }
}

/// A joint between ground and ground acts on no body: its force unknowns enter no
/// equation and its constraint equations hold no unknown. The Newton matrix is singular,
/// and the window reports it, naming the joint, where faer's numeric LU would panic on
/// the zero pivot.
#[test]
fn a_singular_newton_matrix_is_a_reported_failure_not_a_panic() {
    let (mut model, start, mut offsets) = double_pendulum();
    model.joints.push(Joint {
        name: "idle".into(),
        a: None,
        b: None,
        pa: Vector3::zeros(),
        pb: Vector3::zeros(),
        first_row: 6,
        rows: 3,
    });
    offsets.push([[0.0, 0.0], [0.0, 0.0]]);
    let mut w = Window::new(&model, 4, 0.05, 0.0, start, &offsets, gravity([1.0, 0.5]));
    let failure = w
        .newton(1e-12, 20)
        .expect_err("a singular window must fail");
    let why = failure.linear.expect("the linear solve's reason");
    assert!(
        why.contains("singular") && why.contains("joint 'idle'"),
        "{why}"
    );
}
