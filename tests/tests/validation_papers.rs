//! Validation against the papers' own examples (issue 3, checks 4–7). The papers give few
//! numbers (notes C §6); each test says what it reproduces, what it measures instead where
//! the data are missing, and why (see also docs/methods.md).

use mbdc_runtime::scene::{LintForm, MethodSpec, StaggeredOptions};
use mbdc_tests::*;

fn staggered(epsilon: Option<f64>) -> MethodSpec {
    MethodSpec::Staggered(StaggeredOptions {
        epsilon,
        ..Default::default()
    })
}

/// Check 4. The closed four-bar of C3 (four bars, five spherical joints, F_y = 1 N on bars 1
/// and 4, 8 s). The paper: stable with acceptable accuracy for h < 0.075, and responses that
/// show the symmetry of the configuration. Reference for accuracy: the same method at
/// h = 1 ms. Tolerances: at h = 0.07 the run finishes with |Φ| < 1e-10 m and bar 1's mass
/// centre within 1e-3 m of the reference at t = 7 s (measured 3e-4); the mirror image of bar 4
/// (x ↦ 3 − x) follows bar 1 to 1e-12 m, and the joint forces at the two ground joints have
/// equal magnitudes to 1e-5 relative at every step (λ is resolved to about
/// tol_Φ/(h²K) ≈ 1e-13 m/(1e-6 s²/kg) = 1e-7 N by the LINT's Newton tolerance at h = 1 ms).
#[test]
fn four_bar_stable_below_0075_and_symmetric() {
    let scene = load_model("four_bar.mbd");
    let fine = simulate(&scene, staggered(None), 1e-3, 7.0, 1000);
    let coarse = simulate(&scene, staggered(None), 0.07, 7.0, 1);
    assert!(
        fine.report.finished && coarse.report.finished,
        "{:?}",
        coarse.report.failure
    );
    assert!(coarse.max_violation() < 1e-10, "{}", coarse.max_violation());
    let gap = (fine.last().pose[0].r - coarse.last().pose[0].r).norm();
    let moved = fine
        .frames
        .iter()
        .map(|f| (f.pose[0].r - fine.frames[0].pose[0].r).norm())
        .fold(0.0, f64::max);
    eprintln!("bar 1 moves up to {moved:.3} m; h = 0.07 vs 1 ms at t = 7 s: {gap:.2e} m");
    assert!(moved > 0.02, "the arch must move ({moved} m)");
    assert!(gap < 1e-3, "{gap}");
    for tr in [&fine, &coarse] {
        for f in &tr.frames {
            let (a, b) = (f.pose[0].r, f.pose[3].r);
            let asym = (a.x - (3.0 - b.x))
                .abs()
                .max((a.y - b.y).abs())
                .max((a.z - b.z).abs());
            assert!(asym < 1e-12, "t = {}: asymmetry {asym}", f.t);
            let l0 = (f.lambda[0].powi(2) + f.lambda[1].powi(2) + f.lambda[2].powi(2)).sqrt();
            let l4 = (f.lambda[12].powi(2) + f.lambda[13].powi(2) + f.lambda[14].powi(2)).sqrt();
            assert!(
                (l0 - l4).abs() < 1e-5 * (1.0 + l0),
                "t = {}: |λ_j0| {l0} vs |λ_j4| {l4}",
                f.t
            );
        }
    }
}

/// Check 5a. The bowling ball of C3 with its mass centred: rolling without slip along
/// y = sin x at constant speed (no work is done: the ball's centre stays at height a and the
/// steering force is normal to the path). Reference: that periodicity — ω and λ repeat each
/// time the ball passes the same phase of the sine, x = 2πk m. Tolerance: at h = 0.15 s (the
/// paper's step), ω and λ at x = 2π and x = 4π agree to 1e-3 relative (measured 2e-5; the
/// crossing times are interpolated linearly between steps).
#[test]
fn bowling_ball_centred_is_periodic() {
    let scene = load_model("bowling_ball.mbd");
    let tr = simulate(&scene, staggered(Some(1e-6)), 0.15, 130.0, 1);
    assert!(tr.report.finished, "{:?}", tr.report.failure);
    // values at the crossings of x = 2πk, interpolated
    let at = |x0: f64| -> Vec<f64> {
        for w in tr.frames.windows(2) {
            let (a, b) = (w[0].pose[0].r.x, w[1].pose[0].r.x);
            if a < x0 && b >= x0 {
                let s = (x0 - a) / (b - a);
                let mut v: Vec<f64> = (0..3)
                    .map(|c| w[0].twist[0].w[c] * (1.0 - s) + w[1].twist[0].w[c] * s)
                    .collect();
                v.extend(
                    (0..w[0].lambda.len()).map(|r| w[0].lambda[r] * (1.0 - s) + w[1].lambda[r] * s),
                );
                return v;
            }
        }
        panic!("x = {x0} not reached in {} s", tr.last().t);
    };
    let tau = 2.0 * std::f64::consts::PI;
    let (p1, p2) = (at(tau), at(2.0 * tau));
    let scale = p1.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let diff = p1
        .iter()
        .zip(&p2)
        .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
    eprintln!(
        "ω, λ at x = 2π: {p1:.6?}\n        at x = 4π: {p2:.6?}\nrelative difference {:.2e}",
        diff / scale
    );
    assert!(diff < 1e-3 * scale, "not periodic: {}", diff / scale);
}

