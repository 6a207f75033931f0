//! What can go wrong in a study: a request that makes no sense, a scene the interpreter
//! cannot run, a reference that cannot be read, a runner that fails.
//!
//! A simulation that diverges or stops is *not* an error: it is a run with a non-ok
//! [`Status`](super::Status), kept in the results.

use std::path::PathBuf;

/// Why a study could not be planned or run.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// An option of [`StudyOptions`](super::StudyOptions) is out of range; `option` is the
    /// field's name.
    #[error("{option} must be {requirement}, got {got}")]
    InvalidOption {
        /// The field of `StudyOptions`: `duration`, `steps`, `h_max`, `levels`,
        /// `reference_refine`.
        option: &'static str,
        /// What it must be: `positive`, `at least 1`.
        requirement: &'static str,
        /// The value given, with its unit where it has one.
        got: String,
    },
    /// A method name that is not one of [`MethodSpec::NAMES`](crate::contract::scene::MethodSpec::NAMES).
    #[error("unknown method `{0}`")]
    UnknownMethod(String),
    /// No method can start on the scene; each left-out method with the reason.
    #[error("no method applies to this scene ({})", .0.iter().map(|(n, w)| format!("{n}: {w}")).collect::<Vec<_>>().join("; "))]
    NoMethod(Vec<(String, String)>),
    /// The interpreter cannot represent the scene (the study always builds it: it chooses
    /// the methods and runs the numerical reference).
    #[error("{0}")]
    Interp(#[from] crate::interp::InterpError),
    /// The scene's reference table cannot be used.
    #[error(transparent)]
    Reference(#[from] ReferenceError),
    /// A [`Runner`](super::Runner) failed (not the simulation: the runner itself).
    #[error(transparent)]
    Runner(#[from] RunnerError),
}

/// A runner that could not run (a program that does not start, output it cannot read).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct RunnerError(pub String);

/// A reference solution that cannot be read or does not cover a time.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ReferenceError {
    /// A reference table that cannot be read or has the wrong columns or rows.
    #[error("{}: {message}", path.display())]
    Table {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// The reference has no value at this time (a table that ends early, a time that the
    /// numerical reference did not sample).
    #[error("{0}")]
    NotCovered(String),
    /// An analytic orientation that is not a rotation (a zero quaternion).
    #[error("the reference orientation at t = {t} s is not a rotation: {q:?}")]
    NotARotation {
        /// The time, s.
        t: f64,
        /// The quaternion the functions gave.
        q: [f64; 4],
    },
}
