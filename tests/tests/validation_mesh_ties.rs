//! Validation of meshes tied to bodies (`tie SET, BODY`; issue 15, "Meshes and rigid
//! bodies in one scene"; docs/methods.md, "Meshes tied to bodies"): the compound pendulum
//! against the rigid composite's period, momentum of a free body with a tied flexible
//! mesh, the energy balance of a vibrating tied mesh on a moving body, the outputs at the
//! body's own mass centre, and the refusals. Every test states its reference and tolerance.

use mbdc_runtime::integrators::{self, State};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::mesh_model;
use mbdc_runtime::scene::Scene;
use mbdc_runtime::system::System;
use mbdc_tests::*;
use nalgebra::Vector3;

/// 0.9 × the central-difference limit of the scene's meshes.
fn step_of(scene: &Scene) -> f64 {
    let sys = Interp::new(scene).expect("interpretable");
    0.9 * mesh_model::critical_step(&sys.layout().meshes)
        .expect("elements")
        .step
}

/// A pendulum in the x–y plane (gravity −y, hinge about z at the origin): an arm of
/// 0.5 kg, a 4 cm × 20 cm × 1 cm box centred 10 cm below the hinge, and under it a quad4
/// bar (plane stress, 1 cm thick, 4 cm × 20 cm, 2 × 10 elements, ρ = 2000 kg/m³, ν = 0,
/// Young's modulus `e`) whose top edge is tied to the arm. The bar carries its weight as
/// a body force (the scene's gravity acts on bodies).
fn pendulum(e: &str, extra: &str) -> String {
    format!(
        r#"
model tied_pendulum {{
  gravity (0, -9.81, 0) m/s^2
  material poly {{ E {e}; nu 0; rho 2000 kg/m^3 }}
  body arm {{
    mass 0.5 kg
    inertia box(size: (0.04, 0.2, 0.01) m)
    position (0, -0.1, 0) m
    {extra}
  }}
  joint pivot = revolute(ground @ (0, 0, 0), arm @ world((0, 0, 0) m), axis: (0, 0, 1))
  mesh bar {{
    element quad4, plane_stress
    thickness 1 cm
    strain green
    generate rect(origin: (-0.02, -0.4) m, size: (0.04, 0.2) m, divisions: (2, 10))
    material poly
    set top = nodes(y == -0.2 m)
    tie top, arm
    body_force (0, -9.81 m/s^2 * 2000 kg/m^3, 0)
  }}
  simulate {{ duration 1 s; step 10 us }}
}}
"#
    )
}

/// The scene turned rigidly by `theta` about the hinge (z through the origin): the arm's
/// pose and the mesh's nodes, so that the pendulum starts at rest at that angle, undeformed.
fn turned(mut scene: Scene, theta: f64) -> Scene {
    let (s, c) = theta.sin_cos();
    let rot = |p: [f64; 3]| [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]];
    for b in &mut scene.bodies {
        b.position = rot(b.position);
        b.orientation = [(theta / 2.0).cos(), 0.0, 0.0, (theta / 2.0).sin()];
    }
    for m in &mut scene.meshes {
        for n in &mut m.nodes {
            *n = rot(*n);
        }
    }
    scene
}

/// The arm's angle about z from its orientation.
fn angle(r: &Rec) -> f64 {
    let q = r.pose[0].q;
    2.0 * q.k.atan2(q.w)
}

/// The times at which `f` crosses zero (linear interpolation between frames).
fn zero_crossings(tr: &Trajectory, f: impl Fn(&Rec) -> f64) -> Vec<f64> {
    tr.frames
        .windows(2)
        .filter_map(|w| {
            let (a, b) = (f(&w[0]), f(&w[1]));
            (a != 0.0 && a.signum() != b.signum()).then(|| w[0].t + (w[1].t - w[0].t) * a / (a - b))
        })
        .collect()
}

