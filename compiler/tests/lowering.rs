//! Lowering of individual constructs: units, dimension errors, components, loops, frames,
//! inertia, time functions, meshes and beams.

use mbdc_compiler::{load_str, Override, Scene};
use mbdc_runtime::scene::{
    BodyRef, Fn1, ForceKind, HourglassControl, JointKind, MeshCondition, MeshFormulation,
    MeshIntegration, MeshKinematics, MethodSpec, Plasticity,
};
use nalgebra::{Quaternion, Vector3};

fn scene(src: &str) -> Scene {
    let l = load_str("test.mbd", src, &[]);
    assert!(!l.has_errors(), "{}", l.render_plain());
    l.scene.expect("scene")
}

fn errors(src: &str) -> Vec<(String, String)> {
    let l = load_str("test.mbd", src, &[]);
    assert!(l.has_errors(), "expected errors");
    l.errors()
        .map(|d| (d.code.to_string(), d.message.clone()))
        .collect()
}

fn model(items: &str) -> String {
    format!("model t {{\n{items}\n  simulate {{ duration 1 s; step 1 ms }}\n}}\n")
}

fn rot(q: [f64; 4]) -> nalgebra::Matrix3<f64> {
    mbdc_runtime::math::rotation(&Quaternion::new(q[0], q[1], q[2], q[3]))
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn units_convert_to_si() {
    let s = scene(&model(
        "body b {\n mass 250 g\n inertia diag(1, 2, 2.5) g*cm^2\n position (1 in, 2 ft, 3 mm)\n velocity (36 km / 1 min, 0, 0)\n angular_velocity (60 rpm, 90 deg/s, 1 rev/s)\n }",
    ));
    let b = &s.bodies[0];
    assert!(close(b.mass, 0.25));
    assert!(close(b.inertia[0][0], 1e-7) && close(b.inertia[2][2], 2.5e-7));
    assert!(
        close(b.position[0], 0.0254) && close(b.position[1], 0.6096) && close(b.position[2], 0.003)
    );
    assert!(close(b.velocity[0], 600.0));
    let pi = std::f64::consts::PI;
    assert!(close(b.angular_velocity[0], 2.0 * pi) && close(b.angular_velocity[1], pi / 2.0));
    assert!(close(b.angular_velocity[2], 2.0 * pi));
    // A unit name as a value: 20/s.
    let src = model("body b { mass 1 kg; inertia sphere(radius: 1 cm) }").replace(
        "simulate { duration 1 s; step 1 ms }",
        "simulate { duration 1 s; step 1 ms; method baumgarte { alpha 20/s; beta 5 Hz } }",
    );
    let s = scene(&src);
    assert_eq!(
        s.simulate.method,
        MethodSpec::Baumgarte {
            alpha: 20.0,
            beta: 5.0
        }
    );
}

/// `staggered { factorization ... }`: the three values lower, anything else is an error
/// naming them.
#[test]
fn staggered_factorization_option() {
    use mbdc_runtime::scene::{Factorization, StaggeredOptions};
    let body = "body b { mass 1 kg; inertia sphere(radius: 1 cm) }";
    let with = |m: &str| {
        model(body).replace(
            "simulate { duration 1 s; step 1 ms }",
            &format!("simulate {{ duration 1 s; step 1 ms; method {m} }}"),
        )
    };
    for (word, f) in [
        ("auto", Factorization::Auto),
        ("dense", Factorization::Dense),
        ("sparse", Factorization::Sparse),
    ] {
        let s = scene(&with(&format!("staggered {{ factorization {word} }}")));
        assert_eq!(
            s.simulate.method,
            MethodSpec::Staggered(StaggeredOptions {
                factorization: f,
                ..Default::default()
            })
        );
    }
    let e = errors(&with("staggered { factorization lu }"));
    assert!(
        e.iter()
            .any(|(_, m)| m == "`factorization` is `auto`, `dense` or `sparse`"),
        "{e:?}"
    );
    // an option of staggered only
    let e = errors(&with("natural_partitioning { factorization dense }"));
    assert!(!e.is_empty());
}

/// The error-controlled Runge–Kutta methods take `tolerance` (default 1e-9), a positive
/// number; `rk4` takes no option.
#[test]
fn runge_kutta_method_options() {
    let body = "body b { mass 1 kg; inertia sphere(radius: 1 cm) }";
    let with = |m: &str| {
        model(body).replace(
            "simulate { duration 1 s; step 1 ms }",
            &format!("simulate {{ duration 1 s; step 1 ms; method {m} }}"),
        )
    };
    assert_eq!(scene(&with("rk4")).simulate.method, MethodSpec::RungeKutta4);
    assert_eq!(
        scene(&with("dopri5")).simulate.method,
        MethodSpec::DormandPrince { tolerance: 1e-9 }
    );
    assert_eq!(
        scene(&with("dop853")).simulate.method,
        MethodSpec::DormandPrince853 { tolerance: 1e-9 }
    );
    assert_eq!(
        scene(&with("dop853 { tolerance 1e-12 }")).simulate.method,
        MethodSpec::DormandPrince853 { tolerance: 1e-12 }
    );
    assert_eq!(
        scene(&with("dopri5 { tolerance 1e-7 }")).simulate.method,
        MethodSpec::DormandPrince { tolerance: 1e-7 }
    );
    for bad in [
        "dop853 { tolerance 0 }",
        "dop853 { tolerance -1e-9 }",
        "dop853 { max_iterations 3 }",
        "rk4 { tolerance 1e-9 }",
    ] {
        assert!(!errors(&with(bad)).is_empty(), "{bad} accepted");
    }
}

#[test]
fn output_format_and_partitions() {
    use mbdc_runtime::scene::OutputFormat;
    let body = "body b { mass 1 kg; inertia sphere(radius: 1 cm) }";
    let with = |o: &str| {
        model(body).replace(
            "simulate { duration 1 s; step 1 ms }",
            &format!("simulate {{ duration 1 s; step 1 ms; output {{ {o} }} }}"),
        )
    };
    assert_eq!(
        scene(&model(body)).simulate.output.format,
        OutputFormat::Vtk
    );
    for (word, f) in [
        ("csv", OutputFormat::Csv),
        ("vtk", OutputFormat::Vtk),
        ("exodus", OutputFormat::Exodus),
    ] {
        let s = scene(&with(&format!("format {word}; partitions 3")));
        assert_eq!(s.simulate.output.format, f);
        assert_eq!(s.simulate.output.partitions, 3);
    }
    let e = errors(&with("format exodos"));
    assert!(
        e.iter()
            .any(|(c, m)| c == "mbdc::invalid-value" && m == "unknown output format `exodos`"),
        "{e:?}"
    );
    assert!(!errors(&with("partitions 0")).is_empty());
}

#[test]
fn checkpoint_options() {
    use mbdc_runtime::scene::CheckpointOptions;
    let body = "body b { mass 1 kg; inertia sphere(radius: 1 cm) }";
    let with = |o: &str| {
        model(body).replace(
            "simulate { duration 1 s; step 1 ms }",
            &format!("simulate {{ duration 1 s; step 1 ms; output {{ {o} }} }}"),
        )
    };
    assert!(scene(&model(body)).simulate.output.checkpoint.is_none());
    let c = scene(&with(
        "checkpoint_every 500; checkpoint_seconds 10 min; keep_checkpoints 3",
    ))
    .simulate
    .output
    .checkpoint;
    assert_eq!(
        c,
        CheckpointOptions {
            every_steps: Some(500),
            every_seconds: Some(600.0),
            keep: Some(3),
        }
    );
    for (bad, expected) in [
        (
            "checkpoint_every 0",
            "`checkpoint_every` must be a positive integer, found 0",
        ),
        ("checkpoint_every 2.5", "checkpoint_every"),
        ("checkpoint_seconds 5 m", "s"),
        ("checkpoint_seconds 0 s", "checkpoint_seconds"),
        (
            "keep_checkpoints 0",
            "`keep_checkpoints` must be a positive integer, found 0",
        ),
    ] {
        let e = errors(&with(bad));
        assert!(e.iter().any(|(_, m)| m.contains(expected)), "{bad}: {e:?}");
    }
}

#[test]
fn dimension_errors_name_the_units() {
    let e = errors(&model(
        "body b { mass 1 kg; inertia sphere(radius: 1 cm); position (1 m + 2 s, 0, 0) }",
    ));
    assert!(
        e.iter()
            .any(|(c, m)| c == "mbdc::unit-mismatch" && m == "cannot add m and s"),
        "{e:?}"
    );
    let e = errors(&model("body b { mass 2 m; inertia sphere(radius: 1 cm) }"));
    assert!(
        e.iter().any(|(_, m)| m == "a mass must be in kg, found m"),
        "{e:?}"
    );
    let e = errors(&model(
        "body b { mass 1 kg; inertia sphere(radius: sqrt(2 m)) }",
    ));
    assert!(
        e.iter().any(|(_, m)| m.contains("square root of m")),
        "{e:?}"
    );
    let e = errors(&model("body b { mass 1 kg; inertia sphere(radius: 1 cm); orientation axis_angle((0, 0, 1), sin(2 m)) }"));
    assert!(
        e.iter()
            .any(|(_, m)| m.contains("`sin` needs a dimensionless argument")),
        "{e:?}"
    );
    // A bare zero fits any dimension, 0 with a unit does not.
    scene(&model(
        "body b { mass 1 kg; inertia sphere(radius: 1 cm); position (1 m, 0, 0) }",
    ));
    let e = errors(&model(
        "body b { mass 1 kg; inertia sphere(radius: 1 cm); position (1 m, 0 s, 0) }",
    ));
    assert!(e.iter().any(|(c, _)| c == "mbdc::unit-mismatch"), "{e:?}");
}

#[test]
fn params_and_overrides() {
    let src = model("param L = 1 m\n body b { mass 1 kg; inertia sphere(radius: L / 10) }");
    let l = load_str("t.mbd", &src, &["L=2 m".parse::<Override>().unwrap()]);
    let s = l.scene.expect("scene");
    assert!(close(s.bodies[0].inertia[0][0], 0.4 * 0.04));
    assert!(s
        .params
        .iter()
        .any(|p| p.name == "L" && p.value == 2.0 && p.overridden));
    // Wrong dimension and unknown names are errors that point at the override.
    let l = load_str("t.mbd", &src, &["L=2 s".parse::<Override>().unwrap()]);
    assert!(l.errors().any(|d| d.code == "mbdc::override"));
    let l = load_str("t.mbd", &src, &["Lx=2 m".parse::<Override>().unwrap()]);
    let d = l
        .errors()
        .find(|d| d.code == "mbdc::override")
        .expect("unknown override");
    assert_eq!(
        d.help.as_deref(),
        Some("did you mean `L`? its parameters: `L`")
    );
    assert!("no_equals".parse::<Override>().is_err());
    assert!("1x=2".parse::<Override>().is_err());
}

/// The one error of a load with overrides, with its code, message, help and labels as
/// `file name: text under the label`.
fn override_error(src: &str, set: &[&str]) -> (String, String, String, Vec<String>) {
    let set: Vec<Override> = set.iter().map(|s| s.parse().unwrap()).collect();
    let l = load_str("t.mbd", src, &set);
    let errs: Vec<_> = l.errors().collect();
    assert_eq!(errs.len(), 1, "{}", l.render_plain());
    let d = errs[0];
    let labels = d
        .labels
        .iter()
        .map(|lb| {
            let text = &l.sources.text(lb.file)[lb.span.start..lb.span.end];
            format!("{}: {text}", l.sources.name(lb.file))
        })
        .collect();
    (
        d.code.to_string(),
        d.message.clone(),
        d.help.clone().unwrap_or_default(),
        labels,
    )
}

#[test]
fn override_errors_name_the_parameter_the_value_and_what_is_expected() {
    let src = model(
        "param m = 1 kg\n param N = 3\n param g = (0, 0, -9.81) m/s^2\n param on = true\n const c = 2 m\n gravity g\n for i in 0..N { body b[i] { mass m; inertia sphere(radius: c) } }",
    );
    // A value in the wrong unit: the expected unit, the value given, the declaration.
    let (code, msg, help, labels) = override_error(&src, &["m=3 m"]);
    assert_eq!(code, "mbdc::override");
    assert_eq!(
        msg,
        "`--set m=3 m`: expected a quantity in kg (mass), found a quantity in m (length)"
    );
    assert_eq!(labels, ["--set m: 3 m", "t.mbd: 1 kg"]);
    assert!(help.contains("`--set m=1 kg`"), "{help}");
    // A missing unit.
    let (_, msg, _, _) = override_error(&src, &["m=3"]);
    assert_eq!(
        msg,
        "`--set m=3`: expected a quantity in kg (mass), found a number"
    );
    // A unit on a number without one.
    let (_, msg, _, labels) = override_error(&src, &["N=2 m"]);
    assert_eq!(
        msg,
        "`--set N=2 m`: expected a dimensionless number, found a quantity in m (length)"
    );
    assert_eq!(labels, ["--set N: 2 m", "t.mbd: 3"]);
    // A word that is no value: one error, no cascade of unknown names.
    let (code, msg, _, _) = override_error(&src, &["m=abc"]);
    assert_eq!(code, "mbdc::override");
    assert_eq!(
        msg,
        "`--set m=abc`: expected a quantity in kg (mass), found the name `abc`"
    );
    // A vector of the wrong size or unit, a boolean for a number, a function of time.
    let (_, msg, _, _) = override_error(&src, &["g=(0, -9.81) m/s^2"]);
    assert_eq!(
        msg,
        "`--set g=(0, -9.81) m/s^2`: expected a 3-vector in m/s^2 (acceleration), found a 2-vector"
    );
    let (_, msg, _, _) = override_error(&src, &["g=(0, 0, -9.81) m"]);
    assert!(msg.starts_with("`--set g=(0, 0, -9.81) m`: expected a 3-vector in m/s^2"));
    let (_, msg, _, _) = override_error(&src, &["m=true"]);
    assert!(msg.ends_with("found a boolean"), "{msg}");
    let (_, msg, _, _) = override_error(&src, &["on=1"]);
    assert!(msg.ends_with("expected a boolean, found a number"), "{msg}");
    let (_, msg, _, _) = override_error(&src, &["m=t * 1 kg"]);
    assert!(msg.ends_with("found a function of time"), "{msg}");
    // A syntax error names the override and says "value", not "file".
    let (code, msg, _, _) = override_error(&src, &["m=1 kg +"]);
    assert_eq!(code, "mbdc::syntax");
    assert!(msg.starts_with("`--set m=1 kg +`: "), "{msg}");
    assert!(msg.contains("the end of the value"), "{msg}");
    // A constant is not a parameter: said so, at its declaration.
    let (_, msg, help, labels) = override_error(&src, &["c=3 m"]);
    assert_eq!(msg, "`--set c=3 m`: `c` is a `const`, not a `param`");
    assert_eq!(labels, ["--set c: 3 m", "t.mbd: c"]);
    assert!(help.contains("`param c = ...`"), "{help}");
    // An unknown name: the closest, then the parameters nearest first.
    let (_, msg, help, _) = override_error(&src, &["mm=3 kg"]);
    assert_eq!(msg, "`--set mm=3 kg`: there is no parameter `mm`");
    assert_eq!(
        help,
        "did you mean `m`? its parameters: `m`, `N`, `g`, `on`"
    );
    let (_, _, help, _) = override_error(&src, &["mass=3 kg"]);
    assert_eq!(
        help,
        "the model has no parameter of that name; its parameters: `m`, `N`, `g`, `on`"
    );
}

#[test]
fn unknown_override_lists_at_most_eight_parameters() {
    let params: String = (0..20).map(|i| format!("param p{i} = {i}\n")).collect();
    let src = model(&params);
    let (_, _, help, _) = override_error(&src, &["p=1"]);
    assert!(
        help.starts_with("did you mean `p0`? the nearest of its 20 parameters: `p0`, "),
        "{help}"
    );
    assert_eq!(help.matches('`').count(), 2 + 16, "{help}");
}

#[test]
fn model_errors_caused_by_an_override_say_it_is_in_effect() {
    let src = model(
        "param N = 3\n for i in 0..N { body b[i] { mass 1 kg; inertia sphere(radius: 1 cm) } }",
    );
    let set: Vec<Override> = vec!["N=2.5".parse().unwrap()];
    let l = load_str("t.mbd", &src, &set);
    let errs: Vec<_> = l.errors().collect();
    assert_eq!(errs.len(), 1, "{}", l.render_plain());
    assert!(errs[0].message.contains("must be an integer"));
    let note = l
        .diagnostics
        .iter()
        .find(|d| !d.is_error())
        .expect("a note");
    assert_eq!(note.message, "the errors above are with `--set N=2.5`");
    // Without errors, no note.
    let l = load_str("t.mbd", &src, &["N=2".parse::<Override>().unwrap()]);
    assert!(!l.has_errors(), "{}", l.render_plain());
    assert!(
        !l.diagnostics.iter().any(|d| d.code == "mbdc::override"),
        "{}",
        l.render_plain()
    );
}

#[test]
fn components_expand_with_prefixes() {
    let s = scene(
        "component Link(parent, L = 1 m) {\n  body bar { mass 1 kg; inertia rod(length: L, radius: 1 cm); position (0, 0, -L / 2) }\n  joint pin = spherical(parent, bar @ (0, 0, L / 2))\n}\ncomponent Double(L) {\n  instance upper = Link(parent: ground @ (0, 0, 0), L: L)\n  instance lower = Link(parent: upper.bar @ (0, 0, -L / 2), L: L)\n}\nmodel m {\n  instance arm = Double(L: 2 m)\n  force f = point(arm.lower.bar @ (0, 0, 0), (1, 0, 0) N)\n  simulate { duration 1 s; step 1 ms }\n}\n",
    );
    let names: Vec<&str> = s.bodies.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(names, vec!["arm.upper.bar", "arm.lower.bar"]);
    let joints: Vec<&str> = s.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(joints, vec!["arm.upper.pin", "arm.lower.pin"]);
    // The lower link hangs from the upper bar: joint a = body 0.
    assert_eq!(s.joints[1].a.body, BodyRef::Body(0));
    assert_eq!(s.joints[1].b.body, BodyRef::Body(1));
    match &s.forces[0].kind {
        ForceKind::Point { at, .. } => assert_eq!(at.body, BodyRef::Body(1)),
        k => panic!("{k:?}"),
    }
    // Both instance positions use L = 2 m from the caller.
    assert!(close(s.bodies[0].position[2], -1.0));
}

#[test]
fn loops_and_conditions_expand() {
    let s = scene(&model(
        "param N = 5\n for i in 0..N {\n  const x0 = i * 1 m\n  body b[i] { mass (i + 1) * 1 kg; inertia sphere(radius: 1 cm); position (x0, 0, 0) }\n  if i > 0 {\n   joint j[i] = distance(b[i - 1] @ (0, 0, 0), b[i] @ (0, 0, 0))\n  } else {\n   joint j[i] = spherical(ground @ (0, 0, 0), b[i] @ (0, 0, 0))\n  }\n }\n for i in 0..2 { for k in 0..3 { body grid[i][k] { mass 1 kg; inertia sphere(radius: 1 cm) } } }",
    ));
    assert_eq!(s.bodies.len(), 5 + 6);
    assert_eq!(s.bodies[3].name, "b[3]");
    assert!(close(s.bodies[3].mass, 4.0));
    assert_eq!(s.bodies[10].name, "grid[1][2]");
    assert!(matches!(s.joints[0].kind, JointKind::Spherical));
    assert!(matches!(s.joints[2].kind, JointKind::Distance { length } if close(length, 1.0)));
    // An empty range creates nothing; a huge one is refused before expansion.
    let s = scene(&model(
        "for i in 3..1 { body b[i] { mass 1 kg; inertia sphere(radius: 1 cm) } }",
    ));
    assert!(s.bodies.is_empty());
    let e = errors(&model("for i in 0..5000 { for k in 0..5000 { body b[i][k] { mass 1 kg; inertia sphere(radius: 1 cm) } } }"));
    assert!(e.iter().any(|(c, _)| c == "mbdc::limit"), "{e:?}");
}

#[test]
fn joint_frames_coincide_in_world() {
    // Bodies with arbitrary orientations; joint frames must coincide at t = 0 and their
    // z axes must be the given world axis.
    let s = scene(&model(
        "body a { mass 1 kg; inertia sphere(radius: 1 cm); position (1, 2, 3) m; orientation euler_xyz(10 deg, 20 deg, 30 deg) }\n body b { mass 1 kg; inertia sphere(radius: 1 cm); position (1, 2, 4) m; orientation axis_angle((1, 1, 0), 40 deg) }\n joint r = revolute(a @ world((1, 2, 3.5) m), b @ world((1, 2, 3.5) m), axis: (0.2, -1, 0.5))\n joint p = prismatic(ground @ (1, 2, 3) m, a @ (0, 0, 0), axis: (0, 0, 2))\n joint f = fixed(a @ (0, 0, 0), b @ world((1, 2, 3) m))\n joint u = universal(a @ (0, 0, 0), b @ world((1, 2, 3) m), axis_a: (1, 0, 0), axis_b: (0, 1, 1))",
    ));
    let pose = |r: BodyRef| match r {
        BodyRef::Ground => (Vector3::zeros(), nalgebra::Matrix3::identity()),
        BodyRef::Body(i) => (
            Vector3::from(s.bodies[i].position),
            rot(s.bodies[i].orientation),
        ),
    };
    for j in &s.joints {
        let (xa, ra) = pose(j.a.body);
        let (xb, rb) = pose(j.b.body);
        let fa = ra * rot(j.a.frame);
        let fb = rb * rot(j.b.frame);
        let pa = xa + ra * Vector3::from(j.a.point);
        let pb = xb + rb * Vector3::from(j.b.point);
        assert!((pa - pb).norm() < 1e-12, "{}: points {pa} {pb}", j.name);
        match j.name.as_str() {
            "u" => {
                assert!((fa.column(2) - Vector3::x()).norm() < 1e-12);
                assert!((fb.column(2) - Vector3::new(0.0, 1.0, 1.0).normalize()).norm() < 1e-12);
                assert!(fa.column(2).dot(&fb.column(2)).abs() < 1e-12);
            }
            name => {
                assert!((fa - fb).norm() < 1e-12, "{name}: frames differ");
                if name == "r" {
                    let axis = Vector3::new(0.2, -1.0, 0.5).normalize();
                    assert!((fa.column(2) - axis).norm() < 1e-12);
                }
                if name == "p" {
                    assert!((fa.column(2) - Vector3::z()).norm() < 1e-12);
                    assert!((fa.column(0) - Vector3::x()).norm() < 1e-12);
                }
            }
        }
    }
    let e = errors(&model("body a { mass 1 kg; inertia sphere(radius: 1 cm) }\n joint u = universal(ground @ (0, 0, 0), a @ (0, 0, 0), axis_a: (1, 0, 0), axis_b: (1, 1, 0))"));
    assert!(e.iter().any(|(c, _)| c == "mbdc::not-perpendicular"));
}

#[test]
fn inertia_shapes_and_orientation() {
    let s = scene(&model(
        "body r { mass 2 kg; inertia rod(length: 1 m, radius: 10 cm, axis: x) }\n body c { mass 2 kg; inertia cylinder(radius: 10 cm, length: 1 m) }\n body x { mass 12 kg; inertia box(size: (1, 2, 3) m) }\n body s { mass 5 kg; inertia sphere(radius: 2 m); orientation quaternion(0.5, 0.5, 0.5, 0.5) }\n body w { mass 1 kg; inertia diag(1, 2, 3) kg*m^2; orientation axis_angle((0, 0, 1), 90 deg); angular_velocity (1, 0, 0) rad/s }",
    ));
    let b = &s.bodies;
    assert!(close(b[0].inertia[0][0], 2.0 * 0.01 / 2.0));
    assert!(close(b[0].inertia[1][1], 2.0 * (0.03 + 1.0) / 12.0));
    assert!(close(b[1].inertia[2][2], 0.01) && close(b[1].inertia[0][0], b[0].inertia[1][1]));
    assert!(
        close(b[2].inertia[0][0], 13.0)
            && close(b[2].inertia[1][1], 10.0)
            && close(b[2].inertia[2][2], 5.0)
    );
    assert!(close(b[3].inertia[1][1], 8.0));
    // World ω (1, 0, 0) on a body turned 90° about z is (0, −1, 0) in body components.
    assert!(b[4].angular_velocity[0].abs() < 1e-12 && close(b[4].angular_velocity[1], -1.0));
    // A non-unit quaternion is normalised with a warning.
    let l = load_str("t.mbd", &model("body q { mass 1 kg; inertia sphere(radius: 1 cm); orientation quaternion(2, 0, 0, 0) }"), &[]);
    assert!(!l.has_errors());
    assert!(l
        .diagnostics
        .iter()
        .any(|d| d.code == "mbdc::orientation" && d.severity == mbdc_compiler::Severity::Warning));
    assert_eq!(l.scene.unwrap().bodies[0].orientation, [1.0, 0.0, 0.0, 0.0]);
}

#[test]
fn time_functions_become_fn1_trees() {
    let s = scene(&model(
        "const w = 2 * pi * 1 Hz\n const ramp_force = 3 N * smoothstep(t, 0 s, 1 s)\n body b { mass 1 kg; inertia sphere(radius: 1 cm) }\n force f = point(b @ (0, 0, 0), (ramp_force * sin(w * t), 2 N, table(t, [(0 s, 0 N), (1 s, 5 N)])))\n joint d = point_velocity(b @ (0, 0, 0), (0, 0, 1 m/s * step(t - 0.5 s)))",
    ));
    let ForceKind::Point { value, .. } = &s.forces[0].kind else {
        panic!()
    };
    assert_eq!(value[1], Fn1::Const(2.0));
    assert!(!value[0].is_const() && !value[2].is_const());
    let v = |f: &Fn1, t: f64| mbdc_runtime::fn1::value(f, t);
    assert!(close(
        v(&value[0], 0.25),
        3.0 * (3.0 * 0.0625 - 2.0 * 0.015625) * (std::f64::consts::PI / 2.0).sin()
    ));
    assert!(close(v(&value[2], 0.5), 2.5));
    let JointKind::PointVelocity { velocity } = &s.joints[0].kind else {
        panic!()
    };
    assert_eq!(v(&velocity[2], 0.4), 0.0);
    assert_eq!(v(&velocity[2], 0.6), 1.0);
    // Constants fold completely.
    let s = scene(&model("body b { mass 1 kg; inertia sphere(radius: 1 cm) }\n force f = point(b @ (0, 0, 0), (sqrt(4) * 1 N, 0, 0))"));
    let ForceKind::Point { value, .. } = &s.forces[0].kind else {
        panic!()
    };
    assert_eq!(value[0], Fn1::Const(2.0));
    // t where a constant is required.
    let e = errors(&model(
        "body b { mass 1 kg; inertia sphere(radius: 1 cm); position (1 m/s * t, 0, 0) }",
    ));
    assert!(e.iter().any(|(c, _)| c == "mbdc::time-dependent"));
}

#[test]
fn drivers_copy_the_driven_joint() {
    let s = scene(&model(
        "body c { mass 1 kg; inertia rod(length: 0.2 m, radius: 1 cm, axis: x); position (0.1, 0, 0) m }\n joint pivot = revolute(ground @ (0, 0, 0), c @ (-0.1, 0, 0) m, axis: (0, 0, 1))\n joint motor = drive_angle(pivot, 1 rad/s * t)\n body s { mass 1 kg; inertia sphere(radius: 1 cm); position (0.3, 0, 0) m }\n joint slide = prismatic(ground @ (0, 0, 0), s @ (0, 0, 0), axis: (1, 0, 0))\n joint push = drive_displacement(slide, 0.1 m/s * t)",
    ));
    assert_eq!(s.joints[1].a, s.joints[0].a);
    assert_eq!(s.joints[1].b, s.joints[0].b);
    assert!(matches!(
        s.joints[1].kind,
        JointKind::DriveAngle { joint: 0, .. }
    ));
    // The slide counts from the initial configuration: f(0) = 0.3 m.
    let JointKind::DriveDisplacement {
        joint: 2,
        displacement,
    } = &s.joints[3].kind
    else {
        panic!()
    };
    assert!(close(mbdc_runtime::fn1::value(displacement, 1.0), 0.4));
}

#[test]
fn meshes_and_sets() {
    let s = scene(&model(
        "material alu { E 70 GPa; nu 0.33; rho 2700 kg/m^3 }\n mesh p {\n element tri3, plane_strain\n thickness 1 cm\n generate rect(origin: (0, 0) m, size: (2, 1) m, divisions: (4, 2))\n material alu\n set left = nodes(x == 0)\n set top = nodes(y >= 1 m)\n fix left\n displace top, (free, 1 mm * t / 1 s)\n traction top, (0, 1 kPa)\n }\n mesh h {\n element tet4\n generate box(origin: (0, 0, 0) m, size: (1, 1, 1) m, divisions: (2, 2, 2))\n material alu\n set base = nodes(z == 0)\n fix base\n body_force (0, 0, -26487) N/m^3\n }",
    ));
    let p = &s.meshes[0];
    assert_eq!(p.nodes.len(), 15);
    assert_eq!(p.elements.len(), 16);
    assert_eq!(p.node_sets[0].nodes, vec![0, 5, 10]);
    assert_eq!(p.node_sets[0].faces.len(), 2);
    assert_eq!(p.node_sets[1].nodes, vec![10, 11, 12, 13, 14]);
    assert_eq!(p.node_sets[1].faces.len(), 4);
    match &p.conditions[1] {
        MeshCondition::Displacement { set: 1, value } => {
            assert!(value[0].is_none() && value[1].is_some());
        }
        c => panic!("{c:?}"),
    }
    let h = &s.meshes[1];
    assert_eq!(h.elements.len(), 48);
    assert_eq!(h.node_sets[0].faces.len(), 8);
}

/// `tie SET, BODY` lowers to a tie of the set to the body's index; with small strain it
/// warns (the body's rotations strain the elements), naming the mesh and the body; with
/// `strain green` it does not.
#[test]
fn ties_name_their_body_and_warn_with_small_strain() {
    let src = |strain: &str| {
        model(&format!(
            "material alu {{ E 70 GPa; nu 0.33; rho 2700 kg/m^3 }}\n body a {{ mass 1 kg; inertia diag(1, 1, 1) g*m^2 }}\n body b {{ mass 1 kg; inertia diag(1, 1, 1) g*m^2 }}\n mesh p {{\n element quad4\n thickness 1 cm\n {strain}\n generate rect(origin: (0, 0) m, size: (2, 1) m, divisions: (4, 2))\n material alu\n set left = nodes(x == 0)\n tie left, b\n }}"
        ))
    };
    let l = load_str("test.mbd", &src(""), &[]);
    assert!(!l.has_errors(), "{}", l.render_plain());
    let warnings: Vec<&str> = l
        .diagnostics
        .iter()
        .filter(|d| d.severity == mbdc_compiler::Severity::Warning)
        .map(|d| d.message.as_str())
        .collect();
    assert!(
        warnings.len() == 1
            && warnings[0].contains("mesh `p` is tied to body `b` with small strain"),
        "{warnings:?}"
    );
    let s = l.scene.expect("scene");
    assert_eq!(
        s.meshes[0].conditions,
        vec![MeshCondition::Tie { set: 0, body: 1 }]
    );
    // With `strain green`, no warning; a mesh held by `fix` connects its tied body to
    // ground: only `a` is free.
    let l = load_str(
        "test.mbd",
        &src("strain green\n set right = nodes(x == 2 m)\n fix right"),
        &[],
    );
    let shown: Vec<(mbdc_compiler::Severity, &str)> = l
        .diagnostics
        .iter()
        .map(|d| (d.severity, d.message.as_str()))
        .collect();
    assert_eq!(
        shown,
        vec![(
            mbdc_compiler::Severity::Note,
            "this body is not connected to ground: `a`"
        )],
        "{}",
        l.render_plain()
    );
}

/// Two quad4 meshes side by side along x = 1 m, `coarse` (2×2, fixed on the left) then
/// `fine` (3×3), with extra lines in each and the given `simulate` options.
fn glued(coarse: &str, fine: &str, simulate: &str) -> String {
    format!(
        "model t {{
  material alu {{ E 70 GPa; nu 0.33; rho 2700 kg/m^3 }}
  mesh coarse {{
    element quad4
    thickness 1 cm
    generate rect(origin: (0, 0) m, size: (1, 1) m, divisions: (2, 2))
    material alu
    set left = nodes(x == 0)
    set right = nodes(x == 1 m)
    fix left
    {coarse}
  }}
  mesh fine {{
    element quad4
    thickness 1 cm
    generate rect(origin: (1, 0) m, size: (1, 1) m, divisions: (3, 3))
    material alu
    set left = nodes(x == 1 m)
    set right = nodes(x == 2 m)
    {fine}
  }}
  simulate {{ duration 1 s; step 1 s; {simulate} }}
}}
"
    )
}

