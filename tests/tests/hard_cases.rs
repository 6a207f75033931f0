//! The hard-case suite (issue 7): scenes under `models/hard/` (and the deployment arm), each
//! run with every method. Each test says what "stable" means for it and checks it; a method
//! that cannot do a case must stop with a report that names where and why — a run that
//! finishes silently wrong is the one outcome not allowed. docs/stability.md summarizes them.

use mbdc_runtime::run_loop;
use mbdc_runtime::scene::{Gyroscopic, MethodSpec, StaggeredOptions};
use mbdc_tests::*;
use nalgebra::Vector3;

/// Every method of the rigid runtime: the scene's method names, less the state-time one.
fn all() -> impl Iterator<Item = &'static str> {
    MethodSpec::NAMES.into_iter().filter(|n| *n != "state_time")
}

/// Every method either meets `ok` or stops with a report naming a body, a joint or the system.
fn each_method(
    model: &str,
    h: f64,
    duration: f64,
    ok: impl Fn(&str, &Trajectory) -> Result<(), String>,
) -> Vec<(&'static str, bool)> {
    let scene = load_model(model);
    let mut out = Vec::new();
    for name in all() {
        let tr = simulate(&scene, method(name), h, duration, 10);
        let good = match &tr.report.failure {
            None => {
                if let Err(why) = ok(name, &tr) {
                    panic!("{model}: {name} finished but {why}");
                }
                true
            }
            Some(f) => {
                assert_complete(&format!("{model}: {name}"), f);
                eprintln!("{model}: {name} stopped: {f}");
                false
            }
        };
        out.push((name, good));
    }
    out
}

/// A stop's report names where, why and what to try.
fn assert_complete(what: &str, f: &run_loop::Failure) {
    assert!(
        !f.location.is_empty() && !f.cause.is_empty() && f.hint.is_some(),
        "{what}: {f}"
    );
}

fn passed(results: &[(&str, bool)], name: &str) -> bool {
    results.iter().any(|(n, ok)| *n == name && *ok)
}

/// Case 1 (links that line up): the parallelogram four-bar turns through its flat (change-point)
/// configuration twice per revolution, where B loses rank. Reference: with no forces it turns at
/// its initial rate, θ(t) = θ₀ + ωt exactly. Stable means for `staggered` and
/// `natural_partitioning` (required): |Φ| < 1e-7 and the crank angle within [`TOGGLE_ANGLE`] of
/// θ₀ + ωt over 10 s (6 flat passages). The bound is the leapfrog's phase error, which grows
/// like (hω)²·ωt/6 = 1.3e-5 rad at t = 10 s (measured 1.24e-5, no jump at the flat passages).
/// Any other method that finishes must stay within 0.1 rad and |Φ| < 1e-2 (measured: the
/// trapezoid 6.4e-6, coordinate partitioning 2.0e-3, Baumgarte 5.8e-5, penalty 1.2e-2 — its soft
/// constraints sag at each flat passage).
const TOGGLE_ANGLE: f64 = 2e-5;

#[test]
fn toggle_four_bar_through_its_flat_configuration() {
    let w = 2.0;
    let results = each_method("hard/toggle_four_bar.mbd", 1e-3, 10.0, |name, tr| {
        let strict = matches!(name, "staggered" | "natural_partitioning");
        let (tol_angle, tol_phi) = if strict {
            (TOGGLE_ANGLE, 1e-7)
        } else {
            (0.1, 1e-2)
        };
        let mut worst = (0.0f64, 0.0);
        for f in &tr.frames {
            // crank axis (body y, from the pivot to the pin) in world: angle from +x
            let a = f.pose[0].c * Vector3::y();
            let th = a.y.atan2(a.x);
            let exact = std::f64::consts::FRAC_PI_2 + w * f.t;
            let err = (th - exact).sin().abs();
            if err > worst.0 {
                worst = (err, f.t);
            }
        }
        eprintln!(
            "toggle four-bar, {name}: crank angle error {:.2e} rad (worst at t = {})",
            worst.0, worst.1
        );
        if worst.0 > tol_angle {
            return Err(format!(
                "crank angle off by {:.2e} rad at t = {}",
                worst.0, worst.1
            ));
        }
        (tr.max_violation() < tol_phi)
            .then_some(())
            .ok_or(format!("|Φ| = {:.2e}", tr.max_violation()))
    });
    assert!(
        passed(&results, "staggered") && passed(&results, "natural_partitioning"),
        "{results:?}"
    );
}

/// Case 2 (redundant constraints): a planar four-bar of spatial revolutes (3 dependent rows
/// everywhere) and a door on two coaxial hinges (5 dependent rows). Reference: the same motion
/// without the redundancy — the door on one hinge; the four-bar's crank angle from the same run
/// with spherical/universal joints at the coupler is not comparable geometrically, so for it the
/// reference is energy conservation (no dissipation, no sources) and |Φ|. Stable means for
/// `staggered`, `natural_partitioning` and `implicit_trapezoid` (required; the trapezoid sets
/// the dependent rows aside): |Φ| < 1e-10, energy within 1e-3 of the energy in play over 5 s,
/// and the door within 1e-9 m of the one-hinge door. Baumgarte and coordinate partitioning
/// must stop at once with a report naming a joint, since B M⁻¹ Bᵀ is singular.
#[test]
fn redundant_loops_simulate_and_are_reported() {
    for model in ["hard/planar_four_bar.mbd", "hard/door.mbd"] {
        let results = each_method(model, 1e-3, 5.0, |name, tr| {
            if matches!(
                name,
                "staggered" | "natural_partitioning" | "implicit_trapezoid"
            ) {
                let scale = tr.frames.iter().fold(0.0f64, |a, f| a.max(f.kinetic));
                let de = tr.max_energy_error() / scale;
                if tr.max_violation() > 1e-10 || de > 1e-3 {
                    return Err(format!(
                        "|Φ| = {:.2e}, energy error {de:.2e}",
                        tr.max_violation()
                    ));
                }
            }
            Ok(())
        });
        assert!(
            passed(&results, "staggered")
                && passed(&results, "natural_partitioning")
                && passed(&results, "implicit_trapezoid"),
            "{model}: {results:?}"
        );
        for m in ["baumgarte", "coordinate_partitioning"] {
            assert!(
                !passed(&results, m),
                "{model}: {m} should stop on a singular B M⁻¹ Bᵀ"
            );
        }
    }
    // the door on two hinges moves exactly like the door on one
    let two = load_model("hard/door.mbd");
    let text = std::fs::read_to_string(model_path("hard/door.mbd")).unwrap();
    let one = load_text(
        &text
            .lines()
            .filter(|l| !l.contains("joint lower"))
            .collect::<Vec<_>>()
            .join("\n"),
    );
    let a = simulate(&two, method("staggered"), 1e-3, 5.0, 100);
    let b = simulate(&one, method("staggered"), 1e-3, 5.0, 100);
    let gap = a
        .frames
        .iter()
        .zip(&b.frames)
        .fold(0.0f64, |m, (x, y)| m.max(position_difference(x, y)));
    eprintln!("door on two hinges vs one: {gap:.2e} m");
    assert!(gap < 1e-9, "{gap}");
}

