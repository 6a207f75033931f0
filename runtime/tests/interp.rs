//! Integration tests of the interpreter on hand-built scenes.

use mbdc_runtime::energy::{angular_momentum, kinetic_energy, linear_momentum};
use mbdc_runtime::fn1::Jet2;
use mbdc_runtime::interp::{Interp, InterpError, IDENTITY};
use mbdc_runtime::joints::{self, JointGeom, JointOut};
use mbdc_runtime::math::{axis_angle, quat_array, rotation};
use mbdc_runtime::scene::*;
use mbdc_runtime::system::{ConstraintEval, Need, Pose, RowKind, System, Twist, Wrench};
use nalgebra::{DMatrix, DVector, Vector3};

const G: f64 = 9.81;

fn empty_scene(bodies: Vec<Body>) -> Scene {
    Scene {
        name: "test".into(),
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

/// A rod of length `l`, mass `m` hanging from a revolute joint at the world origin with
/// axis world y; the rod makes the angle `phi` with the downward vertical (towards +x)
/// and turns at `w0` rad/s about y.
struct Pendulum {
    scene: Scene,
    m: f64,
    l: f64,
    i_cm: f64,
    phi: f64,
}

fn pendulum(phi: f64, w0: f64) -> Pendulum {
    let (m, l, r) = (2.0, 1.2, 0.02);
    let i_cm = m * l * l / 12.0;
    let q = axis_angle(&Vector3::y(), -phi);
    let rho = Vector3::new(0.0, 0.0, l / 2.0); // pivot end, body frame
    let pos = -(rotation(&q) * rho);
    let ww = Vector3::new(0.0, w0, 0.0);
    let vel = ww.cross(&pos);
    let body = Body {
        name: "rod".into(),
        mass: m,
        inertia: [
            [i_cm, 0.0, 0.0],
            [0.0, i_cm, 0.0],
            [0.0, 0.0, m * r * r / 2.0],
        ],
        position: pos.into(),
        orientation: quat_array(&q),
        velocity: vel.into(),
        angular_velocity: [0.0, w0, 0.0],
        origin: Origin::default(),
    };
    // joint z along world y (and along body y): frame = rotation of −90° about x
    let frame = quat_array(&axis_angle(&Vector3::x(), -std::f64::consts::FRAC_PI_2));
    let mut scene = empty_scene(vec![body]);
    scene.gravity = Some([0.0, 0.0, -G]);
    scene.joints.push(Joint {
        name: "hinge".into(),
        kind: JointKind::Revolute,
        a: Attachment {
            body: BodyRef::Ground,
            point: [0.0; 3],
            frame,
        },
        b: Attachment {
            body: BodyRef::Body(0),
            point: rho.into(),
            frame,
        },
        origin: Origin::default(),
    });
    Pendulum {
        scene,
        m,
        l,
        i_cm,
        phi,
    }
}

fn state(sys: &dyn System) -> (Vec<Pose>, Vec<Twist>) {
    let n = sys.layout().bodies();
    let mut pose = vec![Pose::default(); n];
    let mut twist = vec![Twist::default(); n];
    sys.initial_state(&mut pose, &mut twist);
    (pose, twist)
}

/// Dense `B` (rows × 6n) and the index-1 solve `[M Bᵀ; B 0][u̇'; λ] = [F − ω×Jω; γ]`.
fn index1(
    sys: &dyn System,
    t: f64,
    pose: &[Pose],
    twist: &[Twist],
) -> (DVector<f64>, DVector<f64>) {
    let lay = sys.layout();
    let (n, m) = (lay.bodies(), lay.rows);
    let mut ev = ConstraintEval::new(m);
    sys.constraints(t, pose, twist, Need::ALL, &mut ev);
    let mut w = vec![Wrench::default(); n];
    sys.applied(t, pose, twist, &mut w);
    let mut a = DMatrix::zeros(6 * n + m, 6 * n + m);
    let mut rhs = DVector::zeros(6 * n + m);
    for (i, mp) in lay.mass.iter().enumerate() {
        for k in 0..3 {
            a[(6 * i + k, 6 * i + k)] = mp.m;
            for c in 0..3 {
                a[(6 * i + 3 + k, 6 * i + 3 + c)] = mp.j[(k, c)];
            }
        }
        let gyro = twist[i].w.cross(&(mp.j * twist[i].w));
        for k in 0..3 {
            rhs[6 * i + k] = w[i].f[k];
            rhs[6 * i + 3 + k] = w[i].t[k] - gyro[k];
        }
    }
    for r in 0..m {
        let (ba, bb) = lay.row_bodies(r);
        for (body, blk) in [(ba, ev.jac[r].a), (bb, ev.jac[r].b)] {
            if let Some(i) = body {
                for k in 0..6 {
                    a[(6 * n + r, 6 * i + k)] = blk[k];
                    a[(6 * i + k, 6 * n + r)] = blk[k];
                }
            }
        }
        rhs[6 * n + r] = ev.gamma[r];
    }
    let x = a.lu().solve(&rhs).expect("index-1 matrix is singular");
    (x.rows(0, 6 * n).into_owned(), x.rows(6 * n, m).into_owned())
}

#[test]
fn pendulum_on_revolute_joint() {
    let p = pendulum(0.4, 1.3);
    let sys = Interp::new(&p.scene).unwrap();
    let lay = sys.layout();
    assert_eq!(lay.rows, 5);
    assert_eq!(lay.joints.len(), 1);
    assert_eq!(
        (lay.joints[0].kind, lay.joints[0].a, lay.joints[0].b),
        ("revolute", None, Some(0))
    );
    assert_eq!(lay.row_joint, vec![0; 5]);
    assert_eq!(lay.row_kind, vec![RowKind::Holonomic; 5]);
    assert!(!sys.has_velocity_forces());
    assert!(
        !sys.has_state_forces(),
        "gravity alone does not depend on the state"
    );
    assert_eq!(sys.force_terms(), 0);

    let (pose, twist) = state(&sys);
    let mut ev = ConstraintEval::new(5);
    sys.constraints(0.0, &pose, &twist, Need::ALL, &mut ev);
    let u = [
        twist[0].v.x,
        twist[0].v.y,
        twist[0].v.z,
        twist[0].w.x,
        twist[0].w.y,
        twist[0].w.z,
    ];
    for r in 0..5 {
        assert!(ev.phi[r].abs() < 1e-15, "Φ[{r}] = {}", ev.phi[r]);
        let rate: f64 = (0..6).map(|k| ev.jac[r].b[k] * u[k]).sum::<f64>() + ev.bias[r];
        assert!(rate.abs() < 1e-15, "B u̇ + bias [{r}] = {rate}");
    }

    // applied = m g, no torque
    let mut w = vec![Wrench::default(); 1];
    sys.applied(0.0, &pose, &twist, &mut w);
    assert_eq!(w[0].f, Vector3::new(0.0, 0.0, -p.m * G));
    assert_eq!(w[0].t, Vector3::zeros());
    // potential energy −m g·r
    assert!((sys.potential_energy(0.0, &pose) - p.m * G * pose[0].r.z).abs() < 1e-14);

    // index-1 accelerations: ω̇_y = m g (L/2) sin φ / I_pivot (torque about +y), and the
    // constraint stays satisfied at acceleration level.
    let (acc, lambda) = index1(&sys, 0.0, &pose, &twist);
    let i_p = p.i_cm + p.m * p.l * p.l / 4.0;
    let expect = p.m * G * (p.l / 2.0) * p.phi.sin() / i_p;
    assert!(
        (acc[4] - expect).abs() < 1e-12,
        "ω̇_y {} vs {}",
        acc[4],
        expect
    );
    assert!(acc[3].abs() < 1e-12 && acc[5].abs() < 1e-12);
    // mass-centre acceleration = ω̇ × s + ω × (ω × s) with s = r − pivot
    let s = pose[0].r;
    let wv = Vector3::new(0.0, twist[0].w.y, 0.0);
    let a_cm = Vector3::new(0.0, acc[4], 0.0).cross(&s) + wv.cross(&wv.cross(&s));
    for k in 0..3 {
        assert!(
            (acc[k] - a_cm[k]).abs() < 1e-12,
            "a_cm[{k}] {} vs {}",
            acc[k],
            a_cm[k]
        );
    }
    // Reaction on the rod = −B_bᵀλ (M u̇' + Bᵀλ = F) = m a − m g
    let react: Vector3<f64> = (0..5).fold(Vector3::zeros(), |f, r| {
        f - Vector3::new(ev.jac[r].b[0], ev.jac[r].b[1], ev.jac[r].b[2]) * lambda[r]
    });
    let want = p.m * a_cm - Vector3::new(0.0, 0.0, -p.m * G);
    assert!((react - want).norm() < 1e-11, "{react} vs {want}");

    // energy: T = ½ I_pivot ω²
    let t = kinetic_energy(lay, &twist);
    assert!((t - 0.5 * i_p * 1.3 * 1.3).abs() < 1e-12, "{t}");
    let lm = angular_momentum(lay, &pose, &twist);
    assert!(
        (lm - Vector3::new(0.0, i_p * 1.3, 0.0)).norm() < 1e-12,
        "{lm}"
    );
    assert!((linear_momentum(lay, &twist) - p.m * twist[0].v).norm() < 1e-15);
}

#[test]
fn lock_row_activates_at_the_lock_angle() {
    let mut p = pendulum(0.3, 0.0);
    // θ about the joint z (= world y) is −φ here; lock at θ = 0.2 (φ = −0.2).
    p.scene.forces.push(Force {
        name: "coil".into(),
        kind: ForceKind::RotationalSpring {
            joint: 0,
            stiffness: 5.0,
            rest_angle: 0.0,
            damping: 0.5,
            lock_angle: Some(0.2),
        },
        origin: Origin::default(),
    });
    let sys = Interp::new(&p.scene).unwrap();
    let lay = sys.layout();
    assert_eq!(lay.rows, 6);
    assert_eq!(lay.joints.len(), 2);
    let lj = &lay.joints[1];
    assert_eq!(
        (
            lj.name.as_str(),
            lj.kind,
            lj.first_row,
            lj.rows,
            lj.starts_inactive
        ),
        ("coil.lock", "lock", 5, 1, true)
    );
    assert_eq!(lay.row_joint, vec![0, 0, 0, 0, 0, 1]);
    assert!(sys.has_velocity_forces());
    let mut th = [0.0];
    let at = |phi: f64| {
        let s = pendulum(phi, 0.0).scene;
        let b = &s.bodies[0];
        vec![Pose::new(
            Vector3::from(b.position),
            mbdc_runtime::math::quat(b.orientation),
        )]
    };
    sys.lock_angles(&at(0.3), &mut th);
    assert!((th[0] + 0.3).abs() < 1e-14, "θ0 = {}", th[0]);
    let mut active = vec![true, true, true, true, true, false];
    assert_eq!(
        sys.update_locks(&at(-0.1), &[Twist::default()], &mut active),
        None
    );
    assert!(!active[5]);
    assert_eq!(
        sys.update_locks(&at(-0.25), &[Twist::default()], &mut active),
        Some(1)
    );
    assert!(active[5]);
    assert_eq!(
        sys.update_locks(&at(0.0), &[Twist::default()], &mut active),
        None,
        "locks never release"
    );
    // the lock row is sin(θ − θ_lock)
    let mut ev = ConstraintEval::new(6);
    sys.constraints(0.0, &at(-0.25), &[Twist::default()], Need::PHI, &mut ev);
    assert!((ev.phi[5] - (0.25f64 - 0.2).sin()).abs() < 1e-14);
    // the spring: torque −k θ about the axis (θ = −φ = −0.25 + ...): potential ½ k θ²
    let pe = sys.potential_energy(0.0, &at(-0.25));
    let grav = 2.0 * G * at(-0.25)[0].r.z;
    assert!((pe - grav - 0.5 * 5.0 * 0.25 * 0.25).abs() < 1e-12);
}

#[test]
fn unsupported_items_are_named() {
    let p = pendulum(0.1, 0.0);
    let mut s = p.scene.clone();
    s.beams.push(Beam {
        name: "boom".into(),
        nodes: vec![[0.0; 3], [1.0, 0.0, 0.0]],
        up: [0.0, 0.0, 1.0],
        section: Section {
            ea: 1.0,
            ga2: 1.0,
            ga3: 1.0,
            ei2: 1.0,
            ei3: 1.0,
            gj: 1.0,
            rho_a: 1.0,
            rho_i: 1.0,
        },
        attachments: vec![],
        damping: 0.0,
        rotary_inertia_scale: 1.0,
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        origin: Origin::default(),
    });
    // a beam is simulated: its nodes become bodies after the scene's
    let i = Interp::new(&s).unwrap();
    assert_eq!(i.layout().bodies(), p.scene.bodies.len() + 2);
    assert_eq!(i.layout().beams.elements.len(), 1);
    // a bad one is named
    s.beams[0].nodes[1] = [0.0; 3];
    let e = Interp::new(&s).unwrap_err();
    assert!(matches!(e, InterpError::Beam { ref name, .. } if name == "boom"));
    assert!(
        e.to_string().contains("beam 'boom'") && e.to_string().contains("zero length"),
        "{e}"
    );

    let mut s = p.scene.clone();
    s.contacts.push(Contact {
        name: "bricks".into(),
        a: (
            Attachment {
                body: BodyRef::Body(0),
                point: [0.0; 3],
                frame: IDENTITY,
            },
            Shape::Box {
                half_extents: [0.1; 3],
            },
        ),
        b: (
            Attachment {
                body: BodyRef::Ground,
                point: [0.0; 3],
                frame: IDENTITY,
            },
            Shape::Box {
                half_extents: [0.1; 3],
            },
        ),
        stiffness: 1e4,
        damping: 0.0,
        friction: 0.0,
        origin: Origin::default(),
    });
    let e = Interp::new(&s).unwrap_err().to_string();
    assert!(
        e.contains("contact 'bricks'") && e.contains("box–box"),
        "{e}"
    );

    let mut s = p.scene.clone();
    s.bodies[0].inertia = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]];
    let e = Interp::new(&s).unwrap_err().to_string();
    assert!(e.contains("body 'rod'") && e.contains("singular"), "{e}");

    let mut s = p.scene.clone();
    s.joints.push(Joint {
        name: "motor".into(),
        kind: JointKind::DriveDisplacement {
            joint: 0,
            displacement: Fn1::Var,
        },
        a: s.joints[0].a,
        b: s.joints[0].b,
        origin: Origin::default(),
    });
    let e = Interp::new(&s).unwrap_err().to_string();
    assert!(e.contains("joint 'motor'") && e.contains("revolute"), "{e}");
}

