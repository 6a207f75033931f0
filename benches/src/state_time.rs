//! `mbdc-bench state-time [ROUNDS]`: the parallel-in-time speed-up of one `state_time`
//! window (BENCHMARKS.md, "state_time: time as a parallel dimension").
//!
//! One window of many time elements is solved from the scene's start (the staggered
//! initial-guess sweep, then Newton) on a rayon pool of 1 and of 2 threads, in interleaved
//! rounds, the best of the rounds kept. The window's Newton statistics split its wall time
//! into the assembly (parallel over the elements), the sparse LU (sequential) and the rest
//! (the guess sweep and the bookkeeping, sequential); the sequential fraction `f` at one
//! thread gives Amdahl's projection `S_p = 1 / (f + (1 − f)/p)` for `p` cores.

use std::time::Instant;

use mbdc_runtime::integrators::state_time::StateTime;
use mbdc_runtime::integrators::{Integrator, State};
use mbdc_runtime::interp::Interp;

/// One measured solve: total wall time, assembly and LU time, unknowns, iterations, and
/// the state after the first step (to check the thread counts agree).
struct Solve {
    total: f64,
    assembly: f64,
    lu: f64,
    unknowns: f64,
    iterations: u32,
    state: State,
}

fn solve(sys: &Interp, h: f64, spe: u32, elements: usize, threads: usize) -> Solve {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    pool.install(|| {
        let start = State::initial(sys);
        let mut st = StateTime::new(sys, h, spe, elements, &start).expect("state_time starts");
        let t0 = Instant::now();
        st.step(sys).expect("the window solves");
        let total = t0.elapsed().as_secs_f64();
        let last = st.last_window();
        let mut state = start;
        Integrator::<Interp>::state(&st, sys, &mut state);
        let unknowns = Integrator::<Interp>::stats(&st)
            .iter()
            .find(|s| s.0 == "equations_per_window")
            .map_or(0.0, |s| s.1);
        Solve {
            total,
            assembly: last.assembly_seconds,
            lu: last.lu_seconds,
            unknowns,
            iterations: last.iterations,
            state,
        }
    })
}

/// A measured case: its name, model file and parameters, step, steps per element, and the
/// window's elements.
type Case = (
    &'static str,
    &'static str,
    &'static [(&'static str, &'static str)],
    f64,
    u32,
    usize,
);

/// Run the measurement over `rounds` interleaved rounds and print the table.
pub fn state_time(rounds: usize) {
    let cases: [Case; 3] = [
        (
            "planar double pendulum (notes F), 5 s",
            "state_time_double_pendulum.mbd",
            &[("elements", "1024")],
            5.0 / 2048.0,
            2,
            1024,
        ),
        (
            "3-D double pendulum, 2 s",
            "double_pendulum_3d.mbd",
            &[],
            1e-3,
            2,
            1000,
        ),
        (
            "spatial chain of 8 links, 0.2 s",
            "bench/chain_spatial.mbd",
            &[("N", "8")],
            2e-4,
            2,
            500,
        ),
    ];
    println!(
        "| scene | elements | unknowns | Newton its | 1 thread: total / assembly / LU / rest (s) | 2 threads: total (s) | speed-up | sequential fraction f | projected S₄ / S₁₆ / S₆₄ |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (name, file, sets, h, spe, elements) in cases {
        let scene = super::load(file, sets);
        let sys = Interp::new(&scene).expect("interpretable");
        let mut best: [Option<Solve>; 2] = [None, None];
        for _ in 0..rounds {
            for (i, threads) in [1, 2].into_iter().enumerate() {
                let s = solve(&sys, h, spe, elements, threads);
                if best[i].as_ref().is_none_or(|b| s.total < b.total) {
                    best[i] = Some(s);
                }
            }
        }
        let [Some(one), Some(two)] = best else {
            unreachable!("at least one round")
        };
        assert_eq!(
            one.state.pose, two.state.pose,
            "{name}: 1 and 2 threads disagree"
        );
        let rest = one.total - one.assembly - one.lu;
        let f = (one.lu + rest) / one.total;
        let proj = |p: f64| 1.0 / (f + (1.0 - f) / p);
        println!(
            "| {name} | {elements} | {:.0} | {} | {:.3} / {:.3} / {:.3} / {:.3} | {:.3} | {:.2} | {:.2} | {:.2} / {:.2} / {:.2} |",
            one.unknowns,
            one.iterations,
            one.total,
            one.assembly,
            one.lu,
            rest,
            two.total,
            one.total / two.total,
            f,
            proj(4.0),
            proj(16.0),
            proj(64.0),
        );
    }
}
