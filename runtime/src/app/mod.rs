//! The program entry of a compiled scene: what the `main.rs` of a crate written by
//! `mbdc run` calls, so that the generated program is a few lines.
//!
//! ```text
//! scene-program [--scene FILE.json] [--method NAME] [--step S] [--duration S] [--every N]
//!               [--format csv|vtk|exodus]
//!               [--out DIR] [--on-failure stop|halve-step] [--assemble] [--progress] [--quiet]
//!               [--checkpoint-every N] [--checkpoint-seconds S] [--keep-checkpoints K] [--restart]
//! ```
//!
//! - `--scene`: the scene (JSON of a [`Scene`]) with the numbers to run; it must have the
//!   structure the program was generated for. Default: the scene embedded at generation.
//! - `--method`, `--step`, `--duration`, `--every`: as `mbdc run` ([`run_config`]).
//! - `--format`: the output format instead of the scene's ([`output_spec`]).
//! - `--out`: the output folder (default `out/<model name>`).
//! - `--checkpoint-every`, `--checkpoint-seconds`, `--keep-checkpoints`, `--restart`:
//!   checkpoints in `OUT/checkpoints` and continuing from the newest ([`checkpoints`]).
//! - `--progress`: machine-readable progress on stderr for the `mbdc` command-line
//!   program, one line each: `@mbdc progress <t>` and `@mbdc notice <text>` (newlines
//!   escaped as `\n`); without it, notices are plain lines and a summary is printed at the end.
//!
//! Exit codes: 0 the run finished, 1 the run stopped early (the failure is in
//! `summary.json`), 2 the run could not start (bad arguments, another structure, output
//! folder not writable), 130 or 143 the run was interrupted by SIGINT or SIGTERM: it
//! finished its step, wrote that state as its last frame, flushed every file and wrote
//! `summary.json` with `"status": "interrupted"` ([`StopSignals`]). A second SIGINT ends
//! the program at once (the frames written are whole; `summary.json` stays the one written
//! at the start, `"status": "started"`).

mod signals;

pub use signals::{Signal, StopSignals};

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use crate::compiled::{self, CompiledModel};
use crate::contract::scene::{MethodSpec, Scene};
use crate::contract::system::System;
use crate::driver::output::RunMeta;
use crate::driver::run_loop::{self, Frame, Observer, OnFailure, RunConfig, Watchdog};
use crate::integrators::State;

/// Prefix of the machine-readable lines written with `--progress`.
pub const PROTOCOL: &str = "@mbdc ";

/// The run settings a user may give on the command line (`None`: the scene's).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Settings {
    /// Method name ([`MethodSpec::NAMES`]); the scene's options are kept when it is the
    /// scene's method, the defaults are used otherwise.
    pub method: Option<String>,
    /// Step, s.
    pub step: Option<f64>,
    /// Duration, s.
    pub duration: Option<f64>,
    /// Output every N steps.
    pub every: Option<u32>,
    /// Output format instead of the scene's (`simulate { output { format } }`).
    pub format: Option<crate::contract::scene::OutputFormat>,
    /// Retry with half the step on failure (up to 10 times).
    pub halve_step: bool,
    /// Write a checkpoint at the first output frame at least this many steps after the last.
    pub checkpoint_every: Option<u64>,
    /// Write a checkpoint at the first output frame at least this many seconds of wall time
    /// after the last.
    pub checkpoint_seconds: Option<f64>,
    /// Keep the newest this many checkpoints (default 2).
    pub keep_checkpoints: Option<usize>,
    /// Continue the run in the output folder from its newest checkpoint.
    pub restart: bool,
    /// With `restart`: continue from the newest checkpoint at or before this step (the
    /// ranks of a distributed run restart from a step that every one of them saved).
    pub restart_up_to: Option<u64>,
}

