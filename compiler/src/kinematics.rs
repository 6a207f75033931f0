//! Constraint residuals at the initial state, for `mbdc check`: how far each joint is from
//! being satisfied (positions and velocities), and the rank of the constraint Jacobian.
//!
//! This is a checker, not a simulator: velocity-level residuals of holonomic rows are
//! computed by central differences along the initial motion (accurate to ~1e-10), the
//! Jacobian column by column from them.

use mbdc_runtime::scene::{BodyRef, Joint, JointKind, Scene};
use nalgebra::{DMatrix, Matrix3, Rotation3, Vector3};

use crate::fn1;
use crate::geom;

/// Positions, rotations and velocities of all bodies.
#[derive(Clone, Debug)]
pub struct State {
    x: Vec<Vector3<f64>>,
    r: Vec<Matrix3<f64>>,
    v: Vec<Vector3<f64>>,
    /// Angular velocity, world components.
    w: Vec<Vector3<f64>>,
}

impl State {
    /// The initial state of a scene.
    pub fn initial(scene: &Scene) -> State {
        let mut s = State {
            x: Vec::new(),
            r: Vec::new(),
            v: Vec::new(),
            w: Vec::new(),
        };
        for b in &scene.bodies {
            let r = geom::rot(b.orientation);
            s.x.push(geom::v(b.position));
            s.r.push(r);
            s.v.push(geom::v(b.velocity));
            s.w.push(r * geom::v(b.angular_velocity));
        }
        s
    }

    fn pose(&self, b: BodyRef) -> Pose {
        match b {
            BodyRef::Ground => Pose::GROUND,
            BodyRef::Body(i) => {
                match (self.x.get(i), self.r.get(i), self.v.get(i), self.w.get(i)) {
                    (Some(x), Some(r), Some(v), Some(w)) => Pose {
                        x: *x,
                        r: *r,
                        v: *v,
                        w: *w,
                    },
                    _ => Pose::GROUND,
                }
            }
        }
    }
}

/// Position, rotation and velocities of one body.
#[derive(Clone, Copy, Debug)]
struct Pose {
    x: Vector3<f64>,
    r: Matrix3<f64>,
    v: Vector3<f64>,
    /// World components.
    w: Vector3<f64>,
}

impl Pose {
    const GROUND: Pose = Pose {
        x: Vector3::new(0.0, 0.0, 0.0),
        r: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        v: Vector3::new(0.0, 0.0, 0.0),
        w: Vector3::new(0.0, 0.0, 0.0),
    };

    /// Moved along its velocities for a time `dt`.
    fn advanced(&self, dt: f64) -> Pose {
        Pose {
            x: self.x + self.v * dt,
            r: Rotation3::new(self.w * dt).into_inner() * self.r,
            ..*self
        }
    }
}

/// Holonomic constraint rows of a joint (positions) at time `t`.
pub fn holonomic(j: &Joint, s: &State, t: f64) -> Vec<f64> {
    holonomic_at(j, &s.pose(j.a.body), &s.pose(j.b.body), t)
}

fn holonomic_at(j: &Joint, a: &Pose, b: &Pose, t: f64) -> Vec<f64> {
    let pa = a.x + a.r * geom::v(j.a.point);
    let pb = b.x + b.r * geom::v(j.b.point);
    let fa = a.r * geom::rot(j.a.frame);
    let fb = b.r * geom::rot(j.b.frame);
    let (ax, ay, az) = (
        fa.column(0).into_owned(),
        fa.column(1).into_owned(),
        fa.column(2).into_owned(),
    );
    let (bx, by, bz) = (
        fb.column(0).into_owned(),
        fb.column(1).into_owned(),
        fb.column(2).into_owned(),
    );
    let d = pb - pa;
    match &j.kind {
        JointKind::Spherical => vec![d.x, d.y, d.z],
        JointKind::Revolute => vec![d.x, d.y, d.z, ax.dot(&bz), ay.dot(&bz)],
        JointKind::Prismatic => vec![
            ax.dot(&d),
            ay.dot(&d),
            ay.dot(&bz),
            az.dot(&bx),
            ax.dot(&by),
        ],
        JointKind::Cylindrical => vec![ax.dot(&d), ay.dot(&d), ax.dot(&bz), ay.dot(&bz)],
        JointKind::Universal => vec![d.x, d.y, d.z, az.dot(&bz)],
        JointKind::Fixed => vec![d.x, d.y, d.z, ay.dot(&bz), az.dot(&bx), ax.dot(&by)],
        JointKind::Planar => vec![az.dot(&d), ax.dot(&bz), ay.dot(&bz)],
        JointKind::Distance { length } => vec![d.norm() - length],
        JointKind::DriveAngle { angle, .. } => {
            let theta = ay.dot(&bx).atan2(ax.dot(&bx));
            vec![(theta - fn1::eval(angle, t)).sin()]
        }
        JointKind::DriveDisplacement { displacement, .. } => {
            vec![az.dot(&d) - fn1::eval(displacement, t)]
        }
        JointKind::Rolling { radius } => vec![bz.dot(&(pa - pb)) - radius],
        JointKind::PointVelocity { .. } => vec![],
        JointKind::Curve { curve } => {
            let local = fb.transpose() * (pa - pb);
            vec![local.y - fn1::eval(curve, local.x)]
        }
    }
}

