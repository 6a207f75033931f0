//! End-to-end: the plots `mbdc run` writes next to its CSV files (also for a run that
//! stops), and `mbdc plot` redrawing them or drawing chosen quantities.

mod common;
use common::{mbdc, root, s, scratch};

use std::path::Path;

/// The texts of a well-formed SVG file, and its data series.
fn svg(path: &Path) -> (Vec<String>, Vec<String>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let doc = roxmltree::Document::parse(&text)
        .unwrap_or_else(|e| panic!("{} is not well-formed: {e}", path.display()));
    assert_eq!(doc.root_element().tag_name().name(), "svg");
    let texts = doc
        .descendants()
        .filter(|n| n.has_tag_name("text"))
        .filter_map(|n| n.text().map(|t| t.trim().to_string()))
        .collect();
    let series = doc
        .descendants()
        .filter(|n| n.has_tag_name("polyline"))
        .filter_map(|n| n.attribute("data-series").map(String::from))
        .collect();
    (texts, series)
}

fn has(texts: &[String], want: &str) {
    assert!(
        texts.iter().any(|t| t == want),
        "text `{want}` in {texts:?}"
    );
}

#[test]
fn run_writes_titled_labelled_plots() {
    let dir = scratch("run");
    let out = dir.join("out");
    let o = mbdc(&[
        "run",
        s(&root().join("models/double_pendulum_3d.mbd")),
        "--interp",
        "--duration",
        "0.5",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("plots: energy.svg, constraints.svg, trajectories.svg"),
        "{stdout}"
    );

    let (t, series) = svg(&out.join("energy.svg"));
    has(&t, "double_pendulum_3d: energy");
    has(&t, "staggered, h = 0.001 s, t = 0 … 0.5 s");
    has(&t, "time t (s)");
    has(&t, "energy (J)");
    has(&t, "relative drift (1)");
    for n in ["kinetic", "potential", "total", "drift"] {
        has(&t, n);
        assert!(series.iter().any(|x| x == n), "series {n} in {series:?}");
    }

    let (t, series) = svg(&out.join("constraints.svg"));
    has(&t, "double_pendulum_3d: constraint violation");
    has(&t, "violation |Φ| (m; rad for angular rows)");
    for j in ["shoulder", "elbow"] {
        has(&t, j);
        assert!(series.iter().any(|x| x == j));
    }
    assert!(
        t.iter().any(|x| x.starts_with("10⁻")),
        "log-scale ticks: {t:?}"
    );

    let (t, series) = svg(&out.join("trajectories.svg"));
    for a in ["x (m)", "y (m)", "z (m)"] {
        has(&t, a);
    }
    assert_eq!(series.iter().filter(|x| *x == "rod1").count(), 3);
    assert_eq!(series.iter().filter(|x| *x == "rod2").count(), 3);
    let _ = std::fs::remove_dir_all(&dir);
}

const UNSTABLE: &str = "model unstable {
  body m { mass 1 kg; inertia sphere(radius: 0.1 m); position (0.01, 0, 0) m }
  force k = spring(ground @ (-1, 0, 0) m, m @ (0, 0, 0), stiffness: 1e6 N/m, length: 1 m)
  simulate { duration 1 s; step 1e-2 s }
}
";

