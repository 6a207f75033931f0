//! Finite-element meshes advanced by the explicit central-difference method (notes D §1.1,
//! blueprint §6.2), written in its synchronized (velocity-Verlet) form so that
//! displacements and velocities are known at the same step times:
//!
//! ```text
//! v^{n+½} = vⁿ + h/2 aⁿ,   u^{n+1} = uⁿ + h v^{n+½}      (prescribed components: u = g(t))
//! a^{n+1} = M⁻¹ (f_ext(t^{n+1}) − f_int(u^{n+1}, v^{n+½})),   v^{n+1} = v^{n+½} + h/2 a^{n+1}
//! ```
//!
//! which is the half-step central difference `v^{n+½} = v^{n−½} + h aⁿ` exactly; rate
//! terms (viscous hourglass control) use the lagged `v^{n+½}` (notes D §1.1 [M]).
//!
//! **One step** (no allocation): (1) every element, in parallel over type-homogeneous
//! blocks, evaluates its kernel (each block by the loop of its [`super::mesh_kernels`]
//! table, chosen before the run and monomorphized per element type) and (2) its forces are
//! summed at the nodes by the layout's assembly strategy ([`super::mesh_assembly`]: the
//! node-centric gather, colouring or partitions, notes D §6.3), every node's in one fixed
//! order: no atomic read-modify-write, and results are bitwise the same for every strategy
//! and any number of threads; (3) every node updates its velocity and displacement.
//!
//! **Plasticity**: a block whose material is plastic keeps the plastic strain and the
//! equivalent plastic strain of every integration point (one array per quantity, point
//! after point, built once) and evaluates its elements with the elastoplastic loop
//! ([`super::mesh_kernels::plastic_block`], the kernels of
//! [`crate::kernels::solid::respond_plastic`]), which updates them by return mapping once
//! per step; the choice is made per block, so elastic blocks have no state and run the
//! elastic loop unchanged.
//!
//! **Energy balance** (tracked every step): kinetic `K`, elastic strain energy `U` (of the
//! elastic strains), hourglass stored energy, foundation energy, the work `W` of the loads
//! and of the prescribed displacements' reactions (trapezoidal rule over each step), the
//! work `D` dissipated by viscous hourglass control, and the plastic work `D_p = Σ σ : Δεᵖ`
//! (per integration point times its volume, `σ` the mean of its values at the ends of the
//! step: the trapezoidal rule like `W`, which makes the elements' discrete balance exact).
//! `K + U + U_hg + U_f − W + D + D_p` stays at its initial value up to the method's error;
//! the run loop watches it like a rigid scene's energy.
//!
//! **Tied nodes** (`tie SET, BODY`, [`crate::analysis::tie_model`]): constrained in every
//! component and massless here (their mass is their body's). [`MeshDynamics::step_tied`]
//! takes their displacement and velocity at the step's end from their bodies (the
//! half-step velocity of the rate terms is their displacement increment over h); the
//! constraint's reaction on a tied node is then minus the mesh's net force on it
//! ([`MeshDynamics::reactions`]), which the integrator hands to the body. The work of those
//! reactions is kept apart (`tie_work`): it is what the bodies do on the mesh, and the
//! bodies' energy already counts it.

use std::sync::Arc;

use super::mesh_assembly::Assembler;
use super::mesh_kernels::{BlockArgs, BlockEval, BlockKernel, BlockKernels, ElementScalars};
use super::StepError;
use crate::analysis::mesh_model::{elastic, element_place, options, plastic};
use crate::contract::mesh_layout::MeshLayout;
use crate::contract::ranks::Ranks;
use crate::kernels::fn1;
use crate::kernels::solid::{self, PlasticResponse};