/// Case 3a (fast spin): a free body spinning at 1900 rad/s about its major axis with h = 1 ms
/// (h·ω = 1.9, just below the explicit limit 2). Stable means: energy and |L| conserved to 1e-10
/// relative over 10 s for `staggered` (its midpoint gyroscopic update conserves both exactly)
/// and the wobble bounded (|ω₁| + |ω₂| never above 10× its start); every method that finishes
/// must keep energy within 5 % (measured: coordinate partitioning 1.5e-6, the trapezoid 8e-8).
#[test]
fn fast_spin_near_the_stability_limit() {
    let results = each_method("hard/fast_spin.mbd", 1e-3, 10.0, |name, tr| {
        let e0 = tr.frames[0].energy();
        let l0 = Vector3::from(tr.frames[0].angular_momentum).norm();
        let de = tr.max_energy_error() / e0;
        let dl = tr.frames.iter().fold(0.0f64, |a, f| {
            a.max((Vector3::from(f.angular_momentum).norm() - l0).abs() / l0)
        });
        let w0 = tr.frames[0].twist[0].w.x.abs() + tr.frames[0].twist[0].w.y.abs();
        let wobble = tr.frames.iter().fold(0.0f64, |a, f| {
            a.max(f.twist[0].w.x.abs() + f.twist[0].w.y.abs())
        });
        eprintln!(
            "fast spin {name}: energy {de:.2e}, |L| {dl:.2e}, wobble ×{:.2}",
            wobble / w0
        );
        let bound = if name == "staggered" { 1e-10 } else { 5e-2 };
        if de > bound || (name == "staggered" && dl > 1e-10) || wobble > 10.0 * w0 {
            return Err(format!(
                "energy {de:.2e}, |L| {dl:.2e}, wobble ×{:.1}",
                wobble / w0
            ));
        }
        Ok(())
    });
    assert!(passed(&results, "staggered"), "{results:?}");
}

/// Case 3b (spinning top with gravity): started in exact steady precession (models/hard/top.mbd).
/// Reference: the heavy-top theory, tilt constant at 30° and precession rate Ω from
/// m g l = Ω(C n − A'Ω cos θ) (≈ 2.632 rad/s). Stable means for `staggered` at h = 0.5 ms: the
/// tilt within 1e-3° of 30° over 5 s (no nutation), the measured precession rate within 1e-4 of
/// Ω. The paper's two-stage exchange of ω (`gyroscopic synchronous`) fails here — the top falls
/// past 90° within 5 s — which is why it is not the default (docs/methods.md).
#[test]
fn heavy_top_precesses_as_theory_says() {
    let scene = load_model("hard/top.mbd");
    let omega = top::precession_rate();
    let tilt = |f: &Rec| top::tilt(f).to_degrees();
    let tr = simulate(&scene, method("staggered"), 5e-4, 5.0, 20);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let worst = tr
        .frames
        .iter()
        .fold(0.0f64, |a, f| a.max((tilt(f) - 30.0).abs()));
    let rate = top::measured_precession(&tr.frames);
    eprintln!("top: tilt within {worst:.2e}°, precession {rate:.6} rad/s, theory {omega:.6} (relative {:.1e})", (rate - omega).abs() / omega);
    assert!(worst < 1e-3, "{worst}");
    assert!((rate - omega).abs() < 1e-4 * omega, "{rate} vs {omega}");
    // the paper's exchange
    let o = StaggeredOptions {
        gyroscopic: Gyroscopic::Synchronous,
        ..Default::default()
    };
    let tr = simulate(&scene, MethodSpec::Staggered(o), 5e-4, 5.0, 20);
    let fell = tr.frames.iter().fold(0.0f64, |a, f| a.max(tilt(f)));
    eprintln!("top with the paper's two-stage exchange: tilt reaches {fell:.1}°");
    assert!(
        fell > 90.0,
        "the synchronous exchange kept the top up ({fell}°): revisit docs/methods.md"
    );
}

/// Case 4 (mass ratios): a chain of ten links from 1 g to 1 t (models/hard/mass_ratio_chain.mbd).
/// Stable means for `staggered` at the model's step (20 µs): |Φ| < 1e-9 and energy within 1e-7 of
/// the largest kinetic energy over 2 s; the trapezoid at 100 µs the same. At 200 µs the explicit
/// methods are beyond the stability limit of the light link in tension (see the model) and must
/// stop with a report — which `--on-failure halve-step` turns into a finished run.
#[test]
fn mass_ratio_chain() {
    let scene = load_model("hard/mass_ratio_chain.mbd");
    for (name, h) in [("staggered", 2e-5), ("implicit_trapezoid", 1e-4)] {
        let tr = simulate(&scene, method(name), h, 2.0, 100);
        assert!(tr.report.finished, "{name}: {:?}", tr.report.failure);
        let scale = tr.frames.iter().fold(0.0f64, |a, f| a.max(f.kinetic));
        let de = tr.max_energy_error() / scale;
        eprintln!(
            "mass ratio chain, {name} at {h:e} s: |Φ| {:.2e}, energy {de:.2e}",
            tr.max_violation()
        );
        assert!(tr.max_violation() < 1e-9 && de < 1e-7, "{name}");
    }
    let coarse = simulate(&scene, method("staggered"), 2e-4, 2.0, 100);
    let f = coarse
        .report
        .failure
        .as_ref()
        .expect("beyond the limit the run must stop");
    eprintln!("at 200 µs: {f}");
    assert!(f.hint.as_deref().unwrap_or("").contains("step"), "{f}");
}

/// Case 6 (long runs): 10⁶ steps of the conservative 3-D double pendulum (1000 s at 1 ms) with
/// `staggered`. Stable means: |Φ| < 1e-10 throughout, and no secular energy drift — the largest
/// energy error over the last 10 % of the run no more than twice that over the first 10 %
/// (measured 7.5e-5 and 1.14e-4 of the largest kinetic energy: the leapfrog's O(h²) energy
/// oscillation, whose peaks on a chaotic trajectory vary from window to window), and below
/// 2e-4 of the largest kinetic energy throughout.
#[test]
fn long_run_double_pendulum() {
    let scene = load_model("double_pendulum_3d.mbd");
    let tr = simulate(&scene, method("staggered"), 1e-3, 1000.0, 1000);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    assert_eq!(tr.report.steps, 1_000_000);
    let e0 = tr.frames[0].energy();
    let scale = tr.frames.iter().fold(0.0f64, |a, f| a.max(f.kinetic));
    let window = |lo: f64, hi: f64| {
        tr.frames
            .iter()
            .filter(|f| f.t >= lo && f.t <= hi)
            .fold(0.0f64, |a, f| a.max((f.energy() - e0).abs()))
    };
    let (early, late) = (window(0.0, 100.0), window(900.0, 1000.0));
    eprintln!("10⁶ steps: |Φ| {:.2e}; energy error first 100 s {:.2e}, last 100 s {:.2e} (of {scale:.3} J)", tr.max_violation(), early / scale, late / scale);
    assert!(tr.max_violation() < 1e-10);
    assert!(late <= 2.0 * early, "secular drift: {early} → {late}");
    assert!(late / scale < 2e-4 && early / scale < 2e-4);
}

