//! End-to-end: checkpoints and `mbdc run --restart`. A run continued from a checkpoint — with
//! every method, with beams, with an elastoplastic mesh, with a mesh tied to a body —
//! after a shorter run, after SIGKILL at any moment, from an older checkpoint when the
//! newest is damaged — writes files bitwise equal to the run made straight through; a
//! checkpoint of another run is refused naming the difference; an unwritable checkpoint
//! folder stops the run with a report.

mod common;
use common::{command, mbdc, root, s, scratch, summary};

use std::path::Path;
use std::process::Stdio;

/// Run the interpreter on `model` into `out` with `extra` arguments; returns (success,
/// stderr).
fn run(model: &str, out: &Path, extra: &[&str]) -> (bool, String) {
    let m = root().join(model);
    let mut args = vec!["run", "--interp", "-q", "-o", s(out)];
    args.extend_from_slice(extra);
    args.push(s(&m));
    let o = mbdc(&args);
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stderr).to_string(),
    )
}

/// Start the interpreter on `model` into `out` with `args` (and `RAYON_NUM_THREADS` set to
/// `threads` if given), and kill it (SIGKILL) after `ms` milliseconds.
fn killed_after(model: &str, out: &Path, args: &[&str], ms: u64, threads: Option<&str>) {
    let mut c = command();
    c.args(["run", "--interp", "-q", "-o", s(out)])
        .args(args)
        .arg(root().join(model))
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    if let Some(n) = threads {
        c.env("RAYON_NUM_THREADS", n);
    }
    let mut child = c.spawn().unwrap();
    std::thread::sleep(std::time::Duration::from_millis(ms));
    let _ = child.kill(); // SIGKILL
    let _ = child.wait();
}

/// The files of two output folders that must be equal, byte for byte.
fn same_output(a: &Path, b: &Path) {
    for f in [
        "bodies.csv",
        "energy.csv",
        "constraints.csv",
        "beams.csv",
        "beams.pvd",
        "mesh_energy.csv",
        "mesh.pvd",
    ] {
        let (x, y) = (a.join(f), b.join(f));
        if !x.exists() {
            assert!(!y.exists(), "{f} in one folder only");
            continue;
        }
        let (x, y) = (std::fs::read(&x).unwrap(), std::fs::read(&y).unwrap());
        if let Some(i) = x.iter().zip(&y).position(|(p, q)| p != q) {
            let line = x[..i].iter().filter(|&&c| c == b'\n').count() + 1;
            panic!("{f} differs at line {line}");
        }
        assert_eq!(x.len(), y.len(), "{f}: lengths differ");
    }
    let (sa, sb) = (summary(a), summary(b));
    for k in [
        "steps",
        "frames",
        "final_time",
        "max_constraint_violation",
        "max_energy_drift",
    ] {
        assert_eq!(sa[k], sb[k], "summary {k}");
    }
    assert_eq!(sa["energy_balance"], sb["energy_balance"]);
}

const DP: &str = "models/double_pendulum_3d.mbd";

