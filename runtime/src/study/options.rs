//! What a study is asked to do. Every field has a default ([`StudyOptions::default`]): all
//! the methods that apply, five halving steps from the stability estimate, the scene's
//! duration, about 200 compared frames, repetitions for at least 0.2 s of CPU time per run,
//! the fitted measure chosen from what the reference has — the defaults of `mbdc sweep`.

use std::path::PathBuf;

use super::error_measures::Measure;

/// Most levels of the default step series. Each level halves the step, so the finest of
/// `levels` runs 2^(levels−1) times the steps of the first (and the numerical reference
/// [`reference_refine`](StudyOptions::reference_refine) times more): past 20 a sweep does not
/// end in any useful time.
pub const MAX_LEVELS: usize = 20;

/// What [`StudyOptions::levels`] must be, as the refusal says it (`MAX_LEVELS` spelled out).
pub const LEVELS_REQUIREMENT: &str = "between 1 and 20 (each level halves the step: the 20th takes 2^19 = 524288 times the steps of the first)";

/// The options of a study.
#[derive(Clone, Debug, PartialEq)]
pub struct StudyOptions {
    /// Methods to run, by [name](crate::contract::scene::MethodSpec::NAMES); empty: every method that
    /// can start on the scene.
    pub methods: Vec<String>,
    /// Steps, s; empty: a geometric series (see [`step_series`](super::step_series)).
    pub steps: Vec<f64>,
    /// Largest step of the default series (default: 20 steps per shortest period).
    pub h_max: Option<f64>,
    /// Number of steps in the default series, each half the previous (1 to [`MAX_LEVELS`]).
    pub levels: usize,
    /// Duration, s (default: the scene's).
    pub duration: Option<f64>,
    /// About how many frames of each run are compared with the reference.
    pub frames: usize,
    /// Repeat each run until its repetitions add up to this CPU time, s; the best time is
    /// reported (0: one run each; a run that fails is repeated at most 3 times).
    pub min_time: f64,
    /// The measure that is fitted (default: the largest position error if the reference has
    /// positions, else the largest orientation error).
    pub measure: Option<Measure>,
    /// Method of the numerical reference, when the scene has no `reference` block (default:
    /// the studied method whose two finest runs differ least).
    pub reference_method: Option<String>,
    /// The numerical reference's step is the finest studied step divided by this (at
    /// least 2).
    pub reference_refine: u32,
    /// The folder a `reference { table "…" }` path is relative to: the model file's
    /// (default: the current directory).
    pub reference_dir: Option<PathBuf>,
}

impl Default for StudyOptions {
    fn default() -> StudyOptions {
        StudyOptions {
            methods: Vec::new(),
            steps: Vec::new(),
            h_max: None,
            levels: 5,
            duration: None,
            frames: 200,
            min_time: 0.2,
            measure: None,
            reference_method: None,
            reference_refine: 8,
            reference_dir: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The refusal spells out the limit and what it costs: it must say the same as the
    /// constant.
    #[test]
    fn the_levels_requirement_says_max_levels() {
        let finest = 1u64 << (MAX_LEVELS - 1);
        assert!(LEVELS_REQUIREMENT.contains(&format!("between 1 and {MAX_LEVELS} ")));
        assert!(LEVELS_REQUIREMENT.contains(&format!(
            "the {MAX_LEVELS}th takes 2^{} = {finest} times",
            MAX_LEVELS - 1
        )));
    }
}