/// Case 7a (discontinuous driver): a torque switched on at t = 0.5 s on a disc on an axle.
/// Reference: θ = (τ/2J)(t − 0.5)² after the switch. The force jumps inside a step, so the
/// error is first order in h: at t = 2 s it must be below 2·(τ/J)·h·(t − 0.5) (one step's worth
/// of velocity error carried over the run) for every method that finishes, and halve (±20 %)
/// when h halves for `staggered`.
#[test]
fn step_torque() {
    let scene = load_model("hard/step_torque.mbd");
    let (tau, j) = (1.0, 0.5);
    let angle = |f: &Rec| {
        let x = f.pose[0].c * Vector3::x();
        x.y.atan2(x.x)
    };
    let err_at = |name: &str, h: f64| {
        let tr = simulate(&scene, method(name), h, 2.0, 1_000_000);
        assert!(tr.report.finished, "{name}: {:?}", tr.report.failure);
        let f = tr.last();
        let exact = tau / (2.0 * j) * (f.t - 0.5f64).max(0.0).powi(2);
        (angle(f) - exact).abs()
    };
    for name in all() {
        let e = err_at(name, 1e-3);
        eprintln!("step torque, {name}: error {e:.2e} rad");
        assert!(e < 2.0 * tau / j * 1e-3 * 1.5, "{name}: {e}");
    }
    let (e1, e2) = (err_at("staggered", 1e-3), err_at("staggered", 5e-4));
    assert!(
        (e1 / e2 - 2.0).abs() < 0.4 || e1 < 1e-12,
        "order: {e1} → {e2}"
    );
}

/// Case 7b (a driver with a kink): θ(t) = 2 rad/s · ramp(t − 0.5 s) on a rod's hinge. The
/// velocity jumps at 0.5 s, so the constraint force is an impulse. Stable means for every method
/// that finishes: the driven angle exact to 1e-9 rad at every frame (the driver's row is a
/// position constraint), and after the kink the kinetic energy equal to ½J_pivot ω² to the
/// (3/4)(hω)² relative error of the second-order output velocity (measured 1.1e-6 J of 0.667).
/// Baumgarte cannot produce an impulse: it must stop with a report. The penalty method's
/// constraints are soft by design: it may finish, with the driven angle off by no more than the
/// constraint violation its summary reports (measured 5.6e-3 rad just after the kink), and its
/// kinetic energy is not checked.
#[test]
fn kinked_driver() {
    let (m, l, r) = (1.0f64, 1.0f64, 0.01f64);
    let jp = m * (3.0 * r * r + l * l) / 12.0 + m * (l / 2.0).powi(2);
    let results = each_method("hard/kinked_driver.mbd", 1e-3, 2.0, |name, tr| {
        let soft = name == "penalty";
        let tol = if soft {
            1.01 * tr.max_violation() + 1e-9
        } else {
            1e-9
        };
        for f in &tr.frames {
            let x = f.pose[0].c * Vector3::x();
            let th = x.y.atan2(x.x);
            let exact = 2.0 * (f.t - 0.5).max(0.0);
            if soft {
                if (th - exact).sin().abs() > tol {
                    return Err(format!(
                        "angle off by {:.2e} at t = {}, more than the reported violation {:.2e}",
                        (th - exact).sin().abs(),
                        f.t,
                        tr.max_violation()
                    ));
                }
                continue;
            }
            if (th - exact).sin().abs() > tol {
                return Err(format!(
                    "angle off by {:.2e} at t = {}",
                    (th - exact).sin().abs(),
                    f.t
                ));
            }
            // the reported velocity is the second-order half-kick extrapolation of the
            // leapfrog's half-step velocity; for a point turning at ω it is long by
            // (3/8)(hω)² relative, so the kinetic energy by (3/4)(hω)² (here 2.0e-6 J)
            let (ke, h) = (0.5 * jp * 4.0, 1e-3);
            if f.t > 0.6 && (f.kinetic - ke).abs() > 0.75 * (2.0 * h) * (2.0 * h) * ke {
                return Err(format!("kinetic energy {} at t = {}", f.kinetic, f.t));
            }
        }
        Ok(())
    });
    assert!(passed(&results, "staggered"), "{results:?}");
    assert!(!passed(&results, "baumgarte"), "{results:?}");
}

/// The planar four-bar of four revolutes (3 redundant rows) against the same four-bar without
/// the redundancy (the coupler's joints a spherical and a universal: 17 independent rows), both
/// with `implicit_trapezoid` at 1 ms for 5 s (issue 21). Reference: the non-redundant run, which
/// the method solves without any singular matrix. Before the trapezoid set the dependent rows
/// aside, near-zero pivots in their place fed round-off into the multipliers (the issue saw the
/// linkage 0.18 m off with |Φ| at 2e-12 on such a scene; here it stopped at step 1). Tolerance:
/// 1e-6 m on every body position at every frame (measured: see the test's output), and the
/// summary counts the 3 rows it set aside.
#[test]
fn implicit_trapezoid_sets_redundant_rows_aside() {
    let redundant = load_model("hard/planar_four_bar.mbd");
    let text = std::fs::read_to_string(model_path("hard/planar_four_bar.mbd")).unwrap();
    let text = text
        .replace(
            "joint b = revolute(crank @ world(P1), coupler @ world(P1), axis: (0, 0, 1))",
            "joint b = spherical(crank @ world(P1), coupler @ world(P1))",
        )
        .replace(
            "joint c = revolute(coupler @ world(P2), rocker @ world(P2), axis: (0, 0, 1))",
            "joint c = universal(coupler @ world(P2), rocker @ world(P2), axis_a: (0, 1, 0), axis_b: (0, 0, 1))",
        );
    assert!(text.contains("spherical") && text.contains("universal"));
    let plain = load_text(&text);
    let a = simulate(&redundant, method("implicit_trapezoid"), 1e-3, 5.0, 10);
    let b = simulate(&plain, method("implicit_trapezoid"), 1e-3, 5.0, 10);
    assert!(a.report.finished, "{:?}", a.report.failure);
    assert!(b.report.finished, "{:?}", b.report.failure);
    let set_aside = a
        .report
        .stats
        .iter()
        .find(|(n, _)| n == "redundant_rows")
        .map(|(_, v)| *v);
    assert_eq!(set_aside, Some(3.0));
    let gap = a
        .frames
        .iter()
        .zip(&b.frames)
        .fold(0.0f64, |m, (x, y)| m.max(position_difference(x, y)));
    eprintln!("four revolutes vs revolute-spherical-universal-revolute, implicit_trapezoid: {gap:.2e} m; |Φ| {:.1e}", a.max_violation());
    assert_eq!(a.frames.len(), b.frames.len());
    assert!(gap < 1e-6, "{gap} m");
    assert!(a.max_violation() < 1e-10);
}

