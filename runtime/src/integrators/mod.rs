//! Time integrators. Each advances a [`System`] by fixed steps and exposes the state
//! synchronised at the step times (positions, velocities and multipliers at the same t).
//!
//! | method | module | paper |
//! |---|---|---|
//! | `coordinate_partitioning` | [`partitioning`] | generalized coordinate partitioning, notes A §1.3 |
//! | `implicit_trapezoid` | [`trapezoid`] | simultaneous trapezoidal rule with Newton, notes A §1.2 |
//! | `staggered`, `baumgarte`, `penalty` | [`staggered`] | two-stage CINT with three constraint-force modules, notes A §1.4–1.9, C §3 |
//! | `natural_partitioning` | [`natural`] | tree null space, Schur-complement PCG, cut joints by staggered stabilization, notes C §1 |
//! | `rk4`, `dopri5`, `dop853` | [`runge_kutta`] | explicit Runge–Kutta on the tree coordinates, error control and dense output (Hairer–Nørsett–Wanner I §II) |
//! | `state_time` | [`state_time`] | time elements, Newton on a window of the trajectory, notes F |
//!
//! Flexible beams are bodies of the system with element forces ([`beam_forces`]); with
//! `beam_substeps` the staggered method advances their nodes in substeps ([`beam_subcycle`]).
//! Finite-element meshes ([`mesh_dynamics`]) are advanced beside them with the same step,
//! and node sets tied to bodies couple the two in the staggered scheme ([`mesh_ties`]).
//! Scenes of meshes alone may instead use an implicit analysis ([`mesh_implicit`]: Newmark
//! average acceleration or linear static, `simulate { mesh_method }`).
//!
//! All integrators are generic over the system, so generated code is monomorphized
//! into them, and none allocates inside [`Integrator::step`].

// Numerical kernels index several parallel arrays (rows, bodies) with one counter.
#![allow(clippy::needless_range_loop)]

pub mod beam_forces;
pub mod beam_kernels;
pub mod beam_subcycle;
pub mod common;
pub mod mesh_assembly;
pub mod mesh_dynamics;
pub mod mesh_feti;
pub mod mesh_glue;
pub mod mesh_implicit;
pub mod mesh_kernels;
pub mod mesh_ties;
pub mod natural;
pub mod partitioning;
pub mod runge_kutta;
pub mod staggered;
pub mod state_time;
#[cfg(test)]
pub(crate) mod testsys;
pub mod trapezoid;

use crate::contract::system::{Pose, System, Twist, Wrench};
pub use mesh_dynamics::{MeshEnergy, MeshState, PlasticState};

/// The synchronized state at a step time.
#[derive(Clone, Debug, Default)]
pub struct State {
    /// Time.
    pub t: f64,
    /// Poses.
    pub pose: Vec<Pose>,
    /// Twists.
    pub twist: Vec<Twist>,
    /// Multipliers, one per constraint row (0 for inactive rows).
    pub lambda: Vec<f64>,
    /// Which rows are enforced (locks engage during a run).
    pub active: Vec<bool>,
    /// The flexible beams' element states at these positions (empty without beams, and in
    /// a state not produced by an integrator: the elements then start stress-free).
    pub beams: Vec<crate::kernels::beam_element::ElementState>,
    /// The finite-element meshes' state (empty without meshes, and in a state not produced
    /// by an integrator: the meshes then start at rest, undeformed).
    pub mesh: MeshState,
}

impl State {
    /// The energy of the flexible parts beside the bodies' kinetic and potential energy
    /// (J): the beams' strain energy, and the meshes' [`MeshEnergy::balance_potential`]
    /// (strain, hourglass and foundation energy, less the work of loads and prescribed
    /// displacements, plus what hourglass control dissipated; not the work of ties, which
    /// the bodies' energy already counts), so that with the kinetic energies the total
    /// stays constant in a run.
    pub fn strain_energy(&self) -> f64 {
        beam_forces::total_strain_energy(&self.beams) + self.mesh.energy.balance_potential()
    }

