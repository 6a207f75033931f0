//! The steps a study runs: given, or a geometric series halving from h_max.
//!
//! The explicit methods are stable for h·ω_max ≤ 2 and need about 20 steps per period to
//! be accurate (notes A §1.10), so the default series starts at h_max = T_min / 20 =
//! 2π / (20 ω_max), h_max·ω_max ≈ 0.31, with ω_max the fastest rate of the scene's
//! [stability estimate](crate::analysis::step_limits::estimate) ([`FastestRate`]), and halves from
//! there. h_max is first shrunk so that the duration is a whole number of steps: then every
//! step of the series ends exactly on the end time and all runs share their frame times.
//! A scene without an estimate gets a series with its own step in the middle.

use crate::contract::scene::Scene;

use super::error::StudyError;

/// The fastest rate of a scene at t = 0 and where it comes from: the first source of the
/// runtime's [stability estimate](crate::analysis::step_limits::estimate).
#[derive(Clone, Debug, PartialEq)]
pub struct FastestRate {
    /// ω_max, rad/s.
    pub omega_max: f64,
    /// What sets it, e.g. `spin of body 'top'`.
    pub source: String,
}

impl FastestRate {
    /// The fastest rate of `scene`; `None` when nothing in the scene sets a rate (a body at
    /// rest under no forces), or when it has beams or meshes (the series then starts just
    /// below the beams' stability limit, or at the scene's own step for meshes).
    pub fn of(scene: &Scene) -> Option<FastestRate> {
        if !scene.beams.is_empty() || !scene.meshes.is_empty() {
            return None;
        }
        crate::analysis::step_limits::estimate(scene)
            .fastest()
            .map(|s| FastestRate {
                omega_max: s.omega,
                source: s.what.clone(),
            })
    }

    /// The shortest period 2π/ω_max, s.
    pub fn period(&self) -> f64 {
        std::f64::consts::TAU / self.omega_max
    }

    /// The largest step of the default series: 20 steps per shortest period.
    pub fn h_max(&self) -> f64 {
        self.period() / 20.0
    }

    /// The explicit stability limit h = 2/ω_max, s.
    pub fn h_limit(&self) -> f64 {
        2.0 / self.omega_max
    }
}

/// A geometric series of `levels` steps from `h_max` down, each `ratio` times smaller.
pub fn series(h_max: f64, levels: usize, ratio: f64) -> Vec<f64> {
    (0..levels).map(|k| h_max / ratio.powi(k as i32)).collect()
}

/// Shrink `h` so that `duration / h` is a whole number (every step of a series made
/// from it by halving then lands exactly on the end time).
pub fn fit_to_duration(h: f64, duration: f64) -> f64 {
    if duration <= 0.0 || h <= 0.0 {
        return h;
    }
    let n = (duration / h - 1e-9).ceil().max(1.0);
    duration / n
}

/// The steps of a study, coarsest first, and how they were chosen.
#[derive(Clone, Debug, PartialEq)]
pub struct StepSeries {
    /// Steps, s, coarsest first, without repeats.
    pub steps: Vec<f64>,
    /// How they were chosen, in words.
    pub note: String,
}