/// The errors of a load, each as (message, help, the text under each label).
fn error_texts(src: &str) -> Vec<(String, String, Vec<String>)> {
    let l = load_str("t.mbd", src, &[]);
    assert!(l.has_errors(), "expected errors in\n{src}");
    l.errors()
        .map(|d| {
            let labels = d
                .labels
                .iter()
                .map(|lb| l.sources.text(lb.file)[lb.span.start..lb.span.end].to_string())
                .collect();
            (
                d.message.clone(),
                d.help.clone().unwrap_or_default(),
                labels,
            )
        })
        .collect()
}

/// The one error of a load, as in [`error_texts`].
fn one_error(src: &str) -> (String, String, Vec<String>) {
    let mut e = error_texts(src);
    assert_eq!(e.len(), 1, "{e:#?}");
    e.remove(0)
}

/// `glue SET, MESH.SET` lowers to a glue with this mesh's set, the other mesh's index and
/// set, and the default traction `bessel(points: 5)`; `{ traction ... }` chooses it. A mesh
/// may glue to one declared after it or before it. `mbdc check`'s summary lists the glues.
#[test]
fn glues_lower_with_their_sets_mesh_and_traction() {
    use mbdc_runtime::scene::GlueTraction;
    let glue = |traction: GlueTraction| MeshCondition::Glue {
        set: 1,
        mesh: 1,
        other_set: 0,
        traction,
    };
    let st = "mesh_method static";
    // forward: `coarse` glues to `fine`, declared after it
    let s = scene(&glued("glue right, fine.left", "", st));
    assert_eq!(
        s.meshes[0].conditions,
        vec![
            MeshCondition::Fixed { set: 0 },
            glue(GlueTraction::Bessel { points: 5 })
        ]
    );
    assert_eq!(GlueTraction::default(), GlueTraction::Bessel { points: 5 });
    assert!(s.meshes[1].conditions.is_empty());
    for (opts, t) in [
        (
            "{ traction polynomial(degree: 2) }",
            GlueTraction::Polynomial { degree: 2 },
        ),
        (
            "{ traction polynomial(degree: 0) }",
            GlueTraction::Polynomial { degree: 0 },
        ),
        (
            "{ traction polynomial(degree: 10) }",
            GlueTraction::Polynomial { degree: 10 },
        ),
        (
            "{ traction bessel(points: 8) }",
            GlueTraction::Bessel { points: 8 },
        ),
        (
            "{ traction bessel(points: 1) }",
            GlueTraction::Bessel { points: 1 },
        ),
        (
            "{ traction bessel(points: 2 * 32) }",
            GlueTraction::Bessel { points: 64 },
        ),
        ("{}", GlueTraction::Bessel { points: 5 }),
        (
            "{\n // a comment\n traction bessel(points: 3)\n }",
            GlueTraction::Bessel { points: 3 },
        ),
    ] {
        let s = scene(&glued(&format!("glue right, fine.left {opts}"), "", st));
        assert_eq!(s.meshes[0].conditions[1], glue(t), "{opts}");
    }
    // backward: `fine` glues to `coarse`, declared before it
    let s = scene(&glued(
        "",
        "glue left, coarse.right { traction polynomial(degree: 1) }",
        st,
    ));
    assert_eq!(
        s.meshes[1].conditions,
        vec![MeshCondition::Glue {
            set: 0,
            mesh: 0,
            other_set: 1,
            traction: GlueTraction::Polynomial { degree: 1 }
        }]
    );
    // One set glued to two sets; a glued set may share nodes with a fixed set (the
    // interface's end on a clamped edge).
    let s = scene(&glued(
        "set bottom = nodes(y == 0)\n fix bottom\n glue right, fine.left",
        "set top = nodes(y == 1 m)\n glue right, coarse.right\n glue top, coarse.right",
        st,
    ));
    assert_eq!(s.meshes[1].conditions.len(), 2);
    let text = mbdc_compiler::summary(&s).to_string();
    assert!(
        text.contains("; glued: right → fine.left\n")
            && text.contains("; glued: right → coarse.right, top → coarse.right\n"),
        "{text}"
    );
    // Inside a component, the names resolve in the instance.
    let src = "component Pair() {
  mesh a {
    element tri3; thickness 1 cm; material alu
    generate rect(origin: (0, 0) m, size: (1, 1) m, divisions: (1, 1))
    set r = nodes(x == 1 m)
    glue r, b.l
  }
  mesh b {
    element tri3; thickness 1 cm; material alu
    generate rect(origin: (1, 0) m, size: (1, 1) m, divisions: (2, 2))
    set l = nodes(x == 1 m)
    set r = nodes(x == 2 m)
    fix r
  }
}
model t {
  material alu { E 70 GPa; nu 0.33; rho 2700 kg/m^3 }
  instance p = Pair()
  instance q = Pair()
  simulate { duration 1 s; step 1 s; mesh_method static }
}
";
    let s = scene(src);
    let names: Vec<&str> = s.meshes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["p.a", "p.b", "q.a", "q.b"]);
    assert!(matches!(
        s.meshes[2].conditions[0],
        MeshCondition::Glue {
            set: 0,
            mesh: 3,
            other_set: 0,
            ..
        }
    ));
}

