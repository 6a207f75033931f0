//! Assembly of an initial state onto the constraints (`mbdc run --assemble`).
//!
//! Positions: Newton iterations on the holonomic rows `Φ(q, 0) = 0`, each moving the bodies
//! by the mass-weighted least-norm correction `Δu = −M⁻¹Bᵀ(BM⁻¹Bᵀ)⁺Φ`, so heavy bodies move
//! less than light ones and nothing moves that the constraints do not require. Drivers are
//! rows like the others, evaluated at t = 0, so they hold their initial value. Redundant rows
//! are handled by the pseudo-inverse (pivoted Cholesky, [`crate::linalg::PivotedCholesky`]).
//! A step that does not reduce `|Φ|` is halved (up to 20 times).
//!
//! Velocities: one projection `Δu̇ = −M⁻¹Bᵀ(BM⁻¹Bᵀ)⁺(Bu̇ + b)` over all rows (holonomic at
//! velocity level and nonholonomic), exact because the velocity constraints are linear.
//!
//! If the positions cannot be assembled, the error names the joints whose rows keep the
//! largest residual: those in conflict.

use nalgebra::Vector3;

use crate::contract::system::{ConstraintEval, Layout, Need, Pose, RowKind, System, Twist, Wrench};
use crate::integrators::common::{self, accel};
use crate::linalg::{Backend, Definiteness, KSolver, KSolverOptions, DEFAULT_PIVOT_TOL};

/// What assembly changed, per body.
#[derive(Clone, Debug, PartialEq)]
pub struct Moved {
    /// Body name.
    pub body: String,
    /// Translation of the mass centre, m.
    pub translation: f64,
    /// Rotation angle, rad.
    pub rotation: f64,
    /// Change of the mass-centre velocity, m/s.
    pub velocity: f64,
    /// Change of the angular velocity, rad/s.
    pub angular_velocity: f64,
}

/// The result of a successful assembly.
#[derive(Clone, Debug, PartialEq)]
pub struct Assembly {
    /// Bodies that moved (by more than 1e-15), in body order.
    pub moved: Vec<Moved>,
    /// Newton iterations for the positions.
    pub iterations: u32,
    /// Largest holonomic residual before and after, m or rad.
    pub residual: (f64, f64),
    /// Largest velocity residual before and after.
    pub velocity_residual: (f64, f64),
}

/// Assembly failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AssemblyError {
    /// The constraints cannot all be satisfied together.
    #[error(
        "the joints {joints:?} cannot be assembled together: their {level} constraints remain violated by {residual:.3e}"
    )]
    Conflict {
        /// The joints with the largest remaining residual.
        joints: Vec<String>,
        /// The largest remaining residual.
        residual: f64,
        /// `"position"` or `"velocity"`: which level could not be satisfied.
        level: &'static str,
    },
    /// A linear solver failed.
    #[error("assembly: {0}")]
    Linalg(#[from] crate::linalg::LinalgError),
}

