//! `meshes`: element rates of the finite-element meshes against this machine's limits
//! (BENCHMARKS.md, section "Meshes: element rates against the machine's limits").
//!
//! In one run: the STREAM triad bandwidth with 1 and 2 threads, the core's flop rate (a
//! dependent multiply–add chain, 32 independent chains the compiler vectorizes, and, for
//! context, the AVX2 + FMA peak this build does not use), then for hex8 one-point (viscous
//! hourglass), hex8 2×2×2, tet4 and quad4 meshes of 10³ … 10⁵ (10⁶ with `SCALE ≥ 1`)
//! elements the whole step's cost on one thread, as element updates per second and as
//! fractions of the bandwidth and flop bounds, two threads against one at the largest size,
//! and the memory per element; then the assembly strategies side by side (element rates
//! with 1 and 2 threads on the same meshes, [`assembly_strategies`]; also alone as
//! `meshes-assembly [SCALE] [ROUNDS]`).
//!
//! Every mesh runs through `MeshDynamics`, the runtime's mesh step; hex8 one-point through
//! the language's `integration reduced; hourglass viscous(0.1)`.

use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

use mbdc_compiler::Scene;
use mbdc_runtime::integrators::mesh_dynamics::MeshDynamics;
use mbdc_runtime::integrators::MeshState;
use mbdc_runtime::mesh_layout::MeshLayout;
use mbdc_runtime::mesh_model;
use mbdc_runtime::mesh_plan::{Assembly, AssemblyOptions};
use mbdc_runtime::study::thread_cpu_time;
use rayon::prelude::*;

/// Bytes in a GiB.
const GIB: f64 = (1u64 << 30) as f64;

/// A rayon pool of `threads` threads.
fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
}

// ---------------------------------------------------------------------------------------
// Machine limits

/// The machine's measured limits.
struct Limits {
    /// STREAM triad bandwidth, 1 and 2 threads (B/s; 24 B per index, no write-allocate).
    triad: [f64; 2],
    /// One dependent multiply–add chain (flop/s).
    chain: f64,
    /// 32 independent multiply–add chains, vectorized for the build's target (flop/s).
    vector: f64,
    /// The same with AVX2 + FMA, if the core has them (flop/s): not used by this build.
    fma: Option<f64>,
}

/// STREAM triad `a = b + s c` on three 64 MiB arrays, with pools of 1 and 2 threads,
/// interleaved, best of `rounds`: bytes per second (24 B per index, the STREAM convention).
fn triad(pools: &[rayon::ThreadPool; 2], rounds: usize) -> [f64; 2] {
    const N: usize = 8 << 20;
    const CHUNK: usize = 1 << 14;
    let mut a = vec![0.0f64; N];
    let b: Vec<f64> = (0..N).map(|i| 1.0 + (i % 7) as f64).collect();
    let c: Vec<f64> = (0..N).map(|i| 2.0 + (i % 5) as f64).collect();
    let s = black_box(3.0);
    let mut best = [f64::INFINITY; 2];
    for _ in 0..rounds {
        for (k, p) in pools.iter().enumerate() {
            let t0 = Instant::now();
            p.install(|| {
                a.par_chunks_mut(CHUNK)
                    .zip(b.par_chunks(CHUNK))
                    .zip(c.par_chunks(CHUNK))
                    .for_each(|((a, b), c)| {
                        for ((a, b), c) in a.iter_mut().zip(b).zip(c) {
                            *a = b + s * c;
                        }
                    })
            });
            best[k] = best[k].min(t0.elapsed().as_secs_f64());
            black_box(&a);
        }
    }
    best.map(|t| 24.0 * N as f64 / t)
}

/// One dependent chain `x ← x a + b` (a multiply and an add, each waiting for the last):
/// flop/s.
fn chain_rate(n: usize) -> f64 {
    let (mut x, a, b) = (black_box(1.0f64), black_box(0.999_999_9), black_box(1e-9));
    let t0 = Instant::now();
    for _ in 0..n {
        x = x * a + b;
    }
    let dt = t0.elapsed().as_secs_f64();
    black_box(x);
    2.0 * n as f64 / dt
}