/// Each mistake in a glue is an error at the words that are wrong, with a help line.
#[test]
fn glue_errors_name_what_is_wrong() {
    let st = "mesh_method static";
    let e = |coarse: &str, fine: &str| one_error(&glued(coarse, fine, st));
    let s = |x: &str| x.to_string();
    // unknown mesh, with a suggestion (the meshes may be declared later)
    assert_eq!(
        e("glue right, fien.left", ""),
        (
            s("unknown mesh `fien`"),
            s("did you mean `fine`?"),
            vec![s("fien")]
        )
    );
    // unknown set of this mesh, and of the other mesh
    assert_eq!(
        e("glue rigth, fine.left", ""),
        (
            s("unknown set `rigth`"),
            s("did you mean `right`?"),
            vec![s("rigth")]
        )
    );
    assert_eq!(
        e("glue right, fine.lft", ""),
        (
            s("unknown set `lft` in mesh `fine`"),
            s("did you mean `left`?"),
            vec![s("lft")]
        )
    );
    assert_eq!(
        e("", "glue left, coarse.middle").1,
        "sets of mesh `coarse`: left, right"
    );
    // a mesh glued to itself
    let (m, h, l) = e("glue right, coarse.left", "");
    assert_eq!(
        (m.as_str(), l),
        ("a mesh cannot be glued to itself", vec![s("coarse")])
    );
    assert!(h.contains("another mesh"), "{h}");
    // not `MESH.SET`
    let (m, h, l) = e("glue right, fine", "");
    assert_eq!(
        (m.as_str(), h.as_str(), l),
        (
            "a set is glued to a set of another mesh: `glue SET, MESH.SET`",
            "name the other mesh and its set, e.g. `glue left, other.left`",
            vec![s("fine")]
        )
    );
    // a set without boundary edges, on either side
    assert_eq!(
        e("set c = nodes(x == 1 m and y == 0)\n glue c, fine.left", "").0,
        "set `c` contains no boundary edge"
    );
    let (m, _, l) = e("glue right, fine.c", "set c = nodes(x == 1 m and y == 0)");
    assert_eq!(
        (m.as_str(), l),
        (
            "set `c` of mesh `fine` contains no boundary edge",
            vec![s("c")]
        )
    );
    // the traction: its kind, its argument, its range
    let t = |opts: &str| e(&format!("glue right, fine.left {{ {opts} }}"), "");
    assert_eq!(
        t("traction linear(degree: 1)"),
        (
            s("unknown glue traction `linear`"),
            s("a glue's traction is `polynomial(degree: P)` or `bessel(points: N)`"),
            vec![s("linear")]
        )
    );
    assert_eq!(
        t("traction besel(points: 4)").1,
        "did you mean `bessel`? a glue's traction is `polynomial(degree: P)` or `bessel(points: N)`"
    );
    assert_eq!(
        t("traction 3").0,
        "a glue's traction is `polynomial(degree: P)` or `bessel(points: N)`"
    );
    let errs = error_texts(&glued(
        "glue right, fine.left { traction polynomial(2) }",
        "",
        st,
    ));
    assert!(
        errs.iter()
            .any(|e| e.0 == "`polynomial` takes 0 positional arguments"
                && e.1 == "other arguments are named: `degree:`"
                && e.2 == [s("2")]),
        "{errs:#?}"
    );
    let (m, h, l) = t("traction polynomial(degree: 11)");
    assert_eq!(
        (m.as_str(), l),
        (
            "the degree of a polynomial traction must lie in 0 to 10, found 11",
            vec![s("11")]
        )
    );
    assert!(h.contains("bessel(points: N)"), "{h}");
    assert_eq!(
        t("traction polynomial(degree: -1)").0,
        "the degree of a polynomial traction must lie in 0 to 10, found -1"
    );
    let (m, _, l) = t("traction bessel(points: 0)");
    assert_eq!(
        (m.as_str(), l),
        (
            "the number of points of a Bessel traction must lie in 1 to 64, found 0",
            vec![s("0")]
        )
    );
    assert_eq!(
        t("traction bessel(points: 65)").0,
        "the number of points of a Bessel traction must lie in 1 to 64, found 65"
    );
    assert_eq!(
        t("traction bessel(points: 2.5)").0,
        "the number of points of a Bessel traction must be an integer, found 2.5"
    );
    let (_, h, l) = t("traction bessel(points: 3 m)");
    assert_eq!(
        (h.as_str(), l),
        (
            "the number of points of a Bessel traction is a plain number",
            vec![s("3 m")]
        )
    );
    let (m, h, l) = t("tracton bessel(points: 3)");
    assert_eq!(
        (m.as_str(), l),
        (
            "unknown property `tracton` in the options of `glue`",
            vec![s("tracton")]
        )
    );
    assert!(h.starts_with("did you mean `traction`?"), "{h}");
    // `bessel` has no `degree`: the argument is unknown, and `points` is missing
    let errs = error_texts(&glued(
        "glue right, fine.left { traction bessel(degree: 3) }",
        "",
        st,
    ));
    let mut msgs: Vec<&str> = errs.iter().map(|e| e.0.as_str()).collect();
    msgs.sort_unstable();
    assert_eq!(
        msgs,
        [
            "`bessel` has no argument `degree`",
            "`bessel` needs the argument `points:`"
        ]
    );
    // only `glue` takes an options block
    let (m, _, l) = e("load right, (1, 0) N { traction bessel(points: 3) }", "");
    assert_eq!(
        (m.as_str(), l),
        (
            "`load` takes no options block",
            vec![s("{ traction bessel(points: 3) }")]
        )
    );
    // a glued set whose every node is fixed or tied in its mesh, on either side
    assert_eq!(
        e("glue left, fine.left", ""),
        (
            s("set `left` of mesh `coarse` is glued and fixed"),
            s("every node of `left` is fixed, which leaves the glue nothing to join: remove one of the two (a glued set may share some nodes with a held set, as where the interface meets a clamped edge)"),
            vec![s("glue left, fine.left"), s("fix left")]
        )
    );
    let (m, _, l) = e("glue right, fine.left", "fix left");
    assert_eq!(
        (m.as_str(), l),
        (
            "set `left` of mesh `fine` is glued and fixed",
            vec![s("glue right, fine.left"), s("fix left")]
        )
    );
    let (m, _, l) = e("displace right, (0, 1 mm)\n glue right, fine.left", "");
    assert_eq!(
        (m.as_str(), l),
        (
            "set `right` of mesh `coarse` is glued and displaced",
            vec![s("glue right, fine.left"), s("displace right, (0, 1 mm)")]
        )
    );
    let tied = glued("tie right, b\n glue right, fine.left", "", "").replace(
        "  mesh coarse",
        "  body b { mass 1 kg; inertia diag(1, 1, 1) g*m^2 }\n  mesh coarse",
    );
    let (m, _, l) = one_error(&tied);
    assert_eq!(
        (m.as_str(), l),
        (
            "set `right` of mesh `coarse` is glued and tied to body `b`",
            vec![s("glue right, fine.left"), s("tie right, b")]
        )
    );
    // the same pair twice, from one side or from both
    let (m, h, l) = e(
        "glue right, fine.left\n glue right, fine.left { traction polynomial(degree: 1) }",
        "",
    );
    assert_eq!(
        (m.as_str(), h.as_str(), l),
        (
            "`coarse.right` and `fine.left` are glued twice",
            "a glue joins the two sets both ways: keep one `glue`",
            vec![
                s("glue right, fine.left { traction polynomial(degree: 1) }"),
                s("glue right, fine.left")
            ]
        )
    );
    let (m, _, l) = e("glue right, fine.left", "glue left, coarse.right");
    assert_eq!(
        (m.as_str(), l),
        (
            "`fine.left` and `coarse.right` are glued twice",
            vec![s("glue left, coarse.right"), s("glue right, fine.left")]
        )
    );
    // `glue` takes two values; with one before a block it reads as a declaration
    assert_eq!(e("glue right", "").0, "`glue` takes 2 values, found 1");
    assert_eq!(
        e("glue right { traction bessel(points: 3) }", ""),
        (
            s("`glue` is not allowed in mesh `coarse`"),
            s("`glue` is a property of mesh `coarse`: its values are separated by commas, without `=`, and its block follows its values"),
            vec![s("glue right { traction bessel(points: 3) }")]
        )
    );
}

