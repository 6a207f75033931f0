//! What the energy balance's work booking costs per step (`driver/work.rs`): the same scene and
//! method run with the booking off (as `mbdc run` does for scenes without non-conservative forces
//! or drivers) and on (as for every scene that has them: one force evaluation, two potential
//! evaluations and, with drivers, one Jacobian evaluation per step), interleaved, best of 7.
//!
//! `cargo run --release -p mbdc-tests --example energy_watch`

use std::time::Instant;

use mbdc_runtime::interp::Interp;
use mbdc_runtime::run_loop::{self, Frame, Observer, OnFailure, RunConfig, Watchdog};
use mbdc_tests::{load_model, method};

struct Quiet;
impl Observer for Quiet {
    fn frame(&mut self, _f: &Frame<'_>) {}
}

fn main() {
    let runs = [
        ("double_pendulum_3d.mbd", "staggered", 1e-3, 2000u64),
        ("chain.mbd", "staggered", 1e-4, 300),
        ("chain.mbd", "natural_partitioning", 1e-4, 1000),
        ("hard/driven_pendulum.mbd", "staggered", 1e-3, 2000),
    ];
    println!("| scene | method | µs/step, booking off | µs/step, booking on | on / off |");
    println!("|---|---|---|---|---|");
    for (file, name, h, steps) in runs {
        let scene = load_model(file);
        let sys = Interp::new(&scene).expect("interpretable");
        let mut best = [f64::INFINITY; 2];
        for _round in 0..7 {
            for (k, on) in [false, true].into_iter().enumerate() {
                let cfg = RunConfig {
                    duration: h * steps as f64,
                    step: h,
                    method: method(name),
                    every: u32::MAX,
                    on_failure: OnFailure::Stop,
                    watchdog: Watchdog {
                        // off, the driver's work is not booked and its balance would stop
                        // the run: the timing is what is compared here
                        max_energy_growth: if on { 0.25 } else { f64::INFINITY },
                        ..Watchdog::for_scale(1.0, on)
                    },
                    checkpoint: None,
                    resume: None,
                };
                let t0 = Instant::now();
                let r = run_loop::run(&sys, &cfg, &mut Quiet);
                let dt = t0.elapsed().as_secs_f64();
                assert!(r.failure.is_none(), "{file} {name}: {:?}", r.failure);
                best[k] = best[k].min(dt / r.steps as f64);
            }
        }
        println!(
            "| {} | {name} | {:.2} | {:.2} | {:.2} |",
            file.trim_end_matches(".mbd"),
            best[0] * 1e6,
            best[1] * 1e6,
            best[1] / best[0]
        );
    }
}
