//! An estimate of the fastest motion in a scene, before it runs: the explicit stability limit
//! `h·ω_max ≤ 2` and the accuracy rule of at least 20 steps per period of the fastest response
//! (notes A §1.10).
//!
//! Sources, each with the element it comes from so a report can name it:
//! - spin: a body's initial angular rate |ω| (the paper's "highest angular velocity of the
//!   rigid components");
//! - driven speed: a `drive_angle` driver's largest rate |θ̇| over the run (sampled at up to
//!   10⁴ times over `simulate.duration`, the rate being known in advance): the speed Ω a
//!   driver will reach. Ω is the frequency scale of the gyroscopic and centrifugal terms of the
//!   body it turns and of the rotation update, so it counts as a motion like the initial spin
//!   (a rotor spun up to h·Ω = 2 gets three steps per turn: `staggered` reports its kinetic
//!   energy 19 % high there, `models/hard/rotor_spin_up.mbd`);
//! - translational springs: `ω = √(k/m_eff)` along the spring's line, where
//!   `1/m_eff = Σ_sides (1/m + (ρ × n)·J⁻¹(ρ × n))` includes the lever arm ρ of each attachment
//!   (a body on a constraint can only be stiffer than its free mass suggests through other
//!   springs, which are listed separately);
//! - rotational springs: `ω = √(k (a·J_a⁻¹a + a·J_b⁻¹a))` about the joint axis a;
//! - gravity on a hinged body: `ω = √(|g|/d)`, d the distance from the point of a pivot joint
//!   (spherical, revolute, universal, cylindrical) to the body's mass centre — the
//!   simple-pendulum rate, an upper bound for the physical pendulum (`m g d / J_pivot` with
//!   `J_pivot ≥ m d²`). Without it a pendulum at rest would have no estimate at all. Joints
//!   that are not pivots (rolling, curve, prismatic, …) do not swing the body about their
//!   point: a rolling ball's attachment is its centre, and √(|g|/d) of its mass-centre
//!   offset would be a rate the ball does not have;
//! - penalty contact: `ω = √(k/m)` of the lighter body;
//! - flexible beams: the highest frequency of the beam's shortest element with its lumped
//!   mass ([`beam_element_frequency`], an upper bound on the beam's), lowered by
//!   stiffness-proportional damping to the equivalent `2/h_max`;
//! - damping (springs' and contact's): the rate `c/m_eff`, whose explicit limit (lagged
//!   evaluation, notes A §1.9) is `c h / m_eff < 2`, so it is reported as an equivalent ω.
//!
//! It is an estimate: constraints can raise the frequencies of springs attached through them
//! (a short lever) and motion can raise spin rates; the watchdog catches what it misses.
//! [`estimate_system`] adds the fastest mode of the constrained system linearized at t = 0
//! ([`super::constrained_modes`]), which sees the short lever and the light link under load.
//!
//! ## Each method's limit
//!
//! Every method but `implicit_trapezoid` advances the coordinates by the explicit central
//! difference (leapfrog, velocity Verlet): `staggered`, `baumgarte` and `penalty` share the
//! CINT update (notes A §1.8–1.9), `natural_partitioning` uses it on the tree's coordinates
//! (notes C §3.5), and `coordinate_partitioning` uses velocity Verlet on its independent
//! coordinates (notes A §1.3). On the linear test equation `ẍ = −ω²x` the leapfrog's
//! amplification matrix has eigenvalues on the unit circle exactly when `(hω)² ≤ 4`
//! (Hairer, Lubich and Wanner, *Geometric Numerical Integration*, §I.5; Belytschko and
//! Hughes, *Computational Methods for Transient Analysis*, ch. 2): the limit is `h·ω ≤ 2`
//! for all five. `implicit_trapezoid` is A-stable (the trapezoidal rule): no limit, only the
//! accuracy rule.

use nalgebra::{Matrix3, Vector3};

use crate::contract::system::System;