/// Glues are analysed by `mesh_method static` with the direct solver, on 2-D meshes: other
/// choices are errors at the `glue`.
#[test]
fn glues_need_2d_meshes_static_and_the_direct_solver() {
    let s = |x: &str| x.to_string();
    let g = "glue right, fine.left";
    // the default method, and newmark written
    assert_eq!(
        one_error(&glued(g, "", "")),
        (
            s("glued meshes are solved by `mesh_method static` for now; central_difference and newmark do not take glues yet"),
            s("`central_difference` is the default: add `mesh_method static` to `simulate`"),
            vec![s(g)]
        )
    );
    assert_eq!(
        one_error(&glued(g, "", "mesh_method newmark")),
        (
            s("glued meshes are solved by `mesh_method static` for now; central_difference and newmark do not take glues yet"),
            s("use `mesh_method static`"),
            vec![s(g), s("mesh_method newmark")]
        )
    );
    // FETI
    assert_eq!(
        one_error(&glued(g, "", "mesh_method static; solver feti")),
        (
            s("FETI does not take glues yet: glued meshes are solved by the direct solver"),
            s("remove `solver feti` (the direct solver is the default)"),
            vec![s(g), s("solver feti")]
        )
    );
    let (m, _, l) = one_error(&glued(
        g,
        "",
        "mesh_method static\n solver feti { subdomains 2 }",
    ));
    assert!(m.starts_with("FETI does not take glues yet"), "{m}");
    assert_eq!(l, vec![s(g), s("solver feti { subdomains 2 }")]);
    // 3-D meshes, each named
    let src = glued(g, "", "mesh_method static")
        .replace("element quad4", "element hex8")
        .replace("thickness 1 cm\n", "")
        .replace(
            "rect(origin: (0, 0) m, size: (1, 1) m, divisions: (2, 2))",
            "box(origin: (0, 0, 0) m, size: (1, 1, 1) m, divisions: (2, 2, 2))",
        )
        .replace(
            "rect(origin: (1, 0) m, size: (1, 1) m, divisions: (3, 3))",
            "box(origin: (1, 0, 0) m, size: (1, 1, 1) m, divisions: (3, 3, 3))",
        );
    let errs = error_texts(&src);
    assert_eq!(
        errs,
        vec![
            (
                s("glues join 2-D meshes for now: the interface is a line, and mesh `coarse` has hex8 elements"),
                s("glue meshes of tri3 or quad4 elements"),
                vec![s(g)]
            ),
            (
                s("glues join 2-D meshes for now: the interface is a line, and mesh `fine` has hex8 elements"),
                s("glue meshes of tri3 or quad4 elements"),
                vec![s(g)]
            ),
        ]
    );
}

