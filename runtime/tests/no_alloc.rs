//! The per-step `System` methods of the interpreter do not allocate: checked with a
//! counting global allocator (per thread) on a scene that uses every joint kind, every
//! force element, a lock and every supported contact pair; and the meshes' steps with every
//! assembly strategy, counted on every thread of the pool that runs them.

use mbdc_runtime::interp::{Interp, IDENTITY};
use mbdc_runtime::math::{axis_angle, quat_array};
use mbdc_runtime::scene::*;
use mbdc_runtime::system::{ConstraintEval, Need, Pose, System, Twist, Wrench};
use nalgebra::Vector3;
use std::alloc::{GlobalAlloc, Layout, System as Sys};
use std::cell::Cell;

struct Counting;

thread_local! {
    static COUNT: Cell<usize> = const { Cell::new(0) };
}

fn bump() {
    let _ = COUNT.try_with(|c| c.set(c.get() + 1));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        bump();
        unsafe { Sys.alloc(l) }
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        bump();
        unsafe { Sys.alloc_zeroed(l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        bump();
        unsafe { Sys.realloc(p, l, n) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { Sys.dealloc(p, l) }
    }
}

#[global_allocator]
static A: Counting = Counting;

fn allocations<R>(f: impl FnOnce() -> R) -> (R, usize) {
    let before = COUNT.with(|c| c.get());
    let r = f();
    (r, COUNT.with(|c| c.get()) - before)
}

fn scene() -> Scene {
    let mk = |name: &str, p: [f64; 3], ang: f64| Body {
        name: name.into(),
        mass: 1.0,
        inertia: [[0.1, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.3]],
        position: p,
        orientation: quat_array(&axis_angle(&Vector3::new(1.0, 2.0, 3.0), ang)),
        velocity: [0.1, -0.2, 0.3],
        angular_velocity: [0.4, 0.5, -0.6],
        origin: Origin::default(),
    };
    let a = Attachment {
        body: BodyRef::Body(0),
        point: [0.1, 0.2, 0.3],
        frame: IDENTITY,
    };
    let b = Attachment {
        body: BodyRef::Body(1),
        point: [-0.2, 0.1, 0.0],
        frame: IDENTITY,
    };
    let g = Attachment {
        body: BodyRef::Ground,
        point: [0.0; 3],
        frame: IDENTITY,
    };
    let t = || Fn1::Unary(UnaryFn::Sin, Box::new(Fn1::Var));
    let table = Fn1::Table(Box::new(Fn1::Var), vec![[0.0, 0.0], [1.0, 2.0], [2.0, 1.0]]);
    let kinds = vec![
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
                angle: t(),
            },
            b,
        ),
        (
            JointKind::DriveDisplacement {
                joint: 2,
                displacement: table,
            },
            b,
        ),
        (JointKind::Rolling { radius: 0.3 }, g),
        (
            JointKind::PointVelocity {
                velocity: [t(), Fn1::Const(1.0), Fn1::Var],
            },
            g,
        ),
        (
            JointKind::Curve {
                curve: Fn1::JacobiSn(Box::new(Fn1::Var), 0.5),
            },
            b,
        ),
    ];
    let joints = kinds
        .into_iter()
        .enumerate()
        .map(|(i, (kind, bb))| Joint {
            name: format!("j{i}"),
            kind,
            a,
            b: bb,
            origin: Origin::default(),
        })
        .collect();
    let force = |name: &str, kind| Force {
        name: name.into(),
        kind,
        origin: Origin::default(),
    };
    let contact = |name: &str, sa, sb, ga: Attachment| Contact {
        name: name.into(),
        a: (ga, sa),
        b: (g, sb),
        stiffness: 1e4,
        damping: 5.0,
        friction: 0.4,
        origin: Origin::default(),
    };
    Scene {
        name: "all".into(),
        gravity: Some([0.0, 0.0, -9.81]),
        bodies: vec![
            mk("a", [0.1, 0.2, 0.25], 0.5),
            mk("b", [-0.3, 0.4, 0.2], 1.2),
            mk("c", [0.0, 0.0, 0.05], 0.1),
        ],
        joints,
        forces: vec![
            force(
                "p",
                ForceKind::Point {
                    at: a,
                    value: [t(), Fn1::Const(2.0), Fn1::Var],
                    frame: ForceFrame::Body,
                },
            ),
            force(
                "m",
                ForceKind::Torque {
                    body: BodyRef::Body(1),
                    value: [t(), t(), t()],
                    frame: ForceFrame::World,
                },
            ),
            force(
                "s",
                ForceKind::Spring {
                    a,
                    b,
                    stiffness: 10.0,
                    rest_length: 0.2,
                    damping: 1.0,
                },
            ),
            force(
                "r",
                ForceKind::RotationalSpring {
                    joint: 1,
                    stiffness: 3.0,
                    rest_angle: 0.1,
                    damping: 0.2,
                    lock_angle: Some(0.4),
                },
            ),
        ],
        beams: vec![],
        meshes: vec![],
        contacts: vec![
            contact("sp", Shape::Sphere { radius: 0.3 }, Shape::Plane, a),
            contact(
                "bp",
                Shape::Box {
                    half_extents: [0.1, 0.2, 0.1],
                },
                Shape::Plane,
                Attachment {
                    body: BodyRef::Body(2),
                    ..a
                },
            ),
            Contact {
                b: (b, Shape::Sphere { radius: 0.4 }),
                ..contact("ss", Shape::Sphere { radius: 0.4 }, Shape::Plane, a)
            },
        ],
        simulate: Simulate::default(),
        reference: None,
        params: vec![],
    }
}

