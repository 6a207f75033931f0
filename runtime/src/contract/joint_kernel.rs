//! The one enum of joint kernels.
//!
//! A [`JointKind`] is what the scene says (with its parameters: a driver's time function, a
//! distance's length); a [`JointKernel`] is which kernel evaluates its rows. Every consumer
//! of joint kinds dispatches on this enum: the interpreter's plan (`interp::JointEntry`), the
//! compiled tables and the code generator (`compiled::JointCombo`), natural partitioning's
//! tree joints ([`System::tree_joint`](crate::contract::system::System::tree_joint) and
//! `tree_joints::tree_joint`), and the topology's tree eligibility. Adding a joint kind
//! means: its kernel in `kernels/joints.rs`, its [`JointKind`] variant, its variant here
//! (the compiler tells every `match` that must learn it), and its lowering in the compiler.

use serde::{Deserialize, Serialize};

use crate::contract::scene::JointKind;

/// Which kernel evaluates a joint's rows: one variant per kernel of `kernels::joints`, plus
/// the lock rows that a rotational stop adds (the angle driver's kernel at a constant angle).
///
/// The first seven kinds (spherical … planar) can be tree joints of natural partitioning
/// ([`JointKernel::tree_dof`] is `Some`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum JointKernel {
    /// Point coincidence (3 rows); 3 rotations free.
    Spherical,
    /// Rotation about the common z axis only (5 rows).
    Revolute,
    /// Translation along z only (5 rows).
    Prismatic,
    /// Translation along and rotation about z (4 rows).
    Cylindrical,
    /// Rotations about `za` and `zb`, the cross axes (4 rows).
    Universal,
    /// No relative motion (6 rows).
    Fixed,
    /// Translations in the x–y plane of side a and rotation about z (3 rows).
    Planar,
    /// Constant distance between two points (1 row; length in `JointGeom::param`).
    Distance,
    /// Prescribed relative angle about z (1 row; one time function).
    DriveAngle,
    /// Prescribed relative displacement along z (1 row; one time function).
    DriveDisplacement,
    /// A sphere rolling without slip on a plane (1 holonomic and 2 nonholonomic rows; radius
    /// in `JointGeom::param`).
    Rolling,
    /// Prescribed world velocity of a body point (3 nonholonomic rows; three time functions).
    PointVelocity,
    /// A body point on a plane curve `y = f(x)` (1 row; the curve as a function).
    Curve,
    /// A lock row of a rotational stop: the angle driver's kernel at a constant angle.
    Lock,
}

impl JointKernel {
    /// The tree-eligible kernels ([`JointKernel::is_tree`]), in declaration order.
    pub const TREE: [JointKernel; 7] = [
        JointKernel::Spherical,
        JointKernel::Revolute,
        JointKernel::Prismatic,
        JointKernel::Cylindrical,
        JointKernel::Universal,
        JointKernel::Fixed,
        JointKernel::Planar,
    ];

    /// The kernel of a scene joint kind.
    pub fn of(kind: &JointKind) -> JointKernel {
        match kind {
            JointKind::Spherical => JointKernel::Spherical,
            JointKind::Revolute => JointKernel::Revolute,
            JointKind::Prismatic => JointKernel::Prismatic,
            JointKind::Cylindrical => JointKernel::Cylindrical,
            JointKind::Universal => JointKernel::Universal,
            JointKind::Fixed => JointKernel::Fixed,
            JointKind::Planar => JointKernel::Planar,
            JointKind::Distance { .. } => JointKernel::Distance,
            JointKind::DriveAngle { .. } => JointKernel::DriveAngle,
            JointKind::DriveDisplacement { .. } => JointKernel::DriveDisplacement,
            JointKind::Rolling { .. } => JointKernel::Rolling,
            JointKind::PointVelocity { .. } => JointKernel::PointVelocity,
            JointKind::Curve { .. } => JointKernel::Curve,
        }
    }

