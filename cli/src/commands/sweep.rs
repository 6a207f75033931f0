//! `mbdc sweep FILE`: what accuracy costs in time.
//!
//! Runs the scene across a set of step sizes and methods and measures, for each run, the
//! CPU time (best of k repetitions, k such that the repetitions of one run add up to at
//! least `--min-time`, 0.2 s by default), the error against a reference, the largest
//! constraint violation, the energy drift and the mean iterations where the method
//! iterates. Writes `sweep.csv` (one row per run), `sweep.json` (the same plus the
//! reference and the fitted orders) and `sweep.svg` (work–precision and error-vs-step
//! diagrams) into the output folder, and prints a markdown table, the fitted convergence
//! orders and a short "reading this".
//!
//! The engine lives in the runtime library, [`mbdc_runtime::study`]: the step series, the
//! choice of methods, the references (analytic, table, numerical with its Richardson
//! estimate), the error measures, the order fit and the cost of an error are all there,
//! documented, and usable from Rust. This command is its front end:
//!
//! - the arguments ([`Args`]), turned into [`StudyOptions`] (`--steps`, `--levels`,
//!   `--h-max`, `--methods`, `--reference-method`, `--reference-refine`, `--error`, …);
//! - the runner: by default the scene's compiled program ([`runner::CompiledRunner`], built
//!   once like `mbdc run` builds it; step, method and duration are options of the program),
//!   with `--interp` the library's [`InterpRunner`] in this process. The numerical
//!   reference is always computed with the interpreter (both paths run the same runtime and
//!   agree to round-off);
//! - the progress lines, the markdown table, the "reading this", and `sweep.csv`,
//!   `sweep.json`, `sweep.svg` ([`report`]).
//!
//! SIGINT (Ctrl-C) or SIGTERM stops the sweep at the run in progress, which is left out: an
//! interpreted run stops within a step; a compiled program stops its run too when it has the
//! signal (a terminal's Ctrl-C reaches it), and ends its run first when only this process
//! had it. The runs done before are written as usual, with the scene's analytic or table
//! reference but no numerical one (the longest run of all; a signal during it stops it),
//! `"interrupted"` in `sweep.json`, and the exit code is 130 or 143.

pub mod report;
pub mod runner;

use std::path::PathBuf;
use std::process::ExitCode;

use mbdc_compiler::Override;
use mbdc_runtime::app::{Signal, StopSignals};
use mbdc_runtime::scene::{MethodSpec, Scene};
use mbdc_runtime::study::{
    InterpRunner, MethodEntry, Progress, ReferenceInfo, Runner, Study, StudyError, StudyOptions,
    StudyResult, StudyRun,
};

use runner::CompiledRunner;

/// The error measure that is plotted and fitted (`--error`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum MeasureArg {
    /// Largest position error over the frames (m).
    PosMax,
    /// Position error at the final time (m).
    PosFinal,
    /// Largest orientation error over the frames (rad).
    RotMax,
    /// Orientation error at the final time (rad).
    RotFinal,
}

impl From<MeasureArg> for mbdc_runtime::study::Measure {
    fn from(m: MeasureArg) -> Self {
        use mbdc_runtime::study::Measure;
        match m {
            MeasureArg::PosMax => Measure::PosMax,
            MeasureArg::PosFinal => Measure::PosFinal,
            MeasureArg::RotMax => Measure::RotMax,
            MeasureArg::RotFinal => Measure::RotFinal,
        }
    }
}

/// Arguments of `mbdc sweep`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The .mbd file.
    pub file: PathBuf,
    /// Override a parameter: `--set L=2m` (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_override)]
    pub set: Vec<Override>,
    /// Methods to sweep, comma-separated (default: every method that applies to the scene).
    #[arg(long, value_delimiter = ',', value_name = "NAMES",
          value_parser = clap::builder::PossibleValuesParser::new(MethodSpec::NAMES))]
    pub methods: Vec<String>,
    /// Steps in seconds, comma-separated (default: a geometric series from the scene's
    /// stability estimate).
    #[arg(long, value_delimiter = ',', value_name = "SECONDS")]
    pub steps: Vec<f64>,
    /// Largest step of the default series (default: 20 steps per shortest period).
    #[arg(long, value_name = "SECONDS")]
    pub h_max: Option<f64>,
    /// Number of steps in the default series (each half the previous).
    #[arg(long, default_value_t = 5, value_name = "N")]
    pub levels: usize,
    /// Duration in seconds (default: the scene's).
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// About how many frames of each run are compared with the reference.
    #[arg(long, default_value_t = 200, value_name = "N")]
    pub frames: usize,
    /// Repeat each run until its repetitions add up to this CPU time; the best is reported.
    #[arg(long, default_value_t = 0.2, value_name = "SECONDS")]
    pub min_time: f64,
    /// The error measure that is plotted and fitted (default: pos-max if the reference has
    /// positions, else rot-max).
    #[arg(long, value_enum)]
    pub error: Option<MeasureArg>,
    /// Method of the numerical reference (when the scene has no `reference` block;
    /// default: the most accurate swept method).
    #[arg(long, value_name = "NAME",
          value_parser = clap::builder::PossibleValuesParser::new(MethodSpec::NAMES))]
    pub reference_method: Option<String>,
    /// The numerical reference's step is the finest swept step divided by this.
    #[arg(long, default_value_t = 8, value_name = "N")]
    pub reference_refine: u32,
    /// Run the interpreter in this process instead of the scene's compiled program.
    #[arg(long)]
    pub interp: bool,
    /// Output folder (default: `out/<model name>-sweep`).
    #[arg(short = 'o', long = "out", value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// No progress lines (the table and results are still printed).
    #[arg(short, long)]
    pub quiet: bool,
}

