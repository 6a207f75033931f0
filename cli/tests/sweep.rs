//! End-to-end runs of `mbdc sweep`: the measured convergence orders on scenes with exact
//! references, the files it writes, and runs that fail staying in the results.

mod common;
use common::{root, scratch};

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

/// `mbdc sweep --interp FILE -o OUT EXTRA...`, which must succeed.
fn sweep(file: &Path, out: &Path, extra: &[&str]) -> Output {
    sweep_with(file, out, extra, true)
}

fn sweep_with(file: &Path, out: &Path, extra: &[&str], interp: bool) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_mbdc"));
    c.env("NO_COLOR", "1")
        .arg("sweep")
        .arg(file)
        .arg("-o")
        .arg(out);
    if interp {
        c.arg("--interp");
    }
    let o = c.args(extra).output().expect("mbdc runs");
    assert!(
        o.status.success(),
        "mbdc sweep failed:\n{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn json(dir: &Path) -> Value {
    let text = std::fs::read_to_string(dir.join("sweep.json")).expect("sweep.json");
    serde_json::from_str(&text).expect("valid JSON")
}

fn method<'a>(j: &'a Value, name: &str) -> &'a Value {
    j["methods"]
        .as_array()
        .expect("methods")
        .iter()
        .find(|m| m["name"] == name)
        .unwrap_or_else(|| panic!("method {name} in {j}"))
}

