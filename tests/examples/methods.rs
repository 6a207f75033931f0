//! Cost per step of every method on the 3-D double pendulum and a 32-link chain, through the
//! interpreter, measured side by side in one run (the repetitions of all methods are
//! interleaved, so machine noise affects them alike; each figure is the best of the rounds).
//!
//! `cargo run --release -p mbdc-tests --example methods`

use std::time::Instant;

use mbdc_runtime::interp::Interp;
use mbdc_runtime::run_loop::{self, Frame, Observer, OnFailure, RunConfig, Watchdog};
use mbdc_runtime::scene::MethodSpec;
use mbdc_tests::{load_model, method};

struct Quiet;
impl Observer for Quiet {
    fn frame(&mut self, _f: &Frame<'_>) {}
}

fn main() {
    // every method the runtime integrates (state_time is a formulation without a stepper)
    let methods: Vec<&str> = MethodSpec::NAMES
        .into_iter()
        .filter(|n| *n != "state_time")
        .collect();
    let scenes = [
        ("double_pendulum_3d.mbd", 1e-3, 2000u64),
        ("chain.mbd", 1e-4, 300),
    ];
    println!("| scene | method | µs/step | × staggered |");
    println!("|---|---|---|---|");
    for (file, h, steps) in scenes {
        let scene = load_model(file);
        let sys = Interp::new(&scene).expect("interpretable");
        let mut best = vec![f64::INFINITY; methods.len()];
        let mut failed = vec![None; methods.len()];
        for _round in 0..7 {
            for (k, name) in methods.iter().enumerate() {
                let cfg = RunConfig {
                    duration: h * steps as f64,
                    step: h,
                    method: method(name),
                    every: u32::MAX,
                    on_failure: OnFailure::Stop,
                    // the watchdog `mbdc run` gives the scene (the double pendulum and the
                    // chain have no work to book)
                    watchdog: Watchdog::for_scale(1.0, mbdc_runtime::app::energy_sources(&scene)),
                    checkpoint: None,
                    resume: None,
                };
                let t0 = Instant::now();
                let r = run_loop::run(&sys, &cfg, &mut Quiet);
                let dt = t0.elapsed().as_secs_f64();
                if let Some(f) = r.failure {
                    failed[k] = Some(f.cause);
                    continue;
                }
                best[k] = best[k].min(dt / r.steps as f64);
            }
        }
        let base = best[0];
        let name = file.trim_end_matches(".mbd");
        for (k, m) in methods.iter().enumerate() {
            match &failed[k] {
                Some(c) if !best[k].is_finite() => println!("| {name} | {m} | failed: {c} | |"),
                _ => println!(
                    "| {name} | {m} | {:.2} | {:.2} |",
                    best[k] * 1e6,
                    best[k] / base
                ),
            }
        }
    }
}