/// Choose the steps: `given` (sorted, repeats removed) when not empty; otherwise `levels`
/// steps halving from `h_max` (or the rule of the module doc with `rate`, or around the
/// scene's step), shrunk to a whole number of steps in `duration`.
///
/// # Errors
/// A step or `h_max` that is not a positive number.
pub fn choose(
    given: &[f64],
    h_max: Option<f64>,
    levels: usize,
    duration: f64,
    scene: &Scene,
    rate: Option<&FastestRate>,
) -> Result<StepSeries, StudyError> {
    if !given.is_empty() {
        let mut s = given.to_vec();
        if let Some(bad) = s.iter().find(|h| !(**h > 0.0 && h.is_finite())) {
            return Err(StudyError::InvalidOption {
                option: "steps",
                requirement: "positive",
                got: bad.to_string(),
            });
        }
        s.sort_by(|a, b| b.total_cmp(a));
        s.dedup();
        return Ok(StepSeries {
            steps: s,
            note: "as given".into(),
        });
    }
    let (h, note) = match (h_max, rate) {
        (Some(h), _) => {
            if !(h > 0.0 && h.is_finite()) {
                return Err(StudyError::InvalidOption {
                    option: "h_max",
                    requirement: "positive",
                    got: h.to_string(),
                });
            }
            (h, format!("halving from the requested h_max = {h} s"))
        }
        (None, Some(e)) => (
            e.h_max(),
            format!(
                "halving from h_max = T_min/20, T_min = 2π/ω_max, ω_max = {:.4} rad/s ({})",
                e.omega_max, e.source
            ),
        ),
        (None, None) => {
            // beams: their element modes limit stability, not accuracy; start just below it
            let beam = (scene.meshes.is_empty() && !scene.beams.is_empty())
                .then(|| {
                    use crate::analysis::step_limits::{beam_substeps, estimate};
                    estimate(scene).with_beam_substeps(beam_substeps(&scene.simulate.method))
                })
                .and_then(|e| e.sources.into_iter().find(|s| s.discretization));
            match beam {
                Some(b) => (
                    0.9 * 2.0 / b.omega,
                    format!(
                        "halving from 0.9 × the explicit limit 2/ω = {:.4e} s of the {} (a beam's element modes limit the step, not the accuracy)",
                        2.0 / b.omega,
                        b.what
                    ),
                ),
                None => (
                    scene.simulate.step * 2f64.powi((levels as i32 - 1) / 2),
                    "the scene's step in the middle (no stability estimate: nothing in the scene sets a rate)".to_string(),
                ),
            }
        }
    };
    let h = fit_to_duration(h, duration);
    Ok(StepSeries {
        steps: series(h, levels, 2.0),
        note,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_and_duration() {
        let h = fit_to_duration(0.03, 1.0);
        assert!((1.0 / h - 34.0).abs() < 1e-9, "{h}");
        assert!(h <= 0.03);
        assert_eq!(fit_to_duration(0.25, 1.0), 0.25);
        let s = series(0.1, 3, 2.0);
        assert_eq!(s, vec![0.1, 0.05, 0.025]);
    }

    /// A scene with a beam: the series starts at 0.9 of the beam's stability limit (its
    /// element modes are no motion to resolve), and says so.
    #[test]
    fn beams_start_below_their_stability_limit() {
        use crate::contract::scene::{Beam, Origin, Section, Simulate};
        let section = Section {
            ea: 1e4,
            ga2: 1e4,
            ga3: 1e4,
            ei2: 10.0,
            ei3: 10.0,
            gj: 10.0,
            rho_a: 1.0,
            rho_i: 1e-2,
        };
        let scene = Scene {
            name: "b".into(),
            gravity: None,
            bodies: vec![],
            joints: vec![],
            forces: vec![],
            beams: vec![Beam {
                name: "arm".into(),
                nodes: (0..=10).map(|k| [0.1 * k as f64, 0.0, 0.0]).collect(),
                up: [0.0, 0.0, 1.0],
                section,
                attachments: vec![],
                damping: 0.0,
                rotary_inertia_scale: 1.0,
                velocity: [0.0; 3],
                angular_velocity: [0.0; 3],
                origin: Origin::default(),
            }],
            meshes: vec![],
            contacts: vec![],
            simulate: Simulate::default(),
            reference: None,
            params: vec![],
        };
        assert!(FastestRate::of(&scene).is_none());
        let w = crate::analysis::step_limits::beam_element_frequency(&section, 0.1, 1.0).unwrap();
        // a duration that is a whole number of the first step
        let h0 = 0.9 * 2.0 / w;
        let s = choose(&[], None, 3, 1000.0 * h0, &scene, None).unwrap();
        assert!(
            (s.steps[0] - h0).abs() < 1e-12 * h0,
            "{:?} vs {h0}",
            s.steps
        );
        assert_eq!(s.steps.len(), 3);
        assert!(s.note.contains("beam 'arm'"), "{}", s.note);
    }

    #[test]
    fn rate_rules() {
        let r = FastestRate {
            omega_max: 20.0,
            source: "spring 'k'".into(),
        };
        assert!((r.h_max() - std::f64::consts::TAU / 400.0).abs() < 1e-15);
        assert!((r.h_limit() - 0.1).abs() < 1e-15);
    }
}
