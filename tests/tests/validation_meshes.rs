//! Validation of the finite-element meshes (issue 15, checks 2, 3, 4, 5 and 8 here, and the
//! finite rotation of check 1 through the language; the element patch tests are the
//! kernels' unit tests) against closed forms. Every test states its
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
    // The balance's constant is not 0: the load acts at t = 0, so the half-step term
    // −(h²/8) Σ m |a|² of the first frame is not (it is what the method conserves).
    let e0 = e(&tr.frames[0]);
    let worst = tr
        .frames
        .iter()
        .skip(1)
        .map(|r| (e(r) - e0).abs())
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
    let err = Interp::new(&scene).expect_err("refused").to_string();
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
    let [(_, one), others @ ..] =
        simulate_on_1_2_4_threads(&scene, method("staggered"), h, 20.0 * h, 20);
    assert!(one.report.finished, "{:?}", one.report.failure);
    assert!(one.last().mesh.u.iter().any(|u| u[0] != 0.0));
    for (n, other) in &others {
        assert_eq!(one.last().mesh.u, other.last().mesh.u, "{n} threads");
        assert_eq!(
            one.last().mesh.stress,
            other.last().mesh.stress,
            "{n} threads"
        );
    }
}

/// A mesh made irregular: every node moved by up to 6 % of the 1 cm cell in each
/// direction, and nodes and elements renumbered out of order (a fixed scramble inside
/// windows of 64, as a mesher's numbering is locally unordered), its sets and faces
/// renumbered with them.
fn scramble(m: &mut mbdc_runtime::scene::Mesh) {
    let hash = |i: usize, k: usize| {
        let x = (i as u64 * 3 + k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 11;
        2.0 * (x as f64 / (1u64 << 53) as f64) - 1.0
    };
    for (i, x) in m.nodes.iter_mut().enumerate() {
        for (k, xk) in x.iter_mut().enumerate() {
            *xk += 0.0006 * hash(i, k);
        }
    }
    // new index of old index i
    let window = |n: usize| {
        move |i: usize| {
            let w = i / 64 * 64;
            if w + 64 <= n {
                w + (i % 64 * 29 + 7) % 64
            } else {
                i
            }
        }
    };
    let (nn, ne) = (m.nodes.len(), m.elements.len());
    let (node, element) = (window(nn), window(ne));
    let mut nodes = vec![[0.0; 3]; nn];
    for (i, x) in m.nodes.iter().enumerate() {
        nodes[node(i)] = *x;
    }
    let mut elements = vec![Vec::new(); ne];
    for (e, el) in m.elements.iter().enumerate() {
        elements[element(e)] = el.iter().map(|&n| node(n)).collect();
    }
    m.nodes = nodes;
    m.elements = elements;
    for s in &mut m.node_sets {
        for n in &mut s.nodes {
            *n = node(*n);
        }
        s.nodes.sort_unstable();
        for f in &mut s.faces {
            f.0 = element(f.0);
        }
    }
}

/// The bits of every number of a mesh state (so that −0 ≠ 0 and NaN = NaN in comparisons).
fn state_bits(s: &mbdc_runtime::integrators::MeshState) -> Vec<u64> {
    let e = &s.energy;
    s.u.iter()
        .chain(&s.v)
        .flatten()
        .chain(s.stress.iter().chain(&s.strain).flatten())
        .chain(&[
            e.kinetic,
            e.strain,
            e.hourglass,
            e.external_work,
            e.dissipated,
        ])
        .map(|x| x.to_bits())
        .collect()
}

/// Check 8, the assembly strategies (notes D §6.3): the node-centric gather, colouring and
/// per-thread partitions with an interface sum give bitwise the same displacements,
/// velocities, stresses, strains and energies, and each gives them for 1, 2 and 4 threads —
/// on distorted tet4 and hex8 one-point (viscous hourglass) meshes numbered out of order,
/// with more elements than the parallel threshold (2048), several partitions and colours,
/// a fixed face and a traction, from a rough initial displacement and velocity field, with
/// element colouring (groups of 1) and with groups of 32.
#[test]
fn assembly_strategies_agree_bitwise_for_any_thread_count() {
    use mbdc_runtime::integrators::mesh_dynamics::MeshDynamics;
    use mbdc_runtime::integrators::MeshState;
    use mbdc_runtime::mesh_plan::{Assembly, AssemblyOptions};
    use std::sync::Arc;

    let cases = [
        ("tet4", "", (10, 8, 6)),
        (
            "hex8",
            "integration reduced\n    hourglass viscous(0.1)",
            (16, 12, 12),
        ),
    ];
    for (kind, formulation, (nx, ny, nz)) in cases {
        let scene = load_text(&format!(
            r#"
model strategies {{
  material steel {{ E 200 GPa; nu 0.3; rho 8000 kg/m^3 }}
  mesh block {{
    element {kind}
    {formulation}
    generate box(origin: (0, 0, 0) m, size: ({}, {}, {}) m, divisions: ({nx}, {ny}, {nz}))
    material steel
    set bottom = nodes(z == 0)
    set top = nodes(z == {} m)
    fix bottom
    traction top, (1 MPa * step(t), 0, -2 MPa * step(t))
  }}
  simulate {{ duration 1 ms; step 1 us }}
}}
"#,
            nx as f64 * 0.01,
            ny as f64 * 0.01,
            nz as f64 * 0.01,
            nz as f64 * 0.01,
        ));
        let mut meshes = scene.meshes.clone();
        scramble(&mut meshes[0]);
        for (group, partition_elements) in [(1, 300), (32, 500)] {
            let options = |strategy| AssemblyOptions {
                strategy,
                colour_group: group,
                partition_elements,
                max_interface: 1.0,
                ..AssemblyOptions::default()
            };
            let l = mesh_model::build_with(&meshes, options(Assembly::Gather)).expect("valid");
            let h = 0.9 * mesh_model::critical_step(&l).expect("elements").step;
            let mut start = MeshState::default();
            for (n, x) in l.x0.iter().enumerate() {
                let s = (370.0 * x[0] + 110.0 * x[1] + 50.0 * x[2] + n as f64).sin();
                let c = (130.0 * x[0] - 70.0 * x[1] + 170.0 * x[2]).cos();
                start.u.push([1e-7 * s, 1e-7 * c, 1e-7 * s * c]);
                start.v.push([1e-3 * c, 1e-3 * s, -1e-3 * s]);
            }
            let mut reference: Option<Vec<u64>> = None;
            for strategy in Assembly::ALL {
                let l =
                    Arc::new(mesh_model::build_with(&meshes, options(strategy)).expect("valid"));
                let p = &l.assembly.blocks[0];
                assert!(l.elements() > 2048, "{kind}: above the parallel threshold");
                assert!(p.partitions() >= 4 && p.colours >= 4, "{kind}: {p:?}");
                assert!(!l.assembly.interface_nodes.is_empty());
                for threads in [1, 2, 4] {
                    let st = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .expect("pool")
                        .install(|| {
                            let mut md =
                                MeshDynamics::new(l.clone(), h, 0.0, &start).expect("starts");
                            for _ in 0..12 {
                                md.step().expect("steps");
                            }
                            let mut st = MeshState::default();
                            md.state(&mut st);
                            st
                        });
                    assert!(st.energy.strain > 0.0 && st.energy.external_work != 0.0);
                    let bits = state_bits(&st);
                    match &reference {
                        None => reference = Some(bits),
                        Some(r) => assert!(
                            *r == bits,
                            "{kind}, groups of {group}: {} with {threads} threads departs from the gather with 1 thread",
                            strategy.name()
                        ),
                    }
                }
            }
        }
    }
}

/// Euler–Bernoulli first bending frequency of a cantilever, `f₁ = (1.8751²/(2π L²)) √(EI/(ρA))`,
/// for a rectangular section of depth `h` (`I/A = h²/12`), in Hz.
fn cantilever_f1(e: f64, rho: f64, l: f64, h: f64) -> f64 {
    let beta = 1.875_104_068_711_961_f64;
    beta * beta / (2.0 * std::f64::consts::PI * l * l) * (e / rho * h * h / 12.0).sqrt()
}

/// The period of `f` from its zero crossings (both directions) after `t0`: twice the mean
/// spacing of the crossings, each located by linear interpolation between frames. Also
/// returns how many periods the crossings span.
fn period_from_crossings(tr: &Trajectory, t0: f64, f: impl Fn(&Rec) -> f64) -> (f64, f64) {
    let mut times = Vec::new();
    let frames: Vec<&Rec> = tr.frames.iter().filter(|r| r.t >= t0).collect();
    for w in frames.windows(2) {
        let (a, b) = (f(w[0]), f(w[1]));
        if (a < 0.0 && b >= 0.0) || (a > 0.0 && b <= 0.0) {
            times.push(w[0].t + (w[1].t - w[0].t) * a / (a - b));
        }
    }
    assert!(times.len() >= 4, "only {} zero crossings", times.len());
    let span = times[times.len() - 1] - times[0];
    let half = span / (times.len() - 1) as f64;
    (2.0 * half, (times.len() - 1) as f64 / 2.0)
}

/// The cantilever of check 3: clamped at x = 0, `L` = 1 m, depth `h` = 5 cm (L/h = 20),
/// steel (E = 200 GPa, ν = 0.3, ρ = 8000 kg/m³): `f₁` = 40.39 Hz, `T₁` = 24.76 ms. A
/// tip load pulse `F (smoothstep(t, 0, τ) − smoothstep(t, τ, 2τ))` with `τ = T₁/4` (smooth
/// against the second mode, `T₂ = T₁/6.27`) sets the first mode swinging; the period is
/// measured from the zero crossings of the tip's mean transverse displacement over the
/// free vibration that follows (≥ 2 periods).
///
/// Beam theory's own error here: shear deformation and rotary inertia (Timoshenko) lower
/// the first frequency of a cantilever by about `(1.875 r/L)² (1 + E/(κG))/4 ≈ 0.1 %` at
/// L/h = 20 (`r = h/√12`), well under the tolerances.
const CANTILEVER_E: f64 = 200e9;
const CANTILEVER_RHO: f64 = 8000.0;
const CANTILEVER_L: f64 = 1.0;
const CANTILEVER_H: f64 = 0.05;

/// Run a cantilever scene (its mesh text between `mesh beam {` and its sets) for 2τ + 2.3 T₁
/// and return the measured first period, the reference period and the run.
fn cantilever_period(mesh: &str, nu: f64, tip_component: usize) -> (f64, f64, Trajectory) {
    let f1 = cantilever_f1(CANTILEVER_E, CANTILEVER_RHO, CANTILEVER_L, CANTILEVER_H);
    let t1 = 1.0 / f1;
    let tau = t1 / 4.0;
    let load = if tip_component == 1 {
        "(0, -1 N * pulse, 0)"
    } else {
        "(0, 0, -1 N * pulse)"
    };
    let scene = load_text(&format!(
        r#"
model cantilever_mode {{
  material steel {{ E 200 GPa; nu {nu}; rho 8000 kg/m^3 }}
  const pulse = smoothstep(t, 0 s, {tau} s) - smoothstep(t, {tau} s, {t2} s)
  mesh beam {{
    {mesh}
    material steel
    set root = nodes(x == 0)
    set tip = nodes(x == 1 m)
    fix root
    load tip, {load}
  }}
  simulate {{ duration 1 s; step 1 us }}
}}
"#,
        t2 = 2.0 * tau
    ));
    let h = step_of(&scene);
    let steps_per_frame = 50;
    let tr = simulate(
        &scene,
        method("staggered"),
        h,
        2.0 * tau + 2.3 * t1,
        steps_per_frame,
    );
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let tip: Vec<usize> = scene.meshes[0]
        .nodes
        .iter()
        .enumerate()
        .filter(|(_, p)| (p[0] - CANTILEVER_L).abs() < 1e-9)
        .map(|(i, _)| i)
        .collect();
    let w = |r: &Rec| {
        tip.iter()
            .map(|&n| r.mesh.u.get(n).map_or(0.0, |u| u[tip_component]))
            .sum::<f64>()
            / tip.len() as f64
    };
    let (period, spanned) = period_from_crossings(&tr, 2.0 * tau, w);
    assert!(spanned >= 1.5, "the crossings span {spanned} periods");
    eprintln!(
        "f₁ = {:.4} Hz against {:.4} Hz ({:+.3} %), {} steps of {h:e} s",
        1.0 / period,
        f1,
        100.0 * (t1 / period - 1.0),
        tr.report.steps
    );
    (period, t1, tr)
}

/// Check 3 (quad4, fully integrated, plane stress): 80 × 4 elements (12.5 mm squares).
/// Reference: Euler–Bernoulli `f₁` for a plane-stress plate (`I = t h³/12`, `A = t h`).
/// Tolerance 2 % (the issue's). The fully integrated quad4 shear-locks in bending: its
/// parasitic shear stiffens the bending by up to `(G/E)(a/h)²` = 2.4 % for elements
/// a = 12.5 mm long in a 5 cm depth (the frequency by half that), whatever the number of
/// elements through the depth (B-bar does not help: the parasitic strain is a shear);
/// 4 through the depth relax the Poisson (anticlastic) strain. Measured +1.39 % (with
/// 100 × 4, +0.96 %).
#[test]
fn quad4_cantilever_first_bending_frequency() {
    let (period, t1, _) = cantilever_period(
        "element quad4, plane_stress
    thickness 1 cm
    generate rect(origin: (0, 0) m, size: (1, 0.05) m, divisions: (80, 4))",
        0.3,
        1,
    );
    let err = t1 / period - 1.0;
    assert!(
        err.abs() < 0.02,
        "quad4 f₁ = {} Hz against {} Hz: {:+.3} %",
        1.0 / period,
        1.0 / t1,
        100.0 * err
    );
}

/// Check 3 (hex8, fully integrated 2×2×2): a square 5 cm section, 100 × 1 × 2 elements
/// (10 × 50 × 25 mm), bending in z, ν = 0 (the 3-D section then has no Poisson coupling
/// and bends exactly as the beam; with ν = 0.3 the anticlastic strains need ≥ 4 elements
/// through the depth and a narrower width to stay under 1 %). Reference: Euler–Bernoulli
/// `f₁`; tolerance 2 % (the issue's). Shear locking stiffens the bending by up to
/// `(G/E)(a/h)²` = 2 % here (the frequency by half that). Measured +0.83 %.
#[test]
fn hex8_cantilever_first_bending_frequency() {
    let (period, t1, _) = cantilever_period(
        "element hex8
    generate box(origin: (0, 0, 0) m, size: (1, 0.05, 0.05) m, divisions: (100, 1, 2))",
        0.0,
        2,
    );
    let err = t1 / period - 1.0;
    assert!(
        err.abs() < 0.02,
        "hex8 f₁ = {} Hz against {} Hz: {:+.3} %",
        1.0 / period,
        1.0 / t1,
        100.0 * err
    );
}

/// Check 3 (hex8, one point with viscous hourglass control, κ = 0.1): 50 × 1 × 4 elements
/// (20 × 50 × 12.5 mm), ν = 0. Reference: Euler–Bernoulli `f₁`; tolerance 5 % (the
/// issue's). One-point elements see the mean strain only: n layers through the depth carry
/// `1 − 1/n²` of the bending stiffness (−3.2 % in frequency for n = 4), viscous control
/// adds none. Hourglass check (the issue's 10 %): the viscous form stores no energy, so the
/// measure is the energy it dissipates over the run against the peak strain energy.
/// Measured: −3.33 % (−3.2 % predicted), dissipation 0.1 % of the peak strain energy.
#[test]
fn hex8_one_point_cantilever_first_bending_frequency() {
    let (period, t1, tr) = cantilever_period(
        "element hex8
    integration reduced
    hourglass viscous(0.1)
    generate box(origin: (0, 0, 0) m, size: (1, 0.05, 0.05) m, divisions: (50, 1, 4))",
        0.0,
        2,
    );
    let err = t1 / period - 1.0;
    let peak = tr
        .frames
        .iter()
        .map(|r| r.mesh.energy.strain)
        .fold(0.0, f64::max);
    let dissipated = tr.last().mesh.energy.dissipated;
    eprintln!("dissipated {dissipated:e} J, peak strain energy {peak:e} J");
    assert!(
        err.abs() < 0.05,
        "one-point hex8 f₁ = {} Hz against {} Hz: {:+.3} %",
        1.0 / period,
        1.0 / t1,
        100.0 * err
    );
    assert!(peak > 0.0 && dissipated >= 0.0);
    assert!(
        dissipated < 0.1 * peak,
        "hourglass dissipation {dissipated:e} J against the peak strain energy {peak:e} J"
    );
}

/// Check 3 (hex8, one point with stiffness hourglass control, κ = 0.05): as above; the
/// hourglass check is the largest hourglass energy over the run against the largest strain
/// energy, under 10 % (the issue's bound). Measured −0.71 %, hourglass energy 5.5 % (it
/// grows as κ (a/h)²: 9.9 % with 50 elements along the length, so 80 here).
#[test]
fn hex8_one_point_stiffness_hourglass_cantilever() {
    let (period, t1, tr) = cantilever_period(
        "element hex8
    integration reduced
    hourglass stiffness(0.05)
    generate box(origin: (0, 0, 0) m, size: (1, 0.05, 0.05) m, divisions: (80, 1, 4))",
        0.0,
        2,
    );
    let err = t1 / period - 1.0;
    let max = |f: fn(&Rec) -> f64| tr.frames.iter().map(f).fold(0.0, f64::max);
    let (hg, strain) = (
        max(|r| r.mesh.energy.hourglass),
        max(|r| r.mesh.energy.strain),
    );
    eprintln!("peak hourglass energy {hg:e} J, peak strain energy {strain:e} J");
    assert!(
        err.abs() < 0.05,
        "one-point hex8 f₁ = {} Hz against {} Hz: {:+.3} %",
        1.0 / period,
        1.0 / t1,
        100.0 * err
    );
    assert!(strain > 0.0 && hg > 0.0);
    assert!(
        hg < 0.1 * strain,
        "hourglass energy {hg:e} J against the strain energy {strain:e} J"
    );
}

/// A quad4 plate 0.1 m × 0.05 m (one element) turned rigidly by θ(t) = 90° · smoothstep(t,
/// 0, 1 ms) about the origin, every node prescribed by `displace` with
/// `u = X(cos θ − 1) − Y sin θ`, `v = X sin θ + Y(cos θ − 1)` (displace components are
/// functions of t only, so each corner node is its own set). Reference: with `strain green`
/// (Green–Lagrange, St Venant–Kirchhoff) a rigid rotation strains nothing — the stress is
/// zero to round-off (bound 1e-14 E = 7e-4 Pa: some 50 ulps of `FᵀF − I`, times E).
/// With `strain small` the same motion gives the spurious `ε = sym(R − I)`: at 90° the
/// equibiaxial `ε_xx = ε_yy = −1`, so the plane-stress `σ_xx = σ_yy = −E/(1 − ν)` (to 1e-9).
#[test]
fn green_strain_is_free_of_stress_under_a_large_rigid_rotation() {
    let scene = |strain: &str| {
        let mut corners = String::new();
        for (k, (x, y)) in [(0.0, 0.0), (0.1, 0.0), (0.1, 0.05), (0.0, 0.05)]
            .iter()
            .enumerate()
        {
            corners.push_str(&format!(
                "set c{k} = nodes(x == {x} m and y == {y} m)\n    \
                 displace c{k}, ({x} m * (cos(th) - 1) - {y} m * sin(th), \
                 {x} m * sin(th) + {y} m * (cos(th) - 1))\n    "
            ));
        }
        load_text(&format!(
            r#"
model spin {{
  material alu {{ E 70 GPa; nu 0.33; rho 2700 kg/m^3 }}
  const th = pi / 2 * smoothstep(t, 0 s, 1 ms)
  mesh plate {{
    element quad4, plane_stress
    strain {strain}
    thickness 5 mm
    generate rect(origin: (0, 0) m, size: (0.1, 0.05) m, divisions: (1, 1))
    material alu
    {corners}
  }}
  simulate {{ duration 1 ms; step 1 us }}
}}
"#
        ))
    };
    let (e, nu) = (70e9, 0.33);
    for strain in ["green", "small"] {
        let sc = scene(strain);
        let h = step_of(&sc);
        let steps = (1.2e-3 / h).ceil();
        let tr = simulate(&sc, method("staggered"), h, steps * h, 1);
        assert!(tr.report.finished, "{:?}", tr.report.failure);
        let last = tr.last();
        assert!(last.t > 1e-3);
        // The plate has turned by 90°: node 1 (0.1, 0) is at (0, 0.1).
        let u1 = last.mesh.u[1];
        assert!(
            (u1[0] + 0.1).abs() < 1e-12 && (u1[1] - 0.1).abs() < 1e-12,
            "{u1:?}"
        );
        let s = last.mesh.stress[0];
        if strain == "green" {
            let worst = tr
                .frames
                .iter()
                .filter_map(|r| r.mesh.stress.first())
                .flat_map(|s| s.iter())
                .fold(0.0f64, |m, x| m.max(x.abs()));
            assert!(
                worst < 1e-14 * e,
                "green: stress {worst:e} Pa under a rigid rotation"
            );
            assert!(last.mesh.energy.strain.abs() < 1e-20);
        } else {
            let expected = -e / (1.0 - nu);
            for k in 0..2 {
                assert!(
                    (s[k] / expected - 1.0).abs() < 1e-9,
                    "small strain at 90°: σ = {s:?}, expected {expected:e} Pa on xx and yy"
                );
            }
        }
    }
}

/// Shear locking is not volumetric locking: on a coarse quad4 cantilever in plane strain
/// (20 × 2 elements, a/h = 1, otherwise as check 3) full integration overestimates `f₁`
/// badly — the parasitic shear bound `(G/E)(a/h)²` is 38 % of the bending stiffness — and
/// `integration bbar`, which only averages the volumetric strain, leaves it large (it
/// relieves the Poisson coupling of plane strain, not the parasitic shear). (In plane
/// stress `bbar` changes nothing: plane stress cannot lock volumetrically, and the kernel
/// ignores it there.) Reference: Euler–Bernoulli `f₁` with the plane-strain modulus
/// `E/(1 − ν²)`. Checked: full above +15 %, bbar above +5 % — both far from the 2 % of a
/// fine mesh (check 3). Measured: full +18.6 %, bbar +10.2 %.
#[test]
fn bbar_does_not_cure_shear_locking_in_bending() {
    let err = |integration: &str| {
        let (period, t1, _) = cantilever_period(
            &format!(
                "element quad4, plane_strain
    thickness 1 cm
    integration {integration}
    generate rect(origin: (0, 0) m, size: (1, 0.05) m, divisions: (20, 2))"
            ),
            0.3,
            1,
        );
        let t1_plane_strain = t1 * (1.0f64 - 0.3 * 0.3).sqrt();
        t1_plane_strain / period - 1.0
    };
    let (full, bbar) = (err("full"), err("bbar"));
    eprintln!(
        "20 × 2 quad4, plane strain: full {:+.2} %, bbar {:+.2} %",
        100.0 * full,
        100.0 * bbar
    );
    assert!(full > 0.15 && bbar > 0.05, "full {full:+e}, bbar {bbar:+e}");
}

/// The strip on an elastic foundation of check 4 (the papers' example E4, a bar on a foam
/// layer, notes D §1.9): a steel strip in plane stress, `L` = 0.5 m, depth `h` = 5 cm,
/// 1 cm thick, 40 × 4 quad4 elements (12.5 mm squares), with guided ends (`u_x = 0`, free
/// across: the mirror planes of a periodic strip, so every `cos(nπx/L)` bending wave is an
/// exact mode shape), resting on a Winkler foundation of modulus `K` on its bottom face. A
/// load pulse `F cos(kx) (smoothstep(t, 0, τ) − smoothstep(t, τ, 2τ))` with `k = nπ/L` and
/// `τ = T/4` sets the n-th wave standing; its period is measured from the zero crossings
/// of the mass-weighted projection of the transverse displacement on `cos(kx)` (exact modal
/// filtering: the other harmonics are orthogonal to it under the lumped mass). Returns the
/// measured and the Timoshenko angular frequencies.
///
/// Reference: the dispersion of a Timoshenko beam on a Winkler foundation
/// (`w = W cos kx`, `ψ = Ψ sin kx`):
/// `(κGA k² + K b − ρAω²)(EI k² + κGA − ρIω²) = (κGA k)²`, the smaller root in ω², with
/// `b` the contact width, `A = b h`, `I = b h³/12`, `κ = 5/6` and plane-stress `E`; it
/// tends to `ω² = ω₀² + EI k⁴/(ρA)`, `ω₀² = K/(ρh)`, for slender waves.
fn foundation_wave(n: usize, modulus: f64) -> (f64, f64) {
    let (e, nu, rho, l, h, b) = (200e9_f64, 0.3_f64, 8000.0_f64, 0.5_f64, 0.05_f64, 0.01_f64);
    let k = n as f64 * std::f64::consts::PI / l;
    let (area, inertia) = (b * h, b * h.powi(3) / 12.0);
    let kga = 5.0 / 6.0 * e / (2.0 * (1.0 + nu)) * area;
    let (c0, c1, c2) = (
        (kga * k * k + modulus * b) * (e * inertia * k * k + kga) - (kga * k).powi(2),
        -(rho * area * (e * inertia * k * k + kga) + rho * inertia * (kga * k * k + modulus * b)),
        rho * area * rho * inertia,
    );
    let w2 = (-c1 - (c1 * c1 - 4.0 * c2 * c0).sqrt()) / (2.0 * c2);
    let omega = w2.sqrt();
    let tau = std::f64::consts::PI / (2.0 * omega);
    let columns = 40;
    let mut loads = String::new();
    for i in 0..=columns {
        let x = l * i as f64 / columns as f64;
        loads += &format!(
            "set c{i} = nodes(x == {x} m)\n    load c{i}, (0, {:e} N * pulse)\n    ",
            (k * x).cos()
        );
    }
    let foundation = if modulus > 0.0 {
        format!("foundation bottom, {modulus:e} N/m^3")
    } else {
        String::new()
    };
    let scene = load_text(&format!(
        r#"
model strip_on_foundation {{
  material steel {{ E 200 GPa; nu {nu}; rho 8000 kg/m^3 }}
  const pulse = smoothstep(t, 0 s, {tau} s) - smoothstep(t, {tau} s, {t2} s)
  mesh strip {{
    element quad4, plane_stress
    thickness 1 cm
    generate rect(origin: (0, 0) m, size: ({l}, 0.05) m, divisions: ({columns}, 4))
    material steel
    set left = nodes(x == 0)
    set right = nodes(x == {l} m)
    set bottom = nodes(y == 0)
    displace left, (0, free)
    displace right, (0, free)
    {foundation}
    {loads}
  }}
  simulate {{ duration 1 s; step 1 us }}
}}
"#,
        t2 = 2.0 * tau
    ));
    let hstep = step_of(&scene);
    let period = 2.0 * std::f64::consts::PI / omega;
    let tr = simulate(
        &scene,
        method("staggered"),
        hstep,
        2.0 * tau + 3.3 * period,
        10,
    );
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    // Lumped masses of a uniform grid: half at the end columns and the top and bottom rows.
    let weights: Vec<f64> = scene.meshes[0]
        .nodes
        .iter()
        .map(|p| {
            let edge = |s: f64, len: f64| {
                if s.abs() < 1e-9 || (s - len).abs() < 1e-9 {
                    0.5
                } else {
                    1.0
                }
            };
            edge(p[0], l) * edge(p[1], h) * (k * p[0]).cos()
        })
        .collect();
    let q = |r: &Rec| {
        weights
            .iter()
            .zip(&r.mesh.u)
            .map(|(w, u)| w * u[1])
            .sum::<f64>()
    };
    let (measured, spanned) = period_from_crossings(&tr, 2.0 * tau, q);
    assert!(spanned >= 2.5, "the crossings span {spanned} periods");
    let measured = 2.0 * std::f64::consts::PI / measured;
    eprintln!(
        "n = {n}, K = {modulus:e} N/m³: ω = {measured:.2} rad/s against {omega:.2} rad/s \
         ({:+.3} %), {} steps of {hstep:e} s",
        100.0 * (measured / omega - 1.0),
        tr.report.steps
    );
    (measured, omega)
}

/// Check 4 (the papers' elastic foundation, notes D §1.9 E4): the dispersion of bending
/// waves in a strip on a Winkler foundation. `K` = 3.6·10⁹ N/m³ gives the strip a bounce
/// frequency `ω₀ = √(K/(ρh))` = 3000 rad/s, of the order of the first bending wave's
/// 2800 rad/s, so both terms of the dispersion weigh. Two references, two tolerances:
/// - Timoshenko's dispersion (above) for the waves n = 1 and 2 on the foundation and n = 1
///   without, within 2 % — the fully integrated quad4's shear locking stiffens the bending
///   part by up to `(G/E)(a/h)²` = 2.4 % (12.5 mm elements, check 3), which moves ω by less
///   than half that.
/// - The foundation's share alone, `ω²(K) − ω²(0)`, against the same mesh without
///   foundation (an independent run, so the locking and the lattice's dispersion cancel),
///   within 0.5 %. Reference: Timoshenko's own share `ω_T²(K) − ω_T²(0)` (0.78 % below
///   `ω₀²`: the rotary inertia couples in), times the Poisson breathing of the depth that
///   beam theory leaves out — plane-stress bending `ε_yy = −ν ε_xx` bows the transverse
///   displacement through the depth, so the springs on the bottom face see
///   `w_b²/⟨w²⟩ = 1 − ν k² h²/6` (another −0.49 %). The difference of two squares
///   amplifies the ~0.05 % with which the crossings of 3 periods resolve each ω about 5.6
///   times.
///
/// Measured: ω +0.57 % (n = 1 on the foundation), +1.55 % (n = 1 without), +1.48 %
/// (n = 2 on the foundation) against Timoshenko; the share −1.35 % from `ω₀²` against
/// the reference's −1.27 %.
#[test]
fn bending_waves_on_an_elastic_foundation_follow_the_dispersion_relation() {
    let modulus = 3.6e9;
    let omega0_sq = modulus / (8000.0 * 0.05);
    let (with, reference) = foundation_wave(1, modulus);
    let (without, bare) = foundation_wave(1, 0.0);
    let (second, reference2) = foundation_wave(2, modulus);
    for (n, measured, theory) in [
        (1, with, reference),
        (1, without, bare),
        (2, second, reference2),
    ] {
        assert!(
            (measured / theory - 1.0).abs() < 0.02,
            "n = {n}: ω = {measured} rad/s against Timoshenko's {theory} rad/s"
        );
    }
    let share = with * with - without * without;
    let k = std::f64::consts::PI / 0.5;
    let expected = (reference * reference - bare * bare) * (1.0 - 0.3 * (k * 0.05).powi(2) / 6.0);
    eprintln!(
        "the foundation's share of ω²: {:+.3} % from ω₀², the reference {:+.3} %",
        100.0 * (share / omega0_sq - 1.0),
        100.0 * (expected / omega0_sq - 1.0)
    );
    assert!(
        (share / expected - 1.0).abs() < 0.005,
        "the foundation adds {share} (rad/s)² to ω², not {expected} (ω₀² = {omega0_sq})"
    );
}

/// A steel block of 4 × 4 × 2 hex8 elements (5 cm cubes) on a very stiff foundation
/// (`K` = 10¹⁴ N/m³ under its bottom face): the springs' `√(k/m)` at a bottom node is
/// 2.24× the stiffest element's frequency, so the elements alone would allow a step the
/// foundation makes unstable.
fn stiff_foundation_block(foundation: bool) -> mbdc_runtime::scene::Scene {
    load_text(&format!(
        r#"
model block_on_foundation {{
  material steel {{ E 200 GPa; nu 0.3; rho 8000 kg/m^3 }}
  mesh block {{
    element hex8
    generate box(origin: (0, 0, 0) m, size: (0.2, 0.2, 0.1) m, divisions: (4, 4, 2))
    material steel
    set bottom = nodes(z == 0)
    set top = nodes(z == 0.1 m)
    {}
    load top, (0, 0, -10 kN * smoothstep(t, 0 s, 200 us))
  }}
  simulate {{ duration 1 ms; step 1 us }}
}}
"#,
        if foundation {
            "foundation bottom, 1e14 N/m^3"
        } else {
            ""
        }
    ))
}

/// The critical step counts the foundation (bad input: a step above the critical step).
/// Reference: the bound `ω_max² ≤ max_e ω_e² + max_n Σk_n/m_n` on the lumped system.
/// (1) The limit with the foundation is below the elements' alone, by the node's `√(k/m)`
/// exactly as the bound composes; (2) a step between the two limits is refused, naming the
/// foundation's node; (3) at 0.9 of the new limit the loaded block runs 2000 steps with the
/// energy balance (work of the time-dependent load included) within 1e-3 of the energy in
/// play.
#[test]
fn a_stiff_foundation_lowers_the_critical_step_and_is_named() {
    let with = stiff_foundation_block(true);
    let without = stiff_foundation_block(false);
    let limit = |s: &mbdc_runtime::scene::Scene| {
        let sys = Interp::new(s).expect("interpretable");
        mesh_model::critical_step(&sys.layout().meshes).expect("elements")
    };
    let (lw, lo) = (limit(&with), limit(&without));
    eprintln!(
        "limits: elements {:e} s, with the foundation {:e} s",
        lo.step, lw.step
    );
    assert!(
        lw.place.contains("foundation springs of node"),
        "{}",
        lw.place
    );
    let wf = lw.place.rsplit("√(k/m) = ").next().unwrap();
    let wf: f64 = wf.trim_end_matches(" rad/s)").parse().expect("a frequency");
    let expected = (lo.omega * lo.omega + wf * wf).sqrt();
    assert!(
        (lw.omega / expected - 1.0).abs() < 1e-4,
        "ω = {} against √(ω_e² + k/m) = {expected}",
        lw.omega
    );
    assert!(lw.step < 0.5 * lo.step, "{} vs {}", lw.step, lo.step);
    // A step the elements allow but the foundation does not.
    let h = 0.9 * lo.step;
    let sys = Interp::new(&with).expect("interpretable");
    let refused = match mbdc_runtime::integrators::make(
        &method("staggered"),
        &sys,
        h,
        &mbdc_runtime::integrators::State::initial(&sys),
    ) {
        Err(e) => e.to_string(),
        Ok(_) => panic!(
            "a step of {h:e} s above the limit {:e} s was accepted",
            lw.step
        ),
    };
    assert!(refused.contains("foundation springs of node"), "{refused}");
    // At 0.9 of the limit: stable, and the balance holds with the load's work counted.
    let h = 0.9 * lw.step;
    let tr = simulate(&with, method("staggered"), h, 2000.0 * h, 100);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    assert!(
        tr.report.max_energy_drift < 1e-3,
        "energy drift {}",
        tr.report.max_energy_drift
    );
}
