//! `mbdc-bench output [ROUNDS] [SCALE]`: what writing the results costs (BENCHMARKS.md,
//! "Output: what writing costs"; issue 16, "Results at scale").
//!
//! Whole runs through the real run loop and the real output writer, the way `mbdc run
//! --interp` makes them (`app::run_config`, `app::output_spec`, `RunMeta::new`,
//! `output::write_scene`, `run_loop::run_to_dir`; see `cli/src/commands/run.rs`), with the
//! output off and with a frame every K steps in each format, on two scenes:
//!
//! - a steel box of hex8 one-point elements (`integration reduced`, viscous hourglass),
//!   100 × 100 × 100 = 10⁶ elements of 1 cm (`SCALE` scales the element count: 0.1 gives
//!   46³ ≈ 10⁵), explicit central difference, formats `exodus` and `vtk`;
//! - the spatial chain of `models/bench/chain_spatial.mbd` with N = 10⁴ × `SCALE` links and
//!   its own method, natural partitioning, formats `csv` and `exodus`.
//!
//! "Output off" is the least the runtime writes: `scene.json` and `summary.json`, with the
//! bodies', energy and constraint files switched off in the [`OutputSpec`], format `csv`
//! (no per-frame mesh files) and an interval longer than the run, so that the run loop
//! hands out its two frames (the initial state and the last step: it always does) and the
//! writer writes nothing of them but the meshes' two rows of `mesh_energy.csv`, which every
//! run with a mesh writes. The other runs write what `mbdc run --every K --format F`
//! writes: the scene's output settings (every CSV file) in format F.
//!
//! The box is loaded so that every number written is a full-precision one, as in a run
//! well under way (a box that starts at rest writes mostly `0.0` for hundreds of steps,
//! which makes text formats look cheap): the scene's weight as a body force, and a point
//! load on a scattered half of the nodes, so that every element strains from the first
//! step.
//!
//! In the same process: the disk's write bandwidth in the output folder (1 GiB written with
//! one fsync, [`crate::checkpoints::disk_bandwidth`]) once per round, and per run:
//! - the wall time of the whole run, and its ratio to the same round's run with output off;
//! - the bytes written, and the implied rate (bytes / run time) against the disk's;
//! - the machine's other load: the CPU time every other process of the machine took during
//!   the run (`/proc/stat`, steal included, less this process's), in cores;
//! - where the CPU time went: the threads that outlive the run (the simulation thread and
//!   the rayon pool of the step) and the rest (the writer thread and the threads of its
//!   Exodus partitions, which end with the run; `/proc/self/task`), so the writer's CPU
//!   time per frame and its rate (bytes per CPU second), and the step's threads' extra CPU
//!   time per frame over output off;
//! - on the simulation thread, each step's cycle (step, watchdog, the frame's hand-over when
//!   there is one: its copies, and a wait for a buffer when the writer is behind) from the
//!   observer's calls: the median cycle with a frame less the median without one, in the
//!   same run, is what a frame costs the simulation thread directly, free of the machine's
//!   other load, which changes over minutes;
//! - the drain, from the last frame handed to the writer to the end of the run (the writer
//!   finishing what was queued: a long drain means that the simulation ran ahead of the
//!   writer, and waited for a buffer once the pool was empty).
//!
//! After an untimed run of each scene, the rounds are interleaved (every variant once per
//! round, in turn, each round starting at another variant); the tables give the medians of
//! the rounds, and each round's ratio. Each run writes into a temporary folder under
//! `std::env::temp_dir()` that is deleted after it (then `sync`, so that no run starts with
//! another's dirty pages); a variant whose estimated output ([`output::estimate`]) is above
//! [`MAX_BYTES`] is skipped and says so.

use std::path::{Path, PathBuf};
use std::time::Instant;

use mbdc_compiler::Scene;
use mbdc_runtime::app::{self, Settings};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::output::{self, RunMeta};
use mbdc_runtime::run_loop::{self, Frame, Observer};
use mbdc_runtime::scene::{OutputFormat, OutputSpec};
use mbdc_runtime::system::System;

use crate::checkpoints::disk_bandwidth;
use crate::meshes::{cpu_seconds, load_average};

/// Runs whose estimated output is larger than this are skipped (bytes): the disk had 21–33
/// GB free, and a 10⁶-element ASCII `.vtu` frame is about 0.46 GB.
pub const MAX_BYTES: u64 = 9_000_000_000;

