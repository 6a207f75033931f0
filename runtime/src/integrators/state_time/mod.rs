//! The state-time method (notes F; Anderson & Oghbaei): time is a finite-element
//! coordinate. A window of `W` time elements is solved at once: every unknown of the
//! Newton–Euler equations (angle-like integral of ω, direction cosines, mass-centre
//! positions, joint forces) is interpolated in time, the Galerkin residuals of Euler's and
//! Newton's laws, Poisson's equation and the velocity-level joint constraints make one
//! sparse, at most quadratic system, and Newton's method with the analytic Jacobian and a
//! sparse LU solves it ([`window`]).
//!
//! **Two readings of the scene.** A planar scene ([`planar`] says which) is solved with
//! five fields per body ([`window`]: the angle about the plane's normal, two coordinates,
//! a cosine and a sine); any other scene with spherical joints with fifteen ([`spatial`],
//! [`spatial_window`]: three angle-like integrals of the body angular velocity, three
//! coordinates, nine direction cosines). In the plane the two readings' equations coincide
//! (tested). Both take rigid bodies, loads that do not depend on the state, and revolute
//! (planar scenes only) and spherical joints ([`scope`] refuses the rest, naming the body or
//! joint). Quadratic Lagrange functions for the kinematic unknowns, linear ones for the
//! joint forces (the paper's example, k = 2, p = 1). Newton's method and the sparse LU are
//! shared ([`newton`]).
//!
//! **Stepping.** The method serves the fixed output step `h` of the run: an element spans
//! `steps_per_element` steps. When a step needs a time past the current window, the next
//! window of `W` elements is solved from the state at the window's end (positions at the
//! end node, the momentum-consistent end velocities, notes F §1.10); its initial guess is a
//! staggered explicit sweep over the window on the same node grid (4 steps per node
//! spacing). States inside an element come from the interpolants (velocities from their
//! derivatives; at element ends the momentum-consistent velocities; in space the
//! orientation is the rotation nearest to the interpolated cosines); the multipliers are
//! the interpolated joint forces mapped onto the joints' point rows. The last window is
//! solved whole even when the run ends inside it, so that a run's frames do not depend on
//! its duration.
//!
//! **Allocation.** Between window solves a step allocates nothing. A window solve
//! allocates its unknowns, buffers and the sparse LU's symbolic analysis, and faer
//! allocates the matrix values and the numeric factors at every Newton iteration.

pub mod grid;
pub mod newton;
pub mod planar;
pub mod scope;
pub mod shape;
pub mod spatial;
pub mod spatial_window;
pub mod window;

use crate::contract::math::{axis_angle, qmul, quat_from_rotation};
use crate::contract::scene::StaggeredOptions;
use crate::contract::system::{ConstraintEval, Need, Pose, System, Wrench};
use crate::integrators::{staggered, Integrator, StartError, State, StepError, StepInfo};
use nalgebra::Vector3;
use planar::Planar;
use scope::Joint;
use spatial::Spatial;
use spatial_window::SpatialWindow;
use window::Window;

/// Time elements per window unless told otherwise.
pub const DEFAULT_WINDOW: usize = crate::contract::scene::DEFAULT_STATE_TIME_WINDOW as usize;
/// Newton's tolerance on the update, relative to the largest unknown (max norm).
pub const NEWTON_TOLERANCE: f64 = 1e-11;
/// Newton's iteration limit per window.
pub const NEWTON_MAX_ITERATIONS: u32 = 30;
/// The largest estimated memory of a window's sparse LU that a run accepts
/// ([`StateTime::check_window`]): the LU fills in the node blocks of a spatial window (a
/// window of 64 elements of a nine-body star, 19 000 unknowns, took 385 MB, and one of a
/// six-link chain, 12 700 unknowns, 498 MB; 500 elements of an 8-link chain, 132 000
/// unknowns, took 75 s).
pub const MAX_WINDOW_LU_BYTES: usize = 128 << 20;
/// Explicit steps per node spacing of the initial-guess sweep.
const GUESS_SUBSTEPS: usize = 4;

