//! Property tests of the joint kernels along random rigid-body motions.
//!
//! Each body moves with `r(t) = r0 + v0 t + ½ a t²`, body-frame `ω(t) = ω0 + α t` and
//! `q(t)` from `q̇ = ½ q ⊗ (0, ω)` integrated by RK4 with steps of 1e-4 s (local error
//! ~ (|ω| dt)⁵ ≈ 1e-18, far below the finite-difference error). At `t = 0`, `u̇ = (v0, ω0)`
//! and `u̇' = (a, α)`.
//!
//! Checks, for every joint kind:
//! (a) holonomic rows: `dΦ/dt` (4th-order central difference, step δ = 1e-3) equals
//!     `B u̇ + bias`;
//! (b) holonomic rows: `d²Φ/dt²` equals `B u̇' − gamma`; nonholonomic rows: `d(phi)/dt`
//!     equals `B u̇' − gamma`.
//!
//! Tolerance: the 4th-order stencils have truncation error ~δ⁴ Φ⁽⁵⁾/30 ≈ 1e-12 and
//! round-off ~30 ε |Φ| / (12 δ²) ≈ 5e-10 |Φ| (second derivative), so a relative bound of
//! 1e-6 on `1 + |terms|` leaves three orders of margin while any missing term
//! (O(1) for these motions) is caught.
//!
//! Also: joints assembled at a random configuration have `Φ = 0`, stay at `Φ = 0` under a
//! rigid motion of both bodies together, and have `B u̇ + bias = 0` for a common rigid
//! velocity field.

use mbdc_runtime::fn1::Jet2;
use mbdc_runtime::joints::{self, JointGeom, JointOut};
use mbdc_runtime::math::{axis_angle, qmul, quat_array, quat_rate, rotate};
use mbdc_runtime::scene::{Attachment, BodyRef};
use mbdc_runtime::system::{ConstraintEval, Need, Pose, Twist};
use nalgebra::{Quaternion, Vector3};
use proptest::prelude::*;

/// The joint kinds under test (time functions are fixed closed forms with random
/// coefficients).
#[derive(Clone, Copy, Debug, PartialEq)]
enum K {
    Spherical,
    Revolute,
    Prismatic,
    Cylindrical,
    Universal,
    Fixed,
    Planar,
    Distance,
    DriveAngle,
    DriveDisplacement,
    Rolling,
    PointVelocity,
    Curve,
}

const ALL: [K; 13] = [
    K::Spherical,
    K::Revolute,
    K::Prismatic,
    K::Cylindrical,
    K::Universal,
    K::Fixed,
    K::Planar,
    K::Distance,
    K::DriveAngle,
    K::DriveDisplacement,
    K::Rolling,
    K::PointVelocity,
    K::Curve,
];

impl K {
    fn rows(self) -> usize {
        match self {
            K::Spherical | K::Planar | K::Rolling | K::PointVelocity => 3,
            K::Revolute | K::Prismatic => 5,
            K::Cylindrical | K::Universal => 4,
            K::Fixed => 6,
            K::Distance | K::DriveAngle | K::DriveDisplacement | K::Curve => 1,
        }
    }
    fn nonholonomic(self) -> usize {
        match self {
            K::Rolling => 2,
            K::PointVelocity => 3,
            _ => 0,
        }
    }
    fn b_must_be_ground(self) -> bool {
        matches!(self, K::Rolling | K::PointVelocity)
    }
}

/// Coefficients of the time functions `f(t) = c0 + c1 sin(c2 t + c3) + c4 t²`.
#[derive(Clone, Copy, Debug)]
struct TimeFn([f64; 5]);

impl TimeFn {
    fn at(&self, x: f64) -> Jet2 {
        let c = self.0;
        let x = Jet2::var(x);
        Jet2::constant(c[0]) + (x * c[2] + c[3]).sin() * c[1] + x * x * c[4]
    }
}

