//! Running one (method, step) of a sweep and measuring it.
//!
//! A [`Runner`] runs the scene with a method, a step and a duration, and returns what the
//! sweep needs: the status, the CPU time, the body states at the output frames (a
//! [`Track`]), the largest constraint violation and energy drift over those frames, and
//! the mean iteration count where the method iterates. The scene is built once; method and
//! step are run-time options.
//!
//! [`InterpRunner`] runs in this process through the interpreter and observes the frames
//! in memory (no files). Its CPU time is the CPU time of the running thread
//! (`CLOCK_THREAD_CPUTIME_ID`; wall time where that clock is missing), measured around the
//! whole run: integrator set-up, the steps, and the evaluation of the sparse output
//! frames (constraint violation, energy), but not building the scene.
//!
//! [`CompiledRunner`] runs the scene's generated program (built once by `mbdc run`'s
//! compiled path, `crate::scene_crate`), one process per run, with the method, step, duration
//! and output interval as options, and reads back `summary.json` and `bodies.csv`. Its CPU
//! time is measured around the program: the user + system time the operating system
//! accounts to the finished child (`getrusage(RUSAGE_CHILDREN)`), minus the same for a
//! zero-length run of the program (start-up, reading the scene, writing the files), so
//! that what remains is the integration, as for the interpreter. A run shorter than the
//! noise of that subtraction (a step that diverges at once) is given [`CPU_RESOLUTION`],
//! not zero, so that it stays on the log-scale diagram.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use mbdc_runtime::interp::Interp;
use mbdc_runtime::output::Summary;
use mbdc_runtime::run_loop::{self, Frame, Observer, OnFailure, RunConfig, RunReport, Watchdog};
use mbdc_runtime::scene::{MethodSpec, OutputSpec, Scene};

/// Body states at the output frames of a run, frame-major (`r[f * bodies + b]`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Track {
    /// Number of bodies.
    pub bodies: usize,
    /// Frame times, s.
    pub t: Vec<f64>,
    /// Mass-centre positions, world, m.
    pub r: Vec<[f64; 3]>,
    /// Orientations, unit quaternions `[w, x, y, z]` body → world.
    pub q: Vec<[f64; 4]>,
    /// Mass-centre velocities, world, m/s.
    pub v: Vec<[f64; 3]>,
    /// Angular velocities, body components, rad/s.
    pub w: Vec<[f64; 3]>,
}

impl Track {
    /// An empty track for `bodies` bodies.
    pub fn new(bodies: usize) -> Track {
        Track {
            bodies,
            ..Track::default()
        }
    }

    /// Number of frames.
    pub fn frames(&self) -> usize {
        self.t.len()
    }

    /// Append a frame from the run driver's state.
    pub fn push_frame(&mut self, f: &Frame<'_>) {
        self.t.push(f.state.t);
        for (p, tw) in f.state.pose.iter().zip(&f.state.twist) {
            self.r.push([p.r.x, p.r.y, p.r.z]);
            self.q.push([p.q.w, p.q.i, p.q.j, p.q.k]);
            self.v.push([tw.v.x, tw.v.y, tw.v.z]);
            self.w.push([tw.w.x, tw.w.y, tw.w.z]);
        }
    }
}

/// How a run ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    /// It reached the end time.
    Ok,
    /// The solution blew up: non-finite state, runaway constraint violation or energy.
    Diverged {
        /// Last good time, s.
        t: f64,
        /// What was seen, and where.
        what: String,
    },
    /// The method could not go on: a solver failed, an iteration did not converge, or the
    /// method cannot start on this scene.
    Stopped {
        /// Last good time, s.
        t: f64,
        /// Why.
        why: String,
    },
}

impl Status {
    /// Whether the run reached the end time.
    pub fn is_ok(&self) -> bool {
        matches!(self, Status::Ok)
    }

