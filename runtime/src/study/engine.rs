//! The study itself: plan it ([`Study::new`]: duration, steps, methods), run every
//! (method, step) through a [`Runner`], build the reference, measure the errors and fit
//! the orders ([`Study::run`]).

use std::path::Path;

use crate::contract::scene::{MethodSpec, Scene};

use super::analytic::Analytic;
use super::error::{RunnerError, StudyError};
use super::error_measures::{self, Errors, Measure};
use super::fit::{self, Fit};
use super::interp_runner::InterpRunner;
use super::methods::{self, MethodEntry};
use super::numerical_reference;
use super::options::{StudyOptions, LEVELS_REQUIREMENT, MAX_LEVELS};
use super::progress::Progress;
use super::reference::RefSolution;
use super::result::ReferenceInfo;
use super::result::{StudyResult, StudyRun};
use super::runner::{Outcome, Request, Runner};
use super::sampled::Sampled;
use super::step_series::{self, FastestRate};
use super::table::Table;

/// A planned study of one scene: its duration, steps and methods are fixed; [`Study::run`]
/// runs it. Planning is cheap (it builds the interpreter and tries each method's start), so
/// a caller can show the plan, or refuse it, before preparing an expensive runner.
pub struct Study<'s> {
    scene: &'s Scene,
    options: StudyOptions,
    duration: f64,
    probe: InterpRunner,
    estimate: Option<FastestRate>,
    steps: step_series::StepSeries,
    methods: Vec<MethodEntry>,
    skipped: Vec<(String, String)>,
}