/// Steps of every run of the box, and its output intervals.
const MESH_STEPS: u64 = 32;
const MESH_EVERY: [u32; 3] = [1, 4, 16];
/// Steps of every run of the chain, and its output intervals.
const CHAIN_STEPS: u64 = 600;
const CHAIN_EVERY: [u32; 3] = [1, 3, 10];
/// Clock ticks per second of `/proc` (`USER_HZ`).
const TICKS: f64 = 100.0;

/// The box of `n`³ hex8 one-point elements (1 cm, steel, bottom face fixed), under its
/// weight and a point load on a scattered half of its nodes.
fn box_scene(n: usize) -> Scene {
    let text = format!(
        "model output_box {{
  material steel {{ E 210 GPa; nu 0.3; rho 7850 kg/m^3 }}
  mesh m {{
    element hex8
    integration reduced
    generate box(origin: (0, 0, 0) m, size: ({n}, {n}, {n}) cm, divisions: ({n}, {n}, {n}))
    material steel
    set bottom = nodes(z == 0)
    set scattered = nodes(sin(37 * x / 1 cm + 11 * y / 1 cm + 5 * z / 1 cm) > 0)
    fix bottom
    load scattered, (1 N, -2 N, 3 N)
    body_force (0, 0, -9.81 m/s^2 * 7850 kg/m^3)
  }}
  simulate {{ duration 1 ms; step 0.1 us }}
}}
"
    );
    let l = mbdc_compiler::load_str("output_box.mbd", &text, &[]);
    let msg = l.render_plain();
    l.scene.unwrap_or_else(|| panic!("{msg}"))
}

/// `models/bench/chain_spatial.mbd` with `n` links. Above 1000 links it turns at 1000/N
/// rad/s instead of 1 rad/s (as in the natural-partitioning scaling benchmark): at 1 rad/s
/// the tension of a 1 km chain puts the links near the root past the explicit limit.
fn chain_scene(n: usize) -> Scene {
    let loaded = mbdc_compiler::load_file(
        super::root().join("models/bench/chain_spatial.mbd"),
        &[mbdc_compiler::Override::new("N", n.to_string())],
    );
    let msg = loaded.render_plain();
    let mut scene = loaded.scene.unwrap_or_else(|| panic!("{msg}"));
    if n > 1000 {
        let f = 1000.0 / n as f64;
        for b in &mut scene.bodies {
            b.velocity = b.velocity.map(|x| x * f);
            b.angular_velocity = b.angular_velocity.map(|x| x * f);
        }
    }
    scene
}

/// What one run writes: a format and an interval, or nothing ([`Variant::OFF`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Variant {
    /// `None`: output off (see the module doc).
    format: Option<OutputFormat>,
    /// A frame every this many steps.
    every: u32,
}

impl Variant {
    const OFF: Variant = Variant {
        format: None,
        every: 0,
    };

    fn label(self) -> String {
        match self.format {
            None => "off".into(),
            Some(f) => format!("{} every {}", f.name(), self.every),
        }
    }
}

/// One run's figures.
#[derive(Clone, Copy, Debug)]
struct Sample {
    /// Wall time of the whole run (`write_scene` and `run_to_dir`, writer drained), s.
    wall: f64,
    /// CPU time of the process over the run (every thread), s.
    cpu: f64,
    /// CPU time of the threads that outlive the run (the simulation thread, the rayon
    /// pool), s; the rest of `cpu` is the writer's and its partitions'.
    step_cpu: f64,
    /// CPU time the machine's other processes took during the run, in cores.
    others: f64,
    /// From the first frame handed out to the last, s.
    stepping: f64,
    /// Median step cycle on the simulation thread with a frame, and without, s (NaN when
    /// there was none).
    frame_cycle: f64,
    plain_cycle: f64,
    /// From the last frame handed out to the run's end (the writer finishing), s.
    drain: f64,
    /// Bytes in the output folder after the run.
    bytes: u64,
    /// Frames the writer received.
    frames: u64,
}

impl Sample {
    fn writer_cpu(&self) -> f64 {
        self.cpu - self.step_cpu
    }
}

/// A variant and its rounds.
struct Measured {
    variant: Variant,
    /// Estimated bytes (`output::estimate`), and whether that skipped the variant.
    estimate: u64,
    skipped: bool,
    samples: Vec<Sample>,
}