/// Check 1: the compound pendulum. A mesh bar tied to a pendulum's arm swings with it as
/// one rigid body when it is stiff: the small-amplitude period is that of the composite,
/// `T₀ = 2π √(I_O / (M g d))`, with (all about the hinge O)
/// - arm: `I = m(a² + b²)/12 + m·0.1²` = 6.7333e-3 kg·m², first moment `m·0.1`;
/// - bar (continuum): `m = ρ t w L` = 0.16 kg, `I = m(w² + L²)/12 + m·0.3²`, first moment
///   `m·0.3`; its lumped masses add `m(a_x² + a_y²)/6` to the moment of inertia (the
///   trapezoidal rule on a uniform grid of spacing `a`, exact for `x²`: per direction the
///   excess is `a²/6` per unit mass) and nothing to the first moment;
/// - amplitude θ₀ = 0.02 rad: `T = T₀(1 + θ₀²/16 + 11θ₀⁴/3072)` (2.5e-5; the series' next
///   term is below 1e-12).
///
/// The tolerance, 2e-4, covers the flexibility the rigid reference leaves out: the bar's
/// first bending mode (clamped at its tied edge) is at `ω₁ = 1.875² √(EI/ρAL⁴)` = 718 rad/s
/// for E = 1 GPa against the pendulum's ω₀ = 6.66 rad/s, so the bending under the
/// pendulum's own inertia and weight lengthens the period by about `(ω₀/ω₁)²` = 8.6e-5 at
/// most; the time discretization (`(ω₀h)²/24` ≈ 1e-12) and the interpolation of the zero
/// crossings are far below. The period is measured between consecutive zero crossings of
/// the arm's angle (half a period).
#[test]
fn a_stiff_tied_bar_swings_with_the_period_of_the_rigid_composite() {
    let theta0 = 0.02;
    let scene = turned(load_text(&pendulum("1 GPa", "")), theta0);
    let h = step_of(&scene);
    let tr = simulate(&scene, method("staggered"), h, 0.8, 1);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let z = zero_crossings(&tr, angle);
    assert!(z.len() >= 2, "crossings {z:?}");
    let measured = 2.0 * (z[1] - z[0]);
    let (g, rho, t, w, l) = (9.81, 2000.0, 0.01, 0.04, 0.2);
    let (ma, a_x, a_y) = (0.5, 0.02, 0.02);
    let mb = rho * t * w * l;
    let i_o = ma * (0.04f64.powi(2) + 0.2f64.powi(2)) / 12.0
        + ma * 0.1f64.powi(2)
        + mb * (w * w + l * l) / 12.0
        + mb * 0.3f64.powi(2)
        + mb * (a_x * a_x + a_y * a_y) / 6.0;
    let mgd = g * (ma * 0.1 + mb * 0.3);
    let t0 = std::f64::consts::TAU * (i_o / mgd).sqrt();
    let reference = t0 * (1.0 + theta0.powi(2) / 16.0 + 11.0 * theta0.powi(4) / 3072.0);
    let err = measured / reference - 1.0;
    eprintln!("period {measured:.9} s, rigid composite {reference:.9} s, relative {err:.3e}; h = {h:.3e} s");
    assert!(
        err.abs() < 2e-4,
        "period {measured} s against {reference} s: {err:e}"
    );
    // Without the bar's inertia the period would be 22 % shorter: the tie carries it.
    let arm_alone = std::f64::consts::TAU
        * ((ma * (0.04f64.powi(2) + 0.2f64.powi(2)) / 12.0 + ma * 0.01) / (g * ma * 0.1)).sqrt();
    assert!(
        measured / arm_alone - 1.0 > 0.25,
        "{measured} s against {arm_alone} s"
    );
}

/// A free hub with a flexible hex8 plate (St Venant–Kirchhoff, so its internal forces have
/// no moment) tied by one face; no gravity; the hub starts moving and spinning, the plate
/// at rest, so the tie jerks it into strong vibration.
fn free_hub() -> Scene {
    load_text(
        r#"
model tied_free {
  material soft { E 0.1 GPa; nu 0.3; rho 1000 kg/m^3 }
  body hub {
    mass 1 kg
    inertia diag(0.002, 0.003, 0.004) kg*m^2
    position (-0.05, 0.02, 0.02) m
    velocity (0.3, -0.2, 0.1) m/s
    angular_velocity (2, -3, 5) rad/s
  }
  mesh plate {
    element hex8
    strain green
    generate box(origin: (0, 0, 0) m, size: (0.2, 0.04, 0.04) m, divisions: (10, 2, 2))
    material soft
    set root = nodes(x == 0)
    tie root, hub
  }
  simulate { duration 0.05 s; step 10 us }
}
"#,
    )
}

