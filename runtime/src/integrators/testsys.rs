//! A hand-written system for testing integrators independently of the joint library:
//! one rod hanging from a spherical joint at the world origin, in gravity.

use nalgebra::{Matrix3, Quaternion, Vector3};

use crate::contract::math::skew;
use crate::contract::system::*;

/// A rod of length `l` along its body z axis, pivoted at its top end (body point (0,0,l/2))
/// at the world origin, released at angle `theta0` from the downward vertical in the x–z plane.
pub struct RodPendulum {
    pub layout: Layout,
    pub l: f64,
    pub g: f64,
    pub theta0: f64,
}

impl RodPendulum {
    pub fn new(m: f64, l: f64, radius: f64, theta0: f64) -> RodPendulum {
        let it = m * (3.0 * radius * radius + l * l) / 12.0;
        let ia = m * radius * radius / 2.0;
        let mass = MassProps::new(m, Matrix3::from_diagonal(&Vector3::new(it, it, ia))).unwrap();
        let layout = Layout {
            body_names: vec!["rod".into()],
            mass: vec![mass],
            joints: vec![JointLayout {
                name: "pivot".into(),
                kind: "spherical",
                a: None,
                b: Some(0),
                first_row: 0,
                rows: 3,
                nonholonomic: 0,
                starts_inactive: false,
            }],
            rows: 3,
            row_joint: vec![0; 3],
            row_kind: vec![RowKind::Holonomic; 3],
            beams: Default::default(),
            meshes: Default::default(),
        };
        RodPendulum {
            layout,
            l,
            g: 9.81,
            theta0,
        }
    }

    fn p(&self) -> Vector3<f64> {
        Vector3::new(0.0, 0.0, self.l / 2.0)
    }
}

impl System for RodPendulum {
    fn layout(&self) -> &Layout {
        &self.layout
    }
    fn initial_state(&self, pose: &mut [Pose], twist: &mut [Twist]) {
        // body z points from the c.m. up to the pivot: rotate about y by −θ0
        let th = -self.theta0;
        let q = Quaternion::new((th / 2.0).cos(), 0.0, (th / 2.0).sin(), 0.0);
        let mut p = Pose::new(Vector3::zeros(), q);
        p.r = -(p.c * self.p());
        pose[0] = p;
        twist[0] = Twist::default();
    }
    fn applied(&self, _t: f64, _pose: &[Pose], _twist: &[Twist], out: &mut [Wrench]) {
        out[0] = Wrench {
            f: Vector3::new(0.0, 0.0, -self.g * self.layout.mass[0].m),
            t: Vector3::zeros(),
        };
    }
    fn constraints(
        &self,
        _t: f64,
        pose: &[Pose],
        twist: &[Twist],
        need: Need,
        out: &mut ConstraintEval,
    ) {
        // Φ = r_b + C p − 0 (b side = rod)
        let p = &pose[0];
        let cp = p.c * self.p();
        if need.phi {
            let x = p.r + cp;
            out.phi[..3].copy_from_slice(x.as_slice());
        }
        if need.jac {
            let blk = -(p.c * skew(&self.p()));
            for r in 0..3 {
                let mut b = [0.0; 6];
                b[r] = 1.0;
                for c in 0..3 {
                    b[3 + c] = blk[(r, c)];
                }
                out.jac[r] = RowJac { a: [0.0; 6], b };
                out.bias[r] = 0.0;
            }
        }
        if need.gamma {
            let w = twist[0].w;
            let g = -(p.c * w.cross(&w.cross(&self.p())));
            out.gamma[..3].copy_from_slice(g.as_slice());
        }
    }
    fn has_state_forces(&self) -> bool {
        false
    }
    fn potential_energy(&self, _t: f64, pose: &[Pose]) -> f64 {
        self.layout.mass[0].m * self.g * pose[0].r.z
    }
}