/// The state-time integrator of a rigid scene, planar or spatial.
pub struct StateTime {
    reading: Reading,
    h: f64,
    spe: usize,
    window_elements: usize,
    /// Steps taken since the run's start, and the run's start time.
    steps: u64,
    t_start: f64,
    /// Steps into the current window.
    k: usize,
    win: Option<Win>,
    cur: State,
    ce: ConstraintEval,
    stats: Stats,
    /// The state the current window started from (what a restart solves it again from).
    win_start: State,
    /// Loaded from a checkpoint: the current window must be solved again from
    /// `win_start` before the next step.
    resolve: bool,
    /// Newton's statistics of the last window solved.
    last: newton::NewtonStats,
}

/// How the method reads the scene.
enum Reading {
    /// A planar scene ([`planar`]): five fields per body. `base`: the bodies' poses at the
    /// window's start (the cosines are of the rotation since then); `offplane`: their
    /// constant coordinates along the normal.
    Planar {
        model: Planar,
        base: Vec<Pose>,
        offplane: Vec<f64>,
    },
    /// A spatial scene ([`spatial`]): fifteen fields per body, absolute direction cosines.
    Spatial { model: Spatial },
}

/// The current window of either reading.
enum Win {
    Planar(Window),
    Spatial(SpatialWindow),
}

impl Win {
    fn elements(&self) -> usize {
        match self {
            Win::Planar(w) => w.grid.elements,
            Win::Spatial(w) => w.grid.elements,
        }
    }
    fn t0(&self) -> f64 {
        match self {
            Win::Planar(w) => w.grid.t0,
            Win::Spatial(w) => w.grid.t0,
        }
    }
    fn unknowns(&self) -> usize {
        match self {
            Win::Planar(w) => w.unknowns(),
            Win::Spatial(w) => w.u.len(),
        }
    }
    fn newton(&mut self) -> Result<newton::NewtonStats, newton::Failure> {
        match self {
            Win::Planar(w) => w.newton(NEWTON_TOLERANCE, NEWTON_MAX_ITERATIONS),
            Win::Spatial(w) => w.newton(NEWTON_TOLERANCE, NEWTON_MAX_ITERATIONS),
        }
    }
    /// The largest entry of `CᵀC − I` at the window's nodes (`|c² + s² − 1|` in the plane).
    fn orthogonality_drift(&self) -> f64 {
        match self {
            Win::Planar(w) => {
                let mut worst = 0.0f64;
                for e in 0..w.grid.elements {
                    for tau in [0.5, 1.0] {
                        for b in 0..w.bodies() {
                            let (v, _) = w.body_at(e, tau, b);
                            worst = worst.max((v[3] * v[3] + v[4] * v[4] - 1.0).abs());
                        }
                    }
                }
                worst
            }
            Win::Spatial(w) => w.orthogonality_drift(),
        }
    }
}

/// Above this drift of the direction cosines from orthonormal (the largest entry of
/// `CᵀC − I` at any node, `|c² + s² − 1|` in the plane), a `state_time` run that finishes
/// warns that its rotations are not resolved.
pub const COSINE_DRIFT_WARNING: f64 = 5e-2;

#[derive(Clone, Copy, Debug, Default)]
struct Stats {
    windows: u32,
    iterations: u32,
    max_iterations: u32,
    equations: usize,
    cosine_drift: f64,
    position_residual: f64,
}

impl StateTime {
    /// The method with output step `h`, `steps_per_element` steps per time element and
    /// windows of `window_elements` elements, from `start`: the planar reading when the
    /// scene is planar ([`planar::read`]), the spatial one otherwise ([`spatial::read`]).
    ///
    /// # Errors
    /// A scene the method does not support, a zero element or window size.
    pub fn new<S: System>(
        sys: &S,
        h: f64,
        steps_per_element: u32,
        window_elements: usize,
        start: &State,
    ) -> Result<StateTime, StartError> {
        let reading = match planar::read(sys, start) {
            Ok(model) => Reading::Planar {
                base: start.pose.clone(),
                offplane: start.pose.iter().map(|p| p.r.dot(&model.plane.n)).collect(),
                model,
            },
            Err(why) => Reading::Spatial {
                model: spatial::read(sys, Err(&why)).map_err(StartError::Invalid)?,
            },
        };
        Self::with_reading(sys, h, steps_per_element, window_elements, start, reading)
    }

