//! Order, accuracy, tolerance and constraint tests of the Runge–Kutta methods against exact
//! solutions: the torque-free symmetric top (closed form), the large-amplitude pendulum of
//! models/pendulum.mbd (Jacobi elliptic functions), random trees of every tree joint kind.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use super::tableau::{Tableau, DOP853, DOPRI5, RK4};
use super::*;
use crate::contract::math::quat_array;
use crate::contract::scene::{Attachment, Body, BodyRef, Joint, JointKind, Origin, Scene};
use crate::contract::system::Twist;
use crate::contract::system::{ConstraintEval, Need};
use crate::interp::Interp;
use crate::kernels::fn1::{ellipk, jacobi_sn};

fn scene(bodies: Vec<Body>, joints: Vec<Joint>, gravity: Option<[f64; 3]>) -> Scene {
    Scene {
        name: "rk".into(),
        gravity,
        bodies,
        joints,
        forces: Vec::new(),
        beams: Vec::new(),
        meshes: Vec::new(),
        contacts: Vec::new(),
        simulate: Default::default(),
        reference: None,
        params: Vec::new(),
    }
}

/// Run `tab` (fixed step `h`, or error-controlled with `tol`) over `steps` steps, calling
/// `check` with every reported state.
fn run(
    sys: &Interp,
    tab: &'static Tableau,
    h: f64,
    tol: Option<f64>,
    steps: usize,
    mut check: impl FnMut(&State),
) -> RungeKutta {
    let start = State::initial(sys);
    let mut it = RungeKutta::new(sys, tab, h, tol, &start).expect("start");
    let mut out = State::initial(sys);
    for _ in 0..steps {
        it.step(sys).expect("step");
        Integrator::<Interp>::state(&it, sys, &mut out);
        check(&out);
    }
    it
}

/// The least-squares slope of log(err) against log(h).
fn slope(h: &[f64], e: &[f64]) -> f64 {
    let x: Vec<f64> = h.iter().map(|v| v.ln()).collect();
    let y: Vec<f64> = e.iter().map(|v| v.ln()).collect();
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

// ---------------------------------------------------------------------------------------
// Torque-free symmetric top

const TOP_J: [f64; 3] = [1.0, 1.0, 2.0];
const TOP_W0: [f64; 3] = [0.6, 0.0, 1.5];
const TOP_V0: [f64; 3] = [0.3, -0.2, 0.1];

fn top() -> Interp {
    let b = Body {
        name: "top".into(),
        mass: 1.0,
        inertia: [
            [TOP_J[0], 0.0, 0.0],
            [0.0, TOP_J[1], 0.0],
            [0.0, 0.0, TOP_J[2]],
        ],
        position: [0.0; 3],
        orientation: quat_array(&Quaternion::identity()),
        velocity: TOP_V0,
        angular_velocity: TOP_W0,
        origin: Origin::default(),
    };
    Interp::new(&scene(vec![b], Vec::new(), None)).unwrap()
}

/// The exact motion of the torque-free symmetric top (`J = diag(I, I, I₃)`, from the
/// identity): `R(t) = exp(t [L]/I) exp(−t λ [e₃])`, `λ = ω₃ (I₃ − I)/I`, `L = J ω₀`.
fn top_exact(t: f64) -> (Vector3<f64>, UnitQuaternion<f64>) {
    let (i, i3) = (TOP_J[0], TOP_J[2]);
    let l = Vector3::new(i * TOP_W0[0], i * TOP_W0[1], i3 * TOP_W0[2]);
    let lam = TOP_W0[2] * (i3 - i) / i;
    let e = UnitQuaternion::from_scaled_axis(l * (t / i));
    let f = UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, -lam * t));
    (Vector3::from(TOP_V0) * t, e * f)
}

/// Position and rotation-angle error of the top at the end of `duration`.
fn top_error(tab: &'static Tableau, h: f64, tol: Option<f64>, duration: f64) -> f64 {
    let sys = top();
    let steps = (duration / h).round() as usize;
    let mut last = State::default();
    run(&sys, tab, h, tol, steps, |s| last = s.clone());
    let (r, q) = top_exact(last.t);
    let got = UnitQuaternion::from_quaternion(last.pose[0].q);
    let angle = (q.inverse() * got).angle();
    (last.pose[0].r - r).norm().max(angle)
}