/// A driver's multiplier is its torque (issue 21): the rod of `models/hard/driven_pendulum.mbd`
/// turned at constant speed against gravity needs exactly τ = m g (L/2) cos ωt from its motor,
/// and every method reports the driver's λ = −τ (sign convention M u̇' + Bᵀλ = F). Checked at
/// ω = 100 rad/s, h = 1 ms over 1 s (16 turns). `implicit_trapezoid` reports the step's mean
/// constraint force, centred at t − h/2; its reference is τ there, tolerance 1 % of the 4.905
/// N·m amplitude (its O((hω)²) error, measured below). Before, the trapezoid reported only the
/// Newton multiplier μ and left out the velocity projection's impulse: −40 to −50 N·m here, a
/// bias that grows like ω³. The staggered method's λ is at t; tolerance 2 %, from the third
/// step on (its output λ has a start-up transient: 75 N·m at the first step, −45 at the second).
/// At the kink of `kinked_driver.mbd` the multiplier is the impulse J_pivot·Δω over the step
/// (Δω = 2 rad/s), as a force: −666.7 N·m for one step at h = 1 ms (before: 0).
#[test]
fn driver_multipliers_are_the_driving_torque() {
    let w = 100.0;
    let scene = load_model_with("hard/driven_pendulum.mbd", &["w=100 rad/s"]);
    let amp = 1.0 * 9.81 * 0.5;
    let h = 1e-3;
    for (name, lag, tol, from) in [
        ("implicit_trapezoid", h / 2.0, 0.01, h),
        ("staggered", 0.0, 0.02, 3.0 * h),
    ] {
        let tr = simulate(&scene, method(name), h, 1.0, 1);
        assert!(tr.report.finished, "{name}: {:?}", tr.report.failure);
        let driver_row = tr.frames[0].lambda.len() - 1;
        let late = tr.frames.iter().filter(|f| f.t > from - 1e-12);
        let worst = late.fold(0.0f64, |m, f| {
            let exact = -amp * (w * (f.t - lag)).cos();
            m.max((f.lambda[driver_row] - exact).abs())
        });
        eprintln!(
            "driven pendulum at {w} rad/s, {name}: driver λ within {worst:.3e} N·m of −m g (L/2) cos ωt"
        );
        assert!(worst < tol * amp, "{name}: {worst}");
    }
    let kinked = load_model("hard/kinked_driver.mbd");
    let (m, l, r) = (1.0f64, 1.0f64, 0.01f64);
    let jp = m * (3.0 * r * r + l * l) / 12.0 + m * (l / 2.0).powi(2);
    let tr = simulate(&kinked, method("implicit_trapezoid"), h, 1.0, 1);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let driver_row = tr.frames[0].lambda.len() - 1;
    let peak = tr
        .frames
        .iter()
        .map(|f| f.lambda[driver_row])
        .fold(0.0f64, |a, v| if v.abs() > a.abs() { v } else { a });
    let impulse = -jp * 2.0 / h;
    eprintln!(
        "kinked driver, implicit_trapezoid: λ at the kink {peak:.4} N·m, J Δω / h = {impulse:.4}"
    );
    assert!((peak - impulse).abs() < 1e-6 * impulse.abs(), "{peak}");
    let after = tr
        .frames
        .iter()
        .filter(|f| f.t > 0.51)
        .fold(0.0f64, |a, f| a.max(f.lambda[driver_row].abs()));
    assert!(after < 1e-6, "{after}");
}

/// Coordinate partitioning through a singular choice of coordinates (issue 21): the point-mass
/// pendulum of `models/hard/point_pendulum.mbd` (one `distance` row) released from the
/// horizontal. Its dependent coordinate at the start is the bob's x, whose Jacobian entry
/// vanishes as the bob passes below the pivot; the method must choose again there. Reference:
/// the exact large-amplitude solution in the scene's `reference` block (Jacobi sn, period
/// 2.3674 s), over 5 s (4 passages through the vertical) at the scene's 1 ms. Tolerances: the
/// bob within 1e-3 m of the exact position at every frame and the energy within 1e-3 of
/// m g L (exact: 0 J throughout; measured 2.0e-4 m and 1.4e-4 with 9 partitions);
/// `staggered` and `implicit_trapezoid` are held to the same.
/// Before, the pivot test was relative to B_d's own largest pivot, always 1 for one row: the
/// run kept `partitions: 1` and went wrong at the first passage (the watchdog stopped it on
/// energy growth at t = 0.59 s; with the old every-64-steps watchdog it could end 0.48 m off).
#[test]
fn coordinate_partitioning_chooses_again_through_the_vertical() {
    use mbdc_runtime::study::reference::{RefBody, RefSolution};
    use mbdc_runtime::study::Analytic;
    let scene = load_model("hard/point_pendulum.mbd");
    let exact = Analytic::new(&scene).expect("the scene has a reference");
    let mut rb = vec![RefBody::default(); 1];
    let mgl = 9.81;
    for name in ["coordinate_partitioning", "staggered", "implicit_trapezoid"] {
        let tr = simulate(&scene, method(name), 1e-3, 5.0, 10);
        assert!(tr.report.finished, "{name}: {:?}", tr.report.failure);
        let mut worst = (0.0f64, 0.0);
        for f in &tr.frames {
            exact.at(f.t, &mut rb).unwrap();
            let r = rb[0].r.unwrap();
            let d = (f.pose[0].r - Vector3::from(r)).norm();
            if d > worst.0 {
                worst = (d, f.t);
            }
        }
        let de = tr.max_energy_error() / mgl;
        let partitions = tr
            .report
            .stats
            .iter()
            .find(|(n, _)| n == "partitions")
            .map(|(_, v)| *v);
        eprintln!(
            "point pendulum, {name}: {:.2e} m from the exact solution (worst at t = {}), energy {de:.2e} of m g L, partitions {partitions:?}",
            worst.0, worst.1
        );
        assert!(worst.0 < 1e-3, "{name}: {} m at t = {}", worst.0, worst.1);
        assert!(de < 1e-3, "{name}: energy {de}");
        if let Some(p) = partitions {
            assert!(p >= 5.0, "{name}: {p} partitions through 4 passages");
        }
    }
}

/// The penalty method's default ε holds a joint whose B M⁻¹ Bᵀ diagonal grows as the mechanism
/// moves (issue 21): `models/hard/bob_on_a_hinge.mbd`, a small sphere 1 m from its hinge,
/// whose x row's diagonal goes from 1/m at the start to 25 001/m once the bob swings. Before, ε
/// was sized from the start's diagonal and the run blew up at t ≈ 0.075 s at every step down to
/// 1e-5 s (refining never helped); now it is sized from a bound over every configuration of the
/// joint. Checks, over 1 s: at h = 2e-5 and 1e-5 s the run finishes; its violation converges as
/// h² (ratio 4 ± 1 between the two steps: ε ∝ h²); and the bob stays within 3× its reported
/// violation plus 1e-4 m of `staggered` at 1e-5 s (the reference).
#[test]
fn penalty_default_epsilon_holds_a_bob_on_a_hinge() {
    let scene = load_model("hard/bob_on_a_hinge.mbd");
    let reference = simulate(&scene, method("staggered"), 1e-5, 1.0, 1000);
    assert!(reference.report.finished, "{:?}", reference.report.failure);
    let mut violations = Vec::new();
    for h in [2e-5, 1e-5] {
        let tr = simulate(&scene, method("penalty"), h, 1.0, (1e-2 / h).round() as u32);
        assert!(
            tr.report.finished,
            "penalty at h = {h}: {:?}",
            tr.report.failure
        );
        let v = tr.report.max_violation.0;
        let gap = tr
            .frames
            .iter()
            .filter_map(|f| {
                let g = reference.frames.iter().find(|g| (g.t - f.t).abs() < 1e-9)?;
                Some((f.pose[0].r - g.pose[0].r).norm())
            })
            .fold(0.0f64, f64::max);
        eprintln!(
            "bob on a hinge, penalty at h = {h:e}: violation {v:.3e} m, {gap:.3e} m from staggered"
        );
        assert!(gap < 3.0 * v + 1e-4, "h = {h}: {gap} m off, violation {v}");
        violations.push(v);
    }
    let ratio = violations[0] / violations[1];
    assert!(
        (ratio - 4.0).abs() < 1.0,
        "violation ratio {ratio} when h halves"
    );
}

