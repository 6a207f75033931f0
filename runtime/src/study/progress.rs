//! What a running study reports as it goes, for a caller that shows progress. The study
//! itself prints nothing.

use super::methods::MethodEntry;
use super::result::StudyRun;

/// Receives a study's progress; every method does nothing by default, and `()` is the
/// receiver that ignores everything.
pub trait Progress {
    /// A (method, step) has been run and timed (its errors are not measured yet).
    fn run_done(&mut self, _method: &MethodEntry, _run: &StudyRun) {}
    /// The numerical reference starts: `method` at `step` and at twice that step.
    fn reference_started(&mut self, _method: &str, _step: f64) {}
}

impl Progress for () {}
