//! Subcommands.

pub mod build;
pub mod check;
pub mod fmt;
pub mod plot;
pub mod run;
#[cfg(feature = "mpi")]
pub mod run_mpi;
pub mod sweep;
pub mod view;
