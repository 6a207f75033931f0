//! Benchmarks of natural partitioning, recorded in BENCHMARKS.md. Not a test (ignored);
//! every figure of one report comes from one run, side by side:
//!
//! ```text
//! cargo test -p mbdc-tests --test bench_natural_partitioning -- --ignored --nocapture
//! ```
//!
//! (test profile: opt-level 2.) Time per step is the best of three batches of steps after a
//! warm-up. The machine is shared, so single-thread figures are the CPU time of the
//! running thread (`CLOCK_THREAD_CPUTIME_ID`: time on the CPU, unaffected by other
//! processes taking turns; cache sharing still is); thread speed-ups are wall-clock.
//! Memory is the bytes the integrator (and the interpreter) hold, counted by a global
//! allocator (allocated minus freed during construction).

use std::alloc::{GlobalAlloc, Layout, System as SysAlloc};
use std::sync::atomic::{AtomicIsize, Ordering};
use std::time::Instant;

use mbdc_runtime::integrators::natural::{self, reduced::Precond, Natural};
use mbdc_runtime::integrators::{self, Integrator, State};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::scene::{Factorization, MethodSpec, Scene, StaggeredOptions};
use mbdc_runtime::system::{ConstraintEval, Need, System};

struct Counting;

static LIVE: AtomicIsize = AtomicIsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        LIVE.fetch_add(l.size() as isize, Ordering::Relaxed);
        SysAlloc.alloc(l)
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        LIVE.fetch_sub(l.size() as isize, Ordering::Relaxed);
        SysAlloc.dealloc(p, l)
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        LIVE.fetch_add(new as isize - l.size() as isize, Ordering::Relaxed);
        SysAlloc.realloc(p, l, new)
    }
}

#[global_allocator]
static A: Counting = Counting;

fn live() -> isize {
    LIVE.load(Ordering::Relaxed)
}

/// CPU time of the calling thread, s, to the nanosecond: `CLOCK_THREAD_CPUTIME_ID` asks the
/// scheduler for the running thread's time up to now. (`/proc/thread-self/schedstat`, used
/// before, is only brought up to date at the scheduler tick for a thread that is running: a
/// batch of six 13 ms steps then read in multiples of 4 ms, 0.67 ms per step.) Falls back to
/// wall time where the clock is unavailable.
fn cpu_time() -> f64 {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec; the call writes only into it.
        if unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0 {
            return ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9;
        }
    }
    static T0: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    T0.get_or_init(Instant::now).elapsed().as_secs_f64()
}

/// Whether batches are timed by CPU time (single thread) or wall clock.
#[derive(Clone, Copy, PartialEq)]
enum Clock {
    Cpu,
    Wall,
}

fn load(name: &str, param: &str, n: usize) -> Scene {
    let mut scene =
        mbdc_tests::load_model_with(&format!("bench/{name}"), &[&format!("{param}={n}")]);
    // The chains turn about z at 1 rad/s; the tension grows like N², and in a 1 km chain
    // (N = 10000) it puts the fastest mode of the links near the root past the explicit
    // limit at the scenes' h = 0.1 ms (h·ω ≈ 2.4: the run blows up within 20 steps). Above
    // N = 1000 they start at 1000/N rad/s instead, the tension of N = 1000.
    if name.starts_with("chain") && n > 1000 {
        let f = 1000.0 / n as f64;
        for b in &mut scene.bodies {
            b.velocity = b.velocity.map(|x| x * f);
            b.angular_velocity = b.angular_velocity.map(|x| x * f);
        }
    }
    scene
}