fn parse_override(s: &str) -> Result<Override, String> {
    s.parse()
}

impl Args {
    /// The study these arguments ask for (a reference table is relative to the model file).
    pub fn options(&self) -> StudyOptions {
        StudyOptions {
            methods: self.methods.clone(),
            steps: self.steps.clone(),
            h_max: self.h_max,
            levels: self.levels,
            duration: self.duration,
            frames: self.frames,
            min_time: self.min_time,
            measure: self.error.map(Into::into),
            reference_method: self.reference_method.clone(),
            reference_refine: self.reference_refine,
            reference_dir: Some(
                self.file
                    .parent()
                    .map_or_else(|| PathBuf::from("."), PathBuf::from),
            ),
        }
    }
}

/// Runs `mbdc sweep`. SIGINT or SIGTERM stops it at the run in progress (left out) and
/// writes the runs done before, with no numerical reference; exit code 130 or 143.
pub fn run(args: Args) -> ExitCode {
    let scene = match super::run::load(&args.file, &args.set) {
        Ok(s) => s,
        Err(code) => return code,
    };
    match sweep(&args, &scene) {
        Ok(result) => match report::write_all(&result, &out_dir(&args, &scene)) {
            Ok(()) => match result.interrupted.as_deref().and_then(Signal::from_name) {
                Some(s) => {
                    eprintln!(
                        "interrupted by {}: wrote the {} run(s) done before it",
                        s.name(),
                        result.runs.len()
                    );
                    ExitCode::from(s.exit_code())
                }
                None => ExitCode::SUCCESS,
            },
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        },
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn out_dir(args: &Args, scene: &Scene) -> PathBuf {
    args.out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(format!("{}-sweep", scene.name)))
}

/// A study error in the words of the command line: options by their flags.
fn error_text(e: &StudyError) -> String {
    match e {
        StudyError::InvalidOption {
            option,
            requirement,
            got,
        } if !matches!(*option, "steps" | "duration") => {
            format!(
                "--{} must be {requirement}, got {got}",
                option.replace('_', "-")
            )
        }
        StudyError::InvalidOption {
            option: "duration",
            got,
            ..
        } => format!("the duration must be positive, got {got}"),
        e => e.to_string(),
    }
}

/// The progress lines on stderr.
struct Lines;

impl Progress for Lines {
    fn run_done(&mut self, m: &MethodEntry, run: &StudyRun) {
        eprintln!(
            "  {:<24} h = {:<9} {:<8} {:>10.3e} s × {}",
            m.name,
            crate::plot::figure::short_sci(run.step),
            run.outcome.status.word(),
            run.outcome.cpu_time,
            run.repetitions
        );
    }

    fn reference_started(&mut self, method: &str, step: f64) {
        eprintln!(
            "  reference: {method} at h = {} s and {} s (Richardson)",
            crate::plot::figure::short_sci(step),
            crate::plot::figure::short_sci(2.0 * step)
        );
    }
}

/// Run the sweep and measure everything (no output written).
///
/// # Errors
/// A scene the interpreter cannot run, invalid steps or duration, a program that cannot be
/// built, a runner that fails.
pub fn sweep(args: &Args, scene: &Scene) -> Result<StudyResult, String> {
    let study = Study::new(scene, &args.options()).map_err(|e| error_text(&e))?;
    let mut runner: Box<dyn Runner> = if args.interp {
        Box::new(InterpRunner::new(scene).map_err(|e| e.to_string())?)
    } else {
        Box::new(CompiledRunner::new(scene, args.quiet)?)
    };
    if !args.quiet {
        eprintln!(
            "sweeping {} method(s) × {} step(s) over {} s with the {}",
            study.methods().len(),
            study.steps().len(),
            study.duration(),
            runner.describe()
        );
    }
    // SIGINT and SIGTERM stop the study at the run in progress (a compiled program has the
    // terminal's Ctrl-C too, and stops its run; a SIGTERM to this process alone lets it end
    // its run first)
    let signals = match StopSignals::install() {
        Ok(s) => Some(s),
        Err(e) => {
            eprintln!(
                "warning: SIGINT and SIGTERM will end the sweep at once, writing nothing: {e}"
            );
            None
        }
    };
    let result = if args.quiet {
        study.run(runner.as_mut(), &mut ())
    } else {
        study.run(runner.as_mut(), &mut Lines)
    };
    drop(signals);
    let mut result = result.map_err(|e| error_text(&e))?;
    if let ReferenceInfo::Numerical { chosen, .. } = &mut result.reference {
        if args.reference_method.is_some() {
            *chosen = "chosen with --reference-method".into();
        }
    }
    Ok(result)
}
