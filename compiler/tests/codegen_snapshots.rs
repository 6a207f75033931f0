//! The generated source under review: insta snapshots of the Rust generated for three small
//! scenes (every change to the generator shows up as a snapshot diff), "only the effects the
//! scene calls for" (and only its meshes' element kernels and its beams' element variants) checked on the generated source of
//! several scenes, and the size of the source of a long chain against a short one.
//!
//! The scene's JSON is kept out of the source here (`SceneJson::Include`, as `build.rs` and
//! `mbdc run` generate it): it holds the numbers and source spans, not code.

use std::path::PathBuf;

use mbdc_compiler::codegen::{generate, Generated, Options, SceneJson};
use mbdc_compiler::{load_file, load_str, Override, Scene};
use mbdc_runtime::compiled::Mode;
use mbdc_runtime::scene::{HourglassControl, MeshIntegration};

fn models() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../models")
}

fn load_model(name: &str) -> Scene {
    let loaded = load_file(models().join(format!("{name}.mbd")), &[]);
    match loaded.scene {
        Some(s) => s,
        None => panic!("{name}: {}", loaded.render_plain()),
    }
}

fn options(mode: Option<Mode>) -> Options {
    Options {
        module: None,
        mode,
        scene_json: SceneJson::Include("scene.json".into()),
    }
}

fn gen(scene: &Scene, mode: Option<Mode>) -> Generated {
    generate(scene, &options(mode)).expect("generate")
}

#[test]
fn snapshot_pendulum() {
    insta::assert_snapshot!("pendulum", gen(&load_model("pendulum"), None).source);
}

#[test]
fn snapshot_double_pendulum_3d() {
    insta::assert_snapshot!(
        "double_pendulum_3d",
        gen(&load_model("double_pendulum_3d"), None).source
    );
}

#[test]
fn snapshot_four_bar() {
    insta::assert_snapshot!("four_bar", gen(&load_model("four_bar"), None).source);
}

/// A ball on a floor (contact), as in docs/language.md.
const BOUNCE: &str = "model bounce {
  gravity (0, 0, -9.81) m/s^2
  body ball { mass 1 kg; inertia sphere(radius: 0.1 m); position (0, 0, 1) m }
  contact floor = sphere_plane(ball @ (0, 0, 0), ground @ (0, 0, 0), radius: 0.1 m, normal: (0, 0, 1), stiffness: 1e5 N/m, damping: 20 N*s/m, friction: 0.3)
  simulate { duration 2 s; step 0.1 ms }
}";

/// Whether the code of `source` (doc comments left out: the module doc lists the effects)
/// has any of the markers.
fn has_any(source: &str, markers: &[&str]) -> bool {
    source
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .any(|l| markers.iter().any(|m| l.contains(m)))
}