    /// As [`StateTime::new`] but with the spatial reading even for a planar scene (the two
    /// readings' discrete equations coincide in the plane: a check of both).
    ///
    /// # Errors
    /// As [`StateTime::new`].
    pub fn spatial<S: System>(
        sys: &S,
        h: f64,
        steps_per_element: u32,
        window_elements: usize,
        start: &State,
    ) -> Result<StateTime, StartError> {
        let not_planar = planar::read(sys, start).err();
        let verdict = not_planar.as_deref().map_or(Ok(()), Err);
        let model = spatial::read(sys, verdict).map_err(StartError::Invalid)?;
        let reading = Reading::Spatial { model };
        Self::with_reading(sys, h, steps_per_element, window_elements, start, reading)
    }

    fn with_reading<S: System>(
        sys: &S,
        h: f64,
        steps_per_element: u32,
        window_elements: usize,
        start: &State,
        reading: Reading,
    ) -> Result<StateTime, StartError> {
        if steps_per_element == 0 || window_elements == 0 {
            return Err(StartError::Invalid(
                "state_time: steps_per_element and the window's element count must be at least 1"
                    .into(),
            ));
        }
        let rows = sys.layout().rows;
        let mut cur = start.clone();
        cur.lambda.resize(rows, 0.0);
        cur.active = vec![true; rows];
        Ok(StateTime {
            reading,
            h,
            spe: steps_per_element as usize,
            window_elements,
            steps: 0,
            t_start: start.t,
            k: 0,
            win: None,
            win_start: cur.clone(),
            cur,
            ce: ConstraintEval::new(rows),
            stats: Stats::default(),
            resolve: false,
            last: newton::NewtonStats::default(),
        })
    }

    /// Newton's statistics of the last window solved (iterations, residual, and the wall
    /// time in assembly and in the sparse LU: what limits the parallel speed-up).
    pub fn last_window(&self) -> newton::NewtonStats {
        self.last
    }

    /// Whether a window's sparse LU fits in memory, as a run requires: its estimated size,
    /// `200 · unknowns · unknowns per element` bytes (faer's fill-reducing ordering does not
    /// keep the window's band: the six-link chain's 498 MB is this estimate), must stay
    /// below [`MAX_WINDOW_LU_BYTES`]. The
    /// error names the `window` that fits. (Studies that call [`StateTime::new`] directly
    /// may solve larger windows.)
    ///
    /// # Errors
    /// The window's size, its estimate, and the window that fits.
    pub fn check_window(&self) -> Result<(), String> {
        let per_element = match &self.reading {
            Reading::Planar { model, .. } => 10 * model.bodies.len() + 2 * model.joints.len(),
            Reading::Spatial { model } => 30 * model.bodies.len() + 3 * model.joints.len(),
        };
        let w = self.window_elements;
        let bytes = |w: usize| {
            200usize
                .saturating_mul(w * per_element)
                .saturating_mul(per_element)
        };
        if bytes(w) <= MAX_WINDOW_LU_BYTES {
            return Ok(());
        }
        let fits = MAX_WINDOW_LU_BYTES / bytes(1);
        let unknowns = w * per_element;
        let mb = bytes(w) >> 20;
        Err(if fits == 0 {
            format!(
                "state_time: one time element of this scene has {per_element} unknowns; the sparse LU of even a one-element window would take about {} MB, more than the limit of {} MB: use another method",
                bytes(1) >> 20,
                MAX_WINDOW_LU_BYTES >> 20
            )
        } else {
            format!(
                "state_time: a window of {w} time elements of this scene has {unknowns} unknowns ({per_element} per element); its sparse LU would take about {mb} MB, more than the limit of {} MB: set `window {fits}` or less in the method's options",
                MAX_WINDOW_LU_BYTES >> 20
            )
        })
    }

