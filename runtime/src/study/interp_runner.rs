//! The [`Runner`] of this library: the interpreter, in this process.
//!
//! It observes the frames in memory (no files). Its CPU time is the
//! [CPU time of the running thread](super::thread_cpu_time), measured around the whole run:
//! integrator set-up, the steps, and the evaluation of the sparse output frames
//! (constraint violation, energy), but not building the scene. A panic inside the runtime is
//! caught and reported as a stopped run.

use crate::contract::scene::{MethodSpec, Scene};
use crate::contract::system::System;
use crate::driver::run_loop::{
    self, Failure, Frame, Observer, OnFailure, RunConfig, RunReport, Watchdog,
};
use crate::interp::{Interp, InterpError};

use super::cpu_time::thread_cpu_time;
use super::error::RunnerError;
use super::runner::{iterations_mean, Outcome, Request, Runner, Status};
use super::track::Track;

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
    /// A program that installed [`crate::app::StopSignals`] (`mbdc sweep --interp`) stops
    /// the run on SIGINT or SIGTERM; the study then leaves it out and stops
    /// ([`super::Study::run`]).
    fn stop_requested(&mut self) -> Option<&'static str> {
        crate::app::StopSignals::pending().map(crate::app::Signal::name)
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
    pub fn new(scene: &Scene) -> Result<InterpRunner, InterpError> {
        let sys = Interp::new(scene)?;
        Ok(InterpRunner {
            watchdog: watchdog(&sys, scene),
            sys,
        })
    }

    /// The system.
    pub fn system(&self) -> &Interp {
        &self.sys
    }

    /// Run with a custom observer (the numerical reference samples its own frames). A panic
    /// inside the runtime is caught and reported as a failure at t = 0.
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
            checkpoint: None,
            resume: None,
        };
        guarded(|| run_loop::run(&self.sys, &cfg, obs)).unwrap_or_else(|msg| RunReport {
            failure: Some(Failure {
                time: 0.0,
                step: 0,
                location: "system".into(),
                quantity: "runtime".into(),
                value: f64::NAN,
                cause: format!("the runtime panicked: {msg}"),
                hint: None,
            }),
            ..RunReport::started(step)
        })
    }
}

/// Run `f`, turning a panic into an error with its message. The panic hook is silenced
/// meanwhile (the caller reports the message); it is process-wide, so a panic on another
/// thread during `f` is not printed either.
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
pub fn watchdog<S: System>(sys: &S, scene: &Scene) -> Watchdog {
    Watchdog::for_scale(
        run_loop::length_scale(sys),
        crate::app::energy_sources(scene),
    )
}

impl Runner for InterpRunner {
    fn describe(&self) -> String {
        "interpreter (in process; CPU time of the running thread)".into()
    }

    fn run(&mut self, req: &Request<'_>) -> Result<Outcome, RunnerError> {
        let mut obs = Collect {
            track: Track::new(self.sys.layout().bodies()),
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