/// Seconds per step (best of three batches of `steps`), bytes held by the integrator and
/// by the interpreter, and the integrator's statistics.
struct Timing {
    per_step: f64,
    /// Median seconds per step over the batches (how much the machine's other tenants
    /// moved the figure).
    median: f64,
    integrator_bytes: isize,
    interp_bytes: isize,
    stats: Vec<(&'static str, f64)>,
}

fn time_method(scene: &Scene, method: &MethodSpec, steps: usize) -> Timing {
    time_method_with(scene, method, steps, Clock::Cpu)
}

fn time_method_with(scene: &Scene, method: &MethodSpec, steps: usize, clock: Clock) -> Timing {
    let mut l = Live::new(scene, method, steps);
    for _ in 0..3 {
        l.batch(clock);
    }
    l.timing()
}

/// A scene with its integrator, warmed up, timed batch by batch (the best batch counts).
struct Live {
    sys: Interp,
    it: Box<dyn Integrator<Interp>>,
    steps: usize,
    /// Seconds per step of every batch.
    all: Vec<f64>,
    integrator_bytes: isize,
    interp_bytes: isize,
}

impl Live {
    fn new(scene: &Scene, method: &MethodSpec, steps: usize) -> Live {
        let m0 = live();
        let sys = Interp::new(scene).expect("interpretable");
        let interp_bytes = live() - m0;
        let start = State::initial(&sys);
        let m1 = live();
        let mut it = integrators::make(method, &sys, scene.simulate.step, &start).expect("start");
        let integrator_bytes = live() - m1;
        for _ in 0..2 {
            it.step(&sys).expect("warm-up step");
        }
        Live {
            sys,
            it,
            steps,
            all: Vec::new(),
            integrator_bytes,
            interp_bytes,
        }
    }

    /// One batch of `steps` steps; records its time per step.
    fn batch(&mut self, clock: Clock) {
        let (t, c) = (Instant::now(), cpu_time());
        for _ in 0..self.steps {
            self.it.step(&self.sys).expect("step");
        }
        let dt = match clock {
            Clock::Cpu => cpu_time() - c,
            Clock::Wall => t.elapsed().as_secs_f64(),
        };
        self.all.push(dt / self.steps as f64);
    }