/// The energies of the meshes at one time (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshEnergy {
    /// Kinetic energy `½ Σ m v²`.
    pub kinetic: f64,
    /// Elastic strain energy of the elements.
    pub strain: f64,
    /// Energy stored by hourglass stiffness.
    pub hourglass: f64,
    /// Energy stored in the foundation springs.
    pub foundation: f64,
    /// Work done on the mesh by the loads and the prescribed displacements since t = 0.
    pub external_work: f64,
    /// Energy dissipated by viscous hourglass control since t = 0.
    pub dissipated: f64,
    /// Plastic work `Σ σ : Δεᵖ` since t = 0 (J): the energy dissipated by plastic flow
    /// (with the share that isotropic hardening accounts for).
    pub plastic: f64,
    /// Work done on the mesh by the bodies through ties since t = 0 (the tie reactions on
    /// the tied nodes' displacements). The bodies lose what the mesh gains, so it is not in
    /// [`MeshEnergy::balance_potential`]; it is in [`MeshEnergy::mesh_balance`].
    pub tie_work: f64,
    /// The central difference's half-step term `−(h²/8) Σ m |a|²` (J, ≤ 0). With it the
    /// kinetic energy in the balance is that of the half-step velocities,
    /// `½ v^{n−½}·M v^{n+½} = K − (h²/8) Σ m |a|²`, which is what the method conserves: for
    /// linear elements exactly, and the work of a load is then booked without the half
    /// kick's lag (a load ramped from zero otherwise shows as a balance error as large as
    /// the energy in play over the first steps).
    pub half_step: f64,
}

impl MeshEnergy {
    /// The part that is not kinetic, in the balance `K + (this) = const`:
    /// `U + U_hg + U_f − W + D + D_p + H` (`H` the [`MeshEnergy::half_step`] term).
    pub fn balance_potential(&self) -> f64 {
        self.strain + self.hourglass + self.foundation - self.external_work
            + self.dissipated
            + self.plastic
            + self.half_step
    }

    /// The meshes' own balance, constant up to the method's error:
    /// `K + U + U_hg + U_f − W − W_tie + D + D_p + H` (with ties, the mesh alone is not
    /// conservative: the bodies work on it through the ties).
    pub fn mesh_balance(&self) -> f64 {
        self.kinetic + self.balance_potential() - self.tie_work
    }
}

/// The plastic state of one block's integration points, element after element (empty for
/// an elastic block).
#[derive(Debug, Default, PartialEq)]
pub struct PlasticState {
    /// Plastic strain per point (Voigt xx yy zz yz xz xy, tensor shears; bars: the axial
    /// one in xx).
    pub strain: Vec<[f64; 6]>,
    /// Equivalent plastic strain `ε̄ᵖ` per point.
    pub equivalent: Vec<f64>,
    /// Stress per point at the end of the last step (Voigt; bars: the axial one in xx), for
    /// the trapezoidal plastic work of the next.
    pub stress: Vec<[f64; 6]>,
}

impl Clone for PlasticState {
    fn clone(&self) -> Self {
        PlasticState {
            strain: self.strain.clone(),
            equivalent: self.equivalent.clone(),
            stress: self.stress.clone(),
        }
    }
    /// Field by field, reusing the buffers (the derived `clone_from` would allocate anew:
    /// the state is copied every step).
    fn clone_from(&mut self, source: &Self) {
        self.strain.clone_from(&source.strain);
        self.equivalent.clone_from(&source.equivalent);
        self.stress.clone_from(&source.stress);
    }
}

/// The state of the meshes at a step time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshState {
    /// Nodal displacements (m).
    pub u: Vec<[f64; 3]>,
    /// Nodal velocities (m/s).
    pub v: Vec<[f64; 3]>,
    /// Element mean stress (Pa, Voigt xx yy zz yz xz xy), element after element.
    pub stress: Vec<[f64; 6]>,
    /// Element mean strain (same order, tensor shear).
    pub strain: Vec<[f64; 6]>,
    /// Element mean plastic strain (same order; bars: the axial one in xx), element after
    /// element, 0 for the elements of elastic meshes; empty when no mesh is plastic.
    pub plastic_strain: Vec<[f64; 6]>,
    /// Element mean equivalent plastic strain, like `plastic_strain`.
    pub equivalent_plastic_strain: Vec<f64>,
    /// The integration points' plastic state, one entry per mesh (empty for elastic
    /// meshes; no entries when no mesh is plastic): what a restart continues from.
    pub plastic: Vec<PlasticState>,
    /// The energies.
    pub energy: MeshEnergy,
}

impl MeshState {
    /// Whether there is no mesh.
    pub fn is_empty(&self) -> bool {
        self.u.is_empty()
    }
}

