//! Meshes tied to bodies (`tie SET, BODY`): master–slave kinematic coupling of a node set
//! to a rigid body, laid out once before a run (docs/methods.md, "Meshes tied to bodies").
//!
//! A tied node moves rigidly with its body: its offset from the body's mass centre is fixed
//! in the body's axes as it is at t = 0. The mesh's net force on it acts on the body. Its
//! inertia belongs to the body, exactly: [`apply`] makes each body that carries tied nodes
//! one rigid body with their lumped masses,
//!
//! ```text
//! m' = m + Σ mᵢ,    c = Σ mᵢ sᵢ / m'     (sᵢ: node offsets from the body's mass centre, body axes)
//! J' = J + m(|c|²I − c cᵀ) + Σ mᵢ(|dᵢ|²I − dᵢdᵢᵀ),   dᵢ = sᵢ − c
//! ```
//!
//! whose reference point is the mass centre of the body *with* its nodes, `c` from the
//! body's own. Every integrator takes bodies with their reference point at the mass centre
//! (block-diagonal `M = diag(mI, J)`), so moving the reference point is what makes the
//! nodes' inertia exact — including the first-moment coupling `Σ mᵢ sᵢ` between the body's
//! translation and rotation, which inertia augmented about the body's own mass centre
//! would leave to an explicit (lagged) term. The composite scene has every body-frame point
//! of that body (joints, forces, contacts, beam attachments) moved by `−c`, its initial
//! position by `C₀c` and its initial velocity by `C₀(ω₀ × c)`. Nothing else changes: the
//! interpreter and the generated code (built from the interpreter's plan) both simulate the
//! composite scene, and every output is converted back to the body's own mass centre
//! ([`own_centre`]).
//!
//! In the mesh, a tied node is constrained in every component and has no mass (its mass is
//! the body's): the constraint's reaction is then minus the mesh's net force on the node,
//! which the integrator hands to the body.
//!
//! **Gravity.** The scene's gravity acts on bodies, not on mesh nodes (a mesh takes
//! `body_force`); the composite body's weight `m'g` includes the tied nodes' masses, so
//! each tied node gets the constant load `−mᵢ g` in the mesh, which the tie hands back to
//! the body: its weight is then its own, at its own mass centre, exactly.

use std::collections::HashMap;

use nalgebra::{Matrix3, Vector3};

use crate::analysis::mesh_model::MeshError;
use crate::contract::math::{quat, rotation, vec3};
use crate::contract::mesh_layout::{MeshLayout, MeshTie, TiedBody};
use crate::contract::scene::{Attachment, BodyRef, ForceKind, MeshCondition, Scene};
use crate::contract::system::{Pose, Twist};

