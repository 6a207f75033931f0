//! Three scenes embedded in Rust, one per route, each a `System` that the runtime's
//! integrators advance directly (no files, no `mbdc` program):
//!
//! - [`double_pendulum_3d`]: the build.rs route (`build.rs` calls
//!   `mbdc_compiler::build("…/double_pendulum_3d.mbd")`, this file `include!`s the result);
//! - [`four_bar`]: the proc-macro route from a file, `include_model!("…/four_bar.mbd")`;
//! - [`pendulum`]: the proc-macro route with the model written inline, `model! { … }`.

use mbdc_runtime::run_loop::{self, Frame, Observer, OnFailure, RunConfig, RunReport, Watchdog};
use mbdc_runtime::scene::{MethodSpec, Scene};
use mbdc_runtime::system::System;

// build.rs route
include!(concat!(env!("OUT_DIR"), "/double_pendulum_3d.rs"));

// proc-macro route, from a file (relative to this crate's Cargo.toml)
mbdc_macros::include_model!("../../models/four_bar.mbd");

// proc-macro route, inline
mbdc_macros::model! {
    // A physical pendulum: a 1 m rod hinged at its top end, released at 60°.
    model pendulum {
        gravity (0, 0, -9.81) m/s^2
        param L = 1 m
        body rod {
            mass 1 kg
            inertia rod(length: L, radius: 1 cm, axis: z)
            position (L / 2 * sin(60 deg), 0, -L / 2 * cos(60 deg))
            orientation axis_angle((0, 1, 0), -60 deg)   // body z from the centre to the hinge
        }
        joint hinge = revolute(ground @ (0, 0, 0), rod @ (0, 0, L / 2), axis: (0, 1, 0))
        simulate { duration 2 s; step 1 ms }
    }
}

/// What a run of an embedded scene produced.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The scene.
    pub name: String,
    /// The run's report.
    pub report: RunReport,
    /// Total energy at every frame.
    pub energy: Vec<f64>,
    /// The body positions at the end.
    pub last_positions: Vec<[f64; 3]>,
}

struct Energy(Vec<f64>, Vec<[f64; 3]>);

impl Observer for Energy {
    fn frame(&mut self, f: &Frame<'_>) {
        self.0.push(f.kinetic + f.potential);
        self.1 = f.state.pose.iter().map(|p| [p.r.x, p.r.y, p.r.z]).collect();
    }
}

/// Run a system with its scene's settings for `duration` seconds.
pub fn simulate<S: System>(sys: &S, scene: &Scene, duration: f64) -> Outcome {
    let cfg = RunConfig {
        duration,
        step: scene.simulate.step,
        method: scene.simulate.method.clone(),
        every: 10,
        on_failure: OnFailure::Stop,
        watchdog: Watchdog::for_scale(
            run_loop::length_scale(sys),
            mbdc_runtime::app::energy_sources(scene),
        ),
        checkpoint: None,
        resume: None,
    };
    let mut obs = Energy(Vec::new(), Vec::new());
    let report = run_loop::run(sys, &cfg, &mut obs);
    Outcome {
        name: scene.name.clone(),
        report,
        energy: obs.0,
        last_positions: obs.1,
    }
}

/// Run the three embedded scenes (one per route) for `duration` seconds each.
pub fn run_all(duration: f64) -> Result<Vec<Outcome>, mbdc_runtime::compiled::CompiledError> {
    Ok(vec![
        simulate(
            &double_pendulum_3d::Model::try_new()?,
            &double_pendulum_3d::Model::scene()?,
            duration,
        ),
        simulate(
            &four_bar::Model::try_new()?,
            &four_bar::Model::scene()?,
            duration,
        ),
        simulate(
            &pendulum::Model::try_new()?,
            &pendulum::Model::scene()?,
            duration,
        ),
    ])
}

/// The same runs with another method (by name, with its default options).
pub fn with_method(scene: &Scene, method: &str) -> Scene {
    let mut s = scene.clone();
    if let Some(m) = MethodSpec::default_for(method) {
        s.simulate.method = m;
    }
    s
}
