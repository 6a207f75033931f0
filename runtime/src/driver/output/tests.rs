use std::io::Read as _;

use nalgebra::{Matrix3, Quaternion, Vector3};

use super::*;
use crate::contract::system::{JointLayout, MassProps};

/// Two bodies; joint `hinge, a` (ground–b0, 5 holonomic rows), `roll` (b1–ground, 1
/// holonomic + 2 nonholonomic rows), `lock` (1 row, starts inactive).
fn layout() -> Layout {
    let mp = MassProps::new(1.0, Matrix3::identity()).unwrap();
    let joint = |name: &str, a, b, first_row, rows, nonholonomic| JointLayout {
        name: name.into(),
        kind: "test",
        a,
        b,
        first_row,
        rows,
        nonholonomic,
        starts_inactive: false,
    };
    let mut joints = vec![
        joint("hinge, a", None, Some(0), 0, 5, 0),
        joint("roll", Some(1), None, 5, 3, 2),
        joint("lock", Some(0), Some(1), 8, 1, 0),
    ];
    joints[2].starts_inactive = true;
    let mut row_kind = vec![RowKind::Holonomic; 9];
    row_kind[6] = RowKind::Nonholonomic;
    row_kind[7] = RowKind::Nonholonomic;
    Layout {
        body_names: vec!["b0".into(), "arm.upper[1]".into()],
        mass: vec![mp, mp],
        joints,
        rows: 9,
        row_joint: vec![0, 0, 0, 0, 0, 1, 1, 1, 2],
        row_kind,
        beams: Default::default(),
        meshes: Default::default(),
    }
}

fn meta() -> RunMeta {
    RunMeta {
        model: "m".into(),
        method: "staggered".into(),
        step: 1e-3,
        duration: 1.0,
    }
}

const ALL: OutputSpec = OutputSpec {
    every: 1,
    bodies: true,
    energy: true,
    constraints: true,
    format: crate::contract::scene::OutputFormat::Vtk,
    partitions: 0,
    checkpoint: crate::contract::scene::CheckpointOptions::NONE,
};

/// Awkward values: extremes, subnormals, signed zero, many digits.
fn value(rng: &mut crate::linalg::testutil::Rng, k: usize) -> f64 {
    match k % 7 {
        0 => rng.normal(),
        1 => rng.normal() * 1e300,
        2 => rng.normal() * 1e-300,
        3 => 5e-324,
        4 => -0.0,
        5 => 0.1 + 0.2,
        _ => std::f64::consts::PI * 1e7,
    }
}

fn fill(rng: &mut crate::linalg::testutil::Rng, f: &mut Frame, step: u64) {
    let mut k = step as usize;
    let mut v = || {
        k += 1;
        value(rng, k)
    };
    f.step = step;
    f.t = step as f64 * 1e-3;
    for p in &mut f.poses {
        p.r = Vector3::new(v(), v(), v());
        p.q = Quaternion::new(v(), v(), v(), v());
    }
    for t in &mut f.twists {
        t.v = Vector3::new(v(), v(), v());
        t.w = Vector3::new(v(), v(), v());
    }
    f.kinetic = 1.0 + step as f64;
    f.potential = -2.0 * step as f64;
    f.momentum = [v(), v(), v()];
    f.angular_momentum = [v(), v(), v()];
    for x in &mut f.violation {
        *x = v().abs();
    }
    for x in &mut f.velocity_violation {
        *x = v().abs();
    }
    for x in &mut f.lambda {
        *x = v();
    }
}

fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut r = ::csv::Reader::from_path(path).unwrap();
    let headers = r.headers().unwrap().iter().map(str::to_string).collect();
    let rows = r
        .records()
        .map(|rec| {
            rec.unwrap()
                .iter()
                .map(|s| s.parse::<f64>().unwrap())
                .collect()
        })
        .collect();
    (headers, rows)
}

fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// Frames written and read back with the csv crate: headers as documented (quoted where
/// needed), every number bit-for-bit identical, one row per frame.
#[test]
fn csv_round_trip_is_exact() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let layout = layout();
    let mut w = OutputWriter::create(&out, &layout, &ALL, meta()).unwrap();
    let mut rng = crate::linalg::testutil::Rng::new(1);
    let mut sent = Vec::new();
    for step in 0..50 {
        let mut f = w.frame();
        fill(&mut rng, &mut f, step);
        if step == 7 {
            f.lambda[3] = f64::NAN;
            f.momentum[1] = f64::INFINITY;
        }
        sent.push(f.clone());
        w.submit(f).unwrap();
    }
    let summary = w.finish(&Summary::started(&meta())).unwrap();
    assert_eq!(summary.frames, 50);

    let (h, rows) = read_csv(&out.join("bodies.csv"));
    assert_eq!(h.len(), 1 + 2 * 13);
    assert_eq!(&h[..4], ["t", "b0.x", "b0.y", "b0.z"]);
    assert_eq!(h[14], "arm.upper[1].x");
    assert_eq!(h[26], "arm.upper[1].wz");
    assert_eq!(rows.len(), 50);
    for (row, f) in rows.iter().zip(&sent) {
        assert!(same(row[0], f.t));
        for (b, (p, tw)) in f.poses.iter().zip(&f.twists).enumerate() {
            let expect = [
                p.r.x, p.r.y, p.r.z, p.q.w, p.q.i, p.q.j, p.q.k, tw.v.x, tw.v.y, tw.v.z, tw.w.x,
                tw.w.y, tw.w.z,
            ];
            for (k, e) in expect.iter().enumerate() {
                assert!(
                    same(row[1 + 13 * b + k], *e),
                    "body {b} column {k}: {} vs {e}",
                    row[1 + 13 * b + k]
                );
            }
        }
    }

    let (h, rows) = read_csv(&out.join("energy.csv"));
    assert_eq!(h, ENERGY_COLUMNS);
    for (row, f) in rows.iter().zip(&sent) {
        let expect = [f.t, f.kinetic, f.potential, f.kinetic + f.potential, f.work];
        for (k, e) in expect.iter().enumerate() {
            assert!(same(row[k], *e));
        }
        for k in 0..3 {
            assert!(same(row[6 + k], f.momentum[k]));
            assert!(same(row[9 + k], f.angular_momentum[k]));
        }
    }
    // Drift: E = 1 − step, E₀ = 1, energy in play = K_max + (V_max − V_min) = 50 + 98.
    let last = rows.last().unwrap();
    assert!(
        (last[5] - (-49.0 / (50.0 + 98.0))).abs() < 1e-15,
        "drift {}",
        last[5]
    );

    let mut raw = String::new();
    File::open(out.join("constraints.csv"))
        .unwrap()
        .read_to_string(&mut raw)
        .unwrap();
    assert!(
        raw.starts_with("t,\"hinge, a.violation\",\"hinge, a.lambda0\","),
        "{}",
        &raw[..60]
    );
    let (h, rows) = read_csv(&out.join("constraints.csv"));
    let expect_h = [
        "t",
        "hinge, a.violation",
        "hinge, a.lambda0",
        "hinge, a.lambda1",
        "hinge, a.lambda2",
        "hinge, a.lambda3",
        "hinge, a.lambda4",
        "roll.violation",
        "roll.velocity_violation",
        "roll.lambda0",
        "roll.lambda1",
        "roll.lambda2",
        "lock.violation",
        "lock.lambda0",
    ];
    assert_eq!(h, expect_h);
    for (row, f) in rows.iter().zip(&sent) {
        let expect = [
            f.t,
            f.violation[0],
            f.lambda[0],
            f.lambda[1],
            f.lambda[2],
            f.lambda[3],
            f.lambda[4],
            f.violation[1],
            f.velocity_violation[1],
            f.lambda[5],
            f.lambda[6],
            f.lambda[7],
            f.violation[2],
            f.lambda[8],
        ];
        for (k, e) in expect.iter().enumerate() {
            assert!(same(row[k], *e), "column {k}");
        }
    }
    assert!(rows[7][5].is_nan());
}

/// Only the requested files are created; summary.json always.
#[test]
fn only_requested_files() {
    let dir = tempfile::tempdir().unwrap();
    let spec = OutputSpec {
        every: 1,
        bodies: false,
        energy: true,
        constraints: false,
        ..OutputSpec::default()
    };
    let w = OutputWriter::create(dir.path(), &layout(), &spec, meta()).unwrap();
    w.finish(&Summary::started(&meta())).unwrap();
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["energy.csv", "summary.json"]);
}