/// Check 5b. The offset bowling ball (mass centre 0.15a from the geometric centre; our reading
/// of Table 1): the default update evaluates the gyroscopic terms at a synchronous ω (by the
/// implicit midpoint rule in one leapfrog sequence; the paper's exchange between two sequences
/// gives the same orders here), the conventional single-stage update (C3 eq. 41) uses the
/// lagged ω^{n−1/2}. The paper reports the two-stage scheme stable at h = 0.15 where the
/// single-stage one diverges at h = 0.2 (Fig. 7). With our parameters (the paper's J₁, J₂, r₀
/// and the unit of x are not recoverable) neither diverges in 12 s, but the difference the
/// paper describes shows as accuracy: reference the implicit trapezoid at h = 0.5 ms; the
/// synchronous error in ω converges at order 2 (measured 2.1) and the single-stage one at
/// order 1 (measured 1.2), and the single-stage error at h = 0.2 is more than twice the
/// synchronous error at h = 0.15 (measured 2.5). See docs/methods.md.
#[test]
fn bowling_ball_offset_two_stage_against_single_stage() {
    let text = std::fs::read_to_string(model_path("bowling_ball.mbd")).unwrap();
    let loaded =
        mbdc_compiler::load_str("bowling_ball.mbd", &text, &["r0=1.635cm".parse().unwrap()]);
    let scene = loaded.scene.expect("scene");
    let dur = 12.0;
    let reference = simulate(&scene, method("implicit_trapezoid"), 5e-4, dur, 20);
    let at = |tr: &Trajectory, t: f64| {
        tr.frames
            .iter()
            .min_by(|a, b| (a.t - t).abs().total_cmp(&(b.t - t).abs()))
            .unwrap()
            .twist[0]
            .w
    };
    let error = |single: bool, h: f64| {
        let o = StaggeredOptions {
            single_stage: single,
            ..Default::default()
        };
        let tr = simulate(&scene, MethodSpec::Staggered(o), h, dur, 1);
        assert!(
            tr.report.finished,
            "single={single} h={h}: {:?}",
            tr.report.failure
        );
        (1..=24)
            .map(|k| (at(&tr, k as f64 * 0.5) - at(&reference, k as f64 * 0.5)).norm())
            .fold(0.0, f64::max)
    };
    let two = [error(false, 0.05), error(false, 0.025)];
    let one = [error(true, 0.05), error(true, 0.025)];
    let (p2, p1) = ((two[0] / two[1]).log2(), (one[0] / one[1]).log2());
    let (two_015, one_02) = (error(false, 0.15), error(true, 0.2));
    eprintln!("two-stage errors {two:?} (order {p2:.2}), single-stage {one:?} (order {p1:.2}); two-stage at 0.15: {two_015:.3e}, single-stage at 0.2: {one_02:.3e}");
    assert!((p2 - 2.0).abs() < 0.3, "two-stage order {p2}");
    assert!((p1 - 1.0).abs() < 0.3, "single-stage order {p1}");
    assert!(one_02 > 2.0 * two_015, "{one_02} vs {two_015}");
}

