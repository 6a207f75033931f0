//! An estimate of the fastest motion in a scene, before it runs: the explicit stability limit
//! `h·ω_max ≤ 2` and the accuracy rule of at least 20 steps per period of the fastest response
//! (notes A §1.10).
//!
//! Sources, each with the element it comes from so a report can name it:
//! - spin: a body's initial angular rate |ω| (the paper's "highest angular velocity of the
//!   rigid components");
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
//! - damping (springs' and contact's): the rate `c/m_eff`, whose explicit limit (lagged
//!   evaluation, notes A §1.9) is `c h / m_eff < 2`, so it is reported as an equivalent ω.
//!
//! It is an estimate: constraints can raise the frequencies of springs attached through them
//! (a short lever) and motion can raise spin rates; the watchdog catches what it misses.

use nalgebra::{Matrix3, Vector3};

use crate::contract::math::{quat, rotation, vec3};
use crate::contract::scene::{Attachment, BodyRef, ForceKind, JointKind, Scene};

/// One source of fast motion.
#[derive(Clone, Debug, PartialEq)]
pub struct Source {
    /// Angular frequency (or rate), rad/s.
    pub omega: f64,
    /// What it is, naming the element: `spring 'k'`, `spin of body 'rotor'`.
    pub what: String,
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

    /// Largest step with 20 steps per period of the fastest source: `2π/(20 ω_max)`.
    pub fn accurate_step(&self) -> f64 {
        self.fastest()
            .map_or(f64::INFINITY, |s| std::f64::consts::TAU / (20.0 * s.omega))
    }
}

/// Whether a method integrates the coordinates explicitly (and so has a stability limit).
pub fn is_explicit(method: &crate::contract::scene::MethodSpec) -> bool {
    !matches!(
        method,
        crate::contract::scene::MethodSpec::ImplicitTrapezoid { .. }
            | crate::contract::scene::MethodSpec::StateTime { .. }
    )
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
            });
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
                    });
                }
                if *damping > 0.0 && w > 0.0 {
                    sources.push(Source {
                        omega: damping * w,
                        what: format!("damping of '{}' (rate c/m)", f.name),
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
                    });
                }
                if *damping > 0.0 && w > 0.0 {
                    sources.push(Source {
                        omega: damping * w,
                        what: format!("damping of '{}' (rate c/J)", f.name),
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
            });
        }
        if c.damping > 0.0 && w > 0.0 {
            sources.push(Source {
                omega: c.damping * w,
                what: format!("damping of contact '{}'", c.name),
            });
        }
    }
    sources.sort_by(|a, b| b.omega.total_cmp(&a.omega));
    Estimate { sources }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::scene::*;

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
