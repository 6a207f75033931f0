//! `mbdc check --topology` prints the spanning tree, the cut joints and the independent
//! coordinates of natural partitioning per joint; `mbdc check --partition P` splits the
//! meshes and prints the partition metrics.

use std::process::Command;

#[test]
fn topology_of_the_slider_crank() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/slider_crank.mbd");
    let out = Command::new(env!("CARGO_BIN_EXE_mbdc"))
        .args(["check", model, "--topology"])
        .output()
        .expect("mbdc runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "topology of slider_crank: 3 bodies, 4 joints (3 tree, 1 cut, 0 other)",
        "crank  via pivot (revolute, 1 dof: rotation about z)",
        "wrist (universal, 4 rows) between rod and slider",
        "loops: 1",
        "natural partitioning (independent coordinates per joint):",
        "rod via pin (spherical): 3 — ω_x, ω_y, ω_z of the child (body axes)",
        "total: 5 independent coordinates; 4 cut rows",
    ] {
        assert!(text.contains(needle), "missing {needle:?} in\n{text}");
    }
}

#[test]
fn topology_of_a_parametrized_tree() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/bench/tree8.mbd");
    let out = Command::new(env!("CARGO_BIN_EXE_mbdc"))
        .args(["check", model, "--set", "N=16", "--topology"])
        .output()
        .expect("mbdc runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    // a hub and 8 arms of 2 links: 9 branches in 2 levels, 17 × 3 coordinates
    assert!(text.contains("branches: 9 in 2 levels"), "{text}");
    assert!(
        text.contains("total: 51 independent coordinates; 0 cut rows"),
        "{text}"
    );
}

/// The plate of models/plate.mbd (20 × 4 quads) in 4 parts: bisection cuts it into four
/// 5 × 4 blocks across x. Exact: 15 interface nodes (3 lines of 5), 20 elements per part,
/// 2 neighbours at most, the end blocks with 4 elements on the periphery and the middle
/// ones 8, Σ incidence 30 and P_cm = 2 × 30.
#[test]
fn partition_of_the_plate() {
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/plate.mbd");
    let run = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_mbdc"))
            .args(["check", model])
            .args(extra)
            .env("NO_COLOR", "1")
            .output()
            .expect("mbdc runs")
    };
    let out = run(&["--partition", "4"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    for expected in [
        "into 4 parts (recursive coordinate bisection)",
        "elements per part        20 (largest / mean 1.000)",
        "interface nodes          15 of 105",
        "bandwidth (most of any part) 2",
        "elements on the periphery 4–8 per part",
        "Σ incidence 30; P_cm = 2 × 30 = 60",
    ] {
        assert!(text.contains(expected), "{expected:?} not in\n{text}");
    }
    // more parts than elements, zero parts, a scene without meshes: one clear error each
    let e = run(&["--partition", "81"]);
    assert!(!e.status.success());
    assert!(
        String::from_utf8_lossy(&e.stderr)
            .contains("has 80 elements: it cannot be split into 81 parts"),
        "{}",
        String::from_utf8_lossy(&e.stderr)
    );
    assert!(!run(&["--partition", "0"]).status.success());
    let rigid = Command::new(env!("CARGO_BIN_EXE_mbdc"))
        .args([
            "check",
            concat!(env!("CARGO_MANIFEST_DIR"), "/../models/pendulum.mbd"),
            "--partition",
            "2",
        ])
        .output()
        .expect("mbdc runs");
    assert!(!rigid.status.success());
    assert!(String::from_utf8_lossy(&rigid.stderr).contains("has none"));
}
