//! `natural_partitioning` allocates nothing per step (counting global allocator, per
//! thread): on a scene with a closed loop (cut joint, Newton + PCG path), a tree of
//! revolute, universal and prismatic joints and a free body; and on a pure tree, with
//! `rk4`, `dopri5` and `dop853` too (the error-controlled ones also with outputs inside
//! their steps, so through their dense output).

use mbdc_runtime::integrators::{make, State};
use mbdc_runtime::interp::{Interp, IDENTITY};
use mbdc_runtime::scene::*;
use mbdc_runtime::system::System;
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

fn count() -> usize {
    COUNT.with(|c| c.get())
}

/// A 1 m, 1 kg rod along body axis `axis`.
fn rod(name: &str, p: [f64; 3], axis: usize) -> Body {
    let mut j2 = [[0.0834, 0.0, 0.0], [0.0, 0.0834, 0.0], [0.0, 0.0, 0.0834]];
    j2[axis][axis] = 2e-4;
    Body {
        name: name.into(),
        mass: 1.0,
        inertia: j2,
        position: p,
        orientation: IDENTITY,
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        origin: Origin::default(),
    }
}

fn at(b: Option<usize>, p: [f64; 3]) -> Attachment {
    Attachment {
        body: b.map_or(BodyRef::Ground, BodyRef::Body),
        point: p,
        frame: IDENTITY,
    }
}

fn joint(name: &str, kind: JointKind, a: Attachment, b: Attachment) -> Joint {
    Joint {
        name: name.into(),
        kind,
        a,
        b,
        origin: Origin::default(),
    }
}

/// The four-bar of models/four_bar.mbd (5 spherical joints) under gravity along −z, a
/// revolute–universal–prismatic chain, and a free spinning body.
fn scene(with_loop: bool) -> Scene {
    let mut bodies = vec![
        rod("bar1", [0.0, 0.5, 0.0], 1),
        rod("bar2", [0.5, 1.0, 0.0], 0),
        rod("bar3", [1.5, 1.0, 0.0], 0),
        rod("bar4", [2.0, 0.5, 0.0], 1),
        rod("c1", [5.5, 0.0, 0.0], 0),
        rod("c2", [6.5, 0.0, 0.0], 0),
        rod("c3", [7.5, 0.0, 0.0], 0),
        rod("free", [10.0, 0.0, 0.0], 0),
    ];
    bodies[7].angular_velocity = [1.0, 2.0, 3.0];
    let mut joints = vec![
        joint(
            "j0",
            JointKind::Spherical,
            at(None, [0.0; 3]),
            at(Some(0), [0.0, -0.5, 0.0]),
        ),
        joint(
            "j1",
            JointKind::Spherical,
            at(Some(0), [0.0, 0.5, 0.0]),
            at(Some(1), [-0.5, 0.0, 0.0]),
        ),
        joint(
            "j2",
            JointKind::Spherical,
            at(Some(1), [0.5, 0.0, 0.0]),
            at(Some(2), [-0.5, 0.0, 0.0]),
        ),
        joint(
            "j3",
            JointKind::Spherical,
            at(Some(2), [0.5, 0.0, 0.0]),
            at(Some(3), [0.0, 0.5, 0.0]),
        ),
        joint(
            "c1",
            JointKind::Revolute,
            at(None, [5.0, 0.0, 0.0]),
            at(Some(4), [-0.5, 0.0, 0.0]),
        ),
        // cross axes: z on c1, y (the frame's z turned onto −y) on c2
        joint(
            "c2",
            JointKind::Universal,
            at(Some(4), [0.5, 0.0, 0.0]),
            Attachment {
                frame: [
                    std::f64::consts::FRAC_1_SQRT_2,
                    std::f64::consts::FRAC_1_SQRT_2,
                    0.0,
                    0.0,
                ],
                ..at(Some(5), [-0.5, 0.0, 0.0])
            },
        ),
        joint(
            "c3",
            JointKind::Prismatic,
            at(Some(5), [0.5, 0.0, 0.0]),
            at(Some(6), [-0.5, 0.0, 0.0]),
        ),
    ];
    if with_loop {
        joints.push(joint(
            "j4",
            JointKind::Spherical,
            at(Some(3), [0.0, -0.5, 0.0]),
            at(None, [2.0, 0.0, 0.0]),
        ));
    }
    Scene {
        name: "alloc".into(),
        gravity: Some([0.0, 0.0, -9.81]),
        bodies,
        joints,
        forces: Vec::new(),
        beams: Vec::new(),
        meshes: Vec::new(),
        contacts: Vec::new(),
        simulate: Simulate::default(),
        reference: None,
        params: Vec::new(),
    }
}