#[test]
fn beams_subdivide_and_attach() {
    let s = scene(&model(
        "material steel { E 210 GPa; nu 0.3; rho 7850 kg/m^3 }\n body hub { mass 1 kg; inertia sphere(radius: 5 cm); position (1, 1, 0) m }\n beam l {\n points [(0, 0, 0) m, (1, 0, 0) m, (1, 1, 0) m]\n elements 4\n material steel\n shape tube(outer: 2 cm, inner: 1 cm)\n clamp start\n pin end, hub @ (0, 0, 0)\n }",
    ));
    let b = &s.beams[0];
    assert_eq!(b.nodes.len(), 5);
    assert_eq!(b.nodes[2], [1.0, 0.0, 0.0]);
    assert_eq!(b.up, [0.0, 0.0, 1.0]);
    assert_eq!(b.attachments.len(), 2);
    assert!(b.attachments[0].clamped && !b.attachments[1].clamped);
    assert_eq!(b.attachments[1].node, 4);
    assert_eq!(b.attachments[1].to.body, BodyRef::Body(0));
}

#[test]
fn vector_functions_keep_units() {
    // norm of a length vector is a length (a regression: the running sum of squares was
    // compared with the components, "cannot combine m^2 and m")
    let s = scene(&model(
        "const P = (3, 0, 0) m\n const Q = (0, 4, 0) m\n body b {\n mass 1 kg\n inertia rod(length: norm(P - Q), radius: 1 cm)\n position normalize(P - Q) * norm(P - Q)\n }",
    ));
    let b = &s.bodies[0];
    // rod of length 5 m: transverse inertia m(3r² + L²)/12
    assert!(close(b.inertia[0][0], (3.0 * 1e-4 + 25.0) / 12.0));
    assert!(close(b.position[0], 3.0) && close(b.position[1], -4.0));
    assert_eq!(
        errors(&model("const d = norm((1 m, 2 s, 0))"))[0].0,
        "mbdc::unit-mismatch"
    );
}

