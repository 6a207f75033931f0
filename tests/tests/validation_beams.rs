//! Validation of the flexible beams (issue 14, checks 2–8) against closed forms and
//! published references. Every test states its reference and its tolerance.
//!
//! The scenes are written in the language; their sections are given directly (a `section`
//! block) with the rotary inertia scaled where that only moves the shear/rotary-inertia
//! mode, so that the explicit step stays large and the tests fast.

use mbdc_runtime::integrators::staggered::RELAXATION_TOLERANCE;
use mbdc_runtime::scene::{MethodSpec, Relaxation, Section, StaggeredOptions};
use mbdc_tests::*;

fn relaxed() -> MethodSpec {
    MethodSpec::Staggered(StaggeredOptions {
        relaxation: Relaxation::Kinetic,
        ..Default::default()
    })
}

/// A cantilever of length 1 m along x, clamped at the origin, with a light tip body clamped
/// to its end and a tip load `(0, 0, -P)` on it: bending stiffness `EI` (both axes), shear
/// `GA`, axial `EA`, `ρA` = 1 kg/m.
fn cantilever(elements: usize, p: f64, ei: f64, ga: f64, ea: f64) -> String {
    cantilever_with(
        elements,
        ei,
        ga,
        ea,
        10.0,
        &format!("point(tip @ (0, 0, 0), (0, 0, -{p}) N)"),
        "20 us",
    )
}

/// [`cantilever`] with any load on the tip body, a rotary-inertia scale and a step.
fn cantilever_with(
    elements: usize,
    ei: f64,
    ga: f64,
    ea: f64,
    scale: f64,
    load: &str,
    step: &str,
) -> String {
    format!(
        r#"
model cantilever_test {{
  beam blade {{
    from (0, 0, 0) m
    to (1, 0, 0) m
    elements {elements}
    up (0, 0, 1)
    section {{ EA {ea} N; GA2 {ga} N; GA3 {ga} N; EI2 {ei} N*m^2; EI3 {ei} N*m^2; GJ {ei} N*m^2; rhoA 1 kg/m; rhoI 2e-3 kg*m }}
    rotary_inertia_scale {scale}
    clamp start
    clamp end, tip @ (0, 0, 0)
  }}
  body tip {{
    mass 1 g
    inertia sphere(radius: 1 cm)
    position (1, 0, 0) m
  }}
  force load = {load}
  simulate {{ duration 1 s; step {step} }}
}}
"#
    )
}

/// Check 2. Cantilever with a small tip load, 20 elements, statics by dynamic relaxation.
/// Reference: Timoshenko beam theory, tip deflection `δ = P L³/(3EI) + P L/(GA)` (the shear
/// term is 0.3 % of the total here), and the geometric nonlinearity at `P L²/EI = 0.01` is
/// below 1e-5 relative (the elastica's series). Tolerance 0.5 % (the issue's); the one-point
/// element with lumped loads is expected within `1/(4N²)` = 0.06 %.
#[test]
fn cantilever_small_tip_load_static_deflection() {
    let (p, ei, ga) = (1.0, 100.0, 1e5);
    let scene = load_text(&cantilever(20, p, ei, ga, 1e6));
    let tr = simulate(&scene, relaxed(), 2e-5, 0.5, 1000);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let tip = tr.last().pose[0].r;
    let exact = p / (3.0 * ei) + p / ga;
    let err = (-tip.z - exact).abs() / exact;
    eprintln!(
        "tip deflection {:.6e} m, reference {exact:.6e} m, relative error {err:.2e}",
        -tip.z
    );
    assert!(err < 1e-3, "error {err:.2e}");
    // converged, and the run says so: no warning, its out-of-balance ratio in the stats
    let residual = stat(&tr, "relaxation_residual");
    assert!(tr.report.warnings.is_empty(), "{:?}", tr.report.warnings);
    assert!(residual <= RELAXATION_TOLERANCE, "residual {residual:.2e}");
}

fn stat(tr: &Trajectory, name: &str) -> f64 {
    tr.report
        .stats
        .iter()
        .find(|s| s.0 == name)
        .unwrap_or_else(|| panic!("no stat {name}: {:?}", tr.report.stats))
        .1
}

/// Task of issue 14's relaxation: a relaxation run whose duration ends before the static
/// solution has converged must not pass silently. The cantilever of
/// [`cantilever_small_tip_load_static_deflection`] stopped at 0.06 s (3 000 steps, before
/// the first bending mode has settled) is far from its static deflection (measured 7.7 % off
/// the converged tip, with an out-of-balance ratio of 5.0·10⁻²); the run finishes but ends with a warning that names the
/// out-of-balance ratio and says to run longer, and the ratio in the stats is above the
/// tolerance. Reference: the converged relaxation (0.5 s) of the same scene.
#[test]
fn unconverged_relaxation_warns() {
    let scene = load_text(&cantilever(20, 1.0, 100.0, 1e5, 1e6));
    let short = simulate(&scene, relaxed(), 2e-5, 0.06, 1000);
    let long = simulate(&scene, relaxed(), 2e-5, 0.5, 1000);
    assert!(short.report.finished, "{:?}", short.report.failure);
    let (a, b) = (-short.last().pose[0].r.z, -long.last().pose[0].r.z);
    let err = (a - b).abs() / b;
    let residual = stat(&short, "relaxation_residual");
    eprintln!(
        "0.06 s: tip {a:.6e} m against {b:.6e} m converged ({err:.2e} off), residual {residual:.2e}; {:?}",
        short.report.warnings
    );
    assert!(
        err > 1e-2,
        "the short run is meant to be unconverged: {err:.2e}"
    );
    assert!(residual > RELAXATION_TOLERANCE, "{residual:.2e}");
    assert_eq!(
        short.report.warnings.len(),
        1,
        "{:?}",
        short.report.warnings
    );
    let w = &short.report.warnings[0];
    assert!(
        w.contains("has not converged")
            && w.contains("Run longer")
            && w.contains(&format!("{residual:.3e}")),
        "{w}"
    );
    assert!(
        long.report.warnings.is_empty(),
        "{:?}",
        long.report.warnings
    );
}