/// 32 independent chains `x_i ← x_i a + b`, which the compiler vectorizes for the build's
/// target (SSE2 by default: 2-wide, no FMA): flop/s.
fn vector_rate(n: usize) -> f64 {
    let mut x = black_box([1.0f64; 32]);
    for (k, v) in x.iter_mut().enumerate() {
        *v += k as f64 * 0.01;
    }
    let (a, b) = (black_box(0.999_999_9), black_box(1e-9));
    let outer = n / 64;
    let t0 = Instant::now();
    for _ in 0..outer {
        for _ in 0..64 {
            for v in x.iter_mut() {
                *v = *v * a + b;
            }
        }
        x = black_box(x);
    }
    let dt = t0.elapsed().as_secs_f64();
    black_box(x);
    64.0 * (outer * 64) as f64 / dt
}

/// The same 32 chains with fused multiply–adds in 4-wide AVX2 registers: flop/s.
///
/// # Safety
/// The core must have AVX2 and FMA (checked by the caller).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn fma_rate_avx2(n: usize) -> f64 {
    let mut x = black_box([1.0f64; 32]);
    for (k, v) in x.iter_mut().enumerate() {
        *v += k as f64 * 0.01;
    }
    let (a, b) = (black_box(0.999_999_9), black_box(1e-9));
    let outer = n / 64;
    let t0 = Instant::now();
    for _ in 0..outer {
        for _ in 0..64 {
            for v in x.iter_mut() {
                *v = v.mul_add(a, b);
            }
        }
        x = black_box(x);
    }
    let dt = t0.elapsed().as_secs_f64();
    black_box(x);
    64.0 * (outer * 64) as f64 / dt
}

/// The AVX2 + FMA rate when the core has them.
fn fma_rate(n: usize) -> Option<f64> {
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
        // SAFETY: the features were detected just above.
        return Some(unsafe { fma_rate_avx2(n) });
    }
    let _ = n;
    None
}

fn limits(pools: &[rayon::ThreadPool; 2], rounds: usize) -> Limits {
    let triad = triad(pools, rounds.max(5));
    let (mut chain, mut vector, mut fma) = (0.0f64, 0.0f64, None::<f64>);
    for _ in 0..rounds {
        chain = chain.max(chain_rate(100_000_000));
        vector = vector.max(vector_rate(400_000_000));
        fma = fma_rate(400_000_000).map(|r| fma.map_or(r, |f| f.max(r)));
    }
    Limits {
        triad,
        chain,
        vector,
        fma,
    }
}

// ---------------------------------------------------------------------------------------
// Meshes

/// The element types measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Type {
    Hex8OnePoint,
    Hex8Full,
    Tet4,
    Quad4,
}

impl Type {
    const ALL: [Type; 4] = [Type::Hex8OnePoint, Type::Hex8Full, Type::Tet4, Type::Quad4];

