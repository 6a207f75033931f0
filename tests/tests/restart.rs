//! Bit-identical restart of the integrators: a method saved after k steps
//! (`Integrator::persist` into a `Saver`), then made afresh from the state it had there and
//! loaded, continues exactly as the method run straight through. Every value of the state
//! at the end — time, positions, quaternions, velocities, multipliers, beam element states,
//! the meshes' displacements, velocities, stresses, plastic state and energies — is compared
//! bitwise; a value the method carries between steps and does not persist
//! shows here as a difference.

use mbdc_runtime::integrators::{self, State};
use mbdc_runtime::interp::Interp;
use mbdc_runtime::persist::{Loader, Saver};
use mbdc_runtime::scene::{MethodSpec, Scene};
use mbdc_tests::{load_model, method};

fn bits(s: &State) -> Vec<u64> {
    let mut v = vec![s.t.to_bits()];
    for p in &s.pose {
        v.extend(p.r.iter().chain(p.q.coords.iter()).map(|x| x.to_bits()));
    }
    for t in &s.twist {
        v.extend(t.v.iter().chain(t.w.iter()).map(|x| x.to_bits()));
    }
    v.extend(s.lambda.iter().map(|x| x.to_bits()));
    v.extend(s.active.iter().map(|&a| u64::from(a)));
    for e in &s.beams {
        v.extend(
            e.n.iter()
                .chain(e.m.iter())
                .chain(e.gamma.iter())
                .chain(e.kappa.iter())
                .map(|x| x.to_bits()),
        );
    }
    let m = &s.mesh;
    v.extend(
        m.u.iter()
            .chain(&m.v)
            .flatten()
            .chain(m.stress.iter().chain(&m.strain).flatten())
            .chain(m.plastic_strain.iter().flatten())
            .chain(&m.equivalent_plastic_strain)
            .map(|x| x.to_bits()),
    );
    for p in &m.plastic {
        v.extend(
            p.strain
                .iter()
                .chain(&p.stress)
                .flatten()
                .chain(&p.equivalent)
                .map(|x| x.to_bits()),
        );
    }
    let e = &m.energy;
    v.extend(
        [
            e.kinetic,
            e.strain,
            e.hourglass,
            e.foundation,
            e.external_work,
            e.dissipated,
            e.plastic,
            e.tie_work,
            e.half_step,
        ]
        .map(f64::to_bits),
    );
    v
}

/// Run `n` steps straight, and `k` steps, save, make afresh from the state at step k (and
/// again from the initial state), load, `n − k` steps: the end states must be the same
/// bits. Returns whether the method persists at all (`false`: not supported yet; nothing
/// compared).
fn restart(scene: &Scene, m: &MethodSpec, h: f64, n: usize, k: usize) -> bool {
    restart_checked(scene, m, h, n, k, |_| ())
}

/// [`restart`], with `at_k` called on the synchronized state at the checkpoint (to check
/// that what the test is about — plasticity, say — has happened by then).
fn restart_checked(
    scene: &Scene,
    m: &MethodSpec,
    h: f64,
    n: usize,
    k: usize,
    check_at_k: impl Fn(&State),
) -> bool {
    let sys = Interp::new(scene).expect("interpretable");
    let start = State::initial(&sys);
    let mut end_a = start.clone();
    let mut a = integrators::make(m, &sys, h, &start).expect("starts");
    for _ in 0..n {
        a.step(&sys).expect("steps");
    }
    a.state(&sys, &mut end_a);

    let mut b = integrators::make(m, &sys, h, &start).expect("starts");
    for _ in 0..k {
        b.step(&sys).expect("steps");
    }
    let mut at_k = start.clone();
    b.state(&sys, &mut at_k);
    at_k.active.copy_from_slice(b.active());
    check_at_k(&at_k);
    let mut saver = Saver::new();
    if !b.persist(&mut saver) {
        return false;
    }
    let bytes = saver.into_bytes();
    drop(b);

    // made from the synchronized state at step k (as a run restarts), and from the initial
    // state: the second shows a value the checkpoint leaves out even where the method would
    // derive it again from the restart state (the scenes here do not make every such value
    // differ: a partition chosen afresh, a tolerance from positions within 1 m)
    for (from, what) in [
        (&at_k, "the state at step k"),
        (&start, "the initial state"),
    ] {
        let mut c = integrators::make(m, &sys, h, from).expect("starts from the checkpoint");
        let mut loader = Loader::new(&bytes);
        assert!(c.persist(&mut loader));
        loader.finish().expect("loads");
        for _ in k..n {
            c.step(&sys).expect("steps");
        }
        let mut end_c = start.clone();
        c.state(&sys, &mut end_c);
        let (ba, bc) = (bits(&end_a), bits(&end_c));
        assert_eq!(ba.len(), bc.len());
        if let Some(i) = ba.iter().zip(&bc).position(|(x, y)| x != y) {
            panic!(
                "{} on {}, made from {what} and loaded: the restarted run differs at value {i} of the end state: {} vs {}",
                m.name(),
                scene.name,
                f64::from_bits(ba[i]),
                f64::from_bits(bc[i])
            );
        }
    }
    true
}

const METHODS: [&str; 6] = [
    "staggered",
    "baumgarte",
    "penalty",
    "coordinate_partitioning",
    "natural_partitioning",
    "implicit_trapezoid",
];