/// Check 6. The crank mechanism of the stabilization paper (C2-E2): h = 0.01, one cycle
/// (0.82 s), staggered stabilization with ε = 1e-6 against Baumgarte with α = β = 70. The
/// paper reports a pin-joint error of about 1e-5 for the staggered method and about two
/// orders of magnitude more for Baumgarte. Measured here: 3.9e-5 against 1.1e-3, a ratio of
/// 29; we assert a ratio above 10. The difference from the paper's 100: both methods here
/// run on the explicit two-stage coordinate integrator (the paper used the trapezoidal rule),
/// where Baumgarte's rate term must use the lagged velocity; and the crank's dimensions are
/// ours. With the default ε rule the staggered error is at round-off (< 1e-9).
#[test]
fn crank_staggered_against_baumgarte() {
    let scene = load_model("slider_crank.mbd");
    let pin = 1; // joint index of the crank–rod pin
    let worst = |m: MethodSpec| {
        let tr = simulate(&scene, m, 0.01, 0.82, 1);
        assert!(tr.report.finished, "{:?}", tr.report.failure);
        tr.frames
            .iter()
            .fold(0.0f64, |a, f| a.max(f.violation[pin]))
    };
    let st = worst(staggered(Some(1e-6)));
    let bg = worst(MethodSpec::Baumgarte {
        alpha: 70.0,
        beta: 70.0,
    });
    let st_default = worst(staggered(None));
    eprintln!("pin error: staggered ε = 1e-6 {st:.2e}, Baumgarte α = β = 70 {bg:.2e} (ratio {:.1}), staggered default ε {st_default:.2e}", bg / st);
    assert!(st < 1e-4, "{st}");
    assert!(bg / st > 10.0, "ratio {}", bg / st);
    assert!(st_default < 1e-9, "{st_default}");
}

/// Check 7. The three-link deployment arm with lock-up (C2-E3 / notes A §2.A; our data, see
/// the model): the joints lock one after the other as they straighten, and at full extension
/// the guide's distance row becomes dependent on the others (the Jacobian loses rank). The
/// paper reports Baumgarte failing when the links line up and the staggered stabilization
/// converging. Checked:
/// - staggered (default ε) finishes, all three locks engage, the arm ends straight (tip within
///   1e-6 m of (3, 0)) with |Φ| < 1e-9, the LINT matrix's pivot ratio falls below 1e-6 on the
///   way (the configuration is singular), and halving the step changes the tip at t = 1.5 s by
///   less than 1e-6 m (converged);
/// - Baumgarte stops when the first lock engages (an acceleration-level law cannot absorb the
///   velocity jump) with a report naming a lock, long before full extension.
#[test]
fn deployment_arm_through_lock_up() {
    let scene = load_model("deployment_arm.mbd");
    let tip = |f: &Rec| f.pose[2].r + f.pose[2].c * nalgebra::Vector3::new(0.5, 0.0, 0.0);
    let a = simulate(&scene, staggered(None), 1e-3, 1.5, 10);
    let b = simulate(&scene, staggered(None), 5e-4, 1.5, 20);
    for tr in [&a, &b] {
        assert!(tr.report.finished, "{:?}", tr.report.failure);
    }
    let locks = a.last().lambda[16..].iter().filter(|l| **l != 0.0).count();
    let t = tip(a.last());
    let pivot = a
        .report
        .stats
        .iter()
        .find(|(n, _)| n == "min_pivot_ratio")
        .map(|s| s.1)
        .unwrap();
    let gap = (tip(a.last()) - tip(b.last())).norm();
    eprintln!("staggered: locks {locks}, tip {t:?}, max |Φ| {:.2e}, min pivot ratio {pivot:.2e}, h vs h/2 {gap:.2e} m", a.max_violation());
    assert_eq!(locks, 3);
    assert!((t.x - 3.0).abs() < 1e-6 && t.y.abs() < 1e-6, "{t:?}");
    assert!(a.max_violation() < 1e-9);
    assert!(pivot < 1e-6, "{pivot}");
    assert!(gap < 1e-6, "{gap}");
    let bg = simulate(
        &scene,
        MethodSpec::Baumgarte {
            alpha: 10.0,
            beta: 10.0,
        },
        1e-3,
        1.5,
        10,
    );
    let f = bg.report.failure.as_ref().expect("Baumgarte must stop");
    eprintln!("Baumgarte: {f}");
    assert!(f.location.contains("lock"), "{f}");
    assert!(f.time < 0.7, "{f}");
}

/// The paper's own LINT (the half-step midpoint rule of C3 eq. 34, corrected to h/8) on the
/// crank: documents why it is not the default (docs/methods.md). It leaves the constraint
/// modes undamped; on this mechanism it stops within the cycle.
#[test]
fn paper_midpoint_lint_on_the_crank() {
    let scene = load_model("slider_crank.mbd");
    let o = StaggeredOptions {
        epsilon: Some(1e-6),
        lint: LintForm::Midpoint,
        ..Default::default()
    };
    let tr = simulate(&scene, MethodSpec::Staggered(o), 0.01, 0.82, 1);
    eprintln!(
        "midpoint LINT: finished {}, {:?}",
        tr.report.finished,
        tr.report.failure.as_ref().map(|f| f.to_string())
    );
    assert!(!tr.report.finished || tr.max_violation() > 1e-3);
}