/// Lay out the ties of `scene` in `l` (built by [`crate::analysis::mesh_model::build`]
/// from the same scene) and return the composite scene the system simulates (see the
/// module doc), or `None` when nothing is tied.
///
/// # Errors
/// A tie that refers to a body or set that does not exist, an empty set, a node tied
/// twice, a tied node that is also fixed or displaced, a 2-D mesh tied under a gravity
/// with a component out of its plane.
pub fn apply(scene: &Scene, l: &mut MeshLayout) -> Result<Option<Scene>, MeshError> {
    // The ties, in scene order, and every tied node once.
    let mut tied_by: HashMap<u32, usize> = HashMap::new();
    for (mi, m) in scene.meshes.iter().enumerate() {
        let err = |reason: String| MeshError {
            mesh: m.name.clone(),
            reason,
        };
        let Some(block) = l.blocks.get(mi) else {
            return Err(err("the mesh layout does not match the scene".into()));
        };
        let (first, plane) = (block.first_node, block.kind.dim() == 2);
        for c in &m.conditions {
            let MeshCondition::Tie { set, body } = *c else {
                continue;
            };
            let s = m.node_sets.get(set).ok_or_else(|| {
                err(format!(
                    "a tie refers to node set {set}, but the mesh has {} sets",
                    m.node_sets.len()
                ))
            })?;
            let b = scene.bodies.get(body).ok_or_else(|| {
                err(format!(
                    "tie '{}' refers to body index {body}, but the scene has {} bodies",
                    s.name,
                    scene.bodies.len()
                ))
            })?;
            if s.nodes.is_empty() {
                return Err(err(format!("tie '{}': the set is empty", s.name)));
            }
            // A tied node moves with its body: no other displacement condition on it.
            for other in &m.conditions {
                let (os, what) = match other {
                    MeshCondition::Fixed { set } => (*set, "fixed"),
                    MeshCondition::Displacement { set, value }
                        if value.iter().any(Option::is_some) =>
                    {
                        (*set, "displaced")
                    }
                    _ => continue,
                };
                let Some(o) = m.node_sets.get(os) else {
                    continue;
                };
                if let Some(n) = s.nodes.iter().find(|n| o.nodes.binary_search(n).is_ok()) {
                    return Err(err(format!(
                        "node {n} is tied to body '{}' (set '{}') and {what} (set '{}'): a tied node moves with its body",
                        b.name, s.name, o.name
                    )));
                }
            }
            if plane {
                if let Some(g) = scene.gravity.filter(|g| g[2] != 0.0) {
                    return Err(err(format!(
                        "tie '{}': the 2-D mesh lies in the plane z = 0 and its tied body must move in it, but the gravity ({}, {}, {}) has a component along z",
                        s.name, g[0], g[1], g[2]
                    )));
                }
            }
            let k = l.ties.len();
            let mut nodes = Vec::with_capacity(s.nodes.len());
            for &n in &s.nodes {
                let g = (first + n) as u32;
                if let Some(&prev) = tied_by.get(&g) {
                    if prev == k {
                        // the set lists the node twice (a scene file written by hand)
                        continue;
                    }
                    let p: &MeshTie = &l.ties[prev];
                    return Err(err(format!(
                        "node {n} is tied twice: by set '{}' to body '{}' and by set '{}' to body '{}'",
                        p.set, scene.bodies[p.body].name, s.name, b.name
                    )));
                }
                tied_by.insert(g, k);
                nodes.push(g);
            }
            l.ties.push(MeshTie {
                mesh: m.name.clone(),
                set: s.name.clone(),
                body,
                mass: nodes.iter().map(|&g| l.mass[g as usize]).collect(),
                offsets: Vec::new(),
                nodes,
                plane,
            });
        }
    }
    if l.ties.is_empty() {
        return Ok(None);
    }
    // The composite bodies.
    let mut out = scene_without_meshes(scene);
    let mut bodies: Vec<usize> = l.ties.iter().map(|t| t.body).collect();
    bodies.sort_unstable();
    bodies.dedup();
    for &bi in &bodies {
        let b = &scene.bodies[bi];
        let q = quat(b.orientation);
        let c0 = rotation(&(q / q.norm()));
        let r0 = vec3(&b.position);
        let offsets = |t: &MeshTie| -> Vec<Vector3<f64>> {
            t.nodes
                .iter()
                .map(|&g| c0.transpose() * (vec3(&l.x0[g as usize]) - r0))
                .collect()
        };
        let (mut mt, mut first_moment) = (0.0, Vector3::zeros());
        for t in l.ties.iter().filter(|t| t.body == bi) {
            for (s, m) in offsets(t).iter().zip(&t.mass) {
                mt += m;
                first_moment += s * *m;
            }
        }
        let total = b.mass + mt;
        let c = first_moment / total;
        let point = |m: f64, d: &Vector3<f64>| {
            m * (Matrix3::identity() * d.norm_squared() - d * d.transpose())
        };
        let mut j = Matrix3::from_fn(|r, k| b.inertia[r][k]) + point(b.mass, &c);
        for t in l.ties.iter_mut().filter(|t| t.body == bi) {
            let ds: Vec<Vector3<f64>> = offsets(t).iter().map(|s| s - c).collect();
            for (d, m) in ds.iter().zip(&t.mass) {
                j += point(*m, d);
            }
            t.offsets = ds.iter().map(|d| [d.x, d.y, d.z]).collect();
        }
        // symmetric to the last bit, as the interpreter checks
        let j = (j + j.transpose()) * 0.5;
        let w0 = vec3(&b.angular_velocity);
        let ob = &mut out.bodies[bi];
        ob.mass = total;
        ob.inertia = [
            [j[(0, 0)], j[(0, 1)], j[(0, 2)]],
            [j[(1, 0)], j[(1, 1)], j[(1, 2)]],
            [j[(2, 0)], j[(2, 1)], j[(2, 2)]],
        ];
        let r = r0 + c0 * c;
        let v = vec3(&b.velocity) + c0 * w0.cross(&c);
        ob.position = [r.x, r.y, r.z];
        ob.velocity = [v.x, v.y, v.z];
        l.tied_bodies.push(TiedBody {
            body: bi,
            shift: [c.x, c.y, c.z],
            own_mass: b.mass,
            tied_mass: mt,
        });
    }
    // Every body-frame point of a composite body, from its new reference point.
    let shift: HashMap<usize, Vector3<f64>> = l
        .tied_bodies
        .iter()
        .map(|t| (t.body, Vector3::from(t.shift)))
        .collect();
    let mv = |a: &mut Attachment| {
        if let BodyRef::Body(i) = a.body {
            if let Some(c) = shift.get(&i) {
                a.point = [a.point[0] - c.x, a.point[1] - c.y, a.point[2] - c.z];
            }
        }
    };
    for j in &mut out.joints {
        mv(&mut j.a);
        mv(&mut j.b);
    }
    for f in &mut out.forces {
        match &mut f.kind {
            ForceKind::Point { at, .. } => mv(at),
            ForceKind::Spring { a, b, .. } => {
                mv(a);
                mv(b);
            }
            ForceKind::Torque { .. } | ForceKind::RotationalSpring { .. } => {}
        }
    }
    for c in &mut out.contacts {
        mv(&mut c.a.0);
        mv(&mut c.b.0);
    }
    for b in &mut out.beams {
        for a in &mut b.attachments {
            mv(&mut a.to);
        }
    }
    // The tied nodes: no mass in the mesh, constrained, and their weight counted once.
    let g = scene
        .gravity
        .map(|g| vec3(&g))
        .filter(|g| *g != Vector3::zeros());
    if g.is_some() && l.body_force.is_empty() {
        l.body_force = vec![[0.0; 3]; l.x0.len()];
    }
    for t in &l.ties {
        for (&n, &m) in t.nodes.iter().zip(&t.mass) {
            let n = n as usize;
            l.mass[n] = 0.0;
            l.constrained[n] = [true; 3];
            if let Some(g) = g {
                for k in 0..3 {
                    l.body_force[n][k] -= m * g[k];
                }
            }
        }
    }
    Ok(Some(out))
}