#[test]
fn forces_and_contacts_in_applied() {
    let body = Body {
        name: "ball".into(),
        mass: 3.0,
        inertia: [[0.05, 0.0, 0.0], [0.0, 0.05, 0.0], [0.0, 0.0, 0.05]],
        position: [0.0, 0.0, 0.099],
        orientation: IDENTITY,
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        origin: Origin::default(),
    };
    let mut s = empty_scene(vec![body]);
    let here = Attachment {
        body: BodyRef::Body(0),
        point: [0.0; 3],
        frame: IDENTITY,
    };
    let ground = Attachment {
        body: BodyRef::Ground,
        point: [0.0; 3],
        frame: IDENTITY,
    };
    // plane listed first: the interpreter puts the sphere on side a
    s.contacts.push(Contact {
        name: "floor".into(),
        a: (ground, Shape::Plane),
        b: (here, Shape::Sphere { radius: 0.1 }),
        stiffness: 1e5,
        damping: 0.0,
        friction: 0.0,
        origin: Origin::default(),
    });
    s.forces.push(Force {
        name: "push".into(),
        kind: ForceKind::Point {
            at: Attachment {
                point: [0.0, 0.0, 0.1],
                ..here
            },
            value: [
                Fn1::Mul(Box::new(Fn1::Const(2.0)), Box::new(Fn1::Var)),
                Fn1::Const(0.0),
                Fn1::Const(0.0),
            ],
            frame: ForceFrame::World,
        },
        origin: Origin::default(),
    });
    s.forces.push(Force {
        name: "idle".into(),
        kind: ForceKind::Spring {
            a: here,
            b: ground,
            stiffness: 0.0,
            rest_length: 1.0,
            damping: 0.0,
        },
        origin: Origin::default(),
    });
    let sys = Interp::new(&s).unwrap();
    assert_eq!(sys.force_terms(), 2, "the idle spring builds no term");
    assert!(!sys.has_velocity_forces());
    assert!(sys.has_state_forces());
    // a world force at the mass centre alone is state-independent
    let mut s2 = s.clone();
    s2.contacts.clear();
    if let ForceKind::Point { at, .. } = &mut s2.forces[0].kind {
        at.point = [0.0; 3];
    }
    assert!(!Interp::new(&s2).unwrap().has_state_forces());
    let (pose, twist) = state(&sys);
    let mut w = vec![Wrench::default(); 1];
    sys.applied(1.5, &pose, &twist, &mut w);
    // contact 1e5 · 1 mm up, push 3 N along x at 0.1 above the centre: torque (0, 0.3, 0)
    assert!(
        (w[0].f - Vector3::new(3.0, 0.0, 100.0)).norm() < 1e-9,
        "{}",
        w[0].f
    );
    assert!(
        (w[0].t - Vector3::new(0.0, 0.3, 0.0)).norm() < 1e-12,
        "{}",
        w[0].t
    );
    assert!((sys.potential_energy(0.0, &pose) - 0.5 * 1e5 * 1e-6).abs() < 1e-12);
}

