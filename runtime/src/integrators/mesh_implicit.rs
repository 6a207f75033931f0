//! Finite-element meshes by the implicit analyses of `simulate { mesh_method NAME }`, with
//! the assembled linear stiffness ([`crate::analysis::mesh_stiffness`]) and faer's sparse
//! Cholesky ([`SparseCholesky`]), factored once before the run:
//!
//! - **`newmark`**: Newmark's average acceleration (β = ¼, γ = ½: the trapezoidal rule) with
//!   the lumped mass `M`, in displacement form with the constant step `h`:
//!
//!   ```text
//!   (K + 4/h² M) u^{n+1} = f^{n+1} + M (4/h² uⁿ + 4/h vⁿ + aⁿ)      (free dofs; K_fc u_c moved right)
//!   a^{n+1} = 4/h² (u^{n+1} − uⁿ) − 4/h vⁿ − aⁿ,   v^{n+1} = vⁿ + h/2 (aⁿ + a^{n+1})
//!   ```
//!
//!   Unconditionally stable and second order, without numerical damping; for a linear
//!   undamped mesh it conserves `½ vᵀMv + ½ uᵀKu − W` exactly (W the loads' work by the
//!   trapezoidal rule, which is the method's own), and a mode of frequency ω keeps its
//!   amplitude and turns by `2 atan(ωh/2)` per step: the period lengthens by the factor
//!   `ωh / (2 atan(ωh/2)) ≈ 1 + (ωh)²/12`. The step sets accuracy, not stability.
//! - **`static`**: `K u(t) = f(t)` at every step time (loads and prescribed displacements
//!   as functions of t, no inertia: a sequence of equilibria, each exact up to round-off;
//!   the velocities are zero). Its energy balance is Clapeyron's: the work of the loads
//!   applied proportionally from zero is `½ (f + r)·u`, which equals the strain energy at
//!   equilibrium. The relative residual `‖K u − f‖/‖f‖` of the free dofs is reported
//!   (largest over the steps).
//!
//! Prescribed components follow `g(t)` (with `g'`, `g''` in the dynamic case); their
//! reactions `r_c = [K_cf K_cc] u + m_c a_c − f_c` enter the work. Element stresses,
//! strains and energies are evaluated from the solution with the same kernels as the
//! explicit method. A step allocates nothing.

use std::sync::Arc;

use super::mesh_dynamics::{MeshEnergy, MeshState};
use super::mesh_feti::Feti;
use super::mesh_glue::Glued;
use super::{Integrator, State, StepError, StepInfo};
use crate::analysis::mesh_model::{critical_step, elastic, element_x0, options};
use crate::analysis::mesh_stiffness::{self, MeshStiffness};
use crate::contract::mesh_layout::MeshLayout;
use crate::contract::ranks::Ranks;
use crate::contract::scene::{MeshMethod, MeshSolver};
use crate::contract::system::System;
use crate::kernels::fn1;
use crate::kernels::solid::{self, ElementResponse, MAX_NODES};
use crate::linalg::{Definiteness, LinalgError, SparseCholesky};

/// The relative residual `‖A u − b‖/‖b‖` of an implicit analysis's linear solves above
/// which the run warns ([`MeshImplicit::residual_warning`]): a direct factorization leaves
/// round-off (10⁻¹⁵–10⁻¹²), FETI at its default tolerance about 10⁻⁹.
pub const RESIDUAL_WARNING: f64 = 1e-6;

/// The meshes' implicit integrator (Newmark) or static solver (see the module doc).
pub struct MeshImplicit {
    layout: Arc<MeshLayout>,
    method: MeshMethod,
    h: f64,
    t: f64,
    k: MeshStiffness,
    solver: LinearSolve,
    /// The lumped mass of every free dof.
    mass_free: Vec<f64>,
    /// Displacement, velocity, acceleration, three per node.
    u: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    u_prev: Vec<f64>,
    /// External force at the current time, and the support reactions (non-zero on the
    /// constrained dofs only), with their values at the previous step.
    f: Vec<f64>,
    f_prev: Vec<f64>,
    reaction: Vec<f64>,
    reaction_prev: Vec<f64>,
    /// Free-size buffers: right-hand side / solution, the right-hand side kept, a product,
    /// the effective right-hand side kept (FETI's residual check).
    rhs: Vec<f64>,
    b: Vec<f64>,
    tmp: Vec<f64>,
    kept: Vec<f64>,
    /// The diagonal `4/h² M` of Newmark's matrix (empty for static).
    diag: Vec<f64>,
    /// Constrained-size buffer of `[K_cf K_cc] u`.
    rc: Vec<f64>,
    stress: Vec<[f64; 6]>,
    strain: Vec<[f64; 6]>,
    energy: MeshEnergy,
    /// Largest relative residual so far: of every static solve, and of Newmark's FETI
    /// solves.
    residual: f64,
    notice: Option<String>,
}

/// How the matrix is solved: factored whole, or torn into FETI subdomains.
enum LinearSolve {
    Direct(Box<SparseCholesky>),
    Feti(Box<Feti>),
    /// Meshes glued by reduced multipliers; the mask of the glued interface dofs, whose
    /// equations hold only with the interface force.
    Glued(Box<Glued>, Vec<bool>),
}

