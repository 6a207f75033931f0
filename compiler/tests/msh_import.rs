//! Gmsh import end to end: elements of the mesh's kind, physical groups as sets, faces.

use std::path::Path;

use mbdc_runtime::scene::MeshCondition;

/// Loads `src` as a model file in the tests' data folder (where the .msh files are).
fn load_in_data(src: &str) -> mbdc_compiler::Loaded {
    let name = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/import_test.mbd");
    mbdc_compiler::load_str(&name.to_string_lossy(), src, &[])
}

#[test]
fn imports_quads_and_groups() {
    let src = "model m {\n  material alu { E 70 GPa; nu 0.33; rho 2700 kg/m^3 }\n  mesh p {\n    element quad4\n    thickness 1 cm\n    import \"two_quads.msh\"\n    material alu\n    set left = group(\"left\")\n    set right = group(\"right\")\n    set all = group(\"plate\")\n    fix left\n    traction right, (1 MPa, 0)\n  }\n  simulate { duration 1 ms; step 1 us }\n}\n";
    let loaded = load_in_data(src);
    assert!(!loaded.has_errors(), "{}", loaded.render_plain());
    let scene = loaded.scene.expect("scene");
    let m = &scene.meshes[0];
    assert_eq!(m.nodes.len(), 6);
    assert_eq!(m.elements, vec![vec![0, 1, 4, 3], vec![1, 2, 5, 4]]);
    assert_eq!(m.node_sets[0].nodes, vec![0, 3]);
    assert_eq!(m.node_sets[0].faces, vec![(0, 3)]);
    assert_eq!(m.node_sets[1].nodes, vec![2, 5]);
    assert_eq!(m.node_sets[1].faces, vec![(1, 1)]);
    assert_eq!(m.node_sets[2].nodes.len(), 6);
    assert_eq!(m.node_sets[2].faces.len(), 6);
    assert!(matches!(
        m.conditions[1],
        MeshCondition::Traction { set: 1, .. }
    ));
    // The .msh file is in the source map.
    assert!(loaded
        .sources
        .files()
        .any(|(_, f)| f.name.ends_with("two_quads.msh")));

    // A group that does not exist, and a kind the file does not have.
    let bad = src.replace("group(\"right\")", "group(\"rigth\")");
    let l = load_in_data(&bad);
    let d = l.errors().next().expect("an error");
    assert_eq!(d.help.as_deref(), Some("did you mean `right`?"));
    let bad = src.replace("element quad4", "element tri3");
    let l = load_in_data(&bad);
    let d = l.errors().next().expect("an error");
    assert!(d.message.contains("has no tri3 elements"), "{}", d.message);
    assert_eq!(d.help.as_deref(), Some("it has: line2 × 2, quad4 × 2"));
}

/// An import warns about what it leaves out or cannot connect: a triangle in a quad4 mesh
/// (a hole), a node no quad uses, and two nodes at one place (a crack between the quads).
#[test]
fn warns_about_left_out_elements_stray_and_coincident_nodes() {
    let src = "model m {\n  material alu { E 70 GPa; nu 0.33; rho 2700 kg/m^3 }\n  mesh p {\n    element quad4\n    thickness 1 cm\n    import \"cracked_mixed.msh\"\n    material alu\n  }\n  simulate { duration 1 ms; step 1 us }\n}\n";
    let loaded = load_in_data(src);
    assert!(!loaded.has_errors(), "{}", loaded.render_plain());
    let text = loaded.render_plain();
    let warnings: Vec<&str> = text.lines().filter(|l| l.starts_with("warning")).collect();
    assert_eq!(warnings.len(), 3, "{text}");
    assert!(
        text.contains("also has 1 tri3 element(s), which a quad4 mesh leaves out"),
        "{text}"
    );
    assert!(
        text.contains("2 of the 9 nodes of `") && text.contains("(node 8, 9)"),
        "{text}"
    );
    assert!(
        text.contains("has 1 pair(s) of nodes at the same place, first nodes 2 and 7 at (1, 0, 0)"),
        "{text}"
    );
    // The clean file warns about nothing.
    let clean = src.replace("cracked_mixed.msh", "two_quads.msh");
    let loaded = load_in_data(&clean);
    assert!(
        !loaded.render_plain().contains("warning"),
        "{}",
        loaded.render_plain()
    );
}
