//! The internal forces of a system's flexible beams, as the explicit coordinate integrator
//! uses them: one element evaluation per step at the step's new positions (notes B §6.4,
//! [`crate::kernels::beam_element::internal_force`]), whose nodal wrenches are the beams'
//! share of the applied forces of the next kick.
//!
//! The element states (resultants, accumulated strains and the configuration they were last
//! evaluated at) are owned here and copied into every synchronized [`State`]: a state is
//! always that of the positions it is reported with, so a restart from a state (the run
//! driver's halve-step retry) continues exactly, and the strain energy of a frame is that of
//! its positions.
//!
//! **Damping** (`damping β` on a beam): stiffness-proportional resultants
//! `β·diag(EA, GA₂, GA₃)·γ̇`, `β·diag(GJ, EI₂, EI₃)·κ̇` from the strain rates
//! ([`strain_rate`]) of the newest velocities (half a step behind the positions, as the
//! leapfrog takes damping, notes A §1.9). They are not accumulated into the element state.
//!
//! **Large rotation increments.** The incremental curvature is accurate while the two
//! sections of an element turn by much less than a right angle relative to each other in
//! one step; past ~π/4 ([`LARGE_ROTATION`]) a notice names the beam, the element and the
//! time (once per run; the count is in the statistics).

use crate::contract::system::{BeamElementLayout, Layout, Pose, Twist, Wrench};
use crate::integrators::beam_kernels::{BeamKernels, ElementFn};
use crate::integrators::{State, StepError};
use crate::kernels::beam_element::{
    convected_frame, nodal_wrenches, section_rotations, strain_energy, strain_rate, BeamNode,
    BeamSection, ElementState,
};

/// The relative rotation of an element's two sections within one step above which the
/// incremental curvature stops being accurate: π/4, as the Cayley length `2 tan(π/8)`.
pub const LARGE_ROTATION: f64 = 0.828_427_124_746_190_1;

/// The beams' element states and the nodal forces of the last evaluation.
#[derive(Clone, Debug)]
pub struct BeamForces {
    /// Per beam: the kernel's section.
    sections: Vec<BeamSection>,
    /// Per beam: the damping coefficient β (s).
    damping: Vec<f64>,
    /// Per beam: its element variant's function ([`BeamKernels::per_beam`]).
    kernels: Vec<ElementFn>,
    /// Per beam: its name (for reports).
    names: Vec<String>,
    /// Per element: its beam and node bodies.
    elements: Vec<BeamElementLayout>,
    /// Per element: its state.
    states: Vec<ElementState>,
    /// Per element: the forces on its two nodes (elastic + damping).
    wrench: Vec<[Wrench; 2]>,
    /// Steps with an element above [`LARGE_ROTATION`].
    large_rotation_steps: u64,
    /// The first such event not yet reported: (element, relative rotation).
    pending_notice: Option<(usize, f64)>,
    reported: bool,
}

fn node(pose: &[Pose], twist: &[Twist], b: usize) -> BeamNode {
    BeamNode {
        pose: pose[b],
        twist: twist[b],
    }
}

impl BeamForces {
    /// Save or load the elements' states (their resultants, accumulated strains and the
    /// frames and lengths of the last evaluation), forces and event counters.
    pub fn persist(&mut self, v: &mut dyn crate::contract::persist::StateVisitor) {
        use crate::contract::persist;
        // per element: N, M, γ, κ (12), ℓ₀, ℓⁿ (2), Tⁿ (9), S₁ⁿ, S₂ⁿ (18), the two nodes (6)
        const PER: usize = 47;
        let mut buf: Vec<f64> = Vec::with_capacity(self.states.len() * PER);
        for e in &self.states {
            buf.extend_from_slice(e.n.as_slice());
            buf.extend_from_slice(e.m.as_slice());
            buf.extend_from_slice(e.gamma.as_slice());
            buf.extend_from_slice(e.kappa.as_slice());
            buf.push(e.l0);
            buf.push(e.l_prev);
            buf.extend_from_slice(e.t_prev.as_slice());
            buf.extend_from_slice(e.s_prev[0].as_slice());
            buf.extend_from_slice(e.s_prev[1].as_slice());
            buf.extend_from_slice(e.x_prev[0].as_slice());
            buf.extend_from_slice(e.x_prev[1].as_slice());
        }
        v.f64s("beam.states", &mut buf);
        for (e, b) in self.states.iter_mut().zip(buf.chunks(PER)) {
            let mut it = b.iter().copied();
            let mut take =
                |dst: &mut [f64]| dst.iter_mut().for_each(|d| *d = it.next().unwrap_or(0.0));
            take(e.n.as_mut_slice());
            take(e.m.as_mut_slice());
            take(e.gamma.as_mut_slice());
            take(e.kappa.as_mut_slice());
            take(std::slice::from_mut(&mut e.l0));
            take(std::slice::from_mut(&mut e.l_prev));
            take(e.t_prev.as_mut_slice());
            let [s0, s1] = &mut e.s_prev;
            take(s0.as_mut_slice());
            take(s1.as_mut_slice());
            let [x0, x1] = &mut e.x_prev;
            take(x0.as_mut_slice());
            take(x1.as_mut_slice());
        }
        let mut w: Vec<Wrench> = self.wrench.iter().flatten().copied().collect();
        persist::wrenches(v, "beam.wrench", &mut w);
        for (d, s) in self.wrench.iter_mut().zip(w.chunks(2)) {
            d.copy_from_slice(s);
        }
        persist::u64(
            v,
            "beam.large_rotation_steps",
            &mut self.large_rotation_steps,
        );
        let mut pending = self
            .pending_notice
            .map_or([f64::NAN; 2], |(e, r)| [e as f64, r]);
        v.f64s("beam.pending_notice", &mut pending);
        self.pending_notice = (!pending[0].is_nan()).then(|| (pending[0] as usize, pending[1]));
        persist::bool(v, "beam.reported", &mut self.reported);
    }