use crate::contract::math::{quat, rotation, vec3};
use crate::contract::scene::{Attachment, BodyRef, ForceKind, JointKind, Scene};

/// One source of fast motion.
#[derive(Clone, Debug, PartialEq)]
pub struct Source {
    /// Angular frequency (or rate), rad/s.
    pub omega: f64,
    /// What it is, naming the element: `spring 'k'`, `spin of body 'rotor'`.
    pub what: String,
    /// Whether it is a mode of a beam's discretization (its highest element mode): it limits
    /// the explicit step, but is no motion of the scene to resolve with 20 steps per period.
    pub discretization: bool,
}

/// The estimate for a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// All sources, fastest first.
    pub sources: Vec<Source>,
}

impl Estimate {
    /// The fastest source, if any.
    pub fn fastest(&self) -> Option<&Source> {
        self.sources.first()
    }

    /// Largest step of an explicit method: `2/ω_max` (infinite without sources).
    pub fn stable_step(&self) -> f64 {
        self.fastest().map_or(f64::INFINITY, |s| 2.0 / s.omega)
    }

    /// The estimate for a run whose beams take `n` substeps per step (`beam_substeps`):
    /// a beam's element mode limits the substep, so as a limit on the step it is `n` times
    /// slower.
    pub fn with_beam_substeps(mut self, n: u32) -> Estimate {
        if n > 1 {
            for s in self.sources.iter_mut().filter(|s| s.discretization) {
                s.omega /= n as f64;
                s.what = format!("{}, in {n} substeps per step", s.what);
            }
            self.sources.sort_by(|a, b| b.omega.total_cmp(&a.omega));
        }
        self
    }

    /// The fastest source that is a motion of the scene (not a beam's discretization mode).
    pub fn fastest_motion(&self) -> Option<&Source> {
        self.sources.iter().find(|s| !s.discretization)
    }

    /// Largest step with 20 steps per period of the fastest motion: `2π/(20 ω_max)` (beams'
    /// element modes excluded: they limit stability only).
    pub fn accurate_step(&self) -> f64 {
        self.fastest_motion()
            .map_or(f64::INFINITY, |s| std::f64::consts::TAU / (20.0 * s.omega))
    }
}

/// Whether a method integrates the coordinates explicitly with the run's step (and so has a
/// stability limit on it). `dopri5` and `dop853` are explicit but choose their own internal steps under
/// its error control, as short as the fastest motion needs, between output steps: the
/// run's step is only its output interval.
pub fn is_explicit(method: &crate::contract::scene::MethodSpec) -> bool {
    !matches!(
        method,
        crate::contract::scene::MethodSpec::ImplicitTrapezoid { .. }
            | crate::contract::scene::MethodSpec::StateTime { .. }
            | crate::contract::scene::MethodSpec::DormandPrince { .. }
            | crate::contract::scene::MethodSpec::DormandPrince853 { .. }
    )
}

/// The beams' substeps per step of a method (`beam_substeps` of `staggered`; 1 otherwise).
pub fn beam_substeps(method: &crate::contract::scene::MethodSpec) -> u32 {
    match method {
        crate::contract::scene::MethodSpec::Staggered(o) => o.beam_substeps.max(1),
        _ => 1,
    }
}

/// Whether a joint holds a body at a point it can swing about (the gravity source).
fn is_pivot(kind: &JointKind) -> bool {
    matches!(
        kind,
        JointKind::Spherical | JointKind::Revolute | JointKind::Universal | JointKind::Cylindrical
    )
}

struct BodyData {
    m: f64,
    j_inv: Matrix3<f64>,
    c: Matrix3<f64>,
}

