//! The explicit mesh method across ranks (issue 17, check 4): every rank runs its part of
//! the meshes and exchanges the interface forces each step, and the motion is **bitwise**
//! that of the whole mesh in one process — displacements, velocities, element stresses and
//! strains and the plastic state at every frame — for 2, 3 and 4 ranks. The ranks here are
//! threads of one process (`ThreadRanks`); `cli/tests/mpi.rs` runs the same over Open MPI.
//! The energies are sums over the ranks in rank order, so they agree with the one-process
//! sums to round-off (1e-12 of the energy in play), not bitwise.

use mbdc_tests::*;

fn assert_same(name: &str, one: &Trajectory, ranked: &Trajectory, ranks: usize) {
    assert!(one.report.finished, "{name}: {:?}", one.report.failure);
    assert!(
        ranked.report.finished,
        "{name} on {ranks} ranks: {:?}",
        ranked.report.failure
    );
    assert_eq!(one.frames.len(), ranked.frames.len(), "{name}: frames");
    assert_eq!(one.report.steps, ranked.report.steps);
    let bits = |v: &[[f64; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    let bits6 = |v: &[[f64; 6]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (k, (a, b)) in one.frames.iter().zip(&ranked.frames).enumerate() {
        let (a, b) = (&a.mesh, &b.mesh);
        assert!(
            bits(&a.u) == bits(&b.u),
            "{name}, {ranks} ranks, frame {k}: u differs"
        );
        assert!(
            bits(&a.v) == bits(&b.v),
            "{name}, {ranks} ranks, frame {k}: v differs"
        );
        assert!(
            bits6(&a.stress) == bits6(&b.stress),
            "{name}, {ranks} ranks, frame {k}: stress"
        );
        assert!(
            bits6(&a.strain) == bits6(&b.strain),
            "{name}, {ranks} ranks, frame {k}: strain"
        );
        assert!(
            bits6(&a.plastic_strain) == bits6(&b.plastic_strain),
            "{name}, {ranks} ranks, frame {k}: plastic strain"
        );
        let (ea, eb) = (a.energy, b.energy);
        let scale = ea.kinetic.abs() + ea.strain.abs() + ea.external_work.abs() + 1e-30;
        for (what, x, y) in [
            ("kinetic", ea.kinetic, eb.kinetic),
            ("strain", ea.strain, eb.strain),
            ("external work", ea.external_work, eb.external_work),
            ("plastic", ea.plastic, eb.plastic),
            ("hourglass", ea.hourglass, eb.hourglass),
        ] {
            assert!(
                (x - y).abs() <= 1e-12 * scale,
                "{name}, {ranks} ranks, frame {k}: {what} {x} vs {y}"
            );
        }
    }
}

/// Runs `file` for `duration` in one process and on 2, 3, 4 ranks; returns the one-process
/// run's last mesh energies (for the test to check that something happened).
fn check_model(file: &str, duration: f64, every: u32) -> mbdc_runtime::integrators::MeshEnergy {
    let scene = load_model(file);
    let h = scene.simulate.step;
    let m = method("staggered");
    let one = simulate(&scene, m.clone(), h, duration, every);
    for ranks in [2, 3, 4] {
        let ranked = simulate_on_ranks(&scene, m.clone(), h, duration, every, ranks);
        assert_same(file, &one, &ranked, ranks);
    }
    one.last().mesh.energy
}

/// A quad4 plate with a hole, imported from Gmsh, under a ramped traction.
#[test]
fn plate_with_a_hole_on_ranks_is_bitwise_the_one_process_run() {
    let e = check_model("plate_hole.mbd", 4e-5, 20);
    assert!(e.strain > 0.0 && e.kinetic > 0.0, "{e:?}");
}

/// A hex8 bar (one-point integration with hourglass control) under a step traction.
#[test]
fn hex_bar_on_ranks_is_bitwise_the_one_process_run() {
    let e = check_model("hex_bar.mbd", 1e-4, 50);
    assert!(e.strain > 0.0 && e.kinetic > 0.0, "{e:?}");
}

/// Elastoplastic hex8 and bar2 bars (J2 return mapping, two element blocks) past yield.
#[test]
fn plastic_bars_on_ranks_are_bitwise_the_one_process_run() {
    let scene = load_model("plastic_bar.mbd");
    let d = scene.simulate.duration;
    let e = check_model("plastic_bar.mbd", d * 0.45, 500);
    assert!(e.plastic > 0.0, "the bars have yielded: {e:?}");
}
