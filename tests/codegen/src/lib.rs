//! Generated code for every rigid model in `models/` (see `build.rs`), and helpers to run a
//! system with any method and keep every frame.

use mbdc_runtime::compiled::CompiledModel;
use mbdc_runtime::run_loop::{self, Frame, Observer, OnFailure, RunConfig, RunReport, Watchdog};
use mbdc_runtime::scene::{MethodSpec, Scene};
use mbdc_runtime::system::{
    ConstraintEval, JointGeom, JointKernel, Layout, Need, Pose, System, Twist, Wrench,
};

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
pub fn config(sys: &dyn System, scene: &Scene, method: &MethodSpec, steps: u32) -> RunConfig {
    RunConfig {
        duration: scene.simulate.step * steps as f64,
        step: scene.simulate.step,
        method: method.clone(),
        every: 1,
        on_failure: OnFailure::Stop,
        watchdog: Watchdog::for_scale(
            run_loop::length_scale(&Erased(sys)),
            mbdc_runtime::app::energy_sources(scene),
        ),
        checkpoint: None,
        resume: None,
    }
}

/// Run `sys` and keep every frame's numbers.
///
/// The system runs behind a trait object ([`Erased`]), so that the run loop and every
/// integrator are compiled once for this crate, not once per generated model and layout
/// (some eighty of them: compiling those copies took this crate the better part of a
/// quarter of an hour). Forwarding changes no arithmetic, so the numbers are the model's
/// own, as a monomorphized run computes them.
pub fn frames(sys: &dyn System, cfg: &RunConfig) -> (RunReport, Vec<Numbers>) {
    let mut k = Keep(Vec::new());
    let r = run_loop::run(&Erased(sys), cfg, &mut k);
    (r, k.0)
}

/// A system behind a trait object. Every method forwards, the provided ones too, so the
/// model's own overrides are the ones that run.
pub struct Erased<'a>(pub &'a dyn System);

impl System for Erased<'_> {
    fn layout(&self) -> &Layout {
        self.0.layout()
    }
    fn initial_state(&self, pose: &mut [Pose], twist: &mut [Twist]) {
        self.0.initial_state(pose, twist);
    }
    fn applied(&self, t: f64, pose: &[Pose], twist: &[Twist], out: &mut [Wrench]) {
        self.0.applied(t, pose, twist, out);
    }
    fn constraints(
        &self,
        t: f64,
        pose: &[Pose],
        twist: &[Twist],
        need: Need,
        out: &mut ConstraintEval,
    ) {
        self.0.constraints(t, pose, twist, need, out);
    }
    fn potential_energy(&self, t: f64, pose: &[Pose]) -> f64 {
        self.0.potential_energy(t, pose)
    }
    fn update_locks(&self, pose: &[Pose], twist: &[Twist], active: &mut [bool]) -> Option<usize> {
        self.0.update_locks(pose, twist, active)
    }
    fn has_velocity_forces(&self) -> bool {
        self.0.has_velocity_forces()
    }
    fn has_state_forces(&self) -> bool {
        self.0.has_state_forces()
    }
    fn tree_joint(&self, joint: usize) -> Option<(JointKernel, &JointGeom)> {
        self.0.tree_joint(joint)
    }
    fn mesh_kernels(&self) -> Option<&dyn std::any::Any> {
        self.0.mesh_kernels()
    }

    fn beam_kernels(&self) -> Option<&dyn std::any::Any> {
        self.0.beam_kernels()
    }
}

/// The methods to compare: every one `integrators::make` supports, with the scene's options
/// for the scene's own method.
pub fn methods(scene: &Scene) -> Vec<MethodSpec> {
    // The dense methods factor a (6n + m)² matrix per step: on the benchmark scenes of
    // models/bench (100 bodies) 1000 steps take hours, so they run there with the sparse
    // methods only. Up to 40 bodies (the 32-link chain) every method runs but state_time,
    // which runs on scenes of up to 8 bodies: its windows of long planar chains (a sparse LU
    // of 20 000 unknowns per Newton iteration on the 32-link chain) doubled this test's time
    // and exercise no part of the generated code the small scenes do not.
    let dense_ok = scene.bodies.len() <= 40;
    // A scene of meshes alone runs the same explicit mesh integrator whatever the method:
    // its own method is enough.
    if scene.bodies.is_empty() && scene.beams.is_empty() && !scene.meshes.is_empty() {
        return vec![scene.simulate.method.clone()];
    }
    MethodSpec::NAMES
        .iter()
        .filter(|n| **n != "state_time" || scene.bodies.len() <= 8)
        .filter(|n| {
            dense_ok
                || !matches!(
                    **n,
                    "coordinate_partitioning" | "implicit_trapezoid" | "state_time"
                )
        })
        .map(|n| {
            if *n == scene.simulate.method.name() {
                scene.simulate.method.clone()
            } else {
                MethodSpec::default_for(n).expect("a method")
            }
        })
        .collect()
}
