//! The output-size estimate a run gives before it starts (`mbdc run` warns above 1 GB and
//! suggests an output interval), against the bytes real runs write: rigid bodies and
//! joints, beams, an elastic and a plastic mesh.
//!
//! Reference: the size of the files each run wrote (CSV, the `.vtp`/`.vtu` frames; not
//! `summary.json` or the `.pvd` indexes, a few kB). Tolerance: the estimate counts 21
//! characters per number, the upper side of ryu's 18–24 for values that are not round, so
//! it may exceed what is written by the share of round values (zeros at rest, integers)
//! and must not fall below it by more than the XML tags it leaves out: written/estimate in
//! [0.5, 1.1]. `results.exo` (format `exodus`) is binary and its estimate exact but for the
//! model's name in the header: within 64 bytes. In every format, every data file the run
//! wrote is in the estimate (none is forgotten).

use mbdc_runtime::app::{run_config, Settings};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::output::{estimate, RunMeta};
use mbdc_runtime::run_loop::{self, Frame, Observer};
use mbdc_runtime::scene::{OutputFormat, OutputSpec};
use mbdc_runtime::system::System;
use mbdc_tests::load_model;

struct Quiet;

impl Observer for Quiet {
    fn frame(&mut self, _: &Frame<'_>) {}
}

/// The bytes of one entry of the estimate: a file, or the files of a series' folder
/// (`beams/*.vtp`).
fn written(dir: &std::path::Path, entry: &str) -> u64 {
    match entry.split_once('/') {
        Some((folder, _)) => std::fs::read_dir(dir.join(folder))
            .expect("series folder")
            .flatten()
            .map(|e| e.metadata().expect("metadata").len())
            .sum(),
        None => std::fs::metadata(dir.join(entry)).expect("file").len(),
    }
}

/// The data files (and series folders) of an output folder, as estimate entries name them.
fn data_files(dir: &std::path::Path) -> Vec<String> {
    let mut out: Vec<String> = std::fs::read_dir(dir)
        .expect("output folder")
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let ext = name.rsplit('.').next().unwrap_or("").to_string();
            let folder = e.path().is_dir();
            match (folder, ext.as_str()) {
                (true, _) => Some(format!(
                    "{name}/*.{}",
                    if name == "mesh" { "vtu" } else { "vtp" }
                )),
                (false, "csv" | "exo") => Some(name),
                _ => None, // summary.json, scene.json, the manifest, the .pvd indexes
            }
        })
        .collect();
    out.sort();
    out
}

#[test]
fn output_estimate_is_close_to_what_a_run_writes() {
    for (model, duration, every, format) in [
        ("double_pendulum_3d", 0.2, 1, OutputFormat::Vtk),
        ("double_pendulum_3d", 0.2, 1, OutputFormat::Exodus),
        ("cantilever", 0.01, 10, OutputFormat::Vtk),
        ("cantilever", 0.01, 10, OutputFormat::Csv),
        ("cantilever", 0.01, 10, OutputFormat::Exodus),
        ("plate", 2e-4, 5, OutputFormat::Vtk),
        ("plate", 2e-4, 5, OutputFormat::Exodus),
        ("plastic_bar", 2e-3, 50, OutputFormat::Vtk),
        ("plastic_bar", 2e-3, 50, OutputFormat::Csv),
        ("plastic_bar", 2e-3, 50, OutputFormat::Exodus),
    ] {
        let scene = load_model(&format!("{model}.mbd"));
        let sys = Interp::new(&scene).expect("interpretable");
        let settings = Settings {
            duration: Some(duration),
            every: Some(every),
            ..Settings::default()
        };
        let cfg = run_config(&sys, &scene, &settings).expect("config");
        let spec: &OutputSpec = &OutputSpec {
            format,
            ..scene.simulate.output.clone()
        };
        let steps = run_loop::step_count(cfg.duration, cfg.step);
        let est = estimate(sys.layout(), spec, steps, cfg.every);
        let dir = std::env::temp_dir().join(format!(
            "mbdc-output-estimate-{}-{model}-{}",
            std::process::id(),
            format.name()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        let meta = RunMeta {
            model: model.into(),
            method: cfg.method.name().into(),
            step: cfg.step,
            duration: cfg.duration,
        };
        let (report, _) =
            run_loop::run_to_dir(&sys, &cfg, meta, spec, &dir, &mut Quiet).expect("output");
        assert!(report.finished, "{model}: {:?}", report.failure);
        let f = format.name();
        for &(entry, estimated) in &est.files {
            let bytes = written(&dir, entry);
            let ratio = bytes as f64 / estimated as f64;
            eprintln!(
                "{model} ({f}) {entry}: written {bytes} B, estimated {estimated} B, ratio {ratio:.3}"
            );
            if entry.ends_with(".exo") {
                assert!(
                    bytes.abs_diff(estimated) <= 64,
                    "{model} ({f}) {entry}: wrote {bytes} B, estimated {estimated} B"
                );
            } else {
                assert!(
                    (0.5..=1.1).contains(&ratio),
                    "{model} ({f}) {entry}: wrote {bytes} B, estimated {estimated} B"
                );
            }
        }
        let mut named: Vec<String> = est.files.iter().map(|e| e.0.to_string()).collect();
        named.sort();
        assert_eq!(
            data_files(&dir),
            named,
            "{model} ({f}): the files written and the files estimated"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
