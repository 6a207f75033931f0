//! What scenes the state-time method takes, in the checks its two readings share
//! ([`super::planar`], [`super::spatial`]): rigid bodies only, loads that do not depend on
//! the state, and point joints (revolute and spherical) that act from the first step. Every
//! other scene is refused before the first step, naming the beam or joint and why.

use crate::contract::system::{JointGeom, JointKernel, System};
use nalgebra::Vector3;

/// One joint: the two sides and their attachment points in body components.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    /// Name (for reports).
    pub name: String,
    /// Body of side a (`None`: ground).
    pub a: Option<usize>,
    /// Body of side b (`None`: ground).
    pub b: Option<usize>,
    /// Attachment on side a: body-a components from its mass centre (world for ground).
    pub pa: Vector3<f64>,
    /// Attachment on side b.
    pub pb: Vector3<f64>,
    /// First constraint row of the joint in the system's numbering.
    pub first_row: usize,
    /// Number of rows.
    pub rows: usize,
}

/// The scene's joints with their kernels and geometry, or why the state-time method does
/// not take the scene (beams, no bodies, state-dependent loads, locks, nonholonomic rows,
/// joints other than revolute and spherical).
pub fn point_joints<S: System + ?Sized>(
    sys: &S,
) -> Result<Vec<(Joint, JointKernel, &JointGeom)>, String> {
    let l = sys.layout();
    if !l.beams.is_empty() {
        return Err(format!(
            "beam '{}': state_time does not simulate flexible beams yet",
            l.beams.beams[0].name
        ));
    }
    if l.bodies() == 0 {
        return Err("state_time needs at least one rigid body".into());
    }
    if sys.has_state_forces() {
        return Err("state_time supports only loads that do not depend on the state (gravity, forces and torques given as functions of time) in this version; the scene has springs, dampers, contact or forces in body axes".into());
    }
    let mut joints = Vec::with_capacity(l.joints.len());
    for (k, j) in l.joints.iter().enumerate() {
        if j.starts_inactive {
            return Err(format!(
                "joint '{}' ({}): state_time does not handle locks that engage during a run",
                j.name, j.kind
            ));
        }
        if j.nonholonomic > 0 {
            return Err(format!(
                "joint '{}' ({}): state_time enforces velocity-level point constraints only; nonholonomic rows are not supported",
                j.name, j.kind
            ));
        }
        let Some((kernel, geom)) = sys.tree_joint(k) else {
            return Err(format!(
                "joint '{}' ({}): state_time supports revolute and spherical joints only (no drivers, distances, curves or rolling yet)",
                j.name, j.kind
            ));
        };
        if !matches!(kernel, JointKernel::Revolute | JointKernel::Spherical) {
            return Err(format!(
                "joint '{}' ({}): state_time supports revolute and spherical joints only",
                j.name, j.kind
            ));
        }
        if j.a.is_none() && j.b.is_none() {
            return Err(format!("joint '{}' joins ground to ground", j.name));
        }
        let joint = Joint {
            name: j.name.clone(),
            a: j.a,
            b: j.b,
            pa: Vector3::from(geom.pa),
            pb: Vector3::from(geom.pb),
            first_row: j.first_row,
            rows: j.rows,
        };
        joints.push((joint, kernel, geom));
    }
    Ok(joints)
}