#[test]
fn a_run_continued_from_its_checkpoint_is_the_run_made_straight_through() {
    let dir = scratch("restart-straight");
    // model, duration straight through, duration of the run that "stopped", output every,
    // checkpoint every (steps), other arguments
    for (model, long, short, every, ckpt, extra) in [
        (DP, "2", "1.25", "10", "300", &["--method", "staggered"][..]),
        (DP, "2", "1.25", "10", "300", &["--method", "baumgarte"][..]),
        (DP, "2", "1.25", "10", "300", &["--method", "penalty"][..]),
        (
            DP,
            "2",
            "1.25",
            "10",
            "300",
            &["--method", "coordinate_partitioning"][..],
        ),
        (
            DP,
            "2",
            "1.25",
            "10",
            "300",
            &["--method", "natural_partitioning"][..],
        ),
        (
            DP,
            "2",
            "1.25",
            "10",
            "300",
            &["--method", "implicit_trapezoid"][..],
        ),
        // a closed loop whose locks engage
        (
            "models/deployment_arm.mbd",
            "1.5",
            "0.9",
            "10",
            "300",
            &[][..],
        ),
        // beams: element states, the .vtp series and its index
        (
            "models/cantilever.mbd",
            "0.02",
            "0.013",
            "50",
            "1000",
            &[][..],
        ),
        // meshes: J2 plasticity past yield (about 7 ms), the .vtu series and its index
        (
            "models/plastic_bar.mbd",
            "0.009",
            "0.0085",
            "200",
            "2000",
            &[][..],
        ),
        // state_time: the checkpoint falls inside the window, which the restart solves again
        (
            "models/state_time_double_pendulum.mbd",
            "5",
            "3.2",
            "4",
            "60",
            &[][..],
        ),
        // an implicit mesh analysis (Newmark)
        (
            "models/cantilever_newmark.mbd",
            "0.025",
            "0.0155",
            "5",
            "40",
            &[][..],
        ),
        // a mesh tied to a swinging body
        (
            "models/mesh_on_pendulum.mbd",
            "0.02",
            "0.013",
            "100",
            "1000",
            &[][..],
        ),
    ] {
        let straight = dir.join("straight");
        let cut = dir.join("cut");
        let _ = std::fs::remove_dir_all(&straight);
        let _ = std::fs::remove_dir_all(&cut);
        let common = ["--every", every, "--checkpoint-every", ckpt];
        let with = |d: &'static str| [&["--duration", d][..], &common[..], extra].concat();
        let (ok, e) = run(model, &straight, &with(long));
        assert!(ok, "{model}: {e}");
        // a shorter run stands for one that stopped: its files go on past its last
        // checkpoint, which the restart cuts back
        let (ok, e) = run(model, &cut, &with(short));
        assert!(ok, "{model}: {e}");
        let mut again = with(long);
        again.push("--restart");
        let o = command()
            .args(["run", "--interp", "-o", s(&cut)])
            .args(&again)
            .arg(root().join(model))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{model}: {stderr}");
        assert!(stderr.contains("restarting from"), "{stderr}");
        same_output(&straight, &cut);
        for (series, ext) in [("beams", "vtp"), ("mesh", "vtu")] {
            if !straight.join(series).exists() {
                continue;
            }
            let last = std::fs::read_dir(straight.join(series)).unwrap().count();
            let name = format!("{series}/{series}_{:06}.{ext}", last - 1);
            assert!(
                std::fs::read(straight.join(&name)).unwrap()
                    == std::fs::read(cut.join(&name)).unwrap(),
                "{model}: {name} differs"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_run_killed_at_any_moment_restarts_bitwise() {
    let dir = scratch("restart-killed");
    let straight = dir.join("straight");
    // 10⁵ steps: long enough (about a second) to be killed in the middle
    let args = [
        "--duration",
        "100",
        "--every",
        "20",
        "--checkpoint-every",
        "2000",
    ];
    let (ok, e) = run(DP, &straight, &args);
    assert!(ok, "{e}");
    let mut mid_run = 0;
    for (i, ms) in [100u64, 350, 700].into_iter().enumerate() {
        let out = dir.join(format!("killed{i}"));
        killed_after(DP, &out, &args, ms, None);
        if summary(&out)["status"] == "started" {
            mid_run += 1;
        }
        if !out.join("checkpoints").exists() {
            continue; // killed before its first checkpoint: nothing to continue
        }
        let mut again = args.to_vec();
        again.push("--restart");
        let (ok, e) = run(DP, &out, &again);
        assert!(ok, "killed after {ms} ms: {e}");
        same_output(&straight, &out);
    }
    assert!(
        mid_run > 0,
        "no run was killed before its end: lengthen the run"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_damaged_checkpoint_is_refused_and_the_one_before_used() {
    let dir = scratch("restart-damaged");
    let (straight, cut) = (dir.join("straight"), dir.join("cut"));
    let args = |d: &'static str| {
        [
            "--duration",
            d,
            "--every",
            "10",
            "--checkpoint-every",
            "200",
        ]
    };
    assert!(run(DP, &straight, &args("1")).0);
    assert!(run(DP, &cut, &args("0.7")).0);
    let newest = std::fs::read_dir(cut.join("checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .max()
        .unwrap();
    let bytes = std::fs::read(&newest).unwrap();
    std::fs::write(&newest, &bytes[..bytes.len() - 10]).unwrap();
    let mut again = args("1").to_vec();
    again.push("--restart");
    let o = command()
        .args(["run", "--interp", "-o", s(&cut)])
        .args(&again)
        .arg(root().join(DP))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let name = newest.file_name().unwrap().to_string_lossy().to_string();
    assert!(
        stderr.contains(&name) && stderr.contains("cut short"),
        "the damaged checkpoint is named: {stderr}"
    );
    same_output(&straight, &cut);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_checkpoint_of_another_run_is_refused_naming_the_difference() {
    let dir = scratch("restart-other");
    let out = dir.join("out");
    let base = [
        "--duration",
        "0.5",
        "--every",
        "10",
        "--checkpoint-every",
        "100",
    ];
    assert!(run(DP, &out, &base).0);
    for (extra, says) in [
        (
            &["--method", "baumgarte"][..],
            "method staggered, not baumgarte",
        ),
        (&["--step", "0.0005"][..], "step 1e-3 s, not 5e-4 s"),
        (&["--set", "L=1.2 m"][..], "numbers differ"),
        (&["--format", "exodus"][..], "output format vtk, not exodus"),
    ] {
        let args = [&base[..], extra, &["--restart"]].concat();
        let (ok, e) = run(DP, &out, &args);
        assert!(!ok, "{extra:?} should be refused");
        assert!(
            e.contains("is a checkpoint of another run") && e.contains(says),
            "{e}"
        );
    }
    // no checkpoint at all
    let (ok, e) = run(DP, &dir.join("empty"), &["--restart"]);
    assert!(!ok);
    assert!(e.contains("no checkpoint to restart from"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unwritable_checkpoint_folder_stops_the_run_with_a_report() {
    let dir = scratch("restart-unwritable");
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    // a file where the folder should be
    std::fs::write(out.join("checkpoints"), b"in the way").unwrap();
    let (ok, e) = run(
        DP,
        &out,
        &["--duration", "0.5", "--checkpoint-every", "100"],
    );
    assert!(!ok, "{e}");
    let f = &summary(&out)["failure"];
    assert_eq!(f["where"], "the checkpoint folder", "{f}");
    assert!(f["time"].as_f64().unwrap() > 0.0);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Checkpoint options out of range, and a restart with nothing to restart from, are one
/// error each before the run starts (exit code 1, no frame written), saying what is expected.
#[test]
fn bad_checkpoint_options_are_refused_before_the_run() {
    let dir = scratch("checkpoint-options");
    let cases: [(&[&str], &str); 5] = [
        (
            &["--checkpoint-every", "0"],
            "`--checkpoint-every` must be at least 1 step",
        ),
        (
            &["--checkpoint-seconds", "-1"],
            "`--checkpoint-seconds` must be positive and finite, got -1",
        ),
        (
            &["--checkpoint-seconds", "NaN"],
            "`--checkpoint-seconds` must be positive and finite, got NaN",
        ),
        (
            &["--checkpoint-every", "10", "--keep-checkpoints", "0"],
            "`--keep-checkpoints` must be at least 1",
        ),
        (&["--restart"], "checkpoint"),
    ];
    for (k, (extra, expected)) in cases.iter().enumerate() {
        let out = dir.join(format!("case{k}"));
        let (ok, e) = run("models/pendulum.mbd", &out, extra);
        assert!(!ok, "{extra:?} was accepted");
        assert!(e.contains(expected), "{extra:?}: {e}");
        assert!(!e.contains("panicked"), "{extra:?}: {e}");
        assert!(
            !out.join("bodies.csv").exists(),
            "{extra:?}: the run started before refusing"
        );
    }
}

/// The steps of the checkpoints in the output folder `out`, oldest first.
fn checkpoint_steps(out: &Path) -> Vec<u64> {
    mbdc_runtime::checkpoint::list(&out.join("checkpoints"))
        .expect("the checkpoint folder reads")
        .into_iter()
        .map(|(step, _)| step)
        .collect()
}

/// `simulate { output { checkpoint_every N; keep_checkpoints K } }` in the model writes
/// checkpoints with no option given; `--checkpoint-every` and `--keep-checkpoints` override
/// them; a restart after the model's cadence changed is accepted (the cadence is not part of
/// what a checkpoint must match) and continues bitwise. Reference: the run made straight
/// through; tolerance: none (byte equality).
#[test]
fn checkpoint_options_in_the_model_need_no_flags() {
    let dir = scratch("restart-model-options");
    let text = std::fs::read_to_string(root().join(DP)).unwrap();
    let old = "simulate { duration 10 s; step 1 ms; method staggered }";
    assert!(text.contains(old), "{DP} changed: update this test");
    let with = |every: u32, keep: u32| {
        text.replace(
            old,
            &format!(
                "simulate {{ duration 10 s; step 1 ms; method staggered; output {{ every 10; checkpoint_every {every}; keep_checkpoints {keep} }} }}"
            ),
        )
    };
    let model = dir.join("dp.mbd");
    let go = |out: &Path, extra: &[&str]| {
        let mut args = vec!["run", "--interp", "-q", "-o", s(out)];
        args.extend_from_slice(extra);
        args.push(s(&model));
        let o = mbdc(&args);
        let e = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(o.status.success(), "{extra:?}: {e}");
        e
    };
    std::fs::write(&model, with(300, 3)).unwrap();
    // 2000 steps, a checkpoint every 300: steps 300 … 1800, the newest 3 kept
    let straight = dir.join("straight");
    go(&straight, &["--duration", "2"]);
    assert_eq!(checkpoint_steps(&straight), [1200, 1500, 1800]);
    // the command line overrides each option
    let flags = dir.join("flags");
    go(
        &flags,
        &[
            "--duration",
            "2",
            "--checkpoint-every",
            "700",
            "--keep-checkpoints",
            "1",
        ],
    );
    assert_eq!(checkpoint_steps(&flags), [1400]);
    // a run that stopped at 1.25 s, then the model's cadence changes, then the restart
    let cut = dir.join("cut");
    go(&cut, &["--duration", "1.25"]);
    assert_eq!(checkpoint_steps(&cut), [600, 900, 1200]);
    std::fs::write(&model, with(500, 1)).unwrap();
    let e = go(&cut, &["--duration", "2", "--restart"]);
    assert!(!e.contains("another run"), "{e}");
    same_output(&straight, &cut);
    assert_eq!(checkpoint_steps(&cut), [1700]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A mesh run writing `results.exo` (format exodus), killed (SIGKILL) at several moments:
/// the killed file opens and reads up to its last complete frame; the restart, with another
/// number of threads than the killed run had, continues it to a `results.exo` equal byte for
/// byte to the one the run made straight through (the element kernels are bitwise the same
/// for any number of threads). Reference: the straight run's file; tolerance: none.
#[test]
fn an_exodus_run_killed_at_any_moment_restarts_bitwise_with_other_threads() {
    use mbdc_runtime::output::exodus;
    let dir = scratch("restart-killed-exodus");
    let model = "models/plate.mbd";
    // 2×10⁴ steps of the plate: long enough to be killed in the middle
    let args = [
        "--duration",
        "0.02",
        "--every",
        "200",
        "--format",
        "exodus",
        "--checkpoint-every",
        "2000",
    ];
    let straight = dir.join("straight");
    let (ok, e) = run(model, &straight, &args);
    assert!(ok, "{e}");
    let whole = std::fs::read(straight.join("results.exo")).unwrap();
    let frames = exodus::read(&straight.join("results.exo"))
        .expect("the straight file reads")
        .frames();
    assert_eq!(frames, 101);
    let (mut mid_run, mut read_back, mut restarts) = (0, 0, 0);
    for (i, ms) in [150u64, 500, 1000].into_iter().enumerate() {
        let out = dir.join(format!("killed{i}"));
        killed_after(model, &out, &args, ms, Some("2"));
        if summary(&out)["status"] != "started" {
            continue; // it finished before the kill
        }
        mid_run += 1;
        let path = out.join("results.exo");
        if path.exists() {
            // readable up to its last complete frame, and those frames are the straight run's
            // (a kill while the header is being written leaves a file that is refused as
            // such; the loop asserts below that some killed file was read)
            if let Ok(f) = exodus::read(&path) {
                read_back += usize::from(f.frames() > 0);
                let n = f.frames();
                assert!(n <= frames, "killed after {ms} ms: {n} frames");
                let t = f.times().expect("times");
                let tw = exodus::read(&straight.join("results.exo"))
                    .unwrap()
                    .times()
                    .unwrap();
                assert_eq!(t[..], tw[..t.len()], "killed after {ms} ms");
            }
        }
        if checkpoint_steps(&out).is_empty() {
            continue; // killed before its first checkpoint: nothing to continue
        }
        let mut again = args.to_vec();
        again.push("--restart");
        let o = command()
            .args(["run", "--interp", "-q", "-o", s(&out)])
            .args(again)
            .arg(root().join(model))
            .env("RAYON_NUM_THREADS", "1")
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "killed after {ms} ms: {e}");
        let restarted = std::fs::read(out.join("results.exo")).unwrap();
        assert_eq!(
            restarted.len(),
            whole.len(),
            "killed after {ms} ms: lengths"
        );
        if let Some(at) = restarted.iter().zip(&whole).position(|(a, b)| a != b) {
            panic!("killed after {ms} ms: results.exo differs at byte {at}");
        }
        same_output(&straight, &out);
        restarts += 1;
    }
    assert!(
        mid_run > 0,
        "no run was killed before its end: lengthen the run"
    );
    assert!(read_back > 0, "no killed file had a frame to read");
    assert!(
        restarts > 0,
        "no killed run had a checkpoint to restart from"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