#[test]
fn rk4_is_fourth_order_on_the_torque_free_top() {
    let hs = [0.1, 0.05, 0.025, 0.0125];
    let e: Vec<f64> = hs.iter().map(|&h| top_error(&RK4, h, None, 2.0)).collect();
    let p = slope(&hs, &e);
    eprintln!("rk4 top: errors {e:?}, order {p:.3}");
    assert!((p - 4.0).abs() < 0.3, "order {p} ({e:?})");
}

#[test]
fn dopri5_is_fifth_order_on_the_torque_free_top() {
    let hs = [0.2, 0.1, 0.05, 0.025];
    let e: Vec<f64> = hs
        .iter()
        .map(|&h| top_error(&DOPRI5, h, None, 2.0))
        .collect();
    let p = slope(&hs, &e);
    eprintln!("dopri5 top: errors {e:?}, order {p:.3}");
    assert!((p - 5.0).abs() < 0.3, "order {p} ({e:?})");
}

/// DOP853 at fixed steps on the top's closed form over 8 s: eighth order. The steps are
/// coarse: at h = 0.05 the error is at round-off (~1e-15) already.
#[test]
fn dop853_is_eighth_order_on_the_torque_free_top() {
    let hs = [0.4, 0.2, 0.1];
    let e: Vec<f64> = hs
        .iter()
        .map(|&h| top_error(&DOP853, h, None, 8.0))
        .collect();
    let p = slope(&hs, &e);
    eprintln!("dop853 top: errors {e:?}, order {p:.3}");
    assert!((p - 8.0).abs() < 0.3, "order {p} ({e:?})");
}

/// A free asymmetric body (models/torque_free.mbd, near its unstable intermediate axis,
/// which flips it): energy and |L| drift under dopri5 at 1e-10 over 20 s, and |q| = 1.
#[test]
fn free_body_energy_and_momentum_drift() {
    let b = Body {
        name: "brick".into(),
        mass: 1.0,
        inertia: [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]],
        position: [0.0; 3],
        orientation: quat_array(&Quaternion::identity()),
        velocity: [0.0; 3],
        angular_velocity: [0.01, 2.0, 0.0],
        origin: Origin::default(),
    };
    let sys = Interp::new(&scene(vec![b], Vec::new(), None)).unwrap();
    let j = Vector3::new(1.0, 2.0, 3.0);
    let inv = |s: &State| {
        let w = s.twist[0].w;
        let e = 0.5 * w.dot(&j.component_mul(&w));
        let l = (s.pose[0].c * j.component_mul(&w)).norm();
        (e, l)
    };
    let s0 = State::initial(&sys);
    let (e0, l0) = inv(&s0);
    let (mut de, mut dl, mut dq) = (0.0f64, 0.0f64, 0.0f64);
    let it = run(&sys, &DOPRI5, 0.05, Some(1e-10), 400, |s| {
        let (e, l) = inv(s);
        de = de.max((e - e0).abs() / e0);
        dl = dl.max((l - l0).abs() / l0);
        dq = dq.max((s.pose[0].q.norm() - 1.0).abs());
    });
    let st = Integrator::<Interp>::stats(&it);
    eprintln!("brick: energy drift {de:.2e}, |L| drift {dl:.2e}, |q| − 1 {dq:.1e}; {st:?}");
    assert!(de < 1e-8 && dl < 1e-8, "energy {de:e}, |L| {dl:e}");
    assert!(dq < 1e-14);
}

// ---------------------------------------------------------------------------------------
// Large-amplitude pendulum (models/pendulum.mbd)

const L: f64 = 1.0;
const R: f64 = 0.01;
const THETA0: f64 = 120.0 * std::f64::consts::PI / 180.0;
const G: f64 = 9.81;

fn pendulum() -> Interp {
    let d = L / 2.0;
    let jt = (3.0 * R * R + L * L) / 12.0;
    let q = UnitQuaternion::from_scaled_axis(Vector3::new(0.0, THETA0, 0.0));
    let body = Body {
        name: "rod".into(),
        mass: 1.0,
        inertia: [[jt, 0.0, 0.0], [0.0, jt, 0.0], [0.0, 0.0, R * R / 2.0]],
        position: [-d * THETA0.sin(), 0.0, -d * THETA0.cos()],
        orientation: quat_array(q.quaternion()),
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        origin: Origin::default(),
    };
    // the joint axis (frame z) along world y
    let fy = quat_array(
        UnitQuaternion::from_scaled_axis(Vector3::new(-std::f64::consts::FRAC_PI_2, 0.0, 0.0))
            .quaternion(),
    );
    let pivot = Joint {
        name: "pivot".into(),
        kind: JointKind::Revolute,
        a: Attachment {
            body: BodyRef::Ground,
            point: [0.0; 3],
            frame: fy,
        },
        b: Attachment {
            body: BodyRef::Body(0),
            point: [0.0, 0.0, d],
            frame: fy,
        },
        origin: Origin::default(),
    };
    Interp::new(&scene(vec![body], vec![pivot], Some([0.0, 0.0, -G]))).unwrap()
}

