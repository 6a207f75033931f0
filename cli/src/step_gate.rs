//! The stability gate of `mbdc run`: before a run, compare the step with the scene's stability
//! estimate ([`mbdc_runtime::step_limits`]) and refuse an explicit method whose step is above the
//! limit `h·ω_max ≤ 2`, or warn when there are fewer than 20 steps per period of the fastest
//! motion (notes A §1.10). `mbdc sweep` starts its default steps from the same estimate
//! ([`mbdc_runtime::study::step_series`]).

use std::process::ExitCode;

use mbdc_runtime::scene::{MethodSpec, Scene};
use mbdc_runtime::step_limits;

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

/// Judge step `h` with `method` on `scene`.
pub fn judge(scene: &Scene, method: &MethodSpec, h: f64) -> Verdict {
    let est = step_limits::estimate(scene);
    let Some(fast) = est.fastest() else {
        return Verdict::Ok;
    };
    let (stable, accurate) = (est.stable_step(), est.accurate_step());
    if fast.discretization && h > stable {
        // beams are explicit whatever the method
        return Verdict::Refuse(format!(
            "the step {h:.3e} s is above the stability limit of the {} at ω = {:.4e} rad/s (h·ω = {:.2} > 2): beams are advanced explicitly\n  help: use a step of at most {stable:.3e} s, or raise the beam's `rotary_inertia_scale` (it lowers its shear/rotary-inertia mode; docs/methods.md, \"Beams\")",
            fast.what,
            fast.omega,
            h * fast.omega
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
    if let Some(motion) = est.fastest_motion().filter(|_| h > accurate) {
        return Verdict::Warn(format!(
            "the step {h:.3e} s gives {:.1} steps per period of the {} (ω = {:.4e} rad/s); accuracy needs at least 20 (h ≤ {accurate:.3e} s)",
            std::f64::consts::TAU / (motion.omega * h),
            motion.what,
            motion.omega
        ));
    }
    Verdict::Ok
}

/// Print the verdict; `Err` with the exit code when the run must not start.
pub fn gate(
    scene: &Scene,
    method_name: Option<&str>,
    step: Option<f64>,
    force: bool,
    quiet: bool,
) -> Result<(), ExitCode> {
    let method = match method_name {
        Some(n) if n != scene.simulate.method.name() => {
            MethodSpec::default_for(n).unwrap_or_else(|| scene.simulate.method.clone())
        }
        _ => scene.simulate.method.clone(),
    };
    let h = step.unwrap_or(scene.simulate.step);
    match judge(scene, &method, h) {
        Verdict::Ok => Ok(()),
        Verdict::Warn(m) => {
            if !quiet {
                eprintln!("warning: {m}");
            }
            Ok(())
        }
        Verdict::Refuse(m) if force => {
            eprintln!("warning: {m}\n  (running anyway: --force)");
            Ok(())
        }
        Verdict::Refuse(m) => {
            eprintln!("error: {m}");
            Err(ExitCode::FAILURE)
        }
    }
}