/// The mesh (its name) that holds flattened node `node`, and that mesh's first node.
fn mesh_of_node(l: &MeshLayout, node: usize) -> (String, usize) {
    let i = l
        .blocks
        .partition_point(|b| b.first_node <= node)
        .saturating_sub(1);
    l.blocks
        .get(i)
        .map_or((String::new(), 0), |b| (b.name.clone(), b.first_node))
}

/// The error of a failed factorization, in the user's terms: the node and component whose
/// stiffness is missing.
fn factor_error(
    l: &MeshLayout,
    k: &MeshStiffness,
    e: LinalgError,
    method: MeshMethod,
) -> StepError {
    let (mesh, place) = match e {
        LinalgError::NotPositiveDefinite { row, .. } | LinalgError::NonFinite { row } => {
            let g = k.assembly.free().get(row).copied().unwrap_or(0) as usize;
            let node = g / 3;
            let (name, first) = mesh_of_node(l, node);
            let x = l.x0.get(node).copied().unwrap_or_default();
            (
                name,
                format!(
                    "node {} at ({:.4}, {:.4}, {:.4}) m, component {}",
                    node - first,
                    x[0],
                    x[1],
                    x[2],
                    ["x", "y", "z"][g % 3]
                ),
            )
        }
        other => {
            return StepError::Linalg {
                what: "mesh stiffness",
                message: other.to_string(),
            }
        }
    };
    let why = match method {
        MeshMethod::Static => "the stiffness matrix is singular there: the mesh (or a part of it) can move without straining (a rigid-body motion, a bar's transverse motion, a mechanism); fix or `displace` enough components to hold it (a static analysis has no inertia to resist that motion)",
        _ => "the effective matrix K + 4/h² M is not positive definite there",
    };
    StepError::Mesh {
        mesh,
        place,
        message: why.into(),
    }
}

impl MeshImplicit {
    /// Build the stiffness, factor the matrix of `method` (`K`, or `K + 4/h² M`) and start
    /// at `t0` from `start` (an empty state starts at rest, undeformed; `static` solves the
    /// equilibrium at `t0`).
    ///
    /// # Errors
    /// What [`mesh_stiffness::linear_refusal`] refuses, a singular matrix (the node and
    /// component named), a free dof without mass under Newmark.
    pub fn new(
        layout: Arc<MeshLayout>,
        method: MeshMethod,
        h: f64,
        t0: f64,
        start: &MeshState,
    ) -> Result<MeshImplicit, super::StartError> {
        MeshImplicit::on_ranks(layout, method, h, t0, start, None)
    }

