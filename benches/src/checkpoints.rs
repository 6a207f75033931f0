//! `mbdc-bench checkpoints [ROUNDS]`: what a checkpoint costs and what a restart costs,
//! against the state's size, a step of the same scene and the disk's write bandwidth,
//! measured side by side in one run (BENCHMARKS.md, "Checkpoints and restart").
//!
//! Per scene: the time of one step; of saving the run's state (every value the method
//! carries, `Integrator::persist` into a `Saver`, and the file's encoding with its CRC); of
//! writing the file the way a run does (`checkpoint::write`: temporary file, fsync, rename,
//! fsync of the folder); and of a restart's reading (read, CRC check, decode, a method made
//! afresh and loaded). The disk's bandwidth is that of writing 256 MiB with one fsync at
//! the end, in the same folder. Best of the rounds for each.

use std::hint::black_box;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use mbdc_compiler::Scene;
use mbdc_runtime::checkpoint::{self, Identity};
use mbdc_runtime::integrators::{self, State};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::persist::{Loader, Saver};
use mbdc_runtime::scene::MethodSpec;
use mbdc_runtime::system::System;

fn scene_of(text: &str) -> Scene {
    let l = mbdc_compiler::load_str("bench.mbd", text, &[]);
    let msg = l.render_plain();
    l.scene.unwrap_or_else(|| panic!("{msg}"))
}

fn hex_box(n: usize) -> String {
    format!(
        "model hex_box {{\n  material steel {{ E 210 GPa; nu 0.3; rho 7850 kg/m^3 }}\n  mesh m {{\n    element hex8\n    integration reduced\n    generate box(origin: (0, 0, 0) m, size: ({n}, {n}, {n}) cm, divisions: ({n}, {n}, {n}))\n    material steel\n    set bottom = nodes(z == 0)\n    set top = nodes(z == {n} cm)\n    fix bottom\n    load top, (0, 0, -1 N)\n  }}\n  simulate {{ duration 1 ms; step 0.1 us }}\n}}\n"
    )
}

/// Write `mib` MiB to a file in `dir` with one fsync: MB/s (also the `output` benchmark's
/// yardstick).
pub(crate) fn disk_bandwidth(dir: &Path, mib: usize) -> f64 {
    let path = dir.join("bandwidth.bin");
    let block = vec![0x5au8; 1 << 20];
    let t = Instant::now();
    let mut f = std::fs::File::create(&path).expect("a file in the temp folder");
    for _ in 0..mib {
        f.write_all(&block)
            .expect("disk space for the bandwidth test");
    }
    f.sync_all().expect("fsync");
    let s = t.elapsed().as_secs_f64();
    let _ = std::fs::remove_file(&path);
    (mib << 20) as f64 / s / 1e6
}

struct Row {
    name: String,
    method: &'static str,
    bytes: usize,
    step: f64,
    save: f64,
    write: f64,
    read: f64,
}

fn measure(name: &str, scene: &Scene, method: MethodSpec, dir: &Path, rounds: usize) -> Row {
    let sys = Interp::new(scene).expect("interpretable");
    let h = scene.simulate.step;
    let start = State::initial(&sys);
    let mut integ = integrators::make(&method, &sys, h, &start).expect("starts");
    for _ in 0..5 {
        integ.step(&sys).expect("steps");
    }
    let identity = Identity::of(
        scene,
        sys.layout(),
        method.name(),
        h,
        1,
        scene.simulate.output.format,
    );
    let (mut step, mut save, mut write, mut read) = (f64::MAX, f64::MAX, f64::MAX, f64::MAX);
    let mut bytes = Vec::new();
    let mut at = State::initial(&sys);
    for _ in 0..rounds {
        let t = Instant::now();
        for _ in 0..5 {
            integ.step(&sys).expect("steps");
        }
        step = step.min(t.elapsed().as_secs_f64() / 5.0);

        let t = Instant::now();
        let mut s = Saver::new();
        assert!(integ.persist(&mut s), "{name}: the method persists");
        bytes = checkpoint::encode(&identity, 0, integ.time(), &[], &s.into_bytes());
        save = save.min(t.elapsed().as_secs_f64());

        let t = Instant::now();
        let path = checkpoint::write(dir, 1, &bytes, 1).expect("writes");
        write = write.min(t.elapsed().as_secs_f64());

        integ.state(&sys, &mut at);
        at.active.copy_from_slice(integ.active());
        let t = Instant::now();
        let back = std::fs::read(&path).expect("reads");
        let c = checkpoint::decode(&path, &back).expect("decodes");
        let mut fresh = integrators::make(&method, &sys, h, &at).expect("starts");
        let mut l = Loader::new(&c.run);
        fresh.persist(&mut l);
        l.finish().expect("loads");
        black_box(&fresh);
        read = read.min(t.elapsed().as_secs_f64());
    }
    Row {
        name: name.into(),
        method: method.name(),
        bytes: bytes.len(),
        step,
        save,
        write,
        read,
    }
}

/// Runs the measurement and prints the table of BENCHMARKS.md.
pub fn checkpoints(rounds: usize) {
    let dir: PathBuf = std::env::temp_dir().join(format!("mbdc-bench-ckpt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp folder");
    let chain = |n: usize| {
        let loaded = mbdc_compiler::load_file(
            super::root().join("models/bench/chain_spatial.mbd"),
            &[mbdc_compiler::Override::new("N", n.to_string())],
        );
        let msg = loaded.render_plain();
        loaded.scene.unwrap_or_else(|| panic!("{msg}"))
    };
    let staggered = || MethodSpec::default_for("staggered").expect("a method");
    let natural = || MethodSpec::default_for("natural_partitioning").expect("a method");
    let mut rows = Vec::new();
    let mut bw = f64::MAX;
    // interleaved: every scene once per round, in turn
    for round in 0..rounds.max(1) {
        let cases: Vec<(String, Scene, MethodSpec)> = vec![
            ("chain_spatial N = 100".into(), chain(100), staggered()),
            ("chain_spatial N = 1000".into(), chain(1000), natural()),
            ("hex8 box 20³".into(), scene_of(&hex_box(20)), staggered()),
            ("hex8 box 50³".into(), scene_of(&hex_box(50)), staggered()),
        ];
        bw = bw.min(disk_bandwidth(&dir, 256));
        for (i, (name, scene, method)) in cases.into_iter().enumerate() {
            let m = measure(&name, &scene, method, &dir, 1);
            if round == 0 {
                rows.push(m);
            } else {
                let b = &mut rows[i];
                b.step = b.step.min(m.step);
                b.save = b.save.min(m.save);
                b.write = b.write.min(m.write);
                b.read = b.read.min(m.read);
            }
        }
    }
    // the disk's bandwidth is the worst of the rounds' (the machine is shared): a generous
    // yardstick for the checkpoint writes
    println!("disk write bandwidth (256 MiB, one fsync): {bw:.0} MB/s");
    println!();
    println!("| scene | method | checkpoint | step | save (persist + encode) | write (fsync, rename) | write rate / disk | restart read (read, check, make, load) | checkpoint ÷ step |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for r in &rows {
        let mb = r.bytes as f64 / 1e6;
        println!(
            "| {} | {} | {:.3} MB | {:.3} ms | {:.3} ms | {:.3} ms | {:.2} | {:.3} ms | {:.1} |",
            r.name,
            r.method,
            mb,
            r.step * 1e3,
            r.save * 1e3,
            r.write * 1e3,
            mb / r.write / bw,
            r.read * 1e3,
            (r.save + r.write) / r.step
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