/// Linear and angular momentum (about the origin) of the system's bodies (at their
/// integrated reference points) and the meshes' nodes.
fn momenta(sys: &Interp, st: &State) -> (Vector3<f64>, Vector3<f64>) {
    let l = sys.layout();
    let (mp, ml) = mbdc_runtime::energy::mesh_momenta(&l.meshes, &st.mesh);
    (
        mbdc_runtime::energy::linear_momentum(l, &st.twist) + mp,
        mbdc_runtime::energy::angular_momentum(l, &st.pose, &st.twist) + ml,
    )
}

/// Runs `steps` steps of the free hub with step `h` through the integrator itself (the
/// system's state: the hub at its reference point, the mass centre of hub and tied nodes)
/// and returns the largest errors of: the half-step linear momentum `Σ m (x^{n+1} − xⁿ)/h`,
/// the synchronized linear momentum, and the synchronized angular momentum about the
/// origin.
fn momentum_errors(scene: &Scene, h: f64, steps: usize) -> (f64, f64, f64, f64, f64) {
    let sys = Interp::new(scene).expect("interpretable");
    let start = State::initial(&sys);
    let mut integ = integrators::make(&method("staggered"), &sys, h, &start).expect("starts");
    let (p0, l0) = momenta(&sys, &start);
    let m_hub = sys.layout().mass[0].m;
    let mut prev = start.clone();
    let mut st = start.clone();
    let (mut half, mut sync, mut ang) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..steps {
        integ.step(&sys).expect("steps");
        integ.state(&sys, &mut st);
        let mut ph = (st.pose[0].r - prev.pose[0].r) * (m_hub / h);
        for ((u1, u0), m) in st
            .mesh
            .u
            .iter()
            .zip(&prev.mesh.u)
            .zip(&sys.layout().meshes.mass)
        {
            ph += Vector3::new(u1[0] - u0[0], u1[1] - u0[1], u1[2] - u0[2]) * (m / h);
        }
        half = half.max((ph - p0).norm());
        let (p, l) = momenta(&sys, &st);
        sync = sync.max((p - p0).norm());
        ang = ang.max((l - l0).norm());
        std::mem::swap(&mut prev, &mut st);
    }
    (p0.norm(), l0.norm(), half, sync, ang)
}

/// Check 2: momentum. The tie forces are equal and opposite (what the mesh's elements pull
/// on the tied nodes, the hub gets), and the hub and the free nodes are kicked by forces of
/// the same configuration, so the leapfrog's half-step momentum `Σ m (x^{n+1} − xⁿ)/h` is
/// conserved exactly; measured from the positions, whose round-off the difference quotient
/// divides by h (an ulp of 0.25 m over 3.6e-5 s is 1.5e-12 m/s per node), to 1e-11 of |p|
/// over 2000 steps. The synchronized momentum of the output is conserved to round-off,
/// 1e-13 of |p|: the hub's velocity takes the newest tie wrench's half kick, as the nodes'
/// velocities take their newest forces' (docs/methods.md). The angular momentum is the
/// rigid method's to O(h²) (its rotation is the midpoint rule, exact for a free body's |L|
/// but not for the world direction of a body that the tie torques): within 1e-6 of |L₀|,
/// and the error falls 4-fold (3 to 5.5) when h is halved. (Run 20 000 steps, the error
/// stays bounded: 1.1e-8 at most, 1.5e-9 at the end.)
#[test]
fn a_free_body_with_a_tied_mesh_keeps_its_momentum() {
    let scene = free_hub();
    let h = step_of(&scene);
    let (p0, l0, half, sync, ang) = momentum_errors(&scene, h, 2000);
    let (_, _, _, _, ang2) = momentum_errors(&scene, h / 2.0, 4000);
    eprintln!(
        "|p0| = {p0:.6e}: half-step error {half:.3e}, synchronized {sync:.3e}; |L0| = {l0:.6e}: error {ang:.3e}, at h/2 {ang2:.3e} (ratio {:.2}); h = {h:.3e} s",
        ang / ang2
    );
    assert!(half < 1e-11 * p0, "half-step momentum {half:e}");
    assert!(sync < 1e-13 * p0, "synchronized momentum {sync:e}");
    assert!(ang < 1e-6 * l0, "angular momentum {ang:e}");
    assert!(
        (3.0..5.5).contains(&(ang / ang2)),
        "order: {ang:e} → {ang2:e}"
    );
}

