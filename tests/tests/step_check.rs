//! The pre-run step check that sees the constraints and the drivers (issue 21): the fastest
//! mode of the constrained system linearized at t = 0
//! (`mbdc_runtime::constrained_modes`), and the speed a driver will reach
//! (`step_limits::driven_speed`). docs/stability.md, "The step check".

use mbdc_runtime::constrained_modes::{self, Outcome};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::step_limits;
use mbdc_tests::*;

/// The double pendulum's closed-form modes: `det(K − ω² M) = 0` with
/// `M = [[(m1 + m2) l1², m2 l1 l2], [m2 l1 l2, m2 l2²]]`, `K = diag((m1 + m2) g l1, m2 g l2)`.
fn double_pendulum(m1: f64, m2: f64, l1: f64, l2: f64, g: f64) -> (f64, f64) {
    let (a, b, c) = ((m1 + m2) * l1 * l1, m2 * l1 * l2, m2 * l2 * l2);
    let (k1, k2) = ((m1 + m2) * g * l1, m2 * g * l2);
    let (qa, qb, qc) = (a * c - b * b, -(k1 * c + k2 * a), k1 * k2);
    let d = (qb * qb - 4.0 * qa * qc).sqrt();
    (
        ((-qb + d) / (2.0 * qa)).sqrt(),
        ((-qb - d) / (2.0 * qa)).sqrt(),
    )
}

/// `models/hard/light_over_heavy.mbd`: a 1 g bob between a pivot and a 10 kg bob, on two
/// `distance` rows. The scene-level estimate has no source at all (no spring, no pivot joint),
/// so `mbdc run` used to accept any step; the constrained system's fastest mode is the light
/// bob between its two loaded rods. Reference: the closed form above at rest (`push = 0`),
/// ω = 1400.77 rad/s (tolerance 10⁻⁵ relative: the stiffness is a central difference); the
/// mode is named by the light bob and a rod; the stable step 2/ω is what the refusal gives.
/// With the scene's push (0.01 m/s) the rods' centripetal load raises it by about 10⁻⁴.
#[test]
fn the_step_check_sees_a_light_link_under_load() {
    let scene = load_model_with("hard/light_over_heavy.mbd", &["push=0 m/s"]);
    let (fast, _) = double_pendulum(1e-3, 10.0, 0.1, 0.1, 9.81);
    assert!((fast - 1400.7666).abs() < 1e-3, "{fast}");
    assert!(step_limits::estimate(&scene).fastest().is_none());
    let sys = Interp::new(&scene).unwrap();
    let Outcome::Done(Some(mode)) = constrained_modes::fastest(&sys) else {
        panic!("no mode");
    };
    assert!((mode.omega / fast - 1.0).abs() < 1e-5, "{mode:?} vs {fast}");
    assert_eq!(sys_body(&sys, mode.body), "light");
    assert!(mode.body_share > 0.9, "{mode:?}");
    let (est, note) = step_limits::estimate_system(&scene, &sys);
    assert!(note.is_none());
    let f = est.fastest().unwrap();
    assert!(f.what.contains("body 'light'"), "{}", f.what);
    assert!(
        f.what.contains("joint 'upper'") || f.what.contains("joint 'lower'"),
        "{}",
        f.what
    );
    assert!((est.stable_step() - 2.0 / fast).abs() < 1e-5 * 2.0 / fast);
    let pushed = load_model("hard/light_over_heavy.mbd");
    let sys = Interp::new(&pushed).unwrap();
    let Outcome::Done(Some(mode)) = constrained_modes::fastest(&sys) else {
        panic!("no mode");
    };
    assert!((mode.omega / fast - 1.0).abs() < 2e-4, "{mode:?} vs {fast}");
}

fn sys_body(sys: &Interp, i: usize) -> &str {
    use mbdc_runtime::system::System;
    &sys.layout().body_names[i]
}

/// A point-mass pendulum hanging at rest (`point_pendulum.mbd` with θ₀ = 0): its only mode is
/// the swing, ω = √(g/L) = 3.1321 rad/s, carried by the rod's tension alone (the gravity force
/// does not change with position: the geometric stiffness of the constraint force is all
/// there is). Tolerance 10⁻⁵ relative. Released from the horizontal (θ₀ = 90°) the rod
/// carries no load at t = 0 and there is no mode (none faster than round-off, 10⁻⁶ rad/s).
#[test]
fn the_step_check_sees_a_pendulum_through_its_rod() {
    let scene = load_model_with("hard/point_pendulum.mbd", &["theta0=0 deg"]);
    let sys = Interp::new(&scene).unwrap();
    let Outcome::Done(Some(mode)) = constrained_modes::fastest(&sys) else {
        panic!("no mode");
    };
    let exact = 9.81f64.sqrt();
    assert!((mode.omega / exact - 1.0).abs() < 1e-5, "{mode:?}");
    assert_eq!(mode.joint, Some(0), "{mode:?}");
    let scene = load_model("hard/point_pendulum.mbd");
    let sys = Interp::new(&scene).unwrap();
    match constrained_modes::fastest(&sys) {
        Outcome::Done(None) => {}
        Outcome::Done(Some(m)) => assert!(m.omega < 1e-6, "{m:?}"),
        o => panic!("{o:?}"),
    }
}

/// `models/hard/rotor_spin_up.mbd`: a driver spins the rotor up at 100 rad/s² for 20 s. The
/// rotor starts at rest, so before the driven speed counted the scene had no source and the
/// run at h = 1 ms (three steps per turn at the end, where `staggered` reports its kinetic
/// energy 19 % high) started without a word. Reference: Ω = α T = 2000 rad/s, exact (the
/// rate is sampled at the run's end); h·Ω = 2 is at the limit, not above it (no refusal),
/// and 3.1 steps per turn is below 20 (the accuracy warning: h ≤ 2π/(20 Ω) = 1.57e-4 s).
#[test]
fn the_step_check_sees_the_speed_a_driver_reaches() {
    let scene = load_model("hard/rotor_spin_up.mbd");
    let est = step_limits::estimate(&scene);
    let f = est.fastest().expect("the driver's speed");
    assert!((f.omega - 2000.0).abs() < 1e-9, "{f:?}");
    assert!(f.what.contains("driver 'motor'"), "{}", f.what);
    assert!(est.stable_step() >= 1e-3);
    let accurate = std::f64::consts::TAU / (20.0 * 2000.0);
    assert!((est.accurate_step() - accurate).abs() < 1e-15);
    // a longer run reaches a higher speed: at 30 s, 3000 rad/s, above the limit at 1 ms
    let mut longer = load_model("hard/rotor_spin_up.mbd");
    longer.simulate.duration = 30.0;
    assert!(step_limits::estimate(&longer).stable_step() < 1e-3);
}