/// A failed run: the failure (with a NaN value) round-trips through summary.json, and the
/// maxima the driver left open are filled from the frames, naming the joint.
#[test]
fn failure_summary() {
    let dir = tempfile::tempdir().unwrap();
    let layout = layout();
    let mut w = OutputWriter::create(dir.path(), &layout, &ALL, meta()).unwrap();
    // Initial summary exists and says not finished.
    let s0 = Summary::read(&dir.path().join("summary.json")).unwrap();
    assert!(!s0.finished && s0.failure.is_none() && s0.steps == 0);
    for step in 0..3 {
        let mut f = w.frame();
        f.t = step as f64;
        f.kinetic = 2.0;
        f.potential = if step == 2 { -1.0 } else { 0.0 };
        f.violation
            .copy_from_slice(&[1e-9, if step == 1 { 3e-6 } else { 0.0 }, 0.0]);
        w.submit(f).unwrap();
    }
    let mut s = Summary::started(&meta());
    s.steps = 1234;
    s.final_time = 1.234;
    s.wall_time = 0.5;
    s.failure = Some(Failure {
        time: 1.234,
        step: 1235,
        location: "arm.upper[1]".into(),
        quantity: "angular velocity".into(),
        value: f64::NAN,
        cause: "the state became NaN".into(),
        hint: Some("reduce the step".into()),
    });
    s.extra
        .insert("newton_iterations".into(), serde_json::json!(17));
    let written = w.finish(&s).unwrap();
    assert_eq!(written.max_constraint_violation, Some(3e-6));
    assert_eq!(written.max_violation_joint.as_deref(), Some("roll"));
    // E: 2, 2, 1; E_ref = max(2, 2 + 1) = 3 → |drift| = 1/3.
    assert!((written.max_energy_drift.unwrap() - 1.0 / 3.0).abs() < 1e-15);
    assert_eq!(written.frames, 3);
    let text = std::fs::read_to_string(dir.path().join("summary.json")).unwrap();
    assert!(text.contains("\"where\": \"arm.upper[1]\""), "{text}");
    assert!(text.contains("\"value\": \"NaN\""), "{text}");
    let back = Summary::read(&dir.path().join("summary.json")).unwrap();
    let f = back.failure.as_ref().unwrap();
    assert!(f.value.is_nan());
    assert_eq!(f.step, 1235);
    assert_eq!(back.extra["newton_iterations"], serde_json::json!(17));
    assert!(!back.finished);
    assert_eq!(back.max_violation_joint, written.max_violation_joint);
    // Values the driver did provide are kept.
    let mut w = OutputWriter::create(dir.path(), &layout, &ALL, meta()).unwrap();
    let f = w.frame();
    w.submit(f).unwrap();
    let mut s = Summary::started(&meta());
    s.max_constraint_violation = Some(f64::INFINITY);
    s.max_violation_joint = Some("hinge, a".into());
    let written = w.finish(&s).unwrap();
    assert_eq!(written.max_constraint_violation, Some(f64::INFINITY));
    let back = Summary::read(&dir.path().join("summary.json")).unwrap();
    assert_eq!(back.max_constraint_violation, Some(f64::INFINITY));
}

/// Dropping the writer mid-run (no finish): every submitted frame is on disk as complete
/// lines, the CSV parses, and summary.json still says the run did not finish.
#[test]
fn drop_mid_run_keeps_valid_csv() {
    let dir = tempfile::tempdir().unwrap();
    let layout = layout();
    let mut rng = crate::linalg::testutil::Rng::new(2);
    {
        let mut w = OutputWriter::create(dir.path(), &layout, &ALL, meta()).unwrap();
        for step in 0..1000 {
            let mut f = w.frame();
            fill(&mut rng, &mut f, step);
            w.submit(f).unwrap();
        }
        // dropped here
    }
    for name in ["bodies.csv", "energy.csv", "constraints.csv"] {
        let raw = std::fs::read_to_string(dir.path().join(name)).unwrap();
        assert!(raw.ends_with('\n'));
        let (h, rows) = read_csv(&dir.path().join(name));
        assert_eq!(rows.len(), 1000, "{name}");
        assert!(rows.iter().all(|r| r.len() == h.len()));
        assert_eq!(rows[999][0], 0.999);
    }
    assert!(
        !Summary::read(&dir.path().join("summary.json"))
            .unwrap()
            .finished
    );
}