/// Every joint kind dispatches to its kernel with the geometry of its attachments.
#[test]
fn interpreter_dispatches_every_kind_to_its_kernel() {
    let mk = |name: &str, p: [f64; 3], q: [f64; 4]| Body {
        name: name.into(),
        mass: 1.0,
        inertia: [[0.1, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.3]],
        position: p,
        orientation: q,
        velocity: [0.1, -0.2, 0.3],
        angular_velocity: [0.4, 0.5, -0.6],
        origin: Origin::default(),
    };
    let qa = quat_array(&axis_angle(&Vector3::new(1.0, 2.0, 3.0), 0.5));
    let qb = quat_array(&axis_angle(&Vector3::new(-1.0, 0.5, 1.0), 1.2));
    let a = Attachment {
        body: BodyRef::Body(0),
        point: [0.1, 0.2, 0.3],
        frame: qa,
    };
    let b = Attachment {
        body: BodyRef::Body(1),
        point: [-0.2, 0.1, 0.0],
        frame: qb,
    };
    let gnd = Attachment {
        body: BodyRef::Ground,
        point: [0.3, 0.0, -0.1],
        frame: qb,
    };
    let sinf = Fn1::Unary(UnaryFn::Sin, Box::new(Fn1::Var));
    let kinds: Vec<(JointKind, Attachment)> = vec![
        (JointKind::Spherical, b),
        (JointKind::Revolute, b),
        (JointKind::Prismatic, b),
        (JointKind::Cylindrical, b),
        (JointKind::Universal, b),
        (JointKind::Fixed, b),
        (JointKind::Planar, b),
        (JointKind::Distance { length: 0.7 }, b),
        (
            JointKind::DriveAngle {
                joint: 1,
                angle: sinf.clone(),
            },
            b,
        ),
        (
            JointKind::DriveDisplacement {
                joint: 2,
                displacement: sinf.clone(),
            },
            b,
        ),
        (JointKind::Rolling { radius: 0.3 }, gnd),
        (
            JointKind::PointVelocity {
                velocity: [sinf.clone(), Fn1::Const(1.0), Fn1::Var],
            },
            gnd,
        ),
        (
            JointKind::Curve {
                curve: sinf.clone(),
            },
            b,
        ),
    ];
    let mut s = empty_scene(vec![
        mk("a", [0.1, 0.2, 0.3], qa),
        mk("b", [-0.3, 0.4, 0.2], qb),
    ]);
    for (i, (k, bb)) in kinds.iter().enumerate() {
        s.joints.push(Joint {
            name: format!("j{i}"),
            kind: k.clone(),
            a,
            b: *bb,
            origin: Origin::default(),
        });
    }
    let sys = Interp::new(&s).unwrap();
    let lay = sys.layout();
    assert_eq!(lay.rows, s.constraint_rows());
    let (pose, twist) = state(&sys);
    let t = 0.7;
    let mut ev = ConstraintEval::new(lay.rows);
    sys.constraints(t, &pose, &twist, Need::ALL, &mut ev);
    let gp = Pose::default();
    let gt = Twist::default();
    let st = Jet2::var(t).sin();
    for (i, (k, bb)) in kinds.iter().enumerate() {
        let jl = &lay.joints[i];
        assert_eq!(jl.kind, k.keyword());
        assert_eq!(jl.nonholonomic, k.nonholonomic_rows());
        for r in 0..jl.rows {
            let want = if r >= jl.rows - jl.nonholonomic {
                RowKind::Nonholonomic
            } else {
                RowKind::Holonomic
            };
            assert_eq!(lay.row_kind[jl.first_row + r], want);
        }
        let param = match k {
            JointKind::Distance { length } => *length,
            JointKind::Rolling { radius } => *radius,
            _ => 0.0,
        };
        let g = JointGeom::new(&a, bb, param);
        let (pb, tb) = if bb.body == BodyRef::Ground {
            (&gp, &gt)
        } else {
            (&pose[1], &twist[1])
        };
        let mut e2 = ConstraintEval::new(jl.rows);
        let o = JointOut::new(&mut e2, 0, jl.rows);
        let (pa, ta) = (&pose[0], &twist[0]);
        match k {
            JointKind::Spherical => joints::spherical(&g, pa, pb, ta, tb, Need::ALL, o),
            JointKind::Revolute => joints::revolute(&g, pa, pb, ta, tb, Need::ALL, o),
            JointKind::Prismatic => joints::prismatic(&g, pa, pb, ta, tb, Need::ALL, o),
            JointKind::Cylindrical => joints::cylindrical(&g, pa, pb, ta, tb, Need::ALL, o),
            JointKind::Universal => joints::universal(&g, pa, pb, ta, tb, Need::ALL, o),
            JointKind::Fixed => joints::fixed(&g, pa, pb, ta, tb, Need::ALL, o),
            JointKind::Planar => joints::planar(&g, pa, pb, ta, tb, Need::ALL, o),
            JointKind::Distance { .. } => joints::distance_joint(&g, pa, pb, ta, tb, Need::ALL, o),
            JointKind::DriveAngle { .. } => {
                joints::drive_angle(&g, st, pa, pb, ta, tb, Need::ALL, o)
            }
            JointKind::DriveDisplacement { .. } => {
                joints::drive_displacement(&g, st, pa, pb, ta, tb, Need::ALL, o)
            }
            JointKind::Rolling { .. } => joints::rolling(&g, pa, pb, ta, tb, Need::ALL, o),
            JointKind::PointVelocity { .. } => {
                let v = [st, Jet2::constant(1.0), Jet2::var(t)];
                joints::point_velocity(&g, v, pa, pb, ta, tb, Need::ALL, o)
            }
            JointKind::Curve { .. } => {
                joints::curve(&g, |x| Jet2::var(x).sin(), pa, pb, ta, tb, Need::ALL, o)
            }
        }
        let r0 = jl.first_row;
        assert_eq!(&ev.phi[r0..r0 + jl.rows], &e2.phi[..], "{}", k.keyword());
        assert_eq!(&ev.jac[r0..r0 + jl.rows], &e2.jac[..], "{}", k.keyword());
        assert_eq!(&ev.bias[r0..r0 + jl.rows], &e2.bias[..], "{}", k.keyword());
        assert_eq!(
            &ev.gamma[r0..r0 + jl.rows],
            &e2.gamma[..],
            "{}",
            k.keyword()
        );
        // the joint's rows are not all trivially zero
        assert!(
            e2.jac.iter().any(|j| j.a.iter().any(|x| *x != 0.0)),
            "{}",
            k.keyword()
        );
    }
}