/// The energy balance books the work of applied forces and torques (issue 21). Reference:
/// `models/hard/step_torque.mbd`, τ = 1 N·m switched on at 0.5 s on J = 0.5 kg·m²: the work
/// to t = 2 s is τ²(1.5 s)²/(2J) = 2.25 J, exactly the kinetic energy. Every method books it
/// within 2·10⁻³ J (the torque's switch falls inside a step: one step's worth, first order
/// in h), and its balance K − W closes within 10⁻⁵ of the energy in play.
#[test]
fn the_balance_books_the_work_of_a_torque() {
    let scene = load_model("hard/step_torque.mbd");
    for name in all() {
        let tr = simulate_watched(&scene, method(name), 1e-3, 2.0, 100);
        assert!(tr.report.finished, "{name}: {:?}", tr.report.failure);
        let e = tr.report.energy;
        assert!(
            (e.work_forces - 2.25).abs() < 2e-3,
            "{name}: W = {}",
            e.work_forces
        );
        assert_eq!(e.work_drivers, 0.0, "{name}");
        assert!(
            tr.report.max_energy_drift < 1e-5,
            "{name}: {}",
            tr.report.max_energy_drift
        );
        assert!(
            tr.report.warnings.is_empty(),
            "{name}: {:?}",
            tr.report.warnings
        );
    }
}

/// The energy balance books the work of drivers (issue 21). Reference:
/// `models/hard/driven_pendulum.mbd`, a rod turned at constant ω = 2 rad/s against gravity:
/// its kinetic energy stays constant, so the motor's work up to t is the change of potential
/// energy, m g (L/2) sin ωt = −1.3705 J at t = 3 s. Every method but `penalty` (whose soft
/// driver lets the rod lag; it stops on the violation) books it within 10⁻³ J and closes its
/// balance within 10⁻³ of the energy in play at h = 1 ms. `rk4`, `dopri5` and `dop853`
/// (the driver a cut row, its multiplier the index-1 one at each reported state) book it
/// within 10⁻⁶ J and close the balance within 10⁻⁶: the trapezoidal sum of the driver's
/// power over the 1 ms frames is what is left.
#[test]
fn the_balance_books_the_work_of_a_driver() {
    let scene = load_model("hard/driven_pendulum.mbd");
    let exact = 9.81 * 0.5 * 6f64.sin();
    for name in all().filter(|n| *n != "penalty") {
        let tr = simulate_watched(&scene, method(name), 1e-3, 3.0, 100);
        assert!(tr.report.finished, "{name}: {:?}", tr.report.failure);
        let e = tr.report.energy;
        let high_order = matches!(name, "rk4" | "dopri5" | "dop853");
        eprintln!(
            "{name}: W = {} (exact {exact}), balance {:.2e}",
            e.work_drivers, tr.report.max_energy_drift
        );
        if high_order {
            assert!(
                (e.work_drivers - exact).abs() < 1e-6 && tr.report.max_energy_drift < 1e-6,
                "{name}: W = {} against {exact}, balance {}",
                e.work_drivers,
                tr.report.max_energy_drift
            );
        }
        assert!(
            (e.work_drivers - exact).abs() < 1e-3,
            "{name}: W = {} against {exact}",
            e.work_drivers
        );
        assert!(e.work_forces.abs() < 1e-9, "{name}: {}", e.work_forces);
        assert!(
            tr.report.max_energy_drift < 1e-3,
            "{name}: {}",
            tr.report.max_energy_drift
        );
    }
}

/// A damper's loss is booked, so a damped run's balance closes (issue 21: a loss nothing
/// accounts for is an error too). A 1 kg mass on a spring of 100 N/m with a damper of
/// 2 N·s/m (damping ratio 0.1), released 0.1 m from rest: over 5 s it loses almost all of its
/// ½ k x₀² = 0.5 J, all of it to the damper. Every method closes the balance within 10⁻³ of
/// the energy in play at h = 1 ms, and books between 0.49 and 0.5 J as the damper's work.
#[test]
fn the_balance_books_the_loss_of_a_damper() {
    let scene = load_text(
        "model damped {
  body m { mass 1 kg; inertia sphere(radius: 0.1 m); position (0.1, 0, 0) m }
  force k = spring(ground @ (-1, 0, 0) m, m @ (0, 0, 0), stiffness: 100 N/m, damping: 2 N*s/m, length: 1 m)
  simulate { duration 5 s; step 1 ms }
}",
    );
    for name in all() {
        let tr = simulate_watched(&scene, method(name), 1e-3, 5.0, 100);
        assert!(tr.report.finished, "{name}: {:?}", tr.report.failure);
        let e = tr.report.energy;
        assert!(
            (-0.5005..-0.49).contains(&e.work_forces),
            "{name}: damper work {}",
            e.work_forces
        );
        assert!(
            tr.report.max_energy_drift < 1e-3,
            "{name}: {}",
            tr.report.max_energy_drift
        );
    }
}

/// Energy that disappears stops a run (issue 21). `models/hard/mass_ratio_chain.mbd` at
/// h = 1 ms is above the light link's stability limit; `natural_partitioning` there does not
/// blow up but loses energy — before the balance was checked in both directions it was only
/// stopped by chance. It now stops within 0.1 s, naming a body and the energy that
/// disappeared, and advising the method that conserves it.
#[test]
fn energy_that_disappears_stops_the_run() {
    let scene = load_model("hard/mass_ratio_chain.mbd");
    let tr = simulate_watched(&scene, method("natural_partitioning"), 1e-3, 2.0, 100);
    let f = tr.report.failure.expect("stops");
    assert!(f.quantity.starts_with("energy balance"), "{f}");
    assert!(f.value < -0.25, "{f}");
    assert!(f.cause.contains("disappeared"), "{f}");
    assert!(f.location.starts_with("body '"), "{f}");
    assert!(f.hint.as_deref().unwrap().contains("staggered"), "{f}");
    assert!(f.time < 0.1, "{f}");
}

/// A driver's kink acts by an impulse (issue 21). `models/hard/kinked_driver.mbd` jumps from
/// rest to 2 rad/s at 0.5 s: the rod's kinetic energy jumps to ½ J ω² = 0.6667 J. The
/// balance books the kink's step as an impulse, so every method that follows the kink
/// closes its balance afterwards within 10⁻⁶ of the energy in play, with the jump (as
/// driver work, or as the impulse where the method's multipliers miss it) totalling
/// 0.6667 J within 10⁻⁴.
#[test]
fn a_kinked_driver_is_booked_as_an_impulse() {
    let scene = load_model("hard/kinked_driver.mbd");
    for name in [
        "staggered",
        "natural_partitioning",
        "implicit_trapezoid",
        "coordinate_partitioning",
    ] {
        let tr = simulate_watched(&scene, method(name), 1e-3, 1.0, 100);
        assert!(tr.report.finished, "{name}: {:?}", tr.report.failure);
        let e = tr.report.energy;
        let jump = e.work_drivers + e.impulses;
        assert!((jump - 2.0 / 3.0).abs() < 1e-4, "{name}: {e:?}");
        assert!(
            tr.report.max_energy_drift < 1e-6,
            "{name}: {}",
            tr.report.max_energy_drift
        );
    }
}