    /// The meshes' kinetic energy (J; 0 without meshes).
    pub fn mesh_kinetic(&self) -> f64 {
        self.mesh.energy.kinetic
    }
}

impl State {
    /// Buffers for `bodies` bodies and `rows` rows (all rows active).
    pub fn new(bodies: usize, rows: usize) -> State {
        State {
            t: 0.0,
            pose: vec![Pose::default(); bodies],
            twist: vec![Twist::default(); bodies],
            lambda: vec![0.0; rows],
            active: vec![true; rows],
            beams: Vec::new(),
            mesh: MeshState::default(),
        }
    }

    /// The system's initial state at t = 0. With tied meshes, the meshes' state too
    /// (undeformed, at rest, the tied nodes moving with their bodies); without, the meshes
    /// start at rest from an empty state.
    pub fn initial<S: System + ?Sized>(sys: &S) -> State {
        let layout = sys.layout();
        let mut s = State::new(layout.bodies(), layout.rows);
        sys.initial_state(&mut s.pose, &mut s.twist);
        s.active = common::initial_activity(layout);
        s.mesh = mesh_ties::initial_mesh_state(layout, &s.pose, &s.twist);
        s
    }
}

/// Build the integrator for `method` with step `h`, starting from `start`.
///
/// Refused up front ([`StartError::Invalid`]): a step that is not positive and finite,
/// options out of range ([`crate::analysis::input_limits::check_method`]), and a dense method
/// (`coordinate_partitioning`, `implicit_trapezoid`, `staggered` with `factorization
/// dense`) on a system of more than [`crate::analysis::input_limits::MAX_DENSE_UNKNOWNS`] unknowns.
/// Whether `method` reports as a state's multipliers the mean constraint force over the step
/// that produced it (`implicit_trapezoid`: the step's whole constraint impulse over h),
/// rather than the force at the state's time (every other method). The energy balance books
/// a driver's work accordingly (`driver/work.rs`).
pub fn multipliers_are_step_means(method: &crate::contract::scene::MethodSpec) -> bool {
    matches!(
        method,
        crate::contract::scene::MethodSpec::ImplicitTrapezoid { .. }
    )
}

