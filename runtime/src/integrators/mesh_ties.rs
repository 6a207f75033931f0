//! Meshes tied to bodies in the staggered scheme: master–slave kinematic coupling
//! (docs/methods.md, "Meshes tied to bodies"; the layout is
//! [`crate::analysis::tie_model`]'s).
//!
//! One step from tⁿ to tⁿ⁺¹ of [`super::make`]'s mesh integrator:
//! 1. the mesh's net force on each tied node at tⁿ, `Fᵢ = −reactionᵢ` (its element,
//!    external and foundation forces), becomes a wrench on the body: force `Σ Fᵢ` at the
//!    reference point, torque `Σ dᵢ × (Cᵀ Fᵢ)` in body axes (the [`Wrench`] convention);
//! 2. the rigid integrator advances the bodies with it: [`Tied`] adds it in
//!    [`System::applied`] to whatever the system applies;
//! 3. the tied nodes are put where the bodies now are, `x = r + C dᵢ`, with the velocity
//!    `v + C(ω × dᵢ)` of the bodies' synchronized state;
//! 4. the mesh steps and evaluates its forces at tⁿ⁺¹, which give the next wrench.
//!
//! The rigid methods with the leapfrog kick at τ (`staggered`, `baumgarte`, `penalty`,
//! `natural_partitioning`) evaluate the applied forces once per step at the positions at
//! τ = tⁿ, where the wrench was evaluated: the bodies and the free mesh nodes are kicked by
//! forces of the same configuration, so the coupled step is the central difference of the
//! tied system itself. Its stability limit is then the tied system's highest frequency,
//! below the mesh's element bound (a tie only removes freedoms and adds the body's mass:
//! Rayleigh), whatever the mass ratio; and the half-step momentum is conserved exactly,
//! since the tie forces are equal and opposite (`Σ Fᵢ` on the body, `−Fᵢ` in the mesh's
//! internal forces). Methods that evaluate the forces at the step's end
//! (`coordinate_partitioning`, `implicit_trapezoid`), or at two offset sequences, would
//! take the wrench of the wrong configuration: [`refusal`] refuses them.

use nalgebra::Vector3;

use super::State;
use crate::contract::mesh_layout::MeshLayout;
use crate::contract::scene::{Gyroscopic, MethodSpec, Relaxation};
use crate::contract::system::{
    ConstraintEval, JointGeom, JointKernel, Layout, Need, Pose, System, Twist, Wrench,
};

/// A system with the ties' wrenches added to its applied forces (one per body; none, or
/// an empty slice, adds nothing). Everything else is the inner system's.
pub struct Tied<'s, S: System + ?Sized> {
    /// The system.
    pub sys: &'s S,
    /// The wrench of the ties on each body (empty: no ties).
    pub wrench: &'s [Wrench],
}

impl<S: System + ?Sized> System for Tied<'_, S> {
    fn layout(&self) -> &Layout {
        self.sys.layout()
    }
    fn initial_state(&self, pose: &mut [Pose], twist: &mut [Twist]) {
        self.sys.initial_state(pose, twist)
    }
    fn applied(&self, t: f64, pose: &[Pose], twist: &[Twist], out: &mut [Wrench]) {
        self.sys.applied(t, pose, twist, out);
        for (o, w) in out.iter_mut().zip(self.wrench) {
            o.f += w.f;
            o.t += w.t;
        }
    }
    fn constraints(
        &self,
        t: f64,
        pose: &[Pose],
        twist: &[Twist],
        need: Need,
        out: &mut ConstraintEval,
    ) {
        self.sys.constraints(t, pose, twist, need, out)
    }
    fn potential_energy(&self, t: f64, pose: &[Pose]) -> f64 {
        self.sys.potential_energy(t, pose)
    }
    fn update_locks(&self, pose: &[Pose], twist: &[Twist], active: &mut [bool]) -> Option<usize> {
        self.sys.update_locks(pose, twist, active)
    }
    fn has_velocity_forces(&self) -> bool {
        self.sys.has_velocity_forces()
    }
    fn has_state_forces(&self) -> bool {
        self.sys.has_state_forces() || !self.wrench.is_empty()
    }
    fn tree_joint(&self, joint: usize) -> Option<(JointKernel, &JointGeom)> {
        self.sys.tree_joint(joint)
    }

    fn beam_kernels(&self) -> Option<&dyn std::any::Any> {
        self.sys.beam_kernels()
    }
}