/// Nonholonomic (velocity-level) rows of a joint at time `t`.
pub fn nonholonomic(j: &Joint, s: &State, t: f64) -> Vec<f64> {
    nonholonomic_at(j, &s.pose(j.a.body), &s.pose(j.b.body), t)
}

fn nonholonomic_at(j: &Joint, a: &Pose, b: &Pose, t: f64) -> Vec<f64> {
    match &j.kind {
        JointKind::Rolling { radius } => {
            let fb = b.r * geom::rot(j.b.frame);
            let n = fb.column(2).into_owned();
            let contact_rel = a.r * geom::v(j.a.point) - n * *radius;
            let vp = a.v + a.w.cross(&contact_rel);
            vec![fb.column(0).dot(&vp), fb.column(1).dot(&vp)]
        }
        JointKind::PointVelocity { velocity } => {
            let rel = a.r * geom::v(j.a.point);
            let vp = a.v + a.w.cross(&rel);
            (0..3).map(|k| vp[k] - fn1::eval(&velocity[k], t)).collect()
        }
        _ => vec![],
    }
}

const DT: f64 = 1e-6;

/// Time derivative of the holonomic rows along the state's motion (central differences).
pub fn holonomic_rate(j: &Joint, s: &State, t: f64) -> Vec<f64> {
    rate_at(j, &s.pose(j.a.body), &s.pose(j.b.body), t)
}

fn rate_at(j: &Joint, a: &Pose, b: &Pose, t: f64) -> Vec<f64> {
    let p = holonomic_at(j, &a.advanced(DT), &b.advanced(DT), t + DT);
    let m = holonomic_at(j, &a.advanced(-DT), &b.advanced(-DT), t - DT);
    p.iter()
        .zip(&m)
        .map(|(x, y)| (x - y) / (2.0 * DT))
        .collect()
}

/// All rows of a joint at the velocity level: holonomic rates, then nonholonomic rows.
fn velocity_rows(j: &Joint, a: &Pose, b: &Pose, t: f64) -> Vec<f64> {
    let mut v = rate_at(j, a, b, t);
    v.extend(nonholonomic_at(j, a, b, t));
    v
}

/// Largest absolute position-level and velocity-level residual of a joint at t = 0.
pub fn initial_violation(scene: &Scene, j: &Joint) -> (f64, f64) {
    violation_in(&State::initial(scene), j)
}

/// [`initial_violation`] of every joint, in order.
pub fn initial_violations(scene: &Scene) -> Vec<(f64, f64)> {
    let s = State::initial(scene);
    scene.joints.iter().map(|j| violation_in(&s, j)).collect()
}

fn violation_in(s: &State, j: &Joint) -> (f64, f64) {
    let maxabs = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let pos = maxabs(&holonomic(j, s, 0.0));
    let vel = maxabs(&holonomic_rate(j, s, 0.0)).max(maxabs(&nonholonomic(j, s, 0.0)));
    (pos, vel)
}

/// Largest number of bodies for which the Jacobian rank is computed.
pub const MAX_RANK_BODIES: usize = 100;