pub fn make<'a, S: System + 'a>(
    method: &crate::contract::scene::MethodSpec,
    sys: &S,
    h: f64,
    start: &State,
) -> Result<Box<dyn Integrator<S> + 'a>, StartError> {
    use crate::analysis::input_limits;
    use crate::contract::scene::MethodSpec as M;
    if !(h.is_finite() && h > 0.0) {
        return Err(StartError::Invalid(format!(
            "the step must be positive and finite, got {h}"
        )));
    }
    input_limits::check_method(method).map_err(StartError::Invalid)?;
    if matches!(
        method,
        M::CoordinatePartitioning | M::ImplicitTrapezoid { .. }
    ) {
        let l = sys.layout();
        let n = 6 * l.bodies() + l.rows;
        if n > input_limits::MAX_DENSE_UNKNOWNS {
            return Err(StartError::Invalid(format!(
                "{} is a dense method and this system has {n} unknowns (6 per body and {} constraint rows), more than its limit of {}: use staggered or natural_partitioning",
                method.name(),
                l.rows,
                input_limits::MAX_DENSE_UNKNOWNS
            )));
        }
    }
    if let M::Staggered(o) = method {
        let rows = sys.layout().rows;
        if o.factorization == crate::contract::scene::Factorization::Dense
            && rows > input_limits::MAX_DENSE_UNKNOWNS
        {
            return Err(StartError::Invalid(format!(
                "staggered with `factorization dense` factors a dense matrix of one row and column per constraint row, and this system has {rows} rows, more than the limit of {}: use `factorization auto` (the default) or `sparse`",
                input_limits::MAX_DENSE_UNKNOWNS
            )));
        }
    }
    if let Some(b) = sys.layout().beams.beams.first() {
        let two_sequences = matches!(method, M::Staggered(o)
            if !o.single_stage && o.gyroscopic == crate::contract::scene::Gyroscopic::Synchronous);
        if !matches!(
            method,
            M::Staggered(_) | M::Baumgarte { .. } | M::Penalty { .. }
        ) {
            return Err(StartError::Invalid(format!(
                "beam '{}': {} does not simulate flexible beams; beams are advanced by the explicit coordinate integrator of staggered (the default), baumgarte and penalty",
                b.name,
                method.name()
            )));
        }
        let substeps = match method {
            M::Staggered(o) => o.beam_substeps.max(1),
            _ => 1,
        };
        if let Some(msg) = beam_step_limit(sys.layout(), start, h, substeps) {
            return Err(StartError::Invalid(msg));
        }
        if substeps > 1 {
            if let Some(msg) = beam_subcycle_damping(sys.layout(), start, substeps) {
                return Err(StartError::Invalid(msg));
            }
            if let Some(msg) = beam_coupling_limit(sys.layout(), start, h) {
                return Err(StartError::Invalid(msg));
            }
        }
        if two_sequences {
            return Err(StartError::Invalid(format!(
                "beam '{}': staggered with the paper's two leapfrog sequences (`gyroscopic synchronous`) does not simulate flexible beams; use the defaults",
                b.name
            )));
        }
    }
    let meshes = sys.layout().meshes.clone();
    if let (
        M::StateTime {
            steps_per_element,
            window,
        },
        true,
    ) = (method, meshes.is_empty())
    {
        let st = state_time::StateTime::new(sys, h, *steps_per_element, *window as usize, start)?;
        st.check_window().map_err(StartError::Invalid)?;
        return Ok(Box::new(st));
    }
    if meshes.is_empty() {
        return match rigid(method, sys, h, start)? {
            Some(r) => Ok(Box::new(r)),
            None => Err(StartError::Invalid(
                "the scene has nothing to simulate (no body, beam or mesh)".into(),
            )),
        };
    }
    if meshes.method.is_implicit() {
        return mesh_implicit::make(sys, h, start);
    }
    if matches!(method, M::StateTime { .. }) {
        return Err(StartError::Invalid(
            "state_time does not simulate finite-element meshes".into(),
        ));
    }
    if let Some(why) = mesh_ties::refusal(&meshes, sys.layout(), method) {
        return Err(StartError::Invalid(why));
    }
    // A rank's part checks its own elements' step limit; the ranks agree, so that none
    // starts while another refuses.
    let ranks = sys.ranks().filter(|r| r.size() > 1);
    let over = crate::analysis::mesh_model::critical_step(&meshes).filter(|c| h > c.step);
    if let Some(r) = &ranks {
        if crate::contract::ranks::any(&**r, over.is_some()) && over.is_none() {
            return Err(StartError::Invalid(format!(
                "the step {h:.3e} s is above the central-difference limit of another rank's part of the meshes (its report names the element)"
            )));
        }
    }
    if let Some(c) = over {
        return Err(StartError::Invalid(format!(
            "mesh '{}': the step {h:.3e} s is above the central-difference limit {:.3e} s = 2/ω_max of its stiffest element, {} (ω_max ≤ {:.4e} rad/s){}; reduce the step below it (a step of 0.9× the limit leaves a margin)",
            c.mesh, c.step, c.place, c.omega,
            if meshes.ties.is_empty() { "" } else { ", which bounds the tied system too" }
        )));
    }
    // The meshes first: their forces at the start give the ties' first wrench, which the
    // rigid method's start (consistent λ⁰, accelerations) must see.
    let mut coupler = mesh_ties::Coupler::new(sys.layout());
    let mesh_start = match (&coupler, start.mesh.is_empty()) {
        (Some(_), true) => mesh_ties::initial_mesh_state(sys.layout(), &start.pose, &start.twist),
        _ => start.mesh.clone(),
    };
    // The blocks' element loops: the system's own (generated code), else chosen by kind.
    let kernels = match sys.mesh_kernels() {
        Some(k) => k
            .downcast_ref::<mesh_kernels::BlockKernels>()
            .ok_or_else(|| {
                StartError::Invalid(
                    "the system's mesh kernels are not a `BlockKernels` table (a bug in the code that implements it)".into(),
                )
            })?
            .clone(),
        None => mesh_kernels::BlockKernels::interpreted(&meshes),
    };
    let mesh = mesh_dynamics::MeshDynamics::on_ranks(
        meshes.clone(),
        &kernels,
        h,
        start.t,
        &mesh_start,
        ranks,
    )?;
    if let Some(c) = &mut coupler {
        mesh_ties::wrenches(&meshes, &start.pose, mesh.reactions(), &mut c.wrench);
        c.wrench_prev.copy_from_slice(&c.wrench);
    }
    let wrench: &[Wrench] = coupler.as_ref().map_or(&[], |c| &c.wrench);
    let inner = rigid(method, &mesh_ties::Tied { sys, wrench }, h, start)?;
    Ok(Box::new(WithMeshes {
        inner,
        mesh,
        coupler,
        name: method.name(),
        h,
    }))
}