#[test]
fn per_step_methods_do_not_allocate() {
    let sys = Interp::new(&scene()).unwrap();
    let lay = sys.layout();
    let n = lay.bodies();
    let mut pose = vec![Pose::default(); n];
    let mut twist = vec![Twist::default(); n];
    let mut w = vec![Wrench::default(); n];
    let mut ev = ConstraintEval::new(lay.rows);
    let mut active = vec![false; lay.rows];
    let ((), count) = allocations(|| {
        sys.initial_state(&mut pose, &mut twist);
        for k in 0..10 {
            let t = 0.1 * k as f64;
            sys.applied(t, &pose, &twist, &mut w);
            sys.constraints(t, &pose, &twist, Need::ALL, &mut ev);
            sys.constraints(t, &pose, &twist, Need::PHI, &mut ev);
            let _ = sys.potential_energy(t, &pose);
            let _ = sys.update_locks(&pose, &twist, &mut active);
            let _ = sys.has_velocity_forces();
        }
    });
    assert_eq!(count, 0, "allocations in per-step methods");
    // the scene really exercised contact and all the rows
    assert!(w.iter().all(|x| x.f.iter().all(|v| v.is_finite())));
    assert!(ev.phi.iter().all(|v| v.is_finite()) && ev.gamma.iter().all(|v| v.is_finite()));
    assert_eq!(lay.rows, scene().constraint_rows() + 1);
    assert!(sys.has_velocity_forces());
    assert_eq!(sys.force_terms(), 4 + 3);
    // and the allocator does count
    let (_, c) = allocations(|| vec![1u8; 16]);
    assert!(c >= 1);
}