/// The physical pendulum (exact solution with Jacobi elliptic functions) and the
/// torque-free symmetric top (regular precession): staggered and implicit_trapezoid
/// converge at order 2 ± 0.2 over at least three steps of the asymptotic range. Ten
/// levels (down to h_max/512; well under a second): on the pendulum, implicit_trapezoid's error has a
/// higher-order term of the other sign that cancels part of the h² term around
/// h ≈ 1e-2 s, so the five default levels do not reach its asymptotic range.
#[test]
fn second_order_on_the_analytic_references() {
    for (model, measure) in [
        ("pendulum.mbd", "pos_err_max_m"),
        ("symmetric_top.mbd", "rot_err_max_rad"),
    ] {
        let dir = scratch(model);
        sweep(
            &root().join("models").join(model),
            &dir,
            &[
                "--methods",
                "staggered,implicit_trapezoid",
                "--levels",
                "10",
                "--min-time",
                "0",
                "-q",
            ],
        );
        let j = json(&dir);
        assert_eq!(j["reference"]["kind"], "analytic", "{model}");
        assert_eq!(j["measure"], measure, "{model}");
        for m in ["staggered", "implicit_trapezoid"] {
            let fit = &method(&j, m)["fit"];
            let order = fit["order"]
                .as_f64()
                .unwrap_or_else(|| panic!("{model} {m}: no order in {fit}"));
            assert!(
                (order - 2.0).abs() <= 0.2,
                "{model} {m}: measured order {order}, expected 2 ± 0.2 ({fit})"
            );
            assert!(
                fit["steps_used"].as_array().map_or(0, Vec::len) >= 3,
                "{model} {m}: too few runs in the fit ({fit})"
            );
            assert_eq!(fit["flagged"], false);
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

const DOUBLE: &str = "model small_double {
  gravity (0, 0, -9.81) m/s^2
  body a { mass 1 kg; inertia rod(length: 1 m, radius: 1 cm, axis: x); position (0.5, 0, 0) m }
  body b { mass 1 kg; inertia rod(length: 1 m, radius: 1 cm, axis: x); position (1.5, 0, 0) m }
  joint j1 = spherical(ground @ (0, 0, 0), a @ (-0.5, 0, 0) m)
  joint j2 = spherical(a @ (0.5, 0, 0) m, b @ (-0.5, 0, 0) m)
  simulate { duration 1 s; step 1 ms }
}
";

/// A scene without a reference: a numerical reference with its Richardson estimate,
/// `sweep.csv` with one row per run and the documented columns, a markdown table on the
/// terminal, and an SVG that is well-formed XML with one series per method in each panel.
#[test]
fn files_table_and_diagram() {
    let dir = scratch("files");
    let file = dir.join("small_double.mbd");
    std::fs::write(&file, DOUBLE).expect("write scene");
    let methods = ["staggered", "implicit_trapezoid"];
    let o = sweep(
        &file,
        &dir.join("out"),
        &[
            "--methods",
            &methods.join(","),
            "--levels",
            "3",
            "--min-time",
            "0.01",
            "-q",
        ],
    );
    let out = dir.join("out");
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("| method | h (s) | status | CPU (s) |"),
        "{stdout}"
    );
    assert!(stdout.contains("Reading this:"), "{stdout}");
    assert!(stdout.contains("Convergence order"), "{stdout}");

    // the CSV
    let csv = std::fs::read_to_string(out.join("sweep.csv")).expect("sweep.csv");
    let mut rdr = csv::Reader::from_reader(csv.as_bytes());
    let head: Vec<String> = rdr
        .headers()
        .expect("header")
        .iter()
        .map(String::from)
        .collect();
    for c in [
        "method",
        "step_s",
        "status",
        "cpu_time_s",
        "repetitions",
        "pos_err_final_m",
        "pos_err_max_m",
        "rot_err_final_rad",
        "rot_err_max_rad",
        "max_violation",
        "energy_drift",
        "iterations_mean",
    ] {
        assert!(head.iter().any(|h| h == c), "column {c} in {head:?}");
    }
    let col = |n: &str| head.iter().position(|h| h == n).expect("column");
    let rows: Vec<csv::StringRecord> = rdr.records().map(|r| r.expect("row")).collect();
    assert_eq!(rows.len(), methods.len() * 3, "{csv}");
    for r in &rows {
        assert!(methods.contains(&&r[col("method")]), "{r:?}");
        assert_eq!(&r[col("status")], "ok", "{r:?}");
        let cpu: f64 = r[col("cpu_time_s")].parse().expect("cpu time");
        assert!(cpu > 0.0);
        let reps: u32 = r[col("repetitions")].parse().expect("repetitions");
        assert!(reps >= 1);
        let e: f64 = r[col("pos_err_max_m")].parse().expect("position error");
        let f: f64 = r[col("pos_err_final_m")].parse().expect("position error");
        assert!(e > 0.0 && e >= f, "{r:?}");
        let _: f64 = r[col("rot_err_max_rad")]
            .parse()
            .expect("orientation error");
        let _: f64 = r[col("max_violation")].parse().expect("violation");
        let _: f64 = r[col("energy_drift")].parse().expect("drift");
        let _: f64 = r[col("iterations_mean")]
            .parse()
            .expect("both methods iterate");
    }
    // steps halve
    let steps: Vec<f64> = rows[..3]
        .iter()
        .map(|r| r[col("step_s")].parse().expect("step"))
        .collect();
    assert!((steps[0] / steps[1] - 2.0).abs() < 1e-9 && (steps[1] / steps[2] - 2.0).abs() < 1e-9);

    // the numerical reference says how far it can be trusted
    let j = json(&out);
    assert_eq!(j["reference"]["kind"], "numerical");
    let est = j["reference"]["estimated_error"]["pos_err_max_m"]
        .as_f64()
        .expect("Richardson estimate");
    assert!(est > 0.0 && est < 1e-3, "{est}");
    let ref_step = j["reference"]["step_s"].as_f64().expect("reference step");
    assert!(
        (steps[2] / ref_step - 8.0).abs() < 1e-9,
        "8 × finer than the finest swept step"
    );

    // the SVG: well-formed, titled, labelled, one series per method in each panel
    let svg = std::fs::read_to_string(out.join("sweep.svg")).expect("sweep.svg");
    let doc = roxmltree::Document::parse(&svg).expect("sweep.svg is well-formed XML");
    let texts: Vec<String> = doc
        .descendants()
        .filter(|n| n.has_tag_name("text"))
        .filter_map(|n| n.text().map(|t| t.trim().to_string()))
        .collect();
    for want in [
        "small_double: what accuracy costs",
        "CPU time per run (s)",
        "step h (s)",
        "max-over-time position error, RMS over bodies (m)",
    ] {
        assert!(
            texts.iter().any(|t| t == want),
            "text `{want}` in {texts:?}"
        );
    }
    let series: Vec<&str> = doc
        .descendants()
        .filter(|n| n.has_tag_name("polyline"))
        .filter_map(|n| n.attribute("data-series"))
        .collect();
    for m in methods {
        assert_eq!(
            series.iter().filter(|s| **s == m).count(),
            2,
            "one `{m}` series in each of the two panels: {series:?}"
        );
        assert!(texts.iter().any(|t| t.starts_with(m)), "legend names {m}");
    }
    assert_eq!(series.len(), 2 * methods.len(), "{series:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

const SPRING: &str = "model stiff {
  body m { mass 1 kg; inertia sphere(radius: 0.1 m); position (0.01, 0, 0) m }
  force k = spring(ground @ (-1, 0, 0) m, m @ (0, 0, 0), stiffness: 1e6 N/m, length: 1 m)
  simulate { duration 0.05 s; step 1e-4 s }
}
";

/// A step far above the explicit stability limit (h·ω = 10) diverges; the run stays in
/// the CSV, the JSON and the diagram, marked as such.
#[test]
fn diverged_runs_are_shown_not_dropped() {
    let dir = scratch("diverged");
    let file = dir.join("stiff.mbd");
    std::fs::write(&file, SPRING).expect("write scene");
    let out = dir.join("out");
    sweep(
        &file,
        &out,
        &[
            "--methods",
            "staggered",
            "--steps",
            "0.01,1e-4",
            "--min-time",
            "0",
            "-q",
        ],
    );
    let csv = std::fs::read_to_string(out.join("sweep.csv")).expect("sweep.csv");
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 3, "{csv}");
    assert!(
        lines[1].starts_with("staggered,1e-2,diverged at t = "),
        "{csv}"
    );
    assert!(lines[2].starts_with("staggered,1e-4,ok,"), "{csv}");
    let j = json(&out);
    assert_eq!(j["runs"][0]["status"], "diverged");
    assert_eq!(
        method(&j, "staggered")["fit"]["excluded"][0]["why"],
        "did not finish"
    );
    let svg = std::fs::read_to_string(out.join("sweep.svg")).expect("sweep.svg");
    let doc = roxmltree::Document::parse(&svg).expect("well-formed");
    assert!(
        doc.descendants().any(|n| n.has_tag_name("text")
            && n.text().is_some_and(|t| t.trim() == "diverged or stopped")),
        "the legend names the marks of failed runs"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bad requests are errors with a message, not panics.
#[test]
fn bad_arguments_are_reported() {
    let dir = scratch("bad");
    let o = Command::new(env!("CARGO_BIN_EXE_mbdc"))
        .args(["sweep"])
        .arg(root().join("models/pendulum.mbd"))
        .args(["--interp", "--steps", "0.01,-1", "-q", "-o"])
        .arg(&dir)
        .output()
        .expect("runs");
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("steps must be positive"), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    // `--levels 100` asked for a finest step 2^99 times smaller than the first, and ran
    let o = Command::new(env!("CARGO_BIN_EXE_mbdc"))
        .args(["sweep"])
        .arg(root().join("models/pendulum.mbd"))
        .args(["--interp", "--levels", "100", "-q", "-o"])
        .arg(&dir)
        .output()
        .expect("runs");
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("--levels must be between 1 and 20 (each level halves the step")
            && e.contains("got 100"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `reference { table "/dev/zero" }` read zeros until the process aborted for lack of
/// memory: a special file is refused by its kind, with the file named.
#[cfg(unix)]
#[test]
fn a_reference_table_of_a_special_file_is_refused() {
    let dir = scratch("dev-zero");
    let model = "model m {\n  body ball { mass 1 kg; inertia sphere(radius: 10 cm) }\n  gravity (0, 0, -9.81) m/s^2\n  reference { table \"/dev/zero\" }\n  simulate { duration 0.1 s; step 1 ms }\n}\n";
    let file = dir.join("zero.mbd");
    std::fs::write(&file, model).expect("write");
    let o = Command::new(env!("CARGO_BIN_EXE_mbdc"))
        .args(["sweep"])
        .arg(&file)
        .args(["--interp", "--levels", "1", "--min-time", "0", "-q", "-o"])
        .arg(dir.join("out"))
        .output()
        .expect("runs");
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{e}");
    assert!(
        e.contains("/dev/zero: a character device is not a regular file"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The compiled path measures the same errors as the interpreter (same runtime, same
/// arithmetic up to round-off). Ignored by default: the first run builds the runtime in
/// release mode for compiled scenes (minutes); run with `cargo test -- --ignored`.
#[test]
#[ignore = "builds the compiled-scene runtime in release (minutes the first time)"]
fn compiled_and_interpreted_sweeps_agree() {
    let dir = scratch("compiled");
    let file = dir.join("small_double.mbd");
    std::fs::write(&file, DOUBLE).expect("write scene");
    let args = [
        "--methods",
        "staggered",
        "--levels",
        "2",
        "--min-time",
        "0",
        "-q",
    ];
    sweep_with(&file, &dir.join("c"), &args, false);
    sweep_with(&file, &dir.join("i"), &args, true);
    let (c, i) = (json(&dir.join("c")), json(&dir.join("i")));
    assert!(
        c["runner"]
            .as_str()
            .is_some_and(|r| r.starts_with("compiled program")),
        "{}",
        c["runner"]
    );
    assert!(i["runner"]
        .as_str()
        .is_some_and(|r| r.starts_with("interpreter")));
    for k in 0..2 {
        let (a, b) = (&c["runs"][k], &i["runs"][k]);
        assert_eq!(a["status"], "ok");
        let (ea, eb) = (
            a["pos_err_max_m"].as_f64().expect("error"),
            b["pos_err_max_m"].as_f64().expect("error"),
        );
        assert!(
            (ea - eb).abs() <= 1e-9 * eb.abs().max(1e-12),
            "{ea} vs {eb}"
        );
        assert!(a["cpu_time_s"].as_f64().expect("cpu") > 0.0);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
