//! Subcommands.

pub mod check;
pub mod fmt;
pub mod run;