    fn timing(self) -> Timing {
        Timing {
            per_step: self.all.iter().copied().fold(f64::INFINITY, f64::min),
            median: {
                let mut a = self.all.clone();
                a.sort_by(f64::total_cmp);
                a.get(a.len() / 2).copied().unwrap_or(f64::NAN)
            },
            integrator_bytes: self.integrator_bytes,
            interp_bytes: self.interp_bytes,
            stats: self.it.stats(),
        }
    }
}

fn np() -> MethodSpec {
    MethodSpec::default_for("natural_partitioning").unwrap()
}

/// Steps per batch: about 60 000 body-steps, at least 20 (a batch of the 10 000-body scenes
/// then takes ~0.3 s, long against any clock's resolution).
fn steps_for(bodies: usize) -> usize {
    (60_000 / bodies.max(1)).clamp(20, 5_000)
}

fn stat(t: &Timing, name: &str) -> f64 {
    t.stats
        .iter()
        .find(|(n, _)| *n == name)
        .map_or(f64::NAN, |(_, v)| *v)
}

#[test]
#[ignore]
fn bench_natural_partitioning() {
    println!("threads available: {}", rayon_threads());
    if let Ok(l) = std::fs::read_to_string("/proc/loadavg") {
        println!("load average at start: {}", l.trim());
    }

    // 1. Scaling. All eighteen scenes are built first and timed in interleaved rounds (best
    // of thirty batches each; the medians too), so a slow spell of the shared machine hits
    // every N alike and the ratios stay meaningful. N = 2500 and 5000 show where the working
    // set leaves the cache.
    println!("\n## Scaling (natural_partitioning, 1 thread)\n");
    println!("| scene | N | bodies | µs/step | ns/(step·body) | t(N)/t(N/10) | per body / per body at N = 1000 | median µs/step | t(N)/t(N/10) of medians | gyroscopic it./step | integrator memory | bytes/body | interpreter memory |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let names = ["chain_planar.mbd", "chain_spatial.mbd", "tree8.mbd"];
    let sizes = [10usize, 100, 1000, 2500, 5000, 10000];
    let rows = natural::with_threads(1, || {
        let mut live: Vec<(&str, usize, usize, Live)> = Vec::new();
        for name in names {
            for n in sizes {
                let scene = load(name, "N", n);
                let nb = scene.bodies.len();
                live.push((name, n, nb, Live::new(&scene, &np(), steps_for(nb))));
            }
        }
        for _round in 0..30 {
            for (_, _, _, l) in live.iter_mut() {
                l.batch(Clock::Cpu);
            }
        }
        live.into_iter()
            .map(|(name, n, nb, l)| (name, n, nb, l.timing()))
            .collect::<Vec<_>>()
    });
    for (name, n, nb, t) in &rows {
        let of = |m: usize| {
            rows.iter()
                .find(|(o, k, _, _)| o == name && *k == m)
                .map(|(_, _, b, t)| (t.per_step, *b, t.median))
        };
        let decade = if n % 10 == 0 { of(n / 10) } else { None };
        let per_body = t.per_step / *nb as f64;
        println!(
            "| {name} | {n} | {nb} | {:.1} | {:.0} | {} | {} | {:.1} | {} | {:.2} | {:.2} MB | {} | {:.2} MB |",
            t.per_step * 1e6,
            per_body * 1e9,
            decade.map_or("—".into(), |(p, _, _)| format!("{:.2}", t.per_step / p)),
            of(1000).map_or("—".into(), |(p, b, _)| format!(
                "{:.2}",
                per_body / (p / b as f64)
            )),
            t.median * 1e6,
            decade.map_or("—".into(), |(_, _, m)| format!("{:.2}", t.median / m)),
            stat(t, "gyro_iterations_mean"),
            t.integrator_bytes as f64 / 1e6,
            t.integrator_bytes / *nb as isize,
            t.interp_bytes as f64 / 1e6,
        );
    }

    // 2. Against the Lagrange-multiplier staggered method at N = 100.
    against_staggered_table();

    // 3. Two threads against one.
    println!("\n## Threads: two against one\n");
    println!("| scene | N | 1 thread µs/step | 2 threads µs/step | speed-up |");
    println!("|---|---|---|---|---|");
    for (name, n) in [
        ("tree8.mbd", 10000usize),
        ("tree8.mbd", 1000),
        ("chain_spatial.mbd", 10000),
    ] {
        let scene = load(name, "N", n);
        let nb = scene.bodies.len();
        // alternately, best of four each, so a slow spell hits both
        let (mut t1, mut t2) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..4 {
            for (threads, best) in [(1, &mut t1), (2, &mut t2)] {
                let t = natural::with_threads(threads, || {
                    time_method_with(&scene, &np(), steps_for(nb), Clock::Wall)
                });
                *best = best.min(t.per_step);
            }
        }
        println!(
            "| {name} | {n} | {:.0} | {:.0} | {:.2} |",
            t1 * 1e6,
            t2 * 1e6,
            t1 / t2
        );
    }

    // 4. The parallel threshold: tree8 with every level parallel or none, 2 threads.
    println!("\n## Parallel threshold (tree8, 2 threads): always parallel against never\n");
    println!("| N | bodies | never µs/step | always µs/step | always / never |");
    println!("|---|---|---|---|---|");
    for n in [10usize, 100, 400, 1000, 4000] {
        let scene = load("tree8.mbd", "N", n);
        let nb = scene.bodies.len();
        let run = |par_min: usize| {
            natural::with_threads(2, || {
                let sys = Interp::new(&scene).unwrap();
                let st = State::initial(&sys);
                let mut it = Natural::new(&sys, scene.simulate.step, None, 1e-12, &st).unwrap();
                it.set_par_min(par_min);
                for _ in 0..2 {
                    Integrator::<Interp>::step(&mut it, &sys).unwrap();
                }
                let steps = steps_for(nb);
                let mut best = f64::INFINITY;
                for _ in 0..3 {
                    let t = Instant::now();
                    for _ in 0..steps {
                        Integrator::<Interp>::step(&mut it, &sys).unwrap();
                    }
                    best = best.min(t.elapsed().as_secs_f64() / steps as f64);
                }
                best
            })
        };
        let never = run(usize::MAX);
        let always = run(2);
        println!(
            "| {n} | {nb} | {:.1} | {:.1} | {:.2} |",
            never * 1e6,
            always * 1e6,
            always / never
        );
    }

    // 5. Closed loops: the ladder.
    println!("\n## Closed loops: ladder of K four-bar cells (1 thread)\n");
    println!("| K | bodies | cut rows | natural µs/step | Newton it./step | PCG it./solve (max) | staggered µs/step | max loop violation after 2000 steps |");
    println!("|---|---|---|---|---|---|---|---|");
    for k in [10usize, 30, 100] {
        let scene = load("ladder.mbd", "K", k);
        let nb = scene.bodies.len();
        let (t, ts, viol) = natural::with_threads(1, || {
            let t = time_method(&scene, &np(), steps_for(nb).min(500));
            let ts = time_method(
                &scene,
                &MethodSpec::default_for("staggered").unwrap(),
                steps_for(nb).min(200),
            );
            // violation after 2000 steps (0.2 s)
            let sys = Interp::new(&scene).unwrap();
            let st = State::initial(&sys);
            let mut it = integrators::make(&np(), &sys, scene.simulate.step, &st).unwrap();
            let mut out = State::initial(&sys);
            let mut ce = ConstraintEval::new(sys.layout().rows);
            let mut worst: f64 = 0.0;
            for _ in 0..2000 {
                it.step(&sys).unwrap();
                it.state(&sys, &mut out);
                sys.constraints(out.t, &out.pose, &out.twist, Need::PHI, &mut ce);
                worst = ce.phi.iter().fold(worst, |a, p| a.max(p.abs()));
            }
            (t, ts, worst)
        });
        println!(
            "| {k} | {nb} | {} | {:.0} | {:.2} | {:.1} ({:.0}) | {:.0} | {:.1e} m |",
            stat(&t, "cut_rows"),
            t.per_step * 1e6,
            stat(&t, "newton_iterations_mean"),
            stat(&t, "pcg_iterations_mean"),
            stat(&t, "pcg_iterations_max"),
            ts.per_step * 1e6,
            viol
        );
    }

    // 6. Preconditioners of the PCG on AᵀMA.
    println!("\n## PCG on AᵀMA: iterations to a relative residual of 1e-10\n");
    println!("| scene | N | coordinates | none | block-Jacobi | tree-exact |");
    println!("|---|---|---|---|---|---|");
    for name in ["chain_planar.mbd", "chain_spatial.mbd", "tree8.mbd"] {
        for n in [10usize, 100, 1000] {
            let scene = load(name, "N", n);
            let sys = Interp::new(&scene).unwrap();
            let st = State::initial(&sys);
            let mut it = Natural::new(&sys, scene.simulate.step, None, 1e-12, &st).unwrap();
            for _ in 0..10 {
                Integrator::<Interp>::step(&mut it, &sys).unwrap();
            }
            let nc = it.tree().ncoord;
            let mut cells = Vec::new();
            for pc in [Precond::Identity, Precond::BlockJacobi, Precond::TreeExact] {
                let s = it.measure_pcg(&sys, pc, 1e-10, 7);
                cells.push(if s.converged {
                    format!("{}", s.iterations)
                } else {
                    format!("> {} (residual {:.0e})", s.iterations, s.relative_residual)
                });
            }
            println!(
                "| {name} | {n} | {nc} | {} | {} | {} |",
                cells[0], cells[1], cells[2]
            );
        }
    }
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Profiling aid: `NP_SCENE=tree8.mbd NP_N=1000 NP_STEPS=200 cargo test ... profile_natural
/// -- --ignored` runs one scene (for `perf record`).
#[test]
#[ignore]
fn profile_natural() {
    let name = std::env::var("NP_SCENE").unwrap_or("chain_spatial.mbd".into());
    let n: usize = std::env::var("NP_N").map_or(1000, |v| v.parse().unwrap());
    let steps: usize = std::env::var("NP_STEPS").map_or(200, |v| v.parse().unwrap());
    let param = if name.starts_with("ladder") { "K" } else { "N" };
    let scene = load(&name, param, n);
    let threads: usize = std::env::var("NP_THREADS").map_or(1, |v| v.parse().unwrap());
    let t = natural::with_threads(threads, || {
        time_method_with(&scene, &np(), steps, Clock::Wall)
    });
    println!(
        "{name} N={n}: {:.1} µs/step, {:.2} gyroscopic iterations/step",
        t.per_step * 1e6,
        stat(&t, "gyro_iterations_mean")
    );
}

/// At N = 100, `natural_partitioning` against the Lagrange-multiplier `staggered` method
/// with its default (sparse at this size) and with its dense factorization of
/// `E + h²BM⁻¹Bᵀ` (`factorization dense`), one thread, interleaved.
fn against_staggered_table() {
    println!("\n## N = 100: natural_partitioning against staggered (1 thread)\n");
    println!("| scene | bodies | rows | natural µs/step | staggered (sparse) µs/step | staggered (dense) µs/step | sparse / natural | dense / natural |");
    println!("|---|---|---|---|---|---|---|---|");
    let stag = |f: Factorization| {
        MethodSpec::Staggered(StaggeredOptions {
            factorization: f,
            ..Default::default()
        })
    };
    for name in ["chain_planar.mbd", "chain_spatial.mbd", "tree8.mbd"] {
        let scene = load(name, "N", 100);
        let nb = scene.bodies.len();
        let rows = Interp::new(&scene).unwrap().layout().rows;
        let (mut a, mut b, mut c) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
        natural::with_threads(1, || {
            for _ in 0..3 {
                a = a.min(time_method(&scene, &np(), steps_for(nb)).per_step);
                let sparse = stag(Factorization::Sparse);
                b = b.min(time_method(&scene, &sparse, steps_for(nb) / 4).per_step);
                let dense = stag(Factorization::Dense);
                c = c.min(time_method(&scene, &dense, steps_for(nb) / 8).per_step);
            }
        });
        println!(
            "| {name} | {nb} | {rows} | {:.1} | {:.1} | {:.1} | {:.1} | {:.1} |",
            a * 1e6,
            b * 1e6,
            c * 1e6,
            b / a,
            c / a
        );
    }
}

/// Just the table against `staggered`: `cargo test -p mbdc-tests --test
/// bench_natural_partitioning -- --ignored --nocapture against_staggered`.
#[test]
#[ignore]
fn against_staggered() {
    against_staggered_table();
}

/// Quick check of the scaling target: `NP_SCENE=tree8.mbd cargo test ... quick_ratio --
/// --ignored --nocapture` times N = 1000 and 10000 of one scene in interleaved rounds
/// (`NP_ROUNDS`, default 5) and prints t(10000)/t(1000).
#[test]
#[ignore]
fn quick_ratio() {
    let name = std::env::var("NP_SCENE").unwrap_or("chain_planar.mbd".into());
    let rounds: usize = std::env::var("NP_ROUNDS").map_or(5, |v| v.parse().unwrap());
    natural::with_threads(1, || {
        let mut live: Vec<(usize, Live)> = [1000usize, 10000]
            .into_iter()
            .map(|n| {
                let scene = load(&name, "N", n);
                let nb = scene.bodies.len();
                (nb, Live::new(&scene, &np(), steps_for(nb)))
            })
            .collect();
        for _ in 0..rounds {
            for (_, l) in live.iter_mut() {
                l.batch(Clock::Cpu);
            }
        }
        let t: Vec<(usize, f64)> = live
            .into_iter()
            .map(|(nb, l)| (nb, l.timing().per_step))
            .collect();
        println!(
            "{name}: {:.0} / {:.0} ns/(step·body) at 1000 / 10000, ratio {:.2}",
            t[0].1 * 1e9 / t[0].0 as f64,
            t[1].1 * 1e9 / t[1].0 as f64,
            t[1].1 / t[0].1
        );
    });
}