    /// [`MeshImplicit::new`] as one rank of `ranks` (collective: every rank calls it with
    /// the same layout): FETI then factors and iterates only this rank's subdomains
    /// ([`Feti::on_ranks`]) and hands every rank the whole displacement; the rest of the
    /// analysis (the direct solver too) is replicated. `None` is a run in one process.
    ///
    /// # Errors
    /// What [`MeshImplicit::new`] refuses; fewer FETI subdomains than ranks.
    pub fn on_ranks(
        layout: Arc<MeshLayout>,
        method: MeshMethod,
        h: f64,
        t0: f64,
        start: &MeshState,
        ranks: Option<Arc<dyn Ranks>>,
    ) -> Result<MeshImplicit, super::StartError> {
        let l = &*layout;
        if let Some(e) = mesh_stiffness::linear_refusal(l, method) {
            return Err(super::StartError::Invalid(e.to_string()));
        }
        let k =
            mesh_stiffness::assemble(l).map_err(|e| super::StartError::Invalid(e.to_string()))?;
        let asm = &k.assembly;
        let nf = asm.free().len();
        let mass_free: Vec<f64> = asm.free().iter().map(|&g| l.mass[g as usize / 3]).collect();
        let mut diag = Vec::new();
        if method == MeshMethod::Newmark {
            if let Some(j) = mass_free.iter().position(|&m| !(m.is_finite() && m > 0.0)) {
                return Err(factor_error(
                    l,
                    &k,
                    LinalgError::NotPositiveDefinite { step: 0, row: j },
                    method,
                )
                .into());
            }
            let c = 4.0 / (h * h);
            diag = mass_free.iter().map(|m| c * m).collect();
        }
        let mut notice = None;
        if !l.glues.is_empty() && (method != MeshMethod::Static || !l.solver.is_direct()) {
            return Err(super::StartError::Invalid(format!(
                "glued meshes ('{}' to '{}') are solved by `mesh_method static` with the direct solver for now",
                l.glues[0].mesh, l.glues[0].other_mesh
            )));
        }
        let solver = match l.solver {
            MeshSolver::Direct if !l.glues.is_empty() => {
                let g = Glued::new(l, asm).map_err(super::StartError::Invalid)?;
                let mut mask = vec![false; nf];
                g.glued_dofs(&mut mask);
                notice = Some(format!(
                    "glue: {} meshes, {} glue(s), {} interface parameters",
                    l.blocks.len(),
                    l.glues.len(),
                    g.multipliers()
                ));
                LinearSolve::Glued(Box::new(g), mask)
            }
            MeshSolver::Direct => {
                let mut chol =
                    SparseCholesky::new(nf, asm.col_ptr(), asm.row_idx(), Definiteness::Positive)?;
                chol.values_mut().copy_from_slice(&k.free);
                let vals = chol.values_mut();
                for (j, d) in diag.iter().enumerate() {
                    vals[asm.diagonal(j)] += d;
                }
                chol.factor().map_err(|e| factor_error(l, &k, e, method))?;
                LinearSolve::Direct(Box::new(chol))
            }
            MeshSolver::Feti(opts) => {
                let d = (!diag.is_empty()).then_some(&diag[..]);
                let feti =
                    Feti::on_ranks(l, asm, d, opts, ranks).map_err(super::StartError::Invalid)?;
                let t = feti.tearing();
                let spread = if feti.ranks() > 1 {
                    let here = feti.subdomains_here();
                    format!(
                        ", on {} ranks (this rank {}: subdomains {}..{})",
                        feti.ranks(),
                        feti.rank(),
                        here.start,
                        here.end
                    )
                } else {
                    String::new()
                };
                notice = Some(format!(
                    "feti: {} subdomains ({} floating, {} rigid-body modes), {} interface multipliers, preconditioner {}{spread}",
                    t.subdomains.len(),
                    t.floating(),
                    t.modes(),
                    t.multipliers.len(),
                    opts.preconditioner.name()
                ));
                LinearSolve::Feti(Box::new(feti))
            }
        };
        let n = 3 * l.nodes();
        let ne = l.elements();
        let (u, v) = if start.u.len() == l.nodes() && start.v.len() == l.nodes() {
            (
                start.u.as_flattened().to_vec(),
                start.v.as_flattened().to_vec(),
            )
        } else {
            (vec![0.0; n], vec![0.0; n])
        };
        let step_notice = match (method, critical_step(l)) {
            (MeshMethod::Newmark, Some(c)) if h * c.omega > 0.5 => Some(format!(
                "newmark: the step {h:.3e} s is stable at any size, but it resolves only the modes of periods above about 20 steps ({:.3e} s; the period of a mode with ωh = 0.3 lengthens by 0.75 %, by (ωh)²/12 in general); the mesh's highest element frequency is {:.4e} rad/s (ωh = {:.2}), so its fast modes are integrated stably but not accurately",
                20.0 * h,
                c.omega,
                c.omega * h
            )),
            _ => None,
        };
        let notice = match (notice, step_notice) {
            (Some(a), Some(b)) => Some(format!("{a}\n{b}")),
            (a, b) => a.or(b),
        };
        let nc = asm.constrained().len();
        let mut s = MeshImplicit {
            method,
            h,
            t: t0,
            solver,
            mass_free,
            a: vec![0.0; n],
            u_prev: u.clone(),
            u,
            v,
            f: vec![0.0; n],
            f_prev: vec![0.0; n],
            reaction: vec![0.0; n],
            reaction_prev: vec![0.0; n],
            rhs: vec![0.0; nf],
            b: vec![0.0; nf],
            tmp: vec![0.0; nf],
            kept: vec![0.0; nf],
            diag,
            rc: vec![0.0; nc],
            stress: vec![[0.0; 6]; ne],
            strain: vec![[0.0; 6]; ne],
            energy: if start.u.len() == l.nodes() {
                start.energy
            } else {
                MeshEnergy::default()
            },
            residual: 0.0,
            notice,
            k,
            layout,
        };
        s.loads(t0);
        s.prescribe(t0);
        match method {
            MeshMethod::Static => s.solve_static()?,
            _ => s.initial_acceleration(),
        }
        s.reactions();
        if method == MeshMethod::Static {
            s.clapeyron();
        }
        s.elements()?;
        Ok(s)
    }

    /// The external forces at `t` (body forces and loads), three per node.
    fn loads(&mut self, t: f64) {
        let l = &*self.layout;
        if l.body_force.is_empty() {
            self.f.iter_mut().for_each(|x| *x = 0.0);
        } else {
            self.f.copy_from_slice(l.body_force.as_flattened());
        }
        for g in &l.loads {
            let val = [
                fn1::eval(&g.value[0], t).v,
                fn1::eval(&g.value[1], t).v,
                fn1::eval(&g.value[2], t).v,
            ];
            for (&n, &w) in g.nodes.iter().zip(&g.weights) {
                for k in 0..3 {
                    self.f[3 * n as usize + k] += w * val[k];
                }
            }
        }
    }

    /// The constrained components at `t`: fixed ones zero, prescribed ones `g`, `g'`, `g''`.
    fn prescribe(&mut self, t: f64) {
        for &g in self.k.assembly.constrained() {
            let g = g as usize;
            self.u[g] = 0.0;
            self.v[g] = 0.0;
            self.a[g] = 0.0;
        }
        for p in &self.layout.prescribed {
            let j = fn1::eval(&p.value, t);
            let g = 3 * p.node as usize + p.dof as usize;
            self.u[g] = j.v;
            if self.method == MeshMethod::Newmark {
                self.v[g] = j.d1;
                self.a[g] = j.d2;
            }
        }
    }

    /// `b = f_f − K_fc u_c` at the current loads and constrained values, into `self.b`.
    fn static_rhs(&mut self) {
        let asm = &self.k.assembly;
        for (bj, &g) in self.b.iter_mut().zip(asm.free()) {
            *bj = self.f[g as usize];
        }
        asm.sub_coupling(&self.k.constrained, &self.u, &mut self.b);
    }

