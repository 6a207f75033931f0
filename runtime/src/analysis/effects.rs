//! The effects a scene uses (gravity, springs, drivers, closed loops, …): the generated code
//! and the interpreter contain only these, and `mbdc check --effects` lists them.

use serde::{Deserialize, Serialize};

use crate::analysis::topology::loop_count;
use crate::contract::scene::{Fn1, ForceKind, MeshCondition, Scene};

/// The effects a scene uses; the generated code and the interpreter contain only these.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Effects {
    /// Uniform gravity.
    pub gravity: bool,
    /// Point forces and torques.
    pub applied_forces: bool,
    /// Anything that depends explicitly on time (forces, drivers, prescribed velocities).
    pub time_dependence: bool,
    /// Translational or rotational springs.
    pub springs: bool,
    /// Translational or rotational dampers.
    pub dampers: bool,
    /// Rheonomic joints (drivers).
    pub drivers: bool,
    /// Kinematic loops (more joints than a spanning tree needs).
    pub closed_loops: bool,
    /// Nonholonomic constraints.
    pub nonholonomic: bool,
    /// Joint locks (rotational springs with a lock angle).
    pub locks: bool,
    /// Flexible beams.
    pub beams: bool,
    /// Finite-element meshes.
    pub meshes: bool,
    /// Contact.
    pub contact: bool,
}

impl Effects {
    /// The effects `scene` uses.
    pub fn of(scene: &Scene) -> Effects {
        let fn_time = |f: &Fn1| !f.is_const();
        let mut e = Effects {
            gravity: scene.gravity.is_some_and(|g| g.iter().any(|c| *c != 0.0)),
            beams: !scene.beams.is_empty(),
            meshes: !scene.meshes.is_empty(),
            contact: !scene.contacts.is_empty(),
            ..Effects::default()
        };
        for f in &scene.forces {
            match &f.kind {
                ForceKind::Point { value, .. } | ForceKind::Torque { value, .. } => {
                    e.applied_forces = true;
                    e.time_dependence |= value.iter().any(fn_time);
                }
                ForceKind::Spring {
                    stiffness, damping, ..
                } => {
                    e.springs |= *stiffness != 0.0;
                    e.dampers |= *damping != 0.0;
                }
                ForceKind::RotationalSpring {
                    stiffness,
                    damping,
                    lock_angle,
                    ..
                } => {
                    e.springs |= *stiffness != 0.0;
                    e.dampers |= *damping != 0.0;
                    e.locks |= lock_angle.is_some();
                }
            }
        }
        for j in &scene.joints {
            if j.kind.nonholonomic_rows() > 0 {
                e.nonholonomic = true;
            }
            if j.kind.is_rheonomic() {
                e.drivers = true;
                e.time_dependence = true;
            }
        }
        for m in &scene.meshes {
            for c in &m.conditions {
                match c {
                    MeshCondition::Displacement { value, .. } => {
                        e.time_dependence |= value.iter().flatten().any(fn_time)
                    }
                    MeshCondition::NodalLoad { value, .. }
                    | MeshCondition::Traction { value, .. } => {
                        e.time_dependence |= value.iter().any(fn_time)
                    }
                    _ => {}
                }
            }
        }
        e.closed_loops = loop_count(scene) > 0;
        e
    }

    /// Names of the effects that are on, in a fixed order.
    pub fn names(&self) -> Vec<&'static str> {
        let all = [
            (self.gravity, "gravity"),
            (self.applied_forces, "applied_forces"),
            (self.time_dependence, "time_dependence"),
            (self.springs, "springs"),
            (self.dampers, "dampers"),
            (self.drivers, "drivers"),
            (self.closed_loops, "closed_loops"),
            (self.nonholonomic, "nonholonomic"),
            (self.locks, "locks"),
            (self.beams, "beams"),
            (self.meshes, "meshes"),
            (self.contact, "contact"),
        ];
        all.iter().filter(|(on, _)| *on).map(|(_, n)| *n).collect()
    }
}