/// Only the effects the scene calls for: for scenes with and without each effect, the code
/// for springs, contact, time functions, locks and gravity is in the generated source exactly
/// when the scene declares it. (Closed loops need no code of their own in the model: the
/// loop closure is the integrators' business, through the same constraint rows; the check is
/// that a closed-loop scene's code differs from an open chain's only by its joints.) Meshes
/// likewise: a rigid scene's code has no element kernel, and a mesh scene's code names only
/// the element loops of its own blocks (hex8 for `hex_bar`, no tet4 or quad4).
#[test]
fn only_the_effects_the_scene_calls_for() {
    let mut scenes: Vec<(String, Scene)> = [
        "pendulum",
        "double_pendulum_3d",
        "four_bar",
        "slider_crank",
        "symmetric_top",
        "bowling_ball",
        "deployment_arm",
        "hard/stiff_spring",
        "hard/kinked_driver",
        "hard/step_torque",
    ]
    .iter()
    .map(|n| (n.to_string(), load_model(n)))
    .collect();
    let bounce = load_str("bounce.mbd", BOUNCE, &[]);
    scenes.push(("bounce".into(), bounce.scene.expect("bounce loads")));

    let mut seen = std::collections::BTreeSet::new();
    for (name, scene) in &scenes {
        for mode in [Mode::Unrolled, Mode::Tables] {
            let g = gen(scene, Some(mode));
            let src = &g.source;
            let on = |e: &str| g.effects.contains(&e);
            let check = |what: &str, declared: bool, markers: &[&str]| {
                assert_eq!(
                    has_any(src, markers),
                    declared,
                    "{name} ({mode:?}): {what} declared: {declared}, code for it: {}",
                    !declared
                );
            };
            check(
                "springs",
                on("springs"),
                &["forces::spring", "forces::rotational_spring", "SpringGeom"],
            );
            check(
                "contact",
                on("contact"),
                &["contact::", "sphere_planes", "box_planes"],
            );
            check("locks", on("locks"), &["update_locks", "joint_angle"]);
            check("gravity", on("gravity"), &["forces::gravity"]);
            // No scene here has a mesh or a beam: no element kernel, loop or table.
            check("meshes", false, ELEMENT_MARKERS);
            check("beams", false, BEAM_MARKERS);
            // Time functions (and the other scalar functions: force values, curves) exist only
            // for scenes with time dependence, drivers, applied forces or curve joints.
            let functions = on("time_dependence")
                || on("drivers")
                || on("applied_forces")
                || on("nonholonomic");
            if !functions {
                check("time functions", false, &["Jet2", "fn f0"]);
            }
            if on("time_dependence") {
                check("time functions", true, &["Jet2::var"]);
            }
            for e in &g.effects {
                seen.insert(*e);
            }
        }
    }
    // The scenes cover both sides of every effect checked above.
    for e in [
        "gravity",
        "springs",
        "contact",
        "locks",
        "time_dependence",
        "closed_loops",
    ] {
        assert!(seen.contains(e), "no scene with {e}");
    }

    // A closed loop adds no code of its own: the four-bar's constraint code is its five
    // spherical joints, as an open chain of the same joints would have.
    let four_bar = gen(&load_model("four_bar"), Some(Mode::Unrolled)).source;
    assert_eq!(four_bar.matches("joints::spherical(").count(), 5);
    assert!(!has_any(&four_bar, &["loop", "cut"]));

    // A mesh scene's code names the element loops of its own blocks and no other kernel:
    // (model, the loops it must name, in block order).
    let meshes: [(&str, &[&str]); 4] = [
        ("hex_bar", &["BlockKernel::elastic::<Hex8>()"]),
        (
            "plastic_bar",
            &[
                "BlockKernel::plastic::<Hex8>()",
                "BlockKernel::plastic::<Bar2>()",
            ],
        ),
        (
            "mesh_on_pendulum",
            &["BlockKernel::elastic::<Quad4PlaneStress>()"],
        ),
        ("plate", &["BlockKernel::elastic::<Quad4PlaneStress>()"]),
    ];
    for (name, loops) in meshes {
        let scene = load_model(name);
        for mode in [Mode::Unrolled, Mode::Tables] {
            let src = gen(&scene, Some(mode)).source;
            let code: Vec<&str> = src
                .lines()
                .filter(|l| !l.trim_start().starts_with("//"))
                .collect();
            let code = code.join("\n");
            for l in loops {
                assert!(code.contains(l), "{name} ({mode:?}): no `{l}` in\n{src}");
            }
            assert_eq!(
                code.matches("BlockKernel::").count(),
                loops.len(),
                "{name} ({mode:?}): one loop per block"
            );
            // Every kernel type it names is one of its blocks'.
            for k in KERNEL_TYPES {
                let own = loops.iter().any(|l| l.contains(&format!("<{k}>")));
                let named = code
                    .split(|c: char| !c.is_ascii_alphanumeric() && c != '_')
                    .any(|w| w == *k);
                assert_eq!(named, own, "{name} ({mode:?}): {k} named: {named}");
            }
        }
    }

    // A mesh scene has no beam code.
    for name in ["hex_bar", "plate"] {
        let src = gen(&load_model(name), None).source;
        assert!(!has_any(&src, BEAM_MARKERS), "{name}: beam code in\n{src}");
    }

    // A beam scene's code names the element variants its beams use, each once, and no
    // element kernel of a mesh: (model, the variants it must name).
    let mut mixed = load_model("cantilever");
    let mut damped = mixed.beams[0].clone();
    damped.name = "damped_twin".into();
    damped.damping = 1e-6;
    mixed.beams.push(damped);
    let beams: [(&str, Scene, &[&str]); 3] = [
        (
            "cantilever",
            load_model("cantilever"),
            &["BeamKernel::elastic()"],
        ),
        (
            "arm_probe",
            load_model("arm_probe"),
            &["BeamKernel::damped()"],
        ),
        (
            "cantilever with a damped twin",
            mixed,
            &["BeamKernel::elastic()", "BeamKernel::damped()"],
        ),
    ];
    for (name, scene, variants) in &beams {
        for mode in [Mode::Unrolled, Mode::Tables] {
            let src = gen(scene, Some(mode)).source;
            let code: Vec<&str> = src
                .lines()
                .filter(|l| !l.trim_start().starts_with("//"))
                .collect();
            let code = code.join("\n");
            let found: Vec<&str> = code
                .match_indices("BeamKernel::")
                .map(|(i, _)| {
                    let end = code[i..].find(')').map_or(code.len(), |e| i + e + 1);
                    &code[i..end]
                })
                .collect();
            assert_eq!(&found, variants, "{name} ({mode:?}): variants in\n{src}");
            assert!(code.contains("fn beam_kernels"), "{name} ({mode:?})");
            assert!(
                !has_any(&code, ELEMENT_MARKERS),
                "{name} ({mode:?}): mesh code"
            );
        }
    }

    // The quadrature of hex8 and quad4 is a kernel variant: a one-point hex8 mesh names its
    // own loop and not the fully integrated kernel (its hourglass coefficient is data).
    let mut one_point = load_model("hex_bar");
    for m in &mut one_point.meshes {
        m.formulation.integration = MeshIntegration::Reduced {
            hourglass: HourglassControl::Viscous { coefficient: 0.1 },
        };
    }
    let src = gen(&one_point, None).source;
    assert!(
        src.contains("BlockKernel::elastic::<Hex8Reduced>()"),
        "{src}"
    );
    assert!(!src.contains("<Hex8>") && !src.contains("Hex8,") && !src.contains("Hex8;"));
}

