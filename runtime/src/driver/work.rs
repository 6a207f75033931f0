//! The work of what the potential energy does not hold, booked after every step so that a
//! run's energy balance `K + V − W = K₀ + V₀` can be checked on every scene, driven or not.
//!
//! Two kinds of work enter `W`:
//!
//! - **Forces**: the power of [`System::applied`] (gravity, point forces and torques,
//!   springs, dampers, contact) less the power of the conservative forces, which the
//!   potential energy `V` holds already. The latter is `−dV/dt` along the motion, taken by a
//!   central difference of [`System::potential_energy`] over a time `τ = 10⁻⁴ h` on both
//!   sides of the state (positions moved by `±τ v`, orientations by `±τ ω`): its truncation
//!   error is `(τ ω)²/6 ≤ 10⁻⁸` of the power for `h ω ≤ 2`, its round-off `10⁻¹⁶ |V| / τ`.
//!   What remains is the power of point forces and torques, of dampers and of contact
//!   damping: `P = Σ f·v + τ·ω + dV/dt`, integrated over the step by the trapezoidal rule
//!   (the staggered leapfrog applies its forces the same way, half a kick at each end).
//! - **Drivers** (rheonomic rows) and prescribed velocities: a row's constraint force
//!   `−Bᵀλ` has power `−λ B u̇ = λ b` on the motion that satisfies the row (`B u̇ + b = 0`,
//!   `b = ∂Φ/∂t`), so only rows with an explicit time dependence work. Where a method's
//!   multipliers are the forces at the states' times, booked by the trapezoidal rule over
//!   the step (for the first step, whose start has no multipliers yet, with the step's end
//!   value on both ends); where they are the mean force over the step that produced the
//!   state ([`crate::integrators::multipliers_are_step_means`]), as `h λ (b₀ + b₁)/2`, so
//!   that the impulse of a driver's kink is booked once, in its step.
//!
//! A driver whose rate jumps (a kink in its motion, such as `ramp(t − t₀)`) acts by an
//! impulse, whose work is the jump of kinetic energy it causes and nothing a multiplier at
//! the states can tell; [`WorkWatch::step`] says when a step had such a jump (the second
//! difference of a row's `b` larger than half its first differences), and the watchdog
//! books that step's change of the balance as an impulse's, as for a lock engaging.
//!
//! The beams' elastic forces and the meshes are not here: their strain energies and the
//! meshes' own work and dissipation are in the state ([`crate::integrators::State`]).
//!
//! Scenes whose only forces are conservative (gravity, springs without damping) and that
//! have no drivers do not need any of this: `W` is zero, and [`WorkWatch::off`] costs
//! nothing per step.
//!
//! The balance of a step-by-step method is exact only as `h → 0`: a force switched on (or
//! ramped from zero) gives the synchronized velocity half a kick, `½ h f/m`, before its
//! work shows in the motion, an error `h² |f|²/(8 m)` that the next steps take back.
//! [`Booked::allowance`] is the largest such term seen, which the watchdog counts into
//! the energy in play so that the first steps of a loading are not judged by it.

use crate::contract::math::qmul;
use crate::contract::persist::{self, StateVisitor};
use crate::contract::system::{ConstraintEval, Layout, Need, Pose, System, Twist, Wrench};
use crate::integrators::State;
use nalgebra::Quaternion;

/// The fraction of the step over which the conservative power is differenced.
const TAU: f64 = 1e-4;

/// The joint kinds whose rows depend on time explicitly (drivers, prescribed velocities).
pub const RHEONOMIC: [&str; 3] = ["drive_angle", "drive_displacement", "point_velocity"];