    /// The keyword (as in the language, and in `JointLayout::kind`; `lock` for lock rows).
    pub fn keyword(self) -> &'static str {
        match self {
            JointKernel::Spherical => "spherical",
            JointKernel::Revolute => "revolute",
            JointKernel::Prismatic => "prismatic",
            JointKernel::Cylindrical => "cylindrical",
            JointKernel::Universal => "universal",
            JointKernel::Fixed => "fixed",
            JointKernel::Planar => "planar",
            JointKernel::Distance => "distance",
            JointKernel::DriveAngle => "drive_angle",
            JointKernel::DriveDisplacement => "drive_displacement",
            JointKernel::Rolling => "rolling",
            JointKernel::PointVelocity => "point_velocity",
            JointKernel::Curve => "curve",
            JointKernel::Lock => "lock",
        }
    }

    /// The kernel of a keyword ([`JointKernel::keyword`]'s inverse).
    pub fn from_keyword(k: &str) -> Option<JointKernel> {
        Some(match k {
            "spherical" => JointKernel::Spherical,
            "revolute" => JointKernel::Revolute,
            "prismatic" => JointKernel::Prismatic,
            "cylindrical" => JointKernel::Cylindrical,
            "universal" => JointKernel::Universal,
            "fixed" => JointKernel::Fixed,
            "planar" => JointKernel::Planar,
            "distance" => JointKernel::Distance,
            "drive_angle" => JointKernel::DriveAngle,
            "drive_displacement" => JointKernel::DriveDisplacement,
            "rolling" => JointKernel::Rolling,
            "point_velocity" => JointKernel::PointVelocity,
            "curve" => JointKernel::Curve,
            "lock" => JointKernel::Lock,
            _ => return None,
        })
    }

    /// The kernel's function name in `kernels::joints` (what generated code calls).
    pub fn function(self) -> &'static str {
        match self {
            JointKernel::Distance => "distance_joint",
            JointKernel::Lock => "drive_angle",
            k => k.keyword(),
        }
    }

    /// How many time functions the kernel takes: one for the drivers and the curve, three
    /// for a point velocity, none otherwise.
    pub fn time_functions(self) -> usize {
        match self {
            JointKernel::DriveAngle | JointKernel::DriveDisplacement | JointKernel::Curve => 1,
            JointKernel::PointVelocity => 3,
            _ => 0,
        }
    }

    /// Independent relative velocities the joint leaves free as a tree joint of natural
    /// partitioning, `None` for the kinds that are never tree joints: spherical 3,
    /// revolute 1, prismatic 1, cylindrical 2, universal 2, fixed 0, planar 3.
    pub fn tree_dof(self) -> Option<usize> {
        Some(match self {
            JointKernel::Spherical | JointKernel::Planar => 3,
            JointKernel::Revolute | JointKernel::Prismatic => 1,
            JointKernel::Cylindrical | JointKernel::Universal => 2,
            JointKernel::Fixed => 0,
            _ => return None,
        })
    }

    /// Whether the joint can be a tree edge (spherical … planar).
    pub fn is_tree(self) -> bool {
        self.tree_dof().is_some()
    }

    /// The independent coordinates of a tree joint in the joint frame, for reports.
    pub fn coordinates(self) -> &'static str {
        match self {
            JointKernel::Spherical => "3 rotations",
            JointKernel::Revolute => "rotation about z",
            JointKernel::Prismatic => "translation along z",
            JointKernel::Cylindrical => "translation along and rotation about z",
            JointKernel::Universal => "rotations about za and zb",
            JointKernel::Fixed => "none",
            JointKernel::Planar => "translations along x, y and rotation about z",
            _ => "not a tree joint",
        }
    }

    /// Names of a tree joint's independent rates, in the order natural partitioning keeps
    /// them (for reports).
    pub fn rate_names(self) -> &'static str {
        match self {
            JointKernel::Spherical => "ω_x, ω_y, ω_z of the child (body axes)",
            JointKernel::Revolute => "θ̇ about z",
            JointKernel::Prismatic => "ṡ along z",
            JointKernel::Cylindrical => "θ̇ about z, ṡ along z",
            JointKernel::Universal => "θ̇₁ about za, θ̇₂ about zb",
            JointKernel::Fixed => "none",
            JointKernel::Planar => "θ̇ about z, ṡ₁ along x, ṡ₂ along y",
            _ => "not a tree joint",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keywords_round_trip_and_tree_kinds_are_the_first_seven() {
        let all = [
            JointKernel::Spherical,
            JointKernel::Revolute,
            JointKernel::Prismatic,
            JointKernel::Cylindrical,
            JointKernel::Universal,
            JointKernel::Fixed,
            JointKernel::Planar,
            JointKernel::Distance,
            JointKernel::DriveAngle,
            JointKernel::DriveDisplacement,
            JointKernel::Rolling,
            JointKernel::PointVelocity,
            JointKernel::Curve,
            JointKernel::Lock,
        ];
        for k in all {
            assert_eq!(JointKernel::from_keyword(k.keyword()), Some(k));
            assert_eq!(k.is_tree(), JointKernel::TREE.contains(&k), "{k:?}");
        }
        assert_eq!(JointKernel::from_keyword("hinge"), None);
    }
}
