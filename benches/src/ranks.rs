//! `ranks [MBDC] [N] [ROUNDS]`: the explicit mesh method across MPI ranks against threads
//! in one process (BENCHMARKS.md, "The explicit method across ranks"), issue 17's rank
//! benchmark.
//!
//! A hex8 bar of `4N × N × N` elements (one-point integration with viscous hourglass
//! control, fixed at one end, a step traction at the other) runs for a fixed number of
//! steps, side by side in every round: `mbdc run --interp` on 1 and 2 rayon threads, and
//! `mpirun -n P mbdc run --mpi` on 1, 2 and 4 ranks of one thread each (4 oversubscribes
//! a 2-core machine). Reported per configuration (best of `ROUNDS`): the run's wall time
//! per step from its `summary.json` (the run alone, not MPI's start), element updates per
//! second, and rank 0's communication per step in bytes (the interface forces it sends).
//! `MBDC` is an mbdc built with `--features mpi` (default `target/release/mbdc`).

use std::path::{Path, PathBuf};
use std::process::Command;

/// The bar as a model file.
fn model(n: usize, steps: usize) -> String {
    format!(
        r#"
model ranks_bench {{
  material steel {{ E 210 GPa; nu 0.3; rho 7850 kg/m^3 }}
  mesh bar {{
    element hex8
    integration reduced
    hourglass viscous(0.1)
    generate box(origin: (0, 0, 0) m, size: (4, 1, 1) m, divisions: ({}, {n}, {n}))
    material steel
    set root = nodes(x == 0)
    set tip = nodes(x == 4 m)
    fix root
    traction tip, (1 MPa * step(t), 0, 0)
  }}
  simulate {{ duration {} s; step 1e-6 s; output {{ every {steps}; format csv }} }}
}}
"#,
        4 * n,
        steps as f64 * 1e-6
    )
}

/// One run's (wall seconds per step, bytes sent per step by rank 0).
fn one(mbdc: &Path, file: &Path, out: &Path, ranks: Option<usize>, threads: usize) -> (f64, f64) {
    let _ = std::fs::remove_dir_all(out);
    let mut c = match ranks {
        Some(p) => {
            let mut c = Command::new("mpirun");
            c.env("OMPI_ALLOW_RUN_AS_ROOT", "1")
                .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
                .args(["--oversubscribe", "-n", &p.to_string()])
                .arg(mbdc)
                .args(["run", "--mpi"]);
            c
        }
        None => {
            let mut c = Command::new(mbdc);
            c.args(["run", "--interp"]);
            c
        }
    };
    let status = c
        .env("RAYON_NUM_THREADS", threads.to_string())
        .arg(file)
        .args(["-q", "-o"])
        .arg(out)
        .status()
        .expect("mbdc (or mpirun) runs");
    assert!(status.success(), "{c:?} failed");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let steps = s["steps"].as_f64().unwrap();
    let wall = s["wall_time"].as_f64().unwrap();
    let bytes = s["extra"]["rank0_exchange_bytes_per_step"]
        .as_f64()
        .unwrap_or(0.0);
    (wall / steps, bytes)
}

/// The benchmark (see the module doc).
pub fn ranks(mbdc: &Path, n: usize, rounds: usize) {
    let dir = std::env::temp_dir().join(format!("mbdc-bench-ranks-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let steps = 400;
    let file = dir.join("bar.mbd");
    std::fs::write(&file, model(n, steps)).unwrap();
    let elements = 4 * n * n * n;
    let configs: [(&str, Option<usize>, usize); 5] = [
        ("threads, 1", None, 1),
        ("threads, 2", None, 2),
        ("MPI, 1 rank", Some(1), 1),
        ("MPI, 2 ranks", Some(2), 1),
        ("MPI, 4 ranks", Some(4), 1),
    ];
    let mut best = [(f64::INFINITY, 0.0); 5];
    for _ in 0..rounds {
        for (k, (_, ranks, threads)) in configs.iter().enumerate() {
            let out: PathBuf = dir.join(format!("out{k}"));
            let (t, b) = one(mbdc, &file, &out, *ranks, *threads);
            if t < best[k].0 {
                best[k] = (t, b);
            }
        }
    }
    println!(
        "hex8 one-point bar {}×{n}×{n}: {elements} elements, {steps} steps, best of {rounds}",
        4 * n
    );
    println!(
        "| run | µs per step | element updates/s | vs 1 thread | bytes sent per step (rank 0) |"
    );
    println!("|---|---|---|---|---|");
    for ((name, _, _), (t, b)) in configs.iter().zip(best) {
        println!(
            "| {name} | {:.0} | {:.2e} | {:.2}× | {} |",
            t * 1e6,
            elements as f64 / t,
            best[0].0 / t,
            b
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