    /// The status column of `sweep.csv`: `ok`, `diverged at t = … s: …` or
    /// `stopped at t = … s: …`.
    pub fn text(&self) -> String {
        match self {
            Status::Ok => "ok".into(),
            Status::Diverged { t, what } => format!("diverged at t = {t:.4} s: {what}"),
            Status::Stopped { t, why } => format!("stopped at t = {t:.4} s: {why}"),
        }
    }

    /// When it went wrong (None for a finished run).
    pub fn time(&self) -> Option<f64> {
        match self {
            Status::Ok => None,
            Status::Diverged { t, .. } | Status::Stopped { t, .. } => Some(*t),
        }
    }

    /// A short form for tables: `ok`, `diverged`, `stopped`.
    pub fn word(&self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Diverged { .. } => "diverged",
            Status::Stopped { .. } => "stopped",
        }
    }

    /// From a run driver report.
    pub fn from_report(r: &RunReport) -> Status {
        match &r.failure {
            None if r.finished => Status::Ok,
            None => Status::Stopped {
                t: r.t_end,
                why: "the run ended early".into(),
            },
            Some(f) => classify(f.time, &f.quantity, &f.location, f.value, &f.cause),
        }
    }
}

/// Sort a failure into diverged (the solution blew up) or stopped (the method gave up).
pub fn classify(t: f64, quantity: &str, location: &str, value: f64, cause: &str) -> Status {
    let blew_up = [
        "state",
        "constraint violation",
        "relative energy growth",
        "constraint force",
    ]
    .iter()
    .any(|k| quantity.starts_with(k));
    if blew_up {
        Status::Diverged {
            t,
            what: format!("{quantity} of {location} = {value:.3e}"),
        }
    } else {
        Status::Stopped {
            t,
            why: format!("{cause} ({location})"),
        }
    }
}

/// What to run.
#[derive(Clone, Debug)]
pub struct Request<'a> {
    /// Method and options.
    pub method: &'a MethodSpec,
    /// Step, s.
    pub step: f64,
    /// End time, s.
    pub duration: f64,
    /// Output a frame every this many steps (the last step always).
    pub every: u32,
    /// Keep the frames (false for timing repetitions).
    pub keep: bool,
}

/// What one run produced.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// How it ended.
    pub status: Status,
    /// CPU time of the run, s.
    pub cpu_time: f64,
    /// Steps taken.
    pub steps: u64,
    /// Time reached, s.
    pub t_end: f64,
    /// Body states at the output frames (empty unless requested).
    pub track: Track,
    /// Largest holonomic constraint violation over the output frames.
    pub max_violation: f64,
    /// Largest relative energy drift over the output frames (see `mbdc_runtime::output`).
    pub energy_drift: f64,
    /// Mean iterations per step where the method iterates (Newton, projection).
    pub iterations: Option<f64>,
}

/// Runs a scene with a given method and step.
pub trait Runner {
    /// What runs the scene (`interpreter`, `compiled program …`).
    fn describe(&self) -> String;
    /// Run once. `Err` when the runner itself fails (the simulation failing is an
    /// [`Outcome`] with a non-ok [`Status`]).
    fn run(&mut self, req: &Request<'_>) -> Result<Outcome, String>;
}

/// CPU time of the calling thread, s (monotonic wall time where unavailable).
pub fn thread_cpu_time() -> f64 {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec and the clock id is a constant.
        let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        if rc == 0 {
            return ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9;
        }
    }
    wall_clock()
}

fn wall_clock() -> f64 {
    use std::sync::OnceLock;
    static START: OnceLock<std::time::Instant> = OnceLock::new();
    START
        .get_or_init(std::time::Instant::now)
        .elapsed()
        .as_secs_f64()
}

/// Mean iterations per step from a method's statistics.
pub fn iterations_mean(stats: &[(String, f64)], steps: u64) -> Option<f64> {
    let get = |n: &str| stats.iter().find(|(k, _)| k == n).map(|(_, v)| *v);
    get("newton_iterations_mean")
        .or_else(|| get("pcg_iterations_mean"))
        .or_else(|| get("projection_iterations").map(|v| v / steps.max(1) as f64))
}

