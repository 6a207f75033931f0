//! Validation of `state_time` (docs/methods.md) on the planar double pendulum of the
//! state-time paper (notes F §2.1, `models/state_time_double_pendulum.mbd`).
//!
//! References:
//! - notes F §5: θ1 = 0.902914, θ2 = 1.407019 rad and E = −0.891676 J at t = 5 s (DOP853
//!   at 1e-12 with I = m l²/12; the values of the exact solution, not of a state-time run);
//! - an independent RK4 integration of the pendulum's Lagrangian ODE in absolute angles
//!   below, at a step of 1/64 of the sampling step (its error is below 1e-9 here; it is
//!   checked against the notes' values first).

use mbdc_runtime::integrators::state_time::StateTime;
use mbdc_runtime::integrators::{Integrator, State};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::scene::MethodSpec;
use mbdc_tests::{load_model, load_model_with, method, simulate};
use nalgebra::Vector3;

const M1: f64 = 1.0;
const L1: f64 = 0.8;
const M2: f64 = 0.5;
const L2: f64 = 1.0;
const G: f64 = 2.0;

/// θ̈ of the double pendulum (absolute angles from the downward vertical, rods with
/// I = m l²/12 about their centres), from its Lagrangian.
fn accel(y: [f64; 4]) -> [f64; 4] {
    let (t1, t2, w1, w2) = (y[0], y[1], y[2], y[3]);
    let (i1, i2) = (M1 * L1 * L1 / 12.0, M2 * L2 * L2 / 12.0);
    let k = M2 * L1 * L2 / 2.0;
    let (s, c) = (t1 - t2).sin_cos();
    let m11 = M1 * L1 * L1 / 4.0 + i1 + M2 * L1 * L1;
    let m22 = M2 * L2 * L2 / 4.0 + i2;
    let m12 = k * c;
    let r1 = -k * s * w2 * w2 - (M1 * L1 / 2.0 + M2 * L1) * G * t1.sin();
    let r2 = k * s * w1 * w1 - M2 * L2 / 2.0 * G * t2.sin();
    let det = m11 * m22 - m12 * m12;
    [
        w1,
        w2,
        (m22 * r1 - m12 * r2) / det,
        (m11 * r2 - m12 * r1) / det,
    ]
}

/// The reference angles at `t = k·dt`, `k = 0 … n`, by RK4 with 64 substeps per `dt`.
fn reference(dt: f64, n: usize) -> Vec<[f64; 2]> {
    let mut y = [1.0, 1.2, 1.0, -1.0];
    let h = dt / 64.0;
    let mut out = vec![[y[0], y[1]]];
    for _ in 0..n {
        for _ in 0..64 {
            let k1 = accel(y);
            let k2 = accel(std::array::from_fn(|i| y[i] + 0.5 * h * k1[i]));
            let k3 = accel(std::array::from_fn(|i| y[i] + 0.5 * h * k2[i]));
            let k4 = accel(std::array::from_fn(|i| y[i] + h * k3[i]));
            for i in 0..4 {
                y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
        out.push([y[0], y[1]]);
    }
    out
}

/// The absolute angles of the two rods in a state (rotation about z from the initial
/// orientation, the identity, plus the initial angles).
fn angles(s: &State) -> [f64; 2] {
    let a = |b: usize, q0: f64| {
        let q = s.pose[b].q;
        q0 + 2.0 * q.k.atan2(q.w)
    };
    [a(0, 1.0), a(1, 1.2)]
}

fn wrap(x: f64) -> f64 {
    x - std::f64::consts::TAU * (x / std::f64::consts::TAU).round()
}

/// A run of `elements` elements over 5 s with `spe` steps per element and windows of
/// `window` elements: the states at every step, the method's statistics and its notice at
/// the end.
fn run(elements: usize, spe: u32, window: usize) -> (Vec<State>, Stats, Option<String>) {
    let scene = load_model_with(
        "state_time_double_pendulum.mbd",
        &[&format!("elements={elements}")],
    );
    let sys = Interp::new(&scene).expect("interpretable");
    let start = State::initial(&sys);
    let h = 5.0 / (elements as f64 * f64::from(spe));
    let mut st = StateTime::new(&sys, h, spe, window, &start).expect("starts");
    let mut out = vec![start.clone()];
    let mut s = start;
    for _ in 0..elements * spe as usize {
        st.step(&sys).expect("step");
        Integrator::<Interp>::state(&st, &sys, &mut s);
        out.push(s.clone());
    }
    let notice = Integrator::<Interp>::end_notice(&st);
    (out, Integrator::<Interp>::stats(&st), notice)
}

type Stats = Vec<(&'static str, f64)>;

/// Two runs' states are the same bits: poses, twists and multipliers.
fn assert_identical(a: &[State], b: &[State]) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        assert_eq!(x.pose, y.pose);
        assert_eq!(x.twist, y.twist);
        assert_eq!(x.lambda, y.lambda);
    }
}

/// `f` in a rayon pool of `threads` threads.
fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool")
        .install(f)
}