/// The rigid (and beam) integrator of `method` on `sys`, `None` for a system without
/// bodies and joints (a scene of meshes alone).
fn rigid<T: System>(
    method: &crate::contract::scene::MethodSpec,
    sys: &T,
    h: f64,
    start: &State,
) -> Result<Option<Rigid>, StartError> {
    use crate::contract::scene::MethodSpec as M;
    let rigid = sys.layout().bodies() > 0 || sys.layout().rows > 0;
    if !rigid {
        return Ok(None);
    }
    let rk = |tab, tolerance| -> Result<Rigid, StartError> {
        Ok(Rigid::RungeKutta(runge_kutta::RungeKutta::new(
            sys, tab, h, tolerance, start,
        )?))
    };
    Ok(Some(match method {
        M::Staggered(o) => Rigid::TwoStage(staggered::TwoStage::staggered(sys, h, o, start)?),
        M::Baumgarte { alpha, beta } => Rigid::TwoStage(staggered::TwoStage::baumgarte(
            sys, h, *alpha, *beta, start,
        )?),
        M::Penalty { epsilon } => {
            Rigid::TwoStage(staggered::TwoStage::penalty(sys, h, *epsilon, start)?)
        }
        M::CoordinatePartitioning => {
            Rigid::Partitioning(partitioning::Partitioning::new(sys, h, start)?)
        }
        M::ImplicitTrapezoid {
            tolerance,
            max_iterations,
        } => Rigid::Trapezoid(trapezoid::Trapezoid::new(
            sys,
            h,
            *tolerance,
            *max_iterations,
            start,
        )?),
        M::NaturalPartitioning {
            epsilon,
            tolerance,
            max_iterations,
        } => Rigid::Natural(
            natural::Natural::new(sys, h, *epsilon, *tolerance, start)?
                .with_pcg_limit(*max_iterations),
        ),
        M::RungeKutta4 => rk(&runge_kutta::tableau::RK4, None)?,
        M::DormandPrince { tolerance } => rk(&runge_kutta::tableau::DOPRI5, Some(*tolerance))?,
        M::DormandPrince853 { tolerance } => rk(&runge_kutta::tableau::DOP853, Some(*tolerance))?,
        M::StateTime { .. } => return Err(StartError::Unsupported(method.name())),
    }))
}

/// One of the rigid (and beam) integrators. None of them depends on the system's type,
/// so one value advances a system and the same system with ties ([`mesh_ties::Tied`]).
// One value per run: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
enum Rigid {
    TwoStage(staggered::TwoStage),
    Partitioning(partitioning::Partitioning),
    Trapezoid(trapezoid::Trapezoid),
    Natural(natural::Natural),
    RungeKutta(runge_kutta::RungeKutta),
}