/// The spun-up rotor of the issue (`models/hard/rotor_spin_up.mbd`, to h·ω = 2 at h = 1 ms):
/// `coordinate_partitioning` follows it exactly (kinetic energy = driver work = 2·10⁵ J to
/// 10⁻¹⁰); `staggered` reports the kinetic energy 19 % high (its rotation update at
/// h·ω → 2), and where it used to finish without a word its balance is now off by more
/// than 1 %, which it says at the end of the run.
#[test]
fn the_spun_up_rotor_says_its_balance() {
    let scene = load_model("hard/rotor_spin_up.mbd");
    let exact = 0.5 * 0.1 * 2000.0f64.powi(2);
    let tr = simulate_watched(&scene, method("coordinate_partitioning"), 1e-3, 20.0, 1000);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let e = tr.report.energy;
    assert!((e.kinetic - exact).abs() < 1e-10 * exact, "{e:?}");
    assert!((e.work_drivers - exact).abs() < 1e-10 * exact, "{e:?}");
    let tr = simulate_watched(&scene, method("staggered"), 1e-3, 20.0, 1000);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    assert!(tr.report.energy.kinetic > 1.1 * exact);
    assert!(tr.report.max_energy_drift > run_loop::ENERGY_BALANCE_WARNING);
    assert!(
        tr.report
            .warnings
            .iter()
            .any(|w| w.contains("energy balance")),
        "{:?}",
        tr.report.warnings
    );
}

/// The method × scene × step table of docs/stability.md (issue 21): every method on every
/// hard scene at 20, 5 and 1 ms (durations capped at 3 s), as the energy balance judges them.
/// Prints markdown rows; asserts the table's promise: no run finishes with a balance error
/// above [`run_loop::ENERGY_BALANCE_WARNING`] without a warning. Ignored (a minute in a debug
/// build): `cargo test -p mbdc-tests --test hard_cases -- --ignored --nocapture
/// method_scene_step_table`.
#[test]
#[ignore]
fn method_scene_step_table() {
    let scenes = [
        "toggle_four_bar",
        "planar_four_bar",
        "door",
        "fast_spin",
        "top",
        "mass_ratio_chain",
        "stiff_spring",
        "point_pendulum",
        "bob_on_a_hinge",
        "step_torque",
        "kinked_driver",
        "driven_pendulum",
        "light_over_heavy",
    ];
    let steps = [2e-2, 5e-3, 1e-3];
    let names: Vec<&str> = all().collect();
    println!(
        "| scene | h | {} |\n|---|---|{}",
        names.join(" | "),
        "---|".repeat(names.len())
    );
    for s in scenes {
        let scene = load_model(&format!("hard/{s}.mbd"));
        // the gate of `mbdc run` and `mbdc check`: the scene's sources, the driven speeds and
        // the constrained system's fastest mode
        let sys = mbdc_runtime::interp::Interp::new(&scene).unwrap();
        let stable = mbdc_runtime::step_limits::estimate_system(&scene, &sys)
            .0
            .stable_step();
        for h in steps {
            let mut cells = Vec::new();
            for name in &names {
                // what `mbdc run` refuses before the first step (without --force)
                let explicit = mbdc_runtime::step_limits::is_explicit(&method(name));
                if explicit && h > stable {
                    cells.push("refused".to_string());
                    continue;
                }
                let tr = simulate_watched(
                    &scene,
                    method(name),
                    h,
                    scene.simulate.duration.min(3.0),
                    100,
                );
                let d = tr.report.max_energy_drift;
                let cell = match &tr.report.failure {
                    None => {
                        let warned = tr
                            .report
                            .warnings
                            .iter()
                            .any(|w| w.contains("energy balance"));
                        assert!(
                            d <= run_loop::ENERGY_BALANCE_WARNING
                                || warned
                                || !tr.report.energy.loss_checked,
                            "{s} {name} {h}: finished with balance error {d} and no warning"
                        );
                        eprintln!(
                            "{s} {h:.0e} {name}: violation {:.1e} of joint '{}' length",
                            tr.report.max_relative_violation.0, tr.report.max_relative_violation.1
                        );
                        format!("ok {d:.0e}{}", if warned { " (warns)" } else { "" })
                    }
                    Some(f) => format!("stop: {} at {:.2} s", short(&f.quantity), f.time),
                };
                cells.push(cell);
            }
            println!("| {s} | {h:.0e} | {} |", cells.join(" | "));
        }
    }
}

/// A failure's quantity in a few words for the table.
fn short(q: &str) -> &str {
    if q.starts_with("energy balance") {
        "energy"
    } else if q.contains("growing") {
        "violation growth"
    } else if q.contains("joint's length") {
        "violation/length"
    } else if q.starts_with("constraint violation") {
        "violation"
    } else if q.contains("Newton") {
        "Newton"
    } else if q.contains("pivot") {
        "singular"
    } else if q == "start" {
        "cannot start"
    } else {
        q
    }
}

/// The implicit trapezoid on a light link under load (case 11): its Newton matrix has the
/// constraints' geometric stiffness when the iteration contracts slowly, so the 1 g bob
/// carrying 10 kg (constrained mode 1400 rad/s, h·ω = 1.4 and 7) runs at 1 and 5 ms, where
/// it stopped at step 1 before (Newton stalled at 1e-8, contracting by 0.49 per iteration).
/// Reference: the energy balance of a scene without sources, 3e-11 and 4e-11 measured.
#[test]
fn implicit_trapezoid_carries_a_light_link_under_load() {
    let scene = load_model("hard/light_over_heavy.mbd");
    for h in [1e-3, 5e-3] {
        let tr = simulate_watched(&scene, method("implicit_trapezoid"), h, 1.0, 100);
        assert!(tr.report.finished, "h = {h}: {:?}", tr.report.failure);
        assert!(
            tr.report.max_energy_drift < 1e-9,
            "h = {h}: balance {:.1e}",
            tr.report.max_energy_drift
        );
    }
}

/// The reference of `models/hard/squeezer.mbd` at t = 0.03 s: every body's absolute angle
/// (crank, link2, k3, k4, k5, k6, k7) from the test set's y(1..7) = β, Θ, γ, Φ, δ, Ω, ε
/// (PSIDE at tolerances of 1e-14, the CWI/Bari test set for IVP solvers, problem "andrews").
const SQUEEZER_END: [f64; 7] = {
    let (beta, theta, gamma) = (15.81077119629904, -15.75637105984298, 0.04082224013073101);
    let (phi, delta) = (-0.5347301163226948, 0.5244099658805304);
    let (omega, epsilon) = (0.5347301163226948, 1.048080741042263);
    [
        beta,
        beta + theta,
        gamma,
        phi + delta,
        delta,
        omega + epsilon,
        epsilon,
    ]
};