    /// Solve the method's matrix for `self.rhs` in place. A FETI solve's relative residual
    /// `‖A x − b‖/‖b‖` (against the assembled matrix) is recorded.
    fn solve_rhs(&mut self) -> Result<(), StepError> {
        match &mut self.solver {
            LinearSolve::Direct(chol) => chol.solve_in_place(&mut self.rhs),
            LinearSolve::Feti(feti) => {
                self.kept.copy_from_slice(&self.rhs);
                feti.solve_in_place(&mut self.rhs)?;
                let asm = &self.k.assembly;
                asm.mul_free(&self.k.free, &self.rhs, &mut self.tmp);
                let (mut num, mut den) = (0.0, 0.0);
                for j in 0..self.rhs.len() {
                    let d = self.diag.get(j).copied().unwrap_or(0.0);
                    let e = self.tmp[j] + d * self.rhs[j] - self.kept[j];
                    num += e * e;
                    den += self.kept[j] * self.kept[j];
                }
                let r = if den > 0.0 {
                    (num / den).sqrt()
                } else {
                    num.sqrt()
                };
                self.residual = self.residual.max(r);
            }
            LinearSolve::Glued(g, _) => g.solve_in_place(&mut self.rhs)?,
        }
        Ok(())
    }

    /// Solve `K_ff u_f = f_f − K_fc u_c` and record the relative residual.
    fn solve_static(&mut self) -> Result<(), StepError> {
        self.static_rhs();
        self.rhs.copy_from_slice(&self.b);
        self.solve_rhs()?;
        let asm = &self.k.assembly;
        for (x, &g) in self.rhs.iter().zip(asm.free()) {
            self.u[g as usize] = *x;
        }
        asm.mul_free(&self.k.free, &self.rhs, &mut self.tmp);
        let glued: &[bool] = match &self.solver {
            LinearSolve::Glued(_, mask) => mask,
            _ => &[],
        };
        let (mut num, mut den) = (0.0, 0.0);
        for (j, (kx, b)) in self.tmp.iter().zip(&self.b).enumerate() {
            if glued.get(j).copied().unwrap_or(false) {
                continue;
            }
            num += (kx - b) * (kx - b);
            den += b * b;
        }
        let r = if den > 0.0 {
            (num / den).sqrt()
        } else {
            num.sqrt()
        };
        self.residual = self.residual.max(r);
        Ok(())
    }

    /// `a_f = M_f⁻¹ (f_f − K_ff u_f − K_fc u_c)`.
    fn initial_acceleration(&mut self) {
        self.static_rhs();
        let asm = &self.k.assembly;
        for (x, &g) in self.rhs.iter_mut().zip(asm.free()) {
            *x = self.u[g as usize];
        }
        asm.mul_free(&self.k.free, &self.rhs, &mut self.tmp);
        for (j, &g) in asm.free().iter().enumerate() {
            self.a[g as usize] = (self.b[j] - self.tmp[j]) / self.mass_free[j];
        }
    }

    /// The support reactions `r_c = [K_cf K_cc] u + m_c a_c − f_c`.
    fn reactions(&mut self) {
        let asm = &self.k.assembly;
        asm.reactions(&self.k.constrained, &self.u, &mut self.rc);
        for (&g, r) in asm.constrained().iter().zip(&self.rc) {
            let g = g as usize;
            self.reaction[g] = r + self.layout.mass[g / 3] * self.a[g] - self.f[g];
        }
    }

    /// Clapeyron's work of a linear static state: `½ (f + r)·u`.
    fn clapeyron(&mut self) {
        self.energy.external_work = 0.5
            * self
                .u
                .iter()
                .zip(&self.f)
                .zip(&self.reaction)
                .map(|((u, f), r)| (f + r) * u)
                .sum::<f64>();
    }