/// `$call` on the integrator inside a [`Rigid`].
macro_rules! each {
    ($r:expr, $i:ident => $call:expr) => {
        match $r {
            Rigid::TwoStage($i) => $call,
            Rigid::Partitioning($i) => $call,
            Rigid::Trapezoid($i) => $call,
            Rigid::Natural($i) => $call,
            Rigid::RungeKutta($i) => $call,
        }
    };
}

impl<S: System> Integrator<S> for Rigid {
    fn name(&self) -> &'static str {
        each!(self, i => Integrator::<S>::name(i))
    }
    fn time(&self) -> f64 {
        each!(self, i => Integrator::<S>::time(i))
    }
    fn step_size(&self) -> f64 {
        each!(self, i => Integrator::<S>::step_size(i))
    }
    fn step(&mut self, sys: &S) -> Result<StepInfo, StepError> {
        each!(self, i => i.step(sys))
    }
    fn state(&self, sys: &S, out: &mut State) {
        each!(self, i => i.state(sys, out))
    }
    fn active(&self) -> &[bool] {
        each!(self, i => Integrator::<S>::active(i))
    }
    fn stats(&self) -> Vec<(&'static str, f64)> {
        each!(self, i => Integrator::<S>::stats(i))
    }
    fn take_notice(&mut self) -> Option<String> {
        each!(self, i => Integrator::<S>::take_notice(i))
    }
    fn end_notice(&self) -> Option<String> {
        each!(self, i => Integrator::<S>::end_notice(i))
    }
    fn persist(&mut self, v: &mut dyn crate::contract::persist::StateVisitor) -> bool {
        each!(self, i => Integrator::<S>::persist(i, v))
    }
}

/// A rigid (and beam) integrator, if the scene has bodies, and the meshes' explicit
/// integrator, stepped together with the same step. Tied node sets couple them
/// ([`mesh_ties`]): each step the rigid method advances the bodies with the ties' wrench of
/// the mesh's current state, then the mesh steps with its tied nodes where the bodies now
/// are. Without ties the wrench is empty and the two run side by side.
struct WithMeshes {
    inner: Option<Rigid>,
    mesh: mesh_dynamics::MeshDynamics,
    coupler: Option<mesh_ties::Coupler>,
    name: &'static str,
    h: f64,
}

impl<S: System> Integrator<S> for WithMeshes {
    fn name(&self) -> &'static str {
        self.name
    }
    fn time(&self) -> f64 {
        self.mesh.time()
    }
    fn step_size(&self) -> f64 {
        self.h
    }
    fn step(&mut self, sys: &S) -> Result<StepInfo, StepError> {
        let wrench: &[Wrench] = self.coupler.as_ref().map_or(&[], |c| &c.wrench);
        let tied = mesh_ties::Tied { sys, wrench };
        let info = match &mut self.inner {
            Some(i) => i.step(&tied)?,
            None => StepInfo::default(),
        };
        match (&mut self.coupler, &self.inner) {
            (Some(c), Some(i)) => {
                // the bodies at the step's end carry the tied nodes there
                i.state(&mesh_ties::Tied { sys, wrench: &[] }, &mut c.state);
                let meshes = &sys.layout().meshes;
                c.place_at_state(meshes)?;
                self.mesh.step_tied(&c.u, &c.v)?;
                c.wrenches_at_state(meshes, self.mesh.reactions());
            }
            _ => self.mesh.step()?,
        }
        Ok(info)
    }
    fn state(&self, sys: &S, out: &mut State) {
        if let Some(i) = &self.inner {
            let wrench: &[Wrench] = self.coupler.as_ref().map_or(&[], |c| &c.wrench);
            i.state(&mesh_ties::Tied { sys, wrench }, out);
        } else {
            out.t = self.mesh.time();
        }
        self.mesh.state(&mut out.mesh);
        if let Some(c) = &self.coupler {
            c.synchronize(sys.layout(), self.h, out);
        }
    }
    fn persist(&mut self, v: &mut dyn crate::contract::persist::StateVisitor) -> bool {
        // the rigid method's state (if the scene has bodies; without it nothing persists),
        // the meshes' and the ties'
        let mut has_inner = self.inner.is_some();
        crate::contract::persist::bool(v, "inner", &mut has_inner);
        if let Some(i) = &mut self.inner {
            if !Integrator::<S>::persist(i, v) {
                return false;
            }
        }
        self.mesh.persist(v);
        let mut has_coupler = self.coupler.is_some();
        crate::contract::persist::bool(v, "coupler", &mut has_coupler);
        if let Some(c) = &mut self.coupler {
            c.persist(v);
        }
        true
    }
    fn active(&self) -> &[bool] {
        self.inner
            .as_ref()
            .map_or(&[], |i| Integrator::<S>::active(i))
    }
    fn stats(&self) -> Vec<(&'static str, f64)> {
        let mut s = self
            .inner
            .as_ref()
            .map_or_else(Vec::new, |i| Integrator::<S>::stats(i));
        s.extend(self.mesh.rank_stats());
        s
    }
    fn take_notice(&mut self) -> Option<String> {
        self.inner
            .as_mut()
            .and_then(|i| Integrator::<S>::take_notice(i))
    }
    fn end_notice(&self) -> Option<String> {
        self.inner
            .as_ref()
            .and_then(|i| Integrator::<S>::end_notice(i))
    }
}

