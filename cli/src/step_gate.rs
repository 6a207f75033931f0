//! The stability gate of `mbdc run`: before a run, compare the step with the scene's stability
//! estimate ([`mbdc_runtime::step_limits`]) and refuse an explicit method whose step is above the
//! limit `h·ω_max ≤ 2`, or warn when there are fewer than 20 steps per period of the fastest
//! motion (notes A §1.10). `mbdc sweep` starts its default steps from the same estimate
//! ([`mbdc_runtime::study::step_series`]).
//!
//! Then [`start`]: the refusals of the run itself before its first step (the run settings, the
//! method's start: a method that does not simulate the scene, a step above a beam's limit, a
//! dense method on too large a system), found by the runtime's own functions on the interpreted
//! system. `mbdc check` applies both ([`gate`]), so that it refuses what `mbdc run` refuses, and
//! `mbdc run` applies both before it builds a compiled program. Last, a run that would write
//! more than a gigabyte warns with the output interval that would not
//! ([`mbdc_runtime::output::size_estimate`]).

use std::process::ExitCode;

use mbdc_runtime::app::Settings;
use mbdc_runtime::integrators::{self, State};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::output::size_estimate;
use mbdc_runtime::run_loop;
use mbdc_runtime::scene::{MethodSpec, Scene};
use mbdc_runtime::step_limits;
use mbdc_runtime::system::System;

/// What the gate decided.
#[derive(Debug, PartialEq)]
pub enum Verdict {
    /// Fine.
    Ok,
    /// Runs, but coarse: the message says why.
    Warn(String),
    /// Refused: the message says why and what to do.
    Refuse(String),
}

/// Judge step `h` with `method` on `scene`, whose system is `sys`: the scene's sources and the
/// fastest mode of its constrained system at t = 0 ([`step_limits::estimate_system`]). The
/// second value is the note of a scene too large for the constrained check.
pub fn judge<S: System>(
    scene: &Scene,
    sys: &S,
    method: &MethodSpec,
    h: f64,
) -> (Verdict, Option<String>) {
    let (est, note) = step_limits::estimate_system(scene, sys);
    let est = est.with_beam_substeps(step_limits::beam_substeps(method));
    (judge_estimate(&est, method, h), note)
}

/// [`judge`] on an estimate.
fn judge_estimate(est: &step_limits::Estimate, method: &MethodSpec, h: f64) -> Verdict {
    let Some(fast) = est.fastest() else {
        return Verdict::Ok;
    };
    let (stable, accurate) = (est.stable_step(), est.accurate_step());
    if fast.discretization && h > stable {
        // beams are explicit whatever the method
        return Verdict::Refuse(format!(
            "the step {h:.3e} s is above the stability limit of the {} at ω = {:.4e} rad/s (h·ω = {:.2} > 2): beams are advanced explicitly\n  help: use a step of at most {stable:.3e} s, advance the beams in substeps (`beam_substeps {}` or more in `method staggered {{ }}`: the rigid bodies keep the step), or raise the beam's `rotary_inertia_scale` (it lowers its shear/rotary-inertia mode; docs/methods.md, \"Beams\")",
            fast.what,
            fast.omega,
            h * fast.omega,
            (step_limits::beam_substeps(method) as f64 * h * fast.omega / 2.0).ceil()
        ));
    }
    if step_limits::is_explicit(method) && h > stable {
        return Verdict::Refuse(format!(
            "the step {h:.3e} s is above the stability limit of the explicit method `{}`: the fastest motion is the {} at ω = {:.4e} rad/s, and h·ω = {:.2} > 2\n  help: use a step of at most {stable:.3e} s (20 steps per period: {accurate:.3e} s), or `--method implicit_trapezoid`, which has no stability limit; `--force` runs anyway",
            method.name(),
            fast.what,
            fast.omega,
            h * fast.omega
        ));
    }
    // dopri5's and dop853's accuracy is their tolerance's, whatever their output interval
    let own_steps = matches!(
        method,
        MethodSpec::DormandPrince { .. } | MethodSpec::DormandPrince853 { .. }
    );
    if let Some(motion) = est.fastest_motion().filter(|_| h > accurate && !own_steps) {
        return Verdict::Warn(format!(
            "the step {h:.3e} s gives {:.1} steps per period of the {} (ω = {:.4e} rad/s); accuracy needs at least 20 (h ≤ {accurate:.3e} s)",
            std::f64::consts::TAU / (motion.omega * h),
            motion.what,
            motion.omega
        ));
    }
    Verdict::Ok
}

/// What the run refuses before its first step, without running: the run settings
/// ([`mbdc_runtime::app::run_config`]) and the method's start ([`integrators::make`]) on `sys`
/// (the interpreted scene) from its initial state, the functions the run itself calls. `Err`
/// with the refusal.
pub fn start<S: System>(sys: &S, scene: &Scene, settings: &Settings) -> Result<(), String> {
    let cfg = mbdc_runtime::app::run_config(sys, scene, settings)?;
    let initial = State::initial(sys);
    integrators::make(&cfg.method, sys, cfg.step, &initial)
        .map(drop)
        .map_err(|e| format!("method {}: {e}", cfg.method.name()))
}

/// The interpreted system of a scene, or the error printed (a scene the runtime does not
/// simulate, such as one with a finite-element mesh).
pub fn interp(scene: &Scene) -> Result<Interp, ExitCode> {
    Interp::new(scene).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::FAILURE
    })
}

/// Print the verdict of [`judge`], then of [`start`]; `Err` with the exit code when the run
/// must not start. `force` runs past the gate's refusal (not past the run's own).
pub fn gate<S: System>(
    scene: &Scene,
    sys: &S,
    settings: &Settings,
    force: bool,
    quiet: bool,
) -> Result<(), ExitCode> {
    let method = match settings.method.as_deref() {
        Some(n) if n != scene.simulate.method.name() => {
            MethodSpec::default_for(n).unwrap_or_else(|| scene.simulate.method.clone())
        }
        _ => scene.simulate.method.clone(),
    };
    let h = settings.step.unwrap_or(scene.simulate.step);
    let (verdict, note) = judge(scene, sys, &method, h);
    if let Some(n) = note.filter(|_| !quiet) {
        eprintln!("note: {n}");
    }
    match verdict {
        Verdict::Ok => {}
        Verdict::Warn(m) => {
            if !quiet {
                eprintln!("warning: {m}");
            }
        }
        Verdict::Refuse(m) if force => {
            eprintln!("warning: {m}\n  (running anyway: --force)");
        }
        Verdict::Refuse(m) => {
            eprintln!("error: {m}");
            return Err(ExitCode::FAILURE);
        }
    }
    start(sys, scene, settings).map_err(|m| {
        eprintln!("error: {m}");
        ExitCode::FAILURE
    })?;
    if !quiet {
        if let Some(w) = output_warning(sys, scene, settings) {
            eprintln!("warning: {w}");
        }
    }
    Ok(())
}

/// The warning of a run that would write more than
/// [`size_estimate::OUTPUT_WARN_BYTES`], with the output interval that would not.
pub fn output_warning<S: System>(sys: &S, scene: &Scene, settings: &Settings) -> Option<String> {
    let h = settings.step.unwrap_or(scene.simulate.step);
    let duration = settings.duration.unwrap_or(scene.simulate.duration);
    let every = settings.every.unwrap_or(scene.simulate.output.every);
    let steps = run_loop::step_count(duration, h);
    let spec = mbdc_runtime::app::output_spec(scene, settings);
    size_estimate::warning(sys.layout(), &spec, steps, every)
}