/// Every frame of the pool comes back after being written: taking and submitting many
/// more frames than the pool holds never deadlocks, and the pool is bounded.
#[test]
fn pool_recycles_frames() {
    let dir = tempfile::tempdir().unwrap();
    let mut w = OutputWriter::create(dir.path(), &layout(), &ALL, meta()).unwrap();
    let n = w.pool_size();
    assert!((2..=POOL_MAX).contains(&n));
    for round in 0..20 {
        let frames: Vec<Frame> = (0..n).map(|_| w.frame()).collect();
        for mut f in frames {
            f.t = round as f64;
            w.submit(f).unwrap();
        }
    }
    assert_eq!(
        w.finish(&Summary::started(&meta())).unwrap().frames,
        20 * n as u64
    );
}

#[test]
fn creation_errors_name_the_path() {
    let dir = tempfile::tempdir().unwrap();
    // The "folder" is below a regular file.
    let file = dir.path().join("plain");
    std::fs::write(&file, "x").unwrap();
    let e = OutputWriter::create(&file.join("run"), &layout(), &ALL, meta()).unwrap_err();
    assert!(matches!(
        e,
        OutputError::Io {
            kind: OutputErrorKind::CreateDir,
            ..
        }
    ));
    assert_eq!(e.path(), file.join("run"));
    assert!(e.to_string().contains("plain/run"), "{e}");
    // A full disk: energy.csv is /dev/full.
    #[cfg(target_os = "linux")]
    {
        let out = dir.path().join("full");
        std::fs::create_dir(&out).unwrap();
        std::os::unix::fs::symlink("/dev/full", out.join("energy.csv")).unwrap();
        let e = OutputWriter::create(&out, &layout(), &ALL, meta()).unwrap_err();
        assert!(
            matches!(
                e,
                OutputError::Io {
                    kind: OutputErrorKind::Write,
                    ..
                }
            ),
            "{e}"
        );
        assert_eq!(e.path(), out.join("energy.csv"));
    }
}

/// A write error in the middle of a run (simulated: the file accepts only so many bytes,
/// the last write is cut mid-line): the file is truncated back to its last complete batch
/// and stays valid CSV, the error names the file, nothing more is written, and finish
/// still writes summary.json and returns the error. Whichever file fails — the first one
/// written in a batch or a later one, whose batch-mates were already written — every file
/// ends at the same frame.
#[test]
fn write_error_mid_run_keeps_written_data() {
    for failing in ["bodies.csv", "energy.csv", "constraints.csv"] {
        write_error_mid_run_in(failing);
    }
}

