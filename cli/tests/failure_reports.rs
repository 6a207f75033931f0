//! Each way a run can go wrong ends in a report (issue 7, "When a run goes wrong"): the
//! simulated time, the step, where (a body, a joint or the system), the quantity and its value,
//! the likely cause and what to try; a non-zero exit code; and an output folder that keeps every
//! frame written so far with a `summary.json` saying the run failed and why. Inconsistent scenes
//! are caught before the run: by `mbdc check` (by joint name and span) or by `--assemble`
//! (naming the joints in conflict). The stiff spring is refused before it starts.
//!
//! The PCG of natural partitioning that does not converge is `pcg_does_not_converge`.
//!
//! The constraint that drifts past its tolerance (the watchdog's violation check) is covered by
//! `run_models.rs` (`a_failing_run_reports_and_keeps_its_frames`, with the halve-step retry).

mod common;
use common::{command, last_frame, mbdc, root, s, scratch, summary};

use std::path::{Path, PathBuf};

/// Run `model` (a file) with `args` into a fresh folder; expect a failed run and check the
/// report and the folder. Returns the summary's `failure` object and the stderr.
fn failed_run(name: &str, model: &Path, args: &[&str]) -> (serde_json::Value, String) {
    let dir = scratch(name);
    let out_dir = dir.join("out");
    let mut all = vec!["run", "--interp", "-q", "-o", s(&out_dir)];
    all.extend_from_slice(args);
    all.push(s(model));
    let out = mbdc(&all);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        !out.status.success(),
        "{name}: the run should fail\n{stderr}"
    );
    for part in ["stopped at t =", "cause:", "help:", "every frame up to"] {
        assert!(stderr.contains(part), "{name}: no `{part}` in\n{stderr}");
    }
    let summary = summary(&out_dir);
    assert_eq!(summary["finished"], false, "{name}: {summary}");
    let f = summary["failure"].clone();
    for key in [
        "time", "step", "where", "quantity", "value", "cause", "hint",
    ] {
        assert!(!f[key].is_null(), "{name}: failure without `{key}`: {f}");
    }
    // every frame up to the failure is on disk: the header and at least the initial frame
    let (lines, last_t) = last_frame(&out_dir);
    assert!(lines >= 2, "{name}: bodies.csv has no frame");
    assert!(last_t <= f["time"].as_f64().unwrap() + 1e-12, "{name}");
    let _ = std::fs::remove_dir_all(&dir);
    (f, stderr)
}

fn write(dir: &Path, file: &str, text: &str) -> PathBuf {
    let p = dir.join(file);
    std::fs::write(&p, text).unwrap();
    p
}

/// NaN: a force that becomes NaN at t = 0.5 s (the square root of a negative number). The
/// report names the body and the time of the first non-finite state.
#[test]
fn nan_in_the_state() {
    let dir = scratch("nan-model");
    let model = write(
        &dir,
        "nan.mbd",
        "model nan_force {\n  body ball { mass 1 kg; inertia sphere(radius: 5 cm); position (0, 0, 0) }\n  force push = point(ball @ (0, 0, 0), (1 N * sqrt(0.5 - t / (1 s)), 0, 0))\n  simulate { duration 1 s; step 1 ms }\n}\n",
    );
    let (f, _) = failed_run("nan", &model, &[]);
    assert_eq!(f["where"], "body 'ball'", "{f}");
    assert!(f["quantity"].as_str().unwrap().contains("state"), "{f}");
    let t = f["time"].as_f64().unwrap();
    assert!((0.5..=0.503).contains(&t), "{f}");
    assert!(f["cause"].as_str().unwrap().contains("NaN"), "{f}");
}

/// Energy growing without a source: the stiff spring of models/hard/ run with an explicit
/// method at five times its stability limit (`--force` past the refusal).
#[test]
fn energy_growth_without_a_source() {
    let model = root().join("models/hard/stiff_spring.mbd");
    let (f, stderr) = failed_run("energy", &model, &["--method", "staggered", "--force"]);
    assert!(stderr.contains("running anyway: --force"), "{stderr}");
    assert_eq!(f["where"], "body 'mass1'", "{f}");
    assert!(
        f["quantity"].as_str().unwrap().contains("energy balance"),
        "{f}"
    );
    // growth: energy appeared
    assert!(f["value"].as_f64().unwrap() > 0.25, "{f}");
    assert!(f["cause"].as_str().unwrap().contains("appeared"), "{f}");
    assert!(
        f["hint"].as_str().unwrap().contains("implicit_trapezoid"),
        "{f}"
    );
}

