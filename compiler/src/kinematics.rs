//! Constraint residuals at the initial state, for `mbdc check`: how far each joint is from
//! being satisfied (positions and velocities), the rank of the constraint Jacobian, and
//! which joints are redundant.
//!
//! Everything is evaluated with the runtime's own joint kernels through
//! [`mbdc_runtime::interp::Interp`], so the check and the simulation can never disagree on
//! what a joint means. Scenes the rigid-body runtime cannot interpret (beams, meshes) are
//! not checked here.

use mbdc_runtime::interp::Interp;
use mbdc_runtime::scene::Scene;
use mbdc_runtime::system::{ConstraintEval, Need, Pose, RowKind, System, Twist};
use mbdc_runtime::topology;

/// Relative tolerance of the rank decision (see [`topology::redundancy`]).
pub const RANK_TOLERANCE: f64 = topology::DEFAULT_RANK_TOL;

/// The constraints at t = 0.
#[derive(Clone, Debug, PartialEq)]
pub struct InitialCheck {
    /// Per scene joint: largest |Φ| of its holonomic rows (m or rad) and largest velocity
    /// residual |B u̇ + b| of all its rows (m/s or rad/s).
    pub violations: Vec<(f64, f64)>,
    /// Numerical rank of the constraint Jacobian and its number of rows.
    pub rank: (usize, usize),
    /// One sentence per group of redundant joints, naming them.
    pub redundant: Vec<String>,
}

/// Evaluate the scene's constraints at its initial state; `None` if the rigid-body runtime
/// cannot interpret the scene (it has beams or meshes, or an invalid item that lowering has
/// already reported).
pub fn initial_check(scene: &Scene) -> Option<InitialCheck> {
    let sys = Interp::new(scene).ok()?;
    let layout = sys.layout();
    let (nb, m) = (layout.bodies(), layout.rows);
    let mut pose = vec![Pose::default(); nb];
    let mut twist = vec![Twist::default(); nb];
    sys.initial_state(&mut pose, &mut twist);
    let mut ce = ConstraintEval::new(m);
    sys.constraints(
        0.0,
        &pose,
        &twist,
        Need {
            phi: true,
            jac: true,
            gamma: false,
        },
        &mut ce,
    );
    let violations = scene
        .joints
        .iter()
        .enumerate()
        .map(|(j, _)| {
            let jl = &layout.joints[j];
            let (mut p, mut v) = (0.0f64, 0.0f64);
            for r in jl.first_row..jl.first_row + jl.rows {
                let (a, b) = layout.row_bodies(r);
                let row = &ce.jac[r];
                let dot = |blk: &[f64; 6], t: &Twist| {
                    blk[0] * t.v.x
                        + blk[1] * t.v.y
                        + blk[2] * t.v.z
                        + blk[3] * t.w.x
                        + blk[4] * t.w.y
                        + blk[5] * t.w.z
                };
                let mut vel = ce.bias[r];
                if let Some(a) = a {
                    vel += dot(&row.a, &twist[a]);
                }
                if let Some(b) = b {
                    vel += dot(&row.b, &twist[b]);
                }
                if layout.row_kind[r] == RowKind::Holonomic {
                    p = p.max(ce.phi[r].abs());
                }
                v = v.max(vel.abs());
            }
            (p, v)
        })
        .collect();
    let red = topology::redundancy(&ce.jac, layout, RANK_TOLERANCE);
    let active = (0..m)
        .filter(|&r| !layout.joints[layout.row_joint[r]].starts_inactive)
        .count();
    Some(InitialCheck {
        violations,
        rank: (active - red.dependent.len(), active),
        redundant: red.messages(layout),
    })
}

/// Per joint of the scene, its position and velocity residuals at t = 0 (zeros when the
/// scene cannot be checked).
pub fn initial_violations(scene: &Scene) -> Vec<(f64, f64)> {
    initial_check(scene).map_or_else(|| vec![(0.0, 0.0); scene.joints.len()], |c| c.violations)
}

/// Rank of the constraint Jacobian at t = 0 and its number of (initially active) rows.
pub fn jacobian_rank(scene: &Scene) -> Option<(usize, usize)> {
    initial_check(scene).map(|c| c.rank)
}