/// The work of the non-conservative forces and the drivers since the start of a run.
#[derive(Clone, Debug)]
pub struct WorkWatch {
    on: bool,
    drivers: bool,
    /// The multipliers are step means (see the module doc).
    step_means: bool,
    applied: Vec<Wrench>,
    /// Per body: the smallest principal moment of inertia.
    j_min: Vec<f64>,
    shifted: Vec<Pose>,
    ce: ConstraintEval,
    /// Rows with an explicit time dependence (found at the start).
    timed: Vec<usize>,
    /// At the last state: time, force power, per timed row `λ b`.
    t: f64,
    power: f64,
    row_power: Vec<f64>,
    /// Per timed row: `b` at the last state and its change over the last step.
    b_last: Vec<f64>,
    db_last: Vec<f64>,
    /// States seen (the kink test needs three).
    seen: u8,
    first: bool,
    now: Booked,
    saved: Saved,
}

/// The work booked so far and the allowance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Booked {
    /// Work of point forces, torques, dampers and contact damping, J.
    pub forces: f64,
    /// Work of drivers and prescribed velocities, J.
    pub drivers: f64,
    /// The largest `|W_forces|` seen, J.
    pub max_forces: f64,
    /// The largest `|W_drivers|` seen, J.
    pub max_drivers: f64,
    /// The largest half-kick term `h² Σ |f|²/(8 m)` seen, J (see the module doc).
    pub allowance: f64,
}

#[derive(Clone, Debug)]
struct Saved {
    booked: Booked,
    t: f64,
    power: f64,
    row_power: Vec<f64>,
    b_last: Vec<f64>,
    first: bool,
}

impl WorkWatch {
    /// Save or load (for a checkpoint) what the watch carries from step to step: the work
    /// booked, the last state's powers and drivers' rates, and the copy kept for a retry.
    pub fn persist(&mut self, v: &mut dyn StateVisitor) {
        persist::bool(v, "work.on", &mut self.on);
        persist::wrenches(v, "work.applied", &mut self.applied);
        persist::poses(v, "work.shifted", &mut self.shifted);
        persist::constraint_eval(v, &mut self.ce);
        persist::vec_usize(v, "work.timed", &mut self.timed);
        persist::f64(v, "work.t", &mut self.t);
        persist::f64(v, "work.power", &mut self.power);
        persist::vec_f64(v, "work.row_power", &mut self.row_power);
        persist::vec_f64(v, "work.b_last", &mut self.b_last);
        persist::vec_f64(v, "work.db_last", &mut self.db_last);
        let mut seen = u64::from(self.seen);
        persist::u64(v, "work.seen", &mut seen);
        self.seen = seen as u8;
        persist::bool(v, "work.first", &mut self.first);
        for b in [&mut self.now, &mut self.saved.booked] {
            persist::f64_fields(
                v,
                "work.booked",
                [
                    &mut b.forces,
                    &mut b.drivers,
                    &mut b.max_forces,
                    &mut b.max_drivers,
                    &mut b.allowance,
                ],
            );
        }
        persist::f64(v, "work.saved.t", &mut self.saved.t);
        persist::f64(v, "work.saved.power", &mut self.saved.power);
        persist::vec_f64(v, "work.saved.row_power", &mut self.saved.row_power);
        persist::vec_f64(v, "work.saved.b_last", &mut self.saved.b_last);
        persist::bool(v, "work.saved.first", &mut self.saved.first);
    }

    /// A watch that books nothing: for scenes whose forces are all conservative and that
    /// have no drivers.
    pub fn off() -> WorkWatch {
        WorkWatch {
            on: false,
            drivers: false,
            step_means: false,
            applied: Vec::new(),
            j_min: Vec::new(),
            shifted: Vec::new(),
            ce: ConstraintEval::new(0),
            timed: Vec::new(),
            t: 0.0,
            power: 0.0,
            row_power: Vec::new(),
            b_last: Vec::new(),
            db_last: Vec::new(),
            seen: 0,
            first: true,
            now: Booked::default(),
            saved: Saved {
                booked: Booked::default(),
                t: 0.0,
                power: 0.0,
                row_power: Vec::new(),
                b_last: Vec::new(),
                first: true,
            },
        }
    }