/// The meshes' explicit integrator.
pub struct MeshDynamics {
    layout: Arc<MeshLayout>,
    evals: Vec<BlockEval>,
    /// Per block: its element loop, chosen before the run.
    kernels: Vec<BlockKernel>,
    h: f64,
    t: f64,
    u: Vec<[f64; 3]>,
    v: Vec<[f64; 3]>,
    a: Vec<[f64; 3]>,
    /// The displacement increment of the current step.
    du: Vec<[f64; 3]>,
    /// External force (loads, body force) at the current time.
    f_ext: Vec<[f64; 3]>,
    /// Foundation spring forces at the current displacements.
    f_found: Vec<[f64; 3]>,
    /// Net force on constrained components that the constraint supplies (reaction).
    reaction: Vec<[f64; 3]>,
    /// The assembly's buffers.
    assembly: Assembler,
    stress: Vec<[f64; 6]>,
    strain: Vec<[f64; 6]>,
    scalars: Vec<ElementScalars>,
    /// Per block: the integration points' plastic state (empty for elastic blocks).
    plastic: Vec<PlasticState>,
    /// Per block: each element's plastic means and work of the last evaluation (empty for
    /// elastic blocks).
    plastic_out: Vec<Vec<PlasticResponse>>,
    energy: MeshEnergy,
    /// The tied nodes, tie after tie (the order of [`MeshDynamics::step_tied`]'s targets).
    tied: Vec<u32>,
    /// Per node: whether it is tied.
    is_tied: Vec<bool>,
    /// The ranks of a distributed run whose part the layout is ([`MeshLayout::halo`]).
    ranks: Option<Arc<dyn Ranks>>,
}

impl MeshDynamics {
    /// Start at time `t0` from `start` (displacements and velocities; an empty state starts
    /// at rest, undeformed) with step `h`, each block's elements evaluated by the loop its
    /// kind and material call for ([`BlockKernels::interpreted`]).
    ///
    /// # Errors
    /// An element that is inverted at the start.
    pub fn new(
        layout: Arc<MeshLayout>,
        h: f64,
        t0: f64,
        start: &super::MeshState,
    ) -> Result<MeshDynamics, StepError> {
        let kernels = BlockKernels::interpreted(&layout);
        MeshDynamics::with_kernels(layout, &kernels, h, t0, start)
    }

    /// [`MeshDynamics::new`] with the blocks' element loops given (generated code's table,
    /// [`crate::contract::system::System::mesh_kernels`]).
    ///
    /// # Errors
    /// A table that does not fit the layout's blocks; an element that is inverted at the
    /// start.
    pub fn with_kernels(
        layout: Arc<MeshLayout>,
        kernels: &BlockKernels,
        h: f64,
        t0: f64,
        start: &super::MeshState,
    ) -> Result<MeshDynamics, StepError> {
        MeshDynamics::on_ranks(layout, kernels, h, t0, start, None)
    }

