//! The numerical reference of a scene without a `reference` block: a run of the most
//! accurate method at a step finer than the finest studied one, sampled at every frame time
//! of the study's runs, with its own error estimated by Richardson extrapolation.
//!
//! - **Method**: the one asked for, or the studied method whose two finest runs differ
//!   least (the first of implicit_trapezoid, staggered, coordinate_partitioning studied
//!   when no method finished its two finest runs).
//! - **Error estimate**: a second run at twice the step gives
//!   e(h_ref) ≈ |y(2h_ref) − y(h_ref)| / (2^p − 1), p the method's theoretical order (2
//!   when it has none), for each of the four [error measures](super::Errors).
//!
//! It always runs on the interpreter: it samples the run at every frame time in memory
//! (the interpreter and the compiled program run the same runtime and agree to round-off).

use crate::contract::scene::MethodSpec;

use super::error::StudyError;
use super::error_measures::difference;
use super::error_measures::Errors;
use super::interp_runner::InterpRunner;
use super::methods::{theoretical_order, MethodEntry};
use super::result::StudyRun;
use super::runner::Status;
use super::sampled::Sampler;
use super::track::Track;

/// The reference's method and how it was chosen (see the module doc). `h_min` is the
/// finest studied step.
///
/// # Errors
/// A `requested` name that is not a method.
pub fn choose_method(
    requested: Option<&str>,
    methods: &[MethodEntry],
    runs: &[StudyRun],
    h_min: f64,
) -> Result<(MethodSpec, String), StudyError> {
    if let Some(name) = requested {
        let spec = methods
            .iter()
            .find(|m| m.name == name)
            .map(|m| m.spec.clone())
            .or_else(|| MethodSpec::default_for(name))
            .ok_or_else(|| StudyError::UnknownMethod(name.to_string()))?;
        return Ok((spec, "chosen by the caller".into()));
    }
    let mut best: Option<(f64, usize)> = None;
    for mi in 0..methods.len() {
        let mut mine: Vec<&StudyRun> = runs
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
    Ok(match best {
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
    })
}

/// Run `method` at `h_ref` and at `2 h_ref` to `t_end`, sampled at `times`: the fine
/// track and the Richardson estimate of its error.
///
/// # Errors
/// Either run not finishing, in words.
pub fn run(
    interp: &InterpRunner,
    method: &MethodSpec,
    h_ref: f64,
    bodies: usize,
    times: &[f64],
    t_end: f64,
) -> Result<(Track, Errors), String> {
    let sample = |h: f64| -> Result<Track, String> {
        let mut s = Sampler::new(bodies, times);
        let report = interp.run_observed(method, h, t_end, 1, &mut s);
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
    let fine = sample(h_ref)?;
    let coarse = sample(2.0 * h_ref)?;
    let p = theoretical_order(method.name()).unwrap_or(2.0);
    let estimate = difference(&coarse, &fine)
        .unwrap_or_default()
        .scaled(1.0 / (2f64.powf(p) - 1.0));
    Ok((fine, estimate))
}