#[test]
fn rigid_scenes_restart_bitwise_with_every_method_that_persists() {
    let mut persisted = Vec::new();
    for model in [
        "double_pendulum_3d.mbd",
        "four_bar.mbd",
        "deployment_arm.mbd",
    ] {
        let scene = load_model(model);
        for name in METHODS {
            if restart(&scene, &method(name), scene.simulate.step, 300, 137) {
                persisted.push(name);
            }
        }
    }
    // every method persists, on every scene
    assert_eq!(persisted.len(), 3 * METHODS.len(), "{persisted:?}");
}

#[test]
fn beams_restart_bitwise() {
    let scene = load_model("cantilever.mbd");
    assert!(restart(
        &scene,
        &method("staggered"),
        scene.simulate.step,
        400,
        173
    ));
}

/// Subcycled beams (`beam_substeps`) restart bitwise too: the substeps' multipliers, the
/// nodes' secant velocities and the velocities one substep back are persisted.
#[test]
fn subcycled_beams_restart_bitwise() {
    let scene = load_model("arm_probe.mbd");
    assert!(restart(
        &scene,
        &scene.simulate.method,
        scene.simulate.step,
        300,
        117
    ));
}

#[test]
fn a_checkpoint_of_another_method_is_refused_by_name() {
    let scene = load_model("double_pendulum_3d.mbd");
    let sys = Interp::new(&scene).unwrap();
    let start = State::initial(&sys);
    let h = scene.simulate.step;
    let mut b = integrators::make(&method("staggered"), &sys, h, &start).unwrap();
    let mut saver = Saver::new();
    assert!(b.persist(&mut saver));
    let bytes = saver.into_bytes();
    // the chain has other bodies: the lengths differ, the loader names the item
    let chain = load_model("chain.mbd");
    let sys2 = Interp::new(&chain).unwrap();
    let mut c = integrators::make(&method("staggered"), &sys2, h, &State::initial(&sys2)).unwrap();
    let mut l = Loader::new(&bytes);
    c.persist(&mut l);
    let e = l.finish().unwrap_err().to_string();
    assert!(e.contains("another scene"), "{e}");
}

#[test]
fn an_elastic_mesh_restarts_bitwise() {
    // a hexahedral bar under a step traction: the wave is still travelling at the checkpoint
    let scene = load_model("hex_bar.mbd");
    assert!(restart_checked(
        &scene,
        &method("staggered"),
        scene.simulate.step,
        700,
        311,
        |s| assert!(s.mesh.energy.external_work > 0.0, "loaded by then"),
    ));
}

#[test]
fn a_plastic_mesh_restarts_bitwise_after_yield() {
    // the bars yield at ≈ 7 ms (the load passes 250 MPa of its 300 MPa on its smoothstep
    // over 10 ms; 1 µs steps): checkpoint at 8 ms, with plastic flow under way, end at 9 ms
    let scene = load_model("plastic_bar.mbd");
    assert!(restart_checked(
        &scene,
        &method("staggered"),
        scene.simulate.step,
        9000,
        8000,
        |s| {
            let yielded = s.mesh.plastic.iter().flat_map(|p| &p.equivalent);
            assert!(
                yielded.fold(0.0f64, |a, &e| a.max(e)) > 0.0,
                "the bars have yielded at the checkpoint"
            );
            assert!(s.mesh.energy.plastic > 0.0);
        },
    ));
}

#[test]
fn a_tied_mesh_restarts_bitwise_with_every_method_that_ties() {
    // a panel tied to a swinging arm: the ties' wrenches and the rigid method's state both
    // carry over; the methods that do not tie meshes are refused by `make`
    let scene = load_model("mesh_on_pendulum.mbd");
    let sys = Interp::new(&scene).expect("interpretable");
    let start = State::initial(&sys);
    let h = scene.simulate.step;
    let mut tied = Vec::new();
    for name in METHODS {
        let m = method(name);
        if integrators::make(&m, &sys, h, &start).is_err() {
            continue;
        }
        assert!(
            restart_checked(&scene, &m, h, 1200, 517, |s| assert!(
                s.mesh.energy.tie_work != 0.0,
                "the ties work by then"
            )),
            "{name} does not persist with meshes"
        );
        tied.push(name);
    }
    assert!(tied.len() >= 4, "{tied:?}");
}

/// The implicit mesh analyses (`mesh_method newmark`, `static`) restart bitwise: Newmark
/// with its displacement, velocity and acceleration, loads and energy accumulators; static
/// with its load history and Clapeyron work. Reference: the run made straight through;
/// tolerance: none (bit equality).
#[test]
fn implicit_mesh_analyses_restart_bitwise() {
    for (model, n, k) in [
        ("cantilever_newmark.mbd", 60, 23),
        ("cantilever_static.mbd", 10, 4),
    ] {
        let mut scene = load_model(model);
        // enough step times for a checkpoint in the middle
        scene.simulate.duration = scene.simulate.step * n as f64;
        assert!(
            restart_checked(
                &scene,
                &method("staggered"),
                scene.simulate.step,
                n,
                k,
                |s| assert!(
                    s.mesh.energy.external_work != 0.0,
                    "{model}: loaded by then"
                ),
            ),
            "{model}: the implicit analysis does not persist"
        );
    }
}

/// `state_time` restarts bitwise inside a window and at a window's end: the checkpoint
/// holds the state the window started from, and the restart solves that window again (the
/// same Newton iterations on the same numbers) before going on. Reference: the run made
/// straight through over three windows of 64 elements × 4 steps; tolerance: none.
#[test]
fn state_time_restarts_bitwise_inside_a_window() {
    let scene = load_model("state_time_double_pendulum.mbd");
    for k in [300, 256, 1] {
        assert!(
            restart(&scene, &scene.simulate.method, scene.simulate.step, 600, k),
            "state_time does not persist"
        );
    }
}
