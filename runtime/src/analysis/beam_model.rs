//! Beams as bodies: a scene's flexible beams turned into what the integrators advance.
//!
//! Notes B §3.1: a beam is a chain of nodes, each with a position, an orientation and the
//! lumped translational mass and rotary inertia of its half-elements. [`expand`] makes each
//! node a body of the scene (named `BEAM.node[k]`, appended after the scene's bodies), each
//! `clamp` a `fixed` joint and each `pin` a `spherical` joint (named `BEAM.clamp[k]`,
//! `BEAM.pin[k]`, appended after the scene's joints), and records in a [`BeamLayout`] which
//! bodies each element joins. What is left for the integrator is the elements' internal force
//! between consecutive nodes ([`crate::kernels::beam_element`]).
//!
//! **Node frames.** A node's body frame is its cross-section frame: axis 1 along the beam
//! (at an interior node of a polyline, the bisector of its two elements), axis 2 along the
//! beam's `up` made perpendicular to axis 1, axis 3 = axis 1 × axis 2. The element kernel
//! takes whatever sections the initial configuration has as unstrained.
//!
//! **Lumped inertia.** A node carries `ρA ℓ/2` and `s·ρJ ℓ/2` of each element it belongs to
//! (notes B (3.25), ρ counted once), where `ρJ = diag(ρI₁, ρA·EI₂/EA, ρA·EI₃/EA)` and `s`
//! is the beam's `rotary_inertia_scale`.
//!
//! **Attachments.** A clamp holds the node's frame where it is at t = 0 relative to the
//! body (or the ground), at the attachment point; a pin holds the point only.
//!
//! Knows the contract and the element kernel's section and lumped mass; no integrator.

use nalgebra::{Matrix3, Vector3};

use crate::contract::math::{qconj, qmul, quat, quat_array, quat_from_rotation, vec3};
use crate::contract::scene::{Attachment, Body, BodyRef, Joint, JointKind, Origin, Scene};
use crate::contract::system::{BeamElementLayout, BeamInfo, BeamLayout};
use crate::kernels::beam_element::{lumped_mass, BeamSection};