    /// Whether the scene is read as planar (five fields per body) rather than spatial.
    pub fn is_planar(&self) -> bool {
        matches!(self.reading, Reading::Planar { .. })
    }

    fn joints(&self) -> &[Joint] {
        match &self.reading {
            Reading::Planar { model, .. } => &model.joints,
            Reading::Spatial { model, .. } => &model.joints,
        }
    }

    /// The planar window of `elements` elements from the current state (the loads sampled
    /// once).
    fn planar_window<S: System>(&mut self, sys: &S, elements: usize) -> Result<Window, StepError> {
        let Reading::Planar {
            model,
            base,
            offplane,
        } = &mut self.reading
        else {
            unreachable!("a planar window of a spatial reading")
        };
        let plane = model.plane;
        let nb = model.bodies.len();
        let s = &self.cur;
        let start: Vec<window::BodyStart> = (0..nb)
            .map(|b| window::BodyStart {
                x: plane.xy(&s.pose[b].r),
                v: plane.xy(&s.twist[b].v),
                w: (s.pose[b].c * s.twist[b].w).dot(&plane.n),
            })
            .collect();
        let offsets: Vec<[[f64; 2]; 2]> = model
            .joints
            .iter()
            .map(|j| {
                let off = |side: Option<usize>, p: &Vector3<f64>| match side {
                    Some(b) => plane.xy(&(s.pose[b].c * p)),
                    None => plane.xy(p),
                };
                [off(j.a, &j.pa), off(j.b, &j.pb)]
            })
            .collect();
        base.clone_from(&s.pose);
        for (d, p) in offplane.iter_mut().zip(&s.pose) {
            *d = p.r.dot(&plane.n);
        }
        let he = self.h * self.spe as f64;
        let mut wrench = vec![Wrench::default(); nb];
        let mut off_plane: Option<(usize, f64)> = None;
        let (pose, twist) = (&s.pose, &s.twist);
        let win = Window::new(model, elements, he, s.t, start, &offsets, |t, out| {
            sys.applied(t, pose, twist, &mut wrench);
            for (b, (o, w)) in out.iter_mut().zip(&wrench).enumerate() {
                if planar::off_plane(&plane, &pose[b], w).is_some() {
                    off_plane.get_or_insert((b, t));
                }
                let tw = pose[b].c * w.t;
                *o = [w.f.dot(&plane.e1), w.f.dot(&plane.e2), tw.dot(&plane.n)];
            }
        });
        if let Some((b, t)) = off_plane {
            return Err(StepError::Linalg {
                what: "state_time",
                message: format!(
                    "body '{}': an applied load leaves the plane of motion at t = {t:.6} s (a force along the normal or a torque about an in-plane axis), though it was in the plane at the start, where state_time chose its planar reading: keep the loads in the plane",
                    model.bodies[b].name
                ),
            });
        }
        Ok(win)
    }

    /// The spatial window of `elements` elements from the current state.
    fn spatial_window<S: System>(
        &self,
        sys: &S,
        model: &Spatial,
        elements: usize,
    ) -> SpatialWindow {
        let s = &self.cur;
        let start = (0..model.bodies.len())
            .map(|b| spatial_window::BodyStart {
                x: s.pose[b].r,
                v: s.twist[b].v,
                c: s.pose[b].c,
                w: s.twist[b].w,
            })
            .collect();
        let he = self.h * self.spe as f64;
        let mut wrench = vec![Wrench::default(); model.bodies.len()];
        let (pose, twist) = (&s.pose, &s.twist);
        SpatialWindow::new(model, elements, he, s.t, start, |t, out| {
            sys.applied(t, pose, twist, &mut wrench);
            for ((o, w), p) in out.iter_mut().zip(&wrench).zip(pose) {
                *o = spatial_window::Load {
                    f: w.f,
                    t: p.c * w.t,
                };
            }
        })
    }

