//! Pieces every integrator shares: rigid-body accelerations with the gyroscopic term,
//! products with the constraint Jacobian `B` (row-wise, two bodies per row), assembly of
//! `B M⁻¹ Bᵀ`, and the consistent (index-1) multipliers.
//!
//! Sign convention: `M u̇' + Bᵀλ = F` (notes A §0, C §0).

use nalgebra::Vector3;

use crate::contract::system::{ConstraintEval, Layout, MassProps, Pose, RowKind, Twist, Wrench};
use crate::linalg::{
    Backend, Definiteness, KSolver, KSolverOptions, LinalgError, DEFAULT_PIVOT_TOL,
};

/// `ω × (J ω)`: the gyroscopic term `D_ω` of notes A eq. 37 (body components).
#[inline]
pub fn gyro(m: &MassProps, w: &Vector3<f64>) -> Vector3<f64> {
    w.cross(&(m.j * w))
}

/// Accelerations `(v̇, ω̇)` of one body from a net generalized force (already including the
/// gyroscopic term and the constraint forces).
#[inline]
pub fn accel(m: &MassProps, f: &Wrench) -> Twist {
    Twist {
        v: f.f / m.m,
        w: m.j_inv * f.t,
    }
}

/// `out[r] = (B u̇)_r` for every row.
pub fn b_times(layout: &Layout, jac: &ConstraintEval, vel: &[Twist], out: &mut [f64]) {
    for (r, o) in out.iter_mut().enumerate() {
        let (a, b) = layout.row_bodies(r);
        let row = &jac.jac[r];
        let mut s = 0.0;
        if let Some(a) = a {
            s += dot6(&row.a, &vel[a]);
        }
        if let Some(b) = b {
            s += dot6(&row.b, &vel[b]);
        }
        *o = s;
    }
}

/// `out[r] = (B M⁻¹ F)_r` for per-body generalized forces `f`.
pub fn b_minv(layout: &Layout, jac: &ConstraintEval, f: &[Wrench], out: &mut [f64]) {
    for (r, o) in out.iter_mut().enumerate() {
        let (a, b) = layout.row_bodies(r);
        let row = &jac.jac[r];
        let mut s = 0.0;
        if let Some(a) = a {
            s += dot6(&row.a, &accel(&layout.mass[a], &f[a]));
        }
        if let Some(b) = b {
            s += dot6(&row.b, &accel(&layout.mass[b], &f[b]));
        }
        *o = s;
    }
}

/// `out = Bᵀλ` as per-body generalized forces (overwrites `out`). Rows with
/// `active[r] == false` contribute nothing.
pub fn bt_lambda(
    layout: &Layout,
    jac: &ConstraintEval,
    lambda: &[f64],
    active: &[bool],
    out: &mut [Wrench],
) {
    for w in out.iter_mut() {
        *w = Wrench::default();
    }
    for r in 0..layout.rows {
        if !active[r] || lambda[r] == 0.0 {
            continue;
        }
        let (a, b) = layout.row_bodies(r);
        let row = &jac.jac[r];
        let l = lambda[r];
        if let Some(a) = a {
            add6(&mut out[a], &row.a, l);
        }
        if let Some(b) = b {
            add6(&mut out[b], &row.b, l);
        }
    }
}

#[inline]
fn dot6(row: &[f64; 6], t: &Twist) -> f64 {
    row[0] * t.v.x
        + row[1] * t.v.y
        + row[2] * t.v.z
        + row[3] * t.w.x
        + row[4] * t.w.y
        + row[5] * t.w.z
}

/// `w += l · row` for a Jacobian row block `[v (3), ω (3)]`.
#[inline]
pub fn add6(w: &mut Wrench, row: &[f64; 6], l: f64) {
    w.f.x += row[0] * l;
    w.f.y += row[1] * l;
    w.f.z += row[2] * l;
    w.t.x += row[3] * l;
    w.t.y += row[4] * l;
    w.t.z += row[5] * l;
}

/// The constraint rows' velocity-level residual `B u̇ + bias`.
pub fn velocity_residual(layout: &Layout, ce: &ConstraintEval, vel: &[Twist], out: &mut [f64]) {
    b_times(layout, ce, vel, out);
    for (o, b) in out.iter_mut().zip(&ce.bias) {
        *o += b;
    }
}

