//! The spatial reading of a rigid scene for the state-time method (notes F §1.4–1.8 in
//! three dimensions): per body its mass and inertia tensor, per joint its attachment
//! points. Spherical joints; a revolute joint's two rotational rows would need constraint
//! torques that the point-force formulation of the paper does not have, so a revolute
//! joint is taken only in a planar scene ([`super::planar`] says which), where every axis
//! is the plane's normal and the motion leaves no rotational row to enforce: there it is a
//! point joint to this reading too.

use super::scope::{self, Joint};
use crate::contract::system::{JointKernel, System};
use nalgebra::Matrix3;

/// One body's constants.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// Name (for reports).
    pub name: String,
    /// Mass, kg.
    pub m: f64,
    /// Inertia tensor about the mass centre, body components, kg·m².
    pub j: Matrix3<f64>,
}

/// A spatial scene: the bodies and the (spherical) joints.
#[derive(Clone, Debug, PartialEq)]
pub struct Spatial {
    /// Bodies in the system's order.
    pub bodies: Vec<Body>,
    /// Joints in the system's order.
    pub joints: Vec<Joint>,
}

/// Read `sys` as a spatial scene, or say why the method does not take it. `planar` is the
/// planar reading's verdict: `Ok` when the scene is planar (its revolute joints are then
/// point joints), else why not (quoted when a revolute joint is the obstacle).
pub fn read<S: System + ?Sized>(sys: &S, planar: Result<(), &str>) -> Result<Spatial, String> {
    let l = sys.layout();
    let mut joints = Vec::with_capacity(l.joints.len());
    for (joint, kernel, _) in scope::point_joints(sys)? {
        if let (JointKernel::Revolute, Err(planar_why)) = (kernel, planar) {
            return Err(format!(
                "joint '{}' (revolute): state_time takes revolute joints in planar scenes only (this one is not planar: {planar_why}); in space it supports spherical joints",
                joint.name
            ));
        }
        joints.push(joint);
    }
    let bodies = (0..l.bodies())
        .map(|b| Body {
            name: l.body_names[b].clone(),
            m: l.mass[b].m,
            j: l.mass[b].j,
        })
        .collect();
    Ok(Spatial { bodies, joints })
}
