//! `feti [LARGEST] [ROUNDS]`: FETI against the direct factorization on linear static
//! analyses of 3-D hex8 cantilevers of growing size (BENCHMARKS.md, "FETI against the
//! direct solver"), the comparison of the FETI paper's Table 3 (notes E §4.4: tearing 3.4×
//! faster and 5.3× smaller than a skyline Cholesky at 48 k unknowns on a CRAY-2).
//!
//! Per mesh, side by side in one run: the direct solver (faer's sparse Cholesky with AMD,
//! one thread, as the implicit analyses use it) and FETI with 8 and 32 subdomains
//! (Dirichlet preconditioner, tolerance 1e-8) on 1 and 2 threads. Reported: the setup (the
//! assembly, the tearing, every factorization and the first solve: what `mesh_method
//! static` does before its first frame), one further solve (what every later step of a
//! time-varying load costs), the factors' storage (8 bytes per stored value: the paper's
//! "memory size"), FETI's iterations, and the two solutions' relative difference.

use std::sync::Arc;
use std::time::Instant;

use mbdc_runtime::integrators::mesh_implicit::MeshImplicit;
use mbdc_runtime::integrators::MeshState;
use mbdc_runtime::scene::{FetiOptions, FetiPreconditioner, MeshMethod, MeshSolver, Scene};

/// A hex8 cantilever `4n × n × n` (L = 4 m, 1 m square), clamped at x = 0, under a tip
/// traction that grows with t (so every step solves a new right-hand side).
fn scene(n: usize) -> Scene {
    let text = format!(
        r#"
model feti_bench {{
  material steel {{ E 200 GPa; nu 0.3; rho 7800 kg/m^3 }}
  mesh beam {{
    element hex8
    generate box(origin: (0, 0, 0) m, size: (4, 1, 1) m, divisions: ({}, {n}, {n}))
    material steel
    set root = nodes(x == 0)
    set tip = nodes(x == 4 m)
    fix root
    traction tip, (0, 0, -1 MPa * (1 + t / 1 s))
  }}
  simulate {{ duration 1 s; step 1 s; mesh_method static }}
}}
"#,
        4 * n
    );
    let l = mbdc_compiler::load_str("feti_bench.mbd", &text, &[]);
    let msg = l.render_plain();
    l.scene.unwrap_or_else(|| panic!("{msg}"))
}

/// Setup and one further solve of `solver` on `scene`, best of `rounds`, in a pool of
/// `threads`: (setup s, solve s, factor bytes, iterations, displacements).
fn measure(
    scene: &Scene,
    solver: MeshSolver,
    threads: usize,
    rounds: usize,
) -> (f64, f64, f64, u32, Vec<f64>) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a pool");
    let mut s = scene.clone();
    s.simulate.mesh_solver = solver;
    let sys = mbdc_runtime::interp::Interp::new(&s).expect("the bench scene");
    let layout = mbdc_runtime::system::System::layout(&sys).meshes.clone();
    let (mut setup, mut solve) = (f64::INFINITY, f64::INFINITY);
    let (mut bytes, mut iterations, mut u) = (0.0, 0, Vec::new());
    for _ in 0..rounds {
        pool.install(|| {
            let t0 = Instant::now();
            let mut m = MeshImplicit::new(
                Arc::clone(&layout),
                MeshMethod::Static,
                1.0,
                0.0,
                &MeshState::default(),
            )
            .expect("the bench mesh solves");
            setup = setup.min(t0.elapsed().as_secs_f64());
            let t1 = Instant::now();
            m.advance().expect("the second solve");
            solve = solve.min(t1.elapsed().as_secs_f64());
            bytes = 8.0 * m.factor_nnz() as f64;
            iterations = m.feti().map_or(0, |f| f.stats().max_iterations);
            let mut st = MeshState::default();
            m.mesh_state(&mut st);
            u = st.u.as_flattened().to_vec();
        });
    }
    (setup, solve, bytes, iterations, u)
}

/// The benchmark (see the module doc): meshes `4n × n × n` for `n` = 4, 6, 8, … up to
/// `largest`.
pub fn feti(largest: usize, rounds: usize) {
    println!(
        "# FETI against the direct solver: hex8 cantilevers 4n × n × n, static, best of {rounds}"
    );
    println!(
        "| n | unknowns | solver | threads | setup (s) | solve (s) | factors (MB) | iterations | setup / direct | solve / direct | memory / direct | difference |"
    );
    println!("|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut n = 4;
    while n <= largest {
        let sc = scene(n);
        let unknowns = 3 * (4 * n) * (n + 1) * (n + 1);
        let (ds, dv, db, _, du) = measure(&sc, MeshSolver::Direct, 1, rounds);
        println!(
            "| {n} | {unknowns} | direct | 1 | {ds:.3} | {dv:.4} | {:.1} | – | 1 | 1 | 1 | – |",
            db / 1e6
        );
        for p in [8u32, 32] {
            for threads in [1, 2] {
                let solver = MeshSolver::Feti(FetiOptions {
                    subdomains: p,
                    preconditioner: FetiPreconditioner::Dirichlet,
                    tolerance: 1e-8,
                    max_iterations: 1000,
                });
                let (fs, fv, fb, it, fu) = measure(&sc, solver, threads, rounds);
                let scale = du.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                let diff = fu
                    .iter()
                    .zip(&du)
                    .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
                    / scale;
                println!(
                    "| {n} | {unknowns} | feti {p} | {threads} | {fs:.3} | {fv:.4} | {:.1} | {it} | {:.2} | {:.2} | {:.2} | {diff:.1e} |",
                    fb / 1e6,
                    fs / ds,
                    fv / dv,
                    fb / db
                );
            }
        }
        n += if n < 8 { 2 } else { 4 };
    }
}
