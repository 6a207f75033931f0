//! The example's three routes build, run, and give exactly the interpreter's numbers.

use mbdc_example_embed::{double_pendulum_3d, four_bar, pendulum, simulate};
use mbdc_runtime::interp::Interp;

#[test]
fn every_route_runs_and_matches_the_interpreter() {
    let all = mbdc_example_embed::run_all(0.5).expect("embedded scenes load");
    assert_eq!(all.len(), 3);
    let scenes = [
        double_pendulum_3d::Model::scene().unwrap(),
        four_bar::Model::scene().unwrap(),
        pendulum::Model::scene().unwrap(),
    ];
    for (o, scene) in all.iter().zip(&scenes) {
        assert!(o.report.finished, "{}: {:?}", o.name, o.report.failure);
        assert_eq!(o.report.steps, 500, "{}", o.name);
        let i = simulate(&Interp::new(scene).unwrap(), scene, 0.5);
        assert_eq!(i.energy, o.energy, "{}: energies differ", o.name);
        assert_eq!(i.last_positions, o.last_positions, "{}", o.name);
    }
}

#[test]
fn the_file_routes_embed_the_repository_models() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../models/");
    for (file, embedded) in [
        (
            "double_pendulum_3d.mbd",
            double_pendulum_3d::Model::scene().unwrap(),
        ),
        ("four_bar.mbd", four_bar::Model::scene().unwrap()),
    ] {
        let loaded = mbdc_compiler::load_file(format!("{root}{file}"), &[]);
        assert_eq!(loaded.scene.as_ref(), Some(&embedded), "{file}");
    }
    // the inline pendulum: a 1 m rod released at 60°
    let p = pendulum::Model::scene().unwrap();
    assert_eq!(p.bodies.len(), 1);
    assert!((p.bodies[0].position[0] - 0.5 * 60f64.to_radians().sin()).abs() < 1e-15);
}

#[test]
fn a_compiled_model_takes_the_numbers_of_another_scene_of_the_same_structure() {
    // a --set override in mbdc run does this: same code, other numbers
    let root = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../models/double_pendulum_3d.mbd"
    );
    let o: mbdc_compiler::Override = "L=2m".parse().unwrap();
    let scene = mbdc_compiler::load_file(root, &[o]).scene.unwrap();
    use mbdc_runtime::compiled::CompiledModel;
    let m = double_pendulum_3d::Model::from_scene(&scene).expect("same structure");
    let a = simulate(&m, &scene, 0.2);
    let b = simulate(&Interp::new(&scene).unwrap(), &scene, 0.2);
    assert_eq!(a.energy, b.energy);
    // another structure is refused
    let other = four_bar::Model::scene().unwrap();
    assert!(double_pendulum_3d::Model::from_scene(&other).is_err());
}
