//! Helpers for the workspace-level tests: load a scene, run it in memory with any method,
//! and keep every output frame for checks against closed forms and papers.

use mbdc_runtime::interp::Interp;
use mbdc_runtime::run_loop::{self, Frame, Observer, OnFailure, RunConfig, RunReport, Watchdog};
use mbdc_runtime::scene::{MethodSpec, Scene};
use mbdc_runtime::system::{Pose, Twist};

/// Path of a file in the repository's `models/` folder.
pub fn model_path(name: &str) -> String {
    format!("{}/../models/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// Lower a model file (panics with the rendered diagnostics if it has errors).
pub fn load_model(name: &str) -> Scene {
    load_model_with(name, &[])
}

/// Lower a model file with parameter overrides such as `"N=20"` (panics with the rendered
/// diagnostics if it has errors).
pub fn load_model_with(name: &str, set: &[&str]) -> Scene {
    let set: Vec<mbdc_compiler::Override> = set
        .iter()
        .map(|s| s.parse().expect("an override `name=value`"))
        .collect();
    let loaded = mbdc_compiler::load_file(model_path(name), &set);
    match loaded.scene {
        Some(s) => s,
        None => panic!(
            "{name}: {}",
            loaded
                .diagnostics
                .iter()
                .map(|d| d.render_plain(&loaded.sources))
                .collect::<String>()
        ),
    }
}

/// Lower `.mbd` text (panics with the rendered diagnostics if it has errors).
pub fn load_text(text: &str) -> Scene {
    let loaded = mbdc_compiler::load_str("test.mbd", text, &[]);
    match loaded.scene {
        Some(s) => s,
        None => panic!(
            "{}",
            loaded
                .diagnostics
                .iter()
                .map(|d| d.render_plain(&loaded.sources))
                .collect::<String>()
        ),
    }
}

/// One recorded frame.
#[derive(Clone, Debug)]
pub struct Rec {
    /// Time.
    pub t: f64,
    /// Poses.
    pub pose: Vec<Pose>,
    /// Twists.
    pub twist: Vec<Twist>,
    /// Multipliers per row.
    pub lambda: Vec<f64>,
    /// Kinetic energy.
    pub kinetic: f64,
    /// Potential energy.
    pub potential: f64,
    /// Work of non-conservative forces and drivers since the start (J).
    pub work: f64,
    /// Linear momentum (world).
    pub momentum: [f64; 3],
    /// Angular momentum (world, about the origin).
    pub angular_momentum: [f64; 3],
    /// Per-joint holonomic violation.
    pub violation: Vec<f64>,
    /// Per-joint velocity-level residual.
    pub velocity_violation: Vec<f64>,
    /// The beams' element states (empty without beams).
    pub beams: Vec<mbdc_runtime::beam_element::ElementState>,
    /// The meshes' state (empty without meshes, and in the initial frame).
    pub mesh: mbdc_runtime::integrators::MeshState,
}

impl Rec {
    /// Total mechanical energy.
    pub fn energy(&self) -> f64 {
        self.kinetic + self.potential
    }
    /// Largest violation over joints.
    pub fn max_violation(&self) -> f64 {
        self.violation.iter().fold(0.0, |a, b| a.max(*b))
    }
}

/// A recorded run.
pub struct Trajectory {
    /// The frames (the initial state first).
    pub frames: Vec<Rec>,
    /// The run's report.
    pub report: RunReport,
}

impl Trajectory {
    /// The last frame.
    pub fn last(&self) -> &Rec {
        self.frames.last().expect("at least the initial frame")
    }
    /// Largest violation over all frames.
    pub fn max_violation(&self) -> f64 {
        self.frames
            .iter()
            .fold(0.0, |a, f| a.max(f.max_violation()))
    }
    /// Largest |E − E₀| over all frames.
    pub fn max_energy_error(&self) -> f64 {
        let e0 = self.frames[0].energy();
        self.frames
            .iter()
            .fold(0.0, |a, f| a.max((f.energy() - e0).abs()))
    }
}

/// An observer that keeps every frame.
pub struct Recorder(pub Vec<Rec>);

impl Observer for Recorder {
    fn frame(&mut self, f: &Frame<'_>) {
        self.0.push(Rec {
            t: f.state.t,
            pose: f.state.pose.clone(),
            twist: f.state.twist.clone(),
            lambda: f.state.lambda.clone(),
            kinetic: f.kinetic,
            potential: f.potential,
            work: f.work,
            momentum: f.momentum,
            angular_momentum: f.angular_momentum,
            violation: f.violation.to_vec(),
            velocity_violation: f.velocity_violation.to_vec(),
            beams: f.state.beams.clone(),
            mesh: f.state.mesh.clone(),
        });
    }
}

/// The run settings of [`simulate`]: stop on failure, the watchdog on with the work of
/// forces and drivers booked.
fn watched_config(
    sys: &Interp,
    method: MethodSpec,
    h: f64,
    duration: f64,
    every: u32,
) -> RunConfig {
    RunConfig {
        duration,
        step: h,
        method,
        every,
        on_failure: OnFailure::Stop,
        watchdog: Watchdog::for_scale(run_loop::length_scale(sys), true),
        checkpoint: None,
        resume: None,
    }
}

/// Run `scene` through the interpreter with `method` and step `h` for `duration`, keeping a
/// frame every `every` steps. The watchdog is on and books the work of forces and drivers
/// whatever the scene (`energy_sources` true: for a scene without them `W` stays 0 up to
/// round-off), so its energy balance is checked as `mbdc run` checks it; a failure ends the
/// trajectory and is in `report.failure`.
pub fn simulate(
    scene: &Scene,
    method: MethodSpec,
    h: f64,
    duration: f64,
    every: u32,
) -> Trajectory {
    let sys = Interp::new(scene).expect("interpretable scene");
    let cfg = watched_config(&sys, method, h, duration, every);
    let mut rec = Recorder(Vec::new());
    let report = run_loop::run(&sys, &cfg, &mut rec);
    Trajectory {
        frames: rec.0,
        report,
    }
}

/// [`simulate`] with the watchdog of `mbdc run`: the work is booked only where the scene has
/// non-conservative forces or drivers ([`mbdc_runtime::app::energy_sources`]).
pub fn simulate_watched(
    scene: &Scene,
    method: MethodSpec,
    h: f64,
    duration: f64,
    every: u32,
) -> Trajectory {
    let sys = Interp::new(scene).expect("interpretable scene");
    let cfg = RunConfig {
        duration,
        step: h,
        method,
        every,
        on_failure: OnFailure::Stop,
        watchdog: Watchdog::for_scale(
            run_loop::length_scale(&sys),
            mbdc_runtime::app::energy_sources(scene),
        ),
        checkpoint: None,
        resume: None,
    };
    let mut rec = Recorder(Vec::new());
    let report = run_loop::run(&sys, &cfg, &mut rec);
    Trajectory {
        frames: rec.0,
        report,
    }
}

/// [`simulate`] in a rayon pool of 1, then 2, then 4 threads: each thread count with its
/// trajectory, in that order, for the checks that a result does not depend on the number
/// of threads.
pub fn simulate_on_1_2_4_threads(
    scene: &Scene,
    method: MethodSpec,
    h: f64,
    duration: f64,
    every: u32,
) -> [(usize, Trajectory); 3] {
    [1, 2, 4].map(|threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        let run = pool.install(|| simulate(scene, method.clone(), h, duration, every));
        (threads, run)
    })
}

/// [`simulate`] on `ranks` ranks, each a thread of this process
/// ([`mbdc_runtime::thread_ranks::ThreadRanks`]): every rank runs its part of the scene
/// ([`mbdc_runtime::ranked::Ranked`]) and rank 0 gathers the parts at every frame, as
/// `mbdc run --mpi` does over MPI. The trajectory is rank 0's (the whole scene).
pub fn simulate_on_ranks(
    scene: &Scene,
    method: MethodSpec,
    h: f64,
    duration: f64,
    every: u32,
    ranks: usize,
) -> Trajectory {
    use mbdc_runtime::ranked::{Gather, Ranked};
    let sys = Interp::new(scene).expect("interpretable scene");
    let cfg = watched_config(&sys, method, h, duration, every);
    let mut runs = mbdc_runtime::thread_ranks::ThreadRanks::run(ranks, |r| {
        let part = Ranked::new(&sys, r).unwrap_or_else(|e| panic!("{e}"));
        let mut rec = Recorder(Vec::new());
        let report = {
            let mut g = Gather::new(&part, Some(&mut rec));
            run_loop::run(&part, &cfg, &mut g)
        };
        Trajectory {
            frames: rec.0,
            report,
        }
    });
    runs.swap_remove(0)
}

/// A method by name with its default options.
pub fn method(name: &str) -> MethodSpec {
    MethodSpec::default_for(name).expect("known method")
}

/// Largest distance between the body positions of two frames.
pub fn position_difference(a: &Rec, b: &Rec) -> f64 {
    a.pose
        .iter()
        .zip(&b.pose)
        .fold(0.0, |m, (p, q)| m.max((p.r - q.r).norm()))
}

/// The heavy symmetric top of `models/hard/top.mbd` in steady precession, and what the tests
/// measure on it: one copy of the theory for every method's test.
pub mod top {
    use super::Rec;
    use nalgebra::Vector3;

    /// The tilt of the axis from the vertical, radians (30°, as in the model).
    pub fn theta() -> f64 {
        30f64.to_radians()
    }

    /// The steady precession rate Ω, rad/s: the slow root of m g l = Ω(C n − A'Ω cos θ) with
    /// the model's m = 1 kg, l = 0.1 m, A = 0.002 kg·m², A' = A + m l², C = 0.004 kg·m²,
    /// n = 100 rad/s, g = 9.81 m/s² (Goldstein §5.7); ≈ 2.632 rad/s.
    pub fn precession_rate() -> f64 {
        let (m, l, a, c, g, n) = (1.0f64, 0.1f64, 0.002f64, 0.004f64, 9.81f64, 100.0f64);
        let th = theta();
        let ap = a + m * l * l;
        (c * n - (c * c * n * n - 4.0 * ap * th.cos() * m * g * l).sqrt()) / (2.0 * ap * th.cos())
    }

    /// The tilt of the top's axis (body z) from the vertical in a frame, radians.
    pub fn tilt(f: &Rec) -> f64 {
        (f.pose[0].c * Vector3::z()).z.acos()
    }

    /// The mean precession rate over `frames`: the azimuth of the axis, unwrapped, from the
    /// first frame to the last, over the time between them.
    pub fn measured_precession(frames: &[Rec]) -> f64 {
        let az = |f: &Rec| {
            let e = f.pose[0].c * Vector3::z();
            e.y.atan2(e.x)
        };
        let turn: f64 = frames
            .windows(2)
            .map(|w| {
                (az(&w[1]) - az(&w[0]) + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI
            })
            .sum();
        turn / (frames[frames.len() - 1].t - frames[0].t)
    }
}