/// Estimate the fastest motions of `scene` at its initial state.
pub fn estimate(scene: &Scene) -> Estimate {
    let bodies: Vec<Option<BodyData>> = scene
        .bodies
        .iter()
        .map(|b| {
            let j = Matrix3::from_row_slice(&b.inertia.concat());
            j.try_inverse().map(|j_inv| BodyData {
                m: b.mass,
                j_inv,
                c: rotation(&quat(b.orientation)),
            })
        })
        .collect();
    let mut sources = Vec::new();
    for b in &scene.bodies {
        let w = vec3(&b.angular_velocity).norm();
        if w > 0.0 {
            sources.push(Source {
                omega: w,
                what: format!("spin of body '{}'", b.name),
                discretization: false,
            });
        }
    }
    for j in &scene.joints {
        if let JointKind::DriveAngle { angle, .. } = &j.kind {
            if let Some((w, t)) = driven_speed(angle, scene.simulate.duration) {
                sources.push(Source {
                    omega: w,
                    what: format!(
                        "speed of driver '{}' (|θ̇| = {w:.4e} rad/s at t = {t:.4} s)",
                        j.name
                    ),
                    discretization: false,
                });
            }
        }
    }
    if let Some(g) = scene.gravity.map(|g| vec3(&g).norm()).filter(|g| *g > 0.0) {
        for j in scene.joints.iter().filter(|j| is_pivot(&j.kind)) {
            for at in [&j.a, &j.b] {
                let (Some(i), d) = (at.body.index(), vec3(&at.point).norm()) else {
                    continue;
                };
                if d > 1e-9 {
                    sources.push(Source {
                        omega: (g / d).sqrt(),
                        what: format!(
                            "swing of body '{}' under gravity, hinged {d:.3} m from its mass centre (joint '{}')",
                            scene.bodies[i].name, j.name
                        ),
                        discretization: false,
                    });
                }
            }
        }
    }
    // 1/m_eff of an attachment along world direction n (0 for ground)
    let inv_mass_along = |a: &Attachment, n: &Vector3<f64>| -> f64 {
        match a.body {
            BodyRef::Ground => 0.0,
            BodyRef::Body(i) => match bodies.get(i).and_then(|b| b.as_ref()) {
                Some(b) => {
                    let nb = b.c.transpose() * n;
                    let rn = vec3(&a.point).cross(&nb);
                    1.0 / b.m + rn.dot(&(b.j_inv * rn))
                }
                None => 0.0,
            },
        }
    };
    let world_point = |a: &Attachment| -> Vector3<f64> {
        match a.body {
            BodyRef::Ground => vec3(&a.point),
            BodyRef::Body(i) => {
                let b = &scene.bodies[i];
                vec3(&b.position) + rotation(&quat(b.orientation)) * vec3(&a.point)
            }
        }
    };
    for f in &scene.forces {
        match &f.kind {
            ForceKind::Spring {
                a,
                b,
                stiffness,
                damping,
                ..
            } => {
                let d = world_point(b) - world_point(a);
                let n = if d.norm() > 1e-12 {
                    d / d.norm()
                } else {
                    Vector3::x()
                };
                let w = inv_mass_along(a, &n) + inv_mass_along(b, &n);
                if *stiffness > 0.0 && w > 0.0 {
                    sources.push(Source {
                        omega: (stiffness * w).sqrt(),
                        what: format!("spring '{}'", f.name),
                        discretization: false,
                    });
                }
                if *damping > 0.0 && w > 0.0 {
                    sources.push(Source {
                        omega: damping * w,
                        what: format!("damping of '{}' (rate c/m)", f.name),
                        discretization: false,
                    });
                }
            }
            ForceKind::RotationalSpring {
                joint,
                stiffness,
                damping,
                ..
            } => {
                let Some(j) = scene.joints.get(*joint) else {
                    continue;
                };
                let axis_of = |a: &Attachment| -> f64 {
                    match a.body {
                        BodyRef::Ground => 0.0,
                        BodyRef::Body(i) => match bodies.get(i).and_then(|b| b.as_ref()) {
                            Some(b) => {
                                let ax = rotation(&quat(a.frame)) * Vector3::z();
                                ax.dot(&(b.j_inv * ax))
                            }
                            None => 0.0,
                        },
                    }
                };
                let w = axis_of(&j.a) + axis_of(&j.b);
                if *stiffness > 0.0 && w > 0.0 {
                    sources.push(Source {
                        omega: (stiffness * w).sqrt(),
                        what: format!("rotational spring '{}'", f.name),
                        discretization: false,
                    });
                }
                if *damping > 0.0 && w > 0.0 {
                    sources.push(Source {
                        omega: damping * w,
                        what: format!("damping of '{}' (rate c/J)", f.name),
                        discretization: false,
                    });
                }
            }
            _ => {}
        }
    }
    for c in &scene.contacts {
        let inv = |a: &Attachment| match a.body {
            BodyRef::Ground => 0.0,
            BodyRef::Body(i) => 1.0 / scene.bodies[i].mass,
        };
        let w = inv(&c.a.0) + inv(&c.b.0);
        if c.stiffness > 0.0 && w > 0.0 {
            sources.push(Source {
                omega: (c.stiffness * w).sqrt(),
                what: format!("contact '{}'", c.name),
                discretization: false,
            });
        }
        if c.damping > 0.0 && w > 0.0 {
            sources.push(Source {
                omega: c.damping * w,
                what: format!("damping of contact '{}'", c.name),
                discretization: false,
            });
        }
    }
    for beam in &scene.beams {
        // the shortest element is the stiffest (the shear/rotary mode does not depend on ℓ,
        // the axial and bending ones grow as ℓ shrinks)
        let Some((e, l)) = beam
            .nodes
            .windows(2)
            .map(|w| (vec3(&w[1]) - vec3(&w[0])).norm())
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))
        else {
            continue;
        };
        let Some((w, h_max)) =
            beam_step_limit(&beam.section, l, beam.rotary_inertia_scale, beam.damping)
        else {
            continue;
        };
        // reported as the equivalent rate 2/h_max (the damped limit's)
        sources.push(Source {
            omega: 2.0 / h_max,
            what: if beam.damping > 0.0 {
                format!(
                    "beam '{}', element {e} (its highest mode, {w:.4e} rad/s, with damping {} s)",
                    beam.name, beam.damping
                )
            } else {
                format!("beam '{}', element {e} (its highest mode)", beam.name)
            },
            discretization: true,
        });
    }
    sources.sort_by(|a, b| b.omega.total_cmp(&a.omega));
    Estimate { sources }
}