    /// The beams of `layout` (`None` if it has none), starting from `start`: its element
    /// states if it carries them (a restart), else stress-free in its configuration.
    /// The nodal forces are those of the states' resultants at `start`'s positions (and the
    /// damping of its velocities). Each beam's elements run the interpreter's choice of
    /// variant ([`BeamKernels::interpreted`]); [`BeamForces::with_kernels`] takes a table.
    pub fn new(layout: &Layout, start: &State) -> Result<Option<BeamForces>, StepError> {
        Self::with_kernels(layout, &BeamKernels::interpreted(&layout.beams), start)
    }

    /// [`BeamForces::new`] with the element variants of `kernels` (generated code's table,
    /// [`crate::contract::system::System::beam_kernels`]); errors when it lacks a beam's
    /// variant.
    pub fn with_kernels(
        layout: &Layout,
        kernels: &BeamKernels,
        start: &State,
    ) -> Result<Option<BeamForces>, StepError> {
        let bl = &layout.beams;
        if bl.is_empty() {
            return Ok(None);
        }
        let per_beam = kernels
            .per_beam(bl)
            .map_err(|(b, message)| StepError::Beam {
                beam: bl.beams[b].name.clone(),
                element: 0,
                message,
            })?;
        let fail = |e: usize, message: String| StepError::Beam {
            beam: bl.beams[bl.elements[e].beam].name.clone(),
            element: e - bl.beams[bl.elements[e].beam].first_element,
            message,
        };
        let mut sections = Vec::with_capacity(bl.beams.len());
        for b in &bl.beams {
            sections.push(
                BeamSection::from_scene(&b.section).map_err(|e| StepError::Beam {
                    beam: b.name.clone(),
                    element: 0,
                    message: e.to_string(),
                })?,
            );
        }
        let states = if start.beams.len() == bl.elements.len() {
            start.beams.clone()
        } else {
            let mut s = Vec::with_capacity(bl.elements.len());
            for (e, el) in bl.elements.iter().enumerate() {
                let nodes = [
                    node(&start.pose, &start.twist, el.nodes[0]),
                    node(&start.pose, &start.twist, el.nodes[1]),
                ];
                s.push(ElementState::new(&nodes).map_err(|err| fail(e, err.to_string()))?);
            }
            s
        };
        let mut f = BeamForces {
            sections,
            damping: bl.beams.iter().map(|b| b.damping).collect(),
            kernels: per_beam,
            names: bl.beams.iter().map(|b| b.name.clone()).collect(),
            elements: bl.elements.clone(),
            states,
            wrench: vec![[Wrench::default(); 2]; bl.elements.len()],
            large_rotation_steps: 0,
            pending_notice: None,
            reported: false,
        };
        // the forces of the resultants as they are, at the start's positions
        for e in 0..f.elements.len() {
            let el = f.elements[e];
            let nodes = [
                node(&start.pose, &start.twist, el.nodes[0]),
                node(&start.pose, &start.twist, el.nodes[1]),
            ];
            let (t, l) = convected_frame(&nodes[0].pose.r, &nodes[1].pose.r, &nodes[0].pose.c)
                .map_err(|err| fail(e, err.to_string()))?;
            let s = section_rotations(&nodes, &t);
            let st = &f.states[e];
            f.wrench[e] = nodal_wrenches(&t, l, &s, &st.n, &st.m);
            let beam = f.elements[e].beam;
            add_damping(&f.sections[beam], f.damping[beam], &nodes, &mut f.wrench[e])
                .map_err(|err| fail(e, err))?;
        }
        Ok(Some(f))
    }