/// The refusal of a step above a beam's explicit limit, if any: per beam, the limit of its
/// shortest element ([`crate::analysis::step_limits::beam_step_limit`]).
fn beam_step_limit(
    layout: &crate::contract::system::Layout,
    start: &State,
    step: f64,
    substeps: u32,
) -> Option<String> {
    let h = step / substeps as f64;
    use crate::analysis::step_limits::beam_step_limit;
    for b in &layout.beams.beams {
        let node = |k: usize| start.pose.get(b.first_body + k).map(|p| p.r);
        let Some((e, l)) = (0..b.elements)
            .filter_map(|e| Some((e, (node(e + 1)? - node(e)?).norm())))
            .min_by(|x, y| x.1.total_cmp(&y.1))
        else {
            continue;
        };
        let (w, limit) = beam_step_limit(&b.section, l, b.rotary_inertia_scale, b.damping)?;
        if h > limit {
            let needed = (step / limit).ceil() as u64;
            let what = if substeps > 1 {
                format!("the substep {h:.3e} s (the step over `beam_substeps {substeps}`)")
            } else {
                format!("the step {h:.3e} s")
            };
            return Some(format!(
                "beam '{}', element {e}: {what} is above the explicit limit {limit:.3e} s of the beam's highest mode ({w:.4e} rad/s{}); reduce the step, advance the beams in substeps (`beam_substeps {needed}` or more in `method staggered {{ }}`: the rigid bodies keep the step), or raise the beam's `rotary_inertia_scale` (it lowers the shear/rotary-inertia mode; see docs/methods.md)",
                b.name,
                if b.damping > 0.0 { ", with its damping" } else { "" }
            ));
        }
    }
    None
}