fn stat(stats: &[(&'static str, f64)], name: &str) -> f64 {
    stats.iter().find(|s| s.0 == name).expect(name).1
}

fn report_stat(stats: &[(String, f64)], name: &str) -> f64 {
    stats.iter().find(|s| s.0 == name).expect(name).1
}

#[test]
fn the_rk4_reference_reproduces_the_notes_values_at_5_s() {
    let r = reference(5.0 / 64.0, 64);
    let last = r[64];
    assert!((last[0] - 0.902914).abs() < 1e-6, "θ1 {}", last[0]);
    assert!((last[1] - 1.407019).abs() < 1e-6, "θ2 {}", last[1]);
}

/// `mbdc run` of the model: 64 elements, 4 steps each, one window; θ1, θ2 and the energy
/// at 5 s against notes F §5 (the state-time solution's nodal error at 64 elements is
/// about 5e-4 there).
#[test]
fn double_pendulum_at_5_s_matches_the_reference() {
    let scene = load_model("state_time_double_pendulum.mbd");
    let m = scene.simulate.method.clone();
    let h = scene.simulate.step;
    let t = simulate(&scene, m, h, 5.0, 1_000_000);
    assert!(t.report.failure.is_none(), "{:?}", t.report.failure);
    let last = t.last();
    assert!((last.t - 5.0).abs() < 1e-9);
    let s = State {
        t: last.t,
        pose: last.pose.clone(),
        twist: last.twist.clone(),
        ..State::default()
    };
    let [q1, q2] = angles(&s);
    let e = last.energy();
    eprintln!(
        "t = 5 s: θ1 = {q1:.6}, θ2 = {q2:.6}, E = {e:.6}; stats {:?}",
        t.report.stats
    );
    assert!(wrap(q1 - 0.902914).abs() < 1e-3, "θ1 = {q1}");
    assert!(wrap(q2 - 1.407019).abs() < 1e-3, "θ2 = {q2}");
    assert!((e - -0.891676).abs() < 1e-3, "E = {e}");
    let eq = t
        .report
        .stats
        .iter()
        .find(|s| s.0 == "equations_per_window");
    assert_eq!(eq.map(|s| s.1), Some(1540.0));
}

/// L2 error of θ1 and θ2 over 5 s against the RK4 reference: about third order (notes F
/// §1.10: O(h³) in L2; §5: L2(θ1) = 1.03e-4 at 64 elements).
#[test]
fn l2_error_is_about_third_order() {
    let spe = 8;
    let mut errs = Vec::new();
    for elements in [32usize, 64, 128] {
        let (states, stats, _) = run(elements, spe, elements);
        let n = elements * spe as usize;
        let dt = 5.0 / n as f64;
        let r = reference(dt, n);
        let mut sum = [0.0; 2];
        for (k, s) in states.iter().enumerate() {
            let a = angles(s);
            let w = if k == 0 || k == n { 0.5 } else { 1.0 } * dt;
            for i in 0..2 {
                sum[i] += w * wrap(a[i] - r[k][i]).powi(2);
            }
        }
        let l2 = sum.map(f64::sqrt);
        eprintln!(
            "{elements} elements: L2 θ1 = {:.3e}, θ2 = {:.3e}, Newton iterations {}",
            l2[0],
            l2[1],
            stat(&stats, "newton_iterations_max")
        );
        errs.push(l2);
    }
    for i in 0..2 {
        let order = (errs[1][i] / errs[2][i]).log2();
        assert!((2.5..4.5).contains(&order), "order {order} ({errs:?})");
    }
    assert!(errs[1][0] < 2e-4, "L2 θ1 at 64 elements {}", errs[1][0]);
}

/// Windows of 16 elements hand over the end state (positions and the
/// momentum-consistent velocities): the result differs from one window of 64 elements
/// only by the discretization error (the forces at a window's end are fixed by that
/// window's equations alone): measured 4.3e-3 rad over 5 s of this chaotic motion at two
/// steps per element, against 5e-4 rad for the single window's own error at the end.
#[test]
fn windows_agree_with_one_window() {
    let (one, _, _) = run(64, 2, 64);
    let (four, stats, _) = run(64, 2, 16);
    assert_eq!(stat(&stats, "windows"), 4.0);
    let mut worst = 0.0f64;
    for (a, b) in one.iter().zip(&four) {
        let (x, y) = (angles(a), angles(b));
        worst = worst
            .max(wrap(x[0] - y[0]).abs())
            .max(wrap(x[1] - y[1]).abs());
    }
    eprintln!("windows of 16 vs 64: largest angle difference {worst:.3e}");
    assert!(worst < 1e-2, "{worst}");
}

/// A window too large to factor is refused before the first step, saying which window
/// would fit: the spatial chain of 100 links (in a horizontal plane, gravity across it: the
/// spatial reading) has 3300 unknowns per element, and the LU of even one element would be
/// too large; 8 links have 264 per element, and a window of 64 of them would take about
/// 850 MB.
#[test]
fn a_window_too_large_is_refused_with_one_that_fits() {
    for (n, expected) in [
        ("N=100", "3300 unknowns; the sparse LU of even a one-element window"),
        ("N=8", "16896 unknowns (264 per element); its sparse LU would take about 850 MB, more than the limit of 128 MB: set `window 9` or less"),
    ] {
        let scene = load_model_with("bench/chain_spatial.mbd", &[n]);
        let t = simulate(&scene, method("state_time"), 1e-4, 1e-3, 1);
        let f = t.report.failure.expect("refused");
        assert!(f.cause.contains(expected), "{n}: {}", f.cause);
        assert_eq!(f.step, 0, "before the first step");
    }
}

/// The assembly runs over the elements in parallel; the results are identical on 1 and 2
/// threads.
#[test]
fn one_and_two_threads_give_identical_results() {
    let on = |threads: usize| on_threads(threads, || run(64, 1, 32).0);
    assert_identical(&on(1), &on(2));
}

/// The direction cosines' drift from orthonormal is reported, and a run whose elements do
/// not resolve the rotation (8 elements over 5 s: some 0.6 s and up to a radian of turn
/// each) warns at its end; 64 elements keep the drift below the warning level.
#[test]
fn unresolved_rotations_warn_at_the_end() {
    use mbdc_runtime::integrators::state_time::COSINE_DRIFT_WARNING;
    let (_, fine, quiet) = run(64, 1, 64);
    let drift = stat(&fine, "max_cosine_drift");
    eprintln!("64 elements: cosine drift {drift:.2e}");
    assert!(drift > 0.0 && drift < COSINE_DRIFT_WARNING, "{drift}");
    assert_eq!(quiet, None);
    let (_, coarse, notice) = run(8, 1, 8);
    let drift = stat(&coarse, "max_cosine_drift");
    eprintln!("8 elements: cosine drift {drift:.2e}");
    let notice = notice.expect("a coarse run warns");
    assert!(notice.contains("direction cosines drifted"), "{notice}");
}

/// A two-link chain falling from the horizontal in short elements (0.4 ms: the bench
/// model's 0.1 ms step, four steps each): the window's Newton iteration used to stall at
/// round-off (updates of 1e-10 against a tolerance of 1e-11 on forces of 10 N) and the run
/// stopped. It runs, and its links end where natural partitioning at a tenth of the step
/// puts them (second order there: its own error is about 1e-9 m; the state-time solution's
/// is smaller still). Tolerance 1e-6 m.
#[test]
fn short_elements_converge_and_match_natural_partitioning() {
    let scene = load_model_with("bench/chain_planar.mbd", &["N=2", "L=0.5 m", "m=1.0 kg"]);
    let st = simulate(
        &scene,
        MethodSpec::default_for("state_time").unwrap(),
        1e-4,
        0.1,
        1000,
    );
    assert!(st.report.failure.is_none(), "{:?}", st.report.failure);
    let np = MethodSpec::default_for("natural_partitioning").unwrap();
    let reference = simulate(&scene, np, 1e-5, 0.1, 10_000);
    let (a, b) = (st.last(), reference.last());
    assert!((a.t - b.t).abs() < 1e-9);
    let d = a
        .pose
        .iter()
        .zip(&b.pose)
        .map(|(p, q)| (p.r - q.r).norm())
        .fold(0.0, f64::max);
    eprintln!("state_time vs natural_partitioning at 0.1 s: {d:.2e} m");
    assert!(d < 1e-6, "{d}");
}

/// The spatial reading of the planar pendulum: fifteen fields per body instead of five, but
/// in the plane its discrete equations are those of the planar reading (Poisson's rows
/// `ċᵢ = cᵢ × ω` reduce to `ċ = −ω s`, `ṡ = ω c`; the out-of-plane unknowns stay at their
/// start values). The two runs' positions and velocities agree to the Newton tolerance: a
/// check of both readings. (Their orientations differ by the discretization error: the
/// planar reading turns a body by its angle `q`, the spatial one takes the rotation nearest
/// to the cosines `C`, as it must in space.)
#[test]
fn the_spatial_reading_of_the_planar_pendulum_equals_the_planar_reading() {
    let scene = load_model_with("state_time_double_pendulum.mbd", &["elements=32"]);
    let sys = Interp::new(&scene).expect("interpretable");
    let start = State::initial(&sys);
    let (spe, h) = (2u32, 5.0 / 64.0);
    let mut planar = StateTime::new(&sys, h, spe, 32, &start).expect("starts");
    let mut spatial = StateTime::spatial(&sys, h, spe, 32, &start).expect("starts");
    assert!(planar.is_planar() && !spatial.is_planar());
    let (mut a, mut b) = (start.clone(), start);
    let mut worst = 0.0f64;
    for _ in 0..64 {
        planar.step(&sys).expect("planar step");
        spatial.step(&sys).expect("spatial step");
        Integrator::<Interp>::state(&planar, &sys, &mut a);
        Integrator::<Interp>::state(&spatial, &sys, &mut b);
        for (p, q) in a.pose.iter().zip(&b.pose) {
            worst = worst.max((p.r - q.r).norm());
        }
        for (v, w) in a.twist.iter().zip(&b.twist) {
            worst = worst.max((v.v - w.v).norm()).max((v.w - w.w).norm());
        }
    }
    eprintln!("planar vs spatial reading over 5 s: {worst:.2e}");
    assert!(worst < 1e-10, "{worst}");
}

/// The heavy top of `models/hard/top.mbd` (spinning at 100 rad/s about its axis, a
/// spherical joint at its tip) started on steady precession: its axis must turn about the
/// vertical at Ω ≈ 2.632 rad/s with the tilt fixed at 30° (Goldstein §5.7,
/// `mbdc_tests::top`), so the exact axis is `R_z(Ω t) a₀`. Over 0.5 s the largest distance
/// of the computed axis from it falls with the element length at about third order, and
/// the direction cosines' drift from orthonormal at about second order.
#[test]
fn heavy_top_precesses_steadily_and_converges() {
    use mbdc_tests::top;
    let scene = load_model("hard/top.mbd");
    let omega = top::precession_rate();
    let a0 = Vector3::new(0.0, -top::theta().sin(), top::theta().cos());
    let mut errs = Vec::new();
    for h in [1e-3, 5e-4, 2.5e-4, 1.25e-4] {
        let spec = MethodSpec::StateTime {
            steps_per_element: 2,
            window: 64,
        };
        let t = simulate(&scene, spec, h, 0.5, 1);
        assert!(t.report.failure.is_none(), "{:?}", t.report.failure);
        let axis = t
            .frames
            .iter()
            .map(|f| {
                let exact =
                    nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), omega * f.t) * a0;
                (f.pose[0].c * Vector3::z() - exact).norm()
            })
            .fold(0.0, f64::max);
        let drift = report_stat(&t.report.stats, "max_cosine_drift");
        eprintln!(
            "h = {h:.2e}: axis error {axis:.2e}, cosine drift {drift:.2e}, stats {:?}",
            t.report.stats
        );
        errs.push([axis, drift]);
    }
    // measured: axis 6.4e-4, 9.2e-5, 2.9e-5, 7.6e-6; drift 2.2e-3, 5.6e-4, 1.4e-4, 2.3e-5
    let order = |i: usize| (errs[0][i] / errs[3][i]).log2() / 3.0;
    for (i, what) in [(0, "axis"), (1, "cosine drift")] {
        assert!(
            (1.8..3.5).contains(&order(i)),
            "{what}: order {} ({errs:?})",
            order(i)
        );
    }
    assert!(errs[3][0] < 1.5e-5, "axis error {errs:?}");
    assert!(errs[3][1] < 5e-5, "drift {errs:?}");
}