fn write_error_mid_run_in(failing: &str) {
    let dir = tempfile::tempdir().unwrap();
    let layout = layout();
    let mut w = OutputWriter::create(dir.path(), &layout, &ALL, meta()).unwrap();
    let mut rng = crate::linalg::testutil::Rng::new(3);
    // A first batch that surely reaches the disk.
    for step in 0..10 {
        let mut f = w.frame();
        fill(&mut rng, &mut f, step);
        w.submit(f).unwrap();
    }
    // Wait until the writer has flushed it (the queue runs empty quickly).
    let path = dir.path().join(failing);
    let t0 = std::time::Instant::now();
    while read_csv(&path).1.len() < 10 {
        assert!(t0.elapsed().as_secs() < 10, "writer did not flush");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let good = std::fs::metadata(&path).unwrap().len();
    w.limit_file_bytes_for_test(failing, good + 100);
    let mut err = None;
    for step in 10..10_000 {
        let mut f = w.frame();
        fill(&mut rng, &mut f, step);
        if let Err(e) = w.submit(f) {
            err = Some(e);
            break;
        }
    }
    let e = err.expect("the simulated disk-full error reaches submit");
    assert_eq!(e.path(), path);
    assert!(e.to_string().contains(failing), "{e}");
    let e2 = w.finish(&Summary::started(&meta())).unwrap_err();
    assert_eq!(e2.path(), path);
    let (_, rows) = read_csv(&path);
    assert!(rows.len() >= 10);
    // Every file is valid and stopped at the same frame.
    for name in ["bodies.csv", "energy.csv", "constraints.csv"] {
        let p = dir.path().join(name);
        assert!(
            std::fs::read_to_string(&p).unwrap().ends_with('\n'),
            "{failing}: {name}"
        );
        let (_, r) = read_csv(&p);
        assert_eq!(r.len(), rows.len(), "{failing} failed: {name}");
        assert_eq!(r.last().map(|x| x[0]), rows.last().map(|x| x[0]), "{name}");
    }
    assert!(Summary::read(&dir.path().join("summary.json")).is_ok());
}

#[test]
fn frame_set_constraints() {
    let layout = layout();
    let mut f = Frame::new(&layout);
    let phi = [1e-3, -2e-3, 0.0, 0.0, 0.0, -4e-4, 9.0, 8.0, 5.0];
    let vres = [7.0, 7.0, 7.0, 7.0, 7.0, 7.0, -0.25, 0.5, 7.0];
    let lambda: Vec<f64> = (0..9).map(|i| i as f64 + 0.5).collect();
    let mut active = [true; 9];
    active[8] = false;
    f.set_constraints(&layout, &phi, &vres, &lambda, Some(&active));
    assert_eq!(f.violation, [2e-3, 4e-4, 0.0]);
    assert_eq!(f.velocity_violation, [0.0, 0.5, 0.0]);
    assert_eq!(f.lambda[7], 7.5);
    assert_eq!(f.lambda[8], 0.0);
}

#[test]
fn summary_json_round_trip() {
    let mut s = Summary::started(&meta());
    s.final_time = f64::NEG_INFINITY;
    s.max_energy_drift = Some(f64::NAN);
    s.max_constraint_violation = None;
    let text = serde_json::to_string(&s).unwrap();
    assert!(text.contains("\"final_time\":\"-inf\""), "{text}");
    assert!(text.contains("\"max_energy_drift\":\"NaN\""), "{text}");
    assert!(text.contains("\"max_constraint_violation\":null"), "{text}");
    let back: Summary = serde_json::from_str(&text).unwrap();
    assert_eq!(back.final_time, f64::NEG_INFINITY);
    assert!(back.max_energy_drift.unwrap().is_nan());
    assert_eq!(back.max_constraint_violation, None);
    assert!(serde_json::from_str::<Summary>(&text.replace("\"-inf\"", "\"minus\"")).is_err());
}

#[test]
fn the_drift_is_the_error_of_the_balance_with_the_work() {
    // A body pushed from rest: the energy grows by exactly the work done on it, so the
    // balance K + V − W − E₀ has no error; the same frames without the work drift by 1.
    for (work, want) in [(true, 0.0), (false, 3.0 / 4.0)] {
        let dir = tempfile::tempdir().unwrap();
        let mut w = OutputWriter::create(dir.path(), &layout(), &ALL, meta()).unwrap();
        for step in 0..4 {
            let mut f = w.frame();
            f.t = step as f64;
            f.kinetic = 1.0 + step as f64;
            f.work = if work { step as f64 } else { 0.0 };
            w.submit(f).unwrap();
        }
        let mut s = Summary::started(&meta());
        s.energy_balance = Some(EnergyBalance {
            kinetic: 4.0,
            work_forces: 3.0,
            start: 1.0,
            in_play: 4.0,
            ..EnergyBalance::default()
        });
        let written = w.finish(&s).unwrap();
        // E_ref = max(|E₀| = 1, K_max = 4, |W|_max = 3) = 4
        let d = written.max_energy_drift.unwrap();
        assert!((d - want).abs() < 1e-15, "work {work}: drift {d}");
        let back = Summary::read(&dir.path().join("summary.json")).unwrap();
        assert_eq!(back.energy_balance, s.energy_balance);
        assert_eq!(back.energy_balance.unwrap().error(), 0.0);
        let (h, rows) = read_csv(&dir.path().join("energy.csv"));
        let col = h.iter().position(|c| c == "work").unwrap();
        assert_eq!(rows[3][col], if work { 3.0 } else { 0.0 });
    }
}

/// A restarted Exodus run — resumed from the position synced after 8 frames, after the
/// killed run had written 5 more — leaves the same `results.exo` as a run straight
/// through. Reference: the straight run's bytes; tolerance: none (byte equality).
#[test]
fn exodus_resume_continues_the_file_bitwise() {
    let spec = OutputSpec {
        format: crate::contract::scene::OutputFormat::Exodus,
        partitions: 3,
        ..ALL
    };
    let layout = layout();
    let mut rng = crate::linalg::testutil::Rng::new(7);
    let frames: Vec<Frame> = (0..20)
        .map(|s| {
            let mut f = Frame::new(&layout);
            fill(&mut rng, &mut f, s);
            f
        })
        .collect();
    let submit = |w: &mut OutputWriter, range: std::ops::Range<usize>| {
        for k in range {
            let mut f = w.frame();
            f.clone_from(&frames[k]);
            w.submit(f).unwrap();
        }
    };
    let straight = tempfile::tempdir().unwrap();
    let mut w = OutputWriter::create(straight.path(), &layout, &spec, meta()).unwrap();
    submit(&mut w, 0..20);
    w.finish(&Summary::started(&meta())).unwrap();

    let restarted = tempfile::tempdir().unwrap();
    let mut w = OutputWriter::create(restarted.path(), &layout, &spec, meta()).unwrap();
    submit(&mut w, 0..8);
    let at = w.sync().unwrap();
    submit(&mut w, 8..13);
    drop(w);
    let cut = exodus::read(&restarted.path().join(exodus::EXODUS_FILE)).unwrap();
    assert_eq!(cut.frames(), 13);
    let mut w = OutputWriter::resume(restarted.path(), &layout, &spec, meta(), &at).unwrap();
    submit(&mut w, 8..20);
    w.finish(&Summary::started(&meta())).unwrap();

    let a = std::fs::read(straight.path().join(exodus::EXODUS_FILE)).unwrap();
    let b = std::fs::read(restarted.path().join(exodus::EXODUS_FILE)).unwrap();
    assert!(a == b, "the resumed file differs from the straight one");
    let x = exodus::read(&restarted.path().join(exodus::EXODUS_FILE)).unwrap();
    assert_eq!(x.frames(), 20);
    assert_eq!(x.manifest().unwrap().frames_complete, 20);
    assert_eq!(x.manifest().unwrap().partitions, 3);
    assert!(!restarted.path().join("mesh").exists());
    // A file of another scene is refused on resume, naming it.
    let other = Layout {
        body_names: vec!["x".into()],
        mass: vec![layout.mass[0]],
        ..layout.clone()
    };
    let e = OutputWriter::resume(restarted.path(), &other, &spec, meta(), &at).unwrap_err();
    assert!(e.to_string().contains("results.exo"), "{e}");
}

/// The frame pool says when the simulation thread had to wait for a frame: not while the
/// pool holds one, and for about as long as the writer kept it otherwise. Reference: the
/// writer's sleep of 30 ms; tolerance: the wait is at least 20 ms (the clock starts
/// after the pool was found empty) and a frame that was there costs no wait.
#[test]
fn the_pool_reports_a_wait_for_the_writer() {
    let l = layout();
    let (pool, back) = frame_pool::FramePool::new(vec![Frame::new(&l), Frame::new(&l)]);
    let (a, wa) = pool.take().expect("a frame");
    let (b, wb) = pool.take().expect("a frame");
    assert_eq!((wa, wb), (None, None), "the pool held both");
    let writer = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_millis(30));
        back.give(a);
        back
    });
    let (_c, wc) = pool.take().expect("given back");
    let waited = wc.expect("the pool was empty: a wait");
    assert!(waited.as_secs_f64() >= 0.02, "{waited:?}");
    let back = writer.join().unwrap();
    back.give(b);
    let (_d, wd) = pool.take().expect("given back");
    assert_eq!(wd, None);
}
