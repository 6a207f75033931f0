//! `mbdc check --topology` prints the spanning tree, the cut joints and the independent
//! coordinates of natural partitioning per joint.

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