/// The swinging pendulum of check 3 run for `duration` with step `h` (watchdog of
/// `mbdc run`): (the run, the largest error of the total energy, the largest error of the
/// mesh's own balance, the largest mismatch of the energy the tie moves between the arm and
/// the bar, the peak kinetic energy).
fn swinging(h: f64, duration: f64) -> (Trajectory, f64, f64, f64, f64) {
    let mut scene = turned(
        load_text(&pendulum("20 MPa", "angular_velocity (0, 0, 3) rad/s")),
        0.5,
    );
    // the arm turns about the hinge: its mass centre moves at ω × r
    let r = scene.bodies[0].position;
    scene.bodies[0].velocity = [-3.0 * r[1], 3.0 * r[0], 0.0];
    let tr = simulate_watched(&scene, method("staggered"), h, duration, 10);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let e0 = tr.frames[0].energy();
    let worst = |f: &dyn Fn(&Rec) -> f64| tr.frames.iter().skip(1).map(f).fold(0.0, f64::max);
    let total = worst(&|r| (r.energy() - e0).abs());
    let mesh = worst(&|r| r.mesh.energy.mesh_balance().abs());
    // total − mesh balance = the arm's energy change + the tie's work on the bar
    let coupling = worst(&|r| (r.energy() - e0 - r.mesh.energy.mesh_balance()).abs());
    let peak = worst(&|r| r.kinetic);
    (tr, total, mesh, coupling, peak)
}

/// Check 3: the energy balance over a vibrating tied mesh on a moving body. The pendulum
/// with a soft bar (E = 20 MPa: its first bending mode at ω₁ ≈ 101 rad/s, 15× the
/// pendulum's), turned by 0.5 rad and started with the arm turning about the hinge at
/// 3 rad/s while the bar is at rest: the tie jerks the bar into bending vibration (its
/// peak strain energy is 14 % of the peak kinetic energy) as the pendulum swings. Over 10⁴
/// steps of 0.45 of the critical step (0.9 s, about one period) the run's total energy —
/// the bodies' kinetic energy (the arm with the tied nodes), gravity, and the mesh's
/// kinetic and strain energy less the work of its loads (its weight as a body force) —
/// stays within 1e-3 of the peak kinetic energy (measured 5.1e-4), and `mbdc run`'s
/// watchdog, which checks the energy growth of this scene (it has no energy sources),
/// stays quiet. The error is the central difference's own (the jerk excites the mesh's
/// highest modes): it falls 4-fold when h is halved (3 to 5.5), and the energy the tie
/// moves between arm and bar matches on both sides (the arm's energy change against the
/// tie's work in the mesh's own balance) to 1e-4 of the peak kinetic energy (measured
/// 7.4e-5), also at second order.
#[test]
fn the_energy_of_a_vibrating_tied_mesh_on_a_swinging_arm_balances() {
    let h = 0.5 * step_of(&load_text(&pendulum("20 MPa", "")));
    let (tr, total, mesh, coupling, peak) = swinging(h, 1e4 * h);
    let (_, total2, _, coupling2, _) = swinging(h / 2.0, 1e4 * h);
    let me = |r: &Rec| r.mesh.energy;
    let strain = tr.frames.iter().map(|r| me(r).strain).fold(0.0, f64::max);
    let tie = tr
        .frames
        .iter()
        .map(|r| me(r).tie_work.abs())
        .fold(0.0, f64::max);
    eprintln!(
        "peak kinetic {peak:.4e} J: total energy error {total:.3e} J ({:.2e}), at h/2 {total2:.3e} J; mesh balance {mesh:.3e} J; tie mismatch {coupling:.3e} J ({:.2e}), at h/2 {coupling2:.3e} J; peak strain {strain:.3e} J, tie work up to {tie:.3e} J; drift reported {:.3e}; h = {h:.3e} s",
        total / peak,
        coupling / peak,
        tr.report.max_energy_drift
    );
    assert!(tr.report.warnings.is_empty(), "{:?}", tr.report.warnings);
    assert!(
        total < 1e-3 * peak,
        "energy error {total:e} J, peak {peak:e} J"
    );
    assert!(
        tr.report.max_energy_drift < 1e-3,
        "drift {}",
        tr.report.max_energy_drift
    );
    assert!(
        (3.0..5.5).contains(&(total / total2)),
        "order: {total:e} → {total2:e}"
    );
    assert!(coupling < 1e-4 * peak, "tie mismatch {coupling:e} J");
    assert!(
        (3.0..5.5).contains(&(coupling / coupling2)),
        "order: {coupling:e} → {coupling2:e}"
    );
    // the bar does vibrate, and the tie does work on it
    assert!(
        strain > 0.05 * peak && tie > 0.2 * peak,
        "strain {strain:e} J, tie {tie:e} J"
    );
}