/// The three-dimensional double pendulum of `models/double_pendulum_3d.mbd` (two bars on
/// spherical joints, spinning about the vertical and falling) over 1 s against Dormand–Prince
/// 8(5,3) on the tree coordinates at a tolerance of 1e-12 (an independent method: its
/// error is below 1e-10 m here): the L2 error of the mass centres falls at about third
/// order, and the cosines' drift with it.
#[test]
fn spatial_double_pendulum_converges_to_a_tight_reference() {
    let scene = load_model("double_pendulum_3d.mbd");
    let reference = simulate(
        &scene,
        MethodSpec::DormandPrince853 { tolerance: 1e-12 },
        1e-3,
        1.0,
        1,
    );
    assert!(reference.report.failure.is_none());
    let mut errs = Vec::new();
    for spe in [8u32, 4, 2] {
        let spec = MethodSpec::StateTime {
            steps_per_element: spe,
            window: 64,
        };
        let t = simulate(&scene, spec, 1e-3, 1.0, 1);
        assert!(t.report.failure.is_none(), "{:?}", t.report.failure);
        let l2 = (t
            .frames
            .iter()
            .zip(&reference.frames)
            .map(|(a, b)| mbdc_tests::position_difference(a, b).powi(2) * 1e-3)
            .sum::<f64>())
        .sqrt();
        let drift = report_stat(&t.report.stats, "max_cosine_drift");
        eprintln!(
            "element {} ms: L2 error {l2:.2e} m, cosine drift {drift:.2e}, stats {:?}",
            spe, t.report.stats
        );
        errs.push([l2, drift]);
    }
    // measured: L2 2.5e-5, 6.5e-6, 1.6e-6 m; drift 6.7e-5, 1.5e-5, 2.3e-6
    for k in 0..2 {
        let order = (errs[k][0] / errs[k + 1][0]).log2();
        assert!((1.7..3.5).contains(&order), "order {order} ({errs:?})");
        assert!(errs[k + 1][1] < errs[k][1] / 3.0, "drift {errs:?}");
    }
    assert!(errs[2][0] < 3e-6, "L2 {errs:?}");
}

