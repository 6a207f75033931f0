//! The highest frequency of the *constrained* linearized system at t = 0 (issue 21, "a step
//! check that sees the constraints").
//!
//! [`step_limits::estimate`](super::step_limits::estimate) looks at each spring, spin and
//! pivot alone; a spring on a short lever, a light link between heavy ones, or a chain held in
//! tension by a joint's force has a constrained frequency it does not see. Here the equations
//! of motion `M u̇' + Bᵀλ = F(q)`, `B u̇ = 0` are linearized about the initial state:
//!
//! - coordinates: per body the mass-centre displacement (world) and a small rotation (body
//!   axes, the frame of the angular velocity the Jacobian is written against), `6n` in all;
//! - stiffness `K = −∂(F − Bᵀλ)/∂q` by central differences of [`System::applied`] (springs,
//!   contact, forces that follow the body) and of the Jacobian times the multipliers of the
//!   initial state (the geometric stiffness of the constraint forces: the tension that makes a
//!   pendulum swing, the load a light link carries between heavy ones), symmetrized;
//! - `λ` consistent with the initial state: `(B M⁻¹ Bᵀ) λ = B M⁻¹ F̄ − γ` (least squares, so
//!   redundant rows are fine), `F̄` the applied forces less the gyroscopic torque;
//! - the constraint null space from the symmetric eigendecomposition of `B̃ᵀB̃`, `B̃ = B M^{-1/2}`
//!   (the mass-weighted Jacobian; rows whose singular value is below 10⁻⁶ of the largest
//!   count as dependent), and the modes of `Zᵀ M^{-1/2} K M^{-1/2} Z` with `Z` its orthonormal
//!   basis — the generalized symmetric eigenproblem `Zᵀ K Z x = ω² Zᵀ M Z x` in the
//!   mass-weighted form.
//!
//! The largest positive eigenvalue is `ω²` of the fastest constrained mode. The mode is
//! named by the body with the largest share of its kinetic energy and, when a joint's
//! geometric stiffness holds at least half of its stiffness energy, that joint.
//!
//! Limits: dense, `O((6n)³)`; skipped (with a note) above [`MAX_COORDINATES`] coordinates,
//! and for scenes with beams or meshes (their element limits are checked on their own). The
//! gyroscopic stiffness of spinning bodies is not linearized (their spin is a source of its
//! own in `step_limits`), nor are locks that start open. It is a t = 0 estimate: a
//! configuration far from the initial one can be stiffer, which the run's watchdog sees.

use nalgebra::{DMatrix, DVector, Matrix3, SymmetricEigen, Vector3};

use crate::contract::math::{axis_angle, qmul};
use crate::contract::system::{ConstraintEval, Need, Pose, System, Twist, Wrench};

/// Largest system (6 × bodies) the constrained analysis factors densely: about 0.1 s in a
/// release build, a second in a debug one.
pub const MAX_COORDINATES: usize = 300;

/// The fastest mode of the constrained linearized system.
#[derive(Clone, Debug, PartialEq)]
pub struct Mode {
    /// Angular frequency, rad/s.
    pub omega: f64,
    /// Body index with the largest share of the mode's kinetic energy.
    pub body: usize,
    /// That share (0–1).
    pub body_share: f64,
    /// The joint (layout index) whose constraint force stiffens the mode most, when it
    /// holds at least half of the mode's stiffness energy.
    pub joint: Option<usize>,
}

/// What the analysis found.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// The fastest mode, or `None` when the constrained system has no positive stiffness
    /// (free motion, or every degree of freedom held).
    Done(Option<Mode>),
    /// Not analysed, and why (too large, or the initial state is not finite).
    Skipped(String),
    /// Not analysed: the scene has beams or meshes, whose element limits are checked on
    /// their own.
    Elsewhere,
}

