//! `mbdc plot OUTDIR [QUANTITY...]`: draw the plots of a run from its output folder.
//!
//! Without quantities it redraws the plots `mbdc run` writes (`energy.svg`,
//! `constraints.svg`, `trajectories.svg`), optionally for chosen bodies and joints. With
//! quantities — any column of the output CSV files, by name — it draws them against time
//! into one figure (`plot.svg` by default), one panel per unit.
//!
//! A run that did not finish — its `summary.json` still the one written when it started,
//! after a SIGKILL or a crash — is plotted up to its last frame, with a warning that says so.

use std::path::PathBuf;
use std::process::ExitCode;

use mbdc_runtime::output::{RunStatus, Summary};

use crate::plot::{self, data, run_plots::RunPlotOptions};

/// Arguments of `mbdc plot`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The output folder of a run (`mbdc run FILE -o DIR`).
    pub dir: PathBuf,
    /// Quantities to draw against time: column names of bodies.csv (`rod1.x`, `rod1.wz`),
    /// energy.csv (`kinetic`, `total`, `drift`, `Lz`) or constraints.csv
    /// (`shoulder.violation`, `shoulder.lambda0`); `FILE:COLUMN` where a name is in several
    /// files. None: redraw energy.svg, constraints.svg and trajectories.svg.
    pub quantities: Vec<String>,
    /// Bodies for trajectories.svg, comma-separated (default: the three that move most).
    #[arg(long, value_delimiter = ',', value_name = "NAMES")]
    pub bodies: Vec<String>,
    /// Joints for constraints.svg, comma-separated (default: all, or the eight largest).
    #[arg(long, value_delimiter = ',', value_name = "NAMES")]
    pub joints: Vec<String>,
    /// Logarithmic vertical axis for the quantities.
    #[arg(long)]
    pub log: bool,
    /// File for the quantities' figure (default: DIR/plot.svg).
    #[arg(short = 'o', long = "out", value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// List the quantities that can be drawn, by file, and exit.
    #[arg(long)]
    pub list: bool,
}

/// Runs `mbdc plot`.
pub fn run(args: Args) -> ExitCode {
    match plot_dir(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Says so when the run did not finish: its `summary.json` is still the one written at its
/// start. What it wrote until then is whole and is plotted.
fn warn_unfinished(dir: &std::path::Path) {
    if let Ok(s) = Summary::read(&dir.join("summary.json")) {
        if s.status() == RunStatus::Started {
            eprintln!(
                "warning: the run in {} did not finish: {}; plotting the frames it wrote until then",
                dir.display(),
                crate::commands::run::UNFINISHED
            );
        }
    }
}

fn plot_dir(args: &Args) -> Result<(), plot::PlotError> {
    if args.list {
        let mut any = false;
        for f in ["bodies.csv", "energy.csv", "constraints.csv"] {
            let p = args.dir.join(f);
            if !p.exists() {
                continue;
            }
            any = true;
            let cols: Vec<String> = data::header(&p)?.into_iter().filter(|c| c != "t").collect();
            println!("{f}: {}", cols.join(" "));
        }
        if !any {
            return Err(plot::PlotError::Request(format!(
                "{} has no output files",
                args.dir.display()
            )));
        }
        return Ok(());
    }
    warn_unfinished(&args.dir);
    if args.quantities.is_empty() {
        let opts = RunPlotOptions {
            bodies: args.bodies.clone(),
            joints: args.joints.clone(),
        };
        let d = plot::run_plots::draw_run_plots(&args.dir, &opts)?;
        for f in &d.files {
            println!("wrote {}", f.display());
        }
        for n in &d.notes {
            println!("skipped {n}");
        }
        return Ok(());
    }
    if !args.bodies.is_empty() || !args.joints.is_empty() {
        return Err(plot::PlotError::Request(
            "--bodies and --joints choose what the standard plots show; with quantities, name the columns instead (`rod1.x rod1.z`)".into(),
        ));
    }
    let fig = plot::run_plots::quantities_figure(&args.dir, &args.quantities, args.log)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| args.dir.join("plot.svg"));
    fig.save(&out)?;
    println!("wrote {}", out.display());
    Ok(())
}