/// The largest angle error of a squeezer frame against [`SQUEEZER_END`], each body's angle
/// about z compared modulo 2π.
fn squeezer_error(f: &Rec) -> f64 {
    f.pose
        .iter()
        .zip(SQUEEZER_END)
        .map(|(p, reference)| {
            let a = p.c[(1, 0)].atan2(p.c[(0, 0)]);
            (a - reference).sin().abs().max(1.0 - (a - reference).cos())
        })
        .fold(0.0, f64::max)
}

/// The accuracy a finished run reports, as a bound on its phase error relative to the angle
/// its fastest body turned through: twice its energy-balance error (a spin-up's phase error is
/// about half its energy error, δθ/θ ≈ δE/2E), or the accuracy rule's own bound at the steps
/// per turn of its peak spin ω, (hω)²/4 (the leapfrog's phase error is (hω)²/24 per radian on
/// `ẍ = −ω²x`; at the rule's limit of 20 steps per turn the bound is 2.5 %), whichever is
/// larger. The energy balance alone is no bound on a phase error: a four-bar turning at
/// constant speed keeps its energy to 10⁻¹¹ at any step.
fn reported_accuracy(r: &run_loop::RunReport, h: f64) -> f64 {
    (2.0 * r.max_energy_drift).max((h * r.max_spin.0).powi(2) / 4.0)
}

/// A run on a ladder cell is loud (stopped with a complete report, warned at its end, or warned
/// or refused before it by the pre-run check) or right to the accuracy it reports: its angle
/// error `err` over the `travel` (rad) of its fastest body within [`reported_accuracy`].
/// Returns whether it was loud.
fn right_or_loud(
    what: &str,
    tr: &Trajectory,
    h: f64,
    err: f64,
    travel: f64,
    warned_before: bool,
) -> bool {
    let r = &tr.report;
    if let Some(f) = &r.failure {
        assert_complete(what, f);
        return true;
    }
    if !r.warnings.is_empty() || warned_before {
        return true;
    }
    let relative = err / travel;
    assert!(
        relative <= reported_accuracy(r, h),
        "{what}: finished without a warning {err:.2e} rad from the reference ({relative:.1e} of \
         the travel), where its balance {:.1e} and its peak spin {:.3e} rad/s allow {:.1e}",
        r.max_energy_drift,
        r.max_spin.0,
        reported_accuracy(r, h)
    );
    false
}

/// The angle the squeezer's crank turns through from its start to t = 0.03 s (rad).
const SQUEEZER_TRAVEL: f64 = 15.81077119629904 + 0.061_713_890_014_276_45;

/// Case 12 (millimetre links, a stiff spring, a crank spun to 1140 rad/s in 30 ms): Andrews'
/// squeezer (`models/hard/squeezer.mbd`) against the test set's reference at t = 0.03 s, every
/// method at steps from far too large (1 ms: 6 steps per turn of the crank at the end) to fine
/// (10 µs). Every run either
/// - stops with a report naming where and why, or
/// - finishes with a warning (the peak spin's steps per turn, the energy balance, a violation
///   large for its joint), or
/// - finishes silently and is right to the accuracy it reports: its largest angle error,
///   relative to the crank's travel (15.87 rad), within [`reported_accuracy`].
///
/// `staggered` (and `natural_partitioning`, the same update here) converge to the reference
/// as h²: 2.79e-5 rad at 10 µs, 2.51e-4 at 30 µs (ratio 9.0 for a step ratio of 3);
/// `coordinate_partitioning` 2.13e-5 and `implicit_trapezoid` 4.88e-5 at 10 µs. `penalty`
/// stops on its violation down to 30 µs and warns at 10 µs (its default ε leaves 2.8 % of a
/// joint's length); `baumgarte` stops on its violation's growth at 100 µs and finishes at 30
/// and 10 µs within 1.7e-2 and 1.8e-3 rad. The explicit Runge–Kutta methods close the loops
/// by their index-1 multipliers and a projection after each step: `rk4` is 4.5e-6 rad off
/// at 100 µs and 1.8e-8 at 30 µs (fourth order, and more while its error falls towards the
/// reference's), `dopri5` and `dop853` at their default tolerance 1e-9 are within 5.2e-9 rad
/// at every step from 1 ms down; at 10 µs all three are within 1.3e-9 rad. Their errors
/// level off at 1.14e-9 rad whatever the step or the method: the agreement with the
/// published reference ends there (its digits, or the model's constants), not the methods'.
#[test]
fn squeezer_matches_the_test_set_or_says_why() {
    let scene = load_model("hard/squeezer.mbd");
    let mut fine = std::collections::HashMap::new();
    for h in [1e-3, 3e-4, 1e-4, 3e-5, 1e-5] {
        for name in all() {
            let tr = simulate_watched(&scene, method(name), h, 0.03, 1_000_000);
            let err = squeezer_error(tr.last());
            let what = format!("squeezer, {name} at h = {h}");
            eprintln!(
                "{what}: err {err:.3e}, failure {}",
                tr.report.failure.is_some()
            );
            if tr.report.failure.is_none() {
                assert!((tr.last().t - 0.03).abs() < 1e-12, "{what}");
                fine.insert((name, (h * 1e6).round() as u64), err);
            }
            right_or_loud(&what, &tr, h, err, SQUEEZER_TRAVEL, false);
        }
    }
    // the accuracy at 10 µs and the order of convergence (measured values above)
    for (name, bound) in [
        ("staggered", 3e-5),
        ("natural_partitioning", 3e-5),
        ("coordinate_partitioning", 2.5e-5),
        ("implicit_trapezoid", 5.5e-5),
    ] {
        let e10 = fine[&(name, 10)];
        let e30 = fine[&(name, 30)];
        assert!(e10 < bound, "{name}: {e10:.3e} rad at 10 µs");
        assert!(
            e30 / e10 > 8.0,
            "{name}: error {e30:.2e} at 30 µs, {e10:.2e} at 10 µs: not second order"
        );
    }
    for name in ["rk4", "dopri5", "dop853"] {
        assert!(
            fine[&(name, 10)] < 2e-9,
            "{name}: {:.3e} rad at 10 µs",
            fine[&(name, 10)]
        );
    }
    for name in ["dopri5", "dop853"] {
        for h in [1000, 300, 100, 30] {
            assert!(
                fine[&(name, h)] < 1e-8,
                "{name}: {:.3e} rad at {h} µs",
                fine[&(name, h)]
            );
        }
    }
    let (e100, e30) = (fine[&("rk4", 100)], fine[&("rk4", 30)]);
    assert!(
        e100 / e30 > 100.0,
        "rk4: error {e100:.2e} at 100 µs, {e30:.2e} at 30 µs: not fourth order"
    );
}

/// Every method on the squeezer at a ladder of steps, printed (exploration; the test above
/// asserts the outcomes): `cargo test -p mbdc-tests --test hard_cases -- --ignored
/// --nocapture squeezer_ladder`.
#[test]
#[ignore]
fn squeezer_ladder() {
    let scene = load_model("hard/squeezer.mbd");
    for h in [1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6] {
        for name in all() {
            let tr = simulate_watched(&scene, method(name), h, 0.03, 1_000_000);
            let err = squeezer_error(tr.last());
            eprintln!(
                "{h:.0e} {name}: t {:.4} err {err:.2e} balance {:.1e} viol {:.1e} ({}) warns {:?} failure {:?}",
                tr.last().t,
                tr.report.max_energy_drift,
                tr.report.max_relative_violation.0,
                tr.report.max_relative_violation.1,
                tr.report.warnings,
                tr.report.failure.as_ref().map(|f| f.to_string())
            );
        }
    }
}