    /// Solve the next window of `W` elements from the current state. Returns Newton's
    /// iterations. (The last window is solved whole even when the run ends inside it: a
    /// window's equations couple each element to the next, so cutting it at the run's end
    /// would make a run's early frames depend on its duration, and a run continued from a
    /// checkpoint to a later end differ from the run made straight through.)
    fn next_window<S: System>(&mut self, sys: &S) -> Result<u32, StepError> {
        self.win_start.clone_from(&self.cur);
        let elements = self.window_elements;
        let mut win = match &self.reading {
            Reading::Planar { .. } => Win::Planar(self.planar_window(sys, elements)?),
            Reading::Spatial { model } => Win::Spatial(self.spatial_window(sys, model, elements)),
        };
        self.guess(sys, &mut win)?;
        let t0 = win.t0();
        let t1 = t0 + win.elements() as f64 * self.h * self.spe as f64;
        let stats = win.newton().map_err(|f| {
            let singular = f.linear.is_some();
            StepError::Window {
                message: match &f.linear {
                    Some(why) => format!(
                        "state_time: the window [{t0:.6}, {t1:.6}] s cannot be solved: {why}"
                    ),
                    None => format!(
                        "state_time: Newton's method on the window [{t0:.6}, {t1:.6}] s did not converge in {} iterations: largest residual {:.3e} in {}",
                        f.iterations, f.residual, f.place
                    ),
                },
                place: f.place,
                residual: f.residual,
                singular,
            }
        })?;
        self.stats.cosine_drift = self.stats.cosine_drift.max(win.orthogonality_drift());
        self.last = stats;
        self.stats.windows += 1;
        self.stats.iterations += stats.iterations;
        self.stats.max_iterations = self.stats.max_iterations.max(stats.iterations);
        self.stats.equations = win.unknowns();
        self.win = Some(win);
        self.k = 0;
        Ok(stats.iterations)
    }

    /// The initial guess of `win`: a staggered sweep from the current state on the window's
    /// node grid.
    fn guess<S: System>(&self, sys: &S, win: &mut Win) -> Result<(), StepError> {
        let nb = sys.layout().bodies();
        let nodes = 2 * win.elements();
        let hs = self.h * self.spe as f64 / (2 * GUESS_SUBSTEPS) as f64;
        let mut sweep =
            staggered::TwoStage::staggered(sys, hs, &StaggeredOptions::default(), &self.cur)
                .map_err(|e| StepError::Linalg {
                    what: "state_time initial guess",
                    message: e.to_string(),
                })?;
        let mut st = self.cur.clone();
        let mut ce = ConstraintEval::new(sys.layout().rows);
        // the angle-like unknowns: the planar rotation angle since the window's start
        // (unwrapped), or the integral of the body angular velocity (trapezoid rule)
        let mut angle = vec![Vector3::zeros(); nb];
        let mut w_prev: Vec<Vector3<f64>> = st.twist.iter().map(|t| t.w).collect();
        let forces = |st: &State, ce: &mut ConstraintEval, win: &mut Win, n: usize| {
            sys.constraints(st.t, &st.pose, &st.twist, Need::JAC, ce);
            for (k, j) in self.joints().iter().enumerate() {
                let f = joint_force(j, ce, &st.lambda);
                match (&mut *win, &self.reading) {
                    (Win::Planar(w), Reading::Planar { model, .. }) => {
                        w.set_force(n, k, model.plane.xy(&f));
                    }
                    (Win::Spatial(w), _) => w.set_force(n, k, &f),
                    _ => unreachable!("a window of the other reading"),
                }
            }
        };
        forces(&st, &mut ce, win, 0);
        for j in 1..=nodes {
            for _ in 0..GUESS_SUBSTEPS {
                Integrator::<S>::step(&mut sweep, sys)?;
                if let Win::Spatial(_) = win {
                    Integrator::<S>::state(&sweep, sys, &mut st);
                    for (b, w) in w_prev.iter_mut().enumerate() {
                        angle[b] += 0.5 * hs * (*w + st.twist[b].w);
                        *w = st.twist[b].w;
                    }
                }
            }
            Integrator::<S>::state(&sweep, sys, &mut st);
            for b in 0..nb {
                match (&mut *win, &self.reading) {
                    (Win::Planar(w), Reading::Planar { model, base, .. }) => {
                        let plane = model.plane;
                        let r = st.pose[b].c * base[b].c.transpose();
                        let a =
                            (plane.e2.dot(&(r * plane.e1))).atan2(plane.e1.dot(&(r * plane.e1)));
                        let d = a - angle[b].x;
                        let d = d - std::f64::consts::TAU * (d / std::f64::consts::TAU).round();
                        angle[b].x += d;
                        let (th, x) = (angle[b].x, plane.xy(&st.pose[b].r));
                        w.set_kin(j, b, [th, x[0], x[1], th.cos(), th.sin()]);
                    }
                    (Win::Spatial(w), _) => {
                        w.set_kin(j, b, &angle[b], &st.pose[b].r, &st.pose[b].c);
                    }
                    _ => unreachable!("a window of the other reading"),
                }
            }
            if j % 2 == 0 {
                forces(&st, &mut ce, win, j / 2);
            }
        }
        Ok(())
    }

