//! `mbdc-bench`: the measurements of BENCHMARKS.md, section "Generated code".
//!
//! ```text
//! cargo run --release -p mbdc-bench -- steps [ROUNDS]     cost per step: generated, interpreted, yardstick
//! cargo run --release -p mbdc-bench -- size               generated source size vs bodies
//! cargo run --release -p mbdc-bench -- startup [MBDC]     `mbdc run` to the first step, cold and warm
//! cargo run --release -p mbdc-bench -- profile [STEPS]    the generated double pendulum alone (for perf)
//! cargo run --release -p mbdc-bench -- beams [ROUNDS]      beams: cost per element-step against a rigid body's step and the core's peak
//! cargo run --release -p mbdc-bench -- meshes [SCALE] [ROUNDS]  meshes: element rates against the measured bandwidth and flop rate, and the assembly strategies
//! cargo run --release -p mbdc-bench -- meshes-assembly [SCALE] [ROUNDS]  the assembly strategies side by side alone
//! cargo run --release -p mbdc-bench -- checkpoints [ROUNDS]  checkpoint save, write and restart read against a step and the disk
//! cargo run --release -p mbdc-bench -- output [ROUNDS] [SCALE]  whole runs with output off and every K steps, against the disk
//! cargo run --release -p mbdc-bench -- state-time [ROUNDS]  one state_time window on 1 and 2 threads: speed-up, sequential fraction, projection
//! ```
//!
//! Timings are interleaved rounds (every candidate once per round, in turn) and the best of
//! the rounds is reported, so that the candidates see the same machine load.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use mbdc_bench::generated::{
    chain32_tables, chain32_unrolled, double_pendulum_3d_tables, double_pendulum_3d_unrolled,
    four_bar_tables, four_bar_unrolled,
};
use mbdc_bench::yardstick::DoublePendulum;
use mbdc_compiler::codegen::{self, Options, SceneJson};
use mbdc_compiler::{Override, Scene};
use mbdc_runtime::compiled::{CompiledModel, Mode};
use mbdc_runtime::integrators::{self, State};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::scene::MethodSpec;
use mbdc_runtime::system::{ConstraintEval, Need, System, Wrench};

mod checkpoints;
mod feti;
mod meshes;
mod output;
mod ranks;
mod state_time;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn load(file: &str, sets: &[(&str, &str)]) -> Scene {
    let o: Vec<Override> = sets.iter().map(|(n, v)| Override::new(*n, *v)).collect();
    let loaded = mbdc_compiler::load_file(root().join("models").join(file), &o);
    match loaded.scene {
        Some(s) => s,
        None => panic!("{file}: {}", loaded.render_plain()),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("steps") => steps(args.get(1).and_then(|s| s.parse().ok()).unwrap_or(7)),
        Some("size") => size(),
        Some("beams") => beams(args.get(1).and_then(|s| s.parse().ok()).unwrap_or(5)),
        Some("meshes") => meshes::meshes(
            args.get(1).and_then(|s| s.parse().ok()).unwrap_or(0.1),
            args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3),
        ),
        Some("checkpoints") => {
            checkpoints::checkpoints(args.get(1).and_then(|s| s.parse().ok()).unwrap_or(3))
        }
        Some("output") => output::output(
            args.get(1).and_then(|s| s.parse().ok()).unwrap_or(2),
            args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1.0),
        ),
        Some("meshes-assembly") => meshes::assembly_only(
            args.get(1).and_then(|s| s.parse().ok()).unwrap_or(0.1),
            args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3),
        ),
        Some("meshes-memory") => meshes::memory_child(
            args.get(1).map(String::as_str).unwrap_or("Hex8Full"),
            args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1000),
            args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0),
        ),
        Some("feti") => feti::feti(
            args.get(1).and_then(|s| s.parse().ok()).unwrap_or(16),
            args.get(2).and_then(|s| s.parse().ok()).unwrap_or(2),
        ),
        Some("ranks") => ranks::ranks(
            &args
                .get(1)
                .map(PathBuf::from)
                .unwrap_or_else(|| root().join("target/release/mbdc")),
            args.get(2).and_then(|s| s.parse().ok()).unwrap_or(20),
            args.get(3).and_then(|s| s.parse().ok()).unwrap_or(3),
        ),
        Some("state-time") => {
            state_time::state_time(args.get(1).and_then(|s| s.parse().ok()).unwrap_or(3))
        }
        Some("profile") => profile(args.get(1).and_then(|s| s.parse().ok()).unwrap_or(200_000)),
        Some("startup") => startup(
            &args
                .get(1)
                .map(PathBuf::from)
                .unwrap_or_else(|| root().join("target/release/mbdc")),
        ),
        _ => {
            eprintln!(
                "usage: mbdc-bench steps [ROUNDS] | size | startup [MBDC] | profile [STEPS] | beams [ROUNDS] | meshes [SCALE] [ROUNDS] | meshes-assembly [SCALE] [ROUNDS] | checkpoints [ROUNDS] | output [ROUNDS] [SCALE] | feti [LARGEST] [ROUNDS] | ranks [MBDC] [N] [ROUNDS] | state-time [ROUNDS]"
            );
            std::process::exit(2);
        }
    }
}

