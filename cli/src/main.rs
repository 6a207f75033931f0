//! # mbdc: the command-line program
//!
//! Front end only: argument parsing, rendering diagnostics (miette), progress bars, plots
//! and driving cargo for generated scenes. The work is done by `mbdc-compiler` and
//! `mbdc-runtime`.

fn main() {}