/// A NaN state (a diverged run) must flow through every per-step method as NaN, never
/// as a panic, so that integrators can stop and report it.
#[test]
fn nan_state_does_not_panic() {
    let sys = Interp::new(&scene()).unwrap();
    let lay = sys.layout();
    let n = lay.bodies();
    let mut pose = vec![Pose::default(); n];
    let mut twist = vec![Twist::default(); n];
    sys.initial_state(&mut pose, &mut twist);
    for p in pose.iter_mut() {
        p.r = Vector3::new(f64::NAN, 0.0, f64::NAN);
        p.q = nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0);
        p.c[(0, 0)] = f64::NAN;
    }
    twist[0].w = Vector3::new(f64::INFINITY, f64::NAN, 0.0);
    let mut w = vec![Wrench::default(); n];
    let mut ev = ConstraintEval::new(lay.rows);
    let mut active = vec![false; lay.rows];
    sys.applied(f64::NAN, &pose, &twist, &mut w);
    sys.constraints(f64::NAN, &pose, &twist, Need::ALL, &mut ev);
    assert!(sys.potential_energy(0.0, &pose).is_nan());
    let _ = sys.update_locks(&pose, &twist, &mut active);
    assert!(ev.phi.iter().any(|v| v.is_nan()));
}

/// A staggered step of a scene with a damped beam (nodes, elements, a clamp to the ground,
/// the synchronized state with the element states) does not allocate.
#[test]
fn beam_steps_do_not_allocate() {
    use mbdc_runtime::integrators::{self, State};
    // the beam alone, in gravity (the joint scene above is for evaluations, not for steps)
    let mut s = scene();
    s.contacts.clear();
    s.bodies.clear();
    s.joints.clear();
    s.forces.clear();
    s.beams.push(Beam {
        name: "arm".into(),
        nodes: (0..=20).map(|k| [0.05 * k as f64, 1.0, 0.5]).collect(),
        up: [0.0, 0.0, 1.0],
        section: Section {
            ea: 1e4,
            ga2: 1e4,
            ga3: 1e4,
            ei2: 10.0,
            ei3: 10.0,
            gj: 10.0,
            rho_a: 1.0,
            rho_i: 1e-2,
        },
        attachments: vec![BeamAttachment {
            node: 0,
            to: Attachment {
                body: BodyRef::Ground,
                point: [0.0, 1.0, 0.5],
                frame: [1.0, 0.0, 0.0, 0.0],
            },
            clamped: true,
        }],
        damping: 1e-5,
        rotary_inertia_scale: 10.0,
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        origin: Origin::default(),
    });
    let sys = Interp::new(&s).unwrap();
    let start = State::initial(&sys);
    let method = MethodSpec::default_for("staggered").unwrap();
    let mut it = integrators::make(&method, &sys, 1e-4, &start).unwrap();
    let mut st = start.clone();
    // one step outside the count (the state's buffers take their size)
    it.step(&sys).unwrap();
    it.state(&sys, &mut st);
    let ((), count) = allocations(|| {
        for _ in 0..20 {
            it.step(&sys).unwrap();
            it.state(&sys, &mut st);
            let _ = st.strain_energy();
        }
    });
    assert_eq!(count, 0, "allocations in beam steps");
    assert_eq!(st.beams.len(), 20);
    assert!(st.strain_energy() > 0.0, "gravity bends the beam");
}