/// The element kernel types of `mbdc_runtime::solid`, one per element kind and quadrature
/// variant.
const KERNEL_TYPES: &[&str] = &[
    "Bar2",
    "Tri3PlaneStress",
    "Tri3PlaneStrain",
    "Quad4PlaneStress",
    "Quad4PlaneStrain",
    "Quad4PlaneStressReduced",
    "Quad4PlaneStrainReduced",
    "Tet4",
    "Hex8",
    "Hex8Reduced",
];

/// What code for meshes would contain: element loops, their table, the kernel types.
const ELEMENT_MARKERS: &[&str] = &[
    "mesh_kernels",
    "BlockKernel",
    "MESH_KERNELS",
    "solid::",
    "Bar2",
    "Tri3",
    "Quad4",
    "Tet4",
    "Hex8",
];

/// What code for beams would contain: the variants' table and its hook.
const BEAM_MARKERS: &[&str] = &["beam_kernels", "BeamKernel", "BEAM_KERNELS", "beam_element"];

/// The chain of `models/chain.mbd` with `N` links, as inline text.
const CHAIN: &str = "model chain {
  param N = 10
  param L = 0.1 m
  gravity (0, 0, -9.81) m/s^2
  for i in 0..N {
    body link[i] {
      mass 0.1 kg
      inertia rod(length: L, radius: 5 mm, axis: x)
      position ((i + 0.5) * L, 0, 0)
    }
    if i == 0 {
      joint pin[i] = revolute(ground @ (0, 0, 0), link[i] @ (-L / 2, 0, 0), axis: (0, 1, 0))
    } else {
      joint pin[i] = revolute(link[i - 1] @ (L / 2, 0, 0), link[i] @ (-L / 2, 0, 0), axis: (0, 1, 0))
    }
  }
  simulate { duration 1 s; step 0.1 ms }
}";