/// Components of a vector as an array.
fn arr(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// A scene with its beams made bodies and joints, and the elements between them.
#[derive(Clone, Debug, PartialEq)]
pub struct Expanded {
    /// The scene without beams: its bodies followed by every beam's nodes, its joints
    /// followed by every beam's attachments.
    pub scene: Scene,
    /// The beams and their elements, by body index into `scene.bodies`.
    pub beams: BeamLayout,
}

/// Why a beam cannot be made into bodies. Names the beam and, where it applies, the element
/// or node.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("beam '{beam}': {reason}")]
pub struct BeamModelError {
    /// The beam's name.
    pub beam: String,
    /// What is wrong.
    pub reason: String,
    /// Where the beam is in the source.
    pub origin: Origin,
}

/// Expand the beams of `scene` (see the module doc). A scene without beams comes back
/// unchanged with an empty [`BeamLayout`].
pub fn expand(scene: &Scene) -> Result<Expanded, BeamModelError> {
    let mut out = scene.clone();
    out.beams.clear();
    let mut layout = BeamLayout::default();
    for (bi, beam) in scene.beams.iter().enumerate() {
        let err = |reason: String| BeamModelError {
            beam: beam.name.clone(),
            reason,
            origin: beam.origin,
        };
        let section = BeamSection::from_scene(&beam.section).map_err(|e| err(e.to_string()))?;
        let n = beam.nodes.len();
        if n < 2 {
            return Err(err(format!("needs at least 2 nodes, has {n}")));
        }
        let scale = beam.rotary_inertia_scale;
        if !(scale.is_finite() && scale >= 1.0) {
            return Err(err(format!(
                "rotary_inertia_scale must be at least 1, got {scale}"
            )));
        }
        if !(beam.damping.is_finite() && beam.damping >= 0.0) {
            return Err(err(format!(
                "damping must be zero or positive, got {} s",
                beam.damping
            )));
        }
        let x: Vec<Vector3<f64>> = beam.nodes.iter().map(vec3).collect();
        if x.iter().any(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(err("a node position is not finite".into()));
        }
        let mut dir = Vec::with_capacity(n - 1);
        let mut len = Vec::with_capacity(n - 1);
        for e in 0..n - 1 {
            let d = x[e + 1] - x[e];
            let l = d.norm();
            let scale_x = x[e].norm().max(x[e + 1].norm());
            if !(l > 1e-12 * scale_x && l > 0.0) {
                return Err(err(format!(
                    "element {e} (nodes {e} and {}) has zero length",
                    e + 1
                )));
            }
            dir.push(d / l);
            len.push(l);
        }
        let up = vec3(&beam.up);
        let (v0, w0) = (vec3(&beam.velocity), vec3(&beam.angular_velocity));
        if !(v0.iter().chain(w0.iter()).all(|c| c.is_finite())) {
            return Err(err("the initial velocity is not finite".into()));
        }
        let first_body = out.bodies.len();
        let mut node_q = Vec::with_capacity(n);
        for k in 0..n {
            let t = if k == 0 {
                dir[0]
            } else if k == n - 1 {
                dir[n - 2]
            } else {
                let s = dir[k - 1] + dir[k];
                if s.norm() < 1e-6 {
                    dir[k]
                } else {
                    s.normalize()
                }
            };
            let a2 = up - t * t.dot(&up);
            if a2.norm() < 1e-6 * up.norm().max(1e-300) {
                return Err(err(format!(
                    "the `up` direction is along the beam at node {k}: it cannot fix the section's axis 2 there"
                )));
            }
            let a2 = a2.normalize();
            let a3 = t.cross(&a2);
            let c = Matrix3::from_columns(&[t, a2, a3]);
            let q = quat_from_rotation(&c);
            node_q.push(q);
            let (mut m, mut j) = (0.0, Vector3::zeros());
            for e in [k.checked_sub(1), (k < n - 1).then_some(k)]
                .into_iter()
                .flatten()
            {
                let share = lumped_mass(&section, len[e]);
                m += share.m;
                j += share.j;
            }
            let j = j * scale;
            out.bodies.push(Body {
                name: format!("{}.node[{k}]", beam.name),
                mass: m,
                inertia: [[j.x, 0.0, 0.0], [0.0, j.y, 0.0], [0.0, 0.0, j.z]],
                position: beam.nodes[k],
                orientation: quat_array(&q),
                // the beam's rigid initial motion: ω about the first node, in node axes
                velocity: arr(&(v0 + w0.cross(&(x[k] - x[0])))),
                angular_velocity: arr(&(c.transpose() * w0)),
                origin: beam.origin,
            });
        }
        let first_element = layout.elements.len();
        for e in 0..n - 1 {
            layout.elements.push(BeamElementLayout {
                beam: bi,
                nodes: [first_body + e, first_body + e + 1],
            });
        }
        layout.beams.push(BeamInfo {
            name: beam.name.clone(),
            first_element,
            elements: n - 1,
            first_body,
            section: beam.section,
            damping: beam.damping,
            rotary_inertia_scale: scale,
        });
        for att in &beam.attachments {
            let k = att.node;
            if k >= n {
                return Err(err(format!(
                    "an attachment names node {k}, but the beam has nodes 0 to {}",
                    n - 1
                )));
            }
            // the joint frame on side a is the node's frame at t = 0, in a's components
            let frame_a = match att.to.body {
                BodyRef::Ground => node_q[k],
                BodyRef::Body(i) => {
                    let Some(b) = scene.bodies.get(i) else {
                        return Err(err(format!(
                            "node {k} is attached to body index {i}, which does not exist"
                        )));
                    };
                    qmul(&qconj(&quat(b.orientation).normalize()), &node_q[k])
                }
            };
            let (kind, word) = if att.clamped {
                (JointKind::Fixed, "clamp")
            } else {
                (JointKind::Spherical, "pin")
            };
            out.joints.push(Joint {
                name: format!("{}.{word}[{k}]", beam.name),
                kind,
                a: Attachment {
                    body: att.to.body,
                    point: att.to.point,
                    frame: quat_array(&frame_a),
                },
                b: Attachment {
                    body: BodyRef::Body(first_body + k),
                    point: [0.0; 3],
                    frame: [1.0, 0.0, 0.0, 0.0],
                },
                origin: beam.origin,
            });
        }
    }
    Ok(Expanded {
        scene: out,
        beams: layout,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::math::rotation_array;
    use crate::contract::scene::{Beam, BeamAttachment, Section, Simulate};

    fn section() -> Section {
        Section {
            ea: 2.0e6,
            ga2: 8.0e5,
            ga3: 8.0e5,
            ei2: 50.0,
            ei3: 80.0,
            gj: 40.0,
            rho_a: 2.0,
            rho_i: 3.0e-4,
        }
    }

    fn scene_with(beam: Beam) -> Scene {
        Scene {
            name: "b".into(),
            gravity: None,
            bodies: vec![],
            joints: vec![],
            forces: vec![],
            beams: vec![beam],
            meshes: vec![],
            contacts: vec![],
            simulate: Simulate::default(),
            reference: None,
            params: vec![],
        }
    }

    fn l_beam() -> Beam {
        Beam {
            name: "arm".into(),
            nodes: vec![[0.0; 3], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.5, 0.0]],
            up: [0.0, 0.0, 1.0],
            section: section(),
            attachments: vec![BeamAttachment {
                node: 0,
                to: Attachment {
                    body: BodyRef::Ground,
                    point: [0.0; 3],
                    frame: [1.0, 0.0, 0.0, 0.0],
                },
                clamped: true,
            }],
            damping: 0.0,
            rotary_inertia_scale: 2.0,
            velocity: [0.0; 3],
            angular_velocity: [0.0; 3],
            origin: Origin::default(),
        }
    }

    #[test]
    fn nodes_become_bodies_with_the_lumped_mass_and_section_frames() {
        let ex = expand(&scene_with(l_beam())).unwrap();
        let b = &ex.scene.bodies;
        assert_eq!(b.len(), 4);
        assert_eq!(b[1].name, "arm.node[1]");
        // total mass ρA·L, each element's half to each node
        let total: f64 = b.iter().map(|b| b.mass).sum();
        assert!((total - 2.0 * 1.5).abs() < 1e-12);
        assert!((b[0].mass - 0.5).abs() < 1e-12 && (b[1].mass - 1.0).abs() < 1e-12);
        // rotary inertia: polar ρI₁, bending ρA·EI/EA, times the scale 2, times ℓ/2 = 0.25
        let j = b[0].inertia;
        assert!((j[0][0] - 2.0 * 3.0e-4 * 0.25).abs() < 1e-15);
        assert!((j[1][1] - 2.0 * (2.0 * 50.0 / 2.0e6) * 0.25).abs() < 1e-15);
        // axis 1 along the beam, axis 2 along up; at the corner, the bisector
        let c0 = rotation_array(&b[0].orientation);
        assert!((c0.column(0) - Vector3::x()).norm() < 1e-12);
        assert!((c0.column(1) - Vector3::z()).norm() < 1e-12);
        let c2 = rotation_array(&b[2].orientation);
        let bis = Vector3::new(1.0, 1.0, 0.0).normalize();
        assert!((c2.column(0) - bis).norm() < 1e-12);
        // elements and the clamp
        assert_eq!(ex.beams.elements.len(), 3);
        assert_eq!(ex.beams.elements[2].nodes, [2, 3]);
        assert_eq!(ex.scene.joints.len(), 1);
        assert_eq!(ex.scene.joints[0].name, "arm.clamp[0]");
        assert_eq!(ex.scene.joints[0].kind, JointKind::Fixed);
        assert!(ex.scene.beams.is_empty());
    }

    #[test]
    fn bad_beams_are_named() {
        let mut b = l_beam();
        b.nodes[1] = b.nodes[0];
        let e = expand(&scene_with(b)).unwrap_err();
        assert_eq!(e.beam, "arm");
        assert!(e.reason.contains("element 0"), "{}", e.reason);
        let mut b = l_beam();
        b.section.ei2 = -1.0;
        let e = expand(&scene_with(b)).unwrap_err();
        assert!(e.to_string().contains("EI2"), "{e}");
        let mut b = l_beam();
        b.up = [1.0, 0.0, 0.0];
        let e = expand(&scene_with(b)).unwrap_err();
        assert!(e.reason.contains("node 0"), "{}", e.reason);
    }
}