/// The inextensible, shear-rigid elastica of a cantilever under a dead tip load
/// perpendicular to it, `k = P L²/EI`: `θ'' = −k cos θ`, `θ(0) = 0`, `θ'(1) = 0` (s in units
/// of L, θ the section rotation), solved by shooting on `θ'(0)` (bisection, RK4 with 20 000
/// steps; converged to 1e-10). Returns `(w/L, u/L, θ(1))`: the deflection along the load, the
/// shortening, the tip rotation.
fn elastica(k: f64) -> (f64, f64, f64) {
    let n = 20_000;
    let h = 1.0 / n as f64;
    // integrate (θ, θ', x, z) from s = 0 with θ'(0) = a
    let run = |a: f64| -> [f64; 4] {
        let f = |y: [f64; 4]| [y[1], -k * y[0].cos(), y[0].cos(), y[0].sin()];
        let mut y = [0.0, a, 0.0, 0.0];
        for _ in 0..n {
            let add = |y: [f64; 4], d: [f64; 4], c: f64| {
                [
                    y[0] + c * d[0],
                    y[1] + c * d[1],
                    y[2] + c * d[2],
                    y[3] + c * d[3],
                ]
            };
            let k1 = f(y);
            let k2 = f(add(y, k1, h / 2.0));
            let k3 = f(add(y, k2, h / 2.0));
            let k4 = f(add(y, k3, h));
            for i in 0..4 {
                y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        y
    };
    // θ'(1) decreases with a on the first branch: θ'(1) < 0 at a = 0, > 0 at a = k
    let (mut lo, mut hi) = (0.0, k);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if run(mid)[1] > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let y = run(0.5 * (lo + hi));
    (y[3], 1.0 - y[2], y[0])
}

/// The shooting solution reproduces Mattiasson's table at `P L²/EI = 1` (w/L = 0.30172,
/// u/L = 0.05643, θ = 0.46135 rad) to its five digits.
#[test]
fn elastica_reference_reproduces_mattiasson() {
    let (w, u, th) = elastica(1.0);
    assert!((w - 0.30172).abs() < 1e-5, "{w}");
    assert!((u - 0.05643).abs() < 1e-5, "{u}");
    assert!((th - 0.46135).abs() < 1e-5, "{th}");
}

/// Check 3. Large deflection under a dead tip load at `P L²/EI` = 1, 2, 5 and 10, 20
/// elements, statics by dynamic relaxation. Reference: the elastica (Mattiasson's table at 1,
/// [`elastica`] by shooting at all four). The section is nearly inextensible and shear-rigid
/// (`EA = GA = 10⁵ EI/L²`, a 1e-4 effect). Tolerance 5e-4 L on the displacements and 1e-3
/// relative on the tip rotation (the issue asks 0.5 %; measured at most 2.3e-4 L and 5.5e-4,
/// the discretization error of 20 elements).
#[test]
fn cantilever_large_deflection_follows_the_elastica() {
    for k in [1.0, 2.0, 5.0, 10.0] {
        let load = format!("point(tip @ (0, 0, 0), (0, 0, -{k}) N)");
        let scene = load_text(&cantilever_with(20, 1.0, 1e5, 1e5, 100.0, &load, "50 us"));
        let tr = simulate(&scene, relaxed(), 5e-5, 6.0, 20_000);
        assert!(tr.report.finished, "k = {k}: {:?}", tr.report.failure);
        let tip = tr.last().pose[0];
        let (w, u, th) = elastica(k);
        // the tip body's rotation about y (its x axis turns down by θ)
        let x_axis = tip.c.column(0);
        let rot = (-x_axis.z).atan2(x_axis.x);
        let (ew, eu, eth) = (
            (-tip.r.z - w).abs(),
            (1.0 - tip.r.x - u).abs(),
            (rot - th).abs() / th,
        );
        eprintln!("k = {k}: w/L {:.5} ({w:.5}), u/L {:.5} ({u:.5}), θ {rot:.5} ({th:.5}); errors {ew:.1e}, {eu:.1e}, {eth:.1e}", -tip.r.z, 1.0 - tip.r.x);
        assert!(ew < 5e-4 && eu < 5e-4 && eth < 1e-3, "k = {k}");
    }
}

/// Check 4. Roll-up by an end moment `M = 2π EI/L` (16 elements): the cantilever closes into
/// a circle and the tip returns to the clamp. Reference: the exact circle, tip at
/// `u = L(sin t/t − 1)`, `v = (L/t)(1 − cos t)` for `t = M L/EI` (at 2π, back at the origin
/// with rotation 2π); checked at M/M_max = 0.25, 0.5 and 1. Tolerance: the issue's 1e-3 L at
/// the full moment (measured 1.2e-4 L); 2e-3 L at the intermediate ones (measured up to
/// 9.9e-4 L at M/M_max = 0.5, where the tip is farthest from the clamp).
#[test]
fn cantilever_rolls_up_into_a_circle_under_an_end_moment() {
    for frac in [0.25, 0.5, 1.0] {
        let t = 2.0 * std::f64::consts::PI * frac;
        // a torque about −y bends the beam up towards +z
        let load = format!("torque(tip, (0, -{t}, 0) N*m)");
        let scene = load_text(&cantilever_with(16, 1.0, 1e5, 1e5, 100.0, &load, "50 us"));
        let tr = simulate(&scene, relaxed(), 5e-5, 6.0, 20_000);
        assert!(tr.report.finished, "t = {t}: {:?}", tr.report.failure);
        let tip = tr.last().pose[0].r;
        let (u, v) = (t.sin() / t - 1.0, (1.0 - t.cos()) / t);
        let err = ((tip.x - 1.0 - u).powi(2) + (tip.z - v).powi(2)).sqrt();
        eprintln!(
            "t = {t:.4}: tip ({:.5}, {:.5}), circle ({:.5}, {v:.5}), error {err:.2e} L",
            tip.x - 1.0,
            tip.z,
            u
        );
        let tol = if frac == 1.0 { 1e-3 } else { 2e-3 };
        assert!(err < tol, "t = {t}: error {err:.2e}");
    }
}

/// The linearized clamped–free beam of `n` equal elements (length 1 m, section `sec`,
/// rotary-inertia scale 1): its lowest `count` natural frequencies (rad/s), from the stiffness
/// of the element kernel (central differences of [`internal_force`] at the straight,
/// unstrained beam) and the lumped mass, by a dense symmetric eigensolution.
fn clamped_frequencies(sec: &Section, n: usize, count: usize) -> Vec<f64> {
    use mbdc_runtime::beam_element::{
        internal_force, lumped_mass, BeamNode, BeamSection, ElementForce, ElementState,
    };
    use mbdc_runtime::math::{axis_angle, qmul};
    use mbdc_runtime::system::{Pose, Twist};
    use nalgebra::{DMatrix, Quaternion, Vector3};
    let bs = BeamSection::from_scene(sec).unwrap();
    let l = 1.0 / n as f64;
    let node = |x: f64| BeamNode {
        pose: Pose::new(Vector3::new(x, 0.0, 0.0), Quaternion::identity()),
        twist: Twist::default(),
    };
    let reference = [node(0.0), node(l)];
    let st0 = ElementState::new(&reference).unwrap();
    let forces = |k: usize, d: f64| -> [f64; 12] {
        let mut nodes = reference;
        let (i, c) = (k / 6, k % 6);
        if c < 3 {
            nodes[i].pose.r[c] += d;
        } else {
            let q = qmul(&nodes[i].pose.q, &axis_angle(&Vector3::ith(c - 3, 1.0), d));
            nodes[i].pose.set_q(q);
        }
        let (mut st, mut out) = (st0, ElementForce::default());
        internal_force(&bs, &mut st, &nodes, &mut out).unwrap();
        let mut f = [0.0; 12];
        for j in 0..2 {
            for c in 0..3 {
                f[6 * j + c] = out.wrench[j].f[c];
                f[6 * j + 3 + c] = out.wrench[j].t[c];
            }
        }
        f
    };
    let mut ke = DMatrix::<f64>::zeros(12, 12);
    for k in 0..12 {
        let d = if k % 6 < 3 { 1e-7 * l } else { 1e-7 };
        let (fp, fm) = (forces(k, d), forces(k, -d));
        for i in 0..12 {
            ke[(i, k)] = -(fp[i] - fm[i]) / (2.0 * d);
        }
    }
    let ke = (&ke + ke.transpose()) * 0.5;
    let dofs = 6 * (n + 1);
    let mut kg = DMatrix::<f64>::zeros(dofs, dofs);
    let mut mg = vec![0.0; dofs];
    let share = lumped_mass(&bs, l);
    for e in 0..n {
        for i in 0..12 {
            let gi = 6 * e + i;
            mg[gi] += if i % 6 < 3 { share.m } else { share.j[i % 3] };
            for j in 0..12 {
                kg[(gi, 6 * e + j)] += ke[(i, j)];
            }
        }
    }
    // clamp node 0; scale by M^{-1/2}
    let free = dofs - 6;
    let a = DMatrix::<f64>::from_fn(free, free, |i, j| {
        kg[(i + 6, j + 6)] / (mg[i + 6] * mg[j + 6]).sqrt()
    });
    let mut w: Vec<f64> = a
        .symmetric_eigenvalues()
        .iter()
        .map(|l| l.max(0.0).sqrt())
        .collect();
    w.sort_by(|a, b| a.total_cmp(b));
    // bending pairs (two equal planes) appear twice: keep distinct values
    w.dedup_by(|a, b| (*a - *b).abs() < 1e-6 * *b);
    w.truncate(count);
    w
}

/// Check 5. First three bending frequencies of a slender cantilever, 16 elements. Reference:
/// Euler–Bernoulli, `ω = (βL)² √(EI/(ρA L⁴))` with βL = 1.8751, 4.6941, 7.8548 (any vibration
/// text); the section is slender (`EA = GA = 10⁶ EI/L²`, rotary inertia `ρA·EI/EA`, so the
/// Timoshenko corrections are below 1e-5). Two parts: the linearized lumped beam's
/// frequencies (the kernel's stiffness) within 1 % (the issue's; measured below), and the
/// first mode measured in a run (the explicit integration) within 1 % of the same reference.
#[test]
fn cantilever_bending_frequencies_match_euler_bernoulli() {
    let sec = Section {
        ea: 1e6,
        ga2: 1e6,
        ga3: 1e6,
        ei2: 1.0,
        ei3: 1.0,
        gj: 1.0,
        rho_a: 1.0,
        rho_i: 2e-6,
    };
    let bl = [1.8751f64, 4.6941, 7.8548];
    let w = clamped_frequencies(&sec, 16, 3);
    for (i, b) in bl.iter().enumerate() {
        let exact = b * b;
        let err = (w[i] - exact).abs() / exact;
        eprintln!(
            "mode {}: {:.5} rad/s, Euler–Bernoulli {exact:.5}, error {err:.2e}",
            i + 1,
            w[i]
        );
        assert!(err < 1e-2, "mode {}: {err:.2e}", i + 1);
    }
    // the first mode in a run: a tip load applied at t = 0 excites mostly mode 1 about the
    // static deflection; its period from the crossings of that mean
    // A stockier section keeps the run short (its highest mode, and so the step, set by
    // `EA = GA = 10⁴ EI/L²` and the rotary inertia ×10): shear and rotary inertia then lower
    // mode 1 by ~2e-3, the 1 g tip body by ~3e-4.
    let scene = load_text(&cantilever_with(
        16,
        1.0,
        1e4,
        1e4,
        10.0,
        "point(tip @ (0, 0, 0), (0, 0, -0.01) N)",
        "100 us",
    ));
    let period = 2.0 * std::f64::consts::PI / (bl[0] * bl[0]);
    let tr = simulate(&scene, method("staggered"), 1e-4, 10.5 * period, 1);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let t: Vec<f64> = tr.frames.iter().map(|f| f.t).collect();
    let z: Vec<f64> = tr.frames.iter().map(|f| f.pose[0].r.z).collect();
    let n10 = t.iter().position(|x| *x >= 10.0 * period).unwrap();
    let mean = z[..n10].iter().sum::<f64>() / n10 as f64;
    let mut ups = Vec::new();
    for i in 1..t.len() {
        let (a, b) = (z[i - 1] - mean, z[i] - mean);
        if a < 0.0 && b >= 0.0 {
            ups.push(t[i - 1] + (t[i] - t[i - 1]) * (-a) / (b - a));
        }
    }
    assert!(ups.len() >= 9, "{ups:?}");
    let measured = (ups[ups.len() - 1] - ups[0]) / (ups.len() - 1) as f64;
    let err = (measured - period).abs() / period;
    eprintln!("first-mode period in a run {measured:.6} s, Euler–Bernoulli {period:.6} s, error {err:.2e}");
    assert!(err < 1e-2, "{err:.2e}");
}

/// Check 6. A bar rotating at constant ω about one end, in the plane normal to the axis:
/// axial stretch `U(x) = ρω²/(2E) (x L² − x³/3)` (centrifugal load, small strain; any
/// rotor-dynamics text). The bar is clamped to a hub driven from rest to ω = 10 rad/s over
/// 2 s (angle `Ω(s³/T² − s⁴/(2T³) + t − s)`, s = min(t, T)), then held; its stretch at the tip
/// and at midspan after 3 s is compared with `U(L)` and `U(L/2)`. Tolerance 0.5 % (the issue
/// asks 1 %; measured 2.9e-3, the lumped 20-element bar's discretization error).
#[test]
fn rotating_bar_stretches_as_the_centrifugal_load_says() {
    let (omega, ea, rho_a) = (10.0f64, 1e5, 1.0);
    let text = format!(
        r#"
model spin_bar {{
  param W = {omega} rad/s
  param T = 2 s
  body hub {{ mass 1 kg; inertia diag(0.01, 0.01, 0.01) kg*m^2 }}
  joint axle = revolute(ground @ (0, 0, 0), hub @ (0, 0, 0), axis: (0, 0, 1))
  joint motor = drive_angle(axle, W * (min(t, T)^3 / T^2 - min(t, T)^4 / (2 * T^3) + t - min(t, T)))
  beam bar {{
    from (0, 0, 0) m
    to (1, 0, 0) m
    elements 20
    up (0, 0, 1)
    section {{ EA {ea} N; GA2 {ea} N; GA3 {ea} N; EI2 100 N*m^2; EI3 100 N*m^2; GJ 100 N*m^2; rhoA {rho_a} kg/m; rhoI 1e-3 kg*m }}
    rotary_inertia_scale 10
    damping 1e-5 s
    clamp start, hub @ (0, 0, 0)
  }}
  simulate {{ duration 3 s; step 50 us }}
}}
"#
    );
    let scene = load_text(&text);
    let tr = simulate(&scene, method("staggered"), 5e-5, 3.0, 1000);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let last = tr.last();
    // bodies: hub, then the bar's nodes 0..=20
    let u = |node: usize, x: f64| last.pose[1 + node].r.norm() - x;
    let exact = |x: f64| rho_a * omega * omega / (2.0 * ea) * (x - x * x * x / 3.0);
    for (node, x) in [(20, 1.0), (10, 0.5)] {
        let err = (u(node, x) - exact(x)).abs() / exact(x);
        eprintln!(
            "stretch at x = {x}: {:.6e} m, exact {:.6e} m, error {err:.2e}",
            u(node, x),
            exact(x)
        );
        assert!(err < 5e-3, "x = {x}: {err:.2e}");
    }
}

/// Check 8. A free flexible pendulum (a beam pinned at one end, released horizontal under
/// gravity) over 10⁵ steps: no energy growth. Reference: conservation of
/// `kinetic + gravity + strain` energy (no damping, no source). The leapfrog's energy error
/// oscillates without drift, so the tolerance is on the trend: the largest error over the
/// last tenth of the run is at most 1.5× that over the first tenth (measured 1.13×), and
/// every error stays below 1e-5 of the energy in play (measured 4.7e-6).
#[test]
fn flexible_pendulum_energy_does_not_grow_over_1e5_steps() {
    let scene = load_text(
        r#"
model flexible_pendulum {
  gravity (0, 0, -9.81) m/s^2
  beam rod {
    from (0, 0, 0) m
    to (1, 0, 0) m
    elements 10
    up (0, 0, 1)
    section { EA 1e4 N; GA2 1e4 N; GA3 1e4 N; EI2 10 N*m^2; EI3 10 N*m^2; GJ 10 N*m^2; rhoA 1 kg/m; rhoI 1e-3 kg*m }
    rotary_inertia_scale 10
    pin start
  }
  simulate { duration 40 s; step 400 us }
}
"#,
    );
    let tr = simulate(&scene, method("staggered"), 4e-4, 40.0, 100);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let e0 = tr.frames[0].energy();
    let in_play = tr.frames.iter().map(|f| f.kinetic).fold(0.0, f64::max);
    let n = tr.frames.len();
    let worst = |fr: &[Rec]| {
        fr.iter()
            .map(|f| (f.energy() - e0).abs())
            .fold(0.0, f64::max)
    };
    let (first, last) = (
        worst(&tr.frames[1..n / 10]),
        worst(&tr.frames[n - n / 10..]),
    );
    let all = worst(&tr.frames);
    eprintln!("energy in play {in_play:.4} J; error first tenth {first:.3e} J, last tenth {last:.3e} J, worst {all:.3e} J; max violation {:.2e}", tr.max_violation());
    assert!(
        last <= 1.5 * first,
        "energy grows: {first:.3e} → {last:.3e}"
    );
    assert!(all < 1e-5 * in_play, "{all:.3e} J");
}

/// Check 7, the papers' first example (notes B §7, Example 1; Simo and Vu-Quoc's spin-up
/// beam): a 10 in beam of 5 elements (EA = 2.8e7, GA = 1e7, EI = 1.4e4, ρA = 1.2, ρI = 6e-4,
/// consistent units; GJ = EI and the polar ρI doubled, which plane motion does not see)
/// clamped to a hub driven from rest to 6 rad/s over 15 s by the paper's
/// `θ = (6/15)[t²/2 + (15/2π)²(cos(2πt/15) − 1)]`, then at 6 rad/s.
///
/// Reference: the load is 9 bending periods long, so the tip deflection in the hub frame is
/// quasi-static: the non-rotating cantilever's `ρA α L⁴ (11/120)/EI` under the tangential
/// load `ρA α x` (0.629 in at α_max = 0.8 rad/s²), stiffened by the spin as the first mode
/// is, `ω₁²/(ω₁² + (K − 1)Ω²)` with Southwell's coefficient K = 1.1931 of a uniform
/// cantilever (in-plane bending keeps K − 1 of the centrifugal stiffening) and
/// ω₁ = 3.76 rad/s. A linear floating-frame model without geometric stiffening has
/// `ω₁² − Ω²` instead and diverges once the spin passes 3.76 rad/s. Checked: the mean
/// deflection over a bending period at t = 5, 7.5, 10 s lags (negative) and is within 5 % of
/// the quasi-static stiffened value (measured 1.4 %, 1.8 %, 3.9 %, the rest is the dynamics
/// the quasi-static model leaves out); after the spin-up, "small vibrations" about the hub
/// frame: below 2 % of the peak over the last 5 s (measured 0.9 %). Rotary inertia ×100
/// (the shear/rotary mode sets the step; bending modes change by ~1e-3).
#[test]
fn spin_up_beam_shows_geometric_stiffening() {
    let scene = load_text(
        r#"
model spin_up {
  param W = 6 rad/s
  param T = 15 s
  body hub { mass 1 kg; inertia diag(1, 1, 1) kg*m^2 }
  joint axle = revolute(ground @ (0, 0, 0), hub @ (0, 0, 0), axis: (0, 0, 1))
  joint motor = drive_angle(axle, W / T * (min(t, T)^2 / 2 + (T / (2 * pi))^2 * (cos(2 * pi * min(t, T) / T) - 1)) + W * (t - min(t, T)))
  beam blade {
    from (0, 0, 0) m
    to (10, 0, 0) m
    elements 5
    up (0, 0, 1)
    section { EA 2.8e7 N; GA2 1e7 N; GA3 1e7 N; EI2 1.4e4 N*m^2; EI3 1.4e4 N*m^2; GJ 1.4e4 N*m^2; rhoA 1.2 kg/m; rhoI 1.2e-3 kg*m }
    rotary_inertia_scale 100
    clamp start, hub @ (0, 0, 0)
  }
  simulate { duration 30 s; step 100 us }
}
"#,
    );
    let tr = simulate(&scene, method("staggered"), 1e-4, 30.0, 100);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    // the tip (last node, body 6) in the hub frame (body 0): its transverse coordinate
    let w: Vec<(f64, f64)> = tr
        .frames
        .iter()
        .map(|f| {
            let hub = &f.pose[0];
            let local = hub.c.transpose() * (f.pose[6].r - hub.r);
            (f.t, local.y)
        })
        .collect();
    let peak = w.iter().map(|x| x.1.abs()).fold(0.0, f64::max);
    let late = w
        .iter()
        .filter(|x| x.0 >= 25.0)
        .map(|x| x.1.abs())
        .fold(0.0, f64::max);
    let bound = 1.2 * 0.8 * 10.0 * 1e4 * (11.0 / 120.0) / 1.4e4;
    let around = |t0: f64| {
        let v: Vec<f64> = w
            .iter()
            .filter(|x| (x.0 - t0).abs() <= 0.85)
            .map(|x| x.1)
            .collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    for t in [5.0, 7.5, 10.0] {
        let th = 2.0 * std::f64::consts::PI * t / 15.0;
        let alpha = 0.4 * (1.0 - th.cos());
        let omega = 0.4 * (t - 15.0 / (2.0 * std::f64::consts::PI) * th.sin());
        let w1 = 3.7599f64;
        let qs = bound * alpha / 0.8 * w1 * w1 / (w1 * w1 + 0.1931 * omega * omega);
        let m = around(t);
        eprintln!("t {t}: mean deflection {m:.4e}, quasi-static stiffened {qs:.4e}");
        assert!(
            m < 0.0 && (-m - qs).abs() < 0.05 * qs,
            "t = {t}: {m} vs {qs}"
        );
    }
    eprintln!("tip deflection in the hub frame: peak {peak:.4e} in, last 5 s {late:.4e} in; unstiffened quasi-static bound {bound:.4e} in");
    assert!(late < 0.02 * peak, "{late} vs {peak}");
}

/// Check 7, the papers' spatial double pendulum in the stiff limit (notes B §7, Example 3,
/// case 1 "coincides exactly with a rigid body solution"): two 1 m beams of 8 elements,
/// the first pinned to the ground at the origin along x, the second pinned to the first's
/// end (through a 1 mg hinge body clamped there) along y, released from rest in gravity, so
/// the motion is spatial. Stiff: EA = GA = 10⁸ N, EI = GJ = 10⁵ N·m² (the issue's ×10⁴ of a
/// 1e4/10 section), static sag ~1e-5 m. Reference, an independent model: the rigid double
/// pendulum of two rods with the beams' lumped mass distribution (1 kg each; transverse
/// inertia about the mass centre `Σ mᵢxᵢ² + s·ρI_k·L` = `mL²/12 (1 + 2/N²)` plus the nodes'
/// rotary inertia; polar `s·ρI₁·L`), pinned by spherical joints, run with `staggered` at
/// 1e-5 s. Tolerance: the tip of the second beam within 5e-5 m of the rigid one's over 1 s
/// (the issue asks 1e-3 m; measured 6.8e-6 m, the beams' elastic deflection).
#[test]
fn stiff_flexible_double_pendulum_follows_the_rigid_one() {
    let n = 8.0;
    let scale = 10.0;
    let (rho_i1, rho_ik) = (2e-3, 1.0 * 1e5 / 1e8);
    let jt = (1.0 + 2.0 / (n * n)) / 12.0 + scale * rho_ik;
    let jp = scale * rho_i1;
    let flexible = format!(
        r#"
model flexible_double_pendulum {{
  gravity (0, 0, -9.81) m/s^2
  body hinge {{ mass 1e-6 kg; inertia sphere(radius: 1 mm); position (1, 0, 0) m }}
  beam upper {{
    from (0, 0, 0) m
    to (1, 0, 0) m
    elements 8
    up (0, 0, 1)
    section {{ EA 1e8 N; GA2 1e8 N; GA3 1e8 N; EI2 1e5 N*m^2; EI3 1e5 N*m^2; GJ 1e5 N*m^2; rhoA 1 kg/m; rhoI {rho_i1} kg*m }}
    rotary_inertia_scale {scale}
    pin start
    clamp end, hinge @ (0, 0, 0)
  }}
  beam lower {{
    from (1, 0, 0) m
    to (1, 1, 0) m
    elements 8
    up (0, 0, 1)
    section {{ EA 1e8 N; GA2 1e8 N; GA3 1e8 N; EI2 1e5 N*m^2; EI3 1e5 N*m^2; GJ 1e5 N*m^2; rhoA 1 kg/m; rhoI {rho_i1} kg*m }}
    rotary_inertia_scale {scale}
    pin start, hinge @ (0, 0, 0)
  }}
  simulate {{ duration 1 s; step 10 us }}
}}
"#
    );
    let rigid = format!(
        r#"
model rigid_double_pendulum {{
  gravity (0, 0, -9.81) m/s^2
  body upper {{ mass 1 kg; inertia diag({jp}, {jt}, {jt}) kg*m^2; position (0.5, 0, 0) m }}
  body lower {{ mass 1 kg; inertia diag({jt}, {jp}, {jt}) kg*m^2; position (1, 0.5, 0) m }}
  joint root = spherical(ground @ (0, 0, 0), upper @ (-0.5, 0, 0) m)
  joint elbow = spherical(upper @ (0.5, 0, 0) m, lower @ (0, -0.5, 0) m)
  simulate {{ duration 1 s; step 10 us }}
}}
"#
    );
    let (fs, rs) = (load_text(&flexible), load_text(&rigid));
    let ft = simulate(&fs, method("staggered"), 1e-5, 1.0, 1000);
    let rt = simulate(&rs, method("staggered"), 1e-5, 1.0, 1000);
    assert!(ft.report.finished, "{:?}", ft.report.failure);
    assert!(rt.report.finished, "{:?}", rt.report.failure);
    // bodies: hinge, upper's 9 nodes, lower's 9 nodes: the lower tip is body 18
    let mut worst: f64 = 0.0;
    for (f, r) in ft.frames.iter().zip(&rt.frames) {
        let tip_rigid = r.pose[1].r + r.pose[1].c * nalgebra::Vector3::new(0.0, 0.5, 0.0);
        worst = worst.max((f.pose[18].r - tip_rigid).norm());
    }
    let last = ft.last();
    eprintln!(
        "lower tip at 1 s: flexible {:?}, largest distance to the rigid pendulum's over 1 s {worst:.3e} m",
        last.pose[18].r
    );
    assert!(worst < 5e-5, "{worst:.3e} m");
    // it did move: the lower tip fell by more than 0.3 m
    assert!(last.pose[18].r.z < -0.3, "{:?}", last.pose[18].r);
}

/// The papers' flexible spatial double pendulum, deformation excited (notes B §7, Example 4),
/// in the papers' units: two beams of l = 120 in (EA = 1.8·10⁸ lb, GA = 0.9·10⁸ lb,
/// EI = 1.4·10⁸ lb·in², ρA = 0.98 lbm/in, ρI = 0.67 lbm·in), 8 elements each (Fig. 11: 16),
/// in line along x (240 in in all), the first pinned to the ground at the origin, the second
/// pinned to the first's end (through a 1 g hinge body clamped there). Assumed where the
/// notes have no data: GJ = EI; no gravity (not stated); rotary-inertia scale 100 (lowers
/// the shear/rotary mode from 1.4·10⁶ to 1.4·10⁵ rad/s; the bending modes move by ~0.1 %);
/// and the initial velocity (only in the lost Fig. 11a; fragments "300", "600"): the first
/// beam turning about the vertical at 2.5 rad/s (300 in/s at the elbow), the second with the
/// elbow's velocity and 2.5 rad/s about the vertical and −2.5 rad/s about y (its tip at
/// (0, 600, 300) in/s), so the motion is spatial and the elbow bends.
/// Reference (Fig. 11c): the energy is conserved, and with no gravity and the pin at the
/// origin, so is the angular momentum about the origin. Over 1 s (the lower tip leaves the
/// plane by 1.7 m; strain energy up to 0.09 J of 4 683 J), measured: energy error 2.0e-9 of
/// the energy at h = 10 µs, 5.1e-10 at 5 µs (ratio 4.02: second order), angular momentum
/// within 8.2e-10 of its magnitude. Tolerances: energy 1e-8 and a halving ratio in 3.5–4.5,
/// angular momentum 1e-8.
#[test]
fn papers_flexible_double_pendulum_conserves_energy_and_momentum() {
    let scene = |h: &str| {
        let section = "section { EA 1.8e8 lbf; GA2 0.9e8 lbf; GA3 0.9e8 lbf; EI2 1.4e8 lbf*in^2; EI3 1.4e8 lbf*in^2; GJ 1.4e8 lbf*in^2; rhoA 0.98 lb/in; rhoI 0.67 lb*in }";
        load_text(&format!(
            r#"
model papers_example_4 {{
  body hinge {{
    mass 1 g
    inertia sphere(radius: 1 mm)
    position (120, 0, 0) in
    velocity (0, 300, 0) in/s
  }}
  beam upper {{
    from (0, 0, 0) in
    to (120, 0, 0) in
    elements 8
    up (0, 0, 1)
    {section}
    rotary_inertia_scale 100
    pin start
    clamp end, hinge @ (0, 0, 0)
    angular_velocity (0, 0, 2.5) rad/s
  }}
  beam lower {{
    from (120, 0, 0) in
    to (240, 0, 0) in
    elements 8
    up (0, 0, 1)
    {section}
    rotary_inertia_scale 100
    pin start, hinge @ (0, 0, 0)
    velocity (0, 300, 0) in/s
    angular_velocity (0, -2.5, 2.5) rad/s
  }}
  simulate {{ duration 1 s; step {h} }}
}}
"#
        ))
    };
    let run = |h: f64| {
        let tr = simulate(&scene(&format!("{h} s")), method("staggered"), h, 1.0, 100);
        assert!(tr.report.finished, "h = {h}: {:?}", tr.report.failure);
        tr
    };
    let (a, b) = (run(1e-5), run(5e-6));
    let e0 = a.frames[0].energy();
    // the initial state is the one asked for: the lower tip (body 18) moves at (0, 600, 300) in/s
    let tip_v = a.frames[0].twist[18].v / 0.0254;
    assert!(
        (tip_v - nalgebra::Vector3::new(0.0, 600.0, 300.0)).norm() < 1e-9 * 600.0,
        "{tip_v:?}"
    );
    let l0 = nalgebra::Vector3::from(a.frames[0].angular_momentum);
    let (mut de, mut dl, mut strain, mut z) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for f in &a.frames {
        de = de.max((f.energy() - e0).abs());
        dl = dl.max((nalgebra::Vector3::from(f.angular_momentum) - l0).norm());
        strain = strain.max(f.potential);
        z = z.max(f.pose[18].r.z.abs());
    }
    let de_half = b
        .frames
        .iter()
        .fold(0.0f64, |m, f| m.max((f.energy() - e0).abs()));
    eprintln!(
        "E0 {e0:.6e} J: energy error {:.3e} (h), {:.3e} (h/2), ratio {:.2}; |ΔL|/|L| {:.3e}; largest strain energy {strain:.3e} J; lower tip left the plane by {z:.3} m; {:?}",
        de / e0,
        de_half / e0,
        de / de_half,
        dl / l0.norm(),
        a.report.stats
    );
    assert!(z > 0.5, "the motion is spatial: {z} m");
    assert!(strain > 1e-6 * e0, "the beams deform: {strain:.3e} J");
    assert!(de / e0 < 1e-8, "energy error {:.3e}", de / e0);
    assert!(
        (3.5..4.5).contains(&(de / de_half)),
        "order: ratio {}",
        de / de_half
    );
    assert!(
        dl / l0.norm() < 1e-8,
        "angular momentum {:.3e}",
        dl / l0.norm()
    );
}

fn substeps(n: u32) -> MethodSpec {
    MethodSpec::Staggered(StaggeredOptions {
        beam_substeps: n,
        ..Default::default()
    })
}

/// Subcycling (issue 14): models/arm_probe.mbd, a three-link arm with a stiff steel probe
/// clamped to its end, with the links at 80 µs and the probe in 16 substeps of 5 µs,
/// against the whole scene at 5 µs, over 0.3 s (the arm falls through 25°).
/// Reference: the uniform-step run (the method's own error there is 4e-10 m: 5 µs against
/// 2.5 µs). Measured: every body within 4.3e-7 m (release build); tolerance 1e-6 m. The
/// leapfrog's straight path for the link in the substeps (instead of the parabola) left
/// the arm 4 cm off over 1 s; this test would fail by far.
#[test]
fn subcycled_beam_follows_the_uniform_step() {
    let uniform = load_model_with("arm_probe.mbd", &["substeps=1"]);
    let sub = load_model("arm_probe.mbd");
    let a = simulate(&uniform, substeps(1), 5e-6, 0.3, 16);
    let b = simulate(&sub, substeps(16), 8e-5, 0.3, 1);
    assert!(a.report.finished, "{:?}", a.report.failure);
    assert!(b.report.finished, "{:?}", b.report.failure);
    assert_eq!(a.frames.len(), b.frames.len());
    let mut worst: f64 = 0.0;
    for (x, y) in a.frames.iter().zip(&b.frames) {
        assert!((x.t - y.t).abs() < 1e-9, "{} against {}", x.t, y.t);
        worst = worst.max(position_difference(x, y));
    }
    let fell = a.last().pose[2].r.z;
    eprintln!(
        "subcycled against uniform: {worst:.3e} m; the last link's centre fell to z = {fell:.3} m"
    );
    assert!(worst < 1e-6, "{worst:.3e} m");
    assert!(fell < -0.3, "the arm did not swing: z = {fell}");
    // the statistics say it was subcycled
    assert_eq!(stat(&b, "beam_substeps"), 16.0);
}

/// What `beam_substeps` refuses before the first step, each naming the cause: an
/// undamped beam (with the damping it needs), a scene without beams, a step above the
/// coupling of the last link to the probe, and a substep above the beam's own limit.
#[test]
fn subcycling_refusals_name_their_cause() {
    use mbdc_runtime::integrators::{self, State};
    use mbdc_runtime::interp::Interp;
    let refusal = |scene: &mbdc_runtime::scene::Scene, n: u32, h: f64| -> String {
        let sys = Interp::new(scene).expect("interpretable");
        match integrators::make(&substeps(n), &sys, h, &State::initial(&sys)) {
            Ok(_) => String::new(),
            Err(e) => e.to_string(),
        }
    };
    let probe = load_model("arm_probe.mbd");
    assert_eq!(refusal(&probe, 16, 8e-5), "", "the model itself starts");
    let undamped = load_text(
        &std::fs::read_to_string(model_path("arm_probe.mbd"))
            .unwrap()
            .replace("damping 1 us", ""),
    );
    let m = refusal(&undamped, 16, 8e-5);
    assert!(
        m.contains("beam 'probe'")
            && m.contains("needs stiffness-proportional damping")
            && m.contains("damping 7."),
        "{m}"
    );
    let rigid = load_model("pendulum.mbd");
    let m = refusal(&rigid, 4, 1e-3);
    assert!(m.contains("needs a scene with flexible beams"), "{m}");
    let m = refusal(&probe, 32, 1.6e-4);
    assert!(
        m.contains("joint 'probe.clamp[0]'")
            && m.contains("body 'link[2]'")
            && m.contains("coupling"),
        "{m}"
    );
    let m = refusal(&probe, 8, 8e-5);
    assert!(
        m.contains("beam 'probe'")
            && m.contains("the substep 1.000e-5 s")
            && m.contains("`beam_substeps 13`"),
        "{m}"
    );
}