/// Set up checkpoints and restart in `cfg` from the scene's `output { checkpoint_every …;
/// checkpoint_seconds …; keep_checkpoints … }` and the user's settings, which override them
/// one by one: where checkpoints go (`DIR/checkpoints`) and when, and, with `restart`, the
/// newest checkpoint of `dir` to continue from. Returns notes for the user (a newer
/// checkpoint refused as damaged, where the run continues from).
///
/// # Errors
/// An option out of range, no checkpoint to restart from, or a checkpoint of another run
/// (the message names what differs: model, method, step, output interval, sizes, mbdc
/// version or the scene's numbers).
pub fn checkpoints<S: System>(
    sys: &S,
    scene: &Scene,
    cfg: &mut RunConfig,
    s: &Settings,
    dir: &std::path::Path,
) -> Result<Vec<String>, String> {
    use crate::driver::checkpoint::{self, CheckpointSpec, Identity};
    if s.checkpoint_every == Some(0) {
        return Err("`--checkpoint-every` must be at least 1 step".into());
    }
    if let Some(t) = s.checkpoint_seconds {
        if !(t.is_finite() && t > 0.0) {
            return Err(format!(
                "`--checkpoint-seconds` must be positive and finite, got {t}"
            ));
        }
    }
    if s.keep_checkpoints == Some(0) {
        return Err("`--keep-checkpoints` must be at least 1".into());
    }
    // The scene's `output { checkpoint_every …; checkpoint_seconds …; keep_checkpoints … }`
    // (checked by the compiler), each overridden by its command-line option.
    let own = scene.simulate.output.checkpoint;
    let every_steps = s.checkpoint_every.or(own.every_steps.filter(|&n| n > 0));
    let every_seconds = s
        .checkpoint_seconds
        .or(own.every_seconds.filter(|t| t.is_finite() && *t > 0.0));
    let keep = s
        .keep_checkpoints
        .or(own.keep.filter(|&k| k > 0).map(|k| k as usize))
        .unwrap_or(2);
    let identity = Identity::of(
        scene,
        sys.layout(),
        cfg.method.name(),
        cfg.step,
        cfg.every,
        output_spec(scene, s).format,
    );
    let folder = dir.join(checkpoint::FOLDER);
    let mut notes = Vec::new();
    if s.restart {
        let (c, refused) = checkpoint::latest_up_to(&folder, s.restart_up_to.unwrap_or(u64::MAX))
            .map_err(|e| e.to_string())?;
        for r in refused {
            notes.push(format!("warning: {r}; continuing from an older checkpoint"));
        }
        if let Some(d) = c.identity.difference(&identity) {
            return Err(format!(
                "{} is a checkpoint of another run: {d}
  help: restart with the model, method, step, --every and --format it was written with",
                c.path.display()
            ));
        }
        notes.push(format!(
            "restarting from {} (t = {} s, step {})",
            c.path.display(),
            c.time,
            c.step
        ));
        cfg.resume = Some(run_loop::Resume {
            output: c.output,
            run: c.run,
        });
    }
    if every_steps.is_some() || every_seconds.is_some() {
        cfg.checkpoint = Some(CheckpointSpec {
            dir: folder,
            every_steps,
            every_seconds,
            keep,
            identity,
        });
    }
    Ok(notes)
}

/// Whether a scene has forces or rows that do work the potential energy does not hold
/// (applied forces, dampers, drivers, prescribed velocities, contact, time dependence): then
/// the watchdog's energy balance books their work (`driver/work.rs`), at the cost of
/// one force and two potential-energy evaluations per step. Without them (gravity, springs,
/// beams, meshes, whose own loads' work the meshes book) the balance is `K + V = E₀` and
/// costs nothing.
pub fn energy_sources(scene: &Scene) -> bool {
    let e = crate::analysis::effects::Effects::of(scene);
    e.applied_forces || e.dampers || e.drivers || e.nonholonomic || e.contact || e.time_dependence
}

