//! The numerical reference of a scene without a `reference` block: a run of the most
//! accurate method at a step finer than the finest studied one, sampled at every frame time
//! of the study's runs, with its own error estimated by Richardson extrapolation.
//!
//! - **Method**: the one asked for, or the studied method whose two finest runs differ
//!   least by the sweep's error measure (position when none is given), ties broken by the
//!   other kind of error (the first of implicit_trapezoid, staggered,
//!   coordinate_partitioning studied when no method finished its two finest runs).
//! - **Error estimate**: a second run at twice the step gives
//!   e(h_ref) ≈ |y(2h_ref) − y(h_ref)| / (2^p − 1), p the method's theoretical order (2
//!   when it has none), for each of the four [error measures](super::Errors).
//!
//! It always runs on the interpreter: it samples the run at every frame time in memory
//! (the interpreter and the compiled program run the same runtime and agree to round-off).

use crate::contract::scene::MethodSpec;

use super::error::StudyError;
use super::error_measures::difference;
use super::error_measures::{Errors, Measure};
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
    measure: Option<Measure>,
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
    // by the sweep's error measure (position when none was asked for and there is one),
    // ties broken by the other kind: on a body whose centre never moves every method's
    // positions agree exactly, and the rotations must decide
    let mut best: Option<((f64, f64), usize)> = None;
    for mi in 0..methods.len() {
        let mut mine: Vec<&StudyRun> = runs
            .iter()
            .filter(|r| r.method == mi && r.outcome.status.is_ok())
            .collect();
        mine.sort_by(|a, b| a.step.total_cmp(&b.step));
        if mine.len() < 2 || mine[0].step > h_min * (1.0 + 1e-9) {
            continue;
        }
        let Some(e) = difference(&mine[0].outcome.track, &mine[1].outcome.track) else {
            continue;
        };
        let (first, other) = match measure {
            Some(m) if m.is_position() => (m.of(&e), e.rot_max),
            Some(m) => (m.of(&e), e.pos_max),
            None => (e.pos_max.or(e.rot_max), e.rot_max),
        };
        let Some(d) = first.filter(|d| d.is_finite()) else {
            continue;
        };
        let key = (d, other.filter(|x| x.is_finite()).unwrap_or(0.0));
        if best.is_none_or(|b| key < b.0) {
            best = Some((key, mi));
        }
    }
    Ok(match best {
        Some(((d, _), mi)) => (
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::runner::Outcome;
    use crate::study::track::tests::uniform_rotation;

    /// A finished run of method `method` at `step` whose orientations lag the spin by
    /// `lag` rad at every frame; its mass centre is where every other run's is.
    fn run(method: usize, step: f64, lag: f64) -> StudyRun {
        let times: Vec<f64> = (0..=10).map(|i| f64::from(i) * 0.1).collect();
        let mut track = uniform_rotation(&times, 1.0);
        for q in &mut track.q {
            let (w, z) = (q[0], q[3]);
            let (c, s) = ((lag / 2.0).cos(), (lag / 2.0).sin());
            // q · (cos, 0, 0, −sin): a turn back by `lag` about z
            *q = [w * c + z * s, 0.0, 0.0, z * c - w * s];
        }
        StudyRun {
            method,
            step,
            every: 1,
            outcome: Outcome {
                status: Status::Ok,
                cpu_time: 1e-3,
                steps: 10,
                t_end: 1.0,
                track,
                max_violation: 0.0,
                energy_drift: 0.0,
                iterations: None,
            },
            repetitions: 1,
            errors: None,
        }
    }

    fn entry(name: &'static str) -> MethodEntry {
        MethodEntry {
            name,
            spec: MethodSpec::default_for(name).unwrap(),
            options: String::new(),
            theory: None,
        }
    }

    /// A spinning body whose centre stays put: every method's positions agree exactly, so
    /// the rotations decide (the sweep once took a second-order method as the reference
    /// of a torque-free body this way, the first in the list).
    #[test]
    fn equal_positions_leave_the_choice_to_the_rotations() {
        let methods = [entry("staggered"), entry("rk4")];
        let runs = [
            run(0, 1e-3, 1e-6),
            run(0, 2e-3, 4e-6),
            run(1, 1e-3, 1e-12),
            run(1, 2e-3, 16e-12),
        ];
        for measure in [None, Some(Measure::PosFinal), Some(Measure::RotFinal)] {
            let (spec, why) = choose_method(None, measure, &methods, &runs, 1e-3).unwrap();
            assert_eq!(spec.name(), "rk4", "{measure:?}: {why}");
        }
    }
}