/// The fastest mode of `sys` linearized about its initial state at t = 0.
pub fn fastest<S: System>(sys: &S) -> Outcome {
    let layout = sys.layout();
    let n = layout.bodies();
    let dim = 6 * n;
    if n == 0 {
        return Outcome::Done(None);
    }
    if !layout.beams.is_empty() || !layout.meshes.is_empty() {
        return Outcome::Elsewhere;
    }
    if dim > MAX_COORDINATES {
        return Outcome::Skipped(format!(
            "the constrained step check skips scenes of more than {} bodies ({n} here): its dense eigenproblem would take too long",
            MAX_COORDINATES / 6
        ));
    }
    let mut pose = vec![Pose::default(); n];
    let mut twist = vec![Twist::default(); n];
    sys.initial_state(&mut pose, &mut twist);

    // mass weighting W = M^{-1/2}, per body (1/√m, J^{-1/2})
    let mut w_rot: Vec<Matrix3<f64>> = Vec::with_capacity(n);
    let mut gyr = 0.0f64; // largest radius of gyration, the length scale of perturbations
    for mp in &layout.mass {
        let e = SymmetricEigen::new(mp.j);
        if e.eigenvalues.iter().any(|&v| v.is_nan() || v <= 0.0) || mp.m.is_nan() || mp.m <= 0.0 {
            return Outcome::Skipped("a body without positive mass and inertia".into());
        }
        let d = Matrix3::from_diagonal(&e.eigenvalues.map(|v| 1.0 / v.sqrt()));
        w_rot.push(e.eigenvectors * d * e.eigenvectors.transpose());
        gyr = gyr.max((mp.j.trace() / (2.0 * mp.m)).sqrt());
    }
    let w_lin: Vec<f64> = layout.mass.iter().map(|mp| 1.0 / mp.m.sqrt()).collect();
    // a vector of generalized coordinates (6 per body) times W
    let weigh = |x: &DVector<f64>| -> DVector<f64> {
        let mut y = DVector::zeros(dim);
        for i in 0..n {
            for c in 0..3 {
                y[6 * i + c] = x[6 * i + c] * w_lin[i];
            }
            let r = w_rot[i] * Vector3::new(x[6 * i + 3], x[6 * i + 4], x[6 * i + 5]);
            for c in 0..3 {
                y[6 * i + 3 + c] = r[c];
            }
        }
        y
    };

    // active rows and their Jacobian
    let rows: Vec<usize> = (0..layout.rows)
        .filter(|&r| !layout.joints[layout.row_joint[r]].starts_inactive)
        .collect();
    let mut ev = ConstraintEval::new(layout.rows);
    sys.constraints(0.0, &pose, &twist, Need::ALL, &mut ev);
    let jac_matrix = |ev: &ConstraintEval| -> DMatrix<f64> {
        let mut b = DMatrix::zeros(rows.len(), dim);
        for (k, &r) in rows.iter().enumerate() {
            let (a, bb) = layout.row_bodies(r);
            for (side, blk) in [(a, &ev.jac[r].a), (bb, &ev.jac[r].b)] {
                if let Some(i) = side {
                    for c in 0..6 {
                        b[(k, 6 * i + c)] += blk[c];
                    }
                }
            }
        }
        b
    };
    let b = jac_matrix(&ev);
    if b.iter().any(|v| !v.is_finite()) {
        return Outcome::Skipped("the constraint Jacobian at t = 0 is not finite".into());
    }
    // B̃ = B W (W symmetric, so row-wise: each row times W)
    let mut bt = DMatrix::zeros(rows.len(), dim);
    for k in 0..rows.len() {
        let row = DVector::from_iterator(dim, b.row(k).iter().copied());
        bt.set_row(k, &weigh(&row).transpose());
    }

    // applied forces less the gyroscopic torque, as a 6n vector
    let mut wr = vec![Wrench::default(); n];
    let gen_force = |pose: &[Pose], wr: &mut [Wrench]| -> DVector<f64> {
        sys.applied(0.0, pose, &twist, wr);
        let mut f = DVector::zeros(dim);
        for i in 0..n {
            let mp = &layout.mass[i];
            let t = wr[i].t - twist[i].w.cross(&(mp.j * twist[i].w));
            for c in 0..3 {
                f[6 * i + c] = wr[i].f[c];
                f[6 * i + 3 + c] = t[c];
            }
        }
        f
    };
    let f0 = gen_force(&pose, &mut wr);
    if f0.iter().any(|v| !v.is_finite()) {
        return Outcome::Skipped("the applied forces at t = 0 are not finite".into());
    }
    // consistent multipliers: (B̃B̃ᵀ) λ = B̃ W F̄ − γ, least squares
    let lambda: DVector<f64> = if rows.is_empty() {
        DVector::zeros(0)
    } else {
        let a = &bt * bt.transpose();
        let gamma = DVector::from_iterator(rows.len(), rows.iter().map(|&r| ev.gamma[r]));
        let rhs = &bt * weigh(&f0) - gamma;
        let scale = a.amax().max(f64::MIN_POSITIVE);
        match a.svd(true, true).solve(&rhs, 1e-10 * scale) {
            Ok(l) if l.iter().all(|v| v.is_finite()) => l,
            _ => return Outcome::Skipped("the initial multipliers could not be found".into()),
        }
    };

    // perturbations: δ·x applied to every body
    let step_lin = 1e-6 * gyr.max(1e-6);
    let displaced = |x: &DVector<f64>, d: f64| -> Vec<Pose> {
        let mut p = pose.clone();
        for i in 0..n {
            p[i].r += Vector3::new(x[6 * i], x[6 * i + 1], x[6 * i + 2]) * d;
            let rot = Vector3::new(x[6 * i + 3], x[6 * i + 4], x[6 * i + 5]) * d;
            let q = qmul(&p[i].q, &axis_angle(&rot, rot.norm()));
            p[i].set_q(q);
        }
        p
    };
    // Bᵀλ at a configuration, and each joint's part of it dotted with x
    let mut ev_d = ConstraintEval::new(layout.rows);
    let mut bt_lambda = |p: &[Pose], x: Option<&DVector<f64>>, per_joint: &mut [f64]| {
        sys.constraints(0.0, p, &twist, Need::JAC, &mut ev_d);
        let bb = jac_matrix(&ev_d);
        if let Some(x) = x {
            for (k, &r) in rows.iter().enumerate() {
                per_joint[layout.row_joint[r]] += lambda[k] * bb.row(k).dot(&x.transpose());
            }
        }
        bb.transpose() * &lambda
    };
    let mut scratch = vec![0.0; layout.joints.len()];
    let mut k = DMatrix::zeros(dim, dim);
    for c in 0..dim {
        let d = if c % 6 < 3 { step_lin } else { 1e-6 };
        let mut e = DVector::zeros(dim);
        e[c] = 1.0;
        let (pp, pm) = (displaced(&e, d), displaced(&e, -d));
        let gp = gen_force(&pp, &mut wr) - bt_lambda(&pp, None, &mut scratch);
        let gm = gen_force(&pm, &mut wr) - bt_lambda(&pm, None, &mut scratch);
        let col = -(gp - gm) / (2.0 * d);
        k.set_column(c, &col);
    }
    // K̃ = W K W, symmetrized
    let mut kw = DMatrix::zeros(dim, dim);
    for c in 0..dim {
        let col = DVector::from_iterator(dim, k.column(c).iter().copied());
        kw.set_column(c, &weigh(&col));
    }
    let mut kt = DMatrix::zeros(dim, dim);
    for r in 0..dim {
        let row = DVector::from_iterator(dim, kw.row(r).iter().copied());
        kt.set_row(r, &weigh(&row).transpose());
    }
    let kt = (&kt + kt.transpose()) * 0.5;
    if kt.iter().any(|v| !v.is_finite()) {
        return Outcome::Skipped("the stiffness at t = 0 is not finite".into());
    }

    // null space of B̃
    let z = if rows.is_empty() {
        DMatrix::identity(dim, dim)
    } else {
        let e = SymmetricEigen::new(bt.transpose() * &bt);
        let top = e.eigenvalues.amax();
        let cols: Vec<usize> = (0..dim)
            .filter(|&c| e.eigenvalues[c] <= 1e-12 * top)
            .collect();
        if cols.is_empty() {
            return Outcome::Done(None);
        }
        e.eigenvectors.select_columns(&cols)
    };
    let reduced = z.transpose() * &kt * &z;
    let e = SymmetricEigen::new(reduced);
    let (imax, lmax) = e
        .eigenvalues
        .iter()
        .copied()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((0, 0.0));
    // a stiffness below round-off of the largest entry is no mode
    if !lmax.is_finite() || lmax <= 1e-9 * kt.amax() {
        return Outcome::Done(None);
    }
    let y = &z * e.eigenvectors.column(imax);
    let (body, share) = (0..n)
        .map(|i| (i, (0..6).map(|c| y[6 * i + c].powi(2)).sum::<f64>()))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((0, 0.0));
    let share = share / y.norm_squared().max(f64::MIN_POSITIVE);
    // the mode in physical coordinates, and each joint's geometric stiffness energy along it
    let u = weigh(&y);
    let (mut lin, mut rot) = (0.0f64, 0.0f64);
    for i in 0..n {
        for c in 0..3 {
            lin = lin.max(u[6 * i + c].abs());
            rot = rot.max(u[6 * i + 3 + c].abs());
        }
    }
    let d = 1e-6 / (lin / gyr.max(1e-6)).max(rot).max(f64::MIN_POSITIVE);
    let mut plus = vec![0.0; layout.joints.len()];
    let mut minus = vec![0.0; layout.joints.len()];
    let (pp, pm) = (displaced(&u, d), displaced(&u, -d));
    let fp = gen_force(&pp, &mut wr);
    let fm = gen_force(&pm, &mut wr);
    bt_lambda(&pp, Some(&u), &mut plus);
    bt_lambda(&pm, Some(&u), &mut minus);
    let applied_energy = -u.dot(&(fp - fm)) / (2.0 * d);
    let joint_energy: Vec<f64> = plus
        .iter()
        .zip(&minus)
        .map(|(p, m)| (p - m) / (2.0 * d))
        .collect();
    let total: f64 = applied_energy.max(0.0) + joint_energy.iter().map(|e| e.max(0.0)).sum::<f64>();
    let joint = joint_energy
        .iter()
        .copied()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .filter(|&(_, e)| e > 0.5 * total)
        .map(|(j, _)| j);
    Outcome::Done(Some(Mode {
        omega: lmax.sqrt(),
        body,
        body_share: share,
        joint,
    }))
}