    /// Element stresses, strains and energies at the current state; kinetic and foundation
    /// energy.
    fn elements(&mut self) -> Result<(), StepError> {
        let l = &*self.layout;
        let mut out = ElementResponse::default();
        let (mut strain_energy, mut hourglass) = (0.0, 0.0);
        for b in &l.blocks {
            let (opts, mat) = (options(b), elastic(&b.material));
            let n = b.kind.nodes();
            for e in 0..b.elements() {
                let x0 = element_x0(l, b, e);
                let mut ue = [[0.0; 3]; MAX_NODES];
                let mut ve = [[0.0; 3]; MAX_NODES];
                for (a, &node) in b.element_nodes(e).iter().enumerate() {
                    let g = 3 * node as usize;
                    ue[a].copy_from_slice(&self.u[g..g + 3]);
                    ve[a].copy_from_slice(&self.v[g..g + 3]);
                }
                solid::respond(b.kind, &opts, &mat, &x0[..n], &ue[..n], &ve[..n], &mut out);
                let ge = b.first_element + e;
                self.stress[ge] = out.stress;
                self.strain[ge] = out.strain;
                strain_energy += out.strain_energy;
                hourglass += out.hourglass_energy;
            }
        }
        if let Some(g) = self.u.iter().position(|x| !x.is_finite()) {
            let node = g / 3;
            let (name, first) = mesh_of_node(l, node);
            return Err(StepError::Mesh {
                mesh: name,
                place: format!("node {}", node - first),
                message: "the displacement is not finite".into(),
            });
        }
        self.energy.strain = strain_energy;
        self.energy.hourglass = hourglass;
        self.energy.kinetic = 0.5
            * self
                .v
                .iter()
                .enumerate()
                .map(|(g, v)| l.mass[g / 3] * v * v)
                .sum::<f64>();
        self.energy.foundation = l
            .foundation
            .iter()
            .map(|s| {
                let g = 3 * s.node as usize;
                let un: f64 = (0..3).map(|k| self.u[g + k] * s.n[k]).sum();
                0.5 * s.k * un * un
            })
            .sum();
        self.energy.half_step = 0.0;
        Ok(())
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Advance to `t + h`: one Newmark step, or the static equilibrium there.
    ///
    /// # Errors
    /// A non-finite displacement (a load that is not finite).
    pub fn advance(&mut self) -> Result<(), StepError> {
        let h = self.h;
        let t1 = self.t + h;
        self.u_prev.copy_from_slice(&self.u);
        self.f_prev.copy_from_slice(&self.f);
        self.reaction_prev.copy_from_slice(&self.reaction);
        self.loads(t1);
        self.prescribe(t1);
        match self.method {
            MeshMethod::Static => {
                self.solve_static()?;
                self.reactions();
                self.clapeyron();
            }
            _ => {
                let (c0, c1) = (4.0 / (h * h), 4.0 / h);
                self.static_rhs();
                let asm = &self.k.assembly;
                for (j, &g) in asm.free().iter().enumerate() {
                    let g = g as usize;
                    self.rhs[j] = self.b[j]
                        + self.mass_free[j] * (c0 * self.u[g] + c1 * self.v[g] + self.a[g]);
                }
                self.solve_rhs()?;
                let asm = &self.k.assembly;
                for (j, &g) in asm.free().iter().enumerate() {
                    let g = g as usize;
                    let un = self.rhs[j];
                    let an = c0 * (un - self.u[g]) - c1 * self.v[g] - self.a[g];
                    self.v[g] += 0.5 * h * (self.a[g] + an);
                    self.a[g] = an;
                    self.u[g] = un;
                }
                self.reactions();
                let mut w = 0.0;
                for g in 0..self.u.len() {
                    let du = self.u[g] - self.u_prev[g];
                    w += 0.5
                        * (self.f[g] + self.reaction[g] + self.f_prev[g] + self.reaction_prev[g])
                        * du;
                }
                self.energy.external_work += w;
            }
        }
        self.t = t1;
        self.elements()
    }

    /// Said at the end of a run whose linear solves left a relative residual above
    /// [`RESIDUAL_WARNING`] (or not finite): the displacements are then not to the accuracy
    /// the solver's tolerance suggests, and a run that exits 0 must say so.
    pub fn residual_warning(&self) -> Option<String> {
        if self.residual <= RESIDUAL_WARNING {
            return None;
        }
        let what = match &self.solver {
            LinearSolve::Feti(_) => "FETI stopped at its `tolerance` on the interface problem, which leaves this much in the whole one: lower `tolerance` in `solver feti { … }`",
            _ => "the stiffness is close to singular: check the supports (a part held nowhere), the materials' units and very thin or distorted elements",
        };
        Some(format!(
            "the linear solves' largest relative residual ‖A u − b‖/‖b‖ is {:.2e}, above {RESIDUAL_WARNING:.0e}: the displacements are not to the solver's accuracy; {what}",
            self.residual
        ))
    }

    /// The largest relative residual `‖A u − b‖/‖b‖` of the solves so far: every static
    /// solve (`A = K`; with glues over the dofs off the glued interfaces, whose equations
    /// hold only with the interface force), and Newmark's FETI solves (`A = K + 4/h² M`); 0 for Newmark's
    /// direct solves, exact to round-off.
    pub fn residual(&self) -> f64 {
        self.residual
    }

    /// Stored entries of the factor `L` (of every subdomain's factors under FETI: this
    /// rank's subdomains when it runs across ranks).
    pub fn factor_nnz(&self) -> usize {
        match &self.solver {
            LinearSolve::Direct(c) => c.factor_nnz(),
            LinearSolve::Feti(f) => f.factor_nnz(),
            LinearSolve::Glued(..) => 0,
        }
    }

    /// The FETI solver, when the scene asks for it.
    pub fn feti(&self) -> Option<&Feti> {
        match &self.solver {
            LinearSolve::Feti(f) => Some(f),
            LinearSolve::Direct(_) | LinearSolve::Glued(..) => None,
        }
    }

    /// Copy the state at the current time into `out` (reusing its buffers).
    pub fn mesh_state(&self, out: &mut MeshState) {
        let n = self.layout.nodes();
        out.u.resize(n, [0.0; 3]);
        out.v.resize(n, [0.0; 3]);
        out.u.as_flattened_mut().copy_from_slice(&self.u);
        out.v.as_flattened_mut().copy_from_slice(&self.v);
        out.stress.clone_from(&self.stress);
        out.strain.clone_from(&self.strain);
        out.plastic.clear();
        out.plastic_strain.clear();
        out.equivalent_plastic_strain.clear();
        out.energy = self.energy;
    }
}

impl<S: System> Integrator<S> for MeshImplicit {
    fn name(&self) -> &'static str {
        self.method.name()
    }
    fn time(&self) -> f64 {
        self.t
    }
    fn step_size(&self) -> f64 {
        self.h
    }
    fn step(&mut self, _sys: &S) -> Result<StepInfo, StepError> {
        self.advance()?;
        Ok(StepInfo::default())
    }
    fn state(&self, _sys: &S, out: &mut State) {
        out.t = self.t;
        self.mesh_state(&mut out.mesh);
    }
    fn active(&self) -> &[bool] {
        &[]
    }
    fn stats(&self) -> Vec<(&'static str, f64)> {
        let mut v = vec![
            ("stiffness_nonzeros", self.k.assembly.nnz_free() as f64),
            ("factor_nonzeros", self.factor_nnz() as f64),
        ];
        if self.method == MeshMethod::Static {
            v.push(("static_residual", self.residual));
        }
        if let LinearSolve::Feti(f) = &self.solver {
            let (t, st) = (f.tearing(), f.stats());
            if self.method != MeshMethod::Static {
                v.push(("solve_residual", self.residual));
            }
            v.extend([
                ("feti_subdomains", t.subdomains.len() as f64),
                ("feti_floating", t.floating() as f64),
                ("feti_multipliers", t.multipliers.len() as f64),
                ("feti_iterations_last", f64::from(st.iterations)),
                ("feti_iterations_max", f64::from(st.max_iterations)),
                ("feti_ranks", f.ranks() as f64),
                ("feti_subdomains_here", f.subdomains_here().len() as f64),
                (
                    "feti_bytes_per_iteration",
                    f.summed_bytes_per_iteration() as f64,
                ),
                ("feti_bytes_last_solve", st.summed_bytes as f64),
            ]);
        }
        v
    }
    fn take_notice(&mut self) -> Option<String> {
        self.notice.take()
    }
    fn end_notice(&self) -> Option<String> {
        self.residual_warning()
    }
    /// Every value carried from one step to the next: the time, the displacement, velocity
    /// and acceleration (and the displacement before, for the work), the loads and
    /// reactions now and at the last step, the element stresses and strains, every energy
    /// accumulator and the largest static residual. Not carried: the stiffness and its
    /// factorization (made again identically from the scene) and the solve's buffers.
    fn persist(&mut self, v: &mut dyn crate::contract::persist::StateVisitor) -> bool {
        use crate::contract::persist;
        persist::f64(v, "implicit.h", &mut self.h);
        persist::f64(v, "implicit.t", &mut self.t);
        for (name, x) in [
            ("implicit.u", &mut self.u),
            ("implicit.v", &mut self.v),
            ("implicit.a", &mut self.a),
            ("implicit.u_prev", &mut self.u_prev),
            ("implicit.f", &mut self.f),
            ("implicit.f_prev", &mut self.f_prev),
            ("implicit.reaction", &mut self.reaction),
            ("implicit.reaction_prev", &mut self.reaction_prev),
        ] {
            v.f64s(name, x);
        }
        v.f64s("implicit.stress", self.stress.as_flattened_mut());
        v.f64s("implicit.strain", self.strain.as_flattened_mut());
        let e = &mut self.energy;
        persist::f64_fields(
            v,
            "implicit.energy",
            [
                &mut e.kinetic,
                &mut e.strain,
                &mut e.hourglass,
                &mut e.foundation,
                &mut e.external_work,
                &mut e.dissipated,
                &mut e.plastic,
                &mut e.tie_work,
                &mut e.half_step,
            ],
        );
        persist::f64(v, "implicit.residual", &mut self.residual);
        true
    }
}