/// Rank of the constraint Jacobian (all rows, against the 6 velocities of each body) at
/// t = 0, and the number of rows; `None` for scenes too large to check.
pub fn jacobian_rank(scene: &Scene) -> Option<(usize, usize)> {
    let n = scene.bodies.len();
    if n == 0 || n > MAX_RANK_BODIES {
        return None;
    }
    let rows: usize = scene.joints.iter().map(|j| j.kind.rows()).sum();
    if rows == 0 {
        return Some((0, 0));
    }
    let s = State::initial(scene);
    let mut jac = DMatrix::<f64>::zeros(rows, 6 * n);
    let mut r0 = 0;
    for j in &scene.joints {
        let still = |b: BodyRef| Pose {
            v: Vector3::zeros(),
            w: Vector3::zeros(),
            ..s.pose(b)
        };
        let (a0, b0) = (still(j.a.body), still(j.b.body));
        let f0 = velocity_rows(j, &a0, &b0, 0.0);
        for (side, body) in [(0, j.a.body), (1, j.b.body)] {
            let Some(i) = body.index() else { continue };
            if j.a.body == j.b.body && side == 1 {
                continue;
            }
            for k in 0..6 {
                let mut p = still(body);
                if k < 3 {
                    p.v[k] = 1.0;
                } else {
                    p.w[k - 3] = 1.0;
                }
                let (pa, pb) = if side == 0 { (p, b0) } else { (a0, p) };
                let f = velocity_rows(j, &pa, &pb, 0.0);
                for (r, (x, y)) in f.iter().zip(&f0).enumerate() {
                    if r0 + r < rows {
                        jac[(r0 + r, 6 * i + k)] += x - y;
                    }
                }
            }
        }
        r0 += j.kind.rows();
    }
    if jac.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let sv = jac.svd(false, false).singular_values;
    let smax = sv.iter().fold(0.0f64, |m, x| m.max(*x));
    if smax == 0.0 {
        return Some((0, rows));
    }
    let rank = sv.iter().filter(|x| **x > 1e-7 * smax).count();
    Some((rank, rows))
}

#[cfg(test)]
mod tests {
    use super::*;
    use mbdc_runtime::scene::{Attachment, Body, Origin, Simulate};

    fn body(x: [f64; 3], v: [f64; 3], w: [f64; 3]) -> Body {
        Body {
            name: "b".into(),
            mass: 1.0,
            inertia: geom::diag([1.0, 1.0, 1.0]),
            position: x,
            orientation: geom::IDENTITY,
            velocity: v,
            angular_velocity: w,
            origin: Origin::default(),
        }
    }

    fn scene(bodies: Vec<Body>, joints: Vec<Joint>) -> Scene {
        Scene {
            name: "t".into(),
            gravity: None,
            bodies,
            joints,
            forces: vec![],
            beams: vec![],
            meshes: vec![],
            contacts: vec![],
            simulate: Simulate::default(),
            reference: None,
            params: vec![],
        }
    }

    #[test]
    fn pendulum_residuals_and_rank() {
        // A rod hanging from a spherical joint at the origin, swinging about y.
        let b = body([0.0, 0.0, -0.5], [0.5, 0.0, 0.0], [0.0, -1.0, 0.0]);
        let j = Joint {
            name: "j".into(),
            kind: JointKind::Spherical,
            a: Attachment {
                body: BodyRef::Ground,
                point: [0.0; 3],
                frame: geom::IDENTITY,
            },
            b: Attachment {
                body: BodyRef::Body(0),
                point: [0.0, 0.0, 0.5],
                frame: geom::IDENTITY,
            },
            origin: Origin::default(),
        };
        let s = scene(vec![b], vec![j.clone()]);
        let (p, v) = initial_violation(&s, &j);
        assert!(p < 1e-15 && v < 1e-9, "{p} {v}");
        assert_eq!(jacobian_rank(&s), Some((3, 3)));
        // Wrong velocity: violation 0.5 m/s.
        let s2 = scene(
            vec![body([0.0, 0.0, -0.5], [0.0; 3], [0.0, -1.0, 0.0])],
            vec![j.clone()],
        );
        let (_, v) = initial_violation(&s2, &j);
        assert!((v - 0.5).abs() < 1e-8);
    }
}
