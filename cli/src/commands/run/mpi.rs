//! `mbdc run --mpi FILE` under `mpirun`: the scene across the ranks of Open MPI (cargo
//! feature `mpi`). Every rank loads and checks the same scene and runs its part of it
//! ([`mbdc_runtime::ranked`]): the explicit mesh method on its elements with the interface
//! forces exchanged every step, or the implicit analyses with FETI's subdomains shared
//! between the ranks. Rank 0 gathers the parts at every output frame and writes the one
//! output folder, prints the progress and the summary; each rank writes its own
//! checkpoints (`OUTDIR/ranks/R/checkpoints`), which `--restart` under the same number of
//! ranks continues from.
//!
//! A rank that dies (killed, out of memory) ends the whole run: `mpirun` sees the rank go
//! and stops the others, and says which rank and why; the checkpoints written before stay
//! whole (each is written to a temporary file and renamed).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use mbdc_runtime::ranked::{run_ranked_to_dir, Ranked};
use mbdc_runtime::ranks::Ranks;

use super::{config, exit_code, load, note_unfinished, print_summary, settings, Args, Progress};
use crate::mpi_ranks::MpiRanks;

/// Runs `mbdc run --mpi`.
pub fn run(args: &Args) -> ExitCode {
    let ranks = match MpiRanks::init() {
        Ok(r) => Arc::new(r),
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let rank = ranks.rank();
    let lead = rank == 0;
    // Every rank checks the same scene and reaches the same verdict; rank 0 says it.
    let scene = if lead {
        load(&args.file, &args.set)
    } else {
        mbdc_compiler::load_file(&args.file, &args.set)
            .scene
            .ok_or(ExitCode::FAILURE)
    };
    let Ok(scene) = scene else {
        return ExitCode::FAILURE;
    };
    let sys = match crate::step_gate::interp(&scene) {
        Ok(s) => s,
        Err(code) => return code,
    };
    if let Err(code) = crate::step_gate::gate(
        &scene,
        &sys,
        &settings(args),
        args.force,
        args.quiet || !lead,
    ) {
        return code;
    }
    let part = match Ranked::new(&sys, ranks.clone() as Arc<dyn Ranks>) {
        Ok(p) => p,
        Err(e) => {
            if lead {
                eprintln!("error: {e}");
            }
            return ExitCode::FAILURE;
        }
    };
    let code = simulate(&part, &scene, args, &ranks);
    drop(part);
    code
}

/// [`super::simulate`] for one rank.
fn simulate(
    part: &Ranked<'_, mbdc_runtime::interp::Interp>,
    scene: &mbdc_runtime::scene::Scene,
    args: &Args,
    ranks: &MpiRanks,
) -> ExitCode {
    let rank = ranks.rank();
    let lead = rank == 0;
    let mut cfg = match config(part, scene, args) {
        Ok(c) => c,
        Err(e) => {
            if lead {
                eprintln!("error: {e}");
            }
            return ExitCode::FAILURE;
        }
    };
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&scene.name));
    // each rank its own checkpoints: its part's state
    let own = dir.join("ranks").join(rank.to_string());
    let mut set = settings(args);
    if args.restart {
        match common_checkpoint(ranks, &own.join(mbdc_runtime::checkpoint::FOLDER)) {
            Ok(step) => set.restart_up_to = Some(step),
            Err(e) => {
                if lead {
                    eprintln!("error: {e}");
                }
                return ExitCode::FAILURE;
            }
        }
    }
    match mbdc_runtime::app::checkpoints(part, scene, &mut cfg, &set, &own) {
        Ok(notes) => {
            if !args.quiet && lead {
                for n in notes {
                    eprintln!("rank {rank}: {n}");
                }
            }
        }
        Err(e) => {
            eprintln!("error: rank {rank}: {e}");
            ranks.abort(1);
        }
    }
    let meta = mbdc_runtime::output::RunMeta::new(scene, &cfg);
    if lead {
        note_unfinished(&dir, args.quiet);
        if let Err(e) = mbdc_runtime::output::write_scene(&dir, scene) {
            eprintln!("error: writing the output folder {}: {e}", dir.display());
            ranks.abort(1);
        }
        if !args.quiet {
            let what = match part.part_size() {
                Some((e, n, x)) => format!(
                    "the meshes split by coordinate bisection; rank 0 has {e} elements and {n} nodes and sends {} bytes per step",
                    8 * x
                ),
                None => "FETI's subdomains shared between the ranks".into(),
            };
            eprintln!("{} ranks on {}: {what}", ranks.size(), ranks.engine());
        }
    }
    let mut progress = Progress::new(cfg.duration, args.quiet || !lead);
    if lead {
        progress = progress.stop_on_signals();
    }
    let spec = mbdc_runtime::app::output_spec(scene, &settings(args));
    let result = run_ranked_to_dir(part, &cfg, meta, &spec, &dir, &mut progress);
    progress.finish();
    let code = match result {
        Ok((report, summary)) => {
            if let Some(summary) = summary {
                if !args.quiet || report.failure.is_some() || report.interrupted.is_some() {
                    print_summary(&summary, &dir);
                }
            }
            exit_code(&report)
        }
        Err(e) => {
            if lead {
                eprintln!("error: writing the output folder {}: {e}", dir.display());
            }
            return ExitCode::FAILURE;
        }
    };
    if lead {
        crate::plot::run_plots::after_run(&dir, args.quiet);
    }
    code
}

/// The newest step that every rank has a whole checkpoint of (a rank killed while writing
/// one leaves the others a step ahead): each rank's readable steps, gathered and compared
/// on rank 0, and its verdict broadcast.
///
/// # Errors
/// No step that every rank saved.
fn common_checkpoint(ranks: &MpiRanks, dir: &std::path::Path) -> Result<u64, String> {
    let mine: Vec<f64> = mbdc_runtime::checkpoint::readable_steps(dir)
        .into_iter()
        .map(|s| s as f64)
        .collect();
    // per rank: its count, then its steps
    let mut piece = vec![mine.len() as f64];
    piece.extend(&mine);
    let mut all = Vec::new();
    ranks.gather(&piece, &mut all);
    let mut verdict = [-1.0];
    if ranks.rank() == 0 {
        let mut sets = Vec::new();
        let mut at = 0;
        while at < all.len() {
            let n = all[at] as usize;
            sets.push(all[at + 1..at + 1 + n].to_vec());
            at += 1 + n;
        }
        verdict[0] = mine
            .iter()
            .rev()
            .find(|s| sets.iter().all(|set| set.contains(s)))
            .copied()
            .unwrap_or(-1.0);
    }
    ranks.broadcast(&mut verdict);
    if verdict[0] < 0.0 {
        return Err(format!(
            "the {} ranks have no checkpoint of one same step to restart from (in OUTDIR/ranks/R/checkpoints); restart with the number of ranks the run was written with, or run again from the start",
            ranks.size()
        ));
    }
    Ok(verdict[0] as u64)
}