/// The outputs give the body at its own mass centre (the system integrates it at the
/// mass centre of body and tied nodes): the first frame has the scene's position and
/// velocity, and at every frame each tied node is where the body's own frame carries it,
/// `x = r + C s` with `s = C₀ᵀ(X − r₀)` from the scene (to 1e-12 m), its velocity
/// `v + C(ω × s)` (to 1e-10 m/s).
#[test]
fn outputs_give_the_tied_body_at_its_own_mass_centre() {
    let scene = free_hub();
    let h = step_of(&scene);
    let tr = simulate(&scene, method("staggered"), h, 200.0 * h, 10);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let b = &scene.bodies[0];
    let f0 = &tr.frames[0];
    assert!((f0.pose[0].r - Vector3::from(b.position)).norm() < 1e-15);
    assert!((f0.twist[0].v - Vector3::from(b.velocity)).norm() < 1e-15);
    let r0 = Vector3::from(b.position);
    let m = &scene.meshes[0];
    let root: Vec<usize> = m.node_sets[0].nodes.clone();
    assert_eq!(root.len(), 9);
    let (mut dx, mut dv) = (0.0f64, 0.0f64);
    for f in &tr.frames {
        let (p, t) = (&f.pose[0], &f.twist[0]);
        for &n in &root {
            let x0 = Vector3::from(m.nodes[n]);
            let s = x0 - r0; // the hub starts unturned
            let u = Vector3::from(f.mesh.u[n]);
            let v = Vector3::from(f.mesh.v[n]);
            dx = dx.max((x0 + u - (p.r + p.c * s)).norm());
            dv = dv.max((v - (t.v + p.c * t.w.cross(&s))).norm());
        }
    }
    assert!(
        dx < 1e-12 && dv < 1e-10,
        "tied nodes off the body: {dx:e} m, {dv:e} m/s"
    );
}

/// Methods that cannot take the tie's forces refuse before the first step, naming the mesh,
/// the set and the body: coordinate partitioning and the implicit trapezoid (forces at the
/// step's end), staggered with two leapfrog sequences, and the dynamic relaxation.
#[test]
fn methods_that_cannot_couple_a_tie_refuse_naming_it() {
    let scene = free_hub();
    let h = step_of(&scene);
    let mut two = method("staggered");
    if let mbdc_runtime::scene::MethodSpec::Staggered(o) = &mut two {
        o.gyroscopic = mbdc_runtime::scene::Gyroscopic::Synchronous;
    }
    let mut relax = method("staggered");
    if let mbdc_runtime::scene::MethodSpec::Staggered(o) = &mut relax {
        o.relaxation = mbdc_runtime::scene::Relaxation::Kinetic;
    }
    for m in [
        method("coordinate_partitioning"),
        method("implicit_trapezoid"),
        two,
        relax,
    ] {
        let tr = simulate(&scene, m.clone(), h, 10.0 * h, 1);
        let f = tr.report.failure.expect("refused");
        assert!(
            f.cause
                .contains("mesh 'plate': set 'root' is tied to body 'hub'")
                && f.cause.contains("use staggered"),
            "{}: {}",
            m.name(),
            f.cause
        );
        assert_eq!(tr.report.steps, 0);
    }
    for m in ["baumgarte", "penalty", "natural_partitioning"] {
        let tr = simulate(&scene, method(m), h, 50.0 * h, 10);
        assert!(tr.report.finished, "{m}: {:?}", tr.report.failure);
    }
}

