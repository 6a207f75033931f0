//! Accuracy studies from Rust: a physical pendulum with its exact solution, studied with the
//! interpreter runner; the fitted orders are the methods' theoretical order.

use std::f64::consts::FRAC_PI_2;

use mbdc_runtime::fn1::ellipk;
use mbdc_runtime::math::{axis_angle, quat_array, rotation};
use mbdc_runtime::scene::*;
use mbdc_runtime::study::{run_study, InterpRunner, Measure, ReferenceInfo, Study, StudyOptions};
use nalgebra::Vector3;

const G: f64 = 9.81;

fn f(x: Fn1) -> Box<Fn1> {
    Box::new(x)
}

fn c(x: f64) -> Fn1 {
    Fn1::Const(x)
}

/// A rod of length 1.2 m and mass 2 kg hanging from a revolute joint (axis world y) at its
/// end, released from rest at 40° from the vertical, 3 s (about 1.3 periods).
///
/// Exact solution (the physical pendulum, ω₀² = m g d / J_pivot = 3g/(2l), d = l/2):
/// sin(θ/2) = k sn(u | k²), cos(θ/2) = dn(u | k²), u = K(k²) − ω₀ t, k = sin(θ₀/2), so
/// the mass centre is d (sin θ, 0, −cos θ) = d (2k sn dn, 0, −(1 − 2k² sn²)) and the
/// orientation, a rotation by −θ about y, is (dn, 0, −k sn, 0).
fn pendulum(with_reference: bool) -> Scene {
    let (m, l, r, theta0) = (2.0, 1.2, 0.02, 40f64.to_radians());
    let d = l / 2.0;
    let i_cm = m * l * l / 12.0;
    let q = axis_angle(&Vector3::y(), -theta0);
    let rho = Vector3::new(0.0, 0.0, d); // pivot end, body frame
    let pos = -(rotation(&q) * rho);
    let body = Body {
        name: "rod".into(),
        mass: m,
        inertia: [
            [i_cm, 0.0, 0.0],
            [0.0, i_cm, 0.0],
            [0.0, 0.0, m * r * r / 2.0],
        ],
        position: pos.into(),
        orientation: quat_array(&q),
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        origin: Origin::default(),
    };
    // joint z along world y (and along body y): frame = rotation of −90° about x
    let frame = quat_array(&axis_angle(&Vector3::x(), -FRAC_PI_2));
    let k = (theta0 / 2.0).sin();
    let mm = k * k;
    let w0 = (3.0 * G / (2.0 * l)).sqrt();
    let u = || Fn1::Sub(f(c(ellipk(mm))), f(Fn1::Mul(f(c(w0)), f(Fn1::Var))));
    let sn = || Fn1::JacobiSn(f(u()), mm);
    let dn = || Fn1::JacobiDn(f(u()), mm);
    let x = Fn1::Mul(f(c(2.0 * d * k)), f(Fn1::Mul(f(sn()), f(dn()))));
    let z = Fn1::Neg(f(Fn1::Mul(
        f(c(d)),
        f(Fn1::Sub(
            f(c(1.0)),
            f(Fn1::Mul(f(c(2.0 * mm)), f(Fn1::Powf(f(sn()), 2.0)))),
        )),
    )));
    let qy = Fn1::Mul(f(c(-k)), f(sn()));
    Scene {
        name: "pendulum".into(),
        gravity: Some([0.0, 0.0, -G]),
        bodies: vec![body],
        joints: vec![Joint {
            name: "hinge".into(),
            kind: JointKind::Revolute,
            a: Attachment {
                body: BodyRef::Ground,
                point: [0.0; 3],
                frame,
            },
            b: Attachment {
                body: BodyRef::Body(0),
                point: rho.into(),
                frame,
            },
            origin: Origin::default(),
        }],
        forces: vec![],
        beams: vec![],
        meshes: vec![],
        contacts: vec![],
        simulate: Simulate {
            duration: 3.0,
            ..Simulate::default()
        },
        reference: with_reference.then(|| Reference {
            bodies: vec![BodyReference {
                body: 0,
                position: Some([x, c(0.0), z]),
                orientation: Some([dn(), c(0.0), qy, c(0.0)]),
            }],
            table: None,
        }),
        params: vec![],
    }
}

