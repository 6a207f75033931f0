//! Validation of the finite-element meshes (issue 15, checks 2, 5 and 8 here; the element
//! patch tests are the kernels' unit tests) against closed forms. Every test states its
//! reference and its tolerance.
//!
//! The scenes are written in the language and run through the interpreter with the
//! explicit central-difference method at 0.9 of the critical step the runtime computes.

use mbdc_runtime::interp::Interp;
use mbdc_runtime::mesh_model;
use mbdc_runtime::system::System;
use mbdc_tests::*;

/// 0.9 × the central-difference limit of the scene's meshes.
fn step_of(scene: &mbdc_runtime::scene::Scene) -> f64 {
    let sys = Interp::new(scene).expect("interpretable");
    0.9 * mesh_model::critical_step(&sys.layout().meshes)
        .expect("elements")
        .step
}

/// A steel bar of bar2 elements along x, 1 m, area 1 cm², `E` 200 GPa, `ρ` 8000 kg/m³:
/// `c = √(E/ρ) = 5000 m/s`.
fn bar(elements: usize, conditions: &str) -> String {
    format!(
        r#"
model bar_wave {{
  material steel {{ E 200 GPa; nu 0.3; rho 8000 kg/m^3 }}
  mesh bar {{
    element bar2
    thickness 1 cm^2
    generate line(origin: (0, 0, 0) m, size: (1, 0, 0) m, divisions: {elements})
    material steel
    set root = nodes(x == 0)
    set tip = nodes(x == 1 m)
    {conditions}
  }}
  simulate {{ duration 1 ms; step 1 us }}
}}
"#
    )
}

/// The first time `f` falls to `level` (linear interpolation between frames).
fn crossing(tr: &Trajectory, level: f64, f: impl Fn(&Rec) -> f64) -> f64 {
    for w in tr.frames.windows(2) {
        let (a, b) = (f(&w[0]), f(&w[1]));
        if a > level && b <= level {
            return w[0].t + (w[1].t - w[0].t) * (a - level) / (a - b);
        }
    }
    panic!("never reaches {level}");
}

/// Mean of `f` over the frames with `t0 ≤ t ≤ t1`.
fn mean(tr: &Trajectory, t0: f64, t1: f64, f: impl Fn(&Rec) -> f64) -> f64 {
    let v: Vec<f64> = tr
        .frames
        .iter()
        .filter(|r| r.t >= t0 && r.t <= t1)
        .map(f)
        .collect();
    assert!(!v.is_empty());
    v.iter().sum::<f64>() / v.len() as f64
}

/// Time integral of `f` over `[t0, t1]` (trapezoids over the frames).
fn integral(tr: &Trajectory, t0: f64, t1: f64, f: impl Fn(&Rec) -> f64) -> f64 {
    let fr: Vec<&Rec> = tr
        .frames
        .iter()
        .filter(|r| r.t >= t0 && r.t <= t1)
        .collect();
    fr.windows(2)
        .map(|w| 0.5 * (f(w[0]) + f(w[1])) * (w[1].t - w[0].t))
        .sum()
}

/// Check 2 (bar2): a load `F = 100 N` (σ₀ = 1 MPa) ramped up over 20 µs (smoothstep: the
/// front is resolved by 20 elements, so the lattice's dispersion does not blur it)
/// compresses the free end of a bar clamped at x = 0. Reference: the 1-D wave equation —
/// the front travels at `c = √(E/ρ)` = 5000 m/s with stress −σ₀ behind it, and reflects
/// at the clamp with the same sign (the stress doubles). Tolerances: the half-height
/// crossing times at x = 0.7525 m and 0.2525 m differ by `0.5 m / c` within 1 %; the mean
/// stress of the middle element over windows 30 µs clear of the fronts is −σ₀ and −2σ₀
/// within 1 %.
#[test]
fn bar2_wave_speed_and_reflection_at_a_fixed_end() {
    let scene = load_text(&bar(
        200,
        "fix root\n    load tip, (-100 N * smoothstep(t, 0 s, 20 us), 0, 0)",
    ));
    let h = step_of(&scene);
    let tr = simulate(&scene, method("staggered"), h, 0.45e-3, 1);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let c = 5000.0;
    let sxx = |e: usize| move |r: &Rec| r.mesh.stress.get(e).map_or(0.0, |s| s[0]);
    let (t1, t2) = (
        crossing(&tr, -0.5e6, sxx(150)),
        crossing(&tr, -0.5e6, sxx(50)),
    );
    let expected = 0.5 / c;
    assert!(
        ((t2 - t1) / expected - 1.0).abs() < 0.01,
        "the front took {:e} s for 0.5 m, expected {expected:e} s",
        t2 - t1
    );
    let xm = 0.5025; // element 100
    let start = (1.0 - xm) / c + 20e-6;
    let incident = mean(&tr, start + 30e-6, (1.0 + xm) / c - 30e-6, sxx(100));
    assert!(
        (incident / -1e6 - 1.0).abs() < 0.01,
        "stress behind the front {incident:e} Pa"
    );
    let reflected = mean(&tr, (1.0 + xm) / c + 50e-6, 0.45e-3, sxx(100));
    assert!(
        (reflected / -2e6 - 1.0).abs() < 0.01,
        "stress after the reflection at the clamp {reflected:e} Pa"
    );
}