impl<'s> Study<'s> {
    /// Plan a study of `scene`.
    ///
    /// # Errors
    /// Options out of range, an unknown method name, a scene the interpreter cannot run, or
    /// no method that can start on the scene.
    pub fn new(scene: &'s Scene, options: &StudyOptions) -> Result<Study<'s>, StudyError> {
        let duration = options.duration.unwrap_or(scene.simulate.duration);
        if !(duration > 0.0 && duration.is_finite()) {
            return Err(StudyError::InvalidOption {
                option: "duration",
                requirement: "positive",
                got: format!("{duration} s"),
            });
        }
        if options.levels == 0 || options.levels > MAX_LEVELS {
            return Err(StudyError::InvalidOption {
                option: "levels",
                requirement: LEVELS_REQUIREMENT,
                got: options.levels.to_string(),
            });
        }
        if options.reference_refine < 2 {
            return Err(StudyError::InvalidOption {
                option: "reference_refine",
                requirement: "at least 2",
                got: options.reference_refine.to_string(),
            });
        }
        if let Some(name) = &options.reference_method {
            if MethodSpec::default_for(name).is_none() {
                return Err(StudyError::UnknownMethod(name.clone()));
            }
        }
        let probe = InterpRunner::new(scene)?;
        let estimate = FastestRate::of(scene);
        let steps = step_series::choose(
            &options.steps,
            options.h_max,
            options.levels,
            duration,
            scene,
            estimate.as_ref(),
        )?;
        let methods::Selection { methods, skipped } =
            methods::select(&options.methods, scene, probe.system(), scene.simulate.step)?;
        if methods.is_empty() {
            return Err(StudyError::NoMethod(skipped));
        }
        Ok(Study {
            scene,
            options: options.clone(),
            duration,
            probe,
            estimate,
            steps,
            methods,
            skipped,
        })
    }

    /// The duration, s.
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// The steps, coarsest first.
    pub fn steps(&self) -> &[f64] {
        &self.steps.steps
    }

    /// How the steps were chosen, in words.
    pub fn steps_note(&self) -> &str {
        &self.steps.note
    }

    /// The methods that will run.
    pub fn methods(&self) -> &[MethodEntry] {
        &self.methods
    }

    /// The methods left out, with the reason.
    pub fn skipped(&self) -> &[(String, String)] {
        &self.skipped
    }

    /// The scene's fastest rate (None: no rate, or beams and meshes).
    pub fn estimate(&self) -> Option<&FastestRate> {
        self.estimate.as_ref()
    }

    /// Run every (method, step) with `runner`, build the reference (always with the
    /// interpreter when it is numerical), measure the errors and fit the orders.
    ///
    /// # Errors
    /// The runner failing (not a simulation: those are runs with a non-ok status), or the
    /// scene's reference table that cannot be read.
    pub fn run(
        &self,
        runner: &mut dyn Runner,
        progress: &mut dyn Progress,
    ) -> Result<StudyResult, StudyError> {
        let steps = self.steps();
        let h_max = steps[0];
        let n_max = (self.duration / h_max).round().max(1.0);
        let per_frame = (n_max / self.options.frames.max(1) as f64).round().max(1.0);
        let frame_dt = per_frame * h_max;

        let mut runs = Vec::new();
        let mut interrupted = None;
        'runs: for (mi, m) in self.methods.iter().enumerate() {
            for &h in steps {
                let every = (frame_dt / h).round().max(1.0) as u32;
                let req = Request {
                    method: &m.spec,
                    step: h,
                    duration: self.duration,
                    every,
                    keep: true,
                };
                let (outcome, repetitions) = measure_run(runner, &req, self.options.min_time)?;
                // SIGINT or SIGTERM in a program that handles them (`mbdc sweep`): the run
                // may have been cut, so it is left out, and the study ends with what it has
                if let Some(s) = crate::app::StopSignals::pending() {
                    interrupted = Some(s.name().to_string());
                    break 'runs;
                }
                let run = StudyRun {
                    method: mi,
                    step: h,
                    every,
                    outcome,
                    repetitions,
                    errors: None,
                };
                progress.run_done(m, &run);
                runs.push(run);
            }
        }

        let (info, solution) = self.reference(&runs, progress, interrupted.as_deref())?;
        // a signal during the numerical reference stopped it (it is unavailable then)
        if interrupted.is_none() {
            interrupted = crate::app::StopSignals::pending().map(|s| s.name().to_string());
        }
        if let Some(sol) = &solution {
            for r in &mut runs {
                if r.outcome.status.is_ok() {
                    r.errors = error_measures::measure(&r.outcome.track, sol.as_ref()).ok();
                }
            }
        }

        let has = |f: fn(&Errors) -> Option<f64>| {
            runs.iter().any(|r| r.errors.as_ref().and_then(f).is_some())
        };
        let has_pos = has(|e| e.pos_max);
        let has_rot = has(|e| e.rot_max);
        let measure = self.options.measure.unwrap_or(if has_pos || !has_rot {
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
        let length_scale = crate::driver::run_loop::length_scale(self.probe.system());
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
                h_limit: self
                    .estimate
                    .as_ref()
                    .filter(|_| crate::analysis::step_limits::is_explicit(spec))
                    .map(FastestRate::h_limit),
            }
        };
        let fits: Vec<(Fit, Option<Fit>)> = (0..self.methods.len())
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
                let spec = &self.methods[mi].spec;
                (
                    fit::fit(&pts(measure), &rules(measure, spec)),
                    secondary.map(|s| fit::fit(&pts(s), &rules(s, spec))),
                )
            })
            .collect();

        Ok(StudyResult {
            model: self.scene.name.clone(),
            duration: self.duration,
            runner: runner.describe(),
            estimate: self.estimate.clone(),
            steps_note: self.steps.note.clone(),
            methods: self.methods.clone(),
            skipped: self.skipped.clone(),
            runs,
            reference: info,
            measure,
            secondary,
            length_scale,
            energy_sources: crate::app::energy_sources(self.scene),
            fits,
            interrupted,
        })
    }

    /// The reference: the scene's functions or table, or a numerical run (not after an
    /// interruption by `interrupted`: it is the longest run of all).
    fn reference(
        &self,
        runs: &[StudyRun],
        progress: &mut dyn Progress,
        interrupted: Option<&str>,
    ) -> Result<(ReferenceInfo, Option<Box<dyn RefSolution>>), StudyError> {
        if let Some(a) = Analytic::new(self.scene) {
            return Ok((ReferenceInfo::Analytic, Some(Box::new(a))));
        }
        if let Some(table) = self.scene.reference.as_ref().and_then(|r| r.table.as_ref()) {
            let base = self
                .options
                .reference_dir
                .as_deref()
                .unwrap_or(Path::new("."));
            let path = base.join(table);
            let t = Table::read(&path, self.scene)?;
            return Ok((ReferenceInfo::Table(path), Some(Box::new(t))));
        }
        if let Some(by) = interrupted {
            return Ok((
                ReferenceInfo::Unavailable(format!(
                    "the sweep was interrupted by {by} before its numerical reference"
                )),
                None,
            ));
        }
        let h_min = self.steps().iter().copied().fold(f64::INFINITY, f64::min);
        let h_ref = h_min / f64::from(self.options.reference_refine);
        let (method, chosen) = numerical_reference::choose_method(
            self.options.reference_method.as_deref(),
            self.options.measure,
            &self.methods,
            runs,
            h_min,
        )?;
        let times = frame_times(runs);
        let Some(&t_end) = times.last() else {
            return Ok((
                ReferenceInfo::Unavailable("no run produced a frame".into()),
                None,
            ));
        };
        progress.reference_started(method.name(), h_ref);
        let bodies = runs
            .first()
            .map_or(self.scene.bodies.len(), |r| r.outcome.track.bodies);
        match numerical_reference::run(&self.probe, &method, h_ref, bodies, &times, t_end) {
            Ok((fine, estimate)) => Ok((
                ReferenceInfo::Numerical {
                    method: method.name().to_string(),
                    step: h_ref,
                    estimate,
                    chosen,
                },
                Some(Box::new(Sampled::new(fine))),
            )),
            Err(why) => Ok((ReferenceInfo::Unavailable(why), None)),
        }
    }
}

/// Plan and run a study of `scene` with `runner`, reporting no progress.
///
/// # Errors
/// See [`Study::new`] and [`Study::run`].
pub fn run_study(
    scene: &Scene,
    options: &StudyOptions,
    runner: &mut dyn Runner,
) -> Result<StudyResult, StudyError> {
    Study::new(scene, options)?.run(runner, &mut ())
}

/// Run one (method, step), repeating for the timing: until the repetitions add up to
/// `min_time` of CPU time (at most 1000 of them, and 10 × `min_time` of wall time); the
/// best CPU time is kept.
fn measure_run(
    runner: &mut dyn Runner,
    req: &Request<'_>,
    min_time: f64,
) -> Result<(Outcome, u32), RunnerError> {
    const MAX_REPETITIONS: u32 = 1000;
    // A run that failed has no accuracy to put a price on: its CPU time only places it on
    // a diagram, and a few repetitions do that (a step that diverges at once would
    // otherwise be repeated hundreds of times to fill `min_time`).
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
fn frame_times(runs: &[StudyRun]) -> Vec<f64> {
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