fn eval(
    k: K,
    g: &JointGeom,
    f: &[TimeFn; 3],
    t: f64,
    p: [&Pose; 2],
    w: [&Twist; 2],
    need: Need,
) -> ConstraintEval {
    let mut ev = ConstraintEval::new(k.rows());
    let out = JointOut::new(&mut ev, 0, k.rows());
    let (pa, pb, ta, tb) = (p[0], p[1], w[0], w[1]);
    match k {
        K::Spherical => joints::spherical(g, pa, pb, ta, tb, need, out),
        K::Revolute => joints::revolute(g, pa, pb, ta, tb, need, out),
        K::Prismatic => joints::prismatic(g, pa, pb, ta, tb, need, out),
        K::Cylindrical => joints::cylindrical(g, pa, pb, ta, tb, need, out),
        K::Universal => joints::universal(g, pa, pb, ta, tb, need, out),
        K::Fixed => joints::fixed(g, pa, pb, ta, tb, need, out),
        K::Planar => joints::planar(g, pa, pb, ta, tb, need, out),
        K::Distance => joints::distance_joint(g, pa, pb, ta, tb, need, out),
        K::DriveAngle => joints::drive_angle(g, f[0].at(t), pa, pb, ta, tb, need, out),
        K::DriveDisplacement => {
            joints::drive_displacement(g, f[0].at(t), pa, pb, ta, tb, need, out)
        }
        K::Rolling => joints::rolling(g, pa, pb, ta, tb, need, out),
        K::PointVelocity => joints::point_velocity(
            g,
            [f[0].at(t), f[1].at(t), f[2].at(t)],
            pa,
            pb,
            ta,
            tb,
            need,
            out,
        ),
        K::Curve => joints::curve(g, |x| f[0].at(x), pa, pb, ta, tb, need, out),
    }
    ev
}

/// A body moving with constant acceleration and constant body-frame angular acceleration.
#[derive(Clone, Copy, Debug)]
struct Motion {
    r0: Vector3<f64>,
    v0: Vector3<f64>,
    a: Vector3<f64>,
    q0: Quaternion<f64>,
    w0: Vector3<f64>,
    al: Vector3<f64>,
    ground: bool,
}

impl Motion {
    fn ground() -> Motion {
        Motion {
            r0: Vector3::zeros(),
            v0: Vector3::zeros(),
            a: Vector3::zeros(),
            q0: Quaternion::identity(),
            w0: Vector3::zeros(),
            al: Vector3::zeros(),
            ground: true,
        }
    }

    fn omega(&self, t: f64) -> Vector3<f64> {
        self.w0 + self.al * t
    }

    fn state(&self, t: f64) -> (Pose, Twist) {
        if self.ground {
            return (Pose::default(), Twist::default());
        }
        let n = ((t.abs() / 1e-4).ceil() as usize).max(1);
        let h = t / n as f64;
        let mut q = self.q0;
        let mut s = 0.0;
        for _ in 0..n {
            let k1 = quat_rate(&q, &self.omega(s));
            let k2 = quat_rate(&(q + k1 * (0.5 * h)), &self.omega(s + 0.5 * h));
            let k3 = quat_rate(&(q + k2 * (0.5 * h)), &self.omega(s + 0.5 * h));
            let k4 = quat_rate(&(q + k3 * h), &self.omega(s + h));
            q += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
            s += h;
        }
        let r = self.r0 + self.v0 * t + self.a * (0.5 * t * t);
        (
            Pose::new(r, q),
            Twist {
                v: self.v0 + self.a * t,
                w: self.omega(t),
            },
        )
    }
}

fn v3(s: f64) -> impl Strategy<Value = Vector3<f64>> {
    prop::array::uniform3(-s..s).prop_map(|a| Vector3::new(a[0], a[1], a[2]))
}

fn unit_quat() -> impl Strategy<Value = Quaternion<f64>> {
    (prop::array::uniform4(-1.0f64..1.0)).prop_filter_map("degenerate", |a| {
        let q = Quaternion::new(a[0], a[1], a[2], a[3]);
        let n = q.norm();
        (n > 0.2).then(|| q / n)
    })
}

fn motion() -> impl Strategy<Value = Motion> {
    (v3(2.0), v3(2.0), v3(3.0), unit_quat(), v3(3.0), v3(3.0)).prop_map(
        |(r0, v0, a, q0, w0, al)| Motion {
            r0,
            v0,
            a,
            q0,
            w0,
            al,
            ground: false,
        },
    )
}

fn time_fn() -> impl Strategy<Value = TimeFn> {
    prop::array::uniform5(-1.5f64..1.5).prop_map(TimeFn)
}

fn geom() -> impl Strategy<Value = JointGeom> {
    (v3(1.0), v3(1.0), unit_quat(), unit_quat(), 0.3f64..2.0).prop_map(|(pa, pb, qa, qb, param)| {
        JointGeom::new(
            &Attachment {
                body: BodyRef::Body(0),
                point: pa.into(),
                frame: quat_array(&qa),
            },
            &Attachment {
                body: BodyRef::Body(1),
                point: pb.into(),
                frame: quat_array(&qb),
            },
            param,
        )
    })
}

