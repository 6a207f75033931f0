//! Every scene in models/ checks with no errors and no warnings, and the rigid-body
//! models start exactly on their constraints, positions and velocities.

use std::path::{Path, PathBuf};

fn models() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("models/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "mbd"))
        .collect();
    v.sort();
    v
}

#[test]
fn every_model_checks() {
    let files = models();
    assert!(
        files.len() >= 10,
        "expected at least 10 models, found {}",
        files.len()
    );
    for f in files {
        let loaded = mbdc_compiler::load_file(&f, &[]);
        let bad: Vec<_> = loaded
            .diagnostics
            .iter()
            .filter(|d| d.severity != mbdc_compiler::Severity::Note)
            .collect();
        assert!(
            bad.is_empty(),
            "{}:\n{}",
            f.display(),
            loaded.render_plain()
        );
        let scene = loaded.scene.expect("a scene");
        let summary = mbdc_compiler::summary(&scene);
        for j in &summary.joints {
            assert!(
                j.position_violation < 1e-12,
                "{}: joint {} position residual {}",
                f.display(),
                j.name,
                j.position_violation
            );
            assert!(
                j.velocity_violation < 1e-8,
                "{}: joint {} velocity residual {}",
                f.display(),
                j.name,
                j.velocity_violation
            );
        }
        if let Some((rank, rows)) = summary.jacobian_rank {
            assert_eq!(rank, rows, "{}: redundant constraints", f.display());
        }
    }
}

#[test]
fn chain_scales_with_its_parameter() {
    let f = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/chain.mbd");
    let o: mbdc_compiler::Override = "N=200".parse().unwrap();
    let loaded = mbdc_compiler::load_file(&f, &[o]);
    let scene = loaded.scene.expect("a scene");
    assert_eq!(scene.bodies.len(), 200);
    assert_eq!(scene.joints.len(), 200);
    assert!(scene
        .params
        .iter()
        .any(|p| p.name == "N" && p.value == 200.0 && p.overridden));
}

#[test]
fn model_numbers() {
    let load = |name: &str| {
        let f = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../models")
            .join(name);
        mbdc_compiler::load_file(&f, &[]).scene.expect("a scene")
    };
    // Bowling ball: mass from the weight, sphere inertia, rolling velocities.
    let b = load("bowling_ball.mbd");
    let m = 71.32 / 9.81;
    assert!((b.bodies[0].mass - m).abs() < 1e-12);
    assert!((b.bodies[0].inertia[2][2] - 0.4 * m * 0.109 * 0.109).abs() < 1e-12);
    assert!(
        (b.bodies[0].velocity[0] - 0.109).abs() < 1e-12
            && (b.bodies[0].velocity[1] - 0.109).abs() < 1e-12
    );
    // Slider crank: one cycle of 0.82 s in 82 steps.
    let s = load("slider_crank.mbd");
    assert_eq!(s.simulate.step, 0.01);
    assert!((s.bodies[0].angular_velocity[2] - 7.66).abs() < 1e-12);
    // Torque-free body: angular velocity in body components.
    let t = load("torque_free.mbd");
    assert_eq!(t.bodies[0].angular_velocity, [0.01, 2.0, 0.0]);
    // Cantilever section: EI3 = 350 N m².
    let c = load("cantilever.mbd");
    assert!((c.beams[0].section.ei3 - 350.0).abs() < 1e-9);
    assert_eq!(c.beams[0].nodes.len(), 21);
}

/// The runtime's own constraint kernels agree that the rigid models start on their joints
/// (so the compiler's frame conventions match the runtime's), and that the constraint
/// Jacobian has the rank `mbdc check` reports.
#[test]
fn runtime_kernels_agree_with_the_check() {
    use mbdc_runtime::interp::Interp;
    use mbdc_runtime::system::{ConstraintEval, Need, Pose, RowKind, System, Twist};
    let mut checked = 0;
    for f in models() {
        let scene = mbdc_compiler::load_file(&f, &[]).scene.expect("a scene");
        let Ok(sys) = Interp::new(&scene) else {
            continue;
        };
        let layout = sys.layout().clone();
        let n = layout.bodies();
        let mut pose = vec![Pose::default(); n];
        let mut twist = vec![Twist::default(); n];
        sys.initial_state(&mut pose, &mut twist);
        let mut ev = ConstraintEval::new(layout.rows);
        sys.constraints(0.0, &pose, &twist, Need::ALL, &mut ev);
        let mut active_rows = Vec::new();
        for j in &layout.joints {
            if j.starts_inactive {
                continue;
            }
            for r in j.first_row..j.first_row + j.rows {
                active_rows.push(r);
                let (a, b) = (j.a, j.b);
                let mut vel = ev.bias[r];
                for k in 0..3 {
                    if let Some(a) = a {
                        vel += ev.jac[r].a[k] * twist[a].v[k] + ev.jac[r].a[k + 3] * twist[a].w[k];
                    }
                    if let Some(b) = b {
                        vel += ev.jac[r].b[k] * twist[b].v[k] + ev.jac[r].b[k + 3] * twist[b].w[k];
                    }
                }
                if layout.row_kind[r] == RowKind::Holonomic {
                    assert!(
                        ev.phi[r].abs() < 1e-12,
                        "{}: joint {} row {r}: Φ = {}",
                        f.display(),
                        j.name,
                        ev.phi[r]
                    );
                }
                assert!(
                    vel.abs() < 1e-9,
                    "{}: joint {} row {r}: Φ̇ = {vel}",
                    f.display(),
                    j.name
                );
            }
        }
        // Rank of the runtime's Jacobian (active rows) equals the check's.
        let mut jac = nalgebra::DMatrix::<f64>::zeros(active_rows.len(), 6 * n);
        for (i, &r) in active_rows.iter().enumerate() {
            let (a, b) = layout.row_bodies(r);
            for k in 0..6 {
                if let Some(a) = a {
                    jac[(i, 6 * a + k)] += ev.jac[r].a[k];
                }
                if let Some(b) = b {
                    jac[(i, 6 * b + k)] += ev.jac[r].b[k];
                }
            }
        }
        if let Some((rank, rows)) = mbdc_compiler::summary(&scene).jacobian_rank {
            assert_eq!(rows, active_rows.len(), "{}", f.display());
            if rows > 0 {
                let sv = jac.svd(false, false).singular_values;
                let smax = sv.iter().fold(0.0f64, |m, x| m.max(*x));
                let runtime_rank = sv.iter().filter(|x| **x > 1e-7 * smax).count();
                assert_eq!(runtime_rank, rank, "{}: Jacobian rank", f.display());
            }
        }
        checked += 1;
    }
    assert!(checked >= 7, "only {checked} models could be interpreted");
}
