//! A large scene written out without loops (1200 bodies, about 11 000 lines) parses,
//! formats, and parses back. (Its speed is measured, not asserted: see the crate report.)

mod common;

fn scene(bodies: usize) -> String {
    let mut s = String::from("// generated\nmodel big {\n  gravity (0, 0, -9.81) m/s^2\n");
    for i in 0..bodies {
        s.push_str(&format!(
            "  // body {i}\n  body b{i} {{\n    mass 1 kg\n    inertia diag(1, 2, 3) kg*m^2\n    position ({i} * 0.1, 0, 0) m\n    velocity (0, 0, 0) m/s // at rest\n  }}\n  joint j{i} = revolute(b{i} @ (0, 0, 0.5) m, ground @ ({i} * 0.1, 0, 0) m, axis: (0, 1, 0))\n  force f{i} = point(b{i} @ (0, 0, 0), (1 N * sin(2 * pi * t), 0, 0))\n"
        ));
    }
    s.push_str("  simulate { duration 1 s; step 1 ms }\n}\n");
    s
}

#[test]
fn a_ten_thousand_line_scene_parses_and_formats() {
    let src = scene(1200);
    assert!(src.lines().count() >= 10_000);
    let file = common::parse_ok(&src);
    let mbdc_dsl::ast::ItemKind::Decl { body: Some(b), .. } = &file.items[0].kind else {
        panic!("model")
    };
    assert_eq!(b.items.len(), 3 * 1200 + 2);
    common::check_spans(&src, &file);
    common::check_format_roundtrip(&src, &file);
}
