use mbdc_runtime::integrators::{self, State};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::scene::MethodSpec;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let model = args.get(1).cloned().unwrap_or("double_pendulum_3d".into());
    let method = args.get(2).cloned().unwrap_or("staggered".into());
    let n: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(200000);
    let path = format!("{}/../models/{model}.mbd", env!("CARGO_MANIFEST_DIR"));
    let scene = mbdc_compiler::load_file(&path, &[]).scene.unwrap();
    let sys = Interp::new(&scene).unwrap();
    let m = if method == scene.simulate.method.name() {
        scene.simulate.method.clone()
    } else {
        MethodSpec::default_for(&method).unwrap()
    };
    let st = State::initial(&sys);
    let mut it = integrators::make(&m, &sys, scene.simulate.step, &st).unwrap();
    let t0 = Instant::now();
    for _ in 0..n {
        it.step(&sys).unwrap();
    }
    let dt = t0.elapsed().as_secs_f64();
    println!("{model} {method}: {:.3} us/step", dt / n as f64 * 1e6);
}
