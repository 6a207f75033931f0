//! `mbdc run FILE`: simulate a scene and write its output folder.
//!
//! By default the scene runs as compiled code: its Rust is generated, built with cargo in
//! the shared workspace of compiled scenes (once per scene structure; a changed number or
//! `--set` override reuses the program) and run ([`crate::scene_crate`]). `--interp` runs the
//! interpreter ([`mbdc_runtime::interp::Interp`]) in this process instead, with no build.
//! Both paths give the same numbers, bit for bit. The run streams `bodies.csv`, `energy.csv`, `constraints.csv` and `summary.json` into the output
//! folder as it proceeds, shows a progress bar when the run takes longer than a second, and
//! ends with a summary (steps, wall time, constraint violation, energy drift) or a failure
//! report that says where and why.
//!
//! SIGINT (Ctrl-C) and SIGTERM end a run honestly on both paths: the run finishes its step,
//! writes that state as its last frame, flushes every file, writes `summary.json` with
//! `"status": "interrupted"` and the time and step, prints it, and `mbdc` exits with 130
//! (SIGINT) or 143 (SIGTERM). On the compiled path the program handles them
//! ([`mbdc_runtime::app::StopSignals`]) and this process waits for it
//! ([`crate::child_signals`]). A second Ctrl-C ends the run at once. A run whose process
//! was killed without a word (SIGKILL) leaves the `summary.json` written at its start; the
//! next `mbdc run` or `mbdc plot` on the folder says that the run did not finish.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use mbdc_compiler::Override;
use mbdc_runtime::app::{Settings, Signal, StopSignals, PROTOCOL};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::output::{RunMeta, RunStatus, Summary};
use mbdc_runtime::run_loop::{self, Frame, Observer, RunConfig};
use mbdc_runtime::scene::{MethodSpec, OutputFormat, Scene};
use mbdc_runtime::system::System;

use crate::render;
use crate::scene_crate;

#[cfg(feature = "mpi")]
mod mpi;

/// What to do when a run fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FailurePolicy {
    /// Stop and report.
    Stop,
    /// Retry from the last good frame with half the step (up to `run_loop::MAX_HALVINGS`
    /// times; the help text is built from the constant).
    #[value(help = halve_step_help())]
    HalveStep,
}

/// The help of `--on-failure halve-step`, with the runtime's retry limit.
fn halve_step_help() -> String {
    format!(
        "Retry from the last good frame with half the step (up to {} times)",
        run_loop::MAX_HALVINGS
    )
}

