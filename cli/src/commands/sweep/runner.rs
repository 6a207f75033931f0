//! The compiled-program runner of `mbdc sweep`: a [`Runner`] of
//! [`mbdc_runtime::study`] that runs the scene's generated program (built once by
//! `mbdc run`'s compiled path, `crate::scene_crate`), one process per run, with the method,
//! step, duration and output interval as options, and reads back `summary.json` and
//! `bodies.csv`.
//!
//! Its CPU time is measured around the program: the user + system time the operating
//! system accounts to the finished child (`getrusage(RUSAGE_CHILDREN)`), minus the same for
//! a zero-length run of the program (start-up, reading the scene, writing the files), so
//! that what remains is the integration, as for the library's
//! [`InterpRunner`](mbdc_runtime::study::InterpRunner). A run shorter than the noise of that
//! subtraction (a step that diverges at once) is given [`CPU_RESOLUTION`], not zero, so that
//! it stays on the log-scale diagram.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use mbdc_runtime::output::Summary;
use mbdc_runtime::scene::{MethodSpec, OutputSpec, Scene};
use mbdc_runtime::study::runner::{classify, iterations_mean};
use mbdc_runtime::study::{Outcome, Request, Runner, RunnerError, Status, Track};

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
    mbdc_runtime::study::cpu_time::wall_clock()
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
            ..OutputSpec::default()
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
            best = best.min(r.run(&req).map_err(|e| e.0)?.cpu_time);
        }
        r.baseline = best;
        Ok(r)
    }

    fn scene_file(&mut self, method: &MethodSpec) -> Result<PathBuf, RunnerError> {
        if let Some((_, p)) = self.scene_files.iter().find(|(m, _)| m == method) {
            return Ok(p.clone());
        }
        let mut s = self.scene.clone();
        s.simulate.method = method.clone();
        let text = serde_json::to_string(&s).map_err(|e| RunnerError(e.to_string()))?;
        let p = self
            .work
            .join(format!("scene-{}.json", self.scene_files.len()));
        std::fs::write(&p, text)
            .map_err(|e| RunnerError(format!("writing {}: {e}", p.display())))?;
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
fn read_track(path: &Path, bodies: &[String]) -> Result<Track, RunnerError> {
    let mut names = vec!["t".to_string()];
    for b in bodies {
        for c in mbdc_runtime::output::BODY_COLUMNS {
            names.push(format!("{b}.{c}"));
        }
    }
    let c = crate::plot::data::read(path, &names).map_err(|e| RunnerError(e.to_string()))?;
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

    fn run(&mut self, req: &Request<'_>) -> Result<Outcome, RunnerError> {
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
            .map_err(|e| RunnerError(format!("running {}: {e}", self.program.display())))?;
        // A run that ends within the start-up's own noise (a step that diverges at once)
        // still cost something: keep it positive so that it stays on the log-scale
        // diagram (at the accounting's resolution) instead of falling off it.
        let cpu_time = (children_cpu_time() - c0 - self.baseline).max(CPU_RESOLUTION);
        // 130 and 143: interrupted by SIGINT or SIGTERM, with its summary written
        if !matches!(o.status.code(), Some(0 | 1 | 130 | 143)) {
            return Err(RunnerError(format!(
                "the scene's program {} failed ({}): {}",
                self.program.display(),
                o.status,
                String::from_utf8_lossy(&o.stderr).trim()
            )));
        }
        let summary =
            Summary::read(&out.join("summary.json")).map_err(|e| RunnerError(e.to_string()))?;
        let status = match &summary.failure {
            None if summary.finished => Status::Ok,
            None if summary.interrupted.is_some() => Status::Stopped {
                t: summary.final_time,
                why: summary
                    .interrupted
                    .as_ref()
                    .map(ToString::to_string)
                    .unwrap_or_default(),
            },
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