/// The run configuration of `scene` on `sys` with the user's settings: the same for the
/// interpreter and compiled code. Refused: a step or duration out of range
/// ([`crate::analysis::input_limits::check_run`]) and method options out of range
/// ([`crate::analysis::input_limits::check_method`]).
pub fn run_config<S: System>(sys: &S, scene: &Scene, s: &Settings) -> Result<RunConfig, String> {
    let method = match &s.method {
        Some(name) if name != scene.simulate.method.name() => {
            MethodSpec::default_for(name).ok_or_else(|| format!("unknown method `{name}`"))?
        }
        _ => scene.simulate.method.clone(),
    };
    let step = s.step.unwrap_or(scene.simulate.step);
    let duration = s.duration.unwrap_or(scene.simulate.duration);
    crate::analysis::input_limits::check_run(step, duration)?;
    crate::analysis::input_limits::check_method(&method)?;
    Ok(RunConfig {
        duration,
        step,
        method,
        every: s.every.unwrap_or(scene.simulate.output.every).max(1),
        on_failure: if s.halve_step {
            OnFailure::HalveStep(run_loop::MAX_HALVINGS)
        } else {
            OnFailure::Stop
        },
        watchdog: Watchdog::for_scale(run_loop::length_scale(sys), energy_sources(scene)),
        checkpoint: None,
        resume: None,
    })
}

/// The output the run writes: the scene's, with the format the user chose, if any.
pub fn output_spec(scene: &Scene, s: &Settings) -> crate::contract::scene::OutputSpec {
    let mut spec = scene.simulate.output.clone();
    if let Some(f) = s.format {
        spec.format = f;
    }
    spec
}

/// A run's notice as the terminal shows it: `note: ` before it, unless it says itself what it
/// is (a warning at the end of a run starts with `warning:`).
pub fn notice_line(m: &str) -> String {
    if m.starts_with("warning:") || m.starts_with("note:") {
        m.to_string()
    } else {
        format!("note: {m}")
    }
}

/// The lines `mbdc run --assemble` prints about an assembly.
pub fn assembly_report(a: &crate::driver::assemble::Assembly) -> Vec<String> {
    let mut v = vec![format!(
        "assembled in {} iteration(s): violation {:.3e} → {:.3e}, velocity residual {:.3e} → {:.3e}",
        a.iterations, a.residual.0, a.residual.1, a.velocity_residual.0, a.velocity_residual.1
    )];
    for m in &a.moved {
        v.push(format!(
            "  moved {:<16} by {:.3e} m and {:.3e} rad; velocity changed by {:.3e} m/s and {:.3e} rad/s",
            m.body, m.translation, m.rotation, m.velocity, m.angular_velocity
        ));
    }
    v
}

/// Parsed program arguments.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Args {
    /// `--scene`.
    pub scene: Option<PathBuf>,
    /// Run settings.
    pub settings: Settings,
    /// `--out`.
    pub out: Option<PathBuf>,
    /// `--assemble`.
    pub assemble: bool,
    /// `--progress`.
    pub progress: bool,
    /// `--quiet`.
    pub quiet: bool,
}

impl Args {
    /// Parse arguments (without the program name).
    pub fn parse<I: IntoIterator<Item = String>>(args: I) -> Result<Args, String> {
        let mut a = Args::default();
        let mut it = args.into_iter();
        while let Some(flag) = it.next() {
            let mut value = |what: &str| {
                it.next()
                    .ok_or_else(|| format!("`{flag}` needs a value ({what})"))
            };
            let num = |v: String, what: &str| -> Result<f64, String> {
                v.parse::<f64>()
                    .map_err(|_| format!("`{flag}`: `{v}` is not a number ({what})"))
            };
            match flag.as_str() {
                "--scene" => a.scene = Some(PathBuf::from(value("a JSON file")?)),
                "--method" => a.settings.method = Some(value("a method name")?),
                "--step" => a.settings.step = Some(num(value("seconds")?, "seconds")?),
                "--duration" => a.settings.duration = Some(num(value("seconds")?, "seconds")?),
                "--every" => {
                    let v = value("a step count")?;
                    a.settings.every = Some(
                        v.parse()
                            .map_err(|_| format!("`--every`: `{v}` is not a step count"))?,
                    );
                }
                "--format" => {
                    let v = value("csv, vtk or exodus")?;
                    a.settings.format = Some(
                        crate::contract::scene::OutputFormat::from_name(&v).ok_or_else(|| {
                            format!("`--format`: expected csv, vtk or exodus, found `{v}`")
                        })?,
                    );
                }
                "--out" | "-o" => a.out = Some(PathBuf::from(value("a folder")?)),
                "--on-failure" => match value("stop or halve-step")?.as_str() {
                    "stop" => a.settings.halve_step = false,
                    "halve-step" => a.settings.halve_step = true,
                    v => {
                        return Err(format!(
                            "`--on-failure`: expected stop or halve-step, found `{v}`"
                        ))
                    }
                },
                "--checkpoint-every" => {
                    let v = value("a step count")?;
                    a.settings.checkpoint_every =
                        Some(v.parse().map_err(|_| {
                            format!("`--checkpoint-every`: `{v}` is not a step count")
                        })?);
                }
                "--checkpoint-seconds" => {
                    a.settings.checkpoint_seconds = Some(num(value("seconds")?, "seconds")?)
                }
                "--keep-checkpoints" => {
                    let v = value("a count")?;
                    a.settings.keep_checkpoints = Some(
                        v.parse()
                            .map_err(|_| format!("`--keep-checkpoints`: `{v}` is not a count"))?,
                    );
                }
                "--restart" => a.settings.restart = true,
                "--assemble" => a.assemble = true,
                "--progress" => a.progress = true,
                "--quiet" | "-q" => a.quiet = true,
                f => return Err(format!("unknown argument `{f}`")),
            }
        }
        Ok(a)
    }
}