/// Newton iteration that does not converge: the implicit trapezoid held to one iteration at a
/// tolerance it cannot reach in one.
#[test]
fn newton_does_not_converge() {
    let dir = scratch("newton-model");
    let text = std::fs::read_to_string(root().join("models/hard/stiff_spring.mbd"))
        .unwrap()
        .replace(
            "method implicit_trapezoid }",
            "method implicit_trapezoid { max_iterations 1; tolerance 1e-14 } }",
        );
    assert!(text.contains("max_iterations 1"));
    let model = write(&dir, "newton.mbd", &text);
    let (f, _) = failed_run("newton", &model, &[]);
    assert!(
        f["cause"].as_str().unwrap().contains("did not converge"),
        "{f}"
    );
    assert!(
        f["hint"].as_str().unwrap().contains("max_iterations"),
        "{f}"
    );
}

/// PCG that does not converge: natural partitioning on the ladder of 100 four-bars
/// (`models/bench/ladder.mbd`, 100 cut joints) with the cut-row PCG held to one iteration, where
/// the Jacobi-preconditioned Schur complement takes up to four. The report names the cut joint with
/// the largest residual and the option to raise.
#[test]
fn pcg_does_not_converge() {
    let dir = scratch("pcg-model");
    let text = std::fs::read_to_string(root().join("models/bench/ladder.mbd"))
        .unwrap()
        .replace(
            "method natural_partitioning",
            "method natural_partitioning { max_iterations 1 }",
        );
    assert!(text.contains("max_iterations 1"));
    let model = write(&dir, "ladder.mbd", &text);
    let (f, _) = failed_run("pcg", &model, &[]);
    assert!(f["quantity"].as_str().unwrap().contains("PCG"), "{f}");
    assert!(
        f["cause"]
            .as_str()
            .unwrap()
            .contains("did not converge in 1 iterations"),
        "{f}"
    );
    // the ladder's cut joints are rungs `rr[i]` or rail joints; a named joint, not "system"
    assert!(f["where"].as_str().unwrap().starts_with("joint '"), "{f}");
    assert!(f["value"].as_f64().unwrap() > 1e-3, "{f}");
    assert!(
        f["hint"].as_str().unwrap().contains("max_iterations"),
        "{f}"
    );
}

/// A singular matrix: Baumgarte's `B M⁻¹ Bᵀ` on the door with two coaxial hinges (five
/// dependent rows). The report names a hinge.
#[test]
fn singular_matrix() {
    let model = root().join("models/hard/door.mbd");
    let (f, _) = failed_run("singular", &model, &["--method", "baumgarte"]);
    let at = f["where"].as_str().unwrap();
    assert!(at == "joint 'lower'" || at == "joint 'upper'", "{f}");
    assert!(f["cause"].as_str().unwrap().contains("singular"), "{f}");
    assert!(f["hint"].as_str().unwrap().contains("staggered"), "{f}");
}