fn chain(n: usize) -> Scene {
    let loaded = load_str("chain.mbd", CHAIN, &[Override::new("N", n.to_string())]);
    match loaded.scene {
        Some(s) => s,
        None => panic!("chain N={n}: {}", loaded.render_plain()),
    }
}

/// Repeated structure is a loop over a table, not unrolled code: the source for a 1000-link
/// chain is at most a few times that for a 10-link chain (each in the layout it gets by
/// default: straight-line code for 10 links, tables for 1000), and in the table layout the
/// source does not grow with the number of links at all.
#[test]
fn chain_source_does_not_grow_with_links() {
    let (c10, c100, c1000) = (chain(10), chain(100), chain(1000));
    let (d10, d1000) = (gen(&c10, None), gen(&c1000, None));
    assert_eq!((d10.mode, d1000.mode), (Mode::Unrolled, Mode::Tables));
    let ratio = d1000.source.len() as f64 / d10.source.len() as f64;
    assert!(
        ratio <= 3.0,
        "1000 links: {} bytes, 10 links: {} bytes (×{ratio:.2})",
        d1000.source.len(),
        d10.source.len()
    );
    let t: Vec<usize> = [&c10, &c100, &c1000]
        .iter()
        .map(|s| gen(s, Some(Mode::Tables)).source.len())
        .collect();
    // Only the size constants (BODIES, ROWS) differ in length.
    assert!(
        t.iter().max().unwrap() - t.iter().min().unwrap() <= 16,
        "table layout: {t:?} bytes for 10, 100, 1000 links"
    );
}

/// A FETI mesh solver survives the round trip into generated code: the scene JSON the code
/// carries (inline, as `SCENE_JSON`, or beside it) holds `solver feti` with its options and
/// reads back to the same settings. (A direct solver is left out of the JSON, so the
/// snapshots above do not change.)
#[test]
fn feti_solver_survives_into_generated_code() {
    use mbdc_runtime::scene::{FetiOptions, FetiPreconditioner, MeshSolver};
    let src = "model plate {
  material alu { E 70 GPa; nu 0.33; rho 2700 kg/m^3 }
  mesh p {
    element quad4
    thickness 1 cm
    generate rect(origin: (0, 0) m, size: (2, 1) m, divisions: (4, 2))
    material alu
    set left = nodes(x == 0)
    fix left
  }
  simulate {
    duration 1 s; step 1 s; mesh_method static
    solver feti { subdomains 8; preconditioner lumped; tolerance 1e-9; max_iterations 500 }
  }
}";
    let loaded = load_str("plate.mbd", src, &[]);
    let scene = loaded.scene.expect("the plate loads");
    let feti = MeshSolver::Feti(FetiOptions {
        subdomains: 8,
        preconditioner: FetiPreconditioner::Lumped,
        tolerance: 1e-9,
        max_iterations: 500,
    });
    assert_eq!(scene.simulate.mesh_solver, feti);
    let carried = r#""mesh_solver":{"feti":{"subdomains":8,"preconditioner":"lumped","tolerance":1e-9,"max_iterations":500}}"#;
    let g = gen(&scene, None);
    assert!(g.scene_json.contains(carried), "{}", g.scene_json);
    let back = mbdc_runtime::compiled::scene_from_json(&g.scene_json).expect("reads back");
    assert_eq!(back.simulate, scene.simulate);
    // Inline: the same JSON is the string literal in the source.
    let inline = generate(
        &scene,
        &Options {
            scene_json: SceneJson::Inline,
            ..options(None)
        },
    )
    .expect("generate");
    assert_eq!(inline.scene_json, g.scene_json);
    assert!(
        inline.source.contains(&carried.replace('"', "\\\"")),
        "the source does not carry the solver"
    );
}