    fn label(self) -> &'static str {
        match self {
            Type::Hex8OnePoint => "hex8 one-point, viscous hourglass",
            Type::Hex8Full => "hex8 2×2×2",
            Type::Tet4 => "tet4",
            Type::Quad4 => "quad4 2×2, plane stress",
        }
    }

    fn nodes_per_element(self) -> usize {
        match self {
            Type::Hex8OnePoint | Type::Hex8Full => 8,
            Type::Tet4 | Type::Quad4 => 4,
        }
    }

    /// Floating-point operations of one element update, counted by hand from the kernels
    /// (small strain; a multiply, add, division, square root or power counts one; the
    /// shape-function derivatives at the fixed quadrature points are constants):
    /// - 3-D gradients at a point (`continuum::gradients`, N nodes): Jacobian 18N,
    ///   det 14, inverse 37, `J⁻ᵀ ∂N` 15N; with N = 8: 315.
    /// - one quadrature point of `integrate` (N nodes): ∇u 18N, strain 12, stress 18,
    ///   `P = F S` 45, forces 21N, sums and energy 41; N = 8: 428, N = 4: 272.
    /// - hex8 one-point: mean gradients 8 × (315 + 49) + 24 divisions = 2936, one point 428,
    ///   γ 4 × 96 = 384, b·b 47, coefficients 10, viscous hourglass forces and power 581,
    ///   centroid Jacobian 158, `x0 + u` 24, finish 13: 4581.
    /// - hex8 2×2×2: per point gradients 315 + deformed det J 159 (8 × 474 = 3792), 8 points
    ///   of `integrate` 3424, `x0 + u` 24, finish 13: 7253.
    /// - tet4: gradients (edges, three cross products, 9 divisions) 60, one point 272,
    ///   deformed det 23, `x0 + u` 12, finish 13: 380.
    /// - quad4 (through the 3-D code with N = 4): per point gradients 183 + weight 1 +
    ///   deformed det 87 (4 × 271 = 1084), 4 points of `integrate` 1088, `x0 + u`, finish,
    ///   plane-stress law and outputs 34: 2206.
    fn flops(self) -> f64 {
        match self {
            Type::Hex8OnePoint => 4581.0,
            Type::Hex8Full => 7253.0,
            Type::Tet4 => 380.0,
            Type::Quad4 => 2206.0,
        }
    }

    /// The scene text of about `n` elements (1 cm cells, steel; the face z = 0, or the edge
    /// x = 0 for quad4, fixed) and its element count.
    fn scene(self, n: usize) -> (String, usize) {
        let material = "material steel { E 210 GPa; nu 0.3; rho 7850 kg/m^3 }";
        let simulate = "simulate { duration 1 ms; step 0.1 us }";
        match self {
            Type::Quad4 => {
                let nx = (n as f64).sqrt().round() as usize;
                let ny = (n as f64 / nx as f64).round() as usize;
                let text = format!(
                    "model bench {{\n  {material}\n  mesh m {{\n    element quad4, plane_stress\n    thickness 1 mm\n    generate rect(origin: (0, 0) m, size: ({}, {}) m, divisions: ({nx}, {ny}))\n    material steel\n    set left = nodes(x == 0)\n    fix left\n  }}\n  {simulate}\n}}\n",
                    nx as f64 * 0.01,
                    ny as f64 * 0.01
                );
                (text, nx * ny)
            }
            _ => {
                let per_cell = if self == Type::Tet4 { 6 } else { 1 };
                let cells = n as f64 / per_cell as f64;
                let nx = cells.cbrt().round() as usize;
                let ny = (cells / nx as f64).sqrt().round() as usize;
                let nz = (cells / (nx * ny) as f64).round() as usize;
                let kind = match self {
                    Type::Tet4 => "tet4",
                    Type::Hex8OnePoint => {
                        "hex8\n    integration reduced\n    hourglass viscous(0.1)"
                    }
                    _ => "hex8",
                };
                let text = format!(
                    "model bench {{\n  {material}\n  mesh m {{\n    element {kind}\n    generate box(origin: (0, 0, 0) m, size: ({}, {}, {}) m, divisions: ({nx}, {ny}, {nz}))\n    material steel\n    set bottom = nodes(z == 0)\n    fix bottom\n  }}\n  {simulate}\n}}\n",
                    nx as f64 * 0.01,
                    ny as f64 * 0.01,
                    nz as f64 * 0.01
                );
                (text, nx * ny * nz * per_cell)
            }
        }
    }
}