/// Net generalized force `Q̄ = F_applied − ω × Jω` with the gyroscopic term evaluated at
/// the angular velocities `w_gyro` (which may come from another sequence than `F`).
pub fn qbar(layout: &Layout, applied: &[Wrench], w_gyro: &[Twist], out: &mut [Wrench]) {
    for i in 0..layout.bodies() {
        out[i] = Wrench {
            f: applied[i].f,
            t: applied[i].t - gyro(&layout.mass[i], &w_gyro[i].w),
        };
    }
}

/// Whether a row is enforced (`active`) — inactive rows are locks not yet engaged.
pub fn initial_activity(layout: &Layout) -> Vec<bool> {
    let mut active = vec![true; layout.rows];
    for j in &layout.joints {
        if j.starts_inactive {
            for a in &mut active[j.first_row..j.first_row + j.rows] {
                *a = false;
            }
        }
    }
    active
}

/// Number of holonomic rows.
pub fn holonomic_rows(layout: &Layout) -> usize {
    layout
        .row_kind
        .iter()
        .filter(|k| **k == RowKind::Holonomic)
        .count()
}

/// Consistent (index-1) multipliers: solve `B M⁻¹ Bᵀ λ = B M⁻¹ Q̄ − γ` (notes A eq. 5).
/// Inactive rows get λ = 0; numerically dependent rows get λ = 0 too (a basic solution of
/// the semidefinite system, [`crate::linalg::PivotedCholesky`]).
pub struct Index1 {
    ks: KSolver,
    rhs: Vec<f64>,
}

impl Index1 {
    /// Buffers for `layout`.
    pub fn new(layout: &Layout) -> Result<Index1, LinalgError> {
        let ks = KSolver::new(
            layout,
            KSolverOptions {
                backend: Backend::Auto,
                definiteness: Definiteness::SemiDefinite {
                    tol: DEFAULT_PIVOT_TOL,
                },
            },
        )?;
        Ok(Index1 {
            ks,
            rhs: vec![0.0; layout.rows],
        })
    }

    /// Solve for λ given the evaluated constraints (with `gamma`) and `Q̄`. Returns the
    /// numerical rank of the active rows.
    pub fn solve(
        &mut self,
        layout: &Layout,
        ce: &ConstraintEval,
        qbar: &[Wrench],
        active: &[bool],
        lambda: &mut [f64],
    ) -> Result<usize, LinalgError> {
        self.ks
            .assemble(&ce.jac, &layout.mass, 1.0, 0.0, Some(active));
        b_minv(layout, ce, qbar, &mut self.rhs);
        for r in 0..layout.rows {
            self.rhs[r] = if active[r] {
                self.rhs[r] - ce.gamma[r]
            } else {
                0.0
            };
        }
        let stats = self.ks.factor()?;
        self.ks.solve_in_place(&mut self.rhs);
        lambda.copy_from_slice(&self.rhs);
        Ok(stats.rank)
    }
}

/// Largest diagonal entry and largest Gershgorin row sum (an upper bound of the largest
/// eigenvalue) of the matrix assembled in `ks`, over active rows; the diagonal itself goes to
/// `diag_out`.
pub fn k_bounds(ks: &KSolver, active: &[bool], diag_out: &mut [f64]) -> (f64, f64) {
    let k = ks.matrix();
    let p = k.pattern();
    let (cp, ri, v) = (p.col_ptr(), p.row_idx(), k.values());
    let n = p.rows();
    let mut diag: f64 = 0.0;
    let mut rowsum = vec![0.0; n];
    for s in 0..n {
        for e in cp[s]..cp[s + 1] {
            let r = ri[e];
            if !active[r] || !active[s] {
                continue;
            }
            if r == s {
                diag_out[r] = v[e];
                diag = diag.max(v[e]);
                rowsum[r] += v[e].abs();
            } else {
                rowsum[r] += v[e].abs();
                rowsum[s] += v[e].abs();
            }
        }
    }
    (diag, rowsum.into_iter().fold(0.0, f64::max))
}

/// A pose advanced by a rotation vector `phi` (body components): `q ⊗ exp(φ/2)`.
pub fn rotate_body(p: &Pose, dr: Vector3<f64>, phi: Vector3<f64>) -> Pose {
    let a = phi.norm();
    let (s, c) = if a > 0.0 {
        ((a / 2.0).sin() / a, (a / 2.0).cos())
    } else {
        (0.5, 1.0)
    };
    let dq = nalgebra::Quaternion::new(c, s * phi.x, s * phi.y, s * phi.z);
    Pose::new(p.r + dr, p.q * dq)
}