/// The exact mass-centre position: `sin(θ/2) = k sn(K(m) − ω₀ t | m)`.
fn pendulum_exact(t: f64) -> Vector3<f64> {
    let d = L / 2.0;
    let jp = (3.0 * R * R + L * L) / 12.0 + d * d;
    let w0 = (G * d / jp).sqrt();
    let k = (THETA0 / 2.0).sin();
    let m = k * k;
    let th = 2.0 * (k * jacobi_sn(ellipk(m) - w0 * t, m)).asin();
    Vector3::new(-d * th.sin(), 0.0, -d * th.cos())
}

/// The largest position error over the reported states, and the largest joint violation.
fn pendulum_run(tab: &'static Tableau, h: f64, tol: Option<f64>, duration: f64) -> (f64, f64) {
    let sys = pendulum();
    let steps = (duration / h).round() as usize;
    let mut ce = ConstraintEval::new(sys.layout().rows);
    let (mut err, mut phi) = (0.0f64, 0.0f64);
    run(&sys, tab, h, tol, steps, |s| {
        err = err.max((s.pose[0].r - pendulum_exact(s.t)).norm());
        sys.constraints(s.t, &s.pose, &s.twist, Need::PHI, &mut ce);
        phi = ce.phi.iter().fold(phi, |a, p| a.max(p.abs()));
    });
    (err, phi)
}

/// Fixed-step orders on the pendulum's elliptic-function solution (largest position error
/// over the frames of 1 s). dop853's band is wider: its leading error term is small on this
/// problem, so over the steps where its error stays above round-off the ratios per halving
/// are 286, 410 and 326 (local orders 8.2, 8.7 and 8.3) rather than 2⁸ = 256.
#[test]
fn measured_orders_on_the_pendulum() {
    for (tab, hs, want, band) in [
        (&RK4, [0.02, 0.01, 0.005, 0.0025], 4.0, 0.3),
        (&DOPRI5, [0.04, 0.02, 0.01, 0.005], 5.0, 0.3),
        (&DOP853, [0.2, 0.1, 0.05, 0.025], 8.0, 0.5),
    ] {
        assert_order("pendulum", tab, &hs, want, band, |h| {
            pendulum_run(tab, h, None, 1.0)
        });
    }
}

/// The fitted order of `tab` over the steps `hs` is within `band` of `want`, and every run
/// keeps the joints within 1e-13; `run(h)` gives a run's (error, largest violation).
fn assert_order(
    scene: &str,
    tab: &Tableau,
    hs: &[f64],
    want: f64,
    band: f64,
    run: impl Fn(f64) -> (f64, f64),
) {
    let runs: Vec<(f64, f64)> = hs.iter().map(|&h| run(h)).collect();
    let e: Vec<f64> = runs.iter().map(|r| r.0).collect();
    let phi = runs.iter().map(|r| r.1).fold(0.0, f64::max);
    let p = slope(hs, &e);
    eprintln!(
        "{} {scene}: errors {e:?}, order {p:.3}, max |Φ| {phi:.1e}",
        tab.name
    );
    assert!((p - want).abs() < band, "{}: order {p} ({e:?})", tab.name);
    assert!(phi < 1e-13, "{}: joint violation {phi:e}", tab.name);
}

/// dopri5 driven by its tolerance: the true error (vs the elliptic-function solution,
/// over every output frame of 2 s) is within 10× of the tolerance, and falls with it.
#[test]
fn dopri5_true_error_follows_the_tolerance() {
    let mut prev = f64::INFINITY;
    for tol in [1e-5, 1e-7, 1e-9] {
        let (err, phi) = pendulum_run(&DOPRI5, 0.05, Some(tol), 2.0);
        eprintln!("dopri5 tol {tol:e}: true error {err:.2e}, max |Φ| {phi:.1e}");
        assert!(err < 10.0 * tol, "tol {tol:e}: error {err:e}");
        assert!(err < prev);
        assert!(phi < 1e-13, "joint violation {phi:e}");
        prev = err;
    }
}