/// Move `pose` and `twist` (at t = 0) onto the constraints of `sys`.
pub fn assemble<S: System>(
    sys: &S,
    pose: &mut [Pose],
    twist: &mut [Twist],
) -> Result<Assembly, AssemblyError> {
    let layout = sys.layout();
    let (nb, m) = (layout.bodies(), layout.rows);
    let active = common::initial_activity(layout);
    let hol: Vec<bool> = (0..m)
        .map(|r| active[r] && layout.row_kind[r] == RowKind::Holonomic)
        .collect();
    let mut ks = KSolver::new(
        layout,
        KSolverOptions {
            backend: Backend::Auto,
            definiteness: Definiteness::SemiDefinite {
                tol: DEFAULT_PIVOT_TOL,
            },
        },
    )?;
    let mut ce = ConstraintEval::new(m);
    let scale = pose.iter().fold(1.0f64, |a, p| a.max(p.r.norm()));
    let tol = 1e-12 * scale;
    let original: Vec<Pose> = pose.to_vec();
    let original_twist: Vec<Twist> = twist.to_vec();
    let mut y = vec![0.0; m];
    let mut corr = vec![Wrench::default(); nb];
    let mut trial = pose.to_vec();
    let worst = |ce: &ConstraintEval| {
        (0..m)
            .filter(|&r| hol[r])
            .fold(0.0f64, |a, r| a.max(ce.phi[r].abs()))
    };

    sys.constraints(
        0.0,
        pose,
        twist,
        Need {
            phi: true,
            jac: true,
            gamma: false,
        },
        &mut ce,
    );
    let before = worst(&ce);
    let mut res = before;
    let mut iterations = 0;
    while res > tol && iterations < 50 {
        iterations += 1;
        ks.assemble(&ce.jac, &layout.mass, 1.0, 0.0, Some(&hol));
        ks.factor()?;
        for r in 0..m {
            y[r] = if hol[r] { ce.phi[r] } else { 0.0 };
        }
        ks.solve_in_place(&mut y);
        common::bt_lambda(layout, &ce, &y, &hol, &mut corr);
        let mut step = 1.0;
        let mut improved = false;
        for _ in 0..20 {
            for i in 0..nb {
                let d = accel(&layout.mass[i], &corr[i]);
                trial[i] = common::rotate_body(&pose[i], -d.v * step, -d.w * step);
            }
            sys.constraints(0.0, &trial, twist, Need::PHI, &mut ce);
            let r = worst(&ce);
            if r < res {
                res = r;
                pose.copy_from_slice(&trial);
                improved = true;
                break;
            }
            step /= 2.0;
        }
        sys.constraints(
            0.0,
            pose,
            twist,
            Need {
                phi: true,
                jac: true,
                gamma: false,
            },
            &mut ce,
        );
        if !improved {
            break;
        }
    }
    if res > tol.max(1e-9 * scale) {
        // name the joints with the largest residuals
        return Err(AssemblyError::Conflict {
            joints: joints_by_residual(layout, &ce.phi, &hol, tol)
                .into_iter()
                .take(4)
                .collect(),
            residual: res,
            level: "position",
        });
    }

    // velocities
    sys.constraints(0.0, pose, twist, Need::JAC, &mut ce);
    common::velocity_residual(layout, &ce, twist, &mut y);
    for r in 0..m {
        if !active[r] {
            y[r] = 0.0;
        }
    }
    let vbefore = y.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    ks.assemble(&ce.jac, &layout.mass, 1.0, 0.0, Some(&active));
    ks.factor()?;
    ks.solve_in_place(&mut y);
    common::bt_lambda(layout, &ce, &y, &active, &mut corr);
    for i in 0..nb {
        let d = accel(&layout.mass[i], &corr[i]);
        twist[i].v -= d.v;
        twist[i].w -= d.w;
    }
    common::velocity_residual(layout, &ce, twist, &mut y);
    let vafter = (0..m)
        .filter(|&r| active[r])
        .fold(0.0f64, |a, r| a.max(y[r].abs()));
    // The projection is exact when the velocity constraints are consistent; a residual left
    // over means rows that ask for contradicting velocities (a driver turning a joint that
    // another joint holds still), which the pseudo-inverse can only split the difference of.
    let vtol = 1e-9 * vbefore.max(1.0);
    if vafter > vtol {
        // The pseudo-inverse leaves the contradiction on whichever rows it drops, so name
        // with them the other joints on the same bodies: they are the other side of it.
        let mut joints = joints_by_residual(layout, &y, &active, vtol);
        let bodies: Vec<usize> = layout
            .joints
            .iter()
            .filter(|j| joints.contains(&j.name))
            .flat_map(|j| j.a.into_iter().chain(j.b))
            .collect();
        for j in &layout.joints {
            let shares = j.a.into_iter().chain(j.b).any(|b| bodies.contains(&b));
            if shares && !joints.contains(&j.name) {
                joints.push(j.name.clone());
            }
        }
        joints.truncate(6);
        return Err(AssemblyError::Conflict {
            joints,
            residual: vafter,
            level: "velocity",
        });
    }

    let moved = (0..nb)
        .filter_map(|i| {
            let dr = (pose[i].r - original[i].r).norm();
            let dq = original[i].q.conjugate() * pose[i].q;
            let rot = 2.0 * Vector3::new(dq.i, dq.j, dq.k).norm().atan2(dq.w.abs());
            let dv = (twist[i].v - original_twist[i].v).norm();
            let dw = (twist[i].w - original_twist[i].w).norm();
            (dr.max(rot).max(dv).max(dw) > 1e-15).then(|| Moved {
                body: layout.body_names[i].clone(),
                translation: dr,
                rotation: rot,
                velocity: dv,
                angular_velocity: dw,
            })
        })
        .collect();
    Ok(Assembly {
        moved,
        iterations,
        residual: (before, res),
        velocity_residual: (vbefore, vafter),
    })
}

/// The names of the joints with a row in `rows` whose `|residual|` exceeds `tol`, largest
/// residual first.
fn joints_by_residual(layout: &Layout, residual: &[f64], rows: &[bool], tol: f64) -> Vec<String> {
    let mut per_joint: Vec<(f64, &str)> = layout
        .joints
        .iter()
        .map(|j| {
            let v = (j.first_row..j.first_row + j.rows)
                .filter(|&r| rows[r])
                .fold(0.0f64, |a, r| a.max(residual[r].abs()));
            (v, j.name.as_str())
        })
        .filter(|(v, _)| *v > tol)
        .collect();
    per_joint.sort_by(|a, b| b.0.total_cmp(&a.0));
    per_joint.into_iter().map(|(_, n)| n.to_string()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::testsys::RodPendulum;

    #[test]
    fn moves_a_displaced_pendulum_back_onto_its_pivot() {
        let sys = RodPendulum::new(1.0, 1.0, 0.01, 0.5);
        let mut pose = vec![Pose::default()];
        let mut twist = vec![Twist::default()];
        sys.initial_state(&mut pose, &mut twist);
        pose[0].r += Vector3::new(0.01, -0.02, 0.005);
        twist[0].v = Vector3::new(0.3, 0.1, -0.2);
        let a = assemble(&sys, &mut pose, &mut twist).unwrap();
        assert!(a.residual.1 < 1e-12, "{a:?}");
        assert!(a.velocity_residual.1 < 1e-12, "{a:?}");
        assert_eq!(a.moved.len(), 1);
        let phi = pose[0].r + pose[0].c * Vector3::new(0.0, 0.0, 0.5);
        assert!(phi.norm() < 1e-12);
    }
}