// ---------------------------------------------------------------------------------------
// Cost per step

/// Seconds for `n` steps of the default staggered method from the scene's start, and the
/// mean number of LINT Newton iterations.
fn run_steps<S: System>(sys: &S, h: f64, n: usize) -> (f64, f64) {
    let method = MethodSpec::default_for("staggered").expect("staggered");
    let st = State::initial(sys);
    let mut it = integrators::make(&method, sys, h, &st).expect("starts");
    let t0 = Instant::now();
    for _ in 0..n {
        it.step(sys).expect("steps");
    }
    let dt = t0.elapsed().as_secs_f64();
    let iters = it
        .stats()
        .iter()
        .find(|(k, _)| *k == "newton_iterations_mean")
        .map(|x| x.1)
        .unwrap_or(0.0);
    (dt, iters)
}

/// Seconds per call of the model evaluations a staggered step makes, at the start state:
/// (`applied` + `constraints(ALL)`, `constraints(PHI)`).
fn eval_cost<S: System>(sys: &S, n: usize) -> (f64, f64) {
    let st = State::initial(sys);
    let m = sys.layout().rows;
    let mut ce = ConstraintEval::new(m);
    let mut w = vec![Wrench::default(); sys.layout().bodies()];
    let t0 = Instant::now();
    for k in 0..n {
        let t = black_box(k as f64 * 1e-9);
        sys.applied(t, &st.pose, &st.twist, &mut w);
        sys.constraints(t, &st.pose, &st.twist, Need::ALL, &mut ce);
        black_box(&ce);
        black_box(&w);
    }
    let full = t0.elapsed().as_secs_f64() / n as f64;
    let t0 = Instant::now();
    for k in 0..n {
        let t = black_box(k as f64 * 1e-9);
        sys.constraints(t, &st.pose, &st.twist, Need::PHI, &mut ce);
        black_box(&ce);
    }
    let phi = t0.elapsed().as_secs_f64() / n as f64;
    (full, phi)
}

/// A timed routine: given a count, the seconds it took and a second figure.
type Timed<'a> = Box<dyn Fn(usize) -> (f64, f64) + 'a>;

/// One candidate of the step benchmark.
struct Candidate<'a> {
    scene: &'static str,
    path: &'static str,
    steps: usize,
    /// Runs `steps` steps: (seconds, mean Newton iterations).
    run: Timed<'a>,
    /// Model evaluation cost per call, if it goes through `System`.
    eval: Option<Timed<'a>>,
    best: f64,
    iters: f64,
    eval_best: (f64, f64),
}

impl<'a> Candidate<'a> {
    fn system<S: System>(
        scene: &'static str,
        path: &'static str,
        sys: &'a S,
        h: f64,
        steps: usize,
    ) -> Candidate<'a> {
        Candidate {
            scene,
            path,
            steps,
            run: Box::new(move |n| run_steps(sys, h, n)),
            eval: Some(Box::new(move |n| eval_cost(sys, n))),
            best: f64::INFINITY,
            iters: 0.0,
            eval_best: (f64::INFINITY, f64::INFINITY),
        }
    }
}

