//! The planar reading of a rigid scene for the state-time method: the plane of motion, and
//! per body and joint the constants the element equations need (notes F §2.1 generalised
//! to chains and trees of bodies joined by revolute and spherical joints).
//!
//! A scene is planar here when its motion provably stays in one plane: every revolute axis
//! is along the plane's normal `n`, `n` is a principal axis of every body, every
//! attachment point lies in its body's plane of motion (no offset along `n`), the initial
//! angular velocities are along `n` and the velocities in the plane, and the applied
//! loads (independent of the state) are forces in the plane and torques about `n`. Every
//! other scene is refused with the body or joint that breaks the rule and why.

use super::scope::{self, Joint};
use crate::contract::system::{JointKernel, Pose, System, Wrench};
use crate::integrators::State;
use nalgebra::Vector3;

/// The plane of motion: unit normal `n` and in-plane axes `e1`, `e2 = n × e1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Normal (world).
    pub n: Vector3<f64>,
    /// First in-plane axis (world).
    pub e1: Vector3<f64>,
    /// Second in-plane axis (world).
    pub e2: Vector3<f64>,
}

impl Plane {
    /// The plane with normal `n` (any non-zero vector).
    pub fn new(n: Vector3<f64>) -> Plane {
        let n = n.normalize();
        let t = if n.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let e1 = (t - n * n.dot(&t)).normalize();
        let e2 = n.cross(&e1);
        Plane { n, e1, e2 }
    }
    /// In-plane components of a world vector.
    #[inline]
    pub fn xy(&self, v: &Vector3<f64>) -> [f64; 2] {
        [v.dot(&self.e1), v.dot(&self.e2)]
    }
}

/// One body's constants.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// Name (for reports).
    pub name: String,
    /// Mass, kg.
    pub m: f64,
    /// Moment of inertia about the normal through the mass centre, kg·m².
    pub jn: f64,
}

/// A planar scene: the plane, the bodies and the joints.
#[derive(Clone, Debug, PartialEq)]
pub struct Planar {
    /// Plane of motion.
    pub plane: Plane,
    /// Bodies in the system's order.
    pub bodies: Vec<Body>,
    /// Joints in the system's order.
    pub joints: Vec<Joint>,
}

/// Relative tolerance of the planarity checks.
const TOL: f64 = 1e-8;

/// Read `sys` at `start` as a planar scene, or say why it is not one the method supports.
pub fn read<S: System + ?Sized>(sys: &S, start: &State) -> Result<Planar, String> {
    let l = sys.layout();
    let nb = l.bodies();
    let mut joints = Vec::with_capacity(l.joints.len());
    let mut normal: Option<Vector3<f64>> = None;
    for (joint, kernel, geom) in scope::point_joints(sys)? {
        if kernel == JointKernel::Revolute {
            let axis = match joint.a {
                Some(a) => start.pose[a].c * Vector3::from(geom.fa[2]),
                None => Vector3::from(geom.fa[2]),
            };
            match normal {
                None => normal = Some(axis),
                Some(n) => {
                    if n.normalize().cross(&axis.normalize()).norm() > TOL {
                        return Err(format!(
                            "joint '{}' (revolute): its axis is not parallel to the other revolute axes; state_time supports revolute joints in planar scenes only",
                            joint.name
                        ));
                    }
                }
            }
        }
        joints.push(joint);
    }
    if normal.is_none() {
        normal = (0..nb)
            .map(|b| start.pose[b].c * start.twist[b].w)
            .find(|w| w.norm() > 0.0);
    }
    let Some(n) = normal else {
        return Err("state_time: the plane of motion is not known (no revolute joint and no initial angular velocity); state_time supports planar scenes only in this version".into());
    };
    let plane = Plane::new(n);
    let n = plane.n;
    let mut bodies = Vec::with_capacity(nb);
    for b in 0..nb {
        let name = &l.body_names[b];
        let p = &start.pose[b];
        let nb_ = p.c.transpose() * n;
        let j = l.mass[b].j;
        let jn_vec = j * nb_;
        let jn = nb_.dot(&jn_vec);
        if (jn_vec - nb_ * jn).norm() > TOL * j.norm() {
            return Err(format!(
                "body '{name}': the plane's normal is not a principal axis of its inertia, so its motion would leave the plane; state_time supports planar scenes only in this version"
            ));
        }
        let w = p.c * start.twist[b].w;
        let v = start.twist[b].v;
        if w.cross(&n).norm() > TOL * (1.0 + w.norm()) || v.dot(&n).abs() > TOL * (1.0 + v.norm()) {
            return Err(format!(
                "body '{name}': its initial velocity leaves the plane of motion (angular velocity not along the normal, or velocity out of the plane); state_time supports planar scenes only in this version"
            ));
        }
        bodies.push(Body {
            name: name.clone(),
            m: l.mass[b].m,
            jn,
        });
    }
    for j in &joints {
        for (side, p) in [(j.a, &j.pa), (j.b, &j.pb)] {
            if let Some(b) = side {
                let rho = start.pose[b].c * p;
                if rho.dot(&n).abs() > TOL * (1.0 + rho.norm()) {
                    return Err(format!(
                        "joint '{}': its attachment on body '{}' is off the body's plane of motion (offset {:.3e} m along the normal); state_time supports planar scenes only in this version",
                        j.name,
                        l.body_names[b],
                        rho.dot(&n)
                    ));
                }
            }
        }
    }
    // the loads at the start: a force along the normal or a torque about an in-plane axis
    // makes the motion leave the plane (a load that leaves it later stops the run there)
    let mut wrench = vec![Wrench::default(); nb];
    sys.applied(start.t, &start.pose, &start.twist, &mut wrench);
    for (b, w) in wrench.iter().enumerate() {
        if let Some(why) = off_plane(&plane, &start.pose[b], w) {
            return Err(format!("body '{}': {why}", l.body_names[b]));
        }
    }
    Ok(Planar {
        plane,
        bodies,
        joints,
    })
}

/// Why the applied load `w` on a body at `pose` leaves the plane (a force along the normal,
/// or a torque about an in-plane axis), if it does.
pub fn off_plane(plane: &Plane, pose: &Pose, w: &Wrench) -> Option<&'static str> {
    let tw = pose.c * w.t;
    if w.f.dot(&plane.n).abs() > 1e-9 * (1.0 + w.f.norm()) {
        Some("an applied force has a component along the plane's normal")
    } else if tw.cross(&plane.n).norm() > 1e-9 * (1.0 + tw.norm()) {
        Some("an applied torque has a component about an in-plane axis")
    } else {
        None
    }
}
