//! The independent coordinates natural partitioning uses for a scene, per tree joint: what
//! `mbdc check --topology` prints after the topology.

use crate::analysis::topology::Topology;
use crate::contract::scene::Scene;
use crate::contract::system::JointKernel;

/// The independent coordinates natural partitioning uses for a scene, one line per tree
/// joint (in the tree's parent-before-child order) and per free root, then the totals:
/// what `mbdc check --topology` prints after [`Topology::render`].
pub fn coordinates_report(scene: &Scene, topo: &Topology) -> String {
    use std::fmt::Write as _;
    let mut s = String::from("natural partitioning (independent coordinates per joint):\n");
    let name = |b: usize| scene.bodies.get(b).map_or("?", |x| x.name.as_str());
    for &b in &topo.order {
        match topo.tree_joint(b) {
            Some(tj) => {
                let j = &scene.joints[tj.joint];
                let kernel = JointKernel::of(&j.kind);
                let (n, what) = kernel
                    .tree_dof()
                    .map_or((0, "?"), |n| (n, kernel.rate_names()));
                let _ = writeln!(
                    s,
                    "  {} via {} ({}): {n} — {what}",
                    name(b),
                    j.name,
                    j.kind.keyword()
                );
            }
            None => {
                let _ = writeln!(
                    s,
                    "  {} (free root): 6 — v_x, v_y, v_z (world), ω_x, ω_y, ω_z (body axes)",
                    name(b)
                );
            }
        }
    }
    let cut_rows: usize = topo
        .cut_joints
        .iter()
        .chain(&topo.extra_joints)
        .map(|&j| scene.joints[j].kind.rows())
        .sum();
    let _ = writeln!(
        s,
        "  total: {} independent coordinates; {} cut rows ({} cut joints, {} other constraints) by staggered stabilization",
        topo.dof.tree,
        cut_rows,
        topo.cut_joints.len(),
        topo.extra_joints.len()
    );
    s
}
