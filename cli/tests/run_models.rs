//! End-to-end runs of `mbdc run --interp` on every rigid model, and of a run that fails.

mod common;
use common::{command, last_frame, root, summary};

use std::path::PathBuf;

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mbdc-run-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Every rigid model runs to its end with its own settings, and the summary says so: finished,
/// the steps it should take, a constraint violation below 1e-8 (the models' own ε: 1e-6 for the
/// papers' bowling ball and crank gives εΔλ ≈ 4e-5 there; the deployment arm's locks overshoot
/// by one step) and an output folder with the CSVs.
/// `mbdc view` of a run's folder: the page is written, its data block holds every frame
/// the run shows (every k-th and the last) and one body slot per body of bodies.csv.
/// Returns the data block.
fn replay(dir: &std::path::Path, model: &str) -> serde_json::Value {
    let out = command()
        .args(["view", "--no-open"])
        .arg(dir)
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{model}: mbdc view: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let html = std::fs::read_to_string(dir.join("view.html")).expect("view.html");
    let open = r#"<script id="mbdc-view-data" type="application/json">"#;
    let start = html.find(open).expect("data block") + open.len();
    let end = start + html[start..].find("</script>").unwrap();
    let d: serde_json::Value =
        serde_json::from_str(&html[start..end].replace("<\\/", "</")).expect("JSON");
    let s = summary(dir);
    let frames = d["frames"]["count"].as_u64().unwrap();
    let every = d["frames"]["shown_every"].as_u64().unwrap();
    let run_frames = s["frames"].as_u64().unwrap();
    assert_eq!(
        d["frames"]["run_frames"].as_u64().unwrap(),
        run_frames,
        "{model}"
    );
    // every k-th frame from the first, and the last
    let expect = run_frames.div_ceil(every) + u64::from(!(run_frames - 1).is_multiple_of(every));
    assert_eq!(frames, expect, "{model}: {}", d["frames"]);
    if dir.join("bodies.csv").exists() {
        let head = std::fs::read_to_string(dir.join("bodies.csv")).unwrap();
        let cols = head.lines().next().unwrap().split(',').count();
        assert_eq!(
            d["bodies"].as_array().unwrap().len(),
            (cols - 1) / 13,
            "{model}"
        );
    }
    d
}