fn steps_allocate(with_loop: bool) -> usize {
    steps_allocate_with("natural_partitioning", with_loop)
}

fn steps_allocate_with(name: &str, with_loop: bool) -> usize {
    steps_allocate_at(name, with_loop, 1e-3).0
}

/// Allocations in 200 steps of `h` of the method `name` (default options), and its
/// `dense_outputs` statistic (0 without).
fn steps_allocate_at(name: &str, with_loop: bool, h: f64) -> (usize, f64) {
    let sys = Interp::new(&scene(with_loop)).expect("scene");
    let start = State::initial(&sys);
    let method = MethodSpec::default_for(name).unwrap();
    let mut it = make(&method, &sys, h, &start).expect("start");
    let mut st = State::initial(&sys);
    for _ in 0..3 {
        it.step(&sys).unwrap();
    }
    let before = count();
    for _ in 0..200 {
        it.step(&sys).unwrap();
        it.state(&sys, &mut st);
    }
    let n = count() - before;
    // the scene moved and stayed assembled
    assert!(st.pose[0].r.z < -1e-3, "bar 1 fell: {:?}", st.pose[0].r);
    assert_eq!(sys.layout().bodies(), 8);
    let dense = it
        .stats()
        .into_iter()
        .find(|(k, _)| *k == "dense_outputs")
        .map_or(0.0, |(_, v)| v);
    (n, dense)
}

#[test]
fn steps_with_a_cut_joint_do_not_allocate() {
    assert_eq!(steps_allocate(true), 0);
}

#[test]
fn steps_of_a_tree_do_not_allocate() {
    assert_eq!(steps_allocate(false), 0);
}

/// The Runge–Kutta methods on the same tree stages (the tree solve per stage, the
/// projection, the controller and the dense output) allocate nothing either: at a 1 ms
/// output step, and for the error-controlled methods at 20 ms, where the outputs fall
/// inside their internal steps (dop853's three extra dense-output stages included).
#[test]
fn runge_kutta_steps_of_a_tree_do_not_allocate() {
    for name in ["rk4", "dopri5", "dop853"] {
        assert_eq!(steps_allocate_with(name, false), 0, "{name}");
    }
    for name in ["dopri5", "dop853"] {
        let (n, dense) = steps_allocate_at(name, false, 0.02);
        assert!(dense > 0.0, "{name}: no output inside a step");
        assert_eq!(n, 0, "{name} with dense output");
    }
}

/// The Runge–Kutta methods on the scene with its cut joint (the cut-row matrix, its
/// filtered solve and the projection onto the loop at every stage and after every step,
/// and the multipliers of every reported state) allocate nothing either, with outputs at
/// the step's end and inside it.
#[test]
fn runge_kutta_steps_with_a_cut_joint_do_not_allocate() {
    for name in ["rk4", "dopri5", "dop853"] {
        assert_eq!(steps_allocate_with(name, true), 0, "{name}");
    }
    for name in ["dopri5", "dop853"] {
        let (n, dense) = steps_allocate_at(name, true, 0.02);
        assert!(dense > 0.0, "{name}: no output inside a step");
        assert_eq!(n, 0, "{name} with dense output");
    }
}