/// Samples of a driver's rate over the run: 10⁴ intervals (and both ends).
pub const DRIVEN_SPEED_SAMPLES: usize = 10_000;

/// The largest rate |f'(t)| of a driver's time function over `[0, duration]` and where it is
/// reached, sampled at [`DRIVEN_SPEED_SAMPLES`] + 1 times; `None` when it is zero (or not
/// finite anywhere).
pub fn driven_speed(f: &crate::contract::scene::Fn1, duration: f64) -> Option<(f64, f64)> {
    let duration = if duration.is_finite() && duration > 0.0 {
        duration
    } else {
        0.0
    };
    let mut best: Option<(f64, f64)> = None;
    for k in 0..=DRIVEN_SPEED_SAMPLES {
        let t = duration * k as f64 / DRIVEN_SPEED_SAMPLES as f64;
        let w = crate::kernels::fn1::eval(f, t).d1.abs();
        if w.is_finite() && w > 0.0 && best.is_none_or(|(b, _)| w > b) {
            best = Some((w, t));
        }
        if duration == 0.0 {
            break;
        }
    }
    best
}

/// [`estimate`] with the fastest mode of the constrained system linearized at t = 0
/// ([`super::constrained_modes::fastest`] on `sys`, the scene's system) added as a source,
/// when it is faster than every source of the scene by more than 10⁻³ (a spring on a free body
/// is its own mode, and keeps its name), named by its body and, where one stiffens it, its joint: `constrained mode of body 'link'
/// (93 % of its kinetic energy), stiffened by joint 'pin'`. Also returns the note of a scene
/// the constrained analysis skipped (too large); scenes with beams or meshes are left to their
/// element limits without a note.
pub fn estimate_system<S: System>(scene: &Scene, sys: &S) -> (Estimate, Option<String>) {
    use super::constrained_modes::{fastest, Outcome};
    let mut est = estimate(scene);
    let note = match fastest(sys) {
        Outcome::Skipped(why) => Some(why),
        Outcome::Done(None) | Outcome::Elsewhere => None,
        // a mode no faster than a scene element's source (to 10⁻³) is that element's: the
        // element's name says more than the body's
        Outcome::Done(Some(mode))
            if est
                .fastest()
                .is_some_and(|f| mode.omega <= (1.0 + 1e-3) * f.omega) =>
        {
            None
        }
        Outcome::Done(Some(mode)) => {
            let layout = sys.layout();
            let mut what = format!(
                "constrained mode of body '{}' ({:.0} % of its kinetic energy)",
                layout.body_names[mode.body],
                100.0 * mode.body_share
            );
            if let Some(j) = mode.joint {
                what.push_str(&format!(", stiffened by joint '{}'", layout.joints[j].name));
            }
            est.sources.push(Source {
                omega: mode.omega,
                what,
                discretization: false,
            });
            est.sources.sort_by(|a, b| b.omega.total_cmp(&a.omega));
            None
        }
    };
    (est, note)
}