/// The integrator of a scene whose meshes use an implicit `mesh_method`: the scene must be
/// meshes alone.
///
/// # Errors
/// Bodies, joints or beams beside the meshes; what [`MeshImplicit::new`] refuses.
pub(super) fn make<'a, S: System + 'a>(
    sys: &S,
    h: f64,
    start: &State,
) -> Result<Box<dyn Integrator<S> + 'a>, super::StartError> {
    let l = sys.layout();
    let method = l.meshes.method;
    if l.bodies() > 0 || l.rows > 0 {
        return Err(super::StartError::Invalid(format!(
            "`mesh_method {}` analyses scenes of meshes alone, and this one has {} bodies (beam nodes count as bodies) and {} constraint rows; use `mesh_method central_difference` to simulate meshes beside bodies",
            method.name(),
            l.bodies(),
            l.rows
        )));
    }
    Ok(Box::new(MeshImplicit::on_ranks(
        l.meshes.clone(),
        method,
        h,
        start.t,
        &start.mesh,
        sys.ranks(),
    )?))
}

#[cfg(test)]
mod tests {
    //! Exactness of the implicit analyses on small meshes built directly: the patch tests
    //! (a linear displacement field on the boundary of a distorted mesh is reproduced
    //! inside, with constant stress, to round-off), and Newmark's exact discrete solution
    //! of a single degree of freedom (the trapezoidal rule's rotation by `2 atan(ωh/2)` per
    //! step) with its energy conserved to round-off.

    use super::*;
    use crate::analysis::mesh_model;
    use crate::contract::mesh_layout::Prescribed;
    use crate::contract::scene::{ElementKind, Fn1, Material, Mesh, MeshFormulation};

    const STEEL: Material = Material {
        e: 200e9,
        nu: 0.3,
        rho: 7800.0,
        plastic: None,
    };

    fn mesh(kind: ElementKind, nodes: Vec<[f64; 3]>, elements: Vec<Vec<usize>>) -> Mesh {
        Mesh {
            name: "m".into(),
            kind,
            material: STEEL,
            thickness: 0.01,
            nodes,
            elements,
            node_sets: vec![],
            conditions: vec![],
            formulation: MeshFormulation::default(),
            origin: Default::default(),
        }
    }