/// The toggle four-bar (case 1) at steps from its own 1 ms up to 200 times it, over 10 s
/// (20 rad of crank travel, 6 flat passages), against the exact θ₀ + ωt: every method at
/// every step is loud or right to the accuracy it reports ([`right_or_loud`]; the pre-run
/// check warns above h = 0.157 s, 20 steps per turn of its 2 rad/s). Measured: at 0.1 s
/// `coordinate_partitioning` is 1.7e-2 rad off with its balance at 2e-11 (a constant-speed
/// four-bar keeps its energy at any step: only the steps per turn bound its phase),
/// `implicit_trapezoid` 0.11 rad with its balance at 0.9 %; `staggered`,
/// `natural_partitioning`, `baumgarte` and `penalty` stop on their violations or warn.
#[test]
fn toggle_four_bar_far_too_large_steps_are_loud_or_right() {
    let scene = load_model("hard/toggle_four_bar.mbd");
    let sys = mbdc_runtime::interp::Interp::new(&scene).unwrap();
    let est = mbdc_runtime::step_limits::estimate_system(&scene, &sys).0;
    let w = 2.0;
    let mut loud = 0;
    for h in [0.2, 0.1, 0.05, 0.02, 0.01, 1e-3] {
        for name in all() {
            let m = method(name);
            let explicit = mbdc_runtime::step_limits::is_explicit(&m);
            if explicit && h > est.stable_step() {
                loud += 1;
                continue;
            }
            let tr = simulate_watched(&scene, m, h, 10.0, 1);
            let mut err = 0.0f64;
            for f in &tr.frames {
                let a = f.pose[0].c * Vector3::y();
                let th = a.y.atan2(a.x);
                err = err.max((th - std::f64::consts::FRAC_PI_2 - w * f.t).sin().abs());
            }
            let what = format!("toggle four-bar, {name} at h = {h}");
            if right_or_loud(&what, &tr, h, err, w * 10.0, h > est.accurate_step()) {
                loud += 1;
            }
        }
    }
    // the far-too-large steps are not all quietly right by accident
    assert!(loud >= 12, "{loud} loud cells");
}

/// Closed loops through singular positions under the explicit Runge–Kutta methods (issue
/// 19): the toggle four-bar (a parallelogram turning at a constant 2 rad/s through six flat
/// passages in 10 s, where all its links line up) and the planar four-bar closed by four
/// revolutes (three rows redundant everywhere). At their own 1 ms step `rk4`, `dopri5` and
/// `dop853` (tolerance 1e-9) finish without a warning, keep the energy balance within
/// 10⁻⁹ of the energy in play, and the toggle's crank stays within 10⁻⁸ rad of the exact
/// θ₀ + ωt; the planar four-bar's end state agrees between the three within 10⁻⁸ m.
/// Measured: balances 1e-13 to 2e-11, the crank within 7e-11 rad. Before the multipliers'
/// Tikhonov filter (`natural/loops.rs`), a rank decision or a regularization linear in δ
/// made `dop853` crawl into a flat passage (steps of 1e-13 s) and leave it with 4 % of the
/// energy gone.
#[test]
fn runge_kutta_methods_pass_singular_positions_of_closed_loops() {
    let toggle = load_model("hard/toggle_four_bar.mbd");
    let w = 2.0;
    for name in ["rk4", "dopri5", "dop853"] {
        let tr = simulate_watched(&toggle, method(name), 1e-3, 10.0, 10);
        assert!(
            tr.report.finished,
            "toggle, {name}: {:?}",
            tr.report.failure
        );
        assert!(
            tr.report.warnings.is_empty(),
            "toggle, {name}: {:?}",
            tr.report.warnings
        );
        let mut err = 0.0f64;
        for f in &tr.frames {
            let a = f.pose[0].c * Vector3::y();
            let th = a.y.atan2(a.x);
            err = err.max((th - std::f64::consts::FRAC_PI_2 - w * f.t).sin().abs());
        }
        eprintln!(
            "toggle, {name}: crank {err:.2e} rad, balance {:.1e}",
            tr.report.max_energy_drift
        );
        assert!(err < 1e-8, "toggle, {name}: crank {err:.2e} rad off");
        assert!(
            tr.report.max_energy_drift < 1e-9,
            "toggle, {name}: {}",
            tr.report.max_energy_drift
        );
    }
    let four_bar = load_model("hard/planar_four_bar.mbd");
    let mut ends = Vec::new();
    for name in ["rk4", "dopri5", "dop853"] {
        let tr = simulate_watched(&four_bar, method(name), 1e-3, 5.0, 100);
        assert!(
            tr.report.finished,
            "four-bar, {name}: {:?}",
            tr.report.failure
        );
        assert!(
            tr.report.warnings.is_empty(),
            "four-bar, {name}: {:?}",
            tr.report.warnings
        );
        eprintln!(
            "four-bar, {name}: balance {:.1e}",
            tr.report.max_energy_drift
        );
        assert!(
            tr.report.max_energy_drift < 1e-9,
            "four-bar, {name}: {}",
            tr.report.max_energy_drift
        );
        ends.push(tr.last().clone());
    }
    for (i, name) in [(1, "dopri5"), (2, "dop853")] {
        let d = ends[0]
            .pose
            .iter()
            .zip(&ends[i].pose)
            .map(|(a, b)| (a.r - b.r).norm())
            .fold(0.0, f64::max);
        eprintln!("four-bar: rk4 and {name} {d:.1e} m apart at the end");
        assert!(d < 1e-8, "four-bar: rk4 and {name} {d:.1e} m apart");
    }
}

/// The toggle four-bar at steps up to 200× its own, printed (exploration; the test above
/// asserts the outcomes).
#[test]
#[ignore]
fn toggle_ladder() {
    let scene = load_model("hard/toggle_four_bar.mbd");
    let sys = mbdc_runtime::interp::Interp::new(&scene).unwrap();
    let est = mbdc_runtime::step_limits::estimate_system(&scene, &sys).0;
    eprintln!(
        "stable {:.3e} accurate {:.3e}",
        est.stable_step(),
        est.accurate_step()
    );
    for h in [0.2, 0.1, 0.05, 0.02, 0.01] {
        for name in all() {
            let tr = simulate_watched(&scene, method(name), h, 10.0, 1);
            let mut worst = 0.0f64;
            for f in &tr.frames {
                let a = f.pose[0].c * Vector3::y();
                let th = a.y.atan2(a.x);
                let exact = std::f64::consts::FRAC_PI_2 + 2.0 * f.t;
                worst = worst.max((th - exact).sin().abs());
            }
            eprintln!(
                "{h:.0e} {name}: t {:.2} err {worst:.2e} balance {:.1e} viol {:.1e} warns {:?} failure {:?}",
                tr.last().t,
                tr.report.max_energy_drift,
                tr.report.max_relative_violation.0,
                tr.report.warnings,
                tr.report.failure.as_ref().map(|f| format!("{} at {:.2}", f.quantity, f.time))
            );
        }
    }
}