/// A hex8 box `nx × ny × nz` of unit cells, clamped at x = 0, with a traction on the face
/// x = nx and gravity as a body force.
fn box_mesh(nx: usize, ny: usize, nz: usize) -> Mesh {
    let id = |i: usize, j: usize, k: usize| k * (nx + 1) * (ny + 1) + j * (nx + 1) + i;
    let mut nodes = Vec::new();
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                nodes.push([0.1 * i as f64, 0.1 * j as f64, 0.1 * k as f64]);
            }
        }
    }
    let mut elements = Vec::new();
    let mut end_faces = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if i == nx - 1 {
                    end_faces.push((elements.len(), 3));
                }
                elements.push(vec![
                    id(i, j, k),
                    id(i + 1, j, k),
                    id(i + 1, j + 1, k),
                    id(i, j + 1, k),
                    id(i, j, k + 1),
                    id(i + 1, j, k + 1),
                    id(i + 1, j + 1, k + 1),
                    id(i, j + 1, k + 1),
                ]);
            }
        }
    }
    let set =
        |i: usize| -> Vec<usize> { (0..nodes.len()).filter(|&n| n % (nx + 1) == i).collect() };
    Mesh {
        name: "block".into(),
        kind: ElementKind::Hex8,
        material: Material {
            e: 2e11,
            nu: 0.3,
            rho: 7850.0,
            plastic: None,
        },
        thickness: 1.0,
        node_sets: vec![
            NodeSet {
                name: "root".into(),
                nodes: set(0),
                faces: vec![],
            },
            NodeSet {
                name: "end".into(),
                nodes: set(nx),
                faces: end_faces,
            },
        ],
        nodes,
        elements,
        conditions: vec![
            MeshCondition::Fixed { set: 0 },
            MeshCondition::Traction {
                set: 1,
                value: [
                    Fn1::Const(0.0),
                    Fn1::Mul(Box::new(Fn1::Const(1e6)), Box::new(Fn1::Var)),
                    Fn1::Const(0.0),
                ],
            },
            MeshCondition::BodyForce {
                value: [0.0, 0.0, -7850.0 * 9.81],
            },
        ],
        formulation: MeshFormulation::default(),
        origin: Origin::default(),
    }
}

/// Mesh steps (element loop, gather, update, energy balance, the synchronized state) do not
/// allocate, on the serial path (a small block) and the parallel one (≥ 2048 elements),
/// elastic and elastoplastic (the return mapping at the 8 points of every element, the
/// plastic work, the points' state copied into the synchronized state).
#[test]
fn mesh_steps_do_not_allocate() {
    use mbdc_runtime::integrators::{self, State};
    use mbdc_runtime::scene::Plasticity;
    // A yield stress the first steps exceed, so that the returns do flow.
    let plastic = Plasticity {
        yield_stress: 1e-3,
        hardening: 1e9,
    };
    for (nx, ny, nz, plastic) in [
        (4, 2, 2, None),
        (16, 12, 12, None),
        (4, 2, 2, Some(plastic)),
        (16, 12, 12, Some(plastic)),
    ] {
        let mut s = scene();
        s.contacts.clear();
        s.bodies.clear();
        s.joints.clear();
        s.forces.clear();
        let mut mesh = box_mesh(nx, ny, nz);
        mesh.material.plastic = plastic;
        s.meshes.push(mesh);
        let sys = Interp::new(&s).unwrap();
        let start = State::initial(&sys);
        let method = MethodSpec::default_for("staggered").unwrap();
        let mut it = integrators::make(&method, &sys, 1e-7, &start).unwrap();
        let mut st = start.clone();
        // one step outside the count (the state's buffers take their size, rayon starts)
        it.step(&sys).unwrap();
        it.state(&sys, &mut st);
        let ((), count) = allocations(|| {
            for _ in 0..10 {
                it.step(&sys).unwrap();
                it.state(&sys, &mut st);
                let _ = st.strain_energy();
            }
        });
        assert_eq!(
            count, 0,
            "allocations in mesh steps ({nx}×{ny}×{nz}, plastic {plastic:?})"
        );
        assert_eq!(st.mesh.stress.len(), nx * ny * nz);
        assert!(st.mesh.energy.strain > 0.0, "the load deforms the block");
        if plastic.is_some() {
            assert_eq!(st.mesh.equivalent_plastic_strain.len(), nx * ny * nz);
            assert!(st.mesh.energy.plastic > 0.0, "the block yields");
            assert!(st.mesh.equivalent_plastic_strain.iter().any(|&a| a > 0.0));
        } else {
            assert!(st.mesh.plastic.is_empty() && st.mesh.equivalent_plastic_strain.is_empty());
        }
    }
}