fn jac_dot(ev: &ConstraintEval, i: usize, a: &Motion, b: &Motion, acc: bool) -> f64 {
    let (va, wa) = if acc { (a.a, a.al) } else { (a.v0, a.w0) };
    let (vb, wb) = if acc { (b.a, b.al) } else { (b.v0, b.w0) };
    let ua = [va.x, va.y, va.z, wa.x, wa.y, wa.z];
    let ub = [vb.x, vb.y, vb.z, wb.x, wb.y, wb.z];
    let j = &ev.jac[i];
    let mut s = 0.0;
    for k in 0..6 {
        if !a.ground {
            s += j.a[k] * ua[k];
        }
        if !b.ground {
            s += j.b[k] * ub[k];
        }
    }
    s
}

/// Check (a) and (b) for one joint along the motions; returns an error message.
fn check_derivatives(
    k: K,
    g: &JointGeom,
    f: &[TimeFn; 3],
    a: &Motion,
    b: &Motion,
) -> Result<(), String> {
    let d = 1e-3;
    let ts = [-2.0 * d, -d, 0.0, d, 2.0 * d];
    let evs: Vec<ConstraintEval> = ts
        .iter()
        .map(|&t| {
            let (pa, ta) = a.state(t);
            let (pb, tb) = b.state(t);
            eval(k, g, f, t, [&pa, &pb], [&ta, &tb], Need::ALL)
        })
        .collect();
    let e0 = &evs[2];
    let first_nh = k.rows() - k.nonholonomic();
    for i in 0..k.rows() {
        let p: Vec<f64> = evs.iter().map(|e| e.phi[i]).collect();
        let fd1 = (p[0] - 8.0 * p[1] + 8.0 * p[3] - p[4]) / (12.0 * d);
        let fd2 = (-p[0] + 16.0 * p[1] - 30.0 * p[2] + 16.0 * p[3] - p[4]) / (12.0 * d * d);
        let bu = jac_dot(e0, i, a, b, false);
        let bacc = jac_dot(e0, i, a, b, true);
        let scale = 1.0 + p[2].abs() + bu.abs() + bacc.abs() + e0.bias[i].abs() + e0.gamma[i].abs();
        if i < first_nh {
            let an1 = bu + e0.bias[i];
            if (fd1 - an1).abs() > 1e-6 * scale {
                return Err(format!("{k:?} row {i}: dΦ/dt fd {fd1} vs B u̇ + bias {an1}"));
            }
            let an2 = bacc - e0.gamma[i];
            if (fd2 - an2).abs() > 1e-6 * scale {
                return Err(format!("{k:?} row {i}: d²Φ/dt² fd {fd2} vs B u̇' − γ {an2}"));
            }
        } else {
            let an = bacc - e0.gamma[i];
            if (fd1 - an).abs() > 1e-6 * scale {
                return Err(format!(
                    "{k:?} row {i} (nonholonomic): dΦ/dt fd {fd1} vs B u̇' − γ {an}"
                ));
            }
            // phi = B u̇ + bias by definition
            if (p[2] - (bu + e0.bias[i])).abs() > 1e-12 * scale {
                return Err(format!(
                    "{k:?} row {i}: phi {} ≠ B u̇ + bias {}",
                    p[2],
                    bu + e0.bias[i]
                ));
            }
        }
    }
    // Need flags: partial requests write the same numbers.
    let (pa, ta) = a.state(0.0);
    let (pb, tb) = b.state(0.0);
    let only_phi = eval(k, g, f, 0.0, [&pa, &pb], [&ta, &tb], Need::PHI);
    let only_jac = eval(k, g, f, 0.0, [&pa, &pb], [&ta, &tb], Need::JAC);
    if only_phi.phi != e0.phi || only_jac.jac != e0.jac || only_jac.bias != e0.bias {
        return Err(format!("{k:?}: Need subsets disagree with Need::ALL"));
    }
    if only_phi.jac.iter().any(|j| j.a != [0.0; 6]) || only_jac.gamma.iter().any(|g| *g != 0.0) {
        return Err(format!("{k:?}: wrote outputs that were not asked for"));
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn derivatives_two_bodies(
        g in geom(), f in [time_fn(), time_fn(), time_fn()], a in motion(), b in motion()
    ) {
        for k in ALL {
            let b = if k.b_must_be_ground() { Motion::ground() } else { b };
            if let Err(e) = check_derivatives(k, &g, &f, &a, &b) {
                return Err(TestCaseError::fail(e));
            }
        }
    }

    #[test]
    fn derivatives_with_ground_side_a(
        g in geom(), f in [time_fn(), time_fn(), time_fn()], b in motion()
    ) {
        let a = Motion::ground();
        for k in ALL.into_iter().filter(|k| !k.b_must_be_ground()) {
            if let Err(e) = check_derivatives(k, &g, &f, &a, &b) {
                return Err(TestCaseError::fail(e));
            }
        }
    }
}

/// Geometry assembled so that the joint is satisfied at the given poses: a common world
/// joint frame (point `p`, orientation `qw`), with kind-specific offsets.
fn assembled(
    k: K,
    pa: &Pose,
    pb: &Pose,
    p: Vector3<f64>,
    qw: Quaternion<f64>,
    s: f64,
    f: &TimeFn,
) -> (JointGeom, f64) {
    let conj = |q: &Quaternion<f64>| Quaternion::new(q.w, -q.i, -q.j, -q.k);
    let z = rotate(&qw, &Vector3::z());
    let (x, y) = (rotate(&qw, &Vector3::x()), rotate(&qw, &Vector3::y()));
    // world frame and point of side b
    let (mut pbw, mut qbw) = (p, qw);
    let mut param = 0.0;
    let mut drive = 0.0;
    match k {
        K::Universal => qbw = qmul(&qw, &axis_angle(&Vector3::y(), std::f64::consts::FRAC_PI_2)),
        K::Prismatic | K::Cylindrical | K::DriveDisplacement => {
            pbw = p + s * z;
            drive = s;
        }
        K::Planar => {
            pbw = p + s * x - 0.7 * s * y;
            qbw = qmul(&qw, &axis_angle(&Vector3::z(), s));
        }
        K::Distance => {
            pbw = p + Vector3::new(s, 0.3, -0.2);
            param = (pbw - p).norm();
        }
        K::DriveAngle => {
            qbw = qmul(&qw, &axis_angle(&Vector3::z(), s));
            drive = s;
        }
        K::Curve => {
            // side a's point lies on the curve of side b's frame: pa = pb + x0 xb + f(x0) yb + z0 zb
            pbw = p - s * x - f.at(s).v * y - 0.4 * z;
        }
        _ => {}
    }
    let local = |pose: &Pose, w: &Vector3<f64>| pose.c.transpose() * (w - pose.r);
    let ga = Attachment {
        body: BodyRef::Body(0),
        point: local(pa, &p).into(),
        frame: quat_array(&qmul(&conj(&pa.q), &qw)),
    };
    let gb = Attachment {
        body: BodyRef::Body(1),
        point: local(pb, &pbw).into(),
        frame: quat_array(&qmul(&conj(&pb.q), &qbw)),
    };
    (JointGeom::new(&ga, &gb, param), drive)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn assembled_joints_are_satisfied_and_invariant_under_rigid_motion(
        ma in motion(), mb in motion(), p in v3(1.0), qw in unit_quat(), s in 0.2f64..1.0,
        f in time_fn(), rot in unit_quat(), shift in v3(2.0), vel in v3(2.0), wv in v3(2.0)
    ) {
        let (pa, _) = ma.state(0.0);
        let (pb, _) = mb.state(0.0);
        for k in ALL.into_iter().filter(|k| !k.b_must_be_ground()) {
            let (g, drive) = assembled(k, &pa, &pb, p, qw, s, &f);
            let fs = [TimeFn([drive, 0.0, 0.0, 0.0, 0.0]), f, f];
            let fs = if k == K::Curve { [f, f, f] } else { fs };
            let z = Twist::default();
            let ev = eval(k, &g, &fs, 0.0, [&pa, &pb], [&z, &z], Need::ALL);
            for (i, v) in ev.phi.iter().enumerate() {
                prop_assert!(v.abs() < 1e-12, "{:?} row {} not assembled: {}", k, i, v);
            }
            // same rigid motion of both bodies
            let moved = |pose: &Pose| Pose::new(rotate(&rot, &pose.r) + shift, qmul(&rot, &pose.q));
            let (pa2, pb2) = (moved(&pa), moved(&pb));
            let ev2 = eval(k, &g, &fs, 0.0, [&pa2, &pb2], [&z, &z], Need::PHI);
            for (i, v) in ev2.phi.iter().enumerate() {
                prop_assert!(v.abs() < 1e-12, "{:?} row {} after rigid motion: {}", k, i, v);
            }
            // a common rigid velocity field (v at the world origin, ω world) gives Φ̇ = 0
            let twist = |pose: &Pose| Twist { v: vel + wv.cross(&pose.r), w: pose.c.transpose() * wv };
            let (ta, tb) = (twist(&pa), twist(&pb));
            let ev3 = eval(k, &g, &fs, 0.0, [&pa, &pb], [&ta, &tb], Need::ALL);
            let ua = [ta.v.x, ta.v.y, ta.v.z, ta.w.x, ta.w.y, ta.w.z];
            let ub = [tb.v.x, tb.v.y, tb.v.z, tb.w.x, tb.w.y, tb.w.z];
            for i in 0..k.rows() {
                let j = &ev3.jac[i];
                let rate: f64 = (0..6).map(|c| j.a[c] * ua[c] + j.b[c] * ub[c]).sum::<f64>();
                // all time functions here are constant, so the bias vanishes too
                prop_assert!(ev3.bias[i] == 0.0);
                prop_assert!(rate.abs() < 1e-12 * (1.0 + vel.norm() + wv.norm() * 3.0),
                    "{:?} row {}: B u̇ = {} for a rigid velocity field", k, i, rate);
            }
        }
    }
}

#[test]
fn coinciding_frames_give_zero() {
    // Both joint frames at the same world point and orientation: every kind whose rows
    // vanish there gives Φ = 0 (universal, distance and drives need offsets, tested above).
    let pa = Pose::new(
        Vector3::new(0.3, -0.2, 1.0),
        axis_angle(&Vector3::new(1.0, 1.0, 0.0), 0.4),
    );
    let pb = Pose::new(
        Vector3::new(-0.5, 0.1, 0.2),
        axis_angle(&Vector3::new(0.0, 1.0, 2.0), -1.1),
    );
    let p = Vector3::new(0.1, 0.2, 0.3);
    let qw = axis_angle(&Vector3::new(3.0, 1.0, 2.0), 0.8);
    let f = TimeFn([0.0; 5]);
    for k in [
        K::Spherical,
        K::Revolute,
        K::Prismatic,
        K::Cylindrical,
        K::Fixed,
        K::Planar,
        K::DriveAngle,
        K::DriveDisplacement,
    ] {
        let (g, _) = assembled(K::Spherical, &pa, &pb, p, qw, 0.5, &f);
        let z = Twist::default();
        let ev = eval(k, &g, &[f, f, f], 0.0, [&pa, &pb], [&z, &z], Need::PHI);
        assert!(
            ev.phi.iter().all(|v| v.abs() < 1e-14),
            "{k:?}: {:?}",
            ev.phi
        );
    }
}

#[test]
fn rolling_sphere_without_slip_satisfies_all_rows() {
    // Sphere of radius R centred at its mass centre, on the ground plane z = 0, rolling
    // with ω (world) about a horizontal axis: v = ω × (R ẑ).
    let r = 0.4;
    let ground = Attachment {
        body: BodyRef::Ground,
        point: [0.0; 3],
        frame: [1.0, 0.0, 0.0, 0.0],
    };
    let ball = Attachment {
        body: BodyRef::Body(0),
        point: [0.0; 3],
        frame: [1.0, 0.0, 0.0, 0.0],
    };
    let g = JointGeom::new(&ball, &ground, r);
    let q = axis_angle(&Vector3::new(0.2, -1.0, 0.5), 2.0);
    let pa = Pose::new(Vector3::new(1.0, 2.0, r), q);
    let ww = Vector3::new(1.5, -0.7, 0.3);
    let ta = Twist {
        v: ww.cross(&Vector3::new(0.0, 0.0, r)),
        w: pa.c.transpose() * ww,
    };
    let mut ev = ConstraintEval::new(3);
    joints::rolling(
        &g,
        &pa,
        &Pose::default(),
        &ta,
        &Twist::default(),
        Need::ALL,
        JointOut::new(&mut ev, 0, 3),
    );
    for v in &ev.phi {
        assert!(v.abs() < 1e-15, "{:?}", ev.phi);
    }
    // Spin about the normal is free: only the contact row's gamma vanishes for a centred sphere.
    assert!(ev.gamma[0].abs() < 1e-15);
}
