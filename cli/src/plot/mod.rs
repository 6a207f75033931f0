//! SVG plots: the figures `mbdc run` writes next to its CSV files, `mbdc plot` redraws,
//! and the work–precision diagram of `mbdc sweep`.
//!
//! Drawn with plotters' SVG backend and no default features: text is written as SVG
//! `<text>` elements in the generic `sans-serif` family (no system fonts are read; text
//! extents for the layout are estimated). Every figure has a title, every panel a title,
//! axis labels with units and a legend.
//!
//! - [`figure`]: the generic part, a [`figure::Figure`] of line-chart panels with linear
//!   or logarithmic axes.
//! - [`data`]: reading the columns of the output CSV files.
//! - [`run_plots`]: the run plots (energy, constraint violation, trajectories).
//! - [`beam_plots`]: per beam, its deflection and section forces along it.
//!
//! Each data series is an SVG `<polyline>` carrying `class="series"` and
//! `data-series="<name>"`, so that a figure can be checked or restyled by machine.

pub mod beam_plots;
pub mod data;
pub mod figure;
pub mod run_plots;

/// Why a plot could not be drawn.
#[derive(Debug)]
pub enum PlotError {
    /// A file could not be read.
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// What went wrong.
        source: std::io::Error,
    },
    /// The plot could not be written (the error names the file).
    Write(mbdc_runtime::output::OutputError),
    /// A CSV file is malformed.
    Csv {
        /// The file.
        path: std::path::PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The Exodus II file (`results.exo`) could not be read.
    Exodus(String),
    /// The request cannot be drawn (unknown quantity, nothing to plot, ...).
    Request(String),
    /// The drawing backend failed.
    Draw(String),
}

impl std::fmt::Display for PlotError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PlotError::Io { path, source } => write!(f, "{}: {source}", path.display()),
            PlotError::Write(e) => write!(f, "{e}"),
            PlotError::Csv { path, message } => write!(f, "{}: {message}", path.display()),
            PlotError::Exodus(m) | PlotError::Request(m) => f.write_str(m),
            PlotError::Draw(m) => write!(f, "drawing the plot: {m}"),
        }
    }
}

impl std::error::Error for PlotError {}