/// The refusal of a subcycled beam without enough damping
/// ([`beam_subcycle::MIN_DAMPING_RATIO`] at its highest element mode), naming the beam
/// and the least `damping` it needs.
fn beam_subcycle_damping(
    layout: &crate::contract::system::Layout,
    start: &State,
    substeps: u32,
) -> Option<String> {
    use crate::analysis::step_limits::beam_element_frequency;
    for b in &layout.beams.beams {
        let node = |k: usize| start.pose.get(b.first_body + k).map(|p| p.r);
        let l = (0..b.elements)
            .filter_map(|e| Some((node(e + 1)? - node(e)?).norm()))
            .fold(f64::INFINITY, f64::min);
        let Some(w) = beam_element_frequency(&b.section, l, b.rotary_inertia_scale) else {
            continue;
        };
        let least = 2.0 * beam_subcycle::MIN_DAMPING_RATIO / w;
        if b.damping < least {
            return Some(format!(
                "beam '{}': `beam_substeps {substeps}` needs stiffness-proportional damping on the beam, `damping {least:.2e} s` or more (a damping ratio of {} at its highest element mode, {w:.4e} rad/s; it has {} s): without it the beam's highest modes grow, since the bodies take the beam's forces only once per step (docs/methods.md, \"Beams: subcycling\"). Its effect on a mode of frequency ω is a damping ratio βω/2",
                b.name,
                beam_subcycle::MIN_DAMPING_RATIO,
                b.damping
            ));
        }
    }
    None
}

/// The refusal of a step above the limit of a body's coupling to the beam elements clamped
/// or pinned to it, when the beams are subcycled ([`beam_subcycle`]): the body takes the
/// whole step against the elements' forces, so each attached node's elements, with the
/// body's mobility at the attachment in place of the node's mass, must have
/// `h·ω ≤ 2` ([`crate::analysis::step_limits::beam_coupling_frequency`]).
pub fn beam_coupling_limit(
    layout: &crate::contract::system::Layout,
    start: &State,
    h: f64,
) -> Option<String> {
    use crate::analysis::step_limits::beam_coupling_frequency;
    let beam_of = |body: usize| {
        layout
            .beams
            .beams
            .iter()
            .find(|b| (b.first_body..=b.first_body + b.elements).contains(&body))
    };
    let mut worst: Option<(f64, String)> = None;
    for j in &layout.joints {
        let (node, body) = match (j.a, j.b) {
            (Some(a), Some(b)) if beam_of(a).is_some() && beam_of(b).is_none() => (a, b),
            (Some(a), Some(b)) if beam_of(b).is_some() && beam_of(a).is_none() => (b, a),
            _ => continue,
        };
        let beam = beam_of(node)?;
        let k = node - beam.first_body;
        let p = |i: usize| start.pose[beam.first_body + i];
        let elements: Vec<(Pose, Pose)> = [k.checked_sub(1), (k < beam.elements).then_some(k)]
            .into_iter()
            .flatten()
            .map(|e| (p(e), p(e + 1)))
            .collect();
        let rotation = j.rows == 6;
        let Some(w) = beam_coupling_frequency(
            &beam.section,
            &elements,
            &start.pose[node],
            &layout.mass[body],
            &start.pose[body],
            rotation,
        ) else {
            continue;
        };
        let limit = 2.0 / w;
        if h > limit && worst.as_ref().is_none_or(|x| limit < x.0) {
            worst = Some((
                limit,
                format!(
                    "joint '{}': with `beam_substeps`, body '{}' takes the step {h:.3e} s against the forces of beam '{}' at its node {k}, and the step is above the limit {limit:.3e} s of that coupling (ω = {w:.4e} rad/s: the stiffness of the node's elements against the body's mass{}); reduce the step, or give the body more mass",
                    j.name,
                    layout.body_names[body],
                    beam.name,
                    if rotation { " and inertia" } else { "" },
                ),
            ));
        }
    }
    worst.map(|w| w.1)
}

