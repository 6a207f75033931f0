//! `mbdc check FILE`: diagnostics and a summary of the scene.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use mbdc_compiler::Override;
use mbdc_runtime::app::Settings;
use mbdc_runtime::scene::Scene;

use crate::render;

/// Arguments of `mbdc check`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The .mbd file.
    pub file: PathBuf,
    /// Override a parameter: `--set L=2m` (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_override)]
    pub set: Vec<Override>,
    /// Print the set of effects the scene uses.
    #[arg(long)]
    pub effects: bool,
    /// Print the topology: spanning tree, cut joints, loops, branches, degrees of freedom,
    /// and the independent coordinates of natural partitioning per joint.
    #[arg(long)]
    pub topology: bool,
    /// Print the lowered scene as JSON (SI units) instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Split every mesh into P parts (recursive coordinate bisection) and print the
    /// partition metrics: elements, interface nodes, neighbouring parts, periphery,
    /// incidence.
    #[arg(long, value_name = "P", value_parser = clap::value_parser!(u32).range(1..))]
    pub partition: Option<u32>,
}

fn parse_override(s: &str) -> Result<Override, String> {
    s.parse()
}

/// Runs `mbdc check`.
pub fn run(args: Args) -> ExitCode {
    let loaded = mbdc_compiler::load_file(&args.file, &args.set);
    if !loaded.diagnostics.is_empty() {
        eprint!(
            "{}",
            render::diagnostics(&loaded.diagnostics, &loaded.sources)
        );
    }
    let Some(scene) = &loaded.scene else {
        eprintln!(
            "{}: {}",
            args.file.display(),
            render::counts(&loaded.diagnostics)
        );
        return ExitCode::FAILURE;
    };
    if args.json {
        match serde_json::to_string_pretty(scene) {
            Ok(s) => println!("{s}"),
            Err(e) => {
                eprintln!("error: cannot serialise the scene: {e}");
                return ExitCode::FAILURE;
            }
        }
        return refused_by_run(scene, &args.file);
    }
    let summary = mbdc_compiler::summary(scene);
    print!("{summary}");
    if args.effects {
        let e = mbdc_runtime::effects::Effects::of(scene);
        println!("effects:");
        let names = e.names();
        for n in [
            "gravity",
            "applied_forces",
            "time_dependence",
            "springs",
            "dampers",
            "drivers",
            "closed_loops",
            "nonholonomic",
            "locks",
            "beams",
            "meshes",
            "contact",
        ] {
            println!(
                "  {:<16} {}",
                n,
                if names.contains(&n) { "yes" } else { "no" }
            );
        }
    }
    if args.topology {
        let topo = mbdc_runtime::topology::Topology::new(scene);
        print!("{}", topo.render(scene));
        print!(
            "{}",
            mbdc_runtime::coordinates::coordinates_report(scene, &topo)
        );
    }
    if let Some(p) = args.partition {
        if scene.meshes.is_empty() {
            eprintln!(
                "error: `--partition` splits meshes, and {} has none",
                args.file.display()
            );
            return ExitCode::FAILURE;
        }
        for mesh in &scene.meshes {
            match mbdc_runtime::mesh_partition::bisect(mesh, p as usize) {
                Ok(part) => print!(
                    "{}",
                    mbdc_runtime::mesh_partition::PartitionMetrics::of(mesh, &part)
                        .render(&mesh.name)
                ),
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::FAILURE;
                }
            }
        }
    }
    if !loaded.diagnostics.is_empty() {
        eprintln!(
            "{}: {}",
            args.file.display(),
            render::counts(&loaded.diagnostics)
        );
    }
    refused_by_run(scene, &args.file)
}

/// What `mbdc run` refuses before its first step, found by the same functions
/// ([`crate::step_gate::gate`]): printed, and the exit code.
fn refused_by_run(scene: &Scene, file: &Path) -> ExitCode {
    let started = crate::step_gate::interp(scene)
        .and_then(|sys| crate::step_gate::gate(scene, &sys, &Settings::default(), false, false));
    match started {
        Ok(()) => ExitCode::SUCCESS,
        Err(code) => {
            eprintln!(
                "{}: `mbdc run` refuses this scene before its first step",
                file.display()
            );
            code
        }
    }
}