/// The median of some numbers (NaN for none; NaNs are left out).
fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| !x.is_nan());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

impl Measured {
    fn median(&self, f: impl Fn(&Sample) -> f64) -> f64 {
        median(self.samples.iter().map(f).collect())
    }
}

/// A scene ready to run, with its variants.
struct Case {
    label: String,
    scene: Scene,
    sys: Interp,
    steps: u64,
    variants: Vec<Measured>,
}

/// Timestamps of the frames the run loop hands out (after the writer has taken them), and
/// the simulation thread's step cycles (from one `stop_requested`, asked after every step
/// but the last, to the next), with and without a frame.
#[derive(Default)]
struct Clock {
    first: Option<Instant>,
    last: Option<Instant>,
    prev: Option<Instant>,
    framed: bool,
    frame_cycles: Vec<f64>,
    plain_cycles: Vec<f64>,
}

impl Observer for Clock {
    fn frame(&mut self, _f: &Frame<'_>) {
        let now = Instant::now();
        self.first.get_or_insert(now);
        self.last = Some(now);
        if self.prev.is_none() {
            // the initial frame: the first cycle starts here
            self.prev = Some(now);
        } else {
            self.framed = true;
        }
    }

    fn stop_requested(&mut self) -> Option<&'static str> {
        let now = Instant::now();
        if let Some(p) = self.prev {
            let dt = (now - p).as_secs_f64();
            if self.framed {
                self.frame_cycles.push(dt);
            } else {
                self.plain_cycles.push(dt);
            }
        }
        self.prev = Some(now);
        self.framed = false;
        None
    }
}

/// CPU ticks of each thread of this process (`/proc/self/task/*/stat`, user + system).
fn thread_ticks() -> Vec<(u32, u64)> {
    let Ok(rd) = std::fs::read_dir("/proc/self/task") else {
        return Vec::new();
    };
    rd.flatten()
        .filter_map(|e| {
            let tid: u32 = e.file_name().to_str()?.parse().ok()?;
            let s = std::fs::read_to_string(e.path().join("stat")).ok()?;
            let f: Vec<&str> = s.rsplit_once(')')?.1.split_whitespace().collect();
            // fields 14 and 15 of the line; the split starts at field 3
            Some((
                tid,
                f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?,
            ))
        })
        .collect()
}

/// Busy ticks of the whole machine (`/proc/stat`: user, nice, system, irq, softirq, steal).
fn machine_ticks() -> u64 {
    std::fs::read_to_string("/proc/stat")
        .ok()
        .and_then(|s| {
            let f: Vec<u64> = s
                .lines()
                .next()?
                .split_whitespace()
                .skip(1)
                .filter_map(|x| x.parse().ok())
                .collect();
            Some([0, 1, 2, 5, 6, 7].iter().filter_map(|&i| f.get(i)).sum())
        })
        .unwrap_or(0)
}

/// Bytes of every file under `dir`.
fn folder_bytes(dir: &Path) -> u64 {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return 0;
    };
    rd.flatten()
        .map(|e| match e.metadata() {
            Ok(m) if m.is_dir() => folder_bytes(&e.path()),
            Ok(m) => m.len(),
            Err(_) => 0,
        })
        .sum()
}

/// The run settings and output of `v` on `case`, as `mbdc run --every K --format F` gives
/// them (output off: see the module doc).
fn settings(case: &Case, v: Variant) -> (Settings, OutputSpec) {
    let h = case.scene.simulate.step;
    let off = v.format.is_none();
    let s = Settings {
        duration: Some(case.steps as f64 * h),
        every: Some(if off {
            (case.steps + 1) as u32
        } else {
            v.every
        }),
        format: Some(v.format.unwrap_or(OutputFormat::Csv)),
        ..Settings::default()
    };
    let mut spec = app::output_spec(&case.scene, &s);
    if off {
        spec.bodies = false;
        spec.energy = false;
        spec.constraints = false;
    }
    (s, spec)
}

