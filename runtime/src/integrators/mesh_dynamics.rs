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
//! blocks, evaluates its kernel ([`crate::kernels::solid::respond`]) and (2) its forces are
//! summed at the nodes by the layout's assembly strategy ([`super::mesh_assembly`]: the
//! node-centric gather, colouring or partitions, notes D §6.3), every node's in one fixed
//! order: no atomic read-modify-write, and results are bitwise the same for every strategy
//! and any number of threads; (3) every node updates its velocity and displacement.
//!
//! **Energy balance** (tracked every step): kinetic `K`, elastic strain energy `U`,
//! hourglass stored energy, foundation energy, the work `W` of the loads and of the
//! prescribed displacements' reactions (trapezoidal rule over each step), and the work `D`
//! dissipated by viscous hourglass control. `K + U + U_hg + U_f − W + D` stays at its
//! initial value up to the method's error; the run loop watches it like a rigid scene's
//! energy.

use std::sync::Arc;

use super::mesh_assembly::Assembler;
use super::StepError;
use crate::analysis::mesh_model::{elastic, element_place, options};
use crate::contract::mesh_layout::MeshLayout;
use crate::kernels::fn1;
use crate::kernels::solid::{self, Elastic, ElementOptions, ElementResponse, MAX_NODES};

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
}