/// The spatial window's assembly runs over the elements in parallel too; the results are
/// identical on 1 and 2 threads (the heavy top, 0.05 s, 12.5 windows of 4 elements).
#[test]
fn spatial_runs_are_identical_on_1_and_2_threads() {
    let scene = load_model("hard/top.mbd");
    let sys = Interp::new(&scene).expect("interpretable");
    let on = |threads: usize| {
        on_threads(threads, || {
            let start = State::initial(&sys);
            let mut st = StateTime::new(&sys, 5e-4, 2, 4, &start).expect("starts");
            assert!(!st.is_planar());
            let mut s = start;
            let mut out = Vec::new();
            for _ in 0..100 {
                st.step(&sys).expect("step");
                Integrator::<Interp>::state(&st, &sys, &mut s);
                out.push(s.clone());
            }
            out
        })
    };
    assert_identical(&on(1), &on(2));
}

/// Scenes outside the method's scope are refused with the joint and why: a revolute joint
/// in a scene whose motion leaves the plane (here the rod of `pendulum.mbd` also turns
/// about an axis across the hinge).
#[test]
fn a_revolute_joint_in_a_spatial_scene_is_refused_with_the_reason() {
    let text = std::fs::read_to_string(mbdc_tests::model_path("pendulum.mbd")).expect("model");
    let text = text.replace(
        "orientation axis_angle((0, 1, 0), theta0)",
        "orientation axis_angle((0, 1, 0), theta0)\n    angular_velocity (1, 0, 0) rad/s",
    );
    let scene = mbdc_tests::load_text(&text);
    let sys = Interp::new(&scene).expect("interpretable");
    let start = State::initial(&sys);
    let err = StateTime::new(&sys, 1e-3, 4, 64, &start)
        .err()
        .expect("refused")
        .to_string();
    assert!(
        err.contains("joint 'pivot' (revolute)")
            && err.contains("initial velocity leaves the plane"),
        "{err}"
    );
}