/// One whole run of `v` on `case` in `dir` (created, then deleted).
fn run_once(case: &Case, v: Variant, dir: &Path) -> Sample {
    let (s, spec) = settings(case, v);
    let cfg = app::run_config(&case.sys, &case.scene, &s).expect("the run's settings");
    let meta = RunMeta::new(&case.scene, &cfg);
    let mut clock = Clock {
        frame_cycles: Vec::with_capacity(case.steps as usize),
        plain_cycles: Vec::with_capacity(case.steps as usize),
        ..Clock::default()
    };
    let threads0 = thread_ticks();
    let machine0 = machine_ticks();
    let cpu0 = cpu_seconds();
    let t0 = Instant::now();
    output::write_scene(dir, &case.scene).expect("writes scene.json");
    let (report, summary) = run_loop::run_to_dir(&case.sys, &cfg, meta, &spec, dir, &mut clock)
        .expect("writes the output folder");
    let end = Instant::now();
    let cpu = cpu_seconds() - cpu0;
    let machine = (machine_ticks() - machine0) as f64 / TICKS;
    let threads1 = thread_ticks();
    assert!(
        report.finished && report.steps == case.steps,
        "{} {}: {} steps of {}, {:?}",
        case.label,
        v.label(),
        report.steps,
        case.steps,
        report.failure
    );
    let step_ticks: u64 = threads1
        .iter()
        .filter_map(|(tid, t1)| {
            let t0 = threads0.iter().find(|(t, _)| t == tid)?.1;
            Some(t1 - t0)
        })
        .sum();
    let wall = (end - t0).as_secs_f64();
    let (first, last) = (clock.first.unwrap_or(t0), clock.last.unwrap_or(end));
    let sample = Sample {
        wall,
        cpu,
        step_cpu: step_ticks as f64 / TICKS,
        others: ((machine - cpu) / wall).max(0.0),
        stepping: (last - first).as_secs_f64(),
        frame_cycle: median(clock.frame_cycles),
        plain_cycle: median(clock.plain_cycles),
        drain: (end - last).as_secs_f64(),
        bytes: folder_bytes(dir),
        frames: summary.frames,
    };
    std::fs::remove_dir_all(dir).expect("deletes the run's folder");
    // no run starts with another's dirty pages still being written back
    let _ = std::process::Command::new("sync").status();
    sample
}

fn variants(formats: &[OutputFormat], every: &[u32]) -> Vec<Variant> {
    let mut v = vec![Variant::OFF];
    for &format in formats {
        for &k in every {
            v.push(Variant {
                format: Some(format),
                every: k,
            });
        }
    }
    v
}

fn case(label: String, scene: Scene, steps: u64, vs: Vec<Variant>) -> Case {
    let sys = Interp::new(&scene).expect("interpretable");
    let mut c = Case {
        label,
        scene,
        sys,
        steps,
        variants: Vec::new(),
    };
    c.variants = vs
        .into_iter()
        .map(|v| {
            let (s, spec) = settings(&c, v);
            let every = s.every.unwrap_or(1);
            let estimate = output::estimate(c.sys.layout(), &spec, steps, every).bytes();
            Measured {
                variant: v,
                estimate,
                skipped: v.format.is_some() && estimate > MAX_BYTES,
                samples: Vec::new(),
            }
        })
        .collect();
    c
}

fn mb(bytes: f64) -> String {
    if bytes >= 1e9 {
        format!("{:.2} GB", bytes / 1e9)
    } else {
        format!("{:.1} MB", bytes / 1e6)
    }
}

/// Milliseconds, or a dash for NaN.
fn ms(s: f64) -> String {
    if s.is_nan() {
        "—".into()
    } else {
        format!("{:.1} ms", s * 1e3)
    }
}