/// Why an integrator could not start.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StartError {
    /// The method is not available in this runtime.
    #[error("method `{0}` is not available yet")]
    Unsupported(&'static str),
    /// The step, the method's options or the system's size are out of range.
    #[error("{0}")]
    Invalid(String),
    /// The initial state could not be processed.
    #[error(transparent)]
    Step(#[from] StepError),
    /// A linear solver could not be set up.
    #[error("linear solver: {0}")]
    Linalg(#[from] crate::linalg::LinalgError),
}

/// What went wrong in a step.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StepError {
    /// A linear system could not be factorized.
    #[error("the {what} matrix is singular at row {row} (the constraints there are dependent or degenerate)")]
    Singular {
        /// Which matrix.
        what: &'static str,
        /// Row (constraint row or unknown index) where the factorization failed.
        row: usize,
    },
    /// A linear solve failed for another reason (non-finite entries).
    #[error("{what}: {message}")]
    Linalg {
        /// Which system.
        what: &'static str,
        /// The solver's message.
        message: String,
    },
    /// A beam element could not be evaluated (a zero-length or folded element, a section
    /// turned by half a revolution in one step).
    #[error("beam '{beam}', element {element}: {message}")]
    Beam {
        /// The beam's name.
        beam: String,
        /// The element's index within its beam (0 at the start).
        element: usize,
        /// What went wrong.
        message: String,
    },
    /// A mesh element inverted, or a mesh node's acceleration is not finite.
    #[error("mesh '{mesh}', {place}: {message}")]
    Mesh {
        /// The mesh's name.
        mesh: String,
        /// The element (index, nodes, centroid) or node.
        place: String,
        /// What went wrong.
        message: String,
    },
    /// A state-time window could not be solved: Newton's method did not converge, or its
    /// matrix is singular.
    #[error("{message}")]
    Window {
        /// The body or joint, equation or unknown, and time where it failed.
        place: String,
        /// The largest residual at the end.
        residual: f64,
        /// What happened, with the window's time span.
        message: String,
        /// Whether the window's equations are singular (not merely unconverged).
        singular: bool,
    },
    /// An iteration did not converge.
    #[error("{what} did not converge in {iterations} iterations (residual {residual:.3e})")]
    NoConvergence {
        /// Which iteration.
        what: &'static str,
        /// Iterations made.
        iterations: u32,
        /// Final residual.
        residual: f64,
        /// The constraint row with the largest residual, where the iteration has rows.
        row: Option<usize>,
    },
}

/// The index and magnitude of the largest entry of `res` by absolute value (`None` if empty).
pub(crate) fn worst_entry(res: &[f64]) -> Option<(usize, f64)> {
    res.iter()
        .enumerate()
        .fold(None, |best: Option<(usize, f64)>, (i, v)| match best {
            Some((_, b)) if b >= v.abs() => best,
            _ => Some((i, v.abs())),
        })
}

/// Per-step statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepInfo {
    /// Iterations of the method's inner solver (Newton, PCG), 0 if it does not iterate.
    pub iterations: u32,
}

/// A fixed-step integrator.
pub trait Integrator<S: System> {
    /// The method name.
    fn name(&self) -> &'static str;
    /// Current (synchronized) time.
    fn time(&self) -> f64;
    /// Step size.
    fn step_size(&self) -> f64;
    /// Advance one step.
    fn step(&mut self, sys: &S) -> Result<StepInfo, StepError>;
    /// The synchronized state at [`Integrator::time`].
    fn state(&self, sys: &S, out: &mut State);
    /// Which constraint rows are enforced (locks engage during a run).
    fn active(&self) -> &[bool];
    /// Method statistics for the run summary (name, value).
    fn stats(&self) -> Vec<(&'static str, f64)> {
        Vec::new()
    }
    /// A warning raised by the last step, for the user (once per kind and run); the driver
    /// polls it after every step.
    fn take_notice(&mut self) -> Option<String> {
        None
    }
    /// A warning about the result of a run that reached its end time, asked once there: a
    /// result that is not what the run was asked for (a static solution by dynamic relaxation
    /// that has not converged). The driver gives it to the observer and the run report.
    fn end_notice(&self) -> Option<String> {
        None
    }
    /// Save or load (by the visitor) every value the method carries from one step to the
    /// next, so that a run restarted from a checkpoint continues bitwise as it would have
    /// ([`crate::contract::persist`]). Returns `false` if the method cannot do that yet (the
    /// run then refuses to checkpoint, naming the method).
    fn persist(&mut self, v: &mut dyn crate::contract::persist::StateVisitor) -> bool {
        let _ = v;
        false
    }
}