impl MeshEnergy {
    /// The part that is not kinetic, in the balance `K + (this) = const`:
    /// `U + U_hg + U_f − W + D`.
    pub fn balance_potential(&self) -> f64 {
        self.strain + self.hourglass + self.foundation - self.external_work + self.dissipated
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
    /// The energies.
    pub energy: MeshEnergy,
}

impl MeshState {
    /// Whether there is no mesh.
    pub fn is_empty(&self) -> bool {
        self.u.is_empty()
    }
}

/// One block's evaluation constants.
struct BlockEval {
    opts: ElementOptions,
    mat: Elastic,
}

/// What one element leaves for the reductions.
#[derive(Clone, Copy, Debug, Default)]
struct ElementScalars {
    strain_energy: f64,
    hourglass_energy: f64,
    hourglass_power: f64,
    min_jacobian: f64,
}

/// The meshes' explicit integrator.
pub struct MeshDynamics {
    layout: Arc<MeshLayout>,
    evals: Vec<BlockEval>,
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
    energy: MeshEnergy,
}

impl MeshDynamics {
    /// Start at time `t0` from `start` (displacements and velocities; an empty state starts
    /// at rest, undeformed) with step `h`.
    ///
    /// # Errors
    /// An element that is inverted at the start.
    pub fn new(
        layout: Arc<MeshLayout>,
        h: f64,
        t0: f64,
        start: &super::MeshState,
    ) -> Result<MeshDynamics, StepError> {
        let n = layout.nodes();
        let ne = layout.elements();
        let evals = layout
            .blocks
            .iter()
            .map(|b| BlockEval {
                opts: options(b),
                mat: elastic(&b.material),
            })
            .collect();
        let (u, v) = if start.u.len() == n && start.v.len() == n {
            (start.u.clone(), start.v.clone())
        } else {
            (vec![[0.0; 3]; n], vec![[0.0; 3]; n])
        };
        let mut md = MeshDynamics {
            evals,
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
            energy: if start.u.len() == n {
                start.energy
            } else {
                MeshEnergy::default()
            },
            layout,
        };
        md.prescribe(t0);
        md.accelerations(t0)?;
        md.energy_state();
        Ok(md)
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Advance one step.
    ///
    /// # Errors
    /// An element that inverts (its Jacobian determinant reaches zero) or a non-finite
    /// force: the element, its nodes and location.
    pub fn step(&mut self) -> Result<(), StepError> {
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
        // The work of the loads and reactions over the step, trapezoidal: forces at tⁿ
        // (still stored) and at t^{n+1}, both on the step's displacement increment.
        let w0 = self.work_rate();
        self.accelerations(t1)?;
        let w1 = self.work_rate();
        for (v, a) in self.v.iter_mut().zip(&self.a) {
            for k in 0..3 {
                v[k] += 0.5 * h * a[k];
            }
        }
        for p in &self.layout.prescribed {
            self.v[p.node as usize][p.dof as usize] = fn1::eval(&p.value, t1).d1;
        }
        self.t = t1;
        self.energy.external_work += 0.5 * (w0 + w1);
        self.energy.dissipated += h * self.scalars.iter().map(|s| s.hourglass_power).sum::<f64>();
        self.energy_state();
        Ok(())
    }

    /// `Σ (f_ext + reaction) · Δu` over the nodes, with the forces now stored.
    fn work_rate(&self) -> f64 {
        self.f_ext
            .iter()
            .zip(&self.reaction)
            .zip(&self.du)
            .map(|((f, r), d)| (f[0] + r[0]) * d[0] + (f[1] + r[1]) * d[1] + (f[2] + r[2]) * d[2])
            .sum()
    }

    /// Set the prescribed components at `t` (displacement, velocity, acceleration) and
    /// zero the fixed ones.
    fn prescribe(&mut self, t: f64) {
        let l = &self.layout;
        for (n, c) in l.constrained.iter().enumerate() {
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
        self.assembly.begin(&self.f_ext, &self.f_found);
        let (u, v) = (&self.u, &self.v);
        for (bi, b) in l.blocks.iter().enumerate() {
            let ev = &self.evals[bi];
            let npe = b.kind.nodes();
            let e0 = b.first_element;
            let ne = b.elements();
            let stress = &mut self.stress[e0..e0 + ne];
            let strain = &mut self.strain[e0..e0 + ne];
            let scalars = &mut self.scalars[e0..e0 + ne];
            let one = |e: usize,
                       fs: &mut [[f64; 3]],
                       st: &mut [f64; 6],
                       sn: &mut [f64; 6],
                       sc: &mut ElementScalars| {
                let mut x0 = [[0.0; 3]; MAX_NODES];
                let mut ue = [[0.0; 3]; MAX_NODES];
                let mut ve = [[0.0; 3]; MAX_NODES];
                for (a, &g) in b.element_nodes(e).iter().enumerate() {
                    x0[a] = l.x0[g as usize];
                    ue[a] = u[g as usize];
                    ve[a] = v[g as usize];
                }
                let mut r = ElementResponse::default();
                solid::respond(
                    b.kind,
                    &ev.opts,
                    &ev.mat,
                    &x0[..npe],
                    &ue[..npe],
                    &ve[..npe],
                    &mut r,
                );
                fs.copy_from_slice(&r.f[..npe]);
                *st = r.stress;
                *sn = r.strain;
                *sc = ElementScalars {
                    strain_energy: r.strain_energy,
                    hourglass_energy: r.hourglass_energy,
                    hourglass_power: r.hourglass_power,
                    min_jacobian: r.min_jacobian,
                };
            };
            self.assembly.elements(
                l,
                bi,
                (&mut *stress, &mut *strain, &mut *scalars),
                |e, fs, (st, sn, sc)| one(e, fs, st, sn, sc),
            );
            // An inverted element stops the run where it happened.
            if let Some(e) = scalars
                .iter()
                .position(|s| s.min_jacobian.is_nan() || s.min_jacobian <= 0.0)
            {
                return Err(StepError::Mesh {
                    mesh: b.name.clone(),
                    place: element_place(l, b, e),
                    message: format!(
                        "the element has inverted or collapsed (Jacobian determinant {:.3e})",
                        scalars[e].min_jacobian
                    ),
                });
            }
        }
        // The nodal sums and the accelerations.
        self.assembly.finish(
            l,
            &self.f_ext,
            &self.f_found,
            &mut self.a,
            &mut self.reaction,
        );
        for (n, a) in self.a.iter().enumerate() {
            if !(a[0].is_finite() && a[1].is_finite() && a[2].is_finite()) {
                return Err(StepError::Mesh {
                    mesh: self.mesh_of_node(n).to_string(),
                    place: format!("node {}", n - self.block_of_node(n).first_node),
                    message: "the acceleration is not finite".into(),
                });
            }
        }
        Ok(())
    }

    fn block_of_node(&self, n: usize) -> &crate::contract::mesh_layout::ElementBlock {
        let l = &self.layout;
        let i = l
            .blocks
            .partition_point(|b| b.first_node <= n)
            .saturating_sub(1);
        &l.blocks[i]
    }

    fn mesh_of_node(&self, n: usize) -> &str {
        &self.block_of_node(n).name
    }

    /// The state-function energies at the current state.
    fn energy_state(&mut self) {
        let l = &*self.layout;
        self.energy.kinetic = 0.5
            * self
                .v
                .iter()
                .zip(&l.mass)
                .map(|(v, m)| m * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]))
                .sum::<f64>();
        self.energy.strain = self.scalars.iter().map(|s| s.strain_energy).sum();
        self.energy.hourglass = self.scalars.iter().map(|s| s.hourglass_energy).sum();
        self.energy.foundation = l
            .foundation
            .iter()
            .map(|s| {
                let u = self.u[s.node as usize];
                let un = u[0] * s.n[0] + u[1] * s.n[1] + u[2] * s.n[2];
                0.5 * s.k * un * un
            })
            .sum();
    }

    /// Copy the state at the current time into `out` (reusing its buffers).
    pub fn state(&self, out: &mut super::MeshState) {
        out.u.clone_from(&self.u);
        out.v.clone_from(&self.v);
        out.stress.clone_from(&self.stress);
        out.strain.clone_from(&self.strain);
        out.energy = self.energy;
    }
}