/// Why `method` cannot advance a system with ties (`None`: it can), naming the first tie.
pub fn refusal(meshes: &MeshLayout, layout: &Layout, method: &MethodSpec) -> Option<String> {
    let t = meshes.ties.first()?;
    let body = layout.body_names.get(t.body).map_or("?", String::as_str);
    let why = match method {
        MethodSpec::RungeKutta4
        | MethodSpec::DormandPrince { .. }
        | MethodSpec::DormandPrince853 { .. } => format!(
            "{} evaluates the bodies' forces at stages inside its step, but the tie's forces come from the mesh once per step",
            method.name()
        ),
        MethodSpec::CoordinatePartitioning | MethodSpec::ImplicitTrapezoid { .. } => format!(
            "{} evaluates the bodies' forces at the end of its step, but the tie's forces come from the mesh after the bodies have moved",
            method.name()
        ),
        MethodSpec::Staggered(o)
            if !o.single_stage && o.gyroscopic == Gyroscopic::Synchronous =>
        {
            "staggered with the paper's two leapfrog sequences (`gyroscopic synchronous`) evaluates the forces half a step apart, and the mesh has one sequence".into()
        }
        MethodSpec::Staggered(o) if o.relaxation == Relaxation::Kinetic => {
            "the dynamic relaxation (`relaxation kinetic`) stops the bodies but not the mesh".into()
        }
        _ => return None,
    };
    Some(format!(
        "mesh '{}': set '{}' is tied to body '{body}', and {why}; use staggered (the default), baumgarte, penalty or natural_partitioning",
        t.mesh, t.set
    ))
}

/// The ties' side of one coupled step: the wrench on every body and the tied nodes' motion.
pub struct Coupler {
    /// Per body: the ties' wrench at the mesh's current state.
    pub wrench: Vec<Wrench>,
    /// Per body: the wrench of the step before (the one the bodies' last kick took).
    pub wrench_prev: Vec<Wrench>,
    /// The tied nodes' displacement at the end of the step being taken (tie after tie).
    pub u: Vec<[f64; 3]>,
    /// Their velocity there.
    pub v: Vec<[f64; 3]>,
    /// The bodies' state after their step (buffers reused every step).
    pub state: State,
}

impl Coupler {
    /// Buffers for the ties of `layout` (`None` without ties).
    pub fn new(layout: &Layout) -> Option<Coupler> {
        let m = &layout.meshes;
        if m.ties.is_empty() {
            return None;
        }
        let n: usize = m.ties.iter().map(|t| t.nodes.len()).sum();
        Some(Coupler {
            wrench: vec![Wrench::default(); layout.bodies()],
            wrench_prev: vec![Wrench::default(); layout.bodies()],
            u: vec![[0.0; 3]; n],
            v: vec![[0.0; 3]; n],
            state: State::new(layout.bodies(), layout.rows),
        })
    }

    /// Visit what the coupling carries between steps, for a checkpoint
    /// ([`crate::contract::persist`]): the ties' wrench the bodies' next step takes and the
    /// one before (the synchronized output's half kick uses both), the tied nodes' last
    /// motion, and the bodies' state after the last step.
    pub fn persist(&mut self, v: &mut dyn crate::contract::persist::StateVisitor) {
        use crate::contract::persist;
        persist::wrenches(v, "tie.wrench", &mut self.wrench);
        persist::wrenches(v, "tie.wrench_prev", &mut self.wrench_prev);
        v.f64s("tie.u", self.u.as_flattened_mut());
        v.f64s("tie.v", self.v.as_flattened_mut());
        persist::f64(v, "tie.state.t", &mut self.state.t);
        persist::poses(v, "tie.state.pose", &mut self.state.pose);
        persist::twists(v, "tie.state.twist", &mut self.state.twist);
        v.f64s("tie.state.lambda", &mut self.state.lambda);
        v.bools("tie.state.active", &mut self.state.active);
    }

    /// The tied nodes' motion for the bodies of `self.state` into `self.u`, `self.v`
    /// ([`place`]).
    ///
    /// # Errors
    /// As [`place`].
    pub fn place_at_state(&mut self, meshes: &MeshLayout) -> Result<(), super::StepError> {
        place(
            meshes,
            &self.state.pose,
            &self.state.twist,
            &mut self.u,
            &mut self.v,
        )
    }

    /// The ties' wrenches for the bodies of `self.state` into `self.wrench` ([`wrenches`]),
    /// the previous ones into `self.wrench_prev`.
    pub fn wrenches_at_state(&mut self, meshes: &MeshLayout, reaction: &[[f64; 3]]) {
        self.wrench_prev.copy_from_slice(&self.wrench);
        wrenches(meshes, &self.state.pose, reaction, &mut self.wrench);
    }

