//! What the CLI's integration tests share: the `mbdc` binary under test, the repository root
//! and scratch folders. Each test file uses a part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The `mbdc` binary under test, colours off (so stderr can be matched as text).
pub fn command() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_mbdc"));
    c.env("NO_COLOR", "1");
    c
}

/// Runs `mbdc` with `args` to the end and returns what it printed and its status.
pub fn mbdc(args: &[&str]) -> Output {
    command().args(args).output().expect("mbdc runs")
}

/// The repository root (models/, docs/).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A fresh, empty scratch folder for one test, unique to this test binary's process.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mbdc-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// The `summary.json` of the output folder `dir`.
pub fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("valid JSON")
}

/// The number of lines of `bodies.csv` in the output folder `dir` (header included) and the
/// time of its last frame.
pub fn last_frame(dir: &Path) -> (usize, f64) {
    let csv = std::fs::read_to_string(dir.join("bodies.csv")).expect("bodies.csv");
    let last = csv.lines().last().expect("a header at least");
    let t = last
        .split(',')
        .next()
        .and_then(|t| t.parse().ok())
        .unwrap_or(f64::NAN);
    (csv.lines().count(), t)
}