/// Prints the tables of one scene.
fn table(c: &Case, disk: f64) {
    let Some(off) = c.variants.iter().find(|m| m.variant.format.is_none()) else {
        return;
    };
    let rounds = off.samples.len();
    // each round's run against the same round's run with output off
    let ratios = |m: &Measured| -> Vec<f64> {
        m.samples
            .iter()
            .zip(&off.samples)
            .map(|(s, o)| s.wall / o.wall)
            .collect()
    };
    let extra_frames = |m: &Measured| {
        m.samples
            .first()
            .map_or(0, |s| s.frames.saturating_sub(off.samples[0].frames))
    };
    // per round, against the same round's output off
    // (`least` frames: fewer make a few frames' share of the step's own spread, ±10 %
    // between runs on a shared machine)
    let per_frame = |m: &Measured, least: u64, f: &dyn Fn(&Sample) -> f64| -> f64 {
        let n = extra_frames(m);
        if n < least.max(1) {
            return f64::NAN;
        }
        median(
            m.samples
                .iter()
                .zip(&off.samples)
                .map(|(s, o)| (f(s) - f(o)) / n as f64)
                .collect(),
        )
    };
    let step_wall = off.median(|s| s.stepping) / c.steps as f64;
    let step_cpu = off.median(|s| s.cpu) / c.steps as f64;
    println!(
        "### {} — {} steps\n\nOutput off: {:.2} s per run (rounds: {}), {:.1} ms and {:.1} CPU ms per step (medians); the machine's other load {} cores.\n",
        c.label,
        c.steps,
        off.median(|s| s.wall),
        off.samples
            .iter()
            .map(|s| format!("{:.2} s", s.wall))
            .collect::<Vec<_>>()
            .join(", "),
        step_wall * 1e3,
        step_cpu * 1e3,
        off.samples
            .iter()
            .map(|s| format!("{:.2}", s.others))
            .collect::<Vec<_>>()
            .join(", "),
    );
    println!("| output | frames | written (per frame) | run time | × off, median (each round) | write rate (of disk) | machine's other load, cores |");
    println!("|---|---|---|---|---|---|---|");
    for m in &c.variants {
        if m.variant.format.is_none() {
            continue;
        }
        if m.skipped {
            println!(
                "| {} | — | est. {} | skipped: above the {} cap | — | — | — |",
                m.variant.label(),
                mb(m.estimate as f64),
                mb(MAX_BYTES as f64)
            );
            continue;
        }
        let Some(s0) = m.samples.first() else {
            continue;
        };
        let r = ratios(m);
        let wall = m.median(|s| s.wall);
        let rate = s0.bytes as f64 / wall;
        println!(
            "| {} | {} | {} ({}) | {:.2} s | **{:.2}** ({}) | {:.0} MB/s ({:.2}) | {} |",
            m.variant.label(),
            s0.frames,
            mb(s0.bytes as f64),
            mb(s0.bytes as f64 / s0.frames.max(1) as f64),
            wall,
            median(r.clone()),
            r.iter()
                .map(|x| format!("{x:.2}"))
                .collect::<Vec<_>>()
                .join(", "),
            rate / 1e6,
            rate / 1e6 / disk,
            m.samples
                .iter()
                .map(|s| format!("{:.2}", s.others))
                .collect::<Vec<_>>()
                .join(", "),
        );
    }
    println!(
        "\nWhere the time goes (medians of {rounds} rounds; per frame: per frame beyond the two of output off):\n"
    );
    println!("| output | writer's CPU per frame (its rate) | step threads' extra CPU per frame | simulation thread: cycle with a frame − without | drain |");
    println!("|---|---|---|---|---|");
    for m in &c.variants {
        let Some(s0) = m.samples.first() else {
            continue;
        };
        let writer = m.median(|s| s.writer_cpu() / s.frames.max(1) as f64);
        let per = s0.bytes as f64 / s0.frames.max(1) as f64;
        let writer = if m.variant.format.is_some() {
            format!("{:.3} s ({:.0} MB/s)", writer, per / writer / 1e6)
        } else {
            format!("{writer:.3} s")
        };
        let step_extra = per_frame(m, 20, &|s| s.step_cpu);
        let direct = m.median(|s| s.frame_cycle - s.plain_cycle);
        println!(
            "| {} | {} | {} | {} | {:.2} s |",
            m.variant.label(),
            writer,
            if step_extra.is_nan() {
                "—".into()
            } else {
                format!("{step_extra:.3} s")
            },
            ms(direct),
            m.median(|s| s.drain),
        );
    }
    println!();
    for format in [OutputFormat::Exodus, OutputFormat::Vtk, OutputFormat::Csv] {
        let runs: Vec<&Measured> = c
            .variants
            .iter()
            .filter(|m| m.variant.format == Some(format) && !m.samples.is_empty())
            .collect();
        let Some(most) = runs.first() else {
            continue;
        };
        let measured = match runs.iter().find(|m| median(ratios(m)) <= 1.1) {
            Some(m) => format!("median within 1.1× from K = {}", m.variant.every),
            None => "median above 1.1× at every K measured".into(),
        };
        // the machine's cost of a frame: the writer's CPU and the step threads' extra, from
        // the variant with the most frames
        let cost = per_frame(most, 1, &|s| s.cpu);
        println!(
            "- {}: {measured}; a frame costs the process {:.1} CPU ms (K = {} runs) against {:.1} CPU ms per step: 10 % of the step's CPU from K ≈ {:.1}",
            format.name(),
            cost * 1e3,
            most.variant.every,
            step_cpu * 1e3,
            cost / (0.1 * step_cpu)
        );
    }
    println!();
}