/// Arguments of `mbdc run`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The .mbd file.
    pub file: PathBuf,
    /// Override a parameter: `--set L=2m` (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_override)]
    pub set: Vec<Override>,
    /// Integration method (default: the scene's `simulate { method }`, else staggered).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(MethodSpec::NAMES))]
    pub method: Option<String>,
    /// Time step in seconds (default: the scene's).
    #[arg(long, value_name = "SECONDS")]
    pub step: Option<f64>,
    /// Duration in seconds (default: the scene's).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Write a frame every N steps (default: the scene's output setting).
    #[arg(long, value_name = "N")]
    pub every: Option<u32>,
    /// Output format (default: the scene's `simulate { output { format } }`, else vtk):
    /// `csv` the CSV files only, `vtk` also a ParaView series of one file per frame for
    /// beams and meshes, `exodus` one Exodus II file `results.exo` with the small CSV files.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(OutputFormat::NAMES))]
    pub format: Option<String>,
    /// Output folder (default: `out/<model name>`).
    #[arg(short = 'o', long = "out", value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Use the interpreter (no build; the default compiles the scene).
    #[arg(long)]
    pub interp: bool,
    /// Move the initial state onto the constraints before running, and report what moved.
    #[arg(long)]
    pub assemble: bool,
    /// What to do when the run fails.
    #[arg(long, value_enum, default_value_t = FailurePolicy::Stop)]
    pub on_failure: FailurePolicy,
    /// No progress bar and no summary (errors are still printed).
    #[arg(short, long)]
    pub quiet: bool,
    /// Write a checkpoint (OUTDIR/checkpoints) at the first output frame at least N steps
    /// after the last one.
    #[arg(long, value_name = "N")]
    pub checkpoint_every: Option<u64>,
    /// Write a checkpoint at the first output frame at least this many seconds of wall time
    /// after the last one.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub checkpoint_seconds: Option<f64>,
    /// Keep the newest K checkpoints (default 2).
    #[arg(long, value_name = "K")]
    pub keep_checkpoints: Option<usize>,
    /// Continue the run in the output folder from its newest checkpoint, bit for bit as if it
    /// had not stopped (same model, method, step and --every; a longer --duration extends it).
    #[arg(long)]
    pub restart: bool,
    /// At the end, write OUTDIR/view.html, the run's 3-D replay (`mbdc view`), and open it
    /// where a browser can be opened.
    #[arg(long)]
    pub view: bool,
    /// Run even if the step is above the stability limit of an explicit method.
    #[arg(long)]
    pub force: bool,
    /// Run across the ranks of MPI, under `mpirun -n P mbdc run --mpi FILE` (meshes alone:
    /// the explicit method split between the ranks, or FETI's subdomains shared by them;
    /// the interpreter runs the scene). Needs an mbdc built with `--features mpi`.
    #[arg(long)]
    pub mpi: bool,
}

fn parse_override(s: &str) -> Result<Override, String> {
    s.parse()
}

/// The scene with the command-line settings applied, or diagnostics rendered.
pub fn load(file: &std::path::Path, set: &[Override]) -> Result<Scene, ExitCode> {
    let loaded = mbdc_compiler::load_file(file, set);
    if !loaded.diagnostics.is_empty() {
        eprint!(
            "{}",
            render::diagnostics(&loaded.diagnostics, &loaded.sources)
        );
    }
    loaded.scene.ok_or_else(|| {
        eprintln!(
            "{}: {}",
            file.display(),
            render::counts(&loaded.diagnostics)
        );
        ExitCode::FAILURE
    })
}

/// The run settings from the scene and the arguments (the same rule as the compiled
/// program's, [`mbdc_runtime::app::run_config`]).
pub fn config<S: System>(sys: &S, scene: &Scene, args: &Args) -> Result<RunConfig, String> {
    mbdc_runtime::app::run_config(sys, scene, &settings(args))
}

/// The run settings given on the command line.
pub(crate) fn settings(args: &Args) -> Settings {
    Settings {
        method: args.method.clone(),
        step: args.step,
        duration: args.duration,
        every: args.every,
        format: args.format.as_deref().and_then(OutputFormat::from_name),
        halve_step: args.on_failure == FailurePolicy::HalveStep,
        checkpoint_every: args.checkpoint_every,
        checkpoint_seconds: args.checkpoint_seconds,
        keep_checkpoints: args.keep_checkpoints,
        restart: args.restart,
        restart_up_to: None,
    }
}

/// A progress bar that appears once a run has taken more than a second; with
/// [`Progress::stop_on_signals`], the run's stop requests too.
pub struct Progress {
    bar: Option<ProgressBar>,
    start: Instant,
    duration: f64,
    shown: bool,
    signals: Option<StopSignals>,
}

impl Progress {
    /// A progress observer for a run of `duration` simulated seconds (none if `quiet`).
    pub fn new(duration: f64, quiet: bool) -> Progress {
        let bar = (!quiet).then(|| {
            let b = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::hidden());
            b.set_style(
                ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {wide_bar} {msg} (eta {eta})",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            b
        });
        Progress {
            bar,
            start: Instant::now(),
            duration,
            shown: false,
            signals: None,
        }
    }

