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
//! - **Steps**: `--steps` as given, or a geometric series of `--levels` steps halving from
//!   h_max = T_min/20, T_min = 2π/ω_max from the scene's [stability estimate](stability),
//!   shrunk so that the duration is a whole number of steps (then every step of the series
//!   ends exactly on the end time and all runs share their frame times). A scene without
//!   an estimate gets a series with its own step in the middle.
//! - **Methods**: `--methods`, or every method that can start on the scene (the others are
//!   listed with the reason).
//! - **Reference**: the scene's `reference { … }` (analytic functions or a table) if it has
//!   one; otherwise a run of the most accurate method — the one whose two finest runs
//!   differ least — at a step `--reference-refine` (8) times finer than the finest swept
//!   step, sampled at every frame time of the sweep. Its own error is estimated by
//!   Richardson extrapolation from a second run at twice its step:
//!   e(h_ref) ≈ |y(2h_ref) − y(h_ref)| / (2^p − 1), p the method's theoretical order.
//! - **Errors** (see [`reference`]): RMS over bodies of the position error (m) and of the
//!   rotation angle between computed and reference orientation (rad), at the final time
//!   and as the maximum over the frames (about `--frames` frames per run, at the coarsest
//!   step's frame times).
//! - **Order**: least-squares slope of log(error) on log(h) over the converging range (see
//!   [`fit`]); flagged when it differs from the method's theoretical order by more than 0.3.
//! - Runs that diverge or stop stay in the table (status and time reached) and are drawn
//!   as crosses along the top of the diagrams. They are repeated at most three times (their
//!   CPU time only places the cross).
//!
//! The runs go through a [`runner::Runner`]: by default the scene's compiled program
//! ([`runner::CompiledRunner`], built once like `mbdc run` builds it; step, method and
//! duration are options of the program), with `--interp` the interpreter in this process
//! ([`runner::InterpRunner`]). The numerical reference is always computed with the
//! interpreter (it samples the run at every frame time of the sweep in memory; both paths
//! run the same runtime and agree to round-off).

pub mod fit;
pub mod reference;
mod report;
pub mod runner;
pub mod stability;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use mbdc_compiler::Override;
use mbdc_runtime::integrators::{self, StartError, State};
use mbdc_runtime::scene::{Factorization, LintForm, MethodSpec, Scene};

use reference::{Errors, RefSolution};
use runner::{CompiledRunner, InterpRunner, Outcome, Request, Runner, Status, Track};

/// The error measure that is plotted and fitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Measure {
    /// Largest position error over the frames (m).
    PosMax,
    /// Position error at the final time (m).
    PosFinal,
    /// Largest orientation error over the frames (rad).
    RotMax,
    /// Orientation error at the final time (rad).
    RotFinal,
}

impl Measure {
    /// The value of this measure.
    pub fn of(self, e: &Errors) -> Option<f64> {
        match self {
            Measure::PosMax => e.pos_max,
            Measure::PosFinal => e.pos_final,
            Measure::RotMax => e.rot_max,
            Measure::RotFinal => e.rot_final,
        }
    }

