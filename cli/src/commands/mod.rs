//! Subcommands.

pub mod build;
pub mod check;
pub mod fmt;
pub mod plot;
pub mod run;
pub mod sweep;
pub mod view;