    /// A watch starting at `st`, which books the work of the applied forces and of the rows
    /// of joints that depend on time explicitly ([`RHEONOMIC`]); `step_means` says how the
    /// method's multipliers are to be read (see the module doc).
    pub fn new<S: System>(sys: &S, st: &State, h: f64, step_means: bool) -> WorkWatch {
        let l = sys.layout();
        let ce = ConstraintEval::new(l.rows);
        let timed: Vec<usize> = (0..l.rows)
            .filter(|&r| RHEONOMIC.contains(&l.joints[l.row_joint[r]].kind))
            .collect();
        let mut w = WorkWatch {
            on: true,
            drivers: !timed.is_empty(),
            step_means,
            applied: vec![Wrench::default(); l.bodies()],
            j_min: l
                .mass
                .iter()
                .map(|m| m.j.symmetric_eigenvalues().min())
                .collect(),
            shifted: vec![Pose::default(); l.bodies()],
            ce,
            row_power: vec![0.0; timed.len()],
            b_last: vec![0.0; timed.len()],
            db_last: vec![0.0; timed.len()],
            seen: 0,
            timed,
            t: st.t,
            power: 0.0,
            first: true,
            now: Booked::default(),
            saved: Saved {
                booked: Booked::default(),
                t: st.t,
                power: 0.0,
                row_power: Vec::new(),
                b_last: Vec::new(),
                first: true,
            },
        };
        w.power = w.force_power(sys, st, h);
        if w.drivers {
            sys.constraints(st.t, &st.pose, &st.twist, Need::JAC, &mut w.ce);
            for (k, &r) in w.timed.iter().enumerate() {
                w.b_last[k] = if st.active[r] { w.ce.bias[r] } else { 0.0 };
            }
            w.seen = 1;
        }
        w.save();
        w
    }

    /// The work booked so far.
    pub fn booked(&self) -> Booked {
        self.now
    }

    /// Work in so far, J: forces and drivers.
    pub fn total(&self) -> f64 {
        self.now.forces + self.now.drivers
    }

    /// Book the step that ended in `st` (the step is `st.t` less the last state's time).
    /// Returns whether a driver's rate jumped in this step (see the module doc).
    pub fn step<S: System>(&mut self, sys: &S, st: &State) -> bool {
        if !self.on {
            return false;
        }
        let mut kink = false;
        let h = st.t - self.t;
        let p = self.force_power(sys, st, h);
        self.now.forces += 0.5 * h * (self.power + p);
        self.power = p;
        if self.drivers {
            sys.constraints(st.t, &st.pose, &st.twist, Need::JAC, &mut self.ce);
            let mut w = 0.0;
            for (k, &r) in self.timed.iter().enumerate() {
                let (l, b) = if st.active[r] {
                    (st.lambda[r], self.ce.bias[r])
                } else {
                    (0.0, 0.0)
                };
                let b0 = self.b_last[k];
                let db = b - b0;
                if self.seen >= 2
                    && (db - self.db_last[k]).abs()
                        > 0.5 * (db.abs() + self.db_last[k].abs()).max(1e-12 * b.abs())
                {
                    kink = true;
                }
                if self.seen >= 1 {
                    self.db_last[k] = db;
                }
                self.b_last[k] = b;
                if self.step_means {
                    w += h * l * 0.5 * (b0 + b);
                } else {
                    // the first step's start has no multiplier: the end's, with the start's
                    // rate (a driver starting from rest does no work at its start)
                    let p0 = if self.first {
                        l * b0
                    } else {
                        self.row_power[k]
                    };
                    w += 0.5 * h * (p0 + l * b);
                }
                self.row_power[k] = l * b;
            }
            self.now.drivers += w;
        }
        self.seen = self.seen.saturating_add(1);
        self.first = false;
        self.t = st.t;
        self.now.max_forces = self.now.max_forces.max(self.now.forces.abs());
        self.now.max_drivers = self.now.max_drivers.max(self.now.drivers.abs());
        kink
    }

    /// Remember the present (a frame a retry may restart from).
    pub fn save(&mut self) {
        self.saved.booked = self.now;
        self.saved.t = self.t;
        self.saved.power = self.power;
        self.saved.row_power.clone_from(&self.row_power);
        self.saved.b_last.clone_from(&self.b_last);
        self.saved.first = self.first;
    }