/// A 3-D double pendulum (two rods, two spherical joints, gravity), integrated through
/// the interpreter with classical RK4 on the index-1 equations. With a correct `gamma`
/// the constraint drift and the energy error are O(h⁴) per unit time; a wrong velocity
/// term would make Φ drift like t².
#[test]
fn double_pendulum_index1_rk4_conserves_energy_and_constraints() {
    let l = 1.0;
    let rod = |name: &str,
               r: Vector3<f64>,
               q: nalgebra::Quaternion<f64>,
               v: Vector3<f64>,
               w: Vector3<f64>| Body {
        name: name.into(),
        mass: 1.0,
        inertia: [
            [l * l / 12.0, 0.0, 0.0],
            [0.0, l * l / 12.0, 0.0],
            [0.0, 0.0, 1e-3],
        ],
        position: r.into(),
        orientation: quat_array(&q),
        velocity: v.into(),
        angular_velocity: (rotation(&q).transpose() * w).into(),
        origin: Origin::default(),
    };
    // rod 1 tilted 60° about y from hanging, rod 2 tilted further about x
    let q1 = axis_angle(&Vector3::y(), -std::f64::consts::FRAC_PI_3);
    let q2 = axis_angle(&Vector3::new(1.0, 0.3, 0.0), 0.7);
    let top = Vector3::new(0.0, 0.0, l / 2.0);
    let r1 = -(rotation(&q1) * top);
    let end1 = r1 - rotation(&q1) * top;
    let r2 = end1 - rotation(&q2) * top;
    let (w1, w2) = (Vector3::new(0.0, 0.0, 1.0), Vector3::new(0.5, 0.0, 1.0));
    let v1 = w1.cross(&r1);
    let v2 = w1.cross(&end1) + w2.cross(&(r2 - end1));
    let mut s = empty_scene(vec![
        rod("rod1", r1, q1, v1, w1),
        rod("rod2", r2, q2, v2, w2),
    ]);
    s.gravity = Some([0.0, 0.0, -G]);
    let at = |body, p: [f64; 3]| Attachment {
        body,
        point: p,
        frame: IDENTITY,
    };
    s.joints.push(Joint {
        name: "shoulder".into(),
        kind: JointKind::Spherical,
        a: at(BodyRef::Ground, [0.0; 3]),
        b: at(BodyRef::Body(0), [0.0, 0.0, l / 2.0]),
        origin: Origin::default(),
    });
    s.joints.push(Joint {
        name: "elbow".into(),
        kind: JointKind::Spherical,
        a: at(BodyRef::Body(0), [0.0, 0.0, -l / 2.0]),
        b: at(BodyRef::Body(1), [0.0, 0.0, l / 2.0]),
        origin: Origin::default(),
    });
    let sys = Interp::new(&s).unwrap();
    let energy =
        |p: &[Pose], t: &[Twist]| kinetic_energy(sys.layout(), t) + sys.potential_energy(0.0, p);
    let violation = |p: &[Pose], t: &[Twist]| {
        let mut ev = ConstraintEval::new(6);
        sys.constraints(0.0, p, t, Need::ALL, &mut ev);
        let mut worst: f64 = 0.0;
        for r in 0..6 {
            let (a, b) = sys.layout().row_bodies(r);
            let mut rate = ev.bias[r];
            for (body, blk) in [(a, ev.jac[r].a), (b, ev.jac[r].b)] {
                if let Some(i) = body {
                    let u = [t[i].v.x, t[i].v.y, t[i].v.z, t[i].w.x, t[i].w.y, t[i].w.z];
                    rate += (0..6).map(|k| blk[k] * u[k]).sum::<f64>();
                }
            }
            worst = worst.max(ev.phi[r].abs()).max(rate.abs());
        }
        worst
    };
    // state derivative: (ṙ, q̇, v̇, ω̇) per body
    type D = Vec<(
        Vector3<f64>,
        nalgebra::Quaternion<f64>,
        Vector3<f64>,
        Vector3<f64>,
    )>;
    let deriv = |p: &[Pose], t: &[Twist]| -> D {
        let (acc, _) = index1(&sys, 0.0, p, t);
        (0..2)
            .map(|i| {
                (
                    t[i].v,
                    mbdc_runtime::math::quat_rate(&p[i].q, &t[i].w),
                    Vector3::new(acc[6 * i], acc[6 * i + 1], acc[6 * i + 2]),
                    Vector3::new(acc[6 * i + 3], acc[6 * i + 4], acc[6 * i + 5]),
                )
            })
            .collect()
    };
    let shift = |p: &[Pose], t: &[Twist], d: &D, h: f64| -> (Vec<Pose>, Vec<Twist>) {
        let ps = (0..2)
            .map(|i| Pose::new(p[i].r + d[i].0 * h, p[i].q + d[i].1 * h))
            .collect();
        let ts = (0..2)
            .map(|i| Twist {
                v: t[i].v + d[i].2 * h,
                w: t[i].w + d[i].3 * h,
            })
            .collect();
        (ps, ts)
    };
    let run = |n: usize| -> (f64, f64, Vec<Pose>) {
        let (mut pose, mut twist) = state(&sys);
        let e0 = energy(&pose, &twist);
        assert!(violation(&pose, &twist) < 1e-14);
        let h = 1.0 / n as f64;
        let mut worst_e: f64 = 0.0;
        for _ in 0..n {
            let k1 = deriv(&pose, &twist);
            let (p2, t2) = shift(&pose, &twist, &k1, h / 2.0);
            let k2 = deriv(&p2, &t2);
            let (p3, t3) = shift(&pose, &twist, &k2, h / 2.0);
            let k3 = deriv(&p3, &t3);
            let (p4, t4) = shift(&pose, &twist, &k3, h);
            let k4 = deriv(&p4, &t4);
            for i in 0..2 {
                let c = |f: &dyn Fn(usize) -> f64| f(0) + 2.0 * f(1) + 2.0 * f(2) + f(3);
                let ks = [&k1[i], &k2[i], &k3[i], &k4[i]];
                let dr = Vector3::from_fn(|k, _| c(&|j| ks[j].0[k]));
                let dq = nalgebra::Quaternion::new(
                    c(&|j| ks[j].1.w),
                    c(&|j| ks[j].1.i),
                    c(&|j| ks[j].1.j),
                    c(&|j| ks[j].1.k),
                );
                let dv = Vector3::from_fn(|k, _| c(&|j| ks[j].2[k]));
                let dw = Vector3::from_fn(|k, _| c(&|j| ks[j].3[k]));
                pose[i] = Pose::new(pose[i].r + dr * (h / 6.0), pose[i].q + dq * (h / 6.0));
                twist[i] = Twist {
                    v: twist[i].v + dv * (h / 6.0),
                    w: twist[i].w + dw * (h / 6.0),
                };
            }
            worst_e = worst_e.max((energy(&pose, &twist) - e0).abs());
        }
        (violation(&pose, &twist), worst_e / e0.abs().max(1.0), pose)
    };
    // Over 1 s: errors small and falling like h⁴ (measured: ratio 16.0 per halving).
    let (v1, e1, _) = run(500);
    let (v2, e2, pose) = run(1000);
    assert!(
        v2 < 1e-8 && e2 < 1e-8,
        "constraint drift {v2}, relative energy error {e2}"
    );
    assert!(v1 / v2 > 12.0, "constraint drift not O(h⁴): {v1} → {v2}");
    assert!(e1 / e2 > 12.0, "energy error not O(h⁴): {e1} → {e2}");
    // it actually moved
    assert!((pose[1].r - r2).norm() > 0.1);
}
