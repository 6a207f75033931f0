//! # mbdc: the command-line program
//!
//! **What it is.** The front end only: argument parsing, rendering diagnostics (miette), progress bars, plots
//! the 3-D replay page (`view`) and driving cargo for generated scenes. The work is done by `mbdc-compiler` and
//! `mbdc-runtime`.
//!
//! **What it must never know.** How a scene is checked or simulated: that is
//! `mbdc-compiler` and `mbdc-runtime`, which never import this crate.
//!
//! **API boundary.** The command line (`mbdc --help`); nothing here is a library.
//!
//! Each subcommand lives in its own module under `commands/` with an `Args` struct (clap
//! derive) and a `run(args) -> ExitCode` function; add a variant to [`Command`] to add one.

mod child_signals;
mod commands;
#[cfg(feature = "mpi")]
mod mpi_ranks;
mod plot;
mod render;
mod scene_crate;
mod step_gate;
mod view;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// mbdc: a compiler for multibody and structural dynamics scenes (.mbd files).
#[derive(Debug, Parser)]
#[command(name = "mbdc", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Check a scene: print its diagnostics and a summary.
    Check(commands::check::Args),
    /// Format .mbd files in place (or check that they are formatted).
    Fmt(commands::fmt::Args),
    /// Simulate a scene and write its output folder (CSV time series, summary.json).
    Run(commands::run::Args),
    /// Generate a scene's Rust (`--emit FILE.rs`) or build its program.
    Build(commands::build::Args),
    /// Run a scene across step sizes and methods: error vs CPU time (work–precision).
    Sweep(commands::sweep::Args),
    /// Draw the plots of a run's output folder, or chosen quantities against time.
    Plot(commands::plot::Args),
    /// Replay a run in 3-D in the browser: write OUTDIR/view.html (self-contained) and open it.
    View(commands::view::Args),
}

/// Restores the default action of SIGPIPE (end the process quietly), as Unix tools do, and
/// ignores SIGXFSZ.
///
/// Rust's runtime ignores SIGPIPE, so a write to a closed pipe (`mbdc check f.mbd | head -1`)
/// returns an error and `println!` panics on it. With the default action the process ends at
/// that write, like `cat` or `grep`, on stdout and stderr alike (progress bars included).
///
/// SIGXFSZ (a file grew past the process's file-size limit, `ulimit -f`) would end the
/// process at once and lose the run's report; ignored, the write fails with `EFBIG` and the
/// run stops with a report naming the file, as on a full disk.
#[cfg(unix)]
fn quiet_on_closed_pipe() {
    // SAFETY: called first thing in `main`, before any other thread exists; `signal` with
    // SIG_DFL or SIG_IGN installs no handler.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

#[cfg(not(unix))]
fn quiet_on_closed_pipe() {}

fn main() -> ExitCode {
    quiet_on_closed_pipe();
    let cli = Cli::parse();
    match cli.command {
        Command::Check(a) => commands::check::run(a),
        Command::Fmt(a) => commands::fmt::run(a),
        Command::Run(a) => commands::run::run(a),
        Command::Build(a) => commands::build::run(a),
        Command::Sweep(a) => commands::sweep::run(a),
        Command::Plot(a) => commands::plot::run(a),
        Command::View(a) => commands::view::run(a),
    }
}
