//! One bad value gives one error, not one per use; and a long flat expression is limited by
//! its depth, not its length.

fn load(src: &str) -> mbdc_compiler::Loaded {
    mbdc_compiler::load_str("m.mbd", src, &[])
}

fn errors(l: &mbdc_compiler::Loaded) -> Vec<String> {
    l.errors().map(|d| d.message.clone()).collect()
}

/// An overflowing `const` used by 500 generated bodies gave one "not finite" error and 500
/// "unknown name" errors after it; its uses are now errors that are not reported again.
#[test]
fn a_failed_const_is_reported_once() {
    let src = "model m {\n  const big = 1e200 * 1e200\n  const twice = 2 * big\n  for i in 0..500 {\n    body b[i] { mass big * 1 kg; inertia sphere(radius: 1 cm); position (i * 1 m, 0, 0) }\n  }\n  body c { mass twice * 1 kg; inertia sphere(radius: 1 cm) }\n  simulate { duration 1 s; step 1 ms }\n}\n";
    let l = load(src);
    let e = errors(&l);
    assert_eq!(e.len(), 1, "{}", l.render_plain());
    assert!(!e[0].contains("unknown name"), "{e:?}");
    // a failed `param` too
    let src = "model m {\n  param p = 1 m + 1 kg\n  for i in 0..50 {\n    body b[i] { mass 1 kg; inertia sphere(radius: p) }\n  }\n  simulate { duration 1 s; step 1 ms }\n}\n";
    let l = load(src);
    assert_eq!(errors(&l).len(), 1, "{}", l.render_plain());
    // a name that was never declared is still reported at every use
    let src = "model m {\n  body a { mass nope * 1 kg; inertia sphere(radius: 1 cm) }\n  body b { mass nope * 1 kg; inertia sphere(radius: 1 cm) }\n  simulate { duration 1 s; step 1 ms }\n}\n";
    let l = load(src);
    let e = errors(&l);
    assert_eq!(e.len(), 2, "{}", l.render_plain());
    assert!(e.iter().all(|m| m.contains("unknown name `nope`")), "{e:?}");
}

/// A flat sum of 200 terms was refused as "expression nested too deeply" (the evaluator
/// recursed once per `+`), and one of 300 by the parser: a chain's depth is 1. Long chains
/// are bounded by their own limit, with their own message.
#[test]
fn a_flat_sum_is_limited_by_depth_not_length() {
    for n in [200, 300, 1000] {
        let sum = vec!["0.001"; n].join(" + ");
        let src = format!(
            "model m {{\n  const s = {sum}\n  const d = 1 - 0.001 - 0.001 * 2 / 2 {}\n  body b {{ mass s * 1 kg; inertia sphere(radius: d * 1 cm) }}\n  simulate {{ duration 1 s; step 1 ms }}\n}}\n",
            " - 0.0001".repeat(n)
        );
        let l = load(&src);
        assert!(!l.has_errors(), "{n} terms: {}", l.render_plain());
        let scene = l.scene.expect("scene");
        let expected = 0.001 * n as f64;
        assert!(
            (scene.bodies[0].mass - expected).abs() < 1e-9 * expected,
            "{n}"
        );
    }
    // a time function of 250 terms: one level of the parser's nesting, and of the evaluator's
    let terms: Vec<String> = (1..=250)
        .map(|k| format!("0.001 * sin({k} * t / 1 s) * 1 rad"))
        .collect();
    let src = format!(
        "model m {{\n  body b {{ mass 1 kg; inertia sphere(radius: 1 cm) }}\n  joint j = revolute(ground @ (0, 0, 0), b @ (0, 0, 0), axis: (0, 0, 1))\n  joint motor = drive_angle(j, {})\n  simulate {{ duration 1 s; step 1 ms }}\n}}\n",
        terms.join(" + ")
    );
    let l = load(&src);
    assert!(
        !errors(&l).iter().any(|m| m.contains("nested too deeply")),
        "{}",
        l.render_plain()
    );
    // past the length limit: its own message, at the operator that crosses it
    let n = mbdc_dsl::MAX_OPERATORS + 1;
    let src = format!(
        "model m {{\n  const s = {}\n  simulate {{ duration 1 s; step 1 ms }}\n}}\n",
        vec!["1"; n + 1].join(" + ")
    );
    let e = errors(&load(&src));
    assert_eq!(
        e,
        [format!(
            "more than {} operators in one expression",
            mbdc_dsl::MAX_OPERATORS
        )]
    );
    // deep nesting is still refused
    let deep = format!("{}1{}", "(".repeat(300), ")".repeat(300));
    let src =
        format!("model m {{\n  const s = {deep}\n  simulate {{ duration 1 s; step 1 ms }}\n}}\n");
    let e = errors(&load(&src));
    assert!(
        e.iter().any(|m| m.starts_with("nested too deeply")),
        "{e:?}"
    );
}
