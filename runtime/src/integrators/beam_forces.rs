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
use crate::integrators::{State, StepError};
use crate::kernels::beam_element::{
    convected_frame, internal_force, nodal_wrenches, section_rotations, strain_energy, strain_rate,
    BeamNode, BeamSection, ElementForce, ElementState,
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
    /// Per beam: its name (for reports).
    names: Vec<String>,
    /// Per element: its beam and node bodies.
    elements: Vec<BeamElementLayout>,
    /// Per element: its state.
    states: Vec<ElementState>,
    /// Per element: the forces on its two nodes (elastic + damping).
    wrench: Vec<[Wrench; 2]>,
    /// Scratch for one evaluation.
    out: ElementForce,
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
    /// The beams of `layout` (`None` if it has none), starting from `start`: its element
    /// states if it carries them (a restart), else stress-free in its configuration.
    /// The nodal forces are those of the states' resultants at `start`'s positions (and the
    /// damping of its velocities).
    pub fn new(layout: &Layout, start: &State) -> Result<Option<BeamForces>, StepError> {
        let bl = &layout.beams;
        if bl.is_empty() {
            return Ok(None);
        }
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
            names: bl.beams.iter().map(|b| b.name.clone()).collect(),
            elements: bl.elements.clone(),
            states,
            wrench: vec![[Wrench::default(); 2]; bl.elements.len()],
            out: ElementForce::default(),
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
            f.add_damping(e, &nodes).map_err(|err| fail(e, err))?;
        }
        Ok(Some(f))
    }

    /// Evaluate every element at the new positions `pose` (advancing its state by the
    /// increments since its last evaluation) with damping from the velocities `twist`.
    /// Does not allocate.
    pub fn update(&mut self, pose: &[Pose], twist: &[Twist]) -> Result<(), StepError> {
        let mut largest: (f64, usize) = (0.0, 0);
        for e in 0..self.elements.len() {
            let el = self.elements[e];
            let nodes = [
                node(pose, twist, el.nodes[0]),
                node(pose, twist, el.nodes[1]),
            ];
            let section = self.sections[el.beam];
            if let Err(err) = internal_force(&section, &mut self.states[e], &nodes, &mut self.out) {
                return Err(self.error(e, err.to_string()));
            }
            let turn = self.out.d_kappa.norm() * self.out.length;
            if turn > largest.0 {
                largest = (turn, e);
            }
            self.wrench[e] = self.out.wrench;
            if let Err(m) = self.add_damping(e, &nodes) {
                return Err(self.error(e, m));
            }
        }
        if largest.0 > LARGE_ROTATION {
            self.large_rotation_steps += 1;
            if !self.reported && self.pending_notice.is_none() {
                self.pending_notice = Some((largest.1, largest.0));
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

    /// Add element `e`'s damping forces (if its beam is damped) to its wrenches.
    fn add_damping(&mut self, e: usize, nodes: &[BeamNode; 2]) -> Result<(), String> {
        let b = self.elements[e].beam;
        let beta = self.damping[b];
        if beta == 0.0 {
            return Ok(());
        }
        let sec = &self.sections[b];
        let (gd, kd) = strain_rate(nodes).map_err(|e| e.to_string())?;
        let n = sec.c_gamma().component_mul(&gd) * beta;
        let m = sec.c_kappa().component_mul(&kd) * beta;
        let (t, l) = convected_frame(&nodes[0].pose.r, &nodes[1].pose.r, &nodes[0].pose.c)
            .map_err(|e| e.to_string())?;
        let s = section_rotations(nodes, &t);
        let w = nodal_wrenches(&t, l, &s, &n, &m);
        for i in 0..2 {
            self.wrench[e][i].f += w[i].f;
            self.wrench[e][i].t += w[i].t;
        }
        Ok(())
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

/// The strain energy of element states (J), summed.
pub fn total_strain_energy(states: &[ElementState]) -> f64 {
    states.iter().map(strain_energy).sum()
}