    /// Go back to what [`WorkWatch::save`] remembered (a retry from that frame).
    pub fn restore(&mut self) {
        // the largest values seen stay: they describe the run, not the attempt
        let (mf, md, a) = (
            self.now.max_forces,
            self.now.max_drivers,
            self.now.allowance,
        );
        self.now = self.saved.booked;
        self.now.max_forces = mf;
        self.now.max_drivers = md;
        self.now.allowance = a;
        self.t = self.saved.t;
        self.power = self.saved.power;
        self.row_power.clone_from(&self.saved.row_power);
        self.b_last.clone_from(&self.saved.b_last);
        self.first = self.saved.first;
        // the rate history restarts: no kink is judged until two steps have passed
        self.seen = self.seen.min(1);
    }

    /// The non-conservative power of the applied forces at `st`, and the half-kick term of
    /// a step `h` into the allowance.
    fn force_power<S: System>(&mut self, sys: &S, st: &State, h: f64) -> f64 {
        let l = sys.layout();
        sys.applied(st.t, &st.pose, &st.twist, &mut self.applied);
        let mut p = 0.0;
        let mut kick = 0.0;
        for (((w, tw), m), j) in self
            .applied
            .iter()
            .zip(&st.twist)
            .zip(&l.mass)
            .zip(&self.j_min)
        {
            p += w.f.dot(&tw.v) + w.t.dot(&tw.w);
            kick += w.f.norm_squared() / m.m;
            if *j > 0.0 {
                kick += w.t.norm_squared() / j;
            }
        }
        self.now.allowance = self.now.allowance.max(h * h * kick / 8.0);
        // minus the conservative forces' power: −dV/dt along the motion
        let tau = TAU * h.abs().max(1e-12);
        let vp = self.shifted_energy(sys, st, tau);
        let vm = self.shifted_energy(sys, st, -tau);
        p + (vp - vm) / (2.0 * tau)
    }

    /// `V` of `st` moved along its motion for a time `dt`.
    fn shifted_energy<S: System>(&mut self, sys: &S, st: &State, dt: f64) -> f64 {
        for ((o, p), tw) in self.shifted.iter_mut().zip(&st.pose).zip(&st.twist) {
            *o = shifted(p, tw, dt);
        }
        sys.potential_energy(st.t, &self.shifted)
    }
}

/// A pose moved for a time `dt` with a twist: `r + dt v`, `q ⊗ exp(dt ω / 2)` (ω in body
/// components).
fn shifted(p: &Pose, tw: &Twist, dt: f64) -> Pose {
    let a = tw.w * dt;
    let angle = a.norm();
    let dq = if angle > 0.0 {
        let s = (0.5 * angle).sin() / angle;
        Quaternion::new((0.5 * angle).cos(), s * a.x, s * a.y, s * a.z)
    } else {
        Quaternion::identity()
    };
    Pose::new(p.r + tw.v * dt, qmul(&p.q, &dq))
}

/// Whether `layout` can lose energy without a force that [`WorkWatch`] books: beams with
/// stiffness-proportional damping (their element forces are inside the integrator).
pub fn dissipates_inside(layout: &Layout) -> bool {
    layout.beams.beams.iter().any(|b| b.damping > 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::math::axis_angle;
    use nalgebra::Vector3;

    #[test]
    fn a_shift_follows_the_twist() {
        let p = Pose::new(Vector3::new(1.0, 2.0, 3.0), axis_angle(&Vector3::z(), 0.3));
        let tw = Twist {
            v: Vector3::new(0.5, 0.0, -1.0),
            w: Vector3::new(0.0, 0.0, 2.0),
        };
        let s = shifted(&p, &tw, 0.1);
        assert!((s.r - Vector3::new(1.05, 2.0, 2.9)).norm() < 1e-15);
        // about its own z axis, body and world z agree: the angle grows by ω dt
        let want = axis_angle(&Vector3::z(), 0.5);
        assert!((s.q.coords - want.coords).norm() < 1e-15, "{:?}", s.q);
    }
}