/// The explicit step limit of a beam whose shortest element has length `l`: its highest
/// frequency ω ([`beam_element_frequency`]) and the largest stable leapfrog step,
/// `(2/ω)(√(1 + ξ²) − ξ)` with `ξ = βω/2` for stiffness-proportional damping β (`2/ω`
/// undamped). `None` for a section the kernel refuses.
pub fn beam_step_limit(
    section: &crate::contract::scene::Section,
    l: f64,
    rotary_scale: f64,
    damping: f64,
) -> Option<(f64, f64)> {
    let w = beam_element_frequency(section, l, rotary_scale)?;
    let xi = 0.5 * damping * w;
    Some((w, (2.0 / w) * ((1.0 + xi * xi).sqrt() - xi)))
}

/// The frequency (rad/s) that limits a body's step when it carries a beam node and the
/// beam is subcycled: the node's stiffness in its elements (`elements`: each adjacent
/// element's two node poses at the start, unstrained there; `node` the attached node's
/// pose) against the body's mobility at the node (`mass` and `pose` of the body), the
/// node's mass left out (it only lowers the frequency). With `rotation` (a clamp) the
/// node's six freedoms move with the body; else (a pin) its three translations.
/// `√(2 λ_max(G K))`, G the body's mobility at the node and K the node's diagonal block of
/// its elements' stiffness (central differences of the element's internal force); the
/// factor 2 bounds the part of the elements' far nodes, as a row sum would. `None` for a
/// section or element the kernel refuses.
pub fn beam_coupling_frequency(
    section: &crate::contract::scene::Section,
    elements: &[(crate::contract::system::Pose, crate::contract::system::Pose)],
    node: &crate::contract::system::Pose,
    mass: &crate::contract::system::MassProps,
    pose: &crate::contract::system::Pose,
    rotation: bool,
) -> Option<f64> {
    use crate::contract::math::{axis_angle, qmul, skew};
    use crate::contract::system::Twist;
    use crate::kernels::beam_element::{
        internal_force, BeamNode, BeamSection, ElementForce, ElementState,
    };
    use nalgebra::{Matrix3, Matrix6};
    let sec = BeamSection::from_scene(section).ok()?;
    let n = if rotation { 6 } else { 3 };
    let mut k = Matrix6::<f64>::zeros();
    for (p0, p1) in elements {
        let reference = [
            BeamNode {
                pose: *p0,
                twist: Twist::default(),
            },
            BeamNode {
                pose: *p1,
                twist: Twist::default(),
            },
        ];
        // which end is the attached node
        let i = if (p0.r - node.r).norm() <= (p1.r - node.r).norm() {
            0
        } else {
            1
        };
        let l = (p1.r - p0.r).norm();
        let state0 = ElementState::new(&reference).ok()?;
        let force = |c: usize, d: f64| -> Option<[f64; 6]> {
            let mut nodes = reference;
            if c < 3 {
                nodes[i].pose.r[c] += d;
            } else {
                let q = qmul(&nodes[i].pose.q, &axis_angle(&Vector3::ith(c - 3, 1.0), d));
                nodes[i].pose.set_q(q);
            }
            let mut st = state0;
            let mut out = ElementForce::default();
            internal_force(&sec, &mut st, &nodes, &mut out).ok()?;
            let w = out.wrench[i];
            Some([w.f.x, w.f.y, w.f.z, w.t.x, w.t.y, w.t.z])
        };
        for c in 0..n {
            let d = if c < 3 { 1e-6 * l } else { 1e-6 };
            let (fp, fm) = (force(c, d)?, force(c, -d)?);
            for r in 0..n {
                k[(r, c)] -= (fp[r] - fm[r]) / (2.0 * d);
            }
        }
    }
    // the body's mobility at the node, in (world translation, node-axis rotation)
    let d = node.r - pose.r;
    let jw_inv = pose.c * mass.j_inv * pose.c.transpose();
    let mut g = Matrix6::<f64>::zeros();
    let sd = skew(&d);
    g.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(Matrix3::identity() / mass.m + sd * jw_inv * sd.transpose()));
    if rotation {
        let cn = node.c.transpose();
        g.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(-sd * jw_inv * cn.transpose()));
        g.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&(-cn * jw_inv * sd.transpose()));
        g.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(cn * jw_inv * cn.transpose()));
    }
    let (g, k) = (
        g.view((0, 0), (n, n)).clone_owned(),
        k.view((0, 0), (n, n)).clone_owned(),
    );
    let k = (&k + k.transpose()) * 0.5;
    let l = g.cholesky()?.l();
    let a = l.transpose() * k * &l;
    let lmax = ((&a + a.transpose()) * 0.5).symmetric_eigenvalues().max();
    (lmax.is_finite() && lmax > 0.0).then(|| (2.0 * lmax).sqrt())
}