    /// Fill `self.cur` with the state `k` steps into the current window.
    fn fill_state<S: System>(&mut self, sys: &S) {
        let Some(win) = &self.win else { return };
        let (e, i) = (self.k / self.spe, self.k % self.spe);
        let (e, tau) = if e >= win.elements() {
            (win.elements() - 1, 1.0)
        } else {
            (e, i as f64 / self.spe as f64)
        };
        // velocities: at element ends the momentum-consistent ones, inside from the
        // interpolants' derivatives
        let end = if tau == 1.0 {
            Some(e)
        } else if i == 0 && e > 0 {
            Some(e - 1)
        } else {
            None
        };
        match (win, &self.reading) {
            (
                Win::Planar(win),
                Reading::Planar {
                    model,
                    base,
                    offplane,
                },
            ) => {
                let plane = model.plane;
                for b in 0..model.bodies.len() {
                    let (v, dv) = win.body_at(e, tau, b);
                    let vel = match end {
                        Some(e) => win.end_velocity(e, b),
                        None => [dv[0], dv[1], dv[2]],
                    };
                    let q = qmul(&axis_angle(&plane.n, v[0]), &base[b].q);
                    let r = plane.e1 * v[1] + plane.e2 * v[2] + plane.n * offplane[b];
                    let pose = Pose::new(r, q);
                    self.cur.twist[b].v = plane.e1 * vel[1] + plane.e2 * vel[2];
                    self.cur.twist[b].w = pose.c.transpose() * (plane.n * vel[0]);
                    self.cur.pose[b] = pose;
                }
            }
            (Win::Spatial(win), Reading::Spatial { model }) => {
                for b in 0..model.bodies.len() {
                    let (x, c, xd, w) = win.body_at(e, tau, b);
                    let (w, xd) = match end {
                        Some(e) => win.end_velocity(e, b),
                        None => (w, xd),
                    };
                    // the rotation nearest to the (not quite orthonormal) cosines, on the
                    // side of the previous quaternion
                    let mut q = quat_from_rotation(&nearest_rotation(&c));
                    let prev = self.cur.pose[b].q;
                    if q.coords.dot(&prev.coords) < 0.0 {
                        q = -q;
                    }
                    self.cur.pose[b] = Pose::new(x, q);
                    self.cur.twist[b].v = xd;
                    self.cur.twist[b].w = w;
                }
            }
            _ => unreachable!("a window of the other reading"),
        }
        self.cur.t = self.t_start + self.steps as f64 * self.h;
        let s = &self.cur;
        sys.constraints(
            s.t,
            &s.pose,
            &s.twist,
            Need {
                phi: true,
                jac: true,
                gamma: false,
            },
            &mut self.ce,
        );
        let worst = self.ce.phi.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        self.stats.position_residual = self.stats.position_residual.max(worst);
        let Some(win) = &self.win else { return };
        let joints = match &self.reading {
            Reading::Planar { model, .. } => &model.joints,
            Reading::Spatial { model, .. } => &model.joints,
        };
        for (k, j) in joints.iter().enumerate() {
            let f = match (win, &self.reading) {
                (Win::Planar(w), Reading::Planar { model, .. }) => {
                    let f2 = w.force_at(e, tau, k);
                    model.plane.e1 * f2[0] + model.plane.e2 * f2[1]
                }
                (Win::Spatial(w), _) => w.force_at(e, tau, k),
                _ => unreachable!("a window of the other reading"),
            };
            set_multipliers(j, &self.ce, &f, &mut self.cur.lambda);
        }
    }
}