/// The `output` subcommand: `rounds` interleaved rounds; `scale` scales the box's element
/// count and the chain's links (1: 10⁶ elements, 10⁴ links).
pub fn output(rounds: usize, scale: f64) {
    let rounds = rounds.max(1);
    let load_start = load_average();
    let t_start = Instant::now();
    let base: PathBuf =
        std::env::temp_dir().join(format!("mbdc-bench-output-{}", std::process::id()));
    std::fs::create_dir_all(&base).expect("temp folder");
    let n = (1e6 * scale).cbrt().round().max(2.0) as usize;
    let links = ((1e4 * scale).round() as usize).max(2);
    eprintln!("building the box ({n}³ elements) and the chain ({links} links)…");
    let mut cases = vec![
        case(
            format!(
                "hex8 one-point box {n}³ ({} elements), central difference",
                n * n * n
            ),
            box_scene(n),
            MESH_STEPS,
            variants(&[OutputFormat::Exodus, OutputFormat::Vtk], &MESH_EVERY),
        ),
        case(
            format!("chain_spatial N = {links}, natural_partitioning"),
            chain_scene(links),
            CHAIN_STEPS,
            variants(&[OutputFormat::Csv, OutputFormat::Exodus], &CHAIN_EVERY),
        ),
    ];
    // a first run of each scene, not timed (the allocator's and the caches' first touch)
    for c in &cases {
        let s = run_once(c, Variant::OFF, &base.join("run"));
        eprintln!("  {} warm-up, output off: {:.2} s", c.label, s.wall);
    }
    let mut disk = Vec::new();
    for round in 0..rounds {
        let bw = disk_bandwidth(&base, 1024);
        eprintln!(
            "round {}/{rounds}: disk {bw:.0} MB/s (1 GiB, one fsync); load {}",
            round + 1,
            load_average()
        );
        disk.push(bw);
        for c in cases.iter_mut() {
            // each round starts at another variant, so that none is always first
            let len = c.variants.len();
            for i in (0..len).map(|j| (j + round) % len) {
                let v = c.variants[i].variant;
                if c.variants[i].skipped {
                    if round == 0 {
                        eprintln!(
                            "  {} {}: skipped, estimated {} > {}",
                            c.label,
                            v.label(),
                            mb(c.variants[i].estimate as f64),
                            mb(MAX_BYTES as f64)
                        );
                    }
                    continue;
                }
                let s = run_once(c, v, &base.join("run"));
                eprintln!(
                    "  {} {}: {:.2} s (drain {:.2} s), CPU {:.1} s (writer {:.1} s), others {:.2} cores, cycle {} / {}, {} frames, {} (est. {})",
                    c.label,
                    v.label(),
                    s.wall,
                    s.drain,
                    s.cpu,
                    s.writer_cpu(),
                    s.others,
                    ms(s.frame_cycle),
                    ms(s.plain_cycle),
                    s.frames,
                    mb(s.bytes as f64),
                    mb(c.variants[i].estimate as f64)
                );
                c.variants[i].samples.push(s);
            }
        }
    }
    let _ = std::fs::remove_dir_all(&base);
    let best_disk = disk.iter().copied().fold(0.0, f64::max);
    let worst_disk = disk.iter().copied().fold(f64::INFINITY, f64::min);
    println!(
        "# Output: what writing costs
"
    );
    println!(
        "scale {scale}, {rounds} interleaved rounds, {:.0} s in all; load average {load_start} at the start, {} at the end; {} threads
",
        t_start.elapsed().as_secs_f64(),
        load_average(),
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    println!(
        "disk write bandwidth in {} (1 GiB, one fsync): {best_disk:.0} MB/s best, {worst_disk:.0} MB/s worst of the rounds; the fractions below are of the best
",
        std::env::temp_dir().display()
    );
    for c in &cases {
        table(c, best_disk);
    }
}