#[test]
fn every_rigid_model_runs_to_the_end() {
    for (model, max_violation) in [
        ("double_pendulum_3d", 1e-8),
        ("chain", 1e-8),
        ("four_bar", 1e-8),
        ("slider_crank", 1e-3),
        ("bowling_ball", 1e-3),
        ("torque_free", 1e-8),
        // a lock engages after the step in which its joint passes the lock angle, so the
        // frame of that step shows the overshoot, at most h·θ̇ ≈ 1e-3 s × 8.4 rad/s
        ("deployment_arm", 1e-2),
    ] {
        let dir = out_dir(model);
        let out = command()
            .args(["run", "--interp", "-o"])
            .arg(&dir)
            .arg(root().join(format!("models/{model}.mbd")))
            .output()
            .expect("runs");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{model}: {stdout}\n{stderr}");
        assert!(stdout.contains("finished"), "{model}: {stdout}");
        let s = summary(&dir);
        assert_eq!(s["finished"], true, "{model}: {s}");
        assert!(s["failure"].is_null());
        let v = s["max_constraint_violation"].as_f64().expect("a number");
        assert!(v < max_violation, "{model}: violation {v}");
        let steps = s["steps"].as_u64().unwrap();
        let expect = (s["duration"].as_f64().unwrap() / s["step"].as_f64().unwrap()).round() as u64;
        assert!(
            steps.abs_diff(expect) <= 1,
            "{model}: {steps} steps, expected {expect}"
        );
        for f in ["bodies.csv", "energy.csv", "constraints.csv"] {
            assert!(dir.join(f).exists(), "{model}: no {f}");
        }
        let page = replay(&dir, model);
        // every joint of the scene the run wrote is drawn (the torque-free body has none;
        // the deployment arm's locks are rows of its revolutes, not joints of their own)
        let scene: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("scene.json")).unwrap())
                .unwrap();
        assert_eq!(
            page["joints"].as_array().unwrap().len(),
            scene["joints"].as_array().unwrap().len(),
            "{model}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The beam model runs with `mbdc run --interp` (the compiled path is compared with the
/// interpreter by tests/codegen) and writes `beams.csv`: one row per element and frame with
/// the section forces. Reference for the last frame (t = 1 s, the 10 N tip load fully applied
/// since 0.5 s, ramped over four periods so the beam is near its static state): the root
/// element's bending moment `P (L − s)` at its midpoint s = 0.025 m, within 3 % (the
/// remaining vibration about the static state).
#[test]
fn the_cantilever_runs_and_writes_its_section_forces() {
    let dir = out_dir("cantilever");
    let out = command()
        .args(["run", "--interp", "-o"])
        .arg(&dir)
        .arg(root().join("models/cantilever.mbd"))
        .output()
        .expect("runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        !stderr.contains("warning"),
        "the beam's element modes are no accuracy warning: {stderr}"
    );
    let s = summary(&dir);
    assert_eq!(s["finished"], true, "{s}");
    let text = std::fs::read_to_string(dir.join("beams.csv")).expect("beams.csv");
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t,beam,element,s,N1,N2,N3,M1,M2,M3,gamma1,gamma2,gamma3,kappa1,kappa2,kappa3"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let last_t = rows.last().unwrap()[0];
    let last: Vec<&Vec<&str>> = rows.iter().filter(|r| r[0] == last_t).collect();
    assert_eq!(last.len(), 20, "one row per element");
    let root_el = last.iter().find(|r| r[2] == "0").unwrap();
    assert_eq!(root_el[1], "blade");
    let s_mid: f64 = root_el[3].parse().unwrap();
    assert!((s_mid - 0.025).abs() < 1e-12, "{s_mid}");
    let m: Vec<f64> = root_el[7..10].iter().map(|x| x.parse().unwrap()).collect();
    let bending = m[1].hypot(m[2]);
    let exact = 10.0 * (1.0 - 0.025);
    assert!(
        (bending - exact).abs() < 0.03 * exact,
        "root moment {bending} N·m, static {exact} N·m ({m:?})"
    );
    // the ParaView series: an index with one data set per frame, each a polyline of 21
    // points and 20 line cells with the section quantities
    let pvd = std::fs::read_to_string(dir.join("beams.pvd")).expect("beams.pvd");
    let sets = pvd.matches("<DataSet ").count();
    let frames = text
        .lines()
        .skip(1)
        .filter(|l| l.contains(",blade,0,"))
        .count();
    assert_eq!(sets, frames, "{pvd}");
    let vtp = std::fs::read_to_string(dir.join("beams/beams_000000.vtp")).expect("first .vtp");
    assert!(vtp.contains("NumberOfPoints=\"21\"") && vtp.contains("NumberOfLines=\"20\""));
    for name in ["\"N\"", "\"M\"", "\"gamma\"", "\"kappa\""] {
        assert!(vtp.contains(name), "{name} missing");
    }
    // the beam's plot: deflection, section forces and moments along it
    let svg = std::fs::read_to_string(dir.join("beam_blade.svg")).expect("beam_blade.svg");
    for series in ["uz", "N2 shear", "M3 bending"] {
        assert!(
            svg.contains(&format!("data-series=\"{series}\"")),
            "{series} missing"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run that goes wrong stops with a non-zero exit code and a report naming where and why,
/// keeps the frames written up to then, and says so in summary.json.
#[test]
fn a_failing_run_reports_and_keeps_its_frames() {
    let dir = out_dir("fail");
    // the penalty method with a far too small ε: the penalty frequency is far above 2/h
    let model = std::env::temp_dir().join(format!("mbdc-run-test-{}-fail.mbd", std::process::id()));
    std::fs::write(
        &model,
        "model stiff_penalty {\n gravity (0, 0, -9.81) m/s^2\n body rod { mass 1 kg; inertia rod(length: 1 m, radius: 1 cm); position (0.5, 0, 0) m; orientation axis_angle((0, 1, 0), 90 deg) }\n joint pin = revolute(ground @ (0, 0, 0), rod @ (0, 0, 0.5) m, axis: (0, 1, 0))\n simulate { duration 1 s; step 1 ms; method penalty { epsilon 1e-12 } }\n}\n",
    )
    .unwrap();
    let out = command()
        .args(["run", "--interp", "-o"])
        .arg(&dir)
        .arg(&model)
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("stopped at t ="), "{stderr}");
    assert!(stderr.contains("help:"), "{stderr}");
    let s = summary(&dir);
    assert_eq!(s["finished"], false);
    let f = &s["failure"];
    assert!(
        f["where"].as_str().unwrap().contains("pin")
            || f["where"].as_str().unwrap().contains("rod"),
        "{f}"
    );
    let t_fail = f["time"].as_f64().unwrap();
    // the frames up to the failure are on disk
    let (rows, last_t) = last_frame(&dir);
    assert!(rows >= 2, "only {rows} lines in bodies.csv");
    assert!(
        last_t <= t_fail + 1e-12,
        "frame at {last_t} after the failure at {t_fail}"
    );
    // and halving the step rescues it
    let out = command()
        .args(["run", "--interp", "--on-failure", "halve-step", "-q", "-o"])
        .arg(&dir)
        .arg(&model)
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("halved"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_file(&model);
}

/// Every mesh model runs to its end with `mbdc run --interp` and its own settings, and writes
/// the mesh series: `mesh.pvd` indexing one `.vtu` per frame, `mesh_energy.csv` and its plot.
/// The energy balance holds: the run's drift (largest |E − E₀| over the energy in play,
/// which counts the work of the loads) stays below 1e-3, the issue's bound for 10⁴ steps.
#[test]
fn every_mesh_model_runs_and_writes_its_series() {
    for model in [
        "plate",
        "hex_bar",
        "plate_hole",
        "bracket",
        "block_impact",
        "plastic_bar",
        "plastic_dent",
        "mesh_on_pendulum",
        "cantilever_newmark",
        "cantilever_static",
    ] {
        let dir = out_dir(model);
        let out = command()
            .args(["run", "--interp", "-o"])
            .arg(&dir)
            .arg(root().join(format!("models/{model}.mbd")))
            .output()
            .expect("runs");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{model}: {stdout}\n{stderr}");
        let s = summary(&dir);
        assert_eq!(s["finished"], true, "{model}: {s}");
        // an implicit analysis is reported by its name, not by the unused rigid method
        let method = model.strip_prefix("cantilever_").unwrap_or("");
        if !method.is_empty() {
            assert_eq!(s["method"], method, "{model}: {s}");
        }
        let drift = s["max_energy_drift"].as_f64().expect("a number");
        assert!(drift < 1e-3, "{model}: energy drift {drift}");
        let frames = s["frames"].as_u64().expect("frames");
        let vtus = std::fs::read_dir(dir.join("mesh")).expect("mesh/").count() as u64;
        assert_eq!(vtus, frames, "{model}: one .vtu per frame");
        let pvd = std::fs::read_to_string(dir.join("mesh.pvd")).expect("mesh.pvd");
        assert_eq!(pvd.matches("<DataSet").count() as u64, frames, "{model}");
        let energy = std::fs::read_to_string(dir.join("mesh_energy.csv")).expect("csv");
        assert!(energy.starts_with(
            "t,kinetic,strain,hourglass,foundation,external_work,dissipated,plastic,tie_work,half_step,balance\n"
        ));
        assert_eq!(energy.lines().count() as u64, frames + 1, "{model}");
        assert!(dir.join("mesh_energy.svg").exists(), "{model}: {stdout}");
        // The summary's energy terms; a plastic mesh's frames carry its plastic strains.
        let terms = &s["extra"]["mesh_energy"];
        for k in ["kinetic", "strain", "external_work", "plastic"] {
            assert!(
                terms[k].is_number(),
                "{model}: summary mesh_energy.{k}: {terms}"
            );
        }
        let page = replay(&dir, model);
        let meshes = page["meshes"].as_array().unwrap();
        assert!(
            meshes
                .iter()
                .all(|m| !m["triangles"].as_array().unwrap().is_empty()
                    || !m["lines"].as_array().unwrap().is_empty()),
            "{model}: a mesh without a surface in the replay"
        );
        let vtu = std::fs::read_to_string(dir.join("mesh").join("mesh_000001.vtu")).expect("vtu");
        let plastic = model.starts_with("plastic_");
        assert_eq!(
            vtu.contains("Name=\"equivalent_plastic_strain\""),
            plastic,
            "{model}"
        );
        assert_eq!(vtu.contains("Name=\"plastic_strain\""), plastic, "{model}");
        if plastic {
            assert!(terms["plastic"].as_f64().unwrap() > 0.0, "{model}: {terms}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
