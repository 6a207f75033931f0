//! Running one (method, step) of a study: what is asked ([`Request`]), what comes back
//! ([`Outcome`], with its [`Status`]), and the [`Runner`] trait that does it.
//!
//! A runner runs the scene with a method, a step and a duration, and returns the status,
//! the CPU time, the body states at the output frames (a [`Track`]), the largest
//! constraint violation and energy drift over those frames, and the mean iteration count
//! where the method iterates. The scene is built once; method and step are run-time
//! options. This library has the interpreter's ([`InterpRunner`](super::InterpRunner));
//! `mbdc sweep` adds one that runs the scene's compiled program.

use crate::contract::scene::MethodSpec;
use crate::driver::run_loop::RunReport;

use super::error::RunnerError;
use super::track::Track;

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

    /// In words: `ok`, `diverged at t = … s: …` or `stopped at t = … s: …`.
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
                why: r
                    .interrupted
                    .as_ref()
                    .map_or_else(|| "the run ended early".into(), ToString::to_string),
            },
            Some(f) => classify(f.time, &f.quantity, &f.location, f.value, &f.cause),
        }
    }
}

/// Sort a failure (the fields of [`crate::driver::run_loop::Failure`]) into diverged (the solution blew
/// up) or stopped (the method gave up).
pub fn classify(t: f64, quantity: &str, location: &str, value: f64, cause: &str) -> Status {
    // energy that grew blew up; energy that disappeared is a method giving a wrong answer
    let blew_up = ["state", "constraint violation", "constraint force"]
        .iter()
        .any(|k| quantity.starts_with(k))
        || (quantity.starts_with("energy balance") && value > 0.0);
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
#[derive(Clone, Debug, PartialEq)]
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
    /// Largest relative energy drift over the output frames (see [`crate::driver::output`]).
    pub energy_drift: f64,
    /// Mean iterations per step where the method iterates (Newton, PCG, projection).
    pub iterations: Option<f64>,
}

/// Runs a scene with a given method and step.
pub trait Runner {
    /// What runs the scene (`interpreter …`, `compiled program …`).
    fn describe(&self) -> String;
    /// Run once.
    ///
    /// # Errors
    /// When the runner itself fails; the simulation failing is an [`Outcome`] with a
    /// non-ok [`Status`].
    fn run(&mut self, req: &Request<'_>) -> Result<Outcome, RunnerError>;
}

/// Mean iterations per step from a method's statistics (`newton_iterations_mean`,
/// `pcg_iterations_mean`, or `projection_iterations` over the steps).
pub fn iterations_mean(stats: &[(String, f64)], steps: u64) -> Option<f64> {
    let get = |n: &str| stats.iter().find(|(k, _)| k == n).map(|(_, v)| *v);
    get("newton_iterations_mean")
        .or_else(|| get("pcg_iterations_mean"))
        .or_else(|| get("projection_iterations").map(|v| v / steps.max(1) as f64))
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
}