/// Collects frames in memory.
struct Collect {
    track: Track,
    keep: bool,
}

impl Observer for Collect {
    fn frame(&mut self, f: &Frame<'_>) {
        if self.keep {
            self.track.push_frame(f);
        }
    }
}

/// Runs through the interpreter in this process.
pub struct InterpRunner {
    sys: Interp,
    watchdog: Watchdog,
}

impl InterpRunner {
    /// Build the interpreter for `scene`.
    ///
    /// # Errors
    /// If the interpreter cannot represent the scene.
    pub fn new(scene: &Scene) -> Result<InterpRunner, String> {
        let sys = Interp::new(scene).map_err(|e| e.to_string())?;
        Ok(InterpRunner {
            watchdog: watchdog(&sys, scene),
            sys,
        })
    }

    /// The system.
    pub fn system(&self) -> &Interp {
        &self.sys
    }

    /// Run with a custom observer (the reference runs sample their own frames). A panic
    /// inside the runtime is caught and reported as a stopped run.
    pub fn run_observed(
        &self,
        method: &MethodSpec,
        step: f64,
        duration: f64,
        every: u32,
        obs: &mut dyn Observer,
    ) -> RunReport {
        let cfg = RunConfig {
            duration,
            step,
            method: method.clone(),
            every: every.max(1),
            on_failure: OnFailure::Stop,
            watchdog: self.watchdog,
        };
        guarded(|| run_loop::run(&self.sys, &cfg, obs)).unwrap_or_else(|msg| RunReport {
            steps: 0,
            t_end: 0.0,
            step,
            finished: false,
            failure: Some(mbdc_runtime::run_loop::Failure {
                time: 0.0,
                step: 0,
                location: "system".into(),
                quantity: "runtime".into(),
                value: f64::NAN,
                cause: format!("the runtime panicked: {msg}"),
                hint: None,
            }),
            retries: 0,
            max_violation: (0.0, String::new()),
            max_energy_drift: 0.0,
            stats: Vec::new(),
        })
    }
}

/// Run `f`, turning a panic into an error with its message (the default panic message
/// is not printed: the caller reports it).
pub fn guarded<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    std::panic::set_hook(hook);
    r.map_err(|p| {
        p.downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "(no message)".into())
    })
}

/// The run driver's watchdog for a scene, as `mbdc run` sets it.
pub fn watchdog<S: mbdc_runtime::system::System>(sys: &S, scene: &Scene) -> Watchdog {
    Watchdog::for_scale(
        run_loop::length_scale(sys),
        mbdc_runtime::app::energy_sources(scene),
    )
}

impl Runner for InterpRunner {
    fn describe(&self) -> String {
        "interpreter (in process; CPU time of the running thread)".into()
    }

    fn run(&mut self, req: &Request<'_>) -> Result<Outcome, String> {
        let mut obs = Collect {
            track: Track::new(self.sys_bodies()),
            keep: req.keep,
        };
        let t0 = thread_cpu_time();
        let report = self.run_observed(req.method, req.step, req.duration, req.every, &mut obs);
        let cpu_time = thread_cpu_time() - t0;
        Ok(Outcome {
            status: Status::from_report(&report),
            cpu_time,
            steps: report.steps,
            t_end: report.t_end,
            track: obs.track,
            max_violation: report.max_violation.0,
            energy_drift: report.max_energy_drift,
            iterations: iterations_mean(&report.stats, report.steps),
        })
    }
}

impl InterpRunner {
    fn sys_bodies(&self) -> usize {
        use mbdc_runtime::system::System;
        self.sys.layout().bodies()
    }
}

/// The resolution of the operating system's accounting of a child's CPU time
/// (`getrusage` reports microseconds), s: the least CPU time a compiled run is given.
pub const CPU_RESOLUTION: f64 = 1e-6;