/// Bytes one element update moves, counted pass by pass over `MeshDynamics::step` as
/// written (8-byte reals, 4-byte indices; every pass over an array counted, no cache
/// reuse between elements sharing a node):
/// - per element: the gather of x0, u, v (3 × 24 B) and the index (4 B) of each node, the
///   force slots written (24 B per node) and read back with their indices in the node
///   gather (28 B per node), stress, strain and scalars written (48 + 48 + 32 B), four
///   passes over the scalars (inversion check, dissipation, strain and hourglass energy:
///   4 × 32 B);
/// - per node: the first half kick and displacement update (v, u read and written, a
///   read, du written: 144 B), two work-rate passes (f_ext, reaction, du: 2 × 72 B),
///   f_ext zeroed (24 B), the node gather (offsets, f_ext, foundation, mass, constraint
///   flags, a and reaction written: 111 B), the finiteness check (24 B), the second half
///   kick (72 B), the kinetic energy (32 B): 551 B, times nodes per element.
fn bytes_per_element(npe: usize, nodes: usize, elements: usize) -> f64 {
    let element = npe * (3 * 24 + 4) + npe * 24 + npe * 28 + 48 + 48 + 32 + 4 * 32;
    let node = 144 + 2 * 72 + 24 + 111 + 24 + 72 + 32;
    element as f64 + node as f64 * nodes as f64 / elements as f64
}

/// A smooth displacement and velocity field with a small rough part, so that every element
/// computes on normal (not zero or subnormal) numbers from the first step.
fn start_state(l: &MeshLayout) -> MeshState {
    let mut st = MeshState::default();
    for (n, x) in l.x0.iter().enumerate() {
        let r = ((n.wrapping_mul(2_654_435_761) % 1000) as f64 / 1000.0) - 0.5;
        let s = (37.0 * x[0] + 11.0 * x[1] + 5.0 * x[2]).sin();
        let c = (13.0 * x[0] - 7.0 * x[1] + 17.0 * x[2]).cos();
        st.u.push([1e-7 * (s + 0.1 * r), 1e-7 * c, 1e-7 * (s * c - 0.1 * r)]);
        st.v.push([1e-3 * c, 1e-3 * (s + 0.1 * r), -1e-3 * (s - 0.1 * r)]);
    }
    st
}

/// One step of a benchmark mesh (which has no loads that could make it fail).
fn advance(md: &mut MeshDynamics) {
    md.step().expect("the benchmark mesh steps");
}

/// The compiled scene of `ty` with about `n` elements.
fn compile(ty: Type, n: usize) -> (Scene, usize) {
    let (text, elements) = ty.scene(n);
    let l = mbdc_compiler::load_str("bench.mbd", &text, &[]);
    let msg = l.render_plain();
    (l.scene.unwrap_or_else(|| panic!("{msg}")), elements)
}

/// A field of /proc/self/status in bytes (`VmRSS`, `VmHWM`), if readable.
fn status_bytes(field: &str) -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with(field))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// One mesh ready to step.
struct Case {
    ty: Type,
    elements: usize,
    nodes: usize,
    md: MeshDynamics,
    /// Best seconds per step, per pool.
    best: [f64; 2],
    /// CPU seconds and wall seconds of the 2-thread timings.
    cpu_wall: [f64; 2],
}

/// Builds the mesh of `ty` with about `n` elements.
fn case(ty: Type, n: usize) -> Case {
    let (scene, elements) = compile(ty, n);
    let h = scene.simulate.step;
    let layout = Arc::new(mesh_model::build(&scene.meshes).expect("a valid mesh"));
    drop(scene);
    assert_eq!(layout.elements(), elements);
    let nodes = layout.nodes();
    let st = start_state(&layout);
    let md = MeshDynamics::new(layout, h, 0.0, &st).expect("starts");
    Case {
        ty,
        elements,
        nodes,
        md,
        best: [f64::INFINITY; 2],
        cpu_wall: [0.0; 2],
    }
}

