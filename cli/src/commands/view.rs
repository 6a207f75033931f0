//! `mbdc view OUTDIR`: write `OUTDIR/view.html`, the 3-D replay of a run, and open it.
//!
//! The page is one self-contained file (no network access needed): bodies, beams, meshes,
//! joints and springs moving frame by frame, with play/pause, speed, a scrub bar, frame
//! steps, orbit/pan/zoom, follow, trails, and the energy and violation curves under the
//! view. See `crate::view` for what it is built from.

use std::path::PathBuf;
use std::process::ExitCode;

use crate::view::{self, ViewOptions};

/// Arguments of `mbdc view`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The output folder of a run (`mbdc run FILE -o DIR`).
    pub dir: PathBuf,
    /// Write the page without opening it.
    #[arg(long)]
    pub no_open: bool,
    /// Size budget of the page's frames, MiB: longer runs show every k-th frame (and the
    /// last), also beyond 20 000 frames (600 with meshes, whose frames are read from .vtu).
    #[arg(long, value_name = "MB", default_value_t = 48)]
    pub max_mb: usize,
}

/// Runs `mbdc view`.
pub fn run(args: Args) -> ExitCode {
    if args.max_mb == 0 || args.max_mb > 4096 {
        eprintln!("error: --max-mb must be from 1 to 4096 (a browser holds a page of a few hundred MB at most)");
        return ExitCode::from(2);
    }
    let opts = ViewOptions {
        max_frame_bytes: args.max_mb << 20,
    };
    if write_and_open(&args.dir, opts, !args.no_open, false) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

/// Write the page of `dir` and open it if asked; print what was written (not with
/// `quiet`) and any error. Returns whether the page was written.
pub fn write_and_open(dir: &std::path::Path, opts: ViewOptions, open: bool, quiet: bool) -> bool {
    match view::write_view(dir, opts) {
        Ok(w) => {
            for n in &w.notes {
                eprintln!("note: {n}");
            }
            if !quiet {
                let shown = if w.shown_every > 1 {
                    format!(
                        "{} of {} frames (every {}-th, and the last)",
                        w.frames, w.run_frames, w.shown_every
                    )
                } else {
                    format!("{} frames", w.frames)
                };
                println!(
                    "view: {} ({shown}, {:.1} MB)",
                    w.path.display(),
                    w.bytes as f64 / 1e6
                );
            }
            if open {
                if let Err(why) = view::open_in_browser(&w.path) {
                    if !quiet {
                        println!("  open it in a browser ({why})");
                    }
                }
            }
            true
        }
        Err(e) => {
            eprintln!("error: {e}");
            false
        }
    }
}