/// The rotation matrix nearest to `c` (Frobenius norm): the orthogonal factor of its polar
/// decomposition, by Newton's iteration `R ← (R + R⁻ᵀ)/2` (quadratic convergence; `c` is
/// within the cosines' drift of a rotation). `c` itself if it is singular.
fn nearest_rotation(c: &nalgebra::Matrix3<f64>) -> nalgebra::Matrix3<f64> {
    let mut r = *c;
    for _ in 0..8 {
        let Some(inv) = r.try_inverse() else {
            return *c;
        };
        let next = 0.5 * (r + inv.transpose());
        let change = (next - r).amax();
        r = next;
        if change < 1e-15 {
            break;
        }
    }
    r
}

/// Joint `j`'s force on side b (world) from its rows' multipliers (`M u̇ + Bᵀλ = F`).
fn joint_force(j: &scope::Joint, ce: &ConstraintEval, lambda: &[f64]) -> Vector3<f64> {
    let mut f = Vector3::zeros();
    for r in j.first_row..j.first_row + j.rows {
        let (blk, sign) = if j.b.is_some() {
            (&ce.jac[r].b, -1.0)
        } else {
            (&ce.jac[r].a, 1.0)
        };
        f += sign * Vector3::new(blk[0], blk[1], blk[2]) * lambda[r];
    }
    f
}

/// The multipliers of joint `j`'s rows that give the force `f` on side b: the
/// least-norm solution over the rows' translational Jacobian blocks.
fn set_multipliers(j: &scope::Joint, ce: &ConstraintEval, f: &Vector3<f64>, lambda: &mut [f64]) {
    let rows = j.first_row..j.first_row + j.rows;
    let (target, side_b) = if j.b.is_some() {
        (-f, true)
    } else {
        (*f, false)
    };
    let col = |r: usize| {
        let blk = if side_b { &ce.jac[r].b } else { &ce.jac[r].a };
        Vector3::new(blk[0], blk[1], blk[2])
    };
    let mut g = nalgebra::Matrix3::zeros();
    for r in rows.clone() {
        let c = col(r);
        g += c * c.transpose();
    }
    let y = g.try_inverse().map_or(Vector3::zeros(), |gi| gi * target);
    for r in rows {
        lambda[r] = col(r).dot(&y);
    }
}