/// A one-mesh model with the given element line and formulation lines.
fn mesh_with(element: &str, lines: &str) -> String {
    let (gen, thick) = match element {
        "hex8" | "tet4" => (
            "box(origin: (0, 0, 0) m, size: (1, 1, 1) m, divisions: (1, 1, 1))",
            "",
        ),
        "bar2" => (
            "line(origin: (0, 0, 0) m, size: (1, 0, 0) m, divisions: 2)",
            "thickness 1 cm^2",
        ),
        _ => (
            "rect(origin: (0, 0) m, size: (1, 1) m, divisions: (1, 1))",
            "thickness 1 cm",
        ),
    };
    model(&format!(
        "material alu {{ E 70 GPa; nu 0.33; rho 2700 kg/m^3 }}\n mesh m {{\n element {element}\n {thick}\n {lines}\n generate {gen}\n material alu\n }}"
    ))
}

/// The error of `src`, its code, message and the text under its primary label.
fn error_at(src: &str) -> (String, String, String) {
    let l = load_str("test.mbd", src, &[]);
    assert!(l.has_errors(), "expected errors in\n{src}");
    let d = l.errors().next().expect("an error");
    let label = d
        .labels
        .iter()
        .find(|l| l.primary)
        .expect("a primary label");
    (
        d.code.to_string(),
        d.message.clone(),
        src[label.span.start..label.span.end].to_string(),
    )
}

#[test]
fn mesh_formulation_options() {
    // Defaults: full integration, small strain.
    let s = scene(&mesh_with("hex8", ""));
    assert_eq!(s.meshes[0].formulation, MeshFormulation::default());
    assert_eq!(
        s.meshes[0].formulation,
        MeshFormulation {
            integration: MeshIntegration::Full,
            kinematics: MeshKinematics::Small
        }
    );
    // reduced defaults to viscous 0.1.
    let s = scene(&mesh_with("hex8", "integration reduced\n strain green"));
    assert_eq!(
        s.meshes[0].formulation,
        MeshFormulation {
            integration: MeshIntegration::Reduced {
                hourglass: HourglassControl::Viscous { coefficient: 0.1 }
            },
            kinematics: MeshKinematics::Green
        }
    );
    let s = scene(&mesh_with(
        "quad4",
        "integration reduced\n hourglass stiffness(0.05)",
    ));
    assert_eq!(
        s.meshes[0].formulation.integration,
        MeshIntegration::Reduced {
            hourglass: HourglassControl::Stiffness { coefficient: 0.05 }
        }
    );
    let s = scene(&mesh_with("quad4, plane_strain", "integration bbar"));
    assert_eq!(s.meshes[0].formulation.integration, MeshIntegration::Bbar);
    // tet4, tri3 and bar2 take `strain` but no `integration`.
    for kind in ["tet4", "tri3", "bar2"] {
        let s = scene(&mesh_with(kind, "strain green"));
        assert_eq!(s.meshes[0].formulation.kinematics, MeshKinematics::Green);
        let (code, msg, at) = error_at(&mesh_with(kind, "integration reduced"));
        assert_eq!(code, "mbdc::mesh");
        assert!(
            msg.contains("hex8 and quad4") && msg.contains(kind),
            "{msg}"
        );
        assert_eq!(at, "reduced");
    }
    // Errors with their spans.
    let cases = [
        (
            "hex8",
            "integration half",
            "mbdc::wrong-kind",
            "`full`, `reduced` or `bbar`",
            "half",
        ),
        (
            "hex8",
            "strain large",
            "mbdc::wrong-kind",
            "`small` or `green`",
            "large",
        ),
        (
            "hex8",
            "hourglass viscous(0.1)",
            "mbdc::mesh",
            "needs `integration reduced`",
            "viscous(0.1)",
        ),
        (
            "hex8",
            "integration bbar\n hourglass stiffness(0.1)",
            "mbdc::mesh",
            "needs `integration reduced`",
            "stiffness(0.1)",
        ),
        (
            "hex8",
            "integration reduced\n hourglass viscous(0)",
            "mbdc::invalid-value",
            "(0, 1]",
            "0",
        ),
        (
            "hex8",
            "integration reduced\n hourglass stiffness(1.5)",
            "mbdc::invalid-value",
            "(0, 1]",
            "1.5",
        ),
        (
            "hex8",
            "integration reduced\n hourglass elastic(0.1)",
            "mbdc::unknown-name",
            "unknown hourglass control",
            "elastic",
        ),
        (
            "hex8",
            "integration reduced\n hourglass 0.1",
            "mbdc::wrong-kind",
            "`viscous(COEFFICIENT)`",
            "0.1",
        ),
    ];
    for (kind, lines, code, msg, at) in cases {
        let (c, m, a) = error_at(&mesh_with(kind, lines));
        assert_eq!((c.as_str(), a.as_str()), (code, at), "{lines}: {m}");
        assert!(m.contains(msg), "{lines}: {m}");
    }
    // A coefficient with a unit is a dimension error.
    let (c, _, a) = error_at(&mesh_with(
        "hex8",
        "integration reduced\n hourglass viscous(0.1 m)",
    ));
    assert_eq!((c.as_str(), a.as_str()), ("mbdc::unit-mismatch", "0.1 m"));
}