fn generated<M: CompiledModel>(scene: &Scene) -> M {
    M::from_scene(scene).expect("same structure")
}

fn steps(rounds: usize) {
    let dp = load("double_pendulum_3d.mbd", &[]);
    let fb = load("four_bar.mbd", &[]);
    let ch = load("chain.mbd", &[]);
    let (h_dp, h_fb, h_ch) = (dp.simulate.step, fb.simulate.step, ch.simulate.step);
    let dp_i = Interp::new(&dp).expect("rigid");
    let dp_u: double_pendulum_3d_unrolled::Model = generated(&dp);
    let dp_t: double_pendulum_3d_tables::Model = generated(&dp);
    let fb_i = Interp::new(&fb).expect("rigid");
    let fb_u: four_bar_unrolled::Model = generated(&fb);
    let fb_t: four_bar_tables::Model = generated(&fb);
    let ch_i = Interp::new(&ch).expect("rigid");
    let ch_u: chain32_unrolled::Model = generated(&ch);
    let ch_t: chain32_tables::Model = generated(&ch);
    let (n_small, n_chain) = (2000, 300);
    let dp_ref = &dp;
    let mut c = vec![
        Candidate::system("double_pendulum_3d", "interpreted", &dp_i, h_dp, n_small),
        Candidate::system(
            "double_pendulum_3d",
            "generated, unrolled",
            &dp_u,
            h_dp,
            n_small,
        ),
        Candidate::system(
            "double_pendulum_3d",
            "generated, tables",
            &dp_t,
            h_dp,
            n_small,
        ),
        Candidate {
            scene: "double_pendulum_3d",
            path: "hand-written yardstick",
            steps: n_small,
            run: Box::new(move |n| {
                let mut y = DoublePendulum::new(dp_ref, h_dp);
                let t0 = Instant::now();
                for _ in 0..n {
                    y.step();
                }
                let dt = t0.elapsed().as_secs_f64();
                black_box(y.poses());
                (dt, y.iterations as f64 / n as f64)
            }),
            eval: None,
            best: f64::INFINITY,
            iters: 0.0,
            eval_best: (f64::INFINITY, f64::INFINITY),
        },
        Candidate::system("four_bar", "interpreted", &fb_i, h_fb, n_small),
        Candidate::system("four_bar", "generated, unrolled", &fb_u, h_fb, n_small),
        Candidate::system("four_bar", "generated, tables", &fb_t, h_fb, n_small),
        Candidate::system("chain (32 links)", "interpreted", &ch_i, h_ch, n_chain),
        Candidate::system(
            "chain (32 links)",
            "generated, unrolled",
            &ch_u,
            h_ch,
            n_chain,
        ),
        Candidate::system(
            "chain (32 links)",
            "generated, tables",
            &ch_t,
            h_ch,
            n_chain,
        ),
    ];
    for _ in 0..rounds {
        for x in c.iter_mut() {
            let (dt, it) = (x.run)(x.steps);
            x.best = x.best.min(dt / x.steps as f64);
            x.iters = it;
            if let Some(e) = &x.eval {
                let (a, b) = e(5 * x.steps);
                x.eval_best = (x.eval_best.0.min(a), x.eval_best.1.min(b));
            }
        }
    }
    println!(
        "cost per step, staggered (defaults), best of {rounds} interleaved rounds; \
         model = applied + constraints(ALL) + (iterations + 1) × constraints(PHI) per step\n"
    );
    println!("| scene | path | µs/step | × generated (unrolled) | Newton it./step | model µs/step | rest µs/step |");
    println!("|---|---|---|---|---|---|---|");
    for x in &c {
        let gen = c
            .iter()
            .find(|y| y.scene == x.scene && y.path == "generated, unrolled")
            .map(|y| y.best)
            .unwrap_or(f64::NAN);
        let (model, rest) = match x.eval {
            Some(_) => {
                let m = x.eval_best.0 + (x.iters + 1.0) * x.eval_best.1;
                (
                    format!("{:.2}", m * 1e6),
                    format!("{:.2}", (x.best - m) * 1e6),
                )
            }
            None => ("–".into(), "–".into()),
        };
        println!(
            "| {} | {} | {:.2} | {:.2} | {:.2} | {} | {} |",
            x.scene,
            x.path,
            x.best * 1e6,
            x.best / gen,
            x.iters,
            model,
            rest
        );
    }
}