/// A 2-D mesh tied to a body that leaves the mesh's plane stops the run at that step,
/// naming the mesh and the set.
#[test]
fn a_two_dimensional_tie_out_of_its_plane_stops_the_run() {
    let scene = load_text(
        r#"
model tilted {
  material alu { E 70 GPa; nu 0.33; rho 2700 kg/m^3 }
  body hub { mass 1 kg; inertia diag(1, 1, 1) g*m^2; angular_velocity (5, 0, 0) rad/s }
  mesh sheet {
    element quad4
    thickness 1 mm
    generate rect(origin: (0, 0) m, size: (0.1, 0.02) m, divisions: (5, 1))
    material alu
    set root = nodes(x == 0)
    tie root, hub
  }
  simulate { duration 1 ms; step 0.1 us }
}
"#,
    );
    let h = step_of(&scene);
    let tr = simulate(&scene, method("staggered"), h, 100.0 * h, 1);
    let f = tr.report.failure.expect("stopped");
    assert!(
        f.cause.contains("mesh 'sheet'")
            && f.cause.contains("tied set 'root'")
            && f.cause.contains("out of the mesh's plane"),
        "{}",
        f.cause
    );
}

/// `models/mesh_on_pendulum.mbd`, the numbers of its header: released horizontal, the arm
/// with its tied aluminium panel passes the vertical after `K(sin 45°)/ω₀` = 0.351396 s
/// turning at `√(2 M g d / I_O)` = 7.4618 rad/s (the rigid composite, the panel's lumped
/// masses included), within 1e-4 (the panel's flexibility, `(ω₀/ω₁)²` ≈ 2.4e-6, and the
/// time discretization are far below; the sudden release sets the panel vibrating, which
/// the mean rate below averages out); the header's critical step is the runtime's.
#[test]
fn the_panel_on_the_swinging_arm_passes_the_vertical_as_the_rigid_composite() {
    let scene = load_model("mesh_on_pendulum.mbd");
    let limit = step_of(&scene) / 0.9;
    assert!(
        (limit / 5.4e-6 - 1.0).abs() < 0.01,
        "critical step {limit:e} s"
    );
    let tr = simulate(&scene, method("staggered"), scene.simulate.step, 0.36, 5);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    let z = zero_crossings(&tr, |r| angle(r) + std::f64::consts::FRAC_PI_2);
    let t = z.first().copied().expect("passes the vertical");
    // The arm's angular velocity carries the panel's bending vibration (±2e-4 of it, at
    // ω₁): take the mean rate over ±1 ms (two vibration periods), `(φ(t+Δ) − φ(t−Δ))/2Δ`,
    // whose own error is `(ω₀Δ)²/6` ≈ 5e-6 at the vertical (where the angular
    // acceleration vanishes).
    let at = |t: f64| {
        let k = tr
            .frames
            .iter()
            .position(|r| r.t >= t)
            .expect("a frame after");
        let (a, b) = (&tr.frames[k - 1], &tr.frames[k]);
        angle(a) + (angle(b) - angle(a)) * (t - a.t) / (b.t - a.t)
    };
    let dt = 1e-3;
    let w = (at(t + dt) - at(t - dt)) / (2.0 * dt);
    let (i_o, mgd) = (0.0987326_f64, 9.81 * (0.2 + 0.1458 * 0.55));
    let w0 = (mgd / i_o).sqrt();
    let (t_ref, w_ref) = (1.854_074_677_301_372 / w0, -(2.0 * mgd / i_o).sqrt());
    eprintln!(
        "vertical at {t:.7} s (reference {t_ref:.7}, {:.1e}), ω {w:.5} rad/s (reference {w_ref:.5}, {:.1e})",
        t / t_ref - 1.0,
        w / w_ref - 1.0
    );
    assert!((t / t_ref - 1.0).abs() < 1e-4, "{t} s against {t_ref} s");
    assert!(
        (w / w_ref - 1.0).abs() < 1e-4,
        "{w} rad/s against {w_ref} rad/s"
    );
}