/// A one-mesh hex8 model whose material has the given extra lines.
fn plastic_mesh(material_lines: &str) -> String {
    model(&format!(
        "material steel {{\n E 200 GPa; nu 0.3; rho 7850 kg/m^3\n {material_lines}\n }}\n mesh m {{\n element hex8\n generate box(origin: (0, 0, 0) m, size: (1, 1, 1) m, divisions: (1, 1, 1))\n material steel\n }}"
    ))
}

#[test]
fn plastic_materials() {
    // Yield and hardening in SI; hardening defaults to 0 (perfectly plastic); no block: elastic.
    let s = scene(&plastic_mesh("plastic { yield 250 MPa; hardening 1 GPa }"));
    assert_eq!(
        s.meshes[0].material.plastic,
        Some(Plasticity {
            yield_stress: 250e6,
            hardening: 1e9
        })
    );
    let s = scene(&plastic_mesh("plastic {\n yield 0.3 GPa\n }"));
    assert_eq!(
        s.meshes[0].material.plastic,
        Some(Plasticity {
            yield_stress: 300e6,
            hardening: 0.0
        })
    );
    assert_eq!(scene(&plastic_mesh("")).meshes[0].material.plastic, None);
    // Errors with their spans.
    let cases = [
        (
            "plastic { hardening 1 GPa }",
            "mbdc::missing-property",
            "has no `yield`",
            "plastic { hardening 1 GPa }",
        ),
        (
            "plastic { yield -250 MPa }",
            "mbdc::invalid-value",
            "the yield stress must be positive",
            "-250 MPa",
        ),
        (
            "plastic { yield 0 Pa }",
            "mbdc::invalid-value",
            "the yield stress must be positive",
            "0 Pa",
        ),
        (
            "plastic { yield 250 MPa; hardening -1 GPa }",
            "mbdc::invalid-value",
            "the hardening modulus must not be negative",
            "-1 GPa",
        ),
        (
            "plastic { yield 250 m }",
            "mbdc::unit-mismatch",
            "",
            "250 m",
        ),
        (
            "plastic { yield 250 MPa; hardening 2 }",
            "mbdc::unit-mismatch",
            "",
            "2",
        ),
        (
            "plastic { yield 250 MPa; softening 1 GPa }",
            "mbdc::unknown-property",
            "unknown property `softening`",
            "softening",
        ),
        (
            "plastic { yield 250 MPa }\n plastic { yield 300 MPa }",
            "mbdc::duplicate-property",
            "`plastic` is given twice",
            "plastic { yield 300 MPa }",
        ),
        (
            "plastic = 3 { yield 250 MPa }",
            "mbdc::wrong-kind",
            "written with a block",
            "plastic = 3 { yield 250 MPa }",
        ),
    ];
    for (lines, code, msg, at) in cases {
        let (c, m, a) = error_at(&plastic_mesh(lines));
        assert_eq!((c.as_str(), a.as_str()), (code, at), "{lines}: {m}");
        assert!(m.contains(msg), "{lines}: {m}");
    }
    // Beams are elastic: a plastic material is refused at the beam's `material`.
    let (c, m, a) = error_at(&model(
        "material steel { E 210 GPa; nu 0.3; rho 7850 kg/m^3; plastic { yield 250 MPa } }\n beam b {\n from (0, 0, 0) m\n to (1, 0, 0) m\n elements 4\n material steel\n shape rect(width: 1 cm, height: 1 cm)\n clamp start\n }",
    ));
    assert_eq!(
        (c.as_str(), a.as_str()),
        ("mbdc::beam", "material steel"),
        "{m}"
    );
    assert!(m.contains("beams are elastic"), "{m}");
}

/// A model of one quad4 plate, 4 × 2 = 8 elements, fixed on its left edge, with the given
/// items in `simulate` after `duration 1 s; step 1 s`.
fn plate(simulate: &str) -> String {
    format!(
        "model t {{\n material alu {{ E 70 GPa; nu 0.33; rho 2700 kg/m^3 }}\n mesh p {{\n element quad4\n thickness 1 cm\n generate rect(origin: (0, 0) m, size: (2, 1) m, divisions: (4, 2))\n material alu\n set left = nodes(x == 0)\n fix left\n }}\n simulate {{ duration 1 s; step 1 s\n {simulate} }}\n}}\n"
    )
}

/// Every diagnostic of `src`: severity, code, message, the text under its primary label
/// and its help.
fn diagnostics_at(src: &str) -> Vec<(String, String, String, String, String)> {
    let l = load_str("test.mbd", src, &[]);
    l.diagnostics
        .iter()
        .map(|d| {
            let at = d
                .labels
                .iter()
                .find(|l| l.primary)
                .map(|l| src[l.span.start..l.span.end].to_string())
                .unwrap_or_default();
            (
                format!("{:?}", d.severity),
                d.code.to_string(),
                d.message.clone(),
                at,
                d.help.clone().unwrap_or_default(),
            )
        })
        .collect()
}

/// `simulate { solver direct | feti [{ OPTIONS }] }`: the default is the direct solver,
/// `feti` takes the contract's defaults, and every option lowers.
#[test]
fn mesh_solver_lowers_with_its_options() {
    use mbdc_runtime::scene::{FetiOptions, FetiPreconditioner, MeshSolver};
    assert_eq!(
        FetiOptions::default(),
        FetiOptions {
            subdomains: 4,
            preconditioner: FetiPreconditioner::Dirichlet,
            tolerance: 1e-10,
            max_iterations: 1000
        }
    );
    for (items, expected) in [
        ("mesh_method static", MeshSolver::Direct),
        ("mesh_method static; solver direct", MeshSolver::Direct),
        ("mesh_method static; solver direct {}", MeshSolver::Direct),
        (
            "mesh_method static; solver feti",
            MeshSolver::Feti(FetiOptions::default()),
        ),
        (
            "mesh_method newmark; solver feti {}",
            MeshSolver::Feti(FetiOptions::default()),
        ),
        (
            "mesh_method static\n solver feti { subdomains 8; preconditioner lumped; tolerance 1e-8; max_iterations 500 }",
            MeshSolver::Feti(FetiOptions {
                subdomains: 8,
                preconditioner: FetiPreconditioner::Lumped,
                tolerance: 1e-8,
                max_iterations: 500,
            }),
        ),
        // One option given: the others keep their defaults; options are expressions.
        (
            "mesh_method static; solver feti { subdomains 2 * 3 }",
            MeshSolver::Feti(FetiOptions {
                subdomains: 6,
                ..FetiOptions::default()
            }),
        ),
        (
            "mesh_method static; solver feti { tolerance 1e-6 }",
            MeshSolver::Feti(FetiOptions {
                tolerance: 1e-6,
                ..FetiOptions::default()
            }),
        ),
        (
            "mesh_method static; solver feti { max_iterations 20 }",
            MeshSolver::Feti(FetiOptions {
                max_iterations: 20,
                ..FetiOptions::default()
            }),
        ),
    ] {
        assert_eq!(scene(&plate(items)).simulate.mesh_solver, expected, "{items}");
    }
    for (word, p) in [
        ("dirichlet", FetiPreconditioner::Dirichlet),
        ("lumped", FetiPreconditioner::Lumped),
        ("none", FetiPreconditioner::None),
    ] {
        let s = scene(&plate(&format!(
            "mesh_method static; solver feti {{ preconditioner {word} }}"
        )));
        assert_eq!(
            s.simulate.mesh_solver,
            MeshSolver::Feti(FetiOptions {
                preconditioner: p,
                ..FetiOptions::default()
            })
        );
        assert_eq!(p.name(), word);
    }
}

