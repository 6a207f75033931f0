//! Everything a study measured: the runs with their errors, the reference, the fits.

use super::error_measures::{Errors, Measure};
use super::fit::Fit;
use super::methods::MethodEntry;
use super::runner::Outcome;
use super::step_series::FastestRate;
use std::path::PathBuf;

/// One measured run of a study.
#[derive(Clone, Debug, PartialEq)]
pub struct StudyRun {
    /// Index into [`StudyResult::methods`].
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

/// Everything a study measured.
#[derive(Clone, Debug, PartialEq)]
pub struct StudyResult {
    /// Model name.
    pub model: String,
    /// Duration, s.
    pub duration: f64,
    /// What ran the scene ([`Runner::describe`](super::Runner::describe)).
    pub runner: String,
    /// The fastest rate of the scene, behind the default steps and the stability limit.
    pub estimate: Option<FastestRate>,
    /// How the steps were chosen.
    pub steps_note: String,
    /// The methods.
    pub methods: Vec<MethodEntry>,
    /// Methods left out and why.
    pub skipped: Vec<(String, String)>,
    /// The runs, by method then step (coarse to fine).
    pub runs: Vec<StudyRun>,
    /// The reference.
    pub reference: ReferenceInfo,
    /// The fitted measure.
    pub measure: Measure,
    /// The secondary measure fitted too (orientation when positions are primary and the
    /// reference has both, and the other way round).
    pub secondary: Option<Measure>,
    /// The scene's length scale, m (the largest initial mass-centre distance from the
    /// origin, at least 1 m).
    pub length_scale: f64,
    /// Whether the scene has energy sources (then the energy drift means nothing).
    pub energy_sources: bool,
    /// Per method: fits of the primary and the secondary measure.
    pub fits: Vec<(Fit, Option<Fit>)>,
    /// The signal that stopped the study (`SIGINT`, `SIGTERM`) in a program that handles
    /// them ([`crate::app::StopSignals`]): during the runs, the runs are those done before
    /// it (the run it cut is left out) and a numerical reference is not computed; during
    /// the numerical reference, the runs are all there and the reference is not
    /// ([`ReferenceInfo::Unavailable`] either way).
    pub interrupted: Option<String>,
}

impl StudyResult {
    /// The index of the method called `name`.
    pub fn method_index(&self, name: &str) -> Option<usize> {
        self.methods.iter().position(|m| m.name == name)
    }

    /// The fit of the primary measure of the method called `name`.
    pub fn fit_of(&self, name: &str) -> Option<&Fit> {
        self.method_index(name).map(|i| &self.fits[i].0)
    }
}

/// Which reference a study used.
#[derive(Clone, Debug, PartialEq)]
pub enum ReferenceInfo {
    /// The scene's analytic functions.
    Analytic,
    /// The scene's table, at this path.
    Table(PathBuf),
    /// A numerical run.
    Numerical {
        /// Its method.
        method: String,
        /// Its step, s.
        step: f64,
        /// Richardson estimate of its error: e(h_ref) ≈ |y(2h_ref) − y(h_ref)| / (2^p − 1).
        estimate: Errors,
        /// How the method was chosen, in words.
        chosen: String,
    },
    /// None could be made (the errors are left empty); why, in words.
    Unavailable(String),
}
