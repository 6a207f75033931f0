//! A run whose output folder fills up: the run stops with a report naming the file and the
//! time, every CSV ends at the same frame, and no cut-short plot or temporary file is left.
//!
//! Two ways to fill it: a file-size limit on the process (`RLIMIT_FSIZE`, writes past it fail
//! with `EFBIG`; needs no privileges, so it always runs), and a real 400 KiB tmpfs in a
//! private mount namespace (`ENOSPC`, as on a full disk; runs where `unshare` may mount, and
//! says so where it may not).

mod common;
use common::{command, root, s, scratch, summary};

use std::path::Path;
use std::process::Output;

/// What every full-output stop must leave: exit 1, the error with the file and where the run
/// stopped, CSVs that end at the same time, no plot, no temporary file, a summary that says
/// why the run stopped when there was room for it.
fn check_stopped_cleanly(out: &Output, dir: &Path, why: &str) {
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    assert!(e.contains(why), "{e}");
    assert!(e.contains(".csv"), "the error names the file: {e}");
    assert!(e.contains("the run stopped at t = "), "{e}");
    assert!(e.contains("no plots"), "{e}");
    let mut last_times = Vec::new();
    for entry in std::fs::read_dir(dir).expect("the output folder") {
        let p = entry.expect("entry").path();
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp"), "a temporary file is left: {name}");
        assert!(!name.ends_with(".svg"), "a plot of a cut folder: {name}");
        if name.ends_with(".csv") {
            let text = std::fs::read_to_string(&p).expect("csv");
            assert!(text.ends_with('\n'), "{name} ends mid-line");
            let last = text.lines().last().expect("a header at least");
            last_times.push((name, last.split(',').next().unwrap_or("").to_string()));
        }
    }
    assert!(last_times.len() >= 3, "{last_times:?}");
    let t0 = &last_times[0].1;
    assert!(
        last_times.iter().all(|(_, t)| t == t0),
        "the files end at different frames: {last_times:?}"
    );
    if let Ok(text) = std::fs::read_to_string(dir.join("summary.json")) {
        if let Ok(v) = serde_json::from_str::<serde_json::Value>(&text) {
            if v["status"] != "started" {
                assert_eq!(v["status"], "interrupted", "{v}");
                assert_eq!(v["interrupted"]["by"], "an output write error", "{v}");
            }
        }
    }
}

/// The 32-link chain writes about 6 KB a frame: a 200 kB file-size limit stops it within a
/// few dozen frames of its 10 000.
#[cfg(unix)]
#[test]
fn a_file_size_limit_stops_the_run_with_a_report() {
    use std::os::unix::process::CommandExt;
    let dir = scratch("fsize");
    let out_dir = dir.join("out");
    let mut cmd = command();
    cmd.args([
        "run",
        "--interp",
        s(&root().join("models/chain.mbd")),
        "-o",
        s(&out_dir),
    ]);
    // SAFETY: setrlimit is async-signal-safe; nothing else runs between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            let limit = libc::rlimit {
                rlim_cur: 200_000,
                rlim_max: 200_000,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let out = cmd.output().expect("mbdc runs");
    check_stopped_cleanly(&out, &out_dir, "File too large");
    let v = summary(&out_dir);
    assert_eq!(v["status"], "interrupted", "{v}");
    assert!(v["final_time"].as_f64().unwrap() < 0.5, "{v}");
}

/// A real full disk: a 400 KiB tmpfs mounted in a private mount namespace for this one run.
#[cfg(target_os = "linux")]
#[test]
fn a_full_disk_stops_the_run_with_a_report() {
    let dir = scratch("tmpfs");
    let mnt = dir.join("mnt");
    std::fs::create_dir_all(&mnt).expect("mount point");
    let script = format!(
        "mount -t tmpfs -o size=400k tmpfs '{m}' && exec '{exe}' run --interp '{model}' -o '{m}/out'",
        m = s(&mnt),
        exe = env!("CARGO_BIN_EXE_mbdc"),
        model = s(&root().join("models/chain.mbd")),
    );
    // as root a mount namespace is enough; otherwise a user namespace maps us to root
    let probe = |ns: &[&str]| {
        std::process::Command::new("unshare")
            .args(ns)
            .args([
                "sh",
                "-c",
                "mount -t tmpfs -o size=4k tmpfs \"$0\"",
                s(&mnt),
            ])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    let ns: &[&str] = if probe(&["--mount"]) {
        &["--mount"]
    } else if probe(&["--user", "--map-root-user", "--mount"]) {
        &["--user", "--map-root-user", "--mount"]
    } else {
        eprintln!("skipped: this machine lets no test mount a tmpfs (unshare --mount)");
        return;
    };
    // The output folder lives in the namespace's tmpfs, gone when the run ends: the checks
    // run inside it, by the same test binary's view of the files, through a second shell.
    let check_dir = dir.join("copy");
    let script = format!(
        "{script}; code=$?; cp -r '{m}/out' '{c}'; exit $code",
        c = s(&check_dir),
        m = s(&mnt)
    );
    let script = script.replacen("&& exec ", "&& ", 1);
    let out = std::process::Command::new("unshare")
        .args(ns)
        .args(["sh", "-c", &script])
        .env("NO_COLOR", "1")
        .output()
        .expect("unshare runs");
    check_stopped_cleanly(&out, &check_dir, "No space left on device");
}