/// CPU time (user + system) of this process's finished children, s.
pub fn children_cpu_time() -> f64 {
    #[cfg(unix)]
    {
        // SAFETY: an all-zero rusage is a valid value to be overwritten.
        let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
        // SAFETY: `ru` is a valid, writable rusage.
        if unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut ru) } == 0 {
            let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
            return tv(ru.ru_utime) + tv(ru.ru_stime);
        }
    }
    wall_clock()
}

/// Runs the scene's compiled program, one process per run.
pub struct CompiledRunner {
    program: PathBuf,
    /// Scratch folder: scene files per method and the output of the current run.
    work: PathBuf,
    scene: Scene,
    /// Scene JSON files written so far, by method.
    scene_files: Vec<(MethodSpec, PathBuf)>,
    /// CPU time of a zero-length run, s.
    baseline: f64,
}

impl CompiledRunner {
    /// Generate and build the scene's program (cached by structure, as `mbdc run` does) and
    /// measure its start-up cost.
    ///
    /// # Errors
    /// If the program cannot be generated, built or started.
    pub fn new(scene: &Scene, quiet: bool) -> Result<CompiledRunner, String> {
        let krate = crate::scene_crate::prepare(scene)?;
        let program = crate::scene_crate::build(&krate, quiet).map_err(|f| {
            crate::scene_crate::report_build_failure(&f, &krate);
            format!("{} (`mbdc sweep --interp` runs the interpreter)", f.reason)
        })?;
        let work = std::env::temp_dir().join(format!(
            "mbdc-sweep-{}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_nanos())
                .unwrap_or(0)
        ));
        std::fs::create_dir_all(&work).map_err(|e| format!("creating {}: {e}", work.display()))?;
        let mut scene = scene.clone();
        scene.simulate.output = OutputSpec {
            every: 1,
            bodies: true,
            energy: false,
            constraints: false,
        };
        let mut r = CompiledRunner {
            program,
            work,
            scene,
            scene_files: Vec::new(),
            baseline: 0.0,
        };
        let method = r.scene.simulate.method.clone();
        let step = r.scene.simulate.step;
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let req = Request {
                method: &method,
                step,
                duration: 0.0,
                every: 1,
                keep: false,
            };
            best = best.min(r.run(&req)?.cpu_time);
        }
        r.baseline = best;
        Ok(r)
    }

    fn scene_file(&mut self, method: &MethodSpec) -> Result<PathBuf, String> {
        if let Some((_, p)) = self.scene_files.iter().find(|(m, _)| m == method) {
            return Ok(p.clone());
        }
        let mut s = self.scene.clone();
        s.simulate.method = method.clone();
        let text = serde_json::to_string(&s).map_err(|e| e.to_string())?;
        let p = self
            .work
            .join(format!("scene-{}.json", self.scene_files.len()));
        std::fs::write(&p, text).map_err(|e| format!("writing {}: {e}", p.display()))?;
        self.scene_files.push((method.clone(), p.clone()));
        Ok(p)
    }
}

impl Drop for CompiledRunner {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.work);
    }
}

/// Read the body states of a `bodies.csv`.
fn read_track(path: &Path, bodies: &[String]) -> Result<Track, String> {
    let mut names = vec!["t".to_string()];
    for b in bodies {
        for c in mbdc_runtime::output::BODY_COLUMNS {
            names.push(format!("{b}.{c}"));
        }
    }
    let c = crate::plot::data::read(path, &names).map_err(|e| e.to_string())?;
    let mut tr = Track::new(bodies.len());
    tr.t = c.data[0].clone();
    for f in 0..tr.t.len() {
        for b in 0..bodies.len() {
            let v = |k: usize| c.data[1 + 13 * b + k][f];
            tr.r.push([v(0), v(1), v(2)]);
            tr.q.push([v(3), v(4), v(5), v(6)]);
            tr.v.push([v(7), v(8), v(9)]);
            tr.w.push([v(10), v(11), v(12)]);
        }
    }
    Ok(tr)
}