/// The highest natural frequency (rad/s) of one free beam element of length `l` with its
/// lumped mass (each node half the element's mass and `rotary_scale` times half its rotary
/// inertia): the square root of the largest eigenvalue of `M⁻¹K`, with the element
/// stiffness `K` the derivative of [`beam_element::internal_force`] at the unstrained
/// straight element (by central differences). By the element eigenvalue inequality (Irons
/// and Treharne) it bounds from above every frequency of a beam assembled from such
/// elements, whatever its supports and attached bodies, so `2/ω` is a safe explicit step.
/// Typically the shear/rotary-inertia mode `√(GA/ρI)` for short elements, the axial
/// `2√(EA/ρA)/ℓ` for long ones. `None` for a section the kernel refuses.
pub fn beam_element_frequency(
    section: &crate::contract::scene::Section,
    l: f64,
    rotary_scale: f64,
) -> Option<f64> {
    use crate::contract::math::{axis_angle, qmul};
    use crate::contract::system::{Pose, Twist};
    use crate::kernels::beam_element::{
        internal_force, lumped_mass, BeamNode, BeamSection, ElementForce, ElementState,
    };
    use nalgebra::{DMatrix, Quaternion};
    let sec = BeamSection::from_scene(section).ok()?;
    if !(l.is_finite() && l > 0.0) {
        return None;
    }
    let reference = [
        BeamNode {
            pose: Pose::new(Vector3::zeros(), Quaternion::identity()),
            twist: Twist::default(),
        },
        BeamNode {
            pose: Pose::new(Vector3::new(l, 0.0, 0.0), Quaternion::identity()),
            twist: Twist::default(),
        },
    ];
    let state0 = ElementState::new(&reference).ok()?;
    let mass = lumped_mass(&sec, l);
    let m_diag: Vec<f64> = (0..12)
        .map(|k| {
            if k % 6 < 3 {
                mass.m
            } else {
                mass.j[k % 3] * rotary_scale
            }
        })
        .collect();
    // generalized forces (f world, t body) of both nodes after displacing dof k by d
    let forces = |k: usize, d: f64| -> Option<[f64; 12]> {
        let mut nodes = reference;
        let (n, c) = (k / 6, k % 6);
        if c < 3 {
            nodes[n].pose.r[c] += d;
        } else {
            let q = qmul(&nodes[n].pose.q, &axis_angle(&Vector3::ith(c - 3, 1.0), d));
            nodes[n].pose.set_q(q);
        }
        let mut st = state0;
        let mut out = ElementForce::default();
        internal_force(&sec, &mut st, &nodes, &mut out).ok()?;
        let mut f = [0.0; 12];
        for i in 0..2 {
            for c in 0..3 {
                f[6 * i + c] = out.wrench[i].f[c];
                f[6 * i + 3 + c] = out.wrench[i].t[c];
            }
        }
        Some(f)
    };
    let mut a = DMatrix::<f64>::zeros(12, 12);
    for k in 0..12 {
        let d = if k % 6 < 3 { 1e-6 * l } else { 1e-6 };
        let (fp, fm) = (forces(k, d)?, forces(k, -d)?);
        for i in 0..12 {
            // K = −∂F/∂z, scaled: M^{-1/2} K M^{-1/2}
            a[(i, k)] = -(fp[i] - fm[i]) / (2.0 * d) / (m_diag[i] * m_diag[k]).sqrt();
        }
    }
    let sym = (&a + a.transpose()) * 0.5;
    let lmax = sym.symmetric_eigenvalues().max();
    (lmax.is_finite() && lmax > 0.0).then(|| lmax.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::scene::*;

    /// The free element's modes in closed form (notes B one-point element, lumped mass):
    /// axial `ω² = 4EA/(ρAℓ²)`; torsion `4GJ/(ρI₁ℓ²)`; per bending plane, the antisymmetric
    /// rotation `4EI/(ρI ℓ²)` and the shear/rotary mode `GA(4/(ρAℓ²) + 1/ρI)`.
    #[test]
    fn beam_element_frequency_is_the_free_elements_highest_mode() {
        let sec = Section {
            ea: 2.0e6,
            ga2: 8.0e5,
            ga3: 6.0e5,
            ei2: 50.0,
            ei3: 80.0,
            gj: 40.0,
            rho_a: 2.0,
            rho_i: 3.0e-4,
        };
        for (l, scale) in [(0.05, 1.0), (0.5, 1.0), (0.05, 100.0), (2.0, 10.0)] {
            let ri = [
                sec.rho_i,
                sec.rho_a * sec.ei2 / sec.ea,
                sec.rho_a * sec.ei3 / sec.ea,
            ];
            let ri: Vec<f64> = ri.iter().map(|r| r * scale).collect();
            let modes = [
                4.0 * sec.ea / (sec.rho_a * l * l),
                4.0 * sec.gj / (ri[0] * l * l),
                4.0 * sec.ei2 / (ri[1] * l * l),
                4.0 * sec.ei3 / (ri[2] * l * l),
                // shear along axis 3 pairs with rotation about axis 2, and vice versa
                sec.ga3 * (4.0 / (sec.rho_a * l * l) + 1.0 / ri[1]),
                sec.ga2 * (4.0 / (sec.rho_a * l * l) + 1.0 / ri[2]),
            ];
            let exact = modes.iter().cloned().fold(0.0, f64::max).sqrt();
            let w = beam_element_frequency(&sec, l, scale).unwrap();
            assert!(
                (w / exact - 1.0).abs() < 1e-5,
                "l {l} scale {scale}: {w} vs {exact}"
            );
        }
    }

    fn body(name: &str, m: f64, j: f64, w: [f64; 3]) -> Body {
        Body {
            name: name.into(),
            mass: m,
            inertia: [[j, 0.0, 0.0], [0.0, j, 0.0], [0.0, 0.0, j]],
            position: [0.0; 3],
            orientation: [1.0, 0.0, 0.0, 0.0],
            velocity: [0.0; 3],
            angular_velocity: w,
            origin: Origin::default(),
        }
    }

    #[test]
    fn spring_frequency_and_spin() {
        let at = |body, point| Attachment {
            body,
            point,
            frame: [1.0, 0.0, 0.0, 0.0],
        };
        let scene = Scene {
            name: "s".into(),
            gravity: None,
            bodies: vec![body("m", 2.0, 1.0, [0.0, 0.0, 3.0])],
            joints: vec![],
            forces: vec![Force {
                name: "k".into(),
                kind: ForceKind::Spring {
                    a: at(BodyRef::Ground, [-1.0, 0.0, 0.0]),
                    b: at(BodyRef::Body(0), [0.0; 3]),
                    stiffness: 800.0,
                    rest_length: 1.0,
                    damping: 0.0,
                },
                origin: Origin::default(),
            }],
            beams: vec![],
            meshes: vec![],
            contacts: vec![],
            simulate: Simulate::default(),
            reference: None,
            params: vec![],
        };
        let e = estimate(&scene);
        // √(800/2) = 20 rad/s, then the spin 3 rad/s
        assert_eq!(e.sources.len(), 2);
        assert!((e.sources[0].omega - 20.0).abs() < 1e-12, "{e:?}");
        assert!(e.sources[0].what.contains("'k'"));
        assert!((e.stable_step() - 0.1).abs() < 1e-12);
        assert!((e.accurate_step() - std::f64::consts::TAU / 400.0).abs() < 1e-12);
    }

    fn empty(bodies: Vec<Body>) -> Scene {
        Scene {
            name: "s".into(),
            gravity: None,
            bodies,
            joints: vec![],
            forces: vec![],
            beams: vec![],
            meshes: vec![],
            contacts: vec![],
            simulate: Simulate::default(),
            reference: None,
            params: vec![],
        }
    }

    #[test]
    fn gravity_on_a_hinged_body() {
        let at = |body, point| Attachment {
            body,
            point,
            frame: [1.0, 0.0, 0.0, 0.0],
        };
        let joint = |kind| Joint {
            name: "j".into(),
            kind,
            a: at(BodyRef::Ground, [0.0; 3]),
            b: at(BodyRef::Body(0), [0.0, 0.0, 0.5]),
            origin: Origin::default(),
        };
        // a spinning body on a spherical joint 0.5 m from its mass centre: √(9.81/0.5)
        // beats the spin of 3 rad/s
        let mut s = empty(vec![body("b", 2.0, 1.0, [0.0, 0.0, 3.0])]);
        s.gravity = Some([0.0, 0.0, -9.81]);
        s.joints.push(joint(JointKind::Spherical));
        let e = estimate(&s);
        let fast = e.fastest().expect("a source");
        assert!((fast.omega - (9.81f64 / 0.5).sqrt()).abs() < 1e-12, "{e:?}");
        assert!(fast.what.contains("under gravity"), "{}", fast.what);
        assert!(fast.what.contains("'b'") && fast.what.contains("'j'"));
        assert_eq!(e.sources[1].what, "spin of body 'b'");
        // no gravity, or a joint that is not a pivot: the spin only
        let mut no_g = s.clone();
        no_g.gravity = None;
        assert_eq!(estimate(&no_g).sources.len(), 1);
        let mut rolling = s.clone();
        rolling.joints[0] = joint(JointKind::Rolling { radius: 0.1 });
        assert_eq!(estimate(&rolling).sources.len(), 1);
        // at rest with nothing else: the pendulum still has a rate
        let mut rest = s;
        rest.bodies[0].angular_velocity = [0.0; 3];
        assert_eq!(estimate(&rest).sources.len(), 1);
        assert_eq!(
            estimate(&empty(vec![body("b", 2.0, 1.0, [0.0; 3])])).fastest(),
            None
        );
    }
}
