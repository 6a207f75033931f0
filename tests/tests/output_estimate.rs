//! The output-size estimate a run gives before it starts (`mbdc run` warns above 1 GB and
//! suggests an output interval), against the bytes real runs write: rigid bodies and
//! joints, beams, an elastic and a plastic mesh.
//!
//! Reference: the size of the files each run wrote (CSV, the `.vtp`/`.vtu` frames; not
//! `summary.json` or the `.pvd` indexes, a few kB). Tolerance: the estimate counts 21
//! characters per number, the upper side of ryu's 18–24 for values that are not round, so
//! it may exceed what is written by the share of round values (zeros at rest, integers)
//! and must not fall below it by more than the XML tags it leaves out: written/estimate in
//! [0.5, 1.1].

use mbdc_runtime::app::{run_config, Settings};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::output::{estimate, RunMeta};
use mbdc_runtime::run_loop::{self, Frame, Observer};
use mbdc_runtime::scene::OutputSpec;
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

#[test]
fn output_estimate_is_close_to_what_a_run_writes() {
    for (model, duration, every) in [
        ("double_pendulum_3d", 0.2, 1),
        ("cantilever", 0.01, 10),
        ("plate", 2e-4, 5),
        ("plastic_bar", 2e-3, 50),
    ] {
        let scene = load_model(&format!("{model}.mbd"));
        let sys = Interp::new(&scene).expect("interpretable");
        let settings = Settings {
            duration: Some(duration),
            every: Some(every),
            ..Settings::default()
        };
        let cfg = run_config(&sys, &scene, &settings).expect("config");
        let spec: &OutputSpec = &scene.simulate.output;
        let steps = run_loop::step_count(cfg.duration, cfg.step);
        let est = estimate(sys.layout(), spec, steps, cfg.every);
        let dir = std::env::temp_dir().join(format!(
            "mbdc-output-estimate-{}-{model}",
            std::process::id()
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
        for &(entry, estimated) in &est.files {
            let bytes = written(&dir, entry);
            let ratio = bytes as f64 / estimated as f64;
            eprintln!(
                "{model} {entry}: written {bytes} B, estimated {estimated} B, ratio {ratio:.3}"
            );
            assert!(
                (0.5..=1.1).contains(&ratio),
                "{model} {entry}: wrote {bytes} B, estimated {estimated} B"
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