/// Progress reporting of the program: protocol lines or plain notices; stop requests from
/// the signals.
struct Reporter<'a> {
    protocol: bool,
    last: Instant,
    signals: Option<&'a StopSignals>,
}

impl Observer for Reporter<'_> {
    fn frame(&mut self, _f: &Frame<'_>) {}
    fn progress(&mut self, t: f64) {
        if self.protocol && self.last.elapsed() >= Duration::from_millis(50) {
            self.last = Instant::now();
            eprintln!("{PROTOCOL}progress {t}");
        }
    }
    fn notice(&mut self, m: &str) {
        if self.protocol {
            eprintln!(
                "{PROTOCOL}notice {}",
                m.replace('\\', "\\\\").replace('\n', "\\n")
            );
        } else {
            eprintln!("{}", notice_line(m));
        }
    }
    fn stop_requested(&mut self) -> Option<&'static str> {
        self.signals?.received().map(Signal::name)
    }
}

/// Run the program of a compiled model `M` with the process arguments (see the module
/// doc). The `main` of a generated crate is `mbdc_runtime::app::main::<Model>()`.
pub fn main<M: CompiledModel>() -> ExitCode {
    ignore_file_size_signal();
    match Args::parse(std::env::args().skip(1)) {
        Ok(a) => run_with::<M>(&a),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

/// Ignore SIGXFSZ: past the file-size limit (`ulimit -f`) a write then fails with `EFBIG` and
/// the run stops with a report naming the file, as on a full disk, instead of the process
/// ending at once without one.
fn ignore_file_size_signal() {
    #[cfg(unix)]
    // SAFETY: called first thing in `main`, before the program starts threads; SIG_IGN
    // installs no handler.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

/// Run a compiled model with parsed arguments. For the time of the run, SIGINT and SIGTERM
/// are stop requests ([`StopSignals`]; see the module doc for the exit codes).
pub fn run_with<M: CompiledModel>(args: &Args) -> ExitCode {
    let fail = |e: String| {
        eprintln!("error: {e}");
        ExitCode::from(2)
    };
    let scene = match &args.scene {
        Some(p) => match std::fs::read_to_string(p) {
            Ok(text) => compiled::scene_from_json(&text),
            Err(e) => return fail(format!("reading {}: {e}", p.display())),
        },
        None => M::default_scene(),
    };
    let scene = match scene {
        Ok(s) => s,
        Err(e) => return fail(e.to_string()),
    };
    let mut sys = match M::from_scene(&scene) {
        Ok(s) => s,
        Err(e) => return fail(e.to_string()),
    };
    if args.assemble {
        let mut st = State::initial(&sys);
        match crate::driver::assemble::assemble(&sys, &mut st.pose, &mut st.twist) {
            Ok(a) => {
                if !args.quiet {
                    for l in assembly_report(&a) {
                        eprintln!("{l}");
                    }
                }
                sys.set_initial_state(&st.pose, &st.twist);
            }
            Err(e) => return fail(format!("{e}\n  help: check the joints' points and axes; `mbdc check` lists each joint's violation at t = 0")),
        }
    }
    let mut cfg = match run_config(&sys, &scene, &args.settings) {
        Ok(c) => c,
        Err(e) => return fail(e),
    };
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&scene.name));
    match checkpoints(&sys, &scene, &mut cfg, &args.settings, &dir) {
        Ok(notes) => {
            for n in notes {
                if args.progress {
                    eprintln!(
                        "{PROTOCOL}notice {}",
                        n.replace('\\', "\\\\").replace('\n', "\\n")
                    );
                } else if !args.quiet {
                    eprintln!("{n}");
                }
            }
        }
        Err(e) => return fail(e),
    }
    let meta = RunMeta::new(&scene, &cfg);
    let signals = match StopSignals::install() {
        Ok(s) => Some(s),
        Err(e) => {
            eprintln!(
                "warning: SIGINT and SIGTERM will end the run at once, without its summary: {e}"
            );
            None
        }
    };
    let mut rep = Reporter {
        protocol: args.progress,
        last: Instant::now(),
        signals: signals.as_ref(),
    };
    if let Err(e) = crate::driver::output::write_scene(&dir, &scene) {
        return fail(format!("writing the output folder {}: {e}", dir.display()));
    }
    let spec = output_spec(&scene, &args.settings);
    let result = run_loop::run_to_dir(&sys, &cfg, meta, &spec, &dir, &mut rep);
    // the run is over: a signal ends the program at once again
    drop(signals);
    match result {
        Ok((report, summary)) => {
            if !args.progress && !args.quiet {
                println!(
                    "{} — {} with {}: {} steps to t = {:.6} s in {:.3} s; output in {}",
                    summary.model,
                    summary.status().word(),
                    summary.method,
                    summary.steps,
                    summary.final_time,
                    summary.wall_time,
                    dir.display()
                );
                if let Some(f) = &report.failure {
                    eprintln!("error: {f}");
                }
            }
            if let Some(i) = &report.interrupted {
                if !args.progress {
                    eprintln!("{i}; every frame up to then is in {}", dir.display());
                }
                return exit_code(i);
            }
            if report.finished {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
        Err(e) => fail(format!("writing the output folder {}: {e}", dir.display())),
    }
}

/// The exit code of an interrupted run: 130 for SIGINT, 143 for SIGTERM
/// ([`Signal::exit_code`]), 1 for a request that was no signal.
pub fn exit_code(i: &crate::driver::run_loop::Interruption) -> ExitCode {
    ExitCode::from(Signal::from_name(&i.by).map_or(1, Signal::exit_code))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arguments() {
        let a = Args::parse(
            [
                "--method",
                "baumgarte",
                "--step",
                "1e-3",
                "--out",
                "x",
                "--on-failure",
                "halve-step",
                "--progress",
            ]
            .map(String::from),
        )
        .unwrap();
        assert_eq!(a.settings.method.as_deref(), Some("baumgarte"));
        assert_eq!(a.settings.step, Some(1e-3));
        assert!(a.settings.halve_step && a.progress && !a.quiet);
        assert_eq!(a.out, Some(PathBuf::from("x")));
        assert!(Args::parse(["--step".to_string()]).is_err());
        assert!(Args::parse(["--step", "x"].map(String::from)).is_err());
        assert!(Args::parse(["--bogus".to_string()]).is_err());
        let a = Args::parse(["--format", "exodus"].map(String::from)).unwrap();
        assert_eq!(
            a.settings.format,
            Some(crate::contract::scene::OutputFormat::Exodus)
        );
        let e = Args::parse(["--format", "hdf5"].map(String::from)).unwrap_err();
        assert!(
            e.contains("csv, vtk or exodus") && e.contains("hdf5"),
            "{e}"
        );
    }
}
