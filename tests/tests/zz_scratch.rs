use mbdc_runtime::interp::Interp;
use mbdc_runtime::run::*;
use mbdc_runtime::scene::*;

struct Obs { last: String }
impl Observer for Obs {
    fn frame(&mut self, f: &Frame<'_>) {
        self.last = format!("t={:.3} E={:.6e}", f.state.t, f.kinetic + f.potential);
    }
    fn notice(&mut self, m: &str) { eprintln!("NOTICE {m}"); }
}

#[test]
fn scratch_models() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/");
    for m in ["double_pendulum_3d", "chain", "four_bar", "slider_crank", "bowling_ball", "torque_free", "deployment_arm"] {
        let loaded = mbdc_compiler::load_file(format!("{root}{m}.mbd"), &[]);
        let scene = loaded.scene.expect("scene");
        let sys = Interp::new(&scene).expect("interp");
        for method in ["staggered", "baumgarte", "penalty", "coordinate_partitioning", "implicit_trapezoid"] {
            let mut spec = MethodSpec::default_for(method).unwrap();
            if let (MethodSpec::Staggered(o), MethodSpec::Staggered(so)) = (&mut spec, &scene.simulate.method) { *o = so.clone(); o.epsilon = None; }
            let cfg = RunConfig {
                duration: scene.simulate.duration.min(3.0),
                step: scene.simulate.step,
                method: spec,
                every: 10,
                on_failure: OnFailure::Stop,
                watchdog: Watchdog::for_scale(length_scale(&sys), true),
            };
            let mut obs = Obs { last: String::new() };
            let t0 = std::time::Instant::now();
            let r = run(&sys, &cfg, &mut obs);
            eprintln!("{m:20} {method:24} fin={} t={:.3} viol={:.2e}({}) dE={:.2e} wall={:.2}s {} {:?}", r.finished, r.t_end, r.max_violation.0, r.max_violation.1, r.max_energy_drift, t0.elapsed().as_secs_f64(), obs.last, r.failure.map(|f| f.to_string()));
        }
    }
}