    /// A grid of `n + 1` nodes per side on the unit square or cube, interior nodes moved
    /// by a deterministic distortion of up to 0.2 of a cell; quad4 or hex8 elements.
    fn distorted(kind: ElementKind, n: usize) -> Mesh {
        let dim = kind.dim();
        let nz = if dim == 3 { n } else { 0 };
        let h = 1.0 / n as f64;
        let id = |i: usize, j: usize, k: usize| (k * (n + 1) + j) * (n + 1) + i;
        let mut nodes = Vec::new();
        for k in 0..=nz {
            for j in 0..=n {
                for i in 0..=n {
                    let mut x = [i as f64 * h, j as f64 * h, k as f64 * h];
                    let interior = |m: usize, top: usize| m > 0 && m < top;
                    if interior(i, n) && interior(j, n) && (dim == 2 || interior(k, nz)) {
                        let s = (i * 7 + j * 13 + k * 5) as f64;
                        x[0] += 0.2 * h * s.sin();
                        x[1] += 0.2 * h * (1.3 * s).cos();
                        if dim == 3 {
                            x[2] += 0.2 * h * (0.7 * s).sin();
                        }
                    }
                    nodes.push(x);
                }
            }
        }
        let mut elements = Vec::new();
        for k in 0..nz.max(1) {
            for j in 0..n {
                for i in 0..n {
                    let q = [
                        id(i, j, k),
                        id(i + 1, j, k),
                        id(i + 1, j + 1, k),
                        id(i, j + 1, k),
                    ];
                    if dim == 2 {
                        elements.push(q.to_vec());
                    } else {
                        let mut e = q.to_vec();
                        e.extend(q.iter().map(|&a| a + (n + 1) * (n + 1)));
                        elements.push(e);
                    }
                }
            }
        }
        mesh(kind, nodes, elements)
    }

    /// The linear field of the patch tests, `u = G x` (m).
    const G: [[f64; 3]; 3] = [
        [1.0e-3, 0.4e-3, -0.3e-3],
        [-0.2e-3, 0.7e-3, 0.5e-3],
        [0.6e-3, -0.1e-3, -0.8e-3],
    ];

    fn field(x: &[f64; 3], dim: usize) -> [f64; 3] {
        let mut u = [0.0; 3];
        for (r, ur) in u.iter_mut().enumerate().take(dim) {
            *ur = (0..dim).map(|c| G[r][c] * x[c]).sum();
        }
        u
    }

    /// Prescribe `G x` on every node on the boundary of the unit square or cube.
    fn prescribe_boundary(l: &mut MeshLayout, dim: usize) {
        let on = |v: f64| v.abs() < 1e-12 || (v - 1.0).abs() < 1e-12;
        for n in 0..l.nodes() {
            let x = l.x0[n];
            if (0..dim).any(|k| on(x[k])) {
                let u = field(&x, dim);
                for k in 0..dim {
                    l.constrained[n][k] = true;
                    l.prescribed.push(Prescribed {
                        node: n as u32,
                        dof: k as u8,
                        value: Fn1::Const(u[k]),
                    });
                }
            }
        }
    }