/// The memory subcommand, run in a fresh process by [`memory`]: compiles the scene of `ty`
/// with about `n` elements, then builds the layout and the integrator and takes `steps`
/// steps, and prints `VmRSS` after compiling, `VmHWM` after building, `VmHWM` at the end
/// (bytes) and the element count.
pub fn memory_child(ty: &str, n: usize, steps: usize) {
    let ty = Type::ALL
        .into_iter()
        .find(|t| format!("{t:?}") == ty)
        .expect("a type");
    let (scene, elements) = compile(ty, n);
    let h = scene.simulate.step;
    let rss = status_bytes("VmRSS").unwrap_or(f64::NAN);
    let layout = Arc::new(mesh_model::build(&scene.meshes).expect("a valid mesh"));
    let st = start_state(&layout);
    let mut md = MeshDynamics::new(layout, h, 0.0, &st).expect("starts");
    let built = status_bytes("VmHWM").unwrap_or(f64::NAN);
    let t0 = Instant::now();
    for _ in 0..steps {
        advance(&mut md);
    }
    let per_step = t0.elapsed().as_secs_f64() / steps.max(1) as f64;
    let end = status_bytes("VmHWM").unwrap_or(f64::NAN);
    println!("{rss} {built} {end} {elements} {per_step}");
    drop(scene);
}

/// Memory of `ty` at about `n` elements, measured in a fresh process (so that memory freed
/// by earlier meshes does not hide the growth): (RSS after compiling the scene, peak after
/// building layout and integrator, peak after `steps` steps, elements, s/step).
fn memory(ty: Type, n: usize, steps: usize) -> Option<[f64; 5]> {
    let exe = std::env::current_exe().ok()?;
    let out = std::process::Command::new(exe)
        .args([
            "meshes-memory",
            &format!("{ty:?}"),
            &n.to_string(),
            &steps.to_string(),
        ])
        .output()
        .ok()?;
    let text = String::from_utf8(out.stdout).ok()?;
    let v: Vec<f64> = text
        .split_whitespace()
        .filter_map(|x| x.parse().ok())
        .collect();
    v.try_into().ok()
}

/// CPU time of this process so far (user + system, s; `/proc/self/stat` at 100 ticks/s).
pub(crate) fn cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            let rest = s.rsplit_once(')')?.1.to_string();
            let f: Vec<&str> = rest.split_whitespace().collect();
            // fields 14 and 15 of the line; `rest` starts at field 3
            Some((f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?) / 100.0)
        })
        .unwrap_or(f64::NAN)
}

/// `/proc/loadavg`'s first three fields.
pub(crate) fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "n/a".into())
}

/// Steps per timing so that one timing lasts about `seconds` (from one timed step).
fn calibrate(md: &mut MeshDynamics, p: &rayon::ThreadPool, seconds: f64) -> usize {
    let t0 = Instant::now();
    p.install(|| advance(md));
    let t = t0.elapsed().as_secs_f64();
    ((seconds / t).ceil() as usize).clamp(2, 2000)
}

/// Times `steps` steps in pool `p`: seconds per step.
fn time(md: &mut MeshDynamics, p: &rayon::ThreadPool, steps: usize) -> f64 {
    p.install(|| {
        let t0 = Instant::now();
        for _ in 0..steps {
            advance(md);
        }
        t0.elapsed().as_secs_f64() / steps as f64
    })
}