/// The constrained step check (issue 21): `light_over_heavy.mbd` has no spring, spin or pivot
/// the scene-level estimate sees, but its light bob between two loaded rods is a constrained
/// mode at 1400.77 rad/s (closed form of the double pendulum; `tests/tests/step_check.rs`).
/// `mbdc run` and `mbdc check` refuse an explicit method at 2 ms (h·ω = 2.8), naming the body,
/// the joint and the largest stable step 2/ω = 1.428e-3 s, and run it at its own 0.5 ms.
#[test]
fn a_constrained_mode_above_the_limit_is_refused_with_its_body_named() {
    let model = root().join("models/hard/light_over_heavy.mbd");
    let dir = scratch("light_over_heavy");
    let out = mbdc(&[
        "run",
        "--interp",
        "-q",
        "--step",
        "2e-3",
        "-o",
        s(&dir.join("refused")),
        s(&model),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    for part in [
        "above the stability limit",
        "constrained mode of body 'light'",
        "stiffened by joint",
        // 1400.77 at rest, 10⁻⁴ more with the scene's push (its centripetal load)
        "1.4009e3 rad/s",
        "at most 1.428e-3 s",
    ] {
        assert!(stderr.contains(part), "no `{part}` in\n{stderr}");
    }
    assert!(!dir.join("refused/bodies.csv").exists());
    let out = mbdc(&["run", "--interp", "-q", "-o", s(&dir.join("ok")), s(&model)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The stability estimate before the run: the stiff spring (ω = 1000 rad/s, h = 10 ms) is
/// refused for an explicit method with the numbers, and runs with its own
/// `implicit_trapezoid` and with `dopri5` and `dop853`, which step under the limit by
/// themselves.
#[test]
fn stiff_spring_is_refused_for_explicit_methods_and_runs_implicitly() {
    let model = root().join("models/hard/stiff_spring.mbd");
    let dir = scratch("stiff");
    let out = mbdc(&[
        "run",
        "--interp",
        "-q",
        "--method",
        "staggered",
        "-o",
        s(&dir.join("refused")),
        s(&model),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    for part in [
        "above the stability limit",
        "spring1",
        "1.0000e3 rad/s",
        "h·ω = 10.00 > 2",
        "at most 2.000e-3 s",
        "--force",
    ] {
        assert!(stderr.contains(part), "no `{part}` in\n{stderr}");
    }
    assert!(
        !dir.join("refused/bodies.csv").exists(),
        "a refused run must not start"
    );
    let out = mbdc(&["run", "--interp", "-q", "-o", s(&dir.join("ok")), s(&model)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // dopri5 and dop853 are explicit but the step is only their output interval: their error
    // control takes internal steps under the limit, so the same step is not refused
    for m in ["dopri5", "dop853"] {
        let out = mbdc(&[
            "run",
            "--interp",
            "-q",
            "--method",
            m,
            "-o",
            s(&dir.join(m)),
            s(&model),
        ]);
        assert!(
            out.status.success(),
            "{m}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Inconsistent scenes. A joint whose points are 1 m apart at t = 0 is reported by `mbdc check`
/// by name and span, and `--assemble` moves the body onto it. A driver that turns a crank that
/// a second joint holds still cannot be assembled: the error names the joints in conflict.
#[test]
fn inconsistent_scenes_are_named() {
    let dir = scratch("inconsistent");
    let far = write(
        &dir,
        "far.mbd",
        "model far_apart {\n  gravity (0, 0, -9.81) m/s^2\n  body rod { mass 1 kg; inertia rod(length: 1 m, radius: 1 cm); position (0.5, 0, 0.3) m; orientation axis_angle((0, 1, 0), 90 deg) }\n  joint pin = revolute(ground @ (0, 0, 0), rod @ (0, 0, 0.5) m, axis: (0, 1, 0))\n  simulate { duration 0.1 s; step 1 ms }\n}\n",
    );
    let out = mbdc(&["check", s(&far)]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("joint `pin` is violated by 1.000e0 at t = 0"),
        "{stderr}"
    );
    assert!(stderr.contains("far.mbd:4:3"), "{stderr}");
    assert!(stderr.contains("--assemble"), "{stderr}");
    let out = mbdc(&[
        "run",
        "--interp",
        "--assemble",
        "-o",
        s(&dir.join("far-out")),
        s(&far),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let contra = write(
        &dir,
        "contra.mbd",
        "model contradiction {\n  body crank { mass 1 kg; inertia rod(length: 0.2 m, radius: 1 cm, axis: x); position (0.1, 0, 0) m }\n  joint pivot = revolute(ground @ (0, 0, 0), crank @ (-0.1, 0, 0) m, axis: (0, 0, 1))\n  joint tip = spherical(ground @ (0.2, 0, 0) m, crank @ (0.1, 0, 0) m)\n  joint motor = drive_angle(pivot, 2 * pi * 1 Hz * t)\n  simulate { duration 1 s; step 1 ms }\n}\n",
    );
    let out = mbdc(&[
        "run",
        "--interp",
        "-q",
        "--assemble",
        "-o",
        s(&dir.join("contra-out")),
        s(&contra),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains(r#"the joints ["pivot", "tip", "motor"] cannot be assembled together: their velocity constraints"#),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A step above a beam's explicit limit is refused before the run, naming the beam, the
/// element and the limit and suggesting the rotary-inertia scale; `--force` cannot override
/// it (beams are explicit whatever the method: the runtime refuses it too, and the report
/// says so).
#[test]
fn a_step_above_a_beams_limit_is_refused_with_the_beam_named() {
    let dir = std::env::temp_dir().join(format!("mbdc-beam-refusal-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let model = root().join("models/cantilever.mbd");
    let out = command()
        .args(["run", "--interp", "--step", "2e-5", "-o"])
        .arg(&dir)
        .arg(&model)
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("beam 'blade', element") && stderr.contains("rotary_inertia_scale"),
        "{stderr}"
    );
    assert!(
        !dir.join("bodies.csv").exists(),
        "a refused run must not start"
    );
    let out = command()
        .args(["run", "--interp", "--force", "--step", "2e-5", "-o"])
        .arg(&dir)
        .arg(&model)
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(stderr.contains("beam 'blade', element"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The `error:` lines a command printed.
fn error_lines(stderr: &str) -> Vec<&str> {
    stderr.lines().filter(|l| l.starts_with("error:")).collect()
}

/// `mbdc check` refuses what `mbdc run` refuses before its first step, with the same error:
/// a step above a beam's explicit limit (the stability gate), a method that does not
/// simulate beams and a method that does not exist yet (the method's start; a lock under
/// an explicit Runge–Kutta method), a dense method
/// on too large a system (the runtime's size limit). The run refuses before it writes
/// anything, also on the compiled route (before it builds a program).
#[test]
fn check_refuses_what_run_refuses_before_its_first_step() {
    let dir = scratch("check-refuses");
    let cantilever = std::fs::read_to_string(root().join("models/cantilever.mbd")).expect("model");
    let pendulum = std::fs::read_to_string(root().join("models/pendulum.mbd")).expect("model");
    let chain = std::fs::read_to_string(root().join("models/chain.mbd")).expect("model");
    let arm = std::fs::read_to_string(root().join("models/deployment_arm.mbd")).expect("model");
    let cases = [
        (
            "beam_step",
            cantilever.replace("step 4 us", "step 1 ms"),
            &[][..],
            "above the stability limit of the beam 'blade'",
        ),
        (
            "beam_method",
            cantilever.replace("step 4 us", "step 4 us; method implicit_trapezoid"),
            &[][..],
            "implicit_trapezoid does not simulate flexible beams",
        ),
        (
            "revolute_in_space",
            pendulum
                .replace(
                    "orientation axis_angle((0, 1, 0), theta0)",
                    "orientation axis_angle((0, 1, 0), theta0)\n    angular_velocity (1, 0, 0) rad/s",
                )
                .replace("step 1 ms }", "step 1 ms; method state_time }"),
            &[][..],
            "state_time takes revolute joints in planar scenes only",
        ),
        (
            "rk_lock",
            arm.replace("method staggered }", "method dop853 }"),
            &[][..],
            "method dop853: joint 'spring_wall.lock' (lock) engages during the run: an impact",
        ),
        (
            "dense",
            chain.replace(
                "step 0.1 ms }",
                "step 0.1 ms; method coordinate_partitioning }",
            ),
            &["--set", "N=700"][..],
            "coordinate_partitioning is a dense method and this system has 7700 unknowns",
        ),
    ];
    for (name, text, set, expected) in cases {
        let model = dir.join(format!("{name}.mbd"));
        std::fs::write(&model, text).expect("write");
        let check = command()
            .arg("check")
            .args(set)
            .arg(&model)
            .output()
            .expect("runs");
        let check_err = String::from_utf8_lossy(&check.stderr);
        assert!(!check.status.success(), "{name}: {check_err}");
        assert!(check_err.contains(expected), "{name}: {check_err}");
        assert!(
            check_err.contains("`mbdc run` refuses this scene before its first step"),
            "{name}: {check_err}"
        );
        for route in [&["--interp"][..], &[][..]] {
            let out = dir.join(format!("{name}-out"));
            let run = command()
                .arg("run")
                .args(route)
                .args(set)
                .arg("-o")
                .arg(&out)
                .arg(&model)
                .output()
                .expect("runs");
            let run_err = String::from_utf8_lossy(&run.stderr);
            assert!(!run.status.success(), "{name} {route:?}: {run_err}");
            assert_eq!(
                error_lines(&run_err),
                error_lines(&check_err),
                "{name} {route:?}: the same refusal"
            );
            assert!(
                !out.exists(),
                "{name} {route:?}: a refused run writes nothing"
            );
        }
    }
    // a scene the run accepts passes check
    let ok = command()
        .arg("check")
        .arg(root().join("models/cantilever.mbd"))
        .output()
        .expect("runs");
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}