/// Steps of a mesh tied to a body (the ties' wrench, the rigid step with it, placing the
/// tied nodes, the mesh step, the synchronized state with the newest wrench) do not
/// allocate: a hub turning on a revolute joint in gravity with the block tied by its root
/// face, with every rigid method that takes ties.
#[test]
fn tied_mesh_steps_do_not_allocate() {
    use mbdc_runtime::integrators::{self, State};
    let mut s = scene();
    s.contacts.clear();
    s.forces.clear();
    s.joints.clear();
    s.bodies.truncate(1);
    s.bodies[0].position = [-0.1, 0.1, 0.1];
    s.bodies[0].velocity = [0.0; 3];
    s.bodies[0].angular_velocity = [0.0, 0.0, 0.0];
    s.bodies[0].orientation = [1.0, 0.0, 0.0, 0.0];
    s.joints.push(Joint {
        name: "hinge".into(),
        kind: JointKind::Revolute,
        a: Attachment {
            body: BodyRef::Ground,
            point: [-0.2, 0.1, 0.1],
            frame: IDENTITY,
        },
        b: Attachment {
            body: BodyRef::Body(0),
            point: [-0.1, 0.0, 0.0],
            frame: IDENTITY,
        },
        origin: Origin::default(),
    });
    let mut m = box_mesh(4, 2, 2);
    m.conditions[0] = MeshCondition::Tie { set: 0, body: 0 };
    s.meshes.push(m);
    let sys = Interp::new(&s).unwrap();
    assert_eq!(sys.layout().meshes.ties.len(), 1);
    for name in ["staggered", "baumgarte", "penalty", "natural_partitioning"] {
        let start = State::initial(&sys);
        let method = MethodSpec::default_for(name).unwrap();
        let mut it = integrators::make(&method, &sys, 1e-7, &start).unwrap();
        let mut st = start.clone();
        it.step(&sys).unwrap();
        it.state(&sys, &mut st);
        let ((), count) = allocations(|| {
            for _ in 0..10 {
                it.step(&sys).unwrap();
                it.state(&sys, &mut st);
                let _ = st.strain_energy();
            }
        });
        assert_eq!(count, 0, "allocations in tied mesh steps ({name})");
        assert!(
            st.mesh.energy.strain > 0.0,
            "{name}: its weight bends the block"
        );
        // the system's hub is the hub with its tied nodes, its reference point pulled
        // towards them
        assert!(st.pose[0].r.x > -0.09, "{name}: {:?}", st.pose[0].r);
    }
}

/// Allocations on the calling thread and on every thread of `pool` while `f` runs in it.
fn pool_allocations<R: Send>(pool: &rayon::ThreadPool, f: impl FnOnce() -> R + Send) -> (R, usize) {
    let count =
        |p: &rayon::ThreadPool| -> usize { p.broadcast(|_| COUNT.with(|c| c.get())).iter().sum() };
    let before = count(pool);
    let (r, here) = allocations(|| pool.install(f));
    (r, here + count(pool) - before)
}

/// Each assembly strategy's steps (element pass, assembly, node passes, update, energy) do
/// not allocate, on any thread: a hex8 block above the parallel threshold with 4 partitions,
/// in a pool of 2 threads, and a small block on the serial paths.
#[test]
fn mesh_steps_do_not_allocate_with_any_assembly() {
    use mbdc_runtime::integrators::mesh_dynamics::MeshDynamics;
    use mbdc_runtime::integrators::MeshState;
    use mbdc_runtime::mesh_model;
    use mbdc_runtime::mesh_plan::{Assembly, AssemblyOptions};
    use std::sync::Arc;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    // The counting itself (and an empty task) allocates nothing on the pool's threads.
    let ((), base) = pool_allocations(&pool, || ());
    assert_eq!(base, 0, "the count's own allocations");
    for (nx, ny, nz) in [(4, 2, 2), (16, 12, 12)] {
        let meshes = vec![box_mesh(nx, ny, nz)];
        for strategy in Assembly::ALL {
            let options = AssemblyOptions {
                strategy,
                partition_elements: 460,
                max_interface: 1.0,
                ..AssemblyOptions::default()
            };
            let l = Arc::new(mesh_model::build_with(&meshes, options).unwrap());
            let mut md = MeshDynamics::new(l.clone(), 1e-7, 0.0, &MeshState::default()).unwrap();
            let mut st = MeshState::default();
            // one step outside the count (the state's buffers take their size, the pool's
            // queues grow)
            pool.install(|| md.step()).unwrap();
            md.state(&mut st);
            let ((), count) = pool_allocations(&pool, || {
                for _ in 0..10 {
                    md.step().unwrap();
                    md.state(&mut st);
                }
            });
            let name = strategy.name();
            assert_eq!(
                count, 0,
                "allocations in {name} mesh steps ({nx}×{ny}×{nz})"
            );
            assert!(st.energy.strain > 0.0, "the load deforms the block");
            if nx == 16 {
                assert_eq!(l.assembly.blocks[0].partitions(), 4);
            }
        }
    }
}

