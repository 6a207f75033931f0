//! The constant geometry of one joint: where it attaches on each side and its joint frames,
//! in plain arrays so that generated code can build it in a `const`.

use crate::contract::math::{quat, rotation};
use crate::contract::scene::Attachment;

/// Geometry of one joint, constructible in a `const`/`static` (plain arrays only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointGeom {
    /// Attachment point on side a: body-a components relative to its mass centre (world
    /// for ground), m.
    pub pa: [f64; 3],
    /// Attachment point on side b, m.
    pub pb: [f64; 3],
    /// Joint-frame axes of side a in body-a components: `[x, y, z]`; `z` is the joint axis.
    pub fa: [[f64; 3]; 3],
    /// Joint-frame axes of side b in body-b components: `[x, y, z]`.
    pub fb: [[f64; 3]; 3],
    /// Joint frame of side a as a unit quaternion `[w, x, y, z]` (joint → body a).
    pub qa: [f64; 4],
    /// Joint frame of side b as a unit quaternion (joint → body b).
    pub qb: [f64; 4],
    /// Scalar parameter: length `L` (distance), radius `R` (rolling); 0 otherwise.
    pub param: f64,
}

impl JointGeom {
    /// Geometry from two attachments (frames normalised; axes are the columns of the
    /// frame rotation) and the kind's scalar parameter.
    pub fn new(a: &Attachment, b: &Attachment, param: f64) -> JointGeom {
        let (qa, fa) = frame_axes(&a.frame);
        let (qb, fb) = frame_axes(&b.frame);
        JointGeom {
            pa: a.point,
            pb: b.point,
            fa,
            fb,
            qa,
            qb,
            param,
        }
    }
}

/// Normalised frame quaternion and its axes `[x, y, z]` (columns of its rotation).
fn frame_axes(q: &[f64; 4]) -> ([f64; 4], [[f64; 3]; 3]) {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let q = if n > 0.0 && n.is_finite() {
        [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
    } else {
        [1.0, 0.0, 0.0, 0.0]
    };
    let c = rotation(&quat(q));
    let col = |j: usize| [c[(0, j)], c[(1, j)], c[(2, j)]];
    (q, [col(0), col(1), col(2)])
}