/// Only the generated double pendulum, for a profiler (`perf record`).
fn profile(n: usize) {
    let dp = load("double_pendulum_3d.mbd", &[]);
    let m: double_pendulum_3d_unrolled::Model = generated(&dp);
    let (dt, _) = run_steps(&m, dp.simulate.step, n);
    println!("{:.3} µs/step", dt / n as f64 * 1e6);
}

// ---------------------------------------------------------------------------------------
// Source size

fn size() {
    let opts = |mode| Options {
        module: None,
        mode: Some(mode),
        scene_json: SceneJson::Include("scene.json".into()),
    };
    println!("generated source (formatted, scene JSON in its own file) vs number of bodies\n");
    println!("| scene | bodies | layout | bytes | lines | scene JSON bytes |");
    println!("|---|---|---|---|---|---|");
    let mut rows: Vec<(String, Scene)> = vec![
        (
            "double_pendulum_3d".into(),
            load("double_pendulum_3d.mbd", &[]),
        ),
        ("four_bar".into(), load("four_bar.mbd", &[])),
    ];
    for n in ["10", "100", "1000"] {
        rows.push((format!("chain N = {n}"), load("chain.mbd", &[("N", n)])));
    }
    for (name, scene) in &rows {
        for (mode, label) in [(Mode::Unrolled, "unrolled"), (Mode::Tables, "tables")] {
            let g = codegen::generate(scene, &opts(mode)).expect("generates");
            let default = if codegen::choose_mode(scene) == mode {
                " (default)"
            } else {
                ""
            };
            println!(
                "| {name} | {} | {label}{default} | {} | {} | {} |",
                scene.bodies.len(),
                g.source.len(),
                g.source.lines().count(),
                g.scene_json.len()
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// Start-up of `mbdc run`

/// Wall time of one `mbdc run`, in seconds; panics if it fails.
fn time_run(mbdc: &Path, file: &Path, extra: &[&str], out: &Path) -> f64 {
    let t0 = Instant::now();
    let o = Command::new(mbdc)
        .arg("run")
        .arg(file)
        .args(extra)
        .arg("-o")
        .arg(out)
        .arg("--quiet")
        .output()
        .expect("runs mbdc");
    let dt = t0.elapsed().as_secs_f64();
    assert!(
        o.status.success(),
        "mbdc run {} {extra:?} failed:\n{}{}",
        file.display(),
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    dt
}

fn startup(mbdc: &Path) {
    assert!(
        mbdc.is_file(),
        "{} not found: build it with `cargo build --release -p mbdc`",
        mbdc.display()
    );
    let tmp = std::env::temp_dir().join(format!("mbdc-bench-startup-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("temp dir");
    let out = tmp.join("out");
    // Make sure the runtime of the shared workspace is built (the "runtime already built"
    // condition): one run of a scene, not timed.
    let primed = time_run(
        mbdc,
        &root().join("models/double_pendulum_3d.mbd"),
        &["--duration", "0.001"],
        &out,
    );
    println!("priming run (builds the shared runtime if needed): {primed:.2} s\n");
    println!(
        "wall time of `mbdc run FILE --duration h -q` (one step, output and plots included)\n"
    );
    println!("| scene | cold: new scene crate | warm: second run | warm, changed param | interpreter (`--interp`) |");
    println!("|---|---|---|---|---|");
    let nonce = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    for (label, model, sets, param, h) in [
        (
            "double_pendulum_3d",
            "double_pendulum_3d",
            vec![],
            "L=1.1m",
            "0.001",
        ),
        (
            "chain, N = 1000",
            "chain",
            vec!["--set", "N=1000"],
            "L=0.11m",
            "0.0001",
        ),
    ] {
        // A scene of a new name: the same structure in a crate that was never built.
        let text = std::fs::read_to_string(root().join(format!("models/{model}.mbd")))
            .expect("model file");
        let renamed = text.replacen(
            &format!("model {model} {{"),
            &format!("model {model}_cold{nonce} {{"),
            1,
        );
        assert_ne!(text, renamed, "the model header");
        let file = tmp.join(format!("{model}.mbd"));
        std::fs::write(&file, renamed).expect("write model");
        let mut args = sets.clone();
        args.extend(["--duration", h]);
        let cold = time_run(mbdc, &file, &args, &out);
        let warm = time_run(mbdc, &file, &args, &out);
        let mut changed = args.clone();
        changed.extend(["--set", param]);
        let warm_param = time_run(mbdc, &file, &changed, &out);
        let mut interp = args.clone();
        interp.push("--interp");
        let interp = time_run(mbdc, &file, &interp, &out);
        println!("| {label} | {cold:.2} s | {warm:.2} s | {warm_param:.2} s | {interp:.2} s |");
    }
    let _ = std::fs::remove_dir_all(&tmp);
}

// ---------------------------------------------------------------------------------------
// Beams

/// A 1000-element beam clamped at one end (the cantilever's steel section, rotary inertia
/// ×16), and 1000 free rigid bodies, in the language.
fn beam_scenes() -> (Scene, Scene) {
    let beam = load_bench_model("beam1000.mbd");
    let free = r#"
model free1000 {
  gravity (0, 0, -9.81) m/s^2
  for i in 0..1000 {
    body b[i] { mass 1 kg; inertia diag(1, 2, 3) kg*m^2; position (i * 1 m, 0, 0); angular_velocity (0.1, 0.2, 0.3) rad/s }
  }
  simulate { duration 1 s; step 1 ms }
}
"#;
    let load = |text: &str| {
        let l = mbdc_compiler::load_str("bench.mbd", text, &[]);
        let msg = l.render_plain();
        l.scene.unwrap_or_else(|| panic!("{msg}"))
    };
    (beam, load(free))
}

/// Seconds per element of one evaluation of every element of the beam of `bi` from `start`
/// to `pose` with velocities `twist` and damping: (the damped variant
/// `element_forces::<true>`, the element kernel followed by a damping evaluation that
/// recomputes the frame, as the interpreter did before the variants). Best of 20 passes.
fn damped_element(
    bi: &Interp,
    start: &State,
    pose: &[mbdc_runtime::system::Pose],
    twist: &[mbdc_runtime::system::Twist],
) -> (f64, f64) {
    use mbdc_runtime::beam_element::{
        convected_frame, element_forces, internal_force, nodal_wrenches, section_rotations,
        strain_rate, BeamNode, BeamSection, ElementForce, ElementState,
    };
    let bl = &bi.layout().beams;
    let sec = BeamSection::from_scene(&bl.beams[0].section).expect("section");
    let beta = 1e-6;
    let node = |p: &[mbdc_runtime::system::Pose], b: usize| BeamNode {
        pose: p[b],
        twist: twist[b],
    };
    let fresh: Vec<ElementState> = bl
        .elements
        .iter()
        .map(|e| ElementState::new(&[node(&start.pose, e.nodes[0]), node(&start.pose, e.nodes[1])]))
        .collect::<Result<_, _>>()
        .expect("elements");
    let n = bl.elements.len() as f64;
    let mut w = [Wrench::default(); 2];
    let (mut a, mut b) = (f64::INFINITY, f64::INFINITY);
    for pass in 0..20 {
        let p = if pass % 2 == 0 { pose } else { &start.pose[..] };
        let mut st = fresh.clone();
        let t0 = Instant::now();
        for (e, s) in bl.elements.iter().zip(st.iter_mut()) {
            let nodes = [node(p, e.nodes[0]), node(p, e.nodes[1])];
            black_box(element_forces::<true>(&sec, beta, s, &nodes, &mut w).expect("element"));
            black_box(&w);
        }
        a = a.min(t0.elapsed().as_secs_f64() / n);
        let mut st = fresh.clone();
        let t0 = Instant::now();
        for (e, s) in bl.elements.iter().zip(st.iter_mut()) {
            let nodes = [node(p, e.nodes[0]), node(p, e.nodes[1])];
            let mut out = ElementForce::default();
            internal_force(&sec, s, &nodes, &mut out).expect("element");
            let (gd, kd) = strain_rate(&nodes).expect("rate");
            let (t, l) = convected_frame(&nodes[0].pose.r, &nodes[1].pose.r, &nodes[0].pose.c)
                .expect("frame");
            let sr = section_rotations(&nodes, &t);
            let d = nodal_wrenches(
                &t,
                l,
                &sr,
                &(sec.c_gamma().component_mul(&gd) * beta),
                &(sec.c_kappa().component_mul(&kd) * beta),
            );
            for i in 0..2 {
                w[i].f = out.wrench[i].f + d[i].f;
                w[i].t = out.wrench[i].t + d[i].t;
            }
            black_box(&w);
        }
        b = b.min(t0.elapsed().as_secs_f64() / n);
    }
    (a, b)
}

/// A model of `benches/models/`.
fn load_bench_model(file: &str) -> Scene {
    let loaded = mbdc_compiler::load_file(
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("models")
            .join(file),
        &[],
    );
    match loaded.scene {
        Some(s) => s,
        None => panic!("{file}: {}", loaded.render_plain()),
    }
}

/// Seconds per call of `f(n)` (best of `rounds`).
fn best(rounds: usize, n: usize, mut f: impl FnMut(usize) -> f64) -> f64 {
    (0..rounds)
        .map(|_| f(n) / n as f64)
        .fold(f64::INFINITY, f64::min)
}

/// The core's floating-point rate on multiply–add code like the kernel's: 16 independent
/// multiply–add chains (2 flops each; enough to hide the latency), 64 updates between
/// barriers. Built for the default target (SSE2, no FMA), so the compiler may pair chains in
/// 2-wide registers: an upper bound on what scalar code reaches. Flops per second.
fn scalar_peak(n: usize) -> f64 {
    let mut a = black_box([
        1.0f64, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 2.0, 2.1, 2.2, 2.3, 2.4, 2.5,
    ]);
    let (x, y) = (black_box(0.999_999_9), black_box(1e-9));
    let t0 = Instant::now();
    for _ in 0..n / 64 {
        for _ in 0..64 {
            for v in a.iter_mut() {
                *v = *v * x + y;
            }
        }
        a = black_box(a);
    }
    let dt = t0.elapsed().as_secs_f64();
    black_box(a);
    32.0 * (n / 64 * 64) as f64 / dt
}

fn beams(rounds: usize) {
    use mbdc_runtime::beam_element::ElementState;
    use mbdc_runtime::integrators::beam_forces::BeamForces;
    let (beam, free) = beam_scenes();
    let bi = Interp::new(&beam).expect("beam");
    let fi = Interp::new(&free).expect("free bodies");
    let (hb, hf) = (beam.simulate.step, free.simulate.step);
    let elements = bi.layout().beams.elements.len();
    let start = State::initial(&bi);
    let mut forces = BeamForces::new(bi.layout(), &start)
        .expect("elements")
        .expect("a beam");
    // a bent configuration, so that the kernel does real increments
    let mut pose = start.pose.clone();
    for (k, p) in pose.iter_mut().enumerate() {
        p.r.z += 1e-4 * (k as f64 * 0.01).sin();
    }
    let mut twist = start.twist.clone();
    for (k, w) in twist.iter_mut().enumerate() {
        w.v.z = 1e-3 * (k as f64 * 0.02).cos();
        w.w.y = 1e-3 * (k as f64 * 0.03).sin();
    }
    let bg: mbdc_bench::generated::beam1000::Model = generated(&beam);
    let mut kernel = 0.0;
    let mut beam_step = 0.0;
    let mut beam_step_generated = 0.0;
    let mut body_step = 0.0;
    let mut peak = 0.0f64;
    let (mut fused, mut separate) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..rounds {
        let (f, s) = damped_element(&bi, &start, &pose, &twist);
        fused = fused.min(f);
        separate = separate.min(s);
        beam_step_generated = run_steps(&bg, hb, 100).0 / 100.0 / (elements + 1) as f64;
        kernel = best(1, 200, |n| {
            let t0 = Instant::now();
            for k in 0..n {
                let p = if k % 2 == 0 { &pose } else { &start.pose };
                forces.update(black_box(p), &twist).expect("kernel");
            }
            t0.elapsed().as_secs_f64()
        }) / elements as f64;
        beam_step = run_steps(&bi, hb, 100).0 / 100.0 / (elements + 1) as f64;
        body_step = run_steps(&fi, hf, 100).0 / 100.0 / 1000.0;
        peak = peak.max(scalar_peak(20_000_000));
    }
    // floating-point operations of one undamped element evaluation (`element_forces::<false>`,
    // what a step runs), counted from the source (additions and multiplications; a square
    // root or division counts as one): frame 33, section rotations 2×45, deformation
    // increments 2×45 + Cayley 2×12, half rotation 21 + 36, T½ 45, chord increment 51, shear
    // and curvature 15, resultant update 24, nodal forces 15 + 9 + 2×(15 + 6). (Until stop 24
    // the step also computed the total curvature, 52 more, which only output reads.)
    let flops = 33 + 90 + 90 + 24 + 57 + 45 + 51 + 15 + 24 + 66;
    println!("# Beams: cost per element-step (best of {rounds} rounds)\n");
    println!("| quantity | value |\n|---|---|");
    println!(
        "| element kernel (`element_forces::<false>` + bookkeeping), per element | {:.1} ns |",
        kernel * 1e9
    );
    println!(
        "| full staggered step of the 1000-element beam, per node | {:.1} ns |",
        beam_step * 1e9
    );
    println!(
        "| staggered step of 1000 free rigid bodies, per body | {:.1} ns |",
        body_step * 1e9
    );
    println!(
        "| the same step, generated code (`BeamKernel::elastic()`), per node | {:.1} ns (generated / interpreted {:.3}) |",
        beam_step_generated * 1e9,
        beam_step_generated / beam_step
    );
    println!(
        "| beam node step / rigid body step | {:.2} |",
        beam_step / body_step
    );
    println!(
        "| damped element: the damped variant (frame once) / the elastic kernel + a damping evaluation that recomputes the frame | {:.1} ns / {:.1} ns = {:.3} |",
        fused * 1e9,
        separate * 1e9,
        fused / separate
    );
    println!("| flops per element evaluation (counted) | {flops} |");
    println!(
        "| multiply–add rate of this core (16 independent chains, SSE2) | {:.2} Gflop/s |",
        peak / 1e9
    );
    println!(
        "| element kernel rate, fraction of that rate | {:.2} Gflop/s, {:.0} % |",
        flops as f64 / kernel / 1e9,
        100.0 * flops as f64 / kernel / peak
    );
    // 8 beams of 1000 elements: the element loop on one thread and on two
    let eight = {
        let mut sc = beam.clone();
        let b0 = sc.beams[0].clone();
        sc.beams = (0..8)
            .map(|k| {
                let mut b = b0.clone();
                b.name = format!("blade{k}");
                for n in b.nodes.iter_mut() {
                    n[1] = k as f64;
                }
                for a in b.attachments.iter_mut() {
                    a.to.point[1] = k as f64;
                }
                b
            })
            .collect();
        sc
    };
    let ei = Interp::new(&eight).expect("eight beams");
    let (mut one_thread, mut two_threads) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..rounds {
        for threads in [1, 2] {
            let t = mbdc_runtime::integrators::natural::with_threads(threads, || {
                run_steps(&ei, hb, 50).0 / 50.0
            });
            if threads == 1 {
                one_thread = one_thread.min(t);
            } else {
                two_threads = two_threads.min(t);
            }
        }
    }
    println!(
        "| 8 beams × 1000 elements, staggered step: 1 thread / 2 threads | {:.2} ms / {:.2} ms, speed-up {:.2} |",
        one_thread * 1e3,
        two_threads * 1e3,
        one_thread / two_threads
    );
    println!(
        "| memory per element (element state + node pose, twist, mass; + per-step buffers) | {} B state + {} B node |",
        std::mem::size_of::<ElementState>(),
        std::mem::size_of::<mbdc_runtime::system::Pose>()
            + std::mem::size_of::<mbdc_runtime::system::Twist>()
            + std::mem::size_of::<mbdc_runtime::system::MassProps>()
    );
}