/// The `meshes` subcommand: `scale ≥ 1` adds the 10⁶-element meshes.
pub fn meshes(scale: f64, rounds: usize) {
    let pools = [pool(1), pool(2)];
    let seconds = 0.25;
    let lim = limits(&pools, rounds);
    println!("# Meshes: element rates against the machine's limits\n");
    println!(
        "scale {scale}, best of {rounds} interleaved rounds, about {seconds} s per timing; load average at the start {}\n",
        load_average()
    );
    println!("| machine limit | value |\n|---|---|");
    println!(
        "| STREAM triad, 3 × 64 MiB, 1 thread | {:.2} GB/s |",
        lim.triad[0] / 1e9
    );
    println!(
        "| STREAM triad, 2 threads | {:.2} GB/s ({:.2}×) |",
        lim.triad[1] / 1e9,
        lim.triad[1] / lim.triad[0]
    );
    println!(
        "| one dependent multiply–add chain | {:.2} GFLOP/s |",
        lim.chain / 1e9
    );
    println!(
        "| 32 independent chains, vectorized for this build (SSE2) | {:.2} GFLOP/s |",
        lim.vector / 1e9
    );
    match lim.fma {
        Some(f) => println!(
            "| same, AVX2 + FMA (not used by this build) | {:.2} GFLOP/s |",
            f / 1e9
        ),
        None => println!("| same, AVX2 + FMA | not available |"),
    }

    let mut sizes = vec![1_000, 10_000, 100_000];
    if scale >= 1.0 {
        sizes.push(1_000_000);
    }
    let largest = *sizes.last().expect("sizes");
    println!(
        "\n| type | elements | nodes | B/element | flops/element | M element-steps/s, 1 thread | ns/element | bandwidth bound (M/s) | flop bound (M/s) | of bandwidth bound | of flop bound | of tighter bound |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut last: Vec<Case> = Vec::new();
    for &n in &sizes {
        let mut cases: Vec<Case> = Type::ALL.iter().map(|&ty| case(ty, n)).collect();
        let two = n == largest;
        let steps: Vec<usize> = cases
            .iter_mut()
            .map(|c| calibrate(&mut c.md, &pools[0], seconds))
            .collect();
        for _ in 0..rounds {
            for (c, &s) in cases.iter_mut().zip(&steps) {
                for (k, p) in pools.iter().enumerate().take(if two { 2 } else { 1 }) {
                    let (cpu, wall) = (cpu_seconds(), Instant::now());
                    let t = time(&mut c.md, p, s);
                    c.best[k] = c.best[k].min(t);
                    if k == 1 {
                        c.cpu_wall[0] += cpu_seconds() - cpu;
                        c.cpu_wall[1] += wall.elapsed().as_secs_f64();
                    }
                }
            }
        }
        for c in &cases {
            let npe = c.ty.nodes_per_element();
            let bytes = bytes_per_element(npe, c.nodes, c.elements);
            let rate = c.elements as f64 / c.best[0];
            let bw = lim.triad[0] / bytes;
            let fl = lim.vector / c.ty.flops();
            println!(
                "| {} | {} | {} | {:.0} | {:.0} | {:.3} | {:.0} | {:.2} | {:.2} | {:.0} % | {:.0} % | {:.0} % |",
                c.ty.label(),
                c.elements,
                c.nodes,
                bytes,
                c.ty.flops(),
                rate / 1e6,
                1e9 / rate,
                bw / 1e6,
                fl / 1e6,
                100.0 * rate / bw,
                100.0 * rate / fl,
                100.0 * rate / bw.min(fl)
            );
        }
        if two {
            last = cases;
        }
    }
    println!(
        "\n| type ({largest} elements) | 1 thread, ms/step | 2 threads, ms/step | speed-up | peak RSS of layout + integrator per element | achieved GB/s (2 threads) | achieved GFLOP/s (2 threads) | cores obtained in the 2-thread timings (CPU s / wall s) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for c in &last {
        let bytes = bytes_per_element(c.ty.nodes_per_element(), c.nodes, c.elements);
        let rate2 = c.elements as f64 / c.best[1];
        println!(
            "| {} | {:.2} | {:.2} | {:.2} | {} | {:.2} | {:.2} | {:.2} |",
            c.ty.label(),
            c.best[0] * 1e3,
            c.best[1] * 1e3,
            c.best[0] / c.best[1],
            memory(c.ty, largest, 0).map_or("n/a".to_string(), |m| format!(
                "{:.0} B",
                (m[1] - m[0]) / m[3]
            )),
            rate2 * bytes / 1e9,
            rate2 * c.ty.flops() / 1e9,
            c.cpu_wall[0] / c.cpu_wall[1]
        );
    }
    drop(last);
    if scale >= 1.0 {
        // The 10⁶-element hex8 runs in a fresh process: peak memory of compile + build + steps.
        for ty in [Type::Hex8Full, Type::Hex8OnePoint] {
            if let Some([rss, built, end, elements, step]) = memory(ty, 1_000_000, 3) {
                println!(
                    "\n{}, {elements} elements from the scene text, in a fresh process: RSS after compiling {:.2} GiB, peak after building layout and integrator {:.2} GiB, peak after 3 steps {:.2} GiB ({:.0} B/element; layout + integrator {:.0} B/element), {:.0} ms/step on the default pool",
                    ty.label(),
                    rss / GIB,
                    built / GIB,
                    end / GIB,
                    end / elements,
                    (built - rss) / elements,
                    step * 1e3
                );
            }
        }
    }
    assembly_strategies(&pools, false, rounds, seconds);
    println!("\nload average at the end: {}", load_average());
}

// ---------------------------------------------------------------------------------------
// Assembly strategies side by side

/// The assembly candidates: every strategy with the default plan options, and colouring of
/// single elements (groups of 1) beside colouring of the default groups.
fn assembly_candidates() -> Vec<(String, AssemblyOptions)> {
    let d = AssemblyOptions::default();
    let with = |strategy| AssemblyOptions { strategy, ..d };
    vec![
        ("gather".into(), with(Assembly::Gather)),
        (
            "colouring, single elements".into(),
            AssemblyOptions {
                colour_group: 1,
                ..with(Assembly::Colouring)
            },
        ),
        (
            format!("colouring, groups of {}", d.colour_group),
            with(Assembly::Colouring),
        ),
        ("partitions".into(), with(Assembly::Partitions)),
    ]
}

/// One candidate's stepper and timings.
struct Strategy {
    label: String,
    options: AssemblyOptions,
    /// Colours, partitions and interface nodes of its plan.
    plan: String,
    md: MeshDynamics,
    /// Best wall seconds per step with 1 and 2 threads.
    best: [f64; 2],
    /// Best CPU seconds per step of the 1-thread pool's thread.
    best_cpu: f64,
    /// CPU seconds and wall seconds of the 2-thread timings.
    cpu_wall: [f64; 2],
}

/// The `meshes-assembly` subcommand (also the end of `meshes`, without the 10⁶ rows): the
/// assembly strategies side by side on the same meshes (hex8 one-point, hex8 2×2×2, tet4,
/// quad4 of 10⁴ and 10⁵ elements; with `million` hex8 one-point and tet4 of 10⁶), whole
/// `MeshDynamics::step`s,
/// best of `rounds` interleaved rounds: with 1 thread by the pool thread's CPU time (which
/// the other processes of a shared machine do not inflate) and by wall time, with 2
/// threads by wall time beside the cores the process obtained. Before timing, the
/// candidates that share plan options (all strategies with the default options) are
/// checked to give bitwise the same state after 3 steps.
pub fn assembly_strategies(
    pools: &[rayon::ThreadPool; 2],
    million: bool,
    rounds: usize,
    seconds: f64,
) {
    println!(
        "\n## The assembly strategies side by side\n\nbest of {rounds} interleaved rounds, about {seconds} s per timing; load average {}\n",
        load_average()
    );
    println!("| type | elements | strategy | plan | M element-steps per CPU s, 1 thread | / gather | M element-steps/s (wall), 1 thread | / gather | M element-steps/s (wall), 2 threads | / gather | cores obtained (2 threads) |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut sizes = vec![10_000, 100_000];
    if million {
        sizes.push(1_000_000);
    }
    for &n in &sizes {
        let types: &[Type] = if n >= 1_000_000 {
            &[Type::Hex8OnePoint, Type::Tet4]
        } else {
            &Type::ALL
        };
        for &ty in types {
            let (scene, elements) = compile(ty, n);
            let h = scene.simulate.step;
            let mut cands: Vec<Strategy> = assembly_candidates()
                .into_iter()
                .map(|(label, options)| {
                    let l = Arc::new(
                        mesh_model::build_with(&scene.meshes, options).expect("a valid mesh"),
                    );
                    let p = &l.assembly;
                    let b = &p.blocks[0];
                    let plan = match options.strategy {
                        Assembly::Gather => String::new(),
                        Assembly::Colouring => format!("{} colours", b.colours),
                        Assembly::Partitions => format!(
                            "{} partitions, {:.1} % interface nodes",
                            b.partitions(),
                            100.0 * p.interface_nodes.len() as f64 / l.nodes() as f64
                        ),
                    };
                    let st = start_state(&l);
                    Strategy {
                        label,
                        options,
                        plan,
                        md: MeshDynamics::new(l, h, 0.0, &st).expect("starts"),
                        best: [f64::INFINITY; 2],
                        best_cpu: f64::INFINITY,
                        cpu_wall: [0.0; 2],
                    }
                })
                .collect();
            drop(scene);
            // Same plan options, any strategy: bitwise the same state.
            let mut states: Vec<(AssemblyOptions, MeshState)> = Vec::new();
            for c in &mut cands {
                pools[1].install(|| {
                    for _ in 0..3 {
                        advance(&mut c.md);
                    }
                });
                let mut st = MeshState::default();
                c.md.state(&mut st);
                let key = AssemblyOptions {
                    strategy: Assembly::Gather,
                    ..c.options
                };
                match states.iter().find(|(k, _)| *k == key) {
                    Some((_, first)) => assert!(
                        first.u == st.u && first.v == st.v && first.stress == st.stress,
                        "{}: {} departs from the first strategy with its plan options",
                        ty.label(),
                        c.label
                    ),
                    None => states.push((key, st)),
                }
            }
            drop(states);
            let steps = calibrate(&mut cands[0].md, &pools[0], seconds);
            for _ in 0..rounds {
                for c in cands.iter_mut() {
                    // 1 thread: the pool thread's CPU time (what other processes take
                    // does not count) and the wall time
                    let (cpu, wall) = pools[0].install(|| {
                        let (c0, w0) = (thread_cpu_time(), Instant::now());
                        for _ in 0..steps {
                            advance(&mut c.md);
                        }
                        (thread_cpu_time() - c0, w0.elapsed().as_secs_f64())
                    });
                    c.best_cpu = c.best_cpu.min(cpu / steps as f64);
                    c.best[0] = c.best[0].min(wall / steps as f64);
                    // 2 threads: wall time, and the cores the process obtained
                    let (cpu, wall) = (cpu_seconds(), Instant::now());
                    let t = time(&mut c.md, &pools[1], steps);
                    c.best[1] = c.best[1].min(t);
                    c.cpu_wall[0] += cpu_seconds() - cpu;
                    c.cpu_wall[1] += wall.elapsed().as_secs_f64();
                }
            }
            let (gather_cpu, gather) = (cands[0].best_cpu, cands[0].best);
            for c in &cands {
                let rate = |t: f64| elements as f64 / t / 1e6;
                println!(
                    "| {} | {elements} | {} | {} | {:.3} | {:.2} | {:.3} | {:.2} | {:.3} | {:.2} | {:.2} |",
                    ty.label(),
                    c.label,
                    c.plan,
                    rate(c.best_cpu),
                    gather_cpu / c.best_cpu,
                    rate(c.best[0]),
                    gather[0] / c.best[0],
                    rate(c.best[1]),
                    gather[1] / c.best[1],
                    c.cpu_wall[0] / c.cpu_wall[1]
                );
            }
        }
    }
}

/// The `meshes-assembly` subcommand: [`assembly_strategies`] alone, with the 10⁶-element
/// rows when `scale ≥ 1`.
pub fn assembly_only(scale: f64, rounds: usize) {
    let pools = [pool(1), pool(2)];
    println!(
        "# Meshes: the assembly strategies\n\nscale {scale}; load average at the start {}",
        load_average()
    );
    assembly_strategies(&pools, scale >= 1.0, rounds, 0.25);
    println!("\nload average at the end: {}", load_average());
}