    /// Evaluate every element at the new positions `pose` (advancing its state by the
    /// increments since its last evaluation) with damping from the velocities `twist`.
    /// Elements are independent: from [`PAR_MIN_ELEMENTS`] on they are evaluated in
    /// parallel (rayon, chunks of at least 256). Does not allocate on the serial path.
    pub fn update(&mut self, pose: &[Pose], twist: &[Twist]) -> Result<(), StepError> {
        let (sections, damping, kernels) = (&self.sections, &self.damping, &self.kernels);
        // (largest relative turn, its element, first failing element and why)
        type Acc = (f64, usize, Option<(usize, String)>);
        let one =
            |e: usize, el: &BeamElementLayout, st: &mut ElementState, w: &mut [Wrench; 2]| -> Acc {
                let nodes = [
                    node(pose, twist, el.nodes[0]),
                    node(pose, twist, el.nodes[1]),
                ];
                let b = el.beam;
                match (kernels[b])(&sections[b], damping[b], st, &nodes, w) {
                    Ok(turn) => (turn, e, None),
                    Err(err) => (0.0, e, Some((e, err.to_string()))),
                }
            };
        let merge = |a: Acc, b: Acc| -> Acc {
            let err = match (a.2, b.2) {
                (Some(x), Some(y)) => Some(if x.0 <= y.0 { x } else { y }),
                (x, y) => x.or(y),
            };
            if a.0 >= b.0 {
                (a.0, a.1, err)
            } else {
                (b.0, b.1, err)
            }
        };
        let acc = if self.elements.len() >= PAR_MIN_ELEMENTS {
            use rayon::prelude::*;
            (
                self.elements.par_iter(),
                self.states.par_iter_mut(),
                self.wrench.par_iter_mut(),
            )
                .into_par_iter()
                .enumerate()
                .with_min_len(256)
                .map(|(e, (el, st, w))| one(e, el, st, w))
                .reduce(|| (0.0, 0, None), merge)
        } else {
            let mut acc: Acc = (0.0, 0, None);
            for (e, (el, (st, w))) in self
                .elements
                .iter()
                .zip(self.states.iter_mut().zip(self.wrench.iter_mut()))
                .enumerate()
            {
                acc = merge(acc, one(e, el, st, w));
                if acc.2.is_some() {
                    break;
                }
            }
            acc
        };
        if let Some((e, m)) = acc.2 {
            return Err(self.error(e, m));
        }
        if acc.0 > LARGE_ROTATION {
            self.large_rotation_steps += 1;
            if !self.reported && self.pending_notice.is_none() {
                self.pending_notice = Some((acc.1, acc.0));
            }
        }
        Ok(())
    }

    fn error(&self, e: usize, message: String) -> StepError {
        let b = self.elements[e].beam;
        let first = self.elements.iter().position(|x| x.beam == b).unwrap_or(0);
        StepError::Beam {
            beam: self.names[b].clone(),
            element: e - first,
            message,
        }
    }

    /// Add the beams' nodal forces of the last evaluation to `out` (one entry per body).
    pub fn add_to(&self, out: &mut [Wrench]) {
        for (el, w) in self.elements.iter().zip(&self.wrench) {
            for i in 0..2 {
                let o = &mut out[el.nodes[i]];
                o.f += w[i].f;
                o.t += w[i].t;
            }
        }
    }

    /// The element states (one per element, beam after beam).
    pub fn states(&self) -> &[ElementState] {
        &self.states
    }

    /// Steps in which some element turned by more than [`LARGE_ROTATION`].
    pub fn large_rotation_steps(&self) -> u64 {
        self.large_rotation_steps
    }

    /// The first large-rotation event not yet reported, as a message; then never again.
    pub fn take_notice(&mut self, t: f64) -> Option<String> {
        let (e, turn) = self.pending_notice.take()?;
        self.reported = true;
        let b = self.elements[e].beam;
        let first = self.elements.iter().position(|x| x.beam == b).unwrap_or(0);
        Some(format!(
            "beam '{}', element {}: its sections turned by {:.2} rad relative to each other in one step at t = {t:.6} s, more than π/4: the incremental curvature is no longer accurate there; reduce the step or use more elements",
            self.names[b],
            e - first,
            2.0 * (turn / 2.0).atan(),
        ))
    }
}

/// Elements from which [`BeamForces::update`] evaluates them in parallel.
pub const PAR_MIN_ELEMENTS: usize = 512;