/// Check 2 (bar2): a smooth 20 µs pulse of peak `F = 100 N` (smoothstep up over 10 µs,
/// down over the next 10 µs: impulse `F · 10 µs`) pushed into the x = 0 end of a
/// free–free bar. Reference: the impulse through any section during the pulse's passage is
/// `∫σ dt = −F · 10 µs / A = −10 Pa·s` (momentum; whatever the dispersion), and a free end
/// reflects it with the opposite sign (tension). Tolerance 1 % on both integrals at
/// x = 0.7525 m.
#[test]
fn bar2_pulse_reflects_with_opposite_sign_at_a_free_end() {
    let scene = load_text(&bar(
        200,
        "load root, (100 N * (smoothstep(t, 0 s, 10 us) - smoothstep(t, 10 us, 20 us)), 0, 0)",
    ));
    let h = step_of(&scene);
    let tr = simulate(&scene, method("staggered"), h, 0.34e-3, 1);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let el = 150; // centred at x = 0.7525 m: incident at ~150 µs, reflected at ~250 µs
    let sxx = |r: &Rec| r.mesh.stress.get(el).map_or(0.0, |s| s[0]);
    let incident = integral(&tr, 0.0, 210e-6, sxx);
    let reflected = integral(&tr, 210e-6, 0.34e-3, sxx);
    assert!(
        (incident / -10.0 - 1.0).abs() < 0.01,
        "incident impulse {incident} Pa·s"
    );
    assert!(
        (reflected / 10.0 - 1.0).abs() < 0.01,
        "reflected impulse {reflected} Pa·s"
    );
}

/// Check 2 (hex8): a slender hex8 bar with ν = 0 (so the bar and dilatational speeds
/// coincide, `c = √(E/ρ)` = 5000 m/s), clamped at x = 0, a traction of 1 MPa ramped over
/// 40 µs (8 elements) on the face x = 1 m. Reference: the 1-D wave; the half-height
/// crossing times at x = 0.7625 m and 0.2625 m differ by `0.5 m / c` within 1 %.
#[test]
fn hex8_bar_front_travels_at_the_bar_speed() {
    let scene = load_text(
        r#"
model hex_wave {
  material m { E 200 GPa; nu 0; rho 8000 kg/m^3 }
  mesh bar {
    element hex8
    generate box(origin: (0, 0, 0) m, size: (1, 0.05, 0.05) m, divisions: (40, 1, 1))
    material m
    set clamp = nodes(x == 0)
    set face = nodes(x == 1 m)
    fix clamp
    traction face, (-1 MPa * smoothstep(t, 0 s, 40 us), 0, 0)
  }
  simulate { duration 1 ms; step 1 us }
}
"#,
    );
    let h = step_of(&scene);
    let tr = simulate(&scene, method("staggered"), h, 0.2e-3, 1);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let sxx = |e: usize| move |r: &Rec| r.mesh.stress.get(e).map_or(0.0, |s| s[0]);
    let (t1, t2) = (
        crossing(&tr, -0.5e6, sxx(30)),
        crossing(&tr, -0.5e6, sxx(10)),
    );
    let expected = 0.5 / 5000.0;
    assert!(
        ((t2 - t1) / expected - 1.0).abs() < 0.01,
        "the front took {:e} s for 0.5 m, expected {expected:e} s",
        t2 - t1
    );
}