/// dop853 driven by its tolerance, down to 1e-12: the true error (vs the elliptic-function
/// solution, over every output frame of 2 s, most of them from the seventh-order dense
/// output) is within 10× of the tolerance and falls with it.
#[test]
fn dop853_true_error_follows_the_tolerance() {
    let mut prev = f64::INFINITY;
    for tol in [1e-6, 1e-8, 1e-10, 1e-12] {
        let (err, phi) = pendulum_run(&DOP853, 0.25, Some(tol), 2.0);
        eprintln!("dop853 tol {tol:e}: true error {err:.2e}, max |Φ| {phi:.1e}");
        assert!(err < 10.0 * tol, "tol {tol:e}: error {err:e}");
        assert!(err < prev);
        assert!(phi < 1e-13, "joint violation {phi:e}");
        prev = err;
    }
}

/// Work against precision on the pendulum (2 s, 0.25 s output step): at tight tolerances
/// dop853 reaches the same true error as dopri5 with fewer right-hand-side evaluations
/// (docs/methods.md quotes these numbers).
#[test]
fn dop853_costs_less_than_dopri5_at_tight_tolerances() {
    let evals = |tab: &'static Tableau, tol: f64| {
        let sys = pendulum();
        let mut err = 0.0f64;
        let it = run(&sys, tab, 0.25, Some(tol), 8, |s| {
            err = err.max((s.pose[0].r - pendulum_exact(s.t)).norm());
        });
        let st = Integrator::<Interp>::stats(&it);
        let n = st.iter().find(|(k, _)| *k == "rhs_evaluations").unwrap().1;
        (n, err)
    };
    for tol in [1e-6, 1e-8, 1e-10, 1e-12] {
        let (n5, e5) = evals(&DOPRI5, tol);
        let (n8, e8) = evals(&DOP853, tol);
        eprintln!(
            "tol {tol:e}: dopri5 {n5} evaluations, error {e5:.1e}; dop853 {n8}, error {e8:.1e}"
        );
        if tol <= 1e-10 {
            assert!(e8 < 10.0 * tol && e5 < 10.0 * tol, "{e5:e} {e8:e}");
            assert!(
                n8 < n5,
                "tol {tol:e}: dop853 {n8} vs dopri5 {n5} evaluations"
            );
        }
    }
}

/// The cost of dop853 as docs/methods.md states it: one evaluation at the start, then 12
/// per accepted step (11 stages and the FSAL stage at the result), 11 per rejected step,
/// and 3 more for each output that falls inside a step (dense output); none when every
/// step ends on an output time.
#[test]
fn dop853_evaluates_the_dense_stages_only_for_an_output_inside_a_step() {
    let sys = pendulum();
    let count = |it: &RungeKutta| {
        let st: std::collections::HashMap<_, _> =
            Integrator::<Interp>::stats(it).into_iter().collect();
        let n = |k: &str| st[k] as u64;
        (
            n("rhs_evaluations"),
            n("internal_steps"),
            n("rejected_steps"),
            n("dense_outputs"),
        )
    };
    // loose tolerance, short output step: every internal step is the output step
    let it = run(&sys, &DOP853, 1e-3, Some(1e-6), 200, |_| ());
    let (ev, acc, rej, dense) = count(&it);
    assert_eq!((acc, rej, dense), (200, 0, 0));
    assert_eq!(ev, 1 + 12 * acc);
    // long output step: the outputs fall inside steps
    let it = run(&sys, &DOP853, 0.25, Some(1e-10), 8, |_| ());
    let (ev, acc, rej, dense) = count(&it);
    eprintln!(
        "dop853 pendulum: {acc} steps, {rej} rejected, {dense} dense outputs, {ev} evaluations"
    );
    assert!(dense > 0 && acc > 8, "{acc} steps, {dense} dense outputs");
    assert_eq!(ev, 1 + 12 * acc + 11 * rej + 3 * dense);
}

/// dop853 saved in the middle of a run (stage derivatives, FSAL stage, controller, dense
/// output bookkeeping) and loaded into a fresh integrator continues bit for bit as the run
/// straight through, with outputs inside steps: on the pendulum, and on the closed
/// parallelogram (its reported cut multipliers too).
#[test]
fn dop853_restarts_bitwise() {
    restarts_bitwise(pendulum(), 0.05);
    restarts_bitwise(parallelogram(), 0.25);
}