impl Runner for CompiledRunner {
    fn describe(&self) -> String {
        format!(
            "compiled program {} (CPU time of the process, minus {:.1e} s of start-up)",
            self.program
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            self.baseline
        )
    }

    fn run(&mut self, req: &Request<'_>) -> Result<Outcome, String> {
        let scene_file = self.scene_file(req.method)?;
        let out = self.work.join("run");
        let _ = std::fs::remove_dir_all(&out);
        let c0 = children_cpu_time();
        let o = Command::new(&self.program)
            .arg("--scene")
            .arg(&scene_file)
            .args(["--step", &req.step.to_string()])
            .args(["--duration", &req.duration.to_string()])
            .args(["--every", &req.every.max(1).to_string()])
            .arg("--out")
            .arg(&out)
            .arg("--quiet")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .output()
            .map_err(|e| format!("running {}: {e}", self.program.display()))?;
        // A run that ends within the start-up's own noise (a step that diverges at once)
        // still cost something: keep it positive so that it stays on the log-scale
        // diagram (at the accounting's resolution) instead of falling off it.
        let cpu_time = (children_cpu_time() - c0 - self.baseline).max(CPU_RESOLUTION);
        if !matches!(o.status.code(), Some(0 | 1)) {
            return Err(format!(
                "the scene's program {} failed ({}): {}",
                self.program.display(),
                o.status,
                String::from_utf8_lossy(&o.stderr).trim()
            ));
        }
        let summary = Summary::read(&out.join("summary.json")).map_err(|e| e.to_string())?;
        let status = match &summary.failure {
            None if summary.finished => Status::Ok,
            None => Status::Stopped {
                t: summary.final_time,
                why: "the run ended early".into(),
            },
            Some(f) => classify(f.time, &f.quantity, &f.location, f.value, &f.cause),
        };
        let track = if req.keep {
            let names: Vec<String> = self.scene.bodies.iter().map(|b| b.name.clone()).collect();
            read_track(&out.join("bodies.csv"), &names)?
        } else {
            Track::new(self.scene.bodies.len())
        };
        let stats: Vec<(String, f64)> = summary
            .extra
            .iter()
            .filter_map(|(k, v)| Some((k.clone(), v.as_f64()?)))
            .collect();
        Ok(Outcome {
            status,
            cpu_time,
            steps: summary.steps,
            t_end: summary.final_time,
            track,
            max_violation: summary.max_constraint_violation.unwrap_or(0.0),
            energy_drift: summary.max_energy_drift.unwrap_or(0.0),
            iterations: iterations_mean(&stats, summary.steps),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classification() {
        assert!(matches!(
            classify(
                1.0,
                "state (position, orientation or velocity)",
                "body 'a'",
                f64::NAN,
                "x"
            ),
            Status::Diverged { .. }
        ));
        assert!(matches!(
            classify(
                1.0,
                "Newton residual",
                "system",
                1.0,
                "Newton did not converge"
            ),
            Status::Stopped { .. }
        ));
        let s = classify(0.5, "constraint violation |Φ|", "joint 'j'", 0.02, "c");
        assert_eq!(
            s.text(),
            "diverged at t = 0.5000 s: constraint violation |Φ| of joint 'j' = 2.000e-2"
        );
        assert_eq!(s.word(), "diverged");
    }

    #[test]
    fn iterations() {
        let st = vec![("newton_iterations_mean".to_string(), 2.5)];
        assert_eq!(iterations_mean(&st, 10), Some(2.5));
        let st = vec![("projection_iterations".to_string(), 30.0)];
        assert_eq!(iterations_mean(&st, 10), Some(3.0));
        assert_eq!(iterations_mean(&[], 10), None);
    }

    #[test]
    fn thread_clock_advances_with_work() {
        let t0 = thread_cpu_time();
        let mut x = 0.0f64;
        for i in 0..2_000_000 {
            x += (i as f64).sqrt();
        }
        assert!(x > 0.0);
        assert!(thread_cpu_time() > t0);
    }
}