/// Steps of the implicit mesh analyses (Newmark and static) do not allocate on any thread,
/// with the direct factorization and with FETI (its subdomain solves on the pool, the
/// interface iterations, the coarse problem, the recovery, the residual check).
#[test]
fn implicit_mesh_steps_do_not_allocate_with_either_solver() {
    use mbdc_runtime::integrators::mesh_implicit::MeshImplicit;
    use mbdc_runtime::integrators::MeshState;
    use mbdc_runtime::scene::{FetiOptions, MeshMethod, MeshSolver};
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    for method in [MeshMethod::Newmark, MeshMethod::Static] {
        for solver in [
            MeshSolver::Direct,
            MeshSolver::Feti(FetiOptions {
                subdomains: 4,
                ..FetiOptions::default()
            }),
        ] {
            let mut s = scene();
            s.contacts.clear();
            s.bodies.clear();
            s.joints.clear();
            s.forces.clear();
            s.meshes.push(box_mesh(8, 2, 2));
            s.simulate.mesh_method = method;
            s.simulate.mesh_solver = solver;
            // Everything on the private pool: the other tests of this binary count the
            // global pool's queue, which this one must not touch.
            let mut it = pool
                .install(|| {
                    let sys = Interp::new(&s).unwrap();
                    let l = sys.layout().meshes.clone();
                    MeshImplicit::new(l, method, 1e-4, 0.0, &MeshState::default())
                })
                .unwrap();
            let mut st = MeshState::default();
            pool.install(|| it.advance()).unwrap();
            it.mesh_state(&mut st);
            let ((), count) = pool_allocations(&pool, || {
                for _ in 0..5 {
                    it.advance().unwrap();
                    it.mesh_state(&mut st);
                }
            });
            assert_eq!(
                count,
                0,
                "allocations in {} steps with {}",
                method.name(),
                solver.name()
            );
            assert_eq!(it.feti().is_some(), !solver.is_direct());
            assert!(st.energy.strain > 0.0, "the load deforms the block");
        }
    }
}