    fn patch_test(kind: ElementKind, n: usize) {
        let dim = kind.dim();
        let mut l = mesh_model::build(&[distorted(kind, n)]).unwrap();
        prescribe_boundary(&mut l, dim);
        let interior = l.constrained.iter().filter(|c| !c[0]).count();
        assert!(interior > 0);
        let s = MeshImplicit::new(
            Arc::new(l.clone()),
            MeshMethod::Static,
            1.0,
            0.0,
            &MeshState::default(),
        )
        .unwrap();
        assert!(s.residual() < 1e-14, "residual {}", s.residual());
        // the interior nodes on the linear field, to round-off (|G| ~ 1e-3 m)
        for n in 0..l.nodes() {
            let want = field(&l.x0[n], dim);
            for k in 0..3 {
                let err = (s.u[3 * n + k] - want[k]).abs();
                assert!(err < 1e-14, "{kind:?} node {n} comp {k}: error {err:.2e}");
            }
        }
        // constant strain sym G and stress σ = λ* tr ε I + 2μ ε in every element
        let mat = mesh_model::elastic(&STEEL);
        let lambda = if dim == 2 {
            2.0 * mat.lambda * mat.mu / (mat.lambda + 2.0 * mat.mu)
        } else {
            mat.lambda
        };
        let eps = |r: usize, c: usize| 0.5 * (G[r][c] + G[c][r]);
        let voigt = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];
        let tr: f64 = (0..dim).map(|k| eps(k, k)).sum();
        for (e, (st, sn)) in s.stress.iter().zip(&s.strain).enumerate() {
            for (v, &(r, c)) in voigt.iter().enumerate() {
                if r >= dim || c >= dim {
                    continue;
                }
                let want_e = eps(r, c);
                let want_s = 2.0 * mat.mu * want_e + if r == c { lambda * tr } else { 0.0 };
                assert!(
                    (sn[v] - want_e).abs() < 1e-14,
                    "{kind:?} element {e} strain {v}"
                );
                assert!(
                    (st[v] - want_s).abs() < 1e-12 * want_s.abs().max(1e6),
                    "{kind:?} element {e} stress {v}: {} vs {want_s}",
                    st[v]
                );
            }
        }
    }

    /// Patch test, distorted 4×4 quad4 mesh (plane stress), full integration: exact.
    #[test]
    fn patch_test_distorted_quad4() {
        patch_test(ElementKind::Quad4PlaneStress, 4);
    }

    /// Patch test, distorted 3×3×3 hex8 mesh, full integration: exact.
    #[test]
    fn patch_test_distorted_hex8() {
        patch_test(ElementKind::Hex8, 3);
    }

    /// One bar2 element, root fixed, tip free along the bar only: a spring `k = EA/L` with
    /// the mass `m = ρAL/2`. From `u₀`, `v₀ = 0`, the trapezoidal rule's exact discrete
    /// solution is `uₙ = u₀ cos(nφ)`, `vₙ = −u₀ ω sin(nφ)`, `φ = 2 atan(ωh/2)` (the
    /// amplification matrix has eigenvalues `e^{±iφ}`): checked to 1e-12 of u₀ over 400
    /// steps at ωh = 0.5 and at ωh = 3 (above the explicit limit 2), with the energy
    /// `½ m v² + ½ k u²` constant to 1e-13.
    #[test]
    fn newmark_single_dof_is_the_exact_trapezoidal_rotation() {
        let mut l = mesh_model::build(&[mesh(
            ElementKind::Bar2,
            vec![[0.0; 3], [1.0, 0.0, 0.0]],
            vec![vec![0, 1]],
        )])
        .unwrap();
        l.constrained = vec![[true; 3], [false, true, true]];
        let (k, m) = (STEEL.e * 0.01 / 1.0, l.mass[1]);
        let omega = (k / m).sqrt();
        for wh in [0.5, 3.0] {
            let h = wh / omega;
            let u0 = 1e-4;
            let start = MeshState {
                u: vec![[0.0; 3], [u0, 0.0, 0.0]],
                v: vec![[0.0; 3]; 2],
                ..MeshState::default()
            };
            let mut s = MeshImplicit::new(Arc::new(l.clone()), MeshMethod::Newmark, h, 0.0, &start)
                .unwrap();
            let phi = 2.0 * (wh / 2.0f64).atan();
            let e0 = 0.5 * k * u0 * u0;
            for n in 1..=400 {
                s.advance().unwrap();
                let (u, v) = (s.u[3], s.v[3]);
                let nphi = n as f64 * phi;
                assert!((u - u0 * nphi.cos()).abs() < 1e-12 * u0, "ωh {wh} step {n}");
                assert!((v + u0 * omega * nphi.sin()).abs() < 1e-12 * u0 * omega);
                let e = s.energy.kinetic + s.energy.strain;
                assert!(
                    (e - e0).abs() < 1e-13 * e0,
                    "ωh {wh} step {n}: energy {e} vs {e0}"
                );
                assert_eq!(s.energy.external_work, 0.0);
            }
        }
    }

    /// A 10-element bar fixed at its root, started from a linear stretch at rest, by
    /// Newmark at 5× the central-difference limit: the energy `K + U` is constant to
    /// 1e-12 of its value over 500 steps (the trapezoidal rule conserves the quadratic
    /// energy of a linear system exactly), and the bar stays bounded.
    #[test]
    fn newmark_conserves_a_bars_energy_to_round_off() {
        let n = 10;
        let nodes = (0..=n).map(|i| [i as f64 / n as f64, 0.0, 0.0]).collect();
        let elements = (0..n).map(|i| vec![i, i + 1]).collect();
        let mut l = mesh_model::build(&[mesh(ElementKind::Bar2, nodes, elements)]).unwrap();
        for (i, c) in l.constrained.iter_mut().enumerate() {
            *c = [i == 0, true, true];
        }
        let h = 5.0 * mesh_model::critical_step(&l).unwrap().step;
        let start = MeshState {
            u: (0..=n)
                .map(|i| [1e-4 * i as f64 / n as f64, 0.0, 0.0])
                .collect(),
            v: vec![[0.0; 3]; n + 1],
            ..MeshState::default()
        };
        let mut s = MeshImplicit::new(Arc::new(l), MeshMethod::Newmark, h, 0.0, &start).unwrap();
        let e0 = s.energy.kinetic + s.energy.strain;
        assert!(e0 > 0.0 && s.notice.is_some(), "a large step is noticed");
        let mut worst: f64 = 0.0;
        for _ in 0..500 {
            s.advance().unwrap();
            let e = s.energy.kinetic + s.energy.strain;
            worst = worst.max((e - e0).abs() / e0);
        }
        assert!(worst < 1e-12, "energy error {worst:.2e}");
    }

    /// What a linear stiffness cannot represent is refused, naming the mesh and the way
    /// out; a mesh that can move freely under a static analysis is refused at the node.
    #[test]
    fn refusals_name_the_cause() {
        let mut plastic = mesh(
            ElementKind::Bar2,
            vec![[0.0; 3], [1.0, 0.0, 0.0]],
            vec![vec![0, 1]],
        );
        plastic.material.plastic = Some(crate::contract::scene::Plasticity {
            yield_stress: 1e8,
            hardening: 0.0,
        });
        let l = mesh_model::build(&[plastic]).unwrap();
        let Err(e) = MeshImplicit::new(
            Arc::new(l),
            MeshMethod::Static,
            1.0,
            0.0,
            &MeshState::default(),
        ) else {
            panic!("plastic accepted");
        };
        assert!(e.to_string().contains("plastic"), "{e}");
        let free = mesh_model::build(&[mesh(
            ElementKind::Bar2,
            vec![[0.0; 3], [1.0, 0.0, 0.0]],
            vec![vec![0, 1]],
        )])
        .unwrap();
        let Err(e) = MeshImplicit::new(
            Arc::new(free),
            MeshMethod::Static,
            1.0,
            0.0,
            &MeshState::default(),
        ) else {
            panic!("a free bar accepted");
        };
        assert!(
            e.to_string().contains("singular") && e.to_string().contains("node"),
            "{e}"
        );
    }
}