/// Every run finishes with an error against the exact solution, and the fitted order of both second-order methods is within 0.1 of 2. Why 0.1: against an
/// exact reference the error of a second-order method is C h² (1 + O(h)); over the steps
/// studied here (h·ω₀ ≤ 0.31, the default series: 20 steps per period of the
/// swing and finer) the local orders between neighbouring steps stay within a few
/// hundredths of 2, and the fit keeps only the stretch where they agree. A wrong order
/// (a first-order error somewhere: a lagged force, an inconsistent start) would be off by
/// about 1; the fit's own flag is at 0.3.
#[test]
fn second_order_against_the_exact_pendulum() {
    let scene = pendulum(true);
    let options = StudyOptions {
        methods: vec!["staggered".into(), "implicit_trapezoid".into()],
        levels: 6,
        min_time: 0.0,
        ..StudyOptions::default()
    };
    let mut runner = InterpRunner::new(&scene).expect("the interpreter runs the scene");
    let r = run_study(&scene, &options, &mut runner).expect("the study runs");
    assert_eq!(r.reference, ReferenceInfo::Analytic);
    assert_eq!(r.measure, Measure::PosMax);
    assert_eq!(r.secondary, Some(Measure::RotMax));
    assert!(
        r.estimate
            .as_ref()
            .is_some_and(|e| e.source.contains("under gravity")),
        "the steps come from the swing: {:?}",
        r.estimate
    );
    assert_eq!(r.runs.len(), 12);
    for run in &r.runs {
        assert!(run.outcome.status.is_ok(), "{run:?}");
        let e = run.errors.expect("errors");
        assert!(e.pos_max.is_some_and(|x| x > 0.0 && x < 0.1), "{e:?}");
    }
    for name in ["staggered", "implicit_trapezoid"] {
        let fit = r.fit_of(name).expect("a fit");
        let order = fit.order.expect("an order");
        eprintln!(
            "{name}: order {order:.3} over {:?}, local {:?}",
            fit.used, fit.local
        );
        assert!((order - 2.0).abs() < 0.1, "{name}: {order} {fit:?}");
        assert!(fit.used.len() >= 3, "{name}: {fit:?}");
        assert!(!mbdc_runtime::study::fit::flagged(fit, Some(2.0)));
        let (_, rot) = &r.fits[r.method_index(name).expect("index")];
        let rot = rot
            .as_ref()
            .and_then(|f| f.order)
            .expect("orientation order");
        assert!((rot - 2.0).abs() < 0.1, "{name} orientation: {rot}");
    }
}

/// Without a `reference` block the study makes a numerical one, 8 times finer than the
/// finest step, and says how accurate it is: its Richardson estimate lies far below the
/// errors it is used to measure, and the order measured against it is still 2.
#[test]
fn numerical_reference_with_its_error_estimate() {
    let scene = pendulum(false);
    let options = StudyOptions {
        methods: vec!["staggered".into()],
        levels: 5,
        min_time: 0.0,
        ..StudyOptions::default()
    };
    let study = Study::new(&scene, &options).expect("a plan");
    let h_min = *study.steps().last().expect("steps");
    let mut runner = InterpRunner::new(&scene).expect("interpreter");
    let r = study.run(&mut runner, &mut ()).expect("the study runs");
    let ReferenceInfo::Numerical {
        method,
        step,
        estimate,
        ..
    } = &r.reference
    else {
        panic!("{:?}", r.reference)
    };
    assert_eq!(method, "staggered");
    assert!((step * 8.0 - h_min).abs() < 1e-15, "{step} {h_min}");
    let est = estimate.pos_max.expect("an estimate");
    let finest = r
        .runs
        .last()
        .and_then(|x| x.errors?.pos_max)
        .expect("error");
    assert!(est > 0.0 && est < finest / 20.0, "{est} vs {finest}");
    let order = r.fit_of("staggered").and_then(|f| f.order).expect("order");
    assert!((order - 2.0).abs() < 0.1, "{order}");
}