/// FETI across ranks (ranks as threads, each rank on a private pool of two threads): after
/// the first step, a rank's steps allocate nothing on its own thread or its pool's — the
/// sums over ranks included (their boards grow on the first use only). Newmark and static,
/// 2 ranks of 2 subdomains each.
#[test]
fn ranked_feti_steps_do_not_allocate() {
    use mbdc_runtime::integrators::mesh_implicit::MeshImplicit;
    use mbdc_runtime::integrators::MeshState;
    use mbdc_runtime::scene::{FetiOptions, MeshMethod, MeshSolver};
    use mbdc_runtime::thread_ranks::ThreadRanks;
    for method in [MeshMethod::Newmark, MeshMethod::Static] {
        let mut s = scene();
        s.contacts.clear();
        s.bodies.clear();
        s.joints.clear();
        s.forces.clear();
        s.meshes.push(box_mesh(8, 2, 2));
        s.simulate.mesh_method = method;
        s.simulate.mesh_solver = MeshSolver::Feti(FetiOptions {
            subdomains: 4,
            ..FetiOptions::default()
        });
        let setup = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let l = setup.install(|| Interp::new(&s).unwrap().layout().meshes.clone());
        let counts = ThreadRanks::run(2, |r| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(2)
                .build()
                .unwrap();
            let mut it = pool
                .install(|| {
                    MeshImplicit::on_ranks(
                        l.clone(),
                        method,
                        1e-4,
                        0.0,
                        &MeshState::default(),
                        Some(r),
                    )
                })
                .unwrap();
            let mut st = MeshState::default();
            pool.install(|| it.advance()).unwrap();
            it.mesh_state(&mut st);
            let ((), count) = pool_allocations(&pool, || {
                for _ in 0..5 {
                    it.advance().unwrap();
                    it.mesh_state(&mut st);
                }
            });
            let f = it.feti().unwrap();
            assert_eq!((f.ranks(), f.subdomains_here().len()), (2, 2));
            assert!(f.stats().summed_bytes > 0);
            assert!(st.energy.strain > 0.0, "the load deforms the block");
            count
        });
        assert_eq!(
            counts,
            vec![0, 0],
            "allocations in ranked FETI {} steps",
            method.name()
        );
    }
}

/// Asking whether to stop, which the run loop does after every step (issue 22: SIGINT and
/// SIGTERM end a run honestly), allocates nothing: with no signal and with one received.
#[cfg(unix)]
#[test]
fn asking_whether_a_signal_stops_the_run_does_not_allocate() {
    use mbdc_runtime::app::{Signal, StopSignals};
    let signals = StopSignals::install().expect("handlers");
    let (r, count) = allocations(|| (0..1000).filter_map(|_| signals.received()).count());
    assert_eq!((r, count), (0, 0));
    // SIGTERM is a request while installed (SIGINT's second delivery would end the process)
    signal_hook::low_level::raise(signal_hook::consts::SIGTERM).expect("raise");
    let (r, count) = allocations(|| signals.received().map(Signal::name));
    assert_eq!((r, count), (Some("SIGTERM"), 0));
}

/// One rank's steps of the explicit method across ranks (its element pass, the exchange of
/// interface forces, the energies summed over the ranks, the agreed failure flags) do not
/// allocate: three ranks as threads, each counting its own thread's allocations after a
/// first step (which sizes the engine's boards).
#[test]
fn ranked_mesh_steps_do_not_allocate() {
    use mbdc_runtime::integrators::mesh_dynamics::MeshDynamics;
    use mbdc_runtime::integrators::mesh_kernels::BlockKernels;
    use mbdc_runtime::integrators::MeshState;
    use mbdc_runtime::thread_ranks::ThreadRanks;
    use mbdc_runtime::{mesh_model, mesh_ranks};
    use std::sync::Arc;
    let l = mesh_model::build(&[box_mesh(6, 2, 2)]).unwrap();
    let counts = ThreadRanks::run(3, |r| {
        let map = mesh_ranks::rank_map(&l, 3).unwrap();
        let part = Arc::new(mesh_ranks::rank_part(&l, &map, r.rank()).unwrap().layout);
        let kernels = BlockKernels::interpreted(&part);
        let mut md =
            MeshDynamics::on_ranks(part, &kernels, 1e-7, 0.0, &MeshState::default(), Some(r))
                .unwrap();
        let mut st = MeshState::default();
        md.step().unwrap();
        md.state(&mut st);
        let ((), count) = allocations(|| {
            for _ in 0..10 {
                md.step().unwrap();
                md.state(&mut st);
            }
        });
        (count, st.energy.strain)
    });
    for (rank, (count, strain)) in counts.iter().enumerate() {
        assert_eq!(*count, 0, "allocations in rank {rank}'s steps");
        assert!(*strain > 0.0, "the load deforms the block");
    }
}