/// Bad `solver` items are errors at the offending text, diagnosed as `method` is: unknown
/// solvers and options (with the valid ones in the help), duplicates, wrong kinds, and each
/// option's range.
#[test]
fn mesh_solver_errors_point_at_the_text() {
    let feti_takes = "`feti` takes: subdomains, preconditioner, tolerance, max_iterations";
    let cases: &[(&str, &str, &str, &str, &str)] = &[
        // (solver items, code, message, text under the label, help (part))
        (
            "solvr feti",
            "mbdc::unknown-property",
            "unknown property `solvr` in `simulate`",
            "solvr",
            "did you mean `solver`? `simulate` takes: duration, step, method, mesh_method, solver, output",
        ),
        (
            "solver fetti",
            "mbdc::unknown-method",
            "unknown solver `fetti`",
            "fetti",
            "did you mean `feti`? Solvers: direct, feti",
        ),
        (
            "solver lu { tolerance 1e-9 }",
            "mbdc::unknown-method",
            "unknown solver `lu`",
            "lu",
            "solvers: direct, feti",
        ),
        (
            "solver 3",
            "mbdc::unknown-method",
            "a solver is a name such as `feti`",
            "3",
            "solvers: direct, feti",
        ),
        (
            "solver feti { subdomain 8 }",
            "mbdc::unknown-method-option",
            "unknown option `subdomain` of solver `feti`",
            "subdomain",
            "did you mean `subdomains`? `feti` takes: subdomains, preconditioner, tolerance, max_iterations",
        ),
        (
            "solver feti { epsilon 1e-6 }",
            "mbdc::unknown-method-option",
            "unknown option `epsilon` of solver `feti`",
            "epsilon",
            feti_takes,
        ),
        (
            "solver direct { tolerance 1e-9 }",
            "mbdc::unknown-method-option",
            "unknown option `tolerance` of solver `direct`",
            "tolerance",
            "`direct` takes no options",
        ),
        (
            "solver feti { tolerance 1e-9; tolerance 1e-8 }",
            "mbdc::duplicate-property",
            "option `tolerance` is given twice",
            "tolerance 1e-8",
            "",
        ),
        (
            "solver feti { subdomains 2, 3 }",
            "mbdc::wrong-kind",
            "option `subdomains` takes one value",
            "subdomains 2, 3",
            "",
        ),
        (
            "solver feti { body b {} }",
            "mbdc::unknown-method-option",
            "solver options are written `NAME VALUE`",
            "body b {}",
            "",
        ),
        (
            "solver feti\n solver direct",
            "mbdc::duplicate-property",
            "`solver` is given twice in `simulate`",
            "solver direct",
            "",
        ),
        (
            "solver direct\n solver feti { subdomains 2 }",
            "mbdc::duplicate-property",
            "`solver` is given twice in `simulate`",
            "solver feti { subdomains 2 }",
            "",
        ),
        (
            "solver feti {}\n solver feti { subdomains 2 }",
            "mbdc::duplicate-property",
            "`solver` is given twice in `simulate`",
            "solver feti { subdomains 2 }",
            "",
        ),
        (
            "solver = 3 { subdomains 2 }",
            "mbdc::wrong-kind",
            "write `solver NAME` or `solver NAME { OPTIONS }`",
            "solver = 3 { subdomains 2 }",
            "",
        ),
        (
            "solver feti { subdomains 0 }",
            "mbdc::invalid-value",
            "subdomains must be a positive integer, found 0",
            "0",
            "",
        ),
        (
            "solver feti { subdomains -2 }",
            "mbdc::invalid-value",
            "subdomains must be a positive integer, found -2",
            "-2",
            "",
        ),
        (
            "solver feti { subdomains 2.5 }",
            "mbdc::invalid-value",
            "subdomains must be an integer, found 2.5",
            "2.5",
            "",
        ),
        (
            "solver feti { subdomains 100001 }",
            "mbdc::invalid-value",
            "subdomains must be at most 100000, found 100001",
            "100001",
            "",
        ),
        (
            "solver feti { subdomains 4 m }",
            "mbdc::unit-mismatch",
            "",
            "4 m",
            "",
        ),
        (
            "solver feti { preconditioner jacobi }",
            "mbdc::wrong-kind",
            "`preconditioner` is `dirichlet`, `lumped` or `none`",
            "jacobi",
            "",
        ),
        (
            "solver feti { tolerance 0 }",
            "mbdc::invalid-value",
            "a tolerance must be positive, found 0",
            "0",
            "",
        ),
        (
            "solver feti { tolerance 1 }",
            "mbdc::invalid-value",
            "a tolerance must be less than 1, found 1",
            "1",
            "the interface residual",
        ),
        (
            "solver feti { tolerance 1e-9 s }",
            "mbdc::unit-mismatch",
            "",
            "1e-9 s",
            "",
        ),
        (
            "solver feti { max_iterations 0 }",
            "mbdc::invalid-value",
            "max_iterations must be a positive integer, found 0",
            "0",
            "",
        ),
        (
            "solver feti { max_iterations 1.5 }",
            "mbdc::invalid-value",
            "max_iterations must be an integer, found 1.5",
            "1.5",
            "",
        ),
    ];
    for &(items, code, msg, at, help) in cases {
        let src = plate(&format!("mesh_method static\n {items}"));
        let ds = diagnostics_at(&src);
        let errors: Vec<_> = ds.iter().filter(|d| d.0 == "Error").collect();
        assert_eq!(errors.len(), 1, "{items}: {ds:?}");
        let (_, c, m, a, h) = errors[0];
        assert_eq!((c.as_str(), a.as_str()), (code, at), "{items}: {m}");
        assert!(m.contains(msg), "{items}: {m}");
        assert!(h.contains(help), "{items}: {h}");
    }
}

/// The checker: `solver feti` with the explicit `mesh_method central_difference` (no linear
/// solve) or on a model without meshes is a warning at `solver`; more `subdomains` than the
/// meshes have elements is an error at `subdomains` (or at `solver`, for the default 4).
#[test]
fn mesh_solver_checks_against_the_model() {
    use mbdc_runtime::scene::MeshSolver;
    // The one diagnostic of `src` beside notes (free bodies, degrees of freedom).
    let only = |src: &str| {
        let ds: Vec<_> = diagnostics_at(src)
            .into_iter()
            .filter(|d| d.0 != "Note")
            .collect();
        assert_eq!(ds.len(), 1, "{ds:?}");
        ds[0].clone()
    };
    // Explicit mesh analysis, written or by default: the warning, and the scene still lowers.
    for items in [
        "mesh_method central_difference\n solver feti { subdomains 2 }",
        "solver feti { subdomains 2 }",
    ] {
        let src = plate(items);
        let (sev, code, msg, at, help) = only(&src);
        assert_eq!(
            (sev.as_str(), code.as_str(), at.as_str()),
            ("Warning", "mbdc::no-effect", "solver feti { subdomains 2 }"),
            "{items}"
        );
        assert!(
            msg.contains("`solver feti` has no effect with `mesh_method central_difference`")
                && msg.contains("FETI serves `mesh_method static | newmark`"),
            "{msg}"
        );
        assert!(help.contains("mesh_method static"), "{help}");
        assert!(matches!(
            scene(&src).simulate.mesh_solver,
            MeshSolver::Feti(_)
        ));
    }
    // No meshes.
    let src = model("body b { mass 1 kg; inertia sphere(radius: 1 cm) }").replace(
        "simulate { duration 1 s; step 1 ms }",
        "simulate { duration 1 s; step 1 ms; solver feti }",
    );
    let (sev, code, msg, at, _) = only(&src);
    assert_eq!(
        (sev.as_str(), code.as_str(), msg.as_str(), at.as_str()),
        (
            "Warning",
            "mbdc::no-effect",
            "`solver feti` has no effect: the model has no mesh",
            "solver feti"
        )
    );
    // Subdomains against the 8 elements of the plate.
    assert!(diagnostics_at(&plate("mesh_method static; solver feti { subdomains 8 }")).is_empty());
    assert!(diagnostics_at(&plate("mesh_method newmark; solver feti { subdomains 1 }")).is_empty());
    assert!(diagnostics_at(&plate("mesh_method static; solver direct")).is_empty());
    let (sev, code, msg, at, help) = only(&plate(
        "mesh_method newmark\n solver feti { subdomains 9; tolerance 1e-8 }",
    ));
    assert_eq!(
        (sev.as_str(), code.as_str(), at.as_str()),
        ("Error", "mbdc::invalid-value", "subdomains 9")
    );
    assert_eq!(
        msg,
        "`subdomains 9` is more than the 8 elements of the model's mesh: each subdomain needs at least one element"
    );
    assert_eq!(help, "use at most 8 subdomains (`subdomains 8`)");
    // The default 4 on a mesh of 2 elements: at `solver`.
    let src = mesh_with("quad4", "").replace(
        "generate rect(origin: (0, 0) m, size: (1, 1) m, divisions: (1, 1))",
        "generate rect(origin: (0, 0) m, size: (2, 1) m, divisions: (2, 1))",
    );
    let src = src.replace(
        "simulate { duration 1 s; step 1 ms }",
        "simulate { duration 1 s; step 1 s; mesh_method static; solver feti }",
    );
    let (sev, _, msg, at, _) = only(&src);
    assert_eq!(
        (sev.as_str(), at.as_str()),
        ("Error", "solver feti"),
        "{msg}"
    );
    assert!(
        msg.contains("into 4 subdomains by default, more than the 2 elements"),
        "{msg}"
    );
}

/// The scene's JSON (what generated code and `mbdc run` carry) holds a FETI solver with its
/// options, and reads back to the same settings; a direct solver leaves the field out.
#[test]
fn mesh_solver_survives_the_scene_json() {
    let s = scene(&plate(
        "mesh_method static\n solver feti { subdomains 8; preconditioner none; tolerance 1e-9; max_iterations 500 }",
    ));
    let json = serde_json::to_string(&s).expect("json");
    assert!(
        json.contains(r#""mesh_solver":{"feti":{"subdomains":8,"preconditioner":"none","tolerance":1e-9,"max_iterations":500}}"#),
        "{json}"
    );
    let back = mbdc_runtime::compiled::scene_from_json(&json).expect("reads back");
    assert_eq!(back.simulate, s.simulate);
    let direct = scene(&plate("mesh_method static; solver direct"));
    let json = serde_json::to_string(&direct).expect("json");
    assert!(!json.contains("mesh_solver"), "{json}");
}
