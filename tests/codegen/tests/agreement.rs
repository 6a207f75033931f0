//! Generated and interpreted runs agree: for every rigid model in `models/`, in both code
//! layouts, with every method (the dense ones on scenes of up to 40 bodies), 1000 steps, every
//! output quantity of every frame to 1e-12 relative (in practice they are bit-identical: same
//! kernels, same order).

use mbdc_codegen_tests::{config, frames, methods, visit_all, Visitor};
use mbdc_runtime::compiled::CompiledModel;
use mbdc_runtime::interp::Interp;

struct Agree {
    /// This test's share of the visits: those whose index is `part` modulo [`PARTS`].
    part: usize,
    /// Visits so far (of every part).
    visits: usize,
    checked: usize,
    exact: usize,
    values: usize,
    failures: Vec<String>,
    skipped: Vec<String>,
}

impl Visitor for Agree {
    fn visit<M: CompiledModel>(&mut self, file: &str, layout: &str) {
        self.visits += 1;
        if (self.visits - 1) % PARTS != self.part {
            return;
        }
        let path = format!("{}/../../models/{file}", env!("CARGO_MANIFEST_DIR"));
        let loaded = mbdc_compiler::load_file(&path, &[]);
        let Some(scene) = loaded.scene else {
            self.failures
                .push(format!("{file}: {}", loaded.render_plain()));
            return;
        };
        let interp = Interp::new(&scene).expect("interpretable");
        // The compiled program reads its numbers from the scene's JSON (`mbdc run` passes it):
        // the round trip must be exact.
        let json = serde_json::to_string(&scene).expect("serializes");
        let back = mbdc_runtime::compiled::scene_from_json(&json).expect("parses");
        if back != scene {
            self.failures
                .push(format!("{file}: the scene changes through JSON"));
        }
        let generated = M::from_scene(&back).expect("same structure");
        for method in methods(&scene) {
            let cfg = config(&interp, &scene, &method, 1000);
            // A panic of the interpreter is a runtime bug outside generated code: noted, skipped.
            let Ok((ri, fi)) =
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| frames(&interp, &cfg)))
            else {
                self.skipped.push(format!(
                    "{file} ({layout}) with {}: the interpreter panics",
                    method.name()
                ));
                continue;
            };
            let Ok((rg, fg)) =
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| frames(&generated, &cfg)))
            else {
                self.failures.push(format!(
                    "{file} ({layout}) with {}: generated code panics",
                    method.name()
                ));
                continue;
            };
            let what = format!("{file} ({layout}) with {}", method.name());
            self.checked += 1;
            if ri.failure.as_ref().map(|f| f.to_string())
                != rg.failure.as_ref().map(|f| f.to_string())
                || ri.steps != rg.steps
            {
                self.failures.push(format!(
                    "{what}: reports differ: {:?} vs {:?}",
                    ri.failure, rg.failure
                ));
                continue;
            }
            if fi.len() != fg.len() {
                self.failures
                    .push(format!("{what}: {} vs {} frames", fi.len(), fg.len()));
                continue;
            }
            let mut worst = (0.0f64, 0, 0);
            for (k, (a, b)) in fi.iter().zip(&fg).enumerate() {
                for (i, (x, y)) in a.iter().zip(b).enumerate() {
                    self.values += 1;
                    if x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()) {
                        self.exact += 1;
                        continue;
                    }
                    let rel = (x - y).abs() / x.abs().max(y.abs());
                    if rel.is_nan() || rel > worst.0 {
                        worst = (rel, k, i);
                    }
                }
            }
            if worst.0.is_nan() || worst.0 > 1e-12 {
                self.failures.push(format!(
                    "{what}: relative difference {:.3e} at frame {} value {}",
                    worst.0, worst.1, worst.2
                ));
            }
        }
    }
}

/// The visits are shared between [`PARTS`] tests, which the test harness runs on as many
/// threads as the machine has cores (one test took 2.5 minutes of CI's 2 cores alone).
const PARTS: usize = 4;

/// Part `part` of the comparison: its runs agree; returns how many it compared.
fn agree(part: usize) -> usize {
    let mut a = Agree {
        part,
        visits: 0,
        checked: 0,
        exact: 0,
        values: 0,
        failures: Vec::new(),
        skipped: Vec::new(),
    };
    visit_all(&mut a);
    eprintln!(
        "part {part}: {} runs compared, {} of {} values bit-identical",
        a.checked, a.exact, a.values
    );
    for s in &a.skipped {
        eprintln!("skipped: {s}");
    }
    assert!(a.failures.is_empty(), "{}", a.failures.join("\n"));
    a.checked
}

#[test]
fn generated_and_interpreted_runs_agree_part_0() {
    assert!(agree(0) >= 7 * 2 * 6 / PARTS, "too few runs");
}

#[test]
fn generated_and_interpreted_runs_agree_part_1() {
    assert!(agree(1) >= 7 * 2 * 6 / PARTS, "too few runs");
}

#[test]
fn generated_and_interpreted_runs_agree_part_2() {
    assert!(agree(2) >= 7 * 2 * 6 / PARTS, "too few runs");
}

#[test]
fn generated_and_interpreted_runs_agree_part_3() {
    assert!(agree(3) >= 7 * 2 * 6 / PARTS, "too few runs");
}