impl<S: System> Integrator<S> for StateTime {
    fn name(&self) -> &'static str {
        "state_time"
    }
    fn time(&self) -> f64 {
        self.cur.t
    }
    fn step_size(&self) -> f64 {
        self.h
    }
    fn step(&mut self, sys: &S) -> Result<StepInfo, StepError> {
        let mut iterations = 0;
        if self.resolve {
            // a restart: the window the checkpoint was taken in, solved again from the same
            // start (the same bits), then the checkpoint's place in it
            self.resolve = false;
            let (k, stats, cur) = (self.k, self.stats, self.cur.clone());
            self.cur.clone_from(&self.win_start);
            self.next_window(sys)?;
            (self.k, self.stats, self.cur) = (k, stats, cur);
        }
        let past = |w: &Win| self.k >= w.elements() * self.spe;
        if self.win.as_ref().is_none_or(past) {
            iterations = self.next_window(sys)?;
        }
        self.k += 1;
        self.steps += 1;
        self.fill_state(sys);
        Ok(StepInfo { iterations })
    }
    fn state(&self, _sys: &S, out: &mut State) {
        out.t = self.cur.t;
        out.pose.clone_from(&self.cur.pose);
        out.twist.clone_from(&self.cur.twist);
        out.lambda.clone_from(&self.cur.lambda);
        out.active.clone_from(&self.cur.active);
        out.beams.clear();
    }
    fn active(&self) -> &[bool] {
        &self.cur.active
    }
    /// The direction cosines are unknowns of their own (notes F §2.1): how far `c² + s²`
    /// strays from 1 at the nodes measures how well the elements resolve the rotation, and
    /// a run whose moment arms are off by more than [`COSINE_DRIFT_WARNING`] says so.
    fn end_notice(&self) -> Option<String> {
        let d = self.stats.cosine_drift;
        (d > COSINE_DRIFT_WARNING).then(|| {
            format!(
                "state_time: the direction cosines drifted from orthonormal by {d:.1e} (c² + s² − 1, largest over the nodes); the time elements do not resolve the rotation to better than that, and the joint forces act on moment arms off by up to half of it: use shorter elements (a smaller step or fewer steps_per_element)"
            )
        })
    }
    /// The run's place (steps, the step in the window, the start time), the state now and
    /// the state the window started from, and the statistics. The window's solution is not
    /// saved: a restart solves the window again from its start, which gives the same bits.
    fn persist(&mut self, v: &mut dyn crate::contract::persist::StateVisitor) -> bool {
        use crate::contract::persist;
        persist::u64(v, "state_time.steps", &mut self.steps);
        persist::usize(v, "state_time.k", &mut self.k);
        persist::f64(v, "state_time.t_start", &mut self.t_start);
        let mut has_window = self.win.is_some() || self.resolve;
        persist::bool(v, "state_time.window", &mut has_window);
        for (name, st) in [
            ("state_time.cur", &mut self.cur),
            ("state_time.win_start", &mut self.win_start),
        ] {
            persist::f64(v, name, &mut st.t);
            persist::poses(v, name, &mut st.pose);
            persist::twists(v, name, &mut st.twist);
            v.f64s(name, &mut st.lambda);
            v.bools(name, &mut st.active);
        }
        let s = &mut self.stats;
        let mut counts = [
            u64::from(s.windows),
            u64::from(s.iterations),
            u64::from(s.max_iterations),
            s.equations as u64,
        ];
        v.u64s("state_time.counts", &mut counts);
        s.windows = counts[0] as u32;
        s.iterations = counts[1] as u32;
        s.max_iterations = counts[2] as u32;
        s.equations = counts[3] as usize;
        persist::f64(v, "state_time.cosine_drift", &mut s.cosine_drift);
        persist::f64(v, "state_time.position_residual", &mut s.position_residual);
        // loading: the window is solved again at the next step (saving: unchanged)
        self.resolve = has_window && self.win.is_none();
        if self.resolve {
            if let Reading::Planar { base, .. } = &mut self.reading {
                base.clone_from(&self.win_start.pose);
            }
        }
        true
    }
    fn stats(&self) -> Vec<(&'static str, f64)> {
        let s = &self.stats;
        vec![
            ("windows", f64::from(s.windows)),
            ("equations_per_window", s.equations as f64),
            (
                "newton_iterations_mean",
                f64::from(s.iterations) / f64::from(s.windows.max(1)),
            ),
            ("newton_iterations_max", f64::from(s.max_iterations)),
            ("max_cosine_drift", s.cosine_drift),
            ("max_position_residual", s.position_residual),
        ]
    }
}

#[cfg(test)]
mod spatial_tests;
#[cfg(test)]
mod tests;