/// Check 5: energy balance of a quad4 cantilever plate struck by a 0.1 ms tip pulse and
/// then vibrating freely, 10⁴ steps. Reference: `K + U − W` is constant (the work of the
/// pulse enters through W); tolerance 1e-3 of the peak kinetic energy, the issue's
/// bound (the central difference conserves a shadow energy: the synchronized kinetic
/// energy differs from it by O((ωh)²)).
#[test]
fn quad4_free_vibration_keeps_its_energy_balance() {
    let scene = load_text(
        r#"
model plate_balance {
  material alu { E 70 GPa; nu 0.33; rho 2700 kg/m^3 }
  mesh plate {
    element quad4, plane_stress
    thickness 5 mm
    generate rect(origin: (0, 0) m, size: (0.5, 0.05) m, divisions: (20, 2))
    material alu
    set left = nodes(x == 0)
    set tip = nodes(x == 0.5 m)
    fix left
    load tip, (0, 50 N * (step(t) - step(t - 0.1 ms)), 0)
  }
  simulate { duration 1 ms; step 1 us }
}
"#,
    );
    let h = step_of(&scene);
    let tr = simulate(&scene, method("staggered"), h, 1e4 * h, 10);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let e = |r: &Rec| r.mesh.energy.kinetic + r.mesh.energy.balance_potential();
    let peak = tr
        .frames
        .iter()
        .map(|r| r.mesh.energy.kinetic)
        .fold(0.0, f64::max);
    assert!(peak > 0.0);
    let worst = tr
        .frames
        .iter()
        .skip(1)
        .map(|r| e(r).abs())
        .fold(0.0, f64::max);
    assert!(
        worst < 1e-3 * peak,
        "balance error {worst:e} J against the peak kinetic energy {peak:e} J"
    );
}

/// A step above the critical step is refused before the first step, naming the mesh and
/// the element that sets the limit.
#[test]
fn a_step_above_the_critical_step_is_refused_with_the_element() {
    let scene = load_text(&bar(50, "fix root"));
    let h = step_of(&scene) / 0.9;
    let tr = simulate(&scene, method("staggered"), 1.01 * h, 1e-4, 1);
    let f = tr.report.failure.expect("refused");
    assert!(
        f.cause.contains("mesh 'bar'")
            && f.cause.contains("element")
            && f.cause.contains("central-difference limit"),
        "{}",
        f.cause
    );
    assert_eq!(tr.report.steps, 0);
}

/// An inverted element is refused at the start with its index, nodes and place.
#[test]
fn an_inverted_element_is_refused_with_its_place() {
    let mut scene = load_text(
        r#"
model flipped {
  material alu { E 70 GPa; nu 0.33; rho 2700 kg/m^3 }
  mesh plate {
    element quad4
    thickness 5 mm
    generate rect(origin: (0, 0) m, size: (1, 1) m, divisions: (2, 2))
    material alu
    set left = nodes(x == 0)
    fix left
  }
  simulate { duration 1 ms; step 1 us }
}
"#,
    );
    // Element 3 with its nodes clockwise: turned inside out.
    scene.meshes[0].elements[3].reverse();
    let err = Interp::new(&scene).err().expect("refused").to_string();
    assert!(
        err.contains("mesh 'plate'") && err.contains("element 3") && err.contains("centroid"),
        "{err}"
    );
}

/// Check 8: the results are bitwise the same for 1, 2 and 4 threads (node-centric gather in
/// a fixed order), on a mesh large enough for the parallel element loop.
#[test]
fn results_are_bitwise_identical_for_any_thread_count() {
    let scene = load_text(
        r#"
model threads {
  material steel { E 200 GPa; nu 0.3; rho 8000 kg/m^3 }
  mesh block {
    element hex8
    generate box(origin: (0, 0, 0) m, size: (0.4, 0.2, 0.2) m, divisions: (24, 12, 12))
    material steel
    set bottom = nodes(z == 0)
    set top = nodes(z == 0.2 m)
    fix bottom
    traction top, (1 MPa * step(t), 0, -2 MPa * step(t))
  }
  simulate { duration 1 ms; step 1 us }
}
"#,
    );
    let h = step_of(&scene);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| simulate(&scene, method("staggered"), h, 20.0 * h, 20))
    };
    let one = run(1);
    assert!(one.report.finished, "{:?}", one.report.failure);
    assert!(one.last().mesh.u.iter().any(|u| u[0] != 0.0));
    for n in [2, 4] {
        let other = run(n);
        assert_eq!(one.last().mesh.u, other.last().mesh.u, "{n} threads");
        assert_eq!(
            one.last().mesh.stress,
            other.last().mesh.stress,
            "{n} threads"
        );
    }
}
