//! The program of a compiled scene (`src/bin/scene_program.rs`: generated code and
//! `mbdc_runtime::app::main`, exactly what `mbdc run` builds and runs as its child) ends a
//! run honestly on SIGINT and SIGTERM (issue 22): it finishes its step, writes that state
//! as its last frame, flushes its files, writes `summary.json` with `"status":
//! "interrupted"` by the signal at that time, says so, and exits with 130 or 143. The
//! program is signalled once its first frames are on disk, and its run is far longer than
//! any wait, so nothing depends on timing.
#![cfg(unix)]

use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use mbdc_runtime::output::{RunStatus, Summary};

/// How long the test waits for frames, or for the program to end after the signal.
const PATIENCE: Duration = Duration::from_secs(300);

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mbdc-embed-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn start(out: &Path) -> Child {
    std::process::Command::new(env!("CARGO_BIN_EXE_scene_program"))
        .args(["--duration", "100000", "--every", "50", "--out"])
        .arg(out)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the scene program runs")
}

/// Rows of a CSV below its header, each with the header's column count; (rows, last time).
fn whole_rows(path: &Path) -> (usize, f64) {
    let text = std::fs::read_to_string(path).expect("csv");
    assert!(text.ends_with('\n'), "{}: cut mid-line", path.display());
    let mut lines = text.lines();
    let columns = lines.next().expect("header").split(',').count();
    let mut last = (0, f64::NAN);
    for l in lines {
        let fields: Vec<&str> = l.split(',').collect();
        assert_eq!(fields.len(), columns, "{}: {l}", path.display());
        last = (last.0 + 1, fields[0].parse().expect("a time"));
    }
    last
}

fn interrupt(signal: i32, name: &str, code: i32) {
    let out = scratch(name);
    let mut child = start(&out);
    let t0 = Instant::now();
    while !std::fs::read_to_string(out.join("bodies.csv")).is_ok_and(|t| t.lines().count() >= 4) {
        if let Some(status) = child.try_wait().expect("try_wait") {
            let o = child.wait_with_output().expect("output");
            panic!(
                "the program ended ({status}) before its frames: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        assert!(t0.elapsed() < PATIENCE, "no frames after {PATIENCE:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
    // SAFETY: `kill` has no memory-safety preconditions.
    assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
    let t0 = Instant::now();
    while child.try_wait().expect("try_wait").is_none() {
        if t0.elapsed() > PATIENCE {
            let _ = child.kill();
            panic!("the program did not end within {PATIENCE:?} of {name}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let o = child.wait_with_output().expect("output");
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(code), "{stdout}\n{stderr}");
    assert!(stdout.contains("interrupted with staggered"), "{stdout}");
    assert!(
        stderr.contains(&format!("interrupted by {name} at t = ")),
        "{stderr}"
    );
    let s = Summary::read(&out.join("summary.json")).expect("summary.json");
    assert_eq!(s.status(), RunStatus::Interrupted, "{s:?}");
    let i = s.interrupted.clone().expect("interrupted");
    assert_eq!(i.by, name);
    assert!(
        i.time > 0.0 && i.step == s.steps && s.final_time == i.time,
        "{s:?}"
    );
    for f in ["bodies.csv", "energy.csv", "constraints.csv"] {
        let (rows, last) = whole_rows(&out.join(f));
        assert_eq!(rows as u64, s.frames, "{f}: one row per frame");
        assert_eq!(last, i.time, "{f}: the last row is where the run stopped");
    }
    let text = std::fs::read_to_string(out.join("summary.json")).expect("text");
    assert!(text.contains("\"status\": \"interrupted\""), "{text}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn sigint_ends_the_scene_program_honestly() {
    interrupt(libc::SIGINT, "SIGINT", 130);
}

#[test]
fn sigterm_ends_the_scene_program_honestly() {
    interrupt(libc::SIGTERM, "SIGTERM", 143);
}