    /// Give the synchronized state `out` (the rigid method's, whose velocities at t take a
    /// half kick with the last kick's forces, those of t − h) the newest tie wrench: each
    /// tied body's velocity gets `h/2 M⁻¹(Wⁿ⁺¹ − Wⁿ)`, and the tied nodes the velocity of
    /// their body's points. The velocity is then, for the tie's part, the same half kick
    /// as the mesh's nodes get (velocity Verlet), so the output's momentum is the
    /// conserved half-step momentum plus `h/2` times the newest forces, which cancel.
    pub fn synchronize(&self, layout: &Layout, h: f64, out: &mut State) {
        let m = &layout.meshes;
        for tb in &m.tied_bodies {
            let b = tb.body;
            let (w, wp, mp) = (&self.wrench[b], &self.wrench_prev[b], &layout.mass[b]);
            let t = &mut out.twist[b];
            t.v += (w.f - wp.f) * (0.5 * h / mp.m);
            t.w += mp.j_inv * (w.t - wp.t) * (0.5 * h);
        }
        if out.mesh.v.len() != m.nodes() {
            return;
        }
        for t in &m.ties {
            let (p, w) = (&out.pose[t.body], &out.twist[t.body]);
            for (&n, d) in t.nodes.iter().zip(&t.offsets) {
                let v = w.v + p.c * w.w.cross(&Vector3::from(*d));
                out.mesh.v[n as usize] = [v.x, v.y, if t.plane { 0.0 } else { v.z }];
            }
        }
    }
}

/// The tied nodes' displacement `u` and velocity `vel` (tie after tie) for the bodies at
/// `pose`, `twist`: `x = r + C dᵢ`, `v + C(ω × dᵢ)`.
///
/// # Errors
/// A 2-D mesh's tied node taken out of its plane by its body.
pub fn place(
    meshes: &MeshLayout,
    pose: &[Pose],
    twist: &[Twist],
    u: &mut [[f64; 3]],
    vel: &mut [[f64; 3]],
) -> Result<(), super::StepError> {
    let mut k = 0;
    for t in &meshes.ties {
        let (p, w) = (&pose[t.body], &twist[t.body]);
        for (&n, d) in t.nodes.iter().zip(&t.offsets) {
            let d = Vector3::from(*d);
            let cd = p.c * d;
            let x = p.r + cd;
            let v = w.v + p.c * w.w.cross(&d);
            let x0 = meshes.x0[n as usize];
            u[k] = [x.x - x0[0], x.y - x0[1], x.z - x0[2]];
            vel[k] = [v.x, v.y, v.z];
            if t.plane {
                let size = 1.0 + x0[0].abs().max(x0[1].abs());
                if u[k][2].abs() > 1e-9 * size {
                    return Err(super::StepError::Mesh {
                        mesh: t.mesh.clone(),
                        place: format!("tied set '{}'", t.set),
                        message: format!(
                            "its body moves it out of the mesh's plane z = 0 (by {:.3e} m): a 2-D mesh can be tied only to a body that moves in its plane",
                            u[k][2]
                        ),
                    });
                }
                u[k][2] = 0.0;
                vel[k][2] = 0.0;
            }
            k += 1;
        }
    }
    Ok(())
}

/// The ties' wrench on every body (`out`, one per body) from the tie reactions `reaction`
/// of the mesh (per node) with the bodies at `pose`: force `Σ Fᵢ` (world), torque
/// `Σ dᵢ × (Cᵀ Fᵢ)` (body axes), `Fᵢ = −reactionᵢ`.
pub fn wrenches(meshes: &MeshLayout, pose: &[Pose], reaction: &[[f64; 3]], out: &mut [Wrench]) {
    for w in out.iter_mut() {
        *w = Wrench::default();
    }
    for t in &meshes.ties {
        let ct = pose[t.body].c.transpose();
        let w = &mut out[t.body];
        for (&n, d) in t.nodes.iter().zip(&t.offsets) {
            let r = reaction[n as usize];
            let f = if t.plane {
                Vector3::new(-r[0], -r[1], 0.0)
            } else {
                Vector3::new(-r[0], -r[1], -r[2])
            };
            w.f += f;
            w.t += Vector3::from(*d).cross(&(ct * f));
        }
    }
}

/// The meshes' state at the start for the bodies at `pose`, `twist`: undeformed and at
/// rest, but the tied nodes moving with their bodies (empty without ties).
pub fn initial_mesh_state(layout: &Layout, pose: &[Pose], twist: &[Twist]) -> super::MeshState {
    let m = &layout.meshes;
    let Some(mut c) = Coupler::new(layout) else {
        return super::MeshState::default();
    };
    let mut st = super::MeshState {
        u: vec![[0.0; 3]; m.nodes()],
        v: vec![[0.0; 3]; m.nodes()],
        stress: vec![[0.0; 6]; m.elements()],
        strain: vec![[0.0; 6]; m.elements()],
        // Virgin plastic state: the mesh integrator builds it for plastic blocks when the
        // start has none.
        ..Default::default()
    };
    // At t = 0 the tied nodes are where their bodies put them (to round-off); a body out
    // of a 2-D mesh's plane is reported by the first step.
    if place(m, pose, twist, &mut c.u, &mut c.v).is_ok() {
        let nodes = m.ties.iter().flat_map(|t| t.nodes.iter());
        for ((&n, u), v) in nodes.zip(&c.u).zip(&c.v) {
            st.u[n as usize] = *u;
            st.v[n as usize] = *v;
        }
    }
    st
}