#[test]
fn a_run_that_stops_is_plotted_up_to_where_it_stopped() {
    let dir = scratch("stopped");
    let file = dir.join("unstable.mbd");
    std::fs::write(&file, UNSTABLE).expect("write");
    let out = dir.join("out");
    // --force: past the stability gate, which refuses h·ω = 10 before running
    let o = mbdc(&["run", s(&file), "--interp", "--force", "-o", s(&out)]);
    assert!(!o.status.success(), "h·ω = 10 must not finish");
    for f in ["energy.svg", "trajectories.svg"] {
        let (t, _) = svg(&out.join(f));
        assert!(
            t.iter().any(|x| x.contains("STOPPED at t = ")),
            "{f} says the run stopped: {t:?}"
        );
    }
    // no joints: no constraint plot, and that is not an error
    assert!(!out.join("constraints.svg").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn plot_redraws_and_draws_quantities_by_name() {
    let dir = scratch("plot");
    let out = dir.join("out");
    let o = mbdc(&[
        "run",
        s(&root().join("models/pendulum.mbd")),
        "--interp",
        "--duration",
        "0.3",
        "-q",
        "-o",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::remove_file(out.join("energy.svg")).expect("written by run");

    let o = mbdc(&["plot", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("energy.svg").exists(), "redrawn");

    let o = mbdc(&[
        "plot",
        s(&out),
        "rod.x",
        "rod.z",
        "kinetic",
        "pivot.violation",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (t, series) = svg(&out.join("plot.svg"));
    has(&t, "value (m)");
    has(&t, "value (J)");
    has(&t, "value (m or rad)");
    for q in ["rod.x", "rod.z", "kinetic", "pivot.violation"] {
        assert!(series.iter().any(|x| x == q), "{q} in {series:?}");
    }
    let o = mbdc(&["plot", s(&out), "pivot.violation", "--log"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (t, series) = svg(&out.join("plot.svg"));
    assert!(t.iter().any(|x| x.starts_with("10⁻")), "log ticks: {t:?}");
    assert_eq!(series, vec!["pivot.violation".to_string()]);

    let custom = dir.join("custom.svg");
    let o = mbdc(&["plot", s(&out), "energy:total", "-o", s(&custom)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, series) = svg(&custom);
    assert_eq!(series, vec!["total".to_string()]);

    let o = mbdc(&["plot", s(&out), "rod.xx"]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("no quantity `rod.xx`") && e.contains("`rod.x`"),
        "{e}"
    );

    let o = mbdc(&["plot", s(&out), "--bodies", "rdo"]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("no body `rdo`") && e.contains("`rod`"), "{e}");

    let o = mbdc(&["plot", s(&out), "--list"]);
    assert!(o.status.success());
    let l = String::from_utf8_lossy(&o.stdout);
    assert!(
        l.contains("energy.csv: kinetic potential total work drift"),
        "{l}"
    );

    let o = mbdc(&["plot", s(&dir.join("nothing-here"))]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("not an output folder"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run that keeps its beams in `results.exo` (`--format exodus`, no `beams.csv`) gets the
/// same beam plot as the run that writes `beams.csv`: `mbdc plot` reads the beam blocks'
/// section quantities from the Exodus file. Reference: the CSV run's `beam_blade.svg`; the
/// two files must be equal byte for byte (the same frames, the same `f64`s).
#[test]
fn beam_plots_are_drawn_from_the_exodus_file() {
    let dir = scratch("beam-exodus");
    let model = root().join("models/cantilever.mbd");
    let mut svgs = Vec::new();
    for format in ["csv", "exodus"] {
        let out = dir.join(format);
        let o = mbdc(&[
            "run",
            s(&model),
            "--interp",
            "--duration",
            "0.05",
            "--format",
            format,
            "-q",
            "-o",
            s(&out),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert_eq!(out.join("beams.csv").exists(), format == "csv");
        // redrawn by `mbdc plot` from what the run left
        std::fs::remove_file(out.join("beam_blade.svg")).expect("written by the run");
        let o = mbdc(&["plot", s(&out)]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (_, series) = svg(&out.join("beam_blade.svg"));
        for want in ["uz", "N2 shear", "M3 bending"] {
            assert!(series.iter().any(|x| x == want), "{want} in {series:?}");
        }
        svgs.push(std::fs::read(out.join("beam_blade.svg")).expect("beam_blade.svg"));
    }
    assert!(
        svgs[0] == svgs[1],
        "the Exodus run's beam plot differs from the CSV run's"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