    /// [`MeshDynamics::with_kernels`] for one rank of a distributed run: `layout` is the
    /// rank's part ([`crate::analysis::mesh_ranks::rank_part`], with its
    /// [`MeshLayout::halo`]) and `ranks` the run's engine. Every step exchanges the
    /// interface forces and sums the energies over the ranks; a failure on one rank stops
    /// every rank at the same step. The motion is bitwise that of the whole mesh in one
    /// process.
    ///
    /// # Errors
    /// As [`MeshDynamics::with_kernels`]; a part without its exchange, or ranks without a
    /// part.
    pub fn on_ranks(
        layout: Arc<MeshLayout>,
        kernels: &BlockKernels,
        h: f64,
        t0: f64,
        start: &super::MeshState,
        ranks: Option<Arc<dyn Ranks>>,
    ) -> Result<MeshDynamics, StepError> {
        let distributed = ranks.as_ref().is_some_and(|r| r.size() > 1);
        if distributed != layout.halo.is_some() {
            return Err(StepError::Mesh {
                mesh: layout
                    .blocks
                    .first()
                    .map_or_else(String::new, |b| b.name.clone()),
                place: "its split between ranks".into(),
                message: if distributed {
                    "the run has several ranks but the layout is the whole mesh, not this rank's part (a bug in the caller)".into()
                } else {
                    "the layout is one rank's part but the run has no other ranks (a bug in the caller)".into()
                },
            });
        }
        if let Some(why) = kernels.mismatch(&layout) {
            return Err(StepError::Mesh {
                mesh: layout
                    .blocks
                    .first()
                    .map_or_else(String::new, |b| b.name.clone()),
                place: "its element kernels".into(),
                message: why,
            });
        }
        if let Some(g) = layout.glues.first() {
            return Err(StepError::Mesh {
                mesh: g.mesh.clone(),
                place: format!("set '{}'", g.set),
                message: format!(
                    "the glue to '{}.{}' is solved by `mesh_method static` for now; the explicit method would leave the meshes unglued",
                    g.other_mesh, g.other_set
                ),
            });
        }
        let n = layout.nodes();
        let ne = layout.elements();
        let evals: Vec<BlockEval> = layout
            .blocks
            .iter()
            .map(|b| {
                let opts = options(b);
                BlockEval {
                    points: solid::integration_points(b.kind, &opts),
                    opts,
                    mat: elastic(&b.material),
                    plastic: plastic(&b.material),
                }
            })
            .collect();
        // The plastic state: the start's when it fits the blocks, else virgin.
        let fresh: Vec<PlasticState> = layout
            .blocks
            .iter()
            .zip(&evals)
            .map(|(b, ev)| match ev.plastic {
                Some(_) => PlasticState {
                    strain: vec![[0.0; 6]; b.elements() * ev.points],
                    equivalent: vec![0.0; b.elements() * ev.points],
                    stress: vec![[0.0; 6]; b.elements() * ev.points],
                },
                None => PlasticState::default(),
            })
            .collect();
        let fits = start.plastic.len() == fresh.len()
            && start.plastic.iter().zip(&fresh).all(|(a, b)| {
                a.strain.len() == b.strain.len()
                    && a.equivalent.len() == b.equivalent.len()
                    && a.stress.len() == b.stress.len()
            });
        let any_plastic = evals.iter().any(|e| e.plastic.is_some());
        let plastic = if !any_plastic {
            Vec::new()
        } else if fits && start.u.len() == n {
            start.plastic.clone()
        } else {
            fresh
        };
        let plastic_out = layout
            .blocks
            .iter()
            .zip(&evals)
            .map(|(b, ev)| match ev.plastic {
                Some(_) => vec![PlasticResponse::default(); b.elements()],
                None => Vec::new(),
            })
            .collect();
        let tied: Vec<u32> = layout
            .ties
            .iter()
            .flat_map(|t| t.nodes.iter().copied())
            .collect();
        let mut is_tied = vec![false; n];
        for &t in &tied {
            is_tied[t as usize] = true;
        }
        let (u, v) = if start.u.len() == n && start.v.len() == n {
            (start.u.clone(), start.v.clone())
        } else {
            (vec![[0.0; 3]; n], vec![[0.0; 3]; n])
        };
        let mut md = MeshDynamics {
            evals,
            kernels: kernels.blocks().to_vec(),
            h,
            t: t0,
            u,
            v,
            a: vec![[0.0; 3]; n],
            du: vec![[0.0; 3]; n],
            f_ext: vec![[0.0; 3]; n],
            f_found: vec![[0.0; 3]; n],
            reaction: vec![[0.0; 3]; n],
            assembly: Assembler::new(&layout),
            stress: vec![[0.0; 6]; ne],
            strain: vec![[0.0; 6]; ne],
            scalars: vec![ElementScalars::default(); ne],
            plastic,
            plastic_out,
            energy: if start.u.len() == n {
                start.energy
            } else {
                MeshEnergy::default()
            },
            layout,
            tied,
            is_tied,
            ranks: if distributed { ranks } else { None },
        };
        md.prescribe(t0);
        md.accelerations(t0)?;
        md.energy_state();
        let plastic = md.plastic_work();
        md.account([0.0, 0.0, 0.0, plastic]);
        Ok(md)
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Advance one step (nothing tied: see [`MeshDynamics::step_tied`]).
    ///
    /// # Errors
    /// An element that inverts (its Jacobian determinant reaches zero) or a non-finite
    /// force: the element, its nodes and location.
    pub fn step(&mut self) -> Result<(), StepError> {
        self.step_tied(&[], &[])
    }

    /// Advance one step with the tied nodes' displacement `tied_u` and velocity `tied_v` at
    /// the step's end, one per tied node in the order of the layout's `ties` (their bodies'
    /// motion). Empty slices leave tied nodes drifting with their last velocity.
    ///
    /// # Errors
    /// As [`MeshDynamics::step`]; targets for a different number of tied nodes.
    pub fn step_tied(&mut self, tied_u: &[[f64; 3]], tied_v: &[[f64; 3]]) -> Result<(), StepError> {
        if !tied_u.is_empty() && (tied_u.len() != self.tied.len() || tied_v.len() != tied_u.len()) {
            return Err(StepError::Mesh {
                mesh: self
                    .layout
                    .ties
                    .first()
                    .map_or_else(String::new, |t| t.mesh.clone()),
                place: "its ties".into(),
                message: format!(
                    "{} tied nodes, but motions for {} were given",
                    self.tied.len(),
                    tied_u.len()
                ),
            });
        }
        let h = self.h;
        let t1 = self.t + h;
        for (((v, a), u), du) in self
            .v
            .iter_mut()
            .zip(&self.a)
            .zip(self.u.iter_mut())
            .zip(self.du.iter_mut())
        {
            for k in 0..3 {
                v[k] += 0.5 * h * a[k];
                du[k] = h * v[k];
                u[k] += du[k];
            }
        }
        for p in &self.layout.prescribed {
            let (n, k) = (p.node as usize, p.dof as usize);
            let j = fn1::eval(&p.value, t1);
            let old = self.u[n][k] - self.du[n][k];
            self.du[n][k] = j.v - old;
            self.u[n][k] = j.v;
            self.a[n][k] = j.d2;
        }
        // Tied nodes where their bodies put them; their half-step velocity (for rate terms)
        // is the increment over the step.
        for (&n, ut) in self.tied.iter().zip(tied_u) {
            let n = n as usize;
            for k in 0..3 {
                let old = self.u[n][k] - self.du[n][k];
                self.du[n][k] = ut[k] - old;
                self.u[n][k] = ut[k];
                self.v[n][k] = self.du[n][k] / h;
                self.a[n][k] = 0.0;
            }
        }
        // The work of the loads and reactions over the step, trapezoidal: forces at tⁿ
        // (still stored) and at t^{n+1}, both on the step's displacement increment.
        let (w0, tw0) = self.work_rate();
        self.accelerations(t1)?;
        let (w1, tw1) = self.work_rate();
        for (v, a) in self.v.iter_mut().zip(&self.a) {
            for k in 0..3 {
                v[k] += 0.5 * h * a[k];
            }
        }
        for p in &self.layout.prescribed {
            self.v[p.node as usize][p.dof as usize] = fn1::eval(&p.value, t1).d1;
        }
        for (&n, vt) in self.tied.iter().zip(tied_v) {
            self.v[n as usize] = *vt;
        }
        self.t = t1;
        self.energy_state();
        let dissipated = h * self.scalars.iter().map(|s| s.hourglass_power).sum::<f64>();
        let plastic = self.plastic_work();
        self.account([0.5 * (w0 + w1), 0.5 * (tw0 + tw1), dissipated, plastic]);
        Ok(())
    }

    /// Add the step's work of loads, ties, hourglass damping and plasticity (`d`, in that
    /// order) to the accumulators; on ranks, first sum them and the state energies over
    /// the ranks (each rank has counted its elements and owned nodes).
    fn account(&mut self, mut d: [f64; 4]) {
        let e = &mut self.energy;
        if let Some(r) = &self.ranks {
            let mut x = [
                d[0],
                d[1],
                d[2],
                d[3],
                e.kinetic,
                e.strain,
                e.hourglass,
                e.foundation,
                e.half_step,
            ];
            r.sum(&mut x);
            d.copy_from_slice(&x[..4]);
            [e.kinetic, e.strain, e.hourglass, e.foundation, e.half_step] =
                [x[4], x[5], x[6], x[7], x[8]];
        }
        e.external_work += d[0];
        e.tie_work += d[1];
        e.dissipated += d[2];
        e.plastic += d[3];
    }

    /// On ranks: the number of ranks, and what this rank sends per step (bytes: the
    /// interface forces of the exchange) and how many elements it evaluates; nothing in one
    /// process.
    pub fn rank_stats(&self) -> Vec<(&'static str, f64)> {
        match (&self.ranks, &self.layout.halo) {
            (Some(r), Some(h)) => vec![
                ("ranks", r.size() as f64),
                ("rank0_elements", self.layout.elements() as f64),
                (
                    "rank0_exchange_bytes_per_step",
                    8.0 * h.exchange.send_len() as f64,
                ),
            ],
            _ => Vec::new(),
        }
    }

    /// Whether node `n` counts in this rank's energies (every node, in one process).
    fn owned(&self, n: usize) -> bool {
        self.layout.halo.as_ref().is_none_or(|h| h.owned[n])
    }

    /// On ranks: whether any rank failed (`mine` for this one), agreed by all, as the
    /// error to return: this rank's own, or one that names the failing rank's report.
    fn agree(&self, mine: Result<(), StepError>) -> Result<(), StepError> {
        let Some(r) = &self.ranks else {
            return mine;
        };
        if crate::contract::ranks::any(&**r, mine.is_err()) && mine.is_ok() {
            return Err(StepError::Mesh {
                mesh: self
                    .layout
                    .blocks
                    .first()
                    .map_or_else(String::new, |b| b.name.clone()),
                place: format!("rank {}'s part", r.rank()),
                message: "another rank failed at this step (its report names the element)".into(),
            });
        }
        mine
    }

    /// The plastic work of the last element evaluation, summed in element order.
    fn plastic_work(&self) -> f64 {
        self.plastic_out
            .iter()
            .flat_map(|b| b.iter().map(|r| r.work))
            .sum()
    }

    /// `Σ (f_ext + reaction) · Δu` over the nodes, with the forces now stored, and apart
    /// the tied nodes' reactions' part, `Σ_tied reaction · Δu`.
    fn work_rate(&self) -> (f64, f64) {
        let (mut w, mut tie) = (0.0, 0.0);
        for (n, (((f, r), d), &tied)) in self
            .f_ext
            .iter()
            .zip(&self.reaction)
            .zip(&self.du)
            .zip(&self.is_tied)
            .enumerate()
        {
            if !self.owned(n) {
                continue;
            }
            if tied {
                w += f[0] * d[0] + f[1] * d[1] + f[2] * d[2];
                tie += r[0] * d[0] + r[1] * d[1] + r[2] * d[2];
            } else {
                w += (f[0] + r[0]) * d[0] + (f[1] + r[1]) * d[1] + (f[2] + r[2]) * d[2];
            }
        }
        (w, tie)
    }

    /// Per node, the force the constraints supply at the current state (N, world): on a
    /// fixed or prescribed component the support's reaction; on a tied node minus the
    /// mesh's net force on it (external, foundation and element forces: the node's mass is
    /// its body's), so the tie hands `−reactions()[n]` to the body.
    pub fn reactions(&self) -> &[[f64; 3]] {
        &self.reaction
    }

    /// Set the prescribed components at `t` (displacement, velocity, acceleration) and
    /// zero the fixed ones (tied nodes keep the motion they start with: their bodies').
    fn prescribe(&mut self, t: f64) {
        let l = &self.layout;
        for (n, c) in l.constrained.iter().enumerate() {
            if self.is_tied[n] {
                self.a[n] = [0.0; 3];
                continue;
            }
            for k in 0..3 {
                if c[k] {
                    self.u[n][k] = 0.0;
                    self.v[n][k] = 0.0;
                    self.a[n][k] = 0.0;
                }
            }
        }
        for p in &l.prescribed {
            let j = fn1::eval(&p.value, t);
            let (n, k) = (p.node as usize, p.dof as usize);
            self.u[n][k] = j.v;
            self.v[n][k] = j.d1;
            self.a[n][k] = j.d2;
        }
    }

    /// External forces at `t`, element forces at the current u (rates at the current v),
    /// and the accelerations of the free components.
    fn accelerations(&mut self, t: f64) -> Result<(), StepError> {
        let l = &*self.layout;
        // External forces.
        for f in self.f_ext.iter_mut() {
            *f = [0.0; 3];
        }
        if !l.body_force.is_empty() {
            self.f_ext.copy_from_slice(&l.body_force);
        }
        for g in &l.loads {
            let val = [
                fn1::eval(&g.value[0], t).v,
                fn1::eval(&g.value[1], t).v,
                fn1::eval(&g.value[2], t).v,
            ];
            for (&n, &w) in g.nodes.iter().zip(&g.weights) {
                for k in 0..3 {
                    self.f_ext[n as usize][k] += w * val[k];
                }
            }
        }
        for s in &l.foundation {
            self.f_found[s.node as usize] = [0.0; 3];
        }
        for s in &l.foundation {
            let u = self.u[s.node as usize];
            let un = u[0] * s.n[0] + u[1] * s.n[1] + u[2] * s.n[2];
            for k in 0..3 {
                self.f_found[s.node as usize][k] -= s.k * un * s.n[k];
            }
        }
        // Element forces, summed at the nodes by the assembly strategy.
        let mut failure = Ok(());
        self.assembly.begin(&self.f_ext, &self.f_found);
        let (u, v) = (&self.u, &self.v);
        for (bi, b) in l.blocks.iter().enumerate() {
            let e0 = b.first_element;
            let ne = b.elements();
            // A plastic block's points' state and per-element plastic outputs.
            let plastic = if self.evals[bi].plastic.is_some() {
                let ps = &mut self.plastic[bi];
                Some((
                    &mut ps.strain[..],
                    &mut ps.equivalent[..],
                    &mut ps.stress[..],
                    &mut self.plastic_out[bi][..],
                ))
            } else {
                None
            };
            // The block's loop, chosen before the run.
            (self.kernels[bi].run)(BlockArgs {
                assembly: &mut self.assembly,
                layout: l,
                block: bi,
                eval: &self.evals[bi],
                u,
                v,
                out: (
                    &mut self.stress[e0..e0 + ne],
                    &mut self.strain[e0..e0 + ne],
                    &mut self.scalars[e0..e0 + ne],
                ),
                plastic,
            });
            let scalars = &self.scalars[e0..e0 + ne];
            // An inverted element stops the run where it happened.
            if let Some(e) = scalars
                .iter()
                .position(|s| s.min_jacobian.is_nan() || s.min_jacobian <= 0.0)
            {
                failure = Err(StepError::Mesh {
                    mesh: b.name.clone(),
                    place: element_place(l, b, e),
                    message: format!(
                        "the element has inverted or collapsed (Jacobian determinant {:.3e})",
                        scalars[e].min_jacobian
                    ),
                });
                break;
            }
        }
        // On ranks, every rank learns of a failure before the exchange that would wait for
        // the failed one.
        self.agree(failure)?;
        if let Some(r) = &self.ranks {
            self.assembly.exchange(l, &**r);
        }
        // The nodal sums and the accelerations.
        self.assembly.finish(
            l,
            &self.f_ext,
            &self.f_found,
            &mut self.a,
            &mut self.reaction,
        );
        let mut finite = Ok(());
        for (n, a) in self.a.iter().enumerate() {
            if !(a[0].is_finite() && a[1].is_finite() && a[2].is_finite()) {
                finite = Err(StepError::Mesh {
                    mesh: self.mesh_of_node(n).to_string(),
                    place: self.node_place(n),
                    message: "the acceleration is not finite".into(),
                });
                break;
            }
        }
        self.agree(finite)
    }

    fn block_of_node(&self, n: usize) -> &crate::contract::mesh_layout::ElementBlock {
        let l = &self.layout;
        let i = l
            .blocks
            .partition_point(|b| b.first_node <= n)
            .saturating_sub(1);
        &l.blocks[i]
    }

    /// Node `n` as reports name it: its number in its mesh.
    fn node_place(&self, n: usize) -> String {
        match &self.layout.halo {
            Some(h) => format!("node {}", h.node_ids[n]),
            None => format!("node {}", n - self.block_of_node(n).first_node),
        }
    }

    fn mesh_of_node(&self, n: usize) -> &str {
        &self.block_of_node(n).name
    }

    /// The state-function energies at the current state.
    fn energy_state(&mut self) {
        let l = &*self.layout;
        let owned = |n: &usize| l.halo.as_ref().is_none_or(|h| h.owned[*n]);
        self.energy.kinetic = 0.5
            * (0..l.nodes())
                .filter(owned)
                .map(|n| {
                    let (v, m) = (self.v[n], l.mass[n]);
                    m * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
                })
                .sum::<f64>();
        self.energy.half_step = -0.125
            * self.h
            * self.h
            * (0..l.nodes())
                .filter(owned)
                .map(|n| {
                    let (a, m) = (self.a[n], l.mass[n]);
                    m * (a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
                })
                .sum::<f64>();
        self.energy.strain = self.scalars.iter().map(|s| s.strain_energy).sum();
        self.energy.hourglass = self.scalars.iter().map(|s| s.hourglass_energy).sum();
        self.energy.foundation = l
            .foundation
            .iter()
            .filter(|s| owned(&(s.node as usize)))
            .map(|s| {
                let u = self.u[s.node as usize];
                let un = u[0] * s.n[0] + u[1] * s.n[1] + u[2] * s.n[2];
                0.5 * s.k * un * un
            })
            .sum();
    }

    /// Visit everything the meshes carry from one step to the next, for a checkpoint
    /// ([`crate::contract::persist`]): the step and time, displacements, velocities and
    /// accelerations (the next half kick's, computed with the half-step velocities: the
    /// restart state's velocities would give other rate forces), the step's increments, the
    /// loads, foundation forces and reactions the next step's trapezoidal work starts from,
    /// the element outputs, the integration points' plastic state and the elements' plastic
    /// means, and every energy accumulator (work of loads and ties, hourglass and plastic
    /// dissipation). Not carried: the layout, the element constants and kernels (made again
    /// identically from the scene) and the assembly's nodal sums (set afresh by every
    /// evaluation).
    pub fn persist(&mut self, v: &mut dyn crate::contract::persist::StateVisitor) {
        use crate::contract::persist;
        persist::f64(v, "mesh.h", &mut self.h);
        persist::f64(v, "mesh.t", &mut self.t);
        for (name, x) in [
            ("mesh.u", &mut self.u),
            ("mesh.v", &mut self.v),
            ("mesh.a", &mut self.a),
            ("mesh.du", &mut self.du),
            ("mesh.f_ext", &mut self.f_ext),
            ("mesh.f_found", &mut self.f_found),
            ("mesh.reaction", &mut self.reaction),
        ] {
            v.f64s(name, x.as_flattened_mut());
        }
        v.f64s("mesh.stress", self.stress.as_flattened_mut());
        v.f64s("mesh.strain", self.strain.as_flattened_mut());
        let mut sc: Vec<f64> = self
            .scalars
            .iter()
            .flat_map(|s| {
                [
                    s.strain_energy,
                    s.hourglass_energy,
                    s.hourglass_power,
                    s.min_jacobian,
                ]
            })
            .collect();
        v.f64s("mesh.scalars", &mut sc);
        for (s, b) in self.scalars.iter_mut().zip(sc.chunks_exact(4)) {
            s.strain_energy = b[0];
            s.hourglass_energy = b[1];
            s.hourglass_power = b[2];
            s.min_jacobian = b[3];
        }
        let n = v.len("mesh.plastic", self.plastic.len());
        self.plastic.resize_with(n, PlasticState::default);
        for p in self.plastic.iter_mut() {
            let n = v.len("mesh.plastic.points", p.equivalent.len());
            p.strain.resize(n, [0.0; 6]);
            p.equivalent.resize(n, 0.0);
            p.stress.resize(n, [0.0; 6]);
            v.f64s("mesh.plastic.strain", p.strain.as_flattened_mut());
            v.f64s("mesh.plastic.equivalent", &mut p.equivalent);
            v.f64s("mesh.plastic.stress", p.stress.as_flattened_mut());
        }
        for po in self.plastic_out.iter_mut() {
            let mut b: Vec<f64> = po
                .iter()
                .flat_map(|r| r.strain.iter().copied().chain([r.equivalent, r.work]))
                .collect();
            v.f64s("mesh.plastic_out", &mut b);
            for (r, b) in po.iter_mut().zip(b.chunks_exact(8)) {
                r.strain.copy_from_slice(&b[..6]);
                r.equivalent = b[6];
                r.work = b[7];
            }
        }
        let e = &mut self.energy;
        for (name, x) in [
            ("mesh.energy.kinetic", &mut e.kinetic),
            ("mesh.energy.strain", &mut e.strain),
            ("mesh.energy.hourglass", &mut e.hourglass),
            ("mesh.energy.foundation", &mut e.foundation),
            ("mesh.energy.external_work", &mut e.external_work),
            ("mesh.energy.dissipated", &mut e.dissipated),
            ("mesh.energy.plastic", &mut e.plastic),
            ("mesh.energy.tie_work", &mut e.tie_work),
            ("mesh.energy.half_step", &mut e.half_step),
        ] {
            persist::f64(v, name, x);
        }
    }

    /// Copy the state at the current time into `out` (reusing its buffers).
    pub fn state(&self, out: &mut super::MeshState) {
        out.u.clone_from(&self.u);
        out.v.clone_from(&self.v);
        out.stress.clone_from(&self.stress);
        out.strain.clone_from(&self.strain);
        out.plastic.clone_from(&self.plastic);
        if self.plastic.is_empty() {
            out.plastic_strain.clear();
            out.equivalent_plastic_strain.clear();
        } else {
            let ne = self.stress.len();
            out.plastic_strain.resize(ne, [0.0; 6]);
            out.equivalent_plastic_strain.resize(ne, 0.0);
            for (b, po) in self.layout.blocks.iter().zip(&self.plastic_out) {
                let e0 = b.first_element;
                for (k, r) in po.iter().enumerate() {
                    out.plastic_strain[e0 + k] = r.strain;
                    out.equivalent_plastic_strain[e0 + k] = r.equivalent;
                }
            }
        }
        out.energy = self.energy;
    }
}