/// [`dop853_restarts_bitwise`] on `sys` with output step `h`, saved after 17 of 40 steps.
fn restarts_bitwise(sys: Interp, h: f64) {
    use crate::contract::persist::{Loader, Saver};
    let start = State::initial(&sys);
    let (tol, n, k) = (Some(1e-10), 40, 17);
    let mut straight = RungeKutta::new(&sys, &DOP853, h, tol, &start).unwrap();
    let mut a = State::initial(&sys);
    for _ in 0..n {
        straight.step(&sys).unwrap();
    }
    Integrator::<Interp>::state(&straight, &sys, &mut a);
    let mut first = RungeKutta::new(&sys, &DOP853, h, tol, &start).unwrap();
    for _ in 0..k {
        first.step(&sys).unwrap();
    }
    let mut saver = Saver::new();
    assert!(Integrator::<Interp>::persist(&mut first, &mut saver));
    let bytes = saver.into_bytes();
    let mut second = RungeKutta::new(&sys, &DOP853, h, tol, &start).unwrap();
    let mut loader = Loader::new(&bytes);
    assert!(Integrator::<Interp>::persist(&mut second, &mut loader));
    loader.finish().unwrap();
    for _ in k..n {
        second.step(&sys).unwrap();
    }
    let mut b = State::initial(&sys);
    Integrator::<Interp>::state(&second, &sys, &mut b);
    let dense = Integrator::<Interp>::stats(&second)
        .into_iter()
        .find(|(k, _)| *k == "dense_outputs")
        .unwrap()
        .1;
    assert!(dense > 0.0);
    assert_eq!(a.t.to_bits(), b.t.to_bits());
    for (p, q) in a.pose.iter().zip(&b.pose) {
        for (x, y) in
            p.r.iter()
                .chain(p.q.coords.iter())
                .zip(q.r.iter().chain(q.q.coords.iter()))
        {
            assert_eq!(x.to_bits(), y.to_bits(), "pose {x} vs {y}");
        }
    }
    for (p, q) in a.twist.iter().zip(&b.twist) {
        for (x, y) in
            p.v.iter()
                .chain(p.w.iter())
                .zip(q.v.iter().chain(q.w.iter()))
        {
            assert_eq!(x.to_bits(), y.to_bits(), "twist {x} vs {y}");
        }
    }
    for (x, y) in a.lambda.iter().zip(&b.lambda) {
        assert_eq!(x.to_bits(), y.to_bits(), "λ {x} vs {y}");
    }
}