    /// Axis label with the unit.
    pub fn label(self) -> &'static str {
        match self {
            Measure::PosMax => "max-over-time position error, RMS over bodies (m)",
            Measure::PosFinal => "final-time position error, RMS over bodies (m)",
            Measure::RotMax => "max-over-time orientation error, RMS over bodies (rad)",
            Measure::RotFinal => "final-time orientation error, RMS over bodies (rad)",
        }
    }

    /// Short name.
    pub fn short(self) -> &'static str {
        match self {
            Measure::PosMax => "pos_err_max_m",
            Measure::PosFinal => "pos_err_final_m",
            Measure::RotMax => "rot_err_max_rad",
            Measure::RotFinal => "rot_err_final_rad",
        }
    }

    /// The unit.
    pub fn unit(self) -> &'static str {
        match self {
            Measure::PosMax | Measure::PosFinal => "m",
            Measure::RotMax | Measure::RotFinal => "rad",
        }
    }

    /// Whether this is a position measure.
    pub fn is_position(self) -> bool {
        matches!(self, Measure::PosMax | Measure::PosFinal)
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
    pub error: Option<Measure>,
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

/// A method being swept.
#[derive(Clone, Debug)]
pub struct MethodEntry {
    /// Its name.
    pub name: &'static str,
    /// The method with the options used.
    pub spec: MethodSpec,
    /// The options in words (`ε = 1e-6 (the scene's)`).
    pub options: String,
    /// The theoretical order of convergence.
    pub theory: Option<f64>,
}

/// The theoretical order of a method (notes A §1): all the implemented methods are second
/// order; penalty's constraint error is O(h²) with its default ε = h²·max diag K.
pub fn theoretical_order(name: &str) -> Option<f64> {
    match name {
        "staggered"
        | "baumgarte"
        | "penalty"
        | "coordinate_partitioning"
        | "implicit_trapezoid"
        | "natural_partitioning" => Some(2.0),
        _ => None,
    }
}

/// The options of a method in words.
pub fn describe_options(spec: &MethodSpec) -> String {
    let eps = |e: &Option<f64>, rule: &str| match e {
        Some(v) => format!("ε = {v:e}"),
        None => format!("ε by the default rule ({rule})"),
    };
    match spec {
        MethodSpec::Staggered(o) => {
            let mut s = eps(&o.epsilon, "10⁻⁹·h²·K_rr");
            if o.single_stage {
                s.push_str(", single stage");
            }
            if o.lint == LintForm::Midpoint {
                s.push_str(", midpoint LINT");
            }
            if o.paper_literal {
                s.push_str(", paper-literal formulas");
            }
            match o.factorization {
                Factorization::Auto => {}
                Factorization::Dense => s.push_str(", dense factorization"),
                Factorization::Sparse => s.push_str(", sparse factorization"),
            }
            s
        }
        MethodSpec::Baumgarte { alpha, beta } => format!("α = {alpha} 1/s, β = {beta} 1/s"),
        MethodSpec::Penalty { epsilon } => eps(epsilon, "h²·max diag K"),
        MethodSpec::CoordinatePartitioning => String::new(),
        MethodSpec::ImplicitTrapezoid {
            tolerance,
            max_iterations,
        } => format!("Newton tolerance {tolerance:e}, ≤ {max_iterations} iterations"),
        MethodSpec::NaturalPartitioning {
            epsilon,
            tolerance,
            max_iterations,
        } => {
            let mut s = format!("{}, PCG tolerance {tolerance:e}", eps(epsilon, "default"));
            if let Some(n) = max_iterations {
                s.push_str(&format!(", ≤ {n} PCG iterations"));
            }
            s
        }
        MethodSpec::StateTime { steps_per_element } => {
            format!("{steps_per_element} steps per time element")
        }
    }
}

/// One measured run of the sweep.
#[derive(Clone, Debug)]
pub struct SweepRun {
    /// Index into the methods.
    pub method: usize,
    /// Step, s.
    pub step: f64,
    /// Output every N steps.
    pub every: u32,
    /// The run (its `cpu_time` is the best of the repetitions).
    pub outcome: Outcome,
    /// Repetitions measured.
    pub repetitions: u32,
    /// Errors against the reference (finished runs only).
    pub errors: Option<Errors>,
}

/// The reference used.
#[derive(Clone, Debug)]
pub enum ReferenceInfo {
    /// The scene's analytic functions.
    Analytic,
    /// The scene's table.
    Table(PathBuf),
    /// A numerical run.
    Numerical {
        /// Its method.
        method: String,
        /// Its step, s.
        step: f64,
        /// Richardson estimate of its error.
        estimate: Errors,
        /// How the method was chosen.
        chosen: String,
    },
    /// None could be made (the errors are left empty).
    Unavailable(String),
}

/// Everything a sweep measured.
pub struct SweepResult {
    /// Model name.
    pub model: String,
    /// Duration, s.
    pub duration: f64,
    /// What ran the scene.
    pub runner: String,
    /// The stability estimate.
    pub estimate: Option<stability::Estimate>,
    /// How the steps were chosen.
    pub steps_note: String,
    /// The methods.
    pub methods: Vec<MethodEntry>,
    /// Methods left out and why.
    pub skipped: Vec<(String, String)>,
    /// The runs, by method then step (coarse to fine).
    pub runs: Vec<SweepRun>,
    /// The reference.
    pub reference: ReferenceInfo,
    /// The plotted and fitted measure.
    pub measure: Measure,
    /// The secondary measure fitted too (orientation when positions are primary).
    pub secondary: Option<Measure>,
    /// The scene's length scale, m.
    pub length_scale: f64,
    /// Whether the scene has energy sources (then the energy drift is not reported).
    pub energy_sources: bool,
    /// Per method: fits of the primary and secondary measure.
    pub fits: Vec<(fit::Fit, Option<fit::Fit>)>,
}

/// Runs `mbdc sweep`.
pub fn run(args: Args) -> ExitCode {
    let scene = match super::run::load(&args.file, &args.set) {
        Ok(s) => s,
        Err(code) => return code,
    };
    match sweep(&args, &scene) {
        Ok(result) => match report::write_all(&result, &out_dir(&args, &scene)) {
            Ok(()) => ExitCode::SUCCESS,
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

/// Choose the methods: the requested ones, or every method that can start on the scene.
fn methods(
    args: &Args,
    scene: &Scene,
    runner: &InterpRunner,
    h: f64,
) -> (Vec<MethodEntry>, Vec<(String, String)>) {
    let names: Vec<&'static str> = if args.methods.is_empty() {
        MethodSpec::NAMES.to_vec()
    } else {
        MethodSpec::NAMES
            .iter()
            .copied()
            .filter(|n| args.methods.iter().any(|m| m == n))
            .collect()
    };
    let sys = runner.system();
    let start = State::initial(sys);
    let mut out = Vec::new();
    let mut skipped = Vec::new();
    for name in names {
        let (spec, from_scene) = if scene.simulate.method.name() == name {
            (scene.simulate.method.clone(), true)
        } else {
            match MethodSpec::default_for(name) {
                Some(s) => (s, false),
                None => continue,
            }
        };
        if args.methods.is_empty() {
            match runner::guarded(|| integrators::make(&spec, sys, h, &start).map(|_| ())) {
                Ok(Ok(())) => {}
                Ok(Err(StartError::Unsupported(_))) => {
                    skipped.push((name.to_string(), "not available yet".to_string()));
                    continue;
                }
                Ok(Err(e)) => {
                    skipped.push((name.to_string(), format!("does not apply: {e}")));
                    continue;
                }
                Err(panic) => {
                    skipped.push((
                        name.to_string(),
                        format!("cannot start: the runtime panicked ({panic})"),
                    ));
                    continue;
                }
            }
        }
        let mut options = describe_options(&spec);
        if from_scene && !options.is_empty() {
            options.push_str(" (the scene's)");
        }
        out.push(MethodEntry {
            name,
            spec,
            options,
            theory: theoretical_order(name),
        });
    }
    (out, skipped)
}

/// Run one (method, step), repeating for the timing.
fn measure_run(
    runner: &mut dyn Runner,
    req: &Request<'_>,
    min_time: f64,
) -> Result<(Outcome, u32), String> {
    const MAX_REPETITIONS: u32 = 1000;
    // A run that failed has no accuracy to put a price on: its CPU time only places its
    // cross on the diagram, and a few repetitions do that (a step that diverges at once
    // would otherwise be repeated hundreds of times to fill `min_time`).
    const MAX_FAILED_REPETITIONS: u32 = 3;
    let wall = std::time::Instant::now();
    let mut first = runner.run(req)?;
    let max_reps = if first.status.is_ok() {
        MAX_REPETITIONS
    } else {
        MAX_FAILED_REPETITIONS
    };
    let mut best = first.cpu_time;
    let mut total = first.cpu_time;
    let mut reps = 1u32;
    let again = Request {
        keep: false,
        ..req.clone()
    };
    // (and at most 10 × min_time of wall time: a compiled run also pays its process start)
    while total < min_time && reps < max_reps && wall.elapsed().as_secs_f64() < 10.0 * min_time {
        let o = runner.run(&again)?;
        best = best.min(o.cpu_time);
        total += o.cpu_time.max(1e-9);
        reps += 1;
    }
    first.cpu_time = best;
    Ok((first, reps))
}

/// The sorted union of the frame times of all runs (times closer than 1e-9 merged).
fn frame_times(runs: &[SweepRun]) -> Vec<f64> {
    let mut all: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.outcome.track.t.iter().copied())
        .collect();
    all.sort_by(f64::total_cmp);
    let mut out: Vec<f64> = Vec::with_capacity(all.len());
    for t in all {
        if out
            .last()
            .is_none_or(|l| (t - l).abs() > 1e-9 * t.abs().max(1.0))
        {
            out.push(t);
        }
    }
    out
}

/// Compare two tracks of the same frame times: `a` against `b` as the reference.
fn difference(a: &Track, b: &Track) -> Option<Errors> {
    reference::measure(a, &reference::Sampled::new(b.clone())).ok()
}

/// Run the sweep and measure everything (no output written).
///
/// # Errors
/// A scene the interpreter cannot run, invalid steps or duration.
pub fn sweep(args: &Args, scene: &Scene) -> Result<SweepResult, String> {
    let duration = args.duration.unwrap_or(scene.simulate.duration);
    if !(duration > 0.0 && duration.is_finite()) {
        return Err(format!("the duration must be positive, got {duration} s"));
    }
    if args.levels == 0 {
        return Err("--levels must be at least 1".into());
    }
    if args.reference_refine < 2 {
        return Err("--reference-refine must be at least 2".into());
    }
    let probe = InterpRunner::new(scene)?;
    let length_scale = mbdc_runtime::run_loop::length_scale(probe.system());
    let estimate = stability::estimate(scene);

    // steps
    let (steps, steps_note) = if !args.steps.is_empty() {
        let mut s = args.steps.clone();
        if let Some(bad) = s.iter().find(|h| !(**h > 0.0 && h.is_finite())) {
            return Err(format!("steps must be positive, got {bad}"));
        }
        s.sort_by(|a, b| b.total_cmp(a));
        s.dedup();
        (s, "as given".to_string())
    } else {
        let (h, note) = match (args.h_max, &estimate) {
            (Some(h), _) => {
                if !(h > 0.0 && h.is_finite()) {
                    return Err(format!("--h-max must be positive, got {h}"));
                }
                (h, format!("halving from --h-max {h} s"))
            }
            (None, Some(e)) => (
                e.h_max(),
                format!(
                    "halving from h_max = T_min/20, T_min = 2π/ω_max, ω_max = {:.4} rad/s ({})",
                    e.omega_max, e.source
                ),
            ),
            (None, None) => (
                scene.simulate.step * 2f64.powi((args.levels as i32 - 1) / 2),
                "the scene's step in the middle (no stability estimate: nothing in the scene sets a rate)".to_string(),
            ),
        };
        let h = stability::fit_to_duration(h, duration);
        (stability::series(h, args.levels, 2.0), note)
    };
    let h_max = steps[0];
    let n_max = (duration / h_max).round().max(1.0);
    let per_frame = (n_max / args.frames.max(1) as f64).round().max(1.0);
    let frame_dt = per_frame * h_max;

    let (methods, skipped) = methods(args, scene, &probe, scene.simulate.step);
    if methods.is_empty() {
        let why: Vec<String> = skipped.iter().map(|(n, w)| format!("{n}: {w}")).collect();
        return Err(format!(
            "no method applies to this scene ({})",
            why.join("; ")
        ));
    }
    let mut runner: Box<dyn Runner> = if args.interp {
        Box::new(InterpRunner::new(scene)?)
    } else {
        Box::new(CompiledRunner::new(scene, args.quiet)?)
    };
    if !args.quiet {
        eprintln!(
            "sweeping {} method(s) × {} step(s) over {duration} s with the {}",
            methods.len(),
            steps.len(),
            runner.describe()
        );
    }

    // the runs
    let mut runs = Vec::new();
    for (mi, m) in methods.iter().enumerate() {
        for &h in &steps {
            let every = (frame_dt / h).round().max(1.0) as u32;
            let req = Request {
                method: &m.spec,
                step: h,
                duration,
                every,
                keep: true,
            };
            let (outcome, repetitions) = measure_run(runner.as_mut(), &req, args.min_time)?;
            if !args.quiet {
                eprintln!(
                    "  {:<24} h = {:<9} {:<8} {:>10.3e} s × {}",
                    m.name,
                    crate::plot::figure::short_sci(h),
                    outcome.status.word(),
                    outcome.cpu_time,
                    repetitions
                );
            }
            runs.push(SweepRun {
                method: mi,
                step: h,
                every,
                outcome,
                repetitions,
                errors: None,
            });
        }
    }

    // the reference
    let reference = make_reference(args, scene, &probe, &methods, &runs, &steps)?;
    let (info, solution) = reference;
    if let Some(sol) = &solution {
        for r in &mut runs {
            if r.outcome.status.is_ok() {
                r.errors = reference::measure(&r.outcome.track, sol.as_ref()).ok();
            }
        }
    }

    // measures and fits
    let has = |f: fn(&Errors) -> Option<f64>| {
        runs.iter().any(|r| r.errors.as_ref().and_then(f).is_some())
    };
    let has_pos = has(|e| e.pos_max);
    let has_rot = has(|e| e.rot_max);
    let measure = args.error.unwrap_or(if has_pos || !has_rot {
        Measure::PosMax
    } else {
        Measure::RotMax
    });
    let secondary = if measure.is_position() && has_rot {
        Some(Measure::RotMax)
    } else if !measure.is_position() && has_pos {
        Some(Measure::PosMax)
    } else {
        None
    };
    let rules = |m: Measure, spec: &MethodSpec| {
        let scale = if m.is_position() { length_scale } else { 1.0 };
        let floor = match &info {
            ReferenceInfo::Numerical { estimate, .. } => m
                .of(estimate)
                .filter(|e| *e > 0.0)
                .map_or(1e-10 * scale, |e| (8.0 * e).max(1e-10 * scale)),
            _ => 1e-10 * scale,
        };
        fit::Rules {
            floor,
            ceiling: 0.1 * scale,
            h_limit: estimate
                .as_ref()
                .filter(|_| mbdc_runtime::step_limits::is_explicit(spec))
                .map(|e| e.h_limit()),
        }
    };
    let fits = (0..methods.len())
        .map(|mi| {
            let pts = |m: Measure| -> Vec<fit::Point> {
                runs.iter()
                    .filter(|r| r.method == mi)
                    .map(|r| fit::Point {
                        h: r.step,
                        error: r.errors.as_ref().and_then(|e| m.of(e)),
                        finished: r.outcome.status.is_ok(),
                    })
                    .collect()
            };
            let spec = &methods[mi].spec;
            (
                fit::fit(&pts(measure), &rules(measure, spec)),
                secondary.map(|s| fit::fit(&pts(s), &rules(s, spec))),
            )
        })
        .collect();

    Ok(SweepResult {
        model: scene.name.clone(),
        duration,
        runner: runner.describe(),
        estimate,
        steps_note,
        methods,
        skipped,
        runs,
        reference: info,
        measure,
        secondary,
        length_scale,
        energy_sources: mbdc_runtime::app::energy_sources(scene),
        fits,
    })
}

type Reference = (ReferenceInfo, Option<Box<dyn RefSolution>>);

/// Build the reference: the scene's, or a numerical run (see the module doc).
fn make_reference(
    args: &Args,
    scene: &Scene,
    runner: &InterpRunner,
    methods: &[MethodEntry],
    runs: &[SweepRun],
    steps: &[f64],
) -> Result<Reference, String> {
    if let Some(a) = reference::Analytic::new(scene) {
        return Ok((ReferenceInfo::Analytic, Some(Box::new(a))));
    }
    if let Some(table) = scene.reference.as_ref().and_then(|r| r.table.as_ref()) {
        let base = args.file.parent().unwrap_or(Path::new("."));
        let path = base.join(table);
        let t = reference::Table::read(&path, scene)?;
        return Ok((ReferenceInfo::Table(path), Some(Box::new(t))));
    }
    // the method: asked for, or the one whose two finest runs differ least
    let h_min = steps.iter().copied().fold(f64::INFINITY, f64::min);
    let (method, chosen): (MethodSpec, String) = match &args.reference_method {
        Some(name) => {
            let spec = methods
                .iter()
                .find(|m| m.name == name)
                .map(|m| m.spec.clone())
                .or_else(|| MethodSpec::default_for(name))
                .ok_or_else(|| format!("unknown method `{name}`"))?;
            (spec, "chosen with --reference-method".into())
        }
        None => {
            let mut best: Option<(f64, usize)> = None;
            for (mi, _) in methods.iter().enumerate() {
                let mut mine: Vec<&SweepRun> = runs
                    .iter()
                    .filter(|r| r.method == mi && r.outcome.status.is_ok())
                    .collect();
                mine.sort_by(|a, b| a.step.total_cmp(&b.step));
                if mine.len() < 2 || mine[0].step > h_min * (1.0 + 1e-9) {
                    continue;
                }
                let d = difference(&mine[0].outcome.track, &mine[1].outcome.track)
                    .and_then(|e| e.pos_max.or(e.rot_max));
                if let Some(d) = d.filter(|d| d.is_finite()) {
                    if best.is_none_or(|b| d < b.0) {
                        best = Some((d, mi));
                    }
                }
            }
            match best {
                Some((d, mi)) => (
                    methods[mi].spec.clone(),
                    format!("the swept method whose two finest runs differ least ({d:.2e})"),
                ),
                None => {
                    let pick = ["implicit_trapezoid", "staggered", "coordinate_partitioning"]
                        .iter()
                        .find_map(|n| methods.iter().find(|m| m.name == *n))
                        .unwrap_or(&methods[0]);
                    (
                        pick.spec.clone(),
                        "no method finished its two finest runs; the first of implicit_trapezoid, staggered, coordinate_partitioning swept".into(),
                    )
                }
            }
        }
    };
    let h_ref = h_min / f64::from(args.reference_refine);
    let times = frame_times(runs);
    let Some(&t_end) = times.last() else {
        return Ok((
            ReferenceInfo::Unavailable("no run produced a frame".into()),
            None,
        ));
    };
    if !args.quiet {
        eprintln!(
            "  reference: {} at h = {} s and {} s (Richardson)",
            method.name(),
            crate::plot::figure::short_sci(h_ref),
            crate::plot::figure::short_sci(2.0 * h_ref)
        );
    }
    let bodies = runs
        .first()
        .map_or(scene.bodies.len(), |r| r.outcome.track.bodies);
    let sample = |h: f64| -> Result<Track, String> {
        let mut s = reference::Sampler::new(bodies, &times);
        let report = runner.run_observed(&method, h, t_end, 1, &mut s);
        let track = s.finish();
        if !report.finished || track.t.len() != times.len() {
            let st = Status::from_report(&report);
            return Err(format!(
                "the reference run ({} at h = {h:e} s) did not finish: {}",
                method.name(),
                st.text()
            ));
        }
        Ok(track)
    };
    let fine = match sample(h_ref) {
        Ok(t) => t,
        Err(e) => return Ok((ReferenceInfo::Unavailable(e), None)),
    };
    let estimate = match sample(2.0 * h_ref) {
        Ok(coarse) => {
            let p = theoretical_order(method.name()).unwrap_or(2.0);
            difference(&coarse, &fine)
                .unwrap_or_default()
                .scaled(1.0 / (2f64.powf(p) - 1.0))
        }
        Err(e) => return Ok((ReferenceInfo::Unavailable(e), None)),
    };
    Ok((
        ReferenceInfo::Numerical {
            method: method.name().to_string(),
            step: h_ref,
            estimate,
            chosen,
        },
        Some(Box::new(reference::Sampled::new(fine))),
    ))
}