/// Add an element's stiffness-proportional damping forces (if `beta` > 0) to `w`.
fn add_damping(
    sec: &BeamSection,
    beta: f64,
    nodes: &[BeamNode; 2],
    w: &mut [Wrench; 2],
) -> Result<(), String> {
    if beta == 0.0 {
        return Ok(());
    }
    let (gd, kd) = strain_rate(nodes).map_err(|e| e.to_string())?;
    let n = sec.c_gamma().component_mul(&gd) * beta;
    let m = sec.c_kappa().component_mul(&kd) * beta;
    let (t, l) = convected_frame(&nodes[0].pose.r, &nodes[1].pose.r, &nodes[0].pose.c)
        .map_err(|e| e.to_string())?;
    let s = section_rotations(nodes, &t);
    let d = nodal_wrenches(&t, l, &s, &n, &m);
    for i in 0..2 {
        w[i].f += d[i].f;
        w[i].t += d[i].t;
    }
    Ok(())
}

/// The strain energy of element states (J), summed.
pub fn total_strain_energy(states: &[ElementState]) -> f64 {
    states.iter().map(strain_energy).sum()
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;
    use crate::analysis::beam_model::expand;
    use crate::contract::math::{axis_angle, qmul};
    use crate::contract::scene::{Beam, Origin, Scene, Section, Simulate};
    use crate::contract::system::System;
    use crate::interp::Interp;

    fn two_element_beam() -> Interp {
        let scene = Scene {
            name: "b".into(),
            gravity: None,
            bodies: vec![],
            joints: vec![],
            forces: vec![],
            beams: vec![Beam {
                name: "arm".into(),
                nodes: vec![[0.0; 3], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]],
                up: [0.0, 0.0, 1.0],
                section: Section {
                    ea: 1e4,
                    ga2: 1e4,
                    ga3: 1e4,
                    ei2: 10.0,
                    ei3: 10.0,
                    gj: 10.0,
                    rho_a: 1.0,
                    rho_i: 1e-3,
                },
                attachments: vec![],
                damping: 0.0,
                rotary_inertia_scale: 1.0,
                velocity: [0.0; 3],
                angular_velocity: [0.0; 3],
                origin: Origin::default(),
            }],
            meshes: vec![],
            contacts: vec![],
            simulate: Simulate::default(),
            reference: None,
            params: vec![],
        };
        assert_eq!(expand(&scene).unwrap().scene.bodies.len(), 3);
        Interp::new(&scene).unwrap()
    }

    /// An element whose end section turns by 1 rad (> π/4) relative to its start in one
    /// evaluation is reported once, naming the beam, the element and the time.
    #[test]
    fn a_large_rotation_increment_is_reported_once_with_its_element() {
        let sys = two_element_beam();
        let start = State::initial(&sys);
        let mut f = BeamForces::new(sys.layout(), &start).unwrap().unwrap();
        assert_eq!(f.states().len(), 2);
        let mut pose = start.pose.clone();
        let q0 = pose[2].q;
        pose[2].set_q(qmul(&axis_angle(&Vector3::z(), 1.0), &q0));
        f.update(&pose, &start.twist).unwrap();
        assert_eq!(f.large_rotation_steps(), 1);
        let m = f.take_notice(0.25).expect("a notice");
        assert!(
            m.contains("beam 'arm', element 1") && m.contains("t = 0.25"),
            "{m}"
        );
        assert!(m.contains("1.00 rad"), "{m}");
        assert!(f.take_notice(0.3).is_none(), "once per run");
        // a small increment is not
        let mut pose2 = pose.clone();
        pose2[2].set_q(qmul(&axis_angle(&Vector3::z(), 1.1), &q0));
        f.update(&pose2, &start.twist).unwrap();
        assert_eq!(f.large_rotation_steps(), 1);
    }

    /// The strain energy of a state is that of the section law: a uniform stretch ε of a bar
    /// stores `EA ε² L/2`.
    #[test]
    fn strain_energy_of_a_stretch() {
        let sys = two_element_beam();
        let start = State::initial(&sys);
        let mut f = BeamForces::new(sys.layout(), &start).unwrap().unwrap();
        let mut pose = start.pose.clone();
        let eps = 1e-4;
        for (k, p) in pose.iter_mut().enumerate() {
            p.r.x = 0.5 * k as f64 * (1.0 + eps);
        }
        f.update(&pose, &start.twist).unwrap();
        let u = total_strain_energy(f.states());
        let exact = 0.5 * 1e4 * eps * eps * 1.0;
        assert!((u - exact).abs() < 1e-6 * exact, "{u} vs {exact}");
    }
}
