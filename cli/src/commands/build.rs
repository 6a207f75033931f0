//! `mbdc build FILE`: generate a scene's Rust and build its program.
//!
//! - `mbdc build FILE --emit OUT.rs` writes the generated source (one `pub mod <scene>`
//!   with `Model`, formatted) for people to read, and the scene's numbers next to it
//!   (`OUT.scene.json`, which the source `include_str!`s). Nothing is compiled.
//! - `mbdc build FILE` builds the scene's program in the shared workspace of compiled scenes
//!   (what `mbdc run` runs) and prints its path; the program takes the arguments of
//!   `mbdc_runtime::app` (`--help` lists them).

use std::path::PathBuf;
use std::process::ExitCode;

use mbdc_compiler::codegen::{self, Options, SceneJson};
use mbdc_compiler::Override;
use mbdc_runtime::compiled::Mode;

use crate::commands::run::load;

/// The code layout to force.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Layout {
    /// Straight-line code per joint (small scenes).
    Unrolled,
    /// Loops over tables (large scenes).
    Tables,
}

/// Arguments of `mbdc build`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The .mbd file.
    pub file: PathBuf,
    /// Override a parameter: `--set L=2m` (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_override)]
    pub set: Vec<Override>,
    /// Write the generated Rust to this file instead of building (and the scene's numbers
    /// next to it, as `<stem>.scene.json`).
    #[arg(long, value_name = "FILE.rs")]
    pub emit: Option<PathBuf>,
    /// Force the code layout (default: unrolled up to 64 joints and forces, tables above).
    #[arg(long, value_enum)]
    pub layout: Option<Layout>,
    /// No spinner.
    #[arg(short, long)]
    pub quiet: bool,
}

fn parse_override(s: &str) -> Result<Override, String> {
    s.parse()
}

/// Runs `mbdc build`.
pub fn run(args: Args) -> ExitCode {
    let scene = match load(&args.file, &args.set) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let Some(out) = &args.emit else {
        let krate = match crate::scene_crate::prepare(&scene) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        };
        return match crate::scene_crate::build(&krate, args.quiet) {
            Ok(p) => {
                println!("{}", p.display());
                ExitCode::SUCCESS
            }
            Err(f) => {
                crate::scene_crate::report_build_failure(&f, &krate);
                ExitCode::FAILURE
            }
        };
    };
    let json = out.with_extension("scene.json");
    let json_name = json
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let opts = Options {
        module: None,
        mode: args.layout.map(|l| match l {
            Layout::Unrolled => Mode::Unrolled,
            Layout::Tables => Mode::Tables,
        }),
        scene_json: SceneJson::Include(json_name),
    };
    let g = match codegen::generate(&scene, &opts) {
        Ok(g) => g,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    for (path, text) in [(out, &g.source), (&json, &g.scene_json)] {
        if let Err(e) = std::fs::write(path, text) {
            eprintln!("error: writing {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    }
    if !args.quiet {
        eprintln!(
            "wrote {} ({} lines, {:?} layout, effects: {}) and {}",
            out.display(),
            g.source.lines().count(),
            g.mode,
            if g.effects.is_empty() {
                "none".to_string()
            } else {
                g.effects.join(", ")
            },
            json.display()
        );
    }
    ExitCode::SUCCESS
}