/// The pose and twist of a tied body's own mass centre from the system's pose `p` and
/// twist `t` of the body (at the mass centre of body and tied nodes): `r − C·shift`,
/// `v − C(ω × shift)`; the orientation and ω (body axes) are the same.
pub fn own_centre(tb: &TiedBody, p: &Pose, t: &Twist) -> (Pose, Twist) {
    let c = Vector3::from(tb.shift);
    let mut o = *p;
    o.r = p.r - p.c * c;
    (
        o,
        Twist {
            v: t.v - p.c * t.w.cross(&c),
            w: t.w,
        },
    )
}

/// A copy of `scene` without its meshes (they can be large, and the system's layout has
/// them already).
fn scene_without_meshes(scene: &Scene) -> Scene {
    Scene {
        name: scene.name.clone(),
        gravity: scene.gravity,
        bodies: scene.bodies.clone(),
        joints: scene.joints.clone(),
        forces: scene.forces.clone(),
        beams: scene.beams.clone(),
        meshes: Vec::new(),
        contacts: scene.contacts.clone(),
        simulate: scene.simulate.clone(),
        reference: scene.reference.clone(),
        params: scene.params.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::mesh_model::build;
    use crate::contract::scene::{
        Body, ElementKind, Joint, JointKind, Material, Mesh, MeshFormulation, NodeSet, Origin,
        Simulate,
    };

    /// A bar2 mesh of 2 elements along x from (1, 0, 0) to (3, 0, 0) (lumped masses
    /// ρA·(0.5, 1, 0.5) = 1, 2, 1 kg with ρA = 2 kg/m), node 0 tied to a body of 2 kg at
    /// the origin turned by 90° about z, which a spherical joint holds at (0, 1, 0).
    fn scene(conditions: Vec<MeshCondition>) -> Scene {
        let half = std::f64::consts::FRAC_1_SQRT_2;
        Scene {
            name: "t".into(),
            gravity: Some([0.0, 0.0, -10.0]),
            bodies: vec![Body {
                name: "hub".into(),
                mass: 2.0,
                inertia: [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]],
                position: [0.0, 0.0, 0.0],
                orientation: [half, 0.0, 0.0, half],
                velocity: [0.0, 0.0, 0.0],
                angular_velocity: [0.0, 0.0, 1.0],
                origin: Origin::default(),
            }],
            joints: vec![Joint {
                name: "pin".into(),
                kind: JointKind::Spherical,
                a: Attachment {
                    body: BodyRef::Ground,
                    point: [0.0, 1.0, 0.0],
                    frame: [1.0, 0.0, 0.0, 0.0],
                },
                b: Attachment {
                    body: BodyRef::Body(0),
                    point: [1.0, 0.0, 0.0],
                    frame: [1.0, 0.0, 0.0, 0.0],
                },
                origin: Origin::default(),
            }],
            forces: vec![],
            beams: vec![],
            meshes: vec![Mesh {
                name: "bar".into(),
                kind: ElementKind::Bar2,
                material: Material {
                    e: 1e9,
                    nu: 0.3,
                    rho: 2000.0,
                    plastic: None,
                },
                thickness: 1e-3,
                nodes: vec![[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0]],
                elements: vec![vec![0, 1], vec![1, 2]],
                node_sets: vec![
                    NodeSet {
                        name: "root".into(),
                        nodes: vec![0],
                        faces: vec![],
                    },
                    NodeSet {
                        name: "all".into(),
                        nodes: vec![0, 1, 2],
                        faces: vec![],
                    },
                ],
                conditions,
                formulation: MeshFormulation::default(),
                origin: Origin::default(),
            }],
            contacts: vec![],
            simulate: Simulate::default(),
            reference: None,
            params: vec![],
        }
    }

    fn apply_to(s: &Scene) -> Result<(Option<Scene>, MeshLayout), MeshError> {
        let mut l = build(&s.meshes).expect("a valid mesh");
        apply(s, &mut l).map(|c| (c, l))
    }

    /// The composite of the body (2 kg, J = diag(1, 2, 3) about its centre) and node 0
    /// (1 kg at world (1, 0, 0): body axes (0, −1, 0), the body turned by 90° about z):
    /// 3 kg with its centre c = (0, −1/3, 0) in body axes (world (1/3, 0, 0)); inertia about
    /// it `J + 2(|c|²I − ccᵀ) + 1(|d|²I − ddᵀ)`, d = (0, −2/3, 0): diag(1 + 2/9 + 4/9, 2,
    /// 3 + 2/9 + 4/9). The joint's body point moves by −c, the initial velocity by
    /// C₀(ω₀ × c) = (0, 1/3, 0); the node has no mass in the mesh, is constrained, and
    /// carries −m g = (0, 0, 10) N. Without ties nothing changes.
    #[test]
    fn a_tied_node_becomes_part_of_its_body() {
        let s = scene(vec![MeshCondition::Tie { set: 0, body: 0 }]);
        let (c, l) = apply_to(&s).expect("valid");
        let c = c.expect("a composite");
        let b = &c.bodies[0];
        let close = |a: f64, b: f64| (a - b).abs() < 1e-14;
        assert!(close(b.mass, 3.0));
        let j = b.inertia;
        assert!(close(j[0][0], 1.0 + 6.0 / 9.0) && close(j[1][1], 2.0));
        assert!(close(j[2][2], 3.0 + 6.0 / 9.0));
        assert!(j[0][1].abs() < 1e-15 && j[0][2].abs() < 1e-15 && j[1][2].abs() < 1e-15);
        assert!(close(b.position[0], 1.0 / 3.0) && b.position[1].abs() < 1e-15);
        assert!(b.velocity[0].abs() < 1e-15 && close(b.velocity[1], 1.0 / 3.0));
        let p = c.joints[0].b.point;
        assert!(close(p[0], 1.0) && close(p[1], 1.0 / 3.0));
        assert!(c.meshes.is_empty());
        let t = &l.ties[0];
        assert_eq!(
            (t.body, t.nodes.clone(), t.mass.clone()),
            (0, vec![0], vec![1.0])
        );
        assert!(close(t.offsets[0][1], -2.0 / 3.0) && t.offsets[0][0].abs() < 1e-15);
        let tb = l.tied_bodies[0];
        assert!(close(tb.shift[1], -1.0 / 3.0) && close(tb.tied_mass, 1.0));
        assert_eq!((l.mass[0], l.mass[1]), (0.0, 2.0));
        assert_eq!(l.constrained[0], [true; 3]);
        assert_eq!(l.body_force[0], [0.0, 0.0, 10.0]);
        assert_eq!(l.body_force[1], [0.0; 3]);
        // the own-centre conversion undoes the shift
        let pose = Pose::new(vec3(&b.position), quat(b.orientation));
        let tw = Twist {
            v: vec3(&b.velocity),
            w: vec3(&b.angular_velocity),
        };
        let (op, ot) = own_centre(&tb, &pose, &tw);
        assert!(op.r.norm() < 1e-15 && ot.v.norm() < 1e-15);
        assert_eq!(apply_to(&scene(vec![])).expect("valid").0, None);
    }

    /// A scene file whose tied set lists a node twice (the fuzz test's find: it indexed the
    /// tie being built and panicked) ties the node once.
    #[test]
    fn a_set_that_lists_a_node_twice_ties_it_once() {
        let mut s = scene(vec![MeshCondition::Tie { set: 0, body: 0 }]);
        s.meshes[0].node_sets[0].nodes = vec![0, 0];
        let (_, l) = apply_to(&s).expect("valid");
        assert_eq!(l.ties[0].nodes, vec![0]);
        assert_eq!(l.ties[0].mass, vec![1.0]);
    }

    /// What the compiler reports with spans is refused here too (scenes from JSON): a tie to
    /// a body that does not exist, a tied node also fixed or displaced, a node tied twice.
    #[test]
    fn inconsistent_ties_are_refused() {
        let cases = [
            (
                vec![MeshCondition::Tie { set: 0, body: 3 }],
                "refers to body index 3",
            ),
            (
                vec![
                    MeshCondition::Fixed { set: 1 },
                    MeshCondition::Tie { set: 0, body: 0 },
                ],
                "node 0 is tied to body 'hub' (set 'root') and fixed (set 'all')",
            ),
            (
                vec![
                    MeshCondition::Tie { set: 0, body: 0 },
                    MeshCondition::Tie { set: 1, body: 0 },
                ],
                "node 0 is tied twice",
            ),
        ];
        for (conditions, expected) in cases {
            let err = apply_to(&scene(conditions)).expect_err("refused");
            assert!(err.reason.contains(expected), "{err}");
            assert_eq!(err.mesh, "bar");
        }
    }
}