/// Random trees of every tree joint kind (natural partitioning's test scenes): the joints
/// stay at round-off at every output under every method, and dopri5 and dop853 match a
/// much finer rk4 run.
#[test]
fn random_trees_keep_joints_at_round_off() {
    use crate::linalg::testutil::Rng;
    for seed in [21u64, 22, 23] {
        let mut rng = Rng::new(seed);
        let sc = crate::integrators::natural::tests::random_scene(&mut rng, 6, 0);
        let mut sys = Interp::new(&sc).unwrap();
        // the initial state assembled onto the tree
        let st0 = State::initial(&sys);
        let mut nat = Natural::new(&sys, 1e-3, None, 1e-12, &st0).unwrap();
        let (mut pose, mut vel) = (st0.pose.clone(), st0.twist.clone());
        nat.tree_project(&sys, &mut pose, &mut vel);
        sys.set_initial_state(&pose, &vel);
        let mut ce = ConstraintEval::new(sys.layout().rows);
        let mut finals = Vec::new();
        for (tab, h, tol) in [
            (&RK4, 1e-3, None),
            (&DOPRI5, 0.01, Some(1e-10)),
            (&DOP853, 0.01, Some(1e-10)),
        ] {
            let mut phi = 0.0f64;
            let mut last = State::default();
            run(&sys, tab, h, tol, (0.5 / h).round() as usize, |s| {
                sys.constraints(s.t, &s.pose, &s.twist, Need::PHI, &mut ce);
                phi = ce.phi.iter().fold(phi, |a, p| a.max(p.abs()));
                last = s.clone();
            });
            eprintln!("seed {seed} {}: max |Φ| {phi:.1e}", tab.name);
            assert!(phi < 1e-12, "seed {seed} {}: violation {phi:e}", tab.name);
            finals.push(last);
        }
        for (i, name) in [(1, "dopri5"), (2, "dop853")] {
            let d = finals[0]
                .pose
                .iter()
                .zip(&finals[i].pose)
                .map(|(a, b)| (a.r - b.r).norm())
                .fold(0.0, f64::max);
            eprintln!("seed {seed}: rk4 vs {name} {d:.1e}");
            assert!(d < 1e-6, "seed {seed}: rk4 and {name} differ by {d:e}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// Closed loops

/// Parallelogram: cranks of length `PL`, ground link and coupler of length `PW`.
const PL: f64 = 1.0;
const PW: f64 = 1.5;
const PM_C: f64 = 2.0;
const PTHETA0: f64 = 60.0 * std::f64::consts::PI / 180.0;

/// A parallelogram linkage hanging under gravity, closed by four revolute joints (one of
/// them cut: five rows, three of them redundant in the plane): two equal cranks (rods of
/// 1 kg) from ground pivots `PW` apart, a coupler of `PM_C` that translates. Released at
/// rest with the cranks at `PTHETA0` from the vertical.
fn parallelogram() -> Interp {
    let d = PL / 2.0;
    let jt = (3.0 * R * R + PL * PL) / 12.0;
    let q = UnitQuaternion::from_scaled_axis(Vector3::new(0.0, PTHETA0, 0.0));
    let (s, c) = PTHETA0.sin_cos();
    let crank = |name: &str, x: f64| Body {
        name: name.into(),
        mass: 1.0,
        inertia: [[jt, 0.0, 0.0], [0.0, jt, 0.0], [0.0, 0.0, R * R / 2.0]],
        position: [x - d * s, 0.0, -d * c],
        orientation: quat_array(q.quaternion()),
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        origin: Origin::default(),
    };
    let coupler = Body {
        name: "coupler".into(),
        mass: PM_C,
        inertia: [[0.01, 0.0, 0.0], [0.0, 0.4, 0.0], [0.0, 0.0, 0.4]],
        position: [PW / 2.0 - PL * s, 0.0, -PL * c],
        orientation: quat_array(&Quaternion::identity()),
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        origin: Origin::default(),
    };
    // the joint axes (frame z) along world y, which is every body's y
    let fy = quat_array(
        UnitQuaternion::from_scaled_axis(Vector3::new(-std::f64::consts::FRAC_PI_2, 0.0, 0.0))
            .quaternion(),
    );
    let att = |body: BodyRef, point: [f64; 3]| Attachment {
        body,
        point,
        frame: fy,
    };
    let rev = |name: &str, a: Attachment, b: Attachment| Joint {
        name: name.into(),
        kind: JointKind::Revolute,
        a,
        b,
        origin: Origin::default(),
    };
    let joints = vec![
        rev(
            "pivot1",
            att(BodyRef::Ground, [0.0; 3]),
            att(BodyRef::Body(0), [0.0, 0.0, d]),
        ),
        rev(
            "pivot2",
            att(BodyRef::Ground, [PW, 0.0, 0.0]),
            att(BodyRef::Body(1), [0.0, 0.0, d]),
        ),
        rev(
            "pin1",
            att(BodyRef::Body(0), [0.0, 0.0, -d]),
            att(BodyRef::Body(2), [-PW / 2.0, 0.0, 0.0]),
        ),
        rev(
            "pin2",
            att(BodyRef::Body(1), [0.0, 0.0, -d]),
            att(BodyRef::Body(2), [PW / 2.0, 0.0, 0.0]),
        ),
    ];
    let bodies = vec![crank("crank1", 0.0), crank("crank2", PW), coupler];
    Interp::new(&scene(bodies, joints, Some([0.0, 0.0, -G]))).unwrap()
}

/// The parallelogram's exact crank angle: a pendulum with `J θ̈ = −K sin θ`,
/// `J = 2(j_t + m d²) + m_c L²`, `K = g(2 m d + m_c L)`, so
/// `sin(θ/2) = k sn(K(m) − ω₀ t | m)` with `ω₀² = K/J`.
fn parallelogram_exact(t: f64) -> f64 {
    let d = PL / 2.0;
    let jt = (3.0 * R * R + PL * PL) / 12.0;
    let j = 2.0 * (jt + d * d) + PM_C * PL * PL;
    let k_grav = G * (2.0 * d + PM_C * PL);
    let w0 = (k_grav / j).sqrt();
    let k = (PTHETA0 / 2.0).sin();
    let m = k * k;
    2.0 * (k * jacobi_sn(ellipk(m) - w0 * t, m)).asin()
}

/// Largest position error of the three mass centres over the reported states of
/// `duration`, largest violation of any row, and whether every reported multiplier of the
/// cut rows was finite and not all zero.
fn parallelogram_run(
    tab: &'static Tableau,
    h: f64,
    tol: Option<f64>,
    duration: f64,
) -> (f64, f64, RungeKutta) {
    let sys = parallelogram();
    let steps = (duration / h).round() as usize;
    let mut ce = ConstraintEval::new(sys.layout().rows);
    let (mut err, mut phi) = (0.0f64, 0.0f64);
    let d = PL / 2.0;
    let it = run(&sys, tab, h, tol, steps, |s| {
        let (sn, cs) = parallelogram_exact(s.t).sin_cos();
        let want = [
            Vector3::new(-d * sn, 0.0, -d * cs),
            Vector3::new(PW - d * sn, 0.0, -d * cs),
            Vector3::new(PW / 2.0 - PL * sn, 0.0, -PL * cs),
        ];
        for (p, w) in s.pose.iter().zip(&want) {
            err = err.max((p.r - w).norm());
        }
        sys.constraints(s.t, &s.pose, &s.twist, Need::PHI, &mut ce);
        phi = ce.phi.iter().fold(phi, |a, p| a.max(p.abs()));
        assert!(s.lambda.iter().all(|l| l.is_finite()));
    });
    (err, phi, it)
}

/// A closed loop with redundant rows keeps each method's order against an exact solution
/// (the parallelogram's elliptic-function crank angle), with every joint at round-off at
/// every reported state; the measured orders match rk4's 4 and dopri5's 5.
#[test]
fn closed_loop_keeps_the_order_and_closes_at_round_off() {
    for (tab, hs, want, band) in [
        (&RK4, [0.04, 0.02, 0.01, 0.005], 4.0, 0.3),
        (&DOPRI5, [0.08, 0.04, 0.02, 0.01], 5.0, 0.3),
    ] {
        assert_order("parallelogram", tab, &hs, want, band, |h| {
            let (e, phi, _) = parallelogram_run(tab, h, None, 1.0);
            (e, phi)
        });
    }
}

/// dop853 on the closed loop, driven by its tolerance down to 1e-12: the true error is
/// within 10× of the tolerance, the loop closed at round-off, and three of the cut
/// revolute's five rows found void (out of the plane, where the tree cannot move).
#[test]
fn dop853_on_a_closed_loop_follows_the_tolerance() {
    let mut prev = f64::INFINITY;
    for tol in [1e-6, 1e-9, 1e-12] {
        let (err, phi, it) = parallelogram_run(&DOP853, 0.1, Some(tol), 2.0);
        let st = Integrator::<Interp>::stats(&it);
        let get = |k: &str| st.iter().find(|(n, _)| *n == k).unwrap().1;
        eprintln!(
            "dop853 parallelogram tol {tol:e}: true error {err:.2e}, max |Φ| {phi:.1e}; {st:?}"
        );
        assert!(err < 10.0 * tol, "tol {tol:e}: error {err:e}");
        assert!(err < prev);
        assert!(phi < 1e-13, "joint violation {phi:e}");
        assert_eq!(get("cut_rows_void"), 3.0);
        prev = err;
    }
}

/// Random closed loops (every joint kind, one or two cut joints): each method keeps every
/// row at round-off over 0.5 s, and the three agree.
#[test]
fn random_closed_loops_stay_closed() {
    use crate::linalg::testutil::Rng;
    for (seed, extra) in [(5u64, 1usize), (11, 2), (23, 1)] {
        let mut rng = Rng::new(seed);
        let mut sc = crate::integrators::natural::tests::random_scene(&mut rng, 5, extra);
        // the tree assembled, then each loop-closing joint's second point put where its
        // first is, so that the start closes every loop
        let sys = Interp::new(&sc).unwrap();
        let st0 = State::initial(&sys);
        let mut nat = Natural::new(&sys, 1e-3, None, 1e-12, &st0).unwrap();
        let (mut pose, mut vel) = (st0.pose.clone(), st0.twist.clone());
        nat.tree_project(&sys, &mut pose, &mut vel);
        for (b, p) in sc.bodies.iter_mut().zip(&pose) {
            b.position = p.r.into();
            b.orientation = quat_array(&p.q);
        }
        for j in sc.joints.iter_mut().filter(|j| j.name.starts_with('x')) {
            let BodyRef::Body(a) = j.a.body else {
                unreachable!("a loop joint's first side is a body")
            };
            let world = pose[a].r + pose[a].c * Vector3::from(j.a.point);
            j.b.point = match j.b.body {
                BodyRef::Body(b) => (pose[b].c.transpose() * (world - pose[b].r)).into(),
                BodyRef::Ground => world.into(),
            };
        }
        let sys = Interp::new(&sc).unwrap();
        let mut ce = ConstraintEval::new(sys.layout().rows);
        let st0 = State::initial(&sys);
        sys.constraints(0.0, &st0.pose, &st0.twist, Need::PHI, &mut ce);
        let phi0 = ce.phi.iter().fold(0.0f64, |a, p| a.max(p.abs()));
        assert!(
            phi0 < 1e-12,
            "seed {seed}: the start is off the loops by {phi0:e}"
        );
        let mut finals = Vec::new();
        for (tab, h, tol) in [
            (&RK4, 1e-3, None),
            (&DOPRI5, 0.01, Some(1e-10)),
            (&DOP853, 0.01, Some(1e-10)),
        ] {
            let start = State::initial(&sys);
            let mut it = match RungeKutta::new(&sys, tab, h, tol, &start) {
                Ok(it) => it,
                Err(e) => panic!("seed {seed} {}: {e}", tab.name),
            };
            let mut out = State::initial(&sys);
            let mut phi = 0.0f64;
            for _ in 0..(0.5 / h).round() as usize {
                it.step(&sys).expect("step");
                Integrator::<Interp>::state(&it, &sys, &mut out);
                sys.constraints(out.t, &out.pose, &out.twist, Need::PHI, &mut ce);
                phi = ce.phi.iter().fold(phi, |a, p| a.max(p.abs()));
            }
            eprintln!("seed {seed} {}: max |Φ| {phi:.1e}", tab.name);
            assert!(phi < 1e-12, "seed {seed} {}: violation {phi:e}", tab.name);
            finals.push(out);
        }
        for (i, name) in [(1, "dopri5"), (2, "dop853")] {
            let d = finals[0]
                .pose
                .iter()
                .zip(&finals[i].pose)
                .map(|(a, b)| (a.r - b.r).norm())
                .fold(0.0, f64::max);
            eprintln!("seed {seed}: rk4 vs {name} {d:.1e}");
            assert!(d < 1e-9, "seed {seed}: rk4 and {name} differ by {d:e}");
        }
    }
}

/// The stage accelerations on a closed loop equal the dense index-1 solution
/// `M ü = Q̄ − Bᵀλ`, `B ü = γ` over all rows ([`crate::integrators::common::Index1`]), an
/// independent solve, at a consistent state.
#[test]
fn loop_accelerations_equal_the_dense_index1_solution() {
    use crate::integrators::common::{qbar, Index1};
    let sys = parallelogram();
    let layout = sys.layout();
    let s = State::initial(&sys);
    let mut nat = Natural::new(&sys, 1e-3, None, 1e-12, &s).unwrap();
    let mut loops = Loops::new(&nat, layout, 1.0).unwrap();
    let (mut pose, mut vel) = (s.pose.clone(), s.twist.clone());
    // a consistent state in motion: the crank speeds of a swing
    for v in vel.iter_mut() {
        v.v = Vector3::new(0.3, 0.2, -0.1);
        v.w = Vector3::new(0.1, 0.7, 0.2);
    }
    loops
        .project(&mut nat, &sys, 0.0, &mut pose, &mut vel, false)
        .unwrap();
    let mut acc = vec![Twist::default(); layout.bodies()];
    loops
        .accelerations(&mut nat, &sys, 0.0, &pose, &vel, &mut acc, false)
        .unwrap();
    let mut ce = ConstraintEval::new(layout.rows);
    sys.constraints(0.0, &pose, &vel, Need::ALL, &mut ce);
    let mut ap = vec![Default::default(); layout.bodies()];
    sys.applied(0.0, &pose, &vel, &mut ap);
    let mut q = vec![Default::default(); layout.bodies()];
    qbar(layout, &ap, &vel, &mut q);
    let mut lam = vec![0.0; layout.rows];
    Index1::new(layout)
        .unwrap()
        .solve(layout, &ce, &q, &s.active, &mut lam)
        .unwrap();
    for r in 0..layout.rows {
        let (a, b) = layout.row_bodies(r);
        for (side, jac) in [(a, &ce.jac[r].a), (b, &ce.jac[r].b)] {
            if let Some(i) = side {
                q[i].f -= Vector3::new(jac[0], jac[1], jac[2]) * lam[r];
                q[i].t -= Vector3::new(jac[3], jac[4], jac[5]) * lam[r];
            }
        }
    }
    for (i, m) in layout.mass.iter().enumerate() {
        let (v, w) = (q[i].f / m.m, m.j_inv * q[i].t);
        let d = (v - acc[i].v).norm() + (w - acc[i].w).norm();
        eprintln!(
            "body {i}: dense {v:?} {w:?}, loops {:?} {:?}",
            acc[i].v, acc[i].w
        );
        assert!(d < 1e-9 * (1.0 + v.norm() + w.norm()), "body {i}: {d:e}");
    }
}
