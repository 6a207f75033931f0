//! Generated code for every rigid model in `models/` (see `build.rs`), and helpers to run a
//! system with any method and keep every frame.

use mbdc_runtime::compiled::CompiledModel;
use mbdc_runtime::run_loop::{self, Frame, Observer, OnFailure, RunConfig, RunReport, Watchdog};
use mbdc_runtime::scene::{MethodSpec, Scene};
use mbdc_runtime::system::System;

include!(concat!(env!("OUT_DIR"), "/registry.rs"));

/// Something done with each generated model.
pub trait Visitor {
    /// Called with the generated model type, the model file name and the layout name.
    fn visit<M: CompiledModel>(&mut self, file: &str, layout: &str);
}

/// Every number of one output frame, flattened in a fixed order.
pub type Numbers = Vec<f64>;

struct Keep(Vec<Numbers>);

impl Observer for Keep {
    fn frame(&mut self, f: &Frame<'_>) {
        let s = f.state;
        let mut v = vec![s.t, f.kinetic, f.potential];
        v.extend(f.momentum);
        v.extend(f.angular_momentum);
        for p in &s.pose {
            v.extend(p.r.iter());
            v.extend(p.q.coords.iter());
        }
        for t in &s.twist {
            v.extend(t.v.iter());
            v.extend(t.w.iter());
        }
        v.extend(&s.lambda);
        v.extend(f.violation);
        v.extend(f.velocity_violation);
        // meshes: every node's displacement and velocity, every element's stress, and with
        // plasticity every element's plastic strains, every point's state and the plastic work
        v.extend(s.mesh.u.iter().chain(&s.mesh.v).flatten());
        v.extend(s.mesh.stress.iter().flatten());
        v.extend(s.mesh.plastic_strain.iter().flatten());
        v.extend(&s.mesh.equivalent_plastic_strain);
        for p in &s.mesh.plastic {
            v.extend(p.strain.iter().flatten());
            v.extend(&p.equivalent);
        }
        v.push(s.mesh.energy.plastic);
        self.0.push(v);
    }
}

/// The settings of an agreement run: `steps` steps of the scene's step with `method`, a frame
/// at every step, stop on failure.
pub fn config<S: System>(sys: &S, scene: &Scene, method: &MethodSpec, steps: u32) -> RunConfig {
    RunConfig {
        duration: scene.simulate.step * steps as f64,
        step: scene.simulate.step,
        method: method.clone(),
        every: 1,
        on_failure: OnFailure::Stop,
        watchdog: Watchdog::for_scale(
            run_loop::length_scale(sys),
            mbdc_runtime::app::energy_sources(scene),
        ),
        checkpoint: None,
        resume: None,
    }
}

/// Run `sys` and keep every frame's numbers.
pub fn frames<S: System>(sys: &S, cfg: &RunConfig) -> (RunReport, Vec<Numbers>) {
    let mut k = Keep(Vec::new());
    let r = run_loop::run(sys, cfg, &mut k);
    (r, k.0)
}

/// The methods to compare: every one `integrators::make` supports, with the scene's options
/// for the scene's own method.
pub fn methods(scene: &Scene) -> Vec<MethodSpec> {
    // The dense methods factor a (6n + m)² matrix per step: on the benchmark scenes of
    // models/bench (100 bodies) 1000 steps take hours, so they run there with the sparse
    // methods only. Up to 40 bodies (the 32-link chain) every method runs.
    let dense_ok = scene.bodies.len() <= 40;
    // A scene of meshes alone runs the same explicit mesh integrator whatever the method:
    // its own method is enough.
    if scene.bodies.is_empty() && scene.beams.is_empty() && !scene.meshes.is_empty() {
        return vec![scene.simulate.method.clone()];
    }
    MethodSpec::NAMES
        .iter()
        .filter(|n| **n != "state_time")
        .filter(|n| dense_ok || !matches!(**n, "coordinate_partitioning" | "implicit_trapezoid"))
        .map(|n| {
            if *n == scene.simulate.method.name() {
                scene.simulate.method.clone()
            } else {
                MethodSpec::default_for(n).expect("a method")
            }
        })
        .collect()
}