    /// Make SIGINT and SIGTERM stop requests of the run this observes, until
    /// [`Progress::finish`] (if the handlers cannot be installed, says so: the signals then
    /// end the run at once).
    pub fn stop_on_signals(mut self) -> Progress {
        match StopSignals::install() {
            Ok(s) => self.signals = Some(s),
            Err(e) => self.print(&format!(
                "warning: SIGINT and SIGTERM will end the run at once, without its summary: {e}"
            )),
        }
        self
    }

    /// Print a line on stderr without breaking the bar.
    pub fn print(&self, line: &str) {
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }

    /// Remove the bar; SIGINT and SIGTERM end the process at once again.
    pub fn finish(&mut self) {
        self.signals = None;
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

impl Observer for Progress {
    fn frame(&mut self, _f: &Frame<'_>) {}
    fn progress(&mut self, t: f64) {
        let Some(b) = &self.bar else { return };
        if !self.shown && self.start.elapsed() > Duration::from_secs(1) {
            b.set_draw_target(ProgressDrawTarget::stderr());
            self.shown = true;
        }
        let frac = if self.duration > 0.0 {
            (t / self.duration).clamp(0.0, 1.0)
        } else {
            1.0
        };
        b.set_position((frac * 1000.0) as u64);
        b.set_message(format!("t = {t:.4} s"));
    }
    fn notice(&mut self, m: &str) {
        let line = mbdc_runtime::app::notice_line(m);
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }
    fn stop_requested(&mut self) -> Option<&'static str> {
        self.signals.as_ref()?.received().map(Signal::name)
    }
}

/// Says so when the last run in `dir` did not finish: its `summary.json` is still the one
/// written at its start (its process was killed without a word, or it is still running).
pub fn note_unfinished(dir: &std::path::Path, quiet: bool) {
    if quiet {
        return;
    }
    if let Ok(s) = Summary::read(&dir.join("summary.json")) {
        if s.status() == RunStatus::Started {
            eprintln!(
                "note: the last run in {} did not finish: {}; this run replaces its output",
                dir.display(),
                UNFINISHED
            );
        }
    }
}

/// What a `summary.json` that still says `"status": "started"` means.
pub const UNFINISHED: &str = "its summary.json is still the one written when it started (its process was killed without a word — SIGKILL, a crash, a power cut — or it is still running)";

/// Runs `mbdc run`.
pub fn run(args: Args) -> ExitCode {
    if args.mpi {
        #[cfg(feature = "mpi")]
        return mpi::run(&args);
        #[cfg(not(feature = "mpi"))]
        {
            eprintln!("error: this mbdc was built without MPI: build it with `cargo build --release -p mbdc --features mpi` (which needs Open MPI's headers and libclang: `apt-get install libopenmpi-dev openmpi-bin libclang-dev`), then run `mpirun -n 4 target/release/mbdc run --mpi {}`", args.file.display());
            return ExitCode::FAILURE;
        }
    }
    let scene = match load(&args.file, &args.set) {
        Ok(s) => s,
        Err(code) => return code,
    };
    // what the run refuses before its first step, refused before a compiled program is
    // built, on the system the run starts from
    let mut sys = match crate::step_gate::interp(&scene) {
        Ok(s) => s,
        Err(code) => return code,
    };
    if args.assemble {
        // the compiled program assembles again, and reports it
        if let Err(code) = assemble(&mut sys, args.quiet || !args.interp) {
            return code;
        }
    }
    if let Err(code) =
        crate::step_gate::gate(&scene, &sys, &settings(&args), args.force, args.quiet)
    {
        return code;
    }
    let code = if args.interp {
        simulate(&sys, &scene, &args)
    } else {
        run_compiled(&scene, &args)
    };
    if args.view {
        let dir = args
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("out").join(&scene.name));
        // also after a failure: the replay shows where it went wrong
        if dir.join("summary.json").exists() {
            crate::commands::view::write_and_open(
                &dir,
                crate::view::ViewOptions::default(),
                true,
                args.quiet,
            );
        }
    }
    code
}

fn assemble(sys: &mut Interp, quiet: bool) -> Result<(), ExitCode> {
    let mut st = mbdc_runtime::integrators::State::initial(&*sys);
    match mbdc_runtime::assemble::assemble(&*sys, &mut st.pose, &mut st.twist) {
        Ok(a) => {
            if !quiet {
                for l in mbdc_runtime::app::assembly_report(&a) {
                    eprintln!("{l}");
                }
            }
            sys.set_initial_state(&st.pose, &st.twist);
            Ok(())
        }
        Err(e) => {
            eprintln!("error: {e}\n  help: check the joints' points and axes; `mbdc check` lists each joint's violation at t = 0");
            Err(ExitCode::FAILURE)
        }
    }
}

/// Run a system and write the output folder, printing the summary; shared by the
/// interpreter path and (through the generated program) the compiled path.
pub fn simulate<S: System>(sys: &S, scene: &Scene, args: &Args) -> ExitCode {
    let mut cfg = match config(sys, scene, args) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&scene.name));
    match mbdc_runtime::app::checkpoints(sys, scene, &mut cfg, &settings(args), &dir) {
        Ok(notes) => {
            if !args.quiet {
                for n in notes {
                    eprintln!("{n}");
                }
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    }
    let meta = RunMeta::new(scene, &cfg);
    note_unfinished(&dir, args.quiet);
    if let Err(e) = mbdc_runtime::output::write_scene(&dir, scene) {
        eprintln!("error: writing the output folder {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    let mut progress = Progress::new(cfg.duration, args.quiet).stop_on_signals();
    let spec = mbdc_runtime::app::output_spec(scene, &settings(args));
    let result = run_loop::run_to_dir(sys, &cfg, meta, &spec, &dir, &mut progress);
    progress.finish();
    let code = match result {
        Ok((report, summary)) => {
            if !args.quiet || report.failure.is_some() || report.interrupted.is_some() {
                print_summary(&summary, &dir);
            }
            exit_code(&report)
        }
        Err(e) => {
            eprintln!("error: writing the output folder {}: {e}", dir.display());
            // a folder that cannot be written takes no plots either
            eprintln!("  no plots: the folder's files end where the error left them; `mbdc plot {}` draws them once there is room", dir.display());
            return ExitCode::FAILURE;
        }
    };
    // plots of whatever frames were written, also when the run stopped early
    crate::plot::run_plots::after_run(&dir, args.quiet);
    code
}

/// A finished run's exit code: the signal's for an interrupted run, success for one that
/// reached its end, failure otherwise.
pub(crate) fn exit_code(report: &run_loop::RunReport) -> ExitCode {
    if let Some(i) = &report.interrupted {
        mbdc_runtime::app::exit_code(i)
    } else if report.finished {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

/// The summary's energy-balance line: the terms where the run ended, the error and the
/// largest error over every step, relative to the energy in play.
fn energy_balance_line(b: &mbdc_runtime::output::EnergyBalance, max_drift: Option<f64>) -> String {
    let mut s = format!(
        "  energy balance: kinetic {:.4e} J + potential {:.4e} J",
        b.kinetic, b.potential
    );
    if b.work_forces != 0.0 || b.work_drivers != 0.0 {
        s.push_str(&format!(
            " − work in {:.4e} J (forces {:.4e} J, drivers {:.4e} J)",
            b.work_forces + b.work_drivers,
            b.work_forces,
            b.work_drivers
        ));
    }
    if b.impulses != 0.0 {
        s.push_str(&format!(" − impulses {:.4e} J", b.impulses));
    }
    s.push_str(&format!(
        " − start {:.4e} J = {:.3e} J, {:.3e} of the {:.3e} J in play",
        b.start,
        b.error(),
        b.error() / b.in_play.max(1e-300),
        b.in_play
    ));
    if let Some(d) = max_drift {
        s.push_str(&format!(" (largest over the run {d:.3e})"));
    }
    s
}

/// The end-of-run summary on the terminal.
pub fn print_summary(s: &Summary, dir: &std::path::Path) {
    let status = s.status().word();
    println!(
        "{} — {} with {} (h = {:.3e} s)",
        s.model, status, s.method, s.step
    );
    println!(
        "  {} steps to t = {:.6} s in {:.3} s wall time ({:.3} µs/step)",
        s.steps,
        s.final_time,
        s.wall_time,
        if s.steps > 0 {
            s.wall_time / s.steps as f64 * 1e6
        } else {
            0.0
        }
    );
    if let Some(v) = s.max_constraint_violation {
        let at = s
            .max_violation_joint
            .as_deref()
            .map(|j| format!(" (joint {j})"))
            .unwrap_or_default();
        println!("  max constraint violation {v:.3e}{at}");
    }
    if let Some(b) = &s.energy_balance {
        println!("{}", energy_balance_line(b, s.max_energy_drift));
    } else if let Some(d) = s.max_energy_drift {
        println!("  energy balance error, largest: {d:.3e} of the energy in play");
    }
    for (k, v) in &s.extra {
        if k == "warnings" {
            continue;
        }
        println!("  {k}: {v}");
    }
    // the warnings were notices during the run; repeated here, where they are seen
    if let Some(serde_json::Value::Array(ws)) = s.extra.get("warnings") {
        for w in ws.iter().filter_map(|w| w.as_str()) {
            eprintln!("{w}");
        }
    }
    if let Some(f) = &s.failure {
        eprintln!(
            "error: the run stopped at t = {:.6} s (step {}) at {}",
            f.time, f.step, f.location
        );
        eprintln!("  {} = {:.3e}", f.quantity, f.value);
        eprintln!("  cause: {}", f.cause);
        if let Some(h) = &f.hint {
            eprintln!("  help: {h}");
        }
        eprintln!(
            "  every frame up to t = {:.6} s is in {}",
            f.time,
            dir.display()
        );
    } else if let Some(i) = &s.interrupted {
        eprintln!("{i}");
        eprintln!(
            "  every frame up to t = {:.6} s is in {}",
            i.time,
            dir.display()
        );
    } else if s.status() == RunStatus::Started {
        eprintln!("error: the run did not finish: {UNFINISHED}");
        eprintln!("  the frames written until then are in {}", dir.display());
    } else {
        println!("  output: {}", dir.display());
    }
}

/// `mbdc run` through compiled code.
pub fn run_compiled(scene: &Scene, args: &Args) -> ExitCode {
    let krate = match scene_crate::prepare(scene) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let program = match scene_crate::build(&krate, args.quiet) {
        Ok(p) => p,
        Err(f) => {
            scene_crate::report_build_failure(&f, &krate);
            return ExitCode::FAILURE;
        }
    };
    let scene_file = krate.dir.join(format!(
        "run-{}-{}.json",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0)
    ));
    let json = match serde_json::to_string(scene) {
        Ok(j) => j,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    if let Err(e) = scene_crate::write(&scene_file, &json) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&scene.name));
    note_unfinished(&dir, args.quiet);
    let mut cmd = Command::new(&program);
    cmd.arg("--scene")
        .arg(&scene_file)
        .arg("--out")
        .arg(&dir)
        .arg("--progress");
    if let Some(m) = &args.method {
        cmd.arg("--method").arg(m);
    }
    if let Some(s) = args.step {
        cmd.arg("--step").arg(s.to_string());
    }
    if let Some(d) = args.duration {
        cmd.arg("--duration").arg(d.to_string());
    }
    if let Some(n) = args.every {
        cmd.arg("--every").arg(n.to_string());
    }
    if let Some(f) = &args.format {
        cmd.arg("--format").arg(f);
    }
    if args.on_failure == FailurePolicy::HalveStep {
        cmd.arg("--on-failure").arg("halve-step");
    }
    if args.assemble {
        cmd.arg("--assemble");
    }
    if let Some(n) = args.checkpoint_every {
        cmd.arg("--checkpoint-every").arg(n.to_string());
    }
    if let Some(t) = args.checkpoint_seconds {
        cmd.arg("--checkpoint-seconds").arg(t.to_string());
    }
    if let Some(k) = args.keep_checkpoints {
        cmd.arg("--keep-checkpoints").arg(k.to_string());
    }
    if args.restart {
        cmd.arg("--restart");
    }
    if args.quiet {
        cmd.arg("--quiet");
    }
    cmd.stdin(Stdio::null()).stderr(Stdio::piped());
    let duration = args.duration.unwrap_or(scene.simulate.duration);
    let mut progress = Progress::new(duration, args.quiet);
    // SIGINT must not end this process before the program has written its summary;
    // SIGTERM is forwarded to it
    let mut forward = match crate::child_signals::Forward::start() {
        Ok(f) => Some(f),
        Err(e) => {
            progress.print(&format!("warning: SIGINT and SIGTERM will end mbdc before the run has written its summary: {e}"));
            None
        }
    };
    let status = match cmd.spawn() {
        Ok(mut child) => {
            if let Some(f) = &forward {
                f.child(child.id());
            }
            if let Some(err) = child.stderr.take() {
                for line in BufReader::new(err).lines().map_while(Result::ok) {
                    match line.strip_prefix(PROTOCOL) {
                        Some(rest) => {
                            if let Some(t) = rest.strip_prefix("progress ") {
                                if let Ok(t) = t.trim().parse() {
                                    progress.progress(t);
                                }
                            } else if let Some(m) = rest.strip_prefix("notice ") {
                                progress.notice(&scene_crate::unescape(m));
                            }
                        }
                        None => progress.print(&line),
                    }
                }
            }
            // the program's stderr has ended: it has exited (not yet reaped)
            if let Some(f) = forward.take() {
                f.stop();
            }
            child.wait()
        }
        Err(e) => Err(e),
    };
    if let Some(f) = forward {
        f.stop();
    }
    progress.finish();
    let _ = std::fs::remove_file(&scene_file);
    let status = match status {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: running {}: {e}", program.display());
            return ExitCode::FAILURE;
        }
    };
    if status.code() == Some(2) {
        // the program could not start (its error is printed above)
        return ExitCode::FAILURE;
    }
    if status.code().is_none() {
        // ended by a signal it does not handle, or by a second SIGINT: what it wrote until
        // then is whole, its summary.json is the one written at the start
        eprintln!(
            "error: the scene's program was terminated ({status}) before it wrote its summary"
        );
        eprintln!(
            "  what it wrote until then is in {}, whole (a summary.json there says the run did not finish)",
            dir.display()
        );
        return ExitCode::from(killed_code(&status));
    }
    let summary: Option<Summary> = Summary::read(&dir.join("summary.json")).ok();
    let code = match summary {
        Some(s) => {
            if !args.quiet || s.failure.is_some() || s.interrupted.is_some() {
                print_summary(&s, &dir);
            }
            if let Some(i) = &s.interrupted {
                // the program's own code (130 or 143)
                status
                    .code()
                    .and_then(|c| u8::try_from(c).ok())
                    .map_or_else(|| mbdc_runtime::app::exit_code(i), ExitCode::from)
            } else if s.finished && status.success() {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
        None => {
            eprintln!("error: the run wrote no summary.json in {}", dir.display());
            ExitCode::FAILURE
        }
    };
    crate::plot::run_plots::after_run(&dir, args.quiet);
    code
}

/// The exit code of a program a signal ended, as shells give it: 128 + the signal's number
/// (1 where there are no signals).
fn killed_code(status: &std::process::ExitStatus) -> u8 {
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(sig) = status.signal() {
            return u8::try_from(128 + sig).unwrap_or(1);
        }
    }
    let _ = status;
    1
}
