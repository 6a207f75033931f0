//! One test per construct of the language: the tree the parser builds.

mod common;

use common::{parse_ok, sx};
use mbdc_dsl::ast::*;

fn only_item(src: &str) -> Item {
    let mut f = parse_ok(src);
    assert_eq!(f.items.len(), 1, "expected one item in {src:?}");
    f.items.remove(0)
}

fn prop(src: &str) -> (String, Vec<String>) {
    match only_item(src).kind {
        ItemKind::Prop {
            key,
            values,
            block: None,
        } => (key.name, values.iter().map(common::sexpr).collect()),
        other => panic!("not a property: {other:?}"),
    }
}

// ------------------------------------------------------------------ files and items

#[test]
fn empty_and_blank_files() {
    for src in ["", "\n\n", "  \t\n;;\n ; \n", "\r\n"] {
        let f = parse_ok(src);
        assert!(
            f.items.is_empty() && f.trailing_comments.is_empty(),
            "{src:?}"
        );
    }
}

#[test]
fn comments_only_file_keeps_them_as_trailing() {
    let f = parse_ok("// a\n/* b */\n");
    assert!(f.items.is_empty());
    let texts: Vec<&str> = f
        .trailing_comments
        .iter()
        .map(|c| c.text.as_str())
        .collect();
    assert_eq!(texts, ["// a", "/* b */"]);
}

#[test]
fn import() {
    let item = only_item("import \"parts/link.mbd\"\n");
    let ItemKind::Import { path } = item.kind else {
        panic!()
    };
    assert_eq!(path.value, "parts/link.mbd");
    assert_eq!(path.span, Span::new(7, 23));
}

#[test]
fn param_and_const() {
    let f = parse_ok("param L = 1 m\nconst half = L / 2");
    let ItemKind::Param { name, value } = &f.items[0].kind else {
        panic!()
    };
    assert_eq!(name.name, "L");
    assert_eq!(common::sexpr(value), "1[m]");
    let ItemKind::Const { name, value } = &f.items[1].kind else {
        panic!()
    };
    assert_eq!(name.name, "half");
    assert_eq!(common::sexpr(value), "(/ L 2)");
}

#[test]
fn component_with_parameters_and_defaults() {
    let item =
        only_item("component Pendulum(pivot, L = 1 m, m = 1 kg,) {\n  body bob { mass m }\n}");
    let ItemKind::Component { name, params, body } = item.kind else {
        panic!()
    };
    assert_eq!(name.name, "Pendulum");
    let ps: Vec<(String, Option<String>)> = params
        .iter()
        .map(|p| (p.name.name.clone(), p.default.as_ref().map(common::sexpr)))
        .collect();
    assert_eq!(
        ps,
        [
            ("pivot".into(), None),
            ("L".into(), Some("1[m]".into())),
            ("m".into(), Some("1[kg]".into()))
        ]
    );
    assert_eq!(body.items.len(), 1);
}

#[test]
fn component_without_parameters_and_params_over_lines() {
    let item = only_item("component C() {}");
    let ItemKind::Component { params, body, .. } = item.kind else {
        panic!()
    };
    assert!(params.is_empty() && body.items.is_empty());
    let item = only_item("component C(\n  a,\n  b = 2\n) {\n}");
    let ItemKind::Component { params, .. } = item.kind else {
        panic!()
    };
    assert_eq!(params.len(), 2);
}

#[test]
fn for_loop() {
    let item = only_item("for i in 0..N {\n  body link[i] { mass 1 kg }\n}");
    let ItemKind::For {
        var,
        start,
        end,
        body,
    } = item.kind
    else {
        panic!()
    };
    assert_eq!(var.name, "i");
    assert_eq!(common::sexpr(&start), "0");
    assert_eq!(common::sexpr(&end), "N");
    assert_eq!(body.items.len(), 1);
    // Ranges with expressions and a number with a unit before `..`.
    let item = only_item("for k in i + 1..2 * N - 1 {}");
    let ItemKind::For { start, end, .. } = item.kind else {
        panic!()
    };
    assert_eq!(
        (common::sexpr(&start).as_str(), common::sexpr(&end).as_str()),
        ("(+ i 1)", "(- (* 2 N) 1)")
    );
    let item = only_item("for x in 1.5..a.b {}");
    let ItemKind::For { start, end, .. } = item.kind else {
        panic!()
    };
    assert_eq!(
        (common::sexpr(&start).as_str(), common::sexpr(&end).as_str()),
        ("1.5", "(. a b)")
    );
}

#[test]
fn if_else_and_else_if_chains() {
    let item = only_item("if i == 0 {\n  a 1\n} else {\n  b 2\n}");
    let ItemKind::If {
        cond,
        then,
        otherwise,
    } = item.kind
    else {
        panic!()
    };
    assert_eq!(common::sexpr(&cond), "(== i 0)");
    assert_eq!(then.items.len(), 1);
    assert_eq!(otherwise.map(|b| b.items.len()), Some(1));

    let src = "if a { x 1 } else if b { x 2 } else if c { x 3 } else { x 4 }";
    let item = only_item(src);
    let mut conds = Vec::new();
    let mut cur = item;
    let last_else = loop {
        let ItemKind::If {
            cond, otherwise, ..
        } = cur.kind
        else {
            panic!()
        };
        conds.push(common::sexpr(&cond));
        let other = otherwise.expect("else branch");
        match &other.items[..] {
            [Item {
                kind: ItemKind::If { .. },
                span,
                ..
            }] => {
                // The nested `if` spans from its keyword to the end of the chain, and so does
                // the block wrapping it.
                assert_eq!(&src[span.start..span.start + 2], "if");
                assert_eq!(span.end, src.len());
                assert_eq!(other.span, *span);
                cur = other
                    .items
                    .into_iter()
                    .next()
                    .unwrap_or_else(|| unreachable!());
            }
            _ => break other,
        }
    };
    assert_eq!(conds, ["a", "b", "c"]);
    assert_eq!(last_else.items.len(), 1);

    let item = only_item("if a {}");
    let ItemKind::If { otherwise, .. } = item.kind else {
        panic!()
    };
    assert!(otherwise.is_none());
}

#[test]
fn else_may_start_the_next_line() {
    let item = only_item("if a {\n  x 1\n}\nelse {\n  x 2\n}\n");
    let ItemKind::If { otherwise, .. } = item.kind else {
        panic!()
    };
    assert!(otherwise.is_some());
    let item = only_item("if a {\n} // why\n\n else if b {\n}\n");
    let ItemKind::If { otherwise, .. } = &item.kind else {
        panic!()
    };
    assert!(otherwise.is_some());
    assert_eq!(
        item.comments.len(),
        1,
        "the comment inside the if item moves above it"
    );
}

#[test]
fn declarations_in_all_forms() {
    let decl = |src: &str| match only_item(src).kind {
        ItemKind::Decl {
            keyword,
            name,
            value,
            body,
        } => (
            keyword.name,
            name.map(|n| {
                (
                    n.base.name,
                    n.indices.iter().map(common::sexpr).collect::<Vec<_>>(),
                )
            }),
            value.map(|v| common::sexpr(&v)),
            body.map(|b| b.items.len()),
        ),
        other => panic!("not a declaration: {other:?}"),
    };
    assert_eq!(
        decl("model m {\n}"),
        ("model".into(), Some(("m".into(), vec![])), None, Some(0))
    );
    assert_eq!(
        decl("simulate { duration 1 s; step 1 ms }"),
        ("simulate".into(), None, None, Some(2))
    );
    assert_eq!(
        decl("joint hinge = revolute(a @ (0, 0, 0), b @ p, axis: (0, 1, 0))"),
        (
            "joint".into(),
            Some(("hinge".into(), vec![])),
            Some("(call revolute (@ a (tuple 0 0 0)) (@ b p) axis:(tuple 0 1 0))".into()),
            None
        )
    );
    assert_eq!(
        decl("method staggered { epsilon 1e-6 }"),
        (
            "method".into(),
            Some(("staggered".into(), vec![])),
            None,
            Some(1)
        )
    );
    assert_eq!(
        decl("instance a = Link(L: 1 m) { extra 1 }"),
        (
            "instance".into(),
            Some(("a".into(), vec![])),
            Some("(call Link L:1[m])".into()),
            Some(1)
        )
    );
    assert_eq!(
        decl("output = x { every 10 }"),
        ("output".into(), None, Some("x".into()), Some(1))
    );
    assert_eq!(
        decl("body grid[i][j + 1] { mass 1 }"),
        (
            "body".into(),
            Some(("grid".into(), vec!["i".into(), "(+ j 1)".into()])),
            None,
            Some(1)
        )
    );
    assert_eq!(
        decl("set left = nodes(x == 0)"),
        (
            "set".into(),
            Some(("left".into(), vec![])),
            Some("(call nodes (== x 0))".into()),
            None
        )
    );
    // `model` and `instance` are ordinary words: they may be names.
    assert_eq!(
        decl("body model {}"),
        ("body".into(), Some(("model".into(), vec![])), None, Some(0))
    );
}

#[test]
fn properties_with_zero_one_and_many_values() {
    assert_eq!(prop("clamp"), ("clamp".into(), vec![]));
    assert_eq!(prop("fix left"), ("fix".into(), vec!["left".into()]));
    assert_eq!(prop("mass 1 kg"), ("mass".into(), vec!["1[kg]".into()]));
    assert_eq!(
        prop("include bodies, energy, constraints").1,
        ["bodies", "energy", "constraints"]
    );
    assert_eq!(
        prop("angular_velocity (0.01, 2, 0) rad/s, body").1,
        ["(unit rad/s (tuple 0.01 2 0))", "body"]
    );
    assert_eq!(
        prop("clamp end, arm @ (0, 0, 1)").1,
        ["end", "(@ arm (tuple 0 0 1))"]
    );
    assert_eq!(prop("offset -1").1, ["(neg 1)"]);
    assert_eq!(
        prop("points [(0, 0), (1, 2)]").1,
        ["(list (tuple 0 0) (tuple 1 2))"]
    );
    assert_eq!(prop("position(0, 0, 1)").1, ["(tuple 0 0 1)"]);
    assert_eq!(prop("fix link[2]").1, ["(index link 2)"]);
    assert_eq!(prop("single_stage false").1, ["false"]);
}

#[test]
fn a_property_may_end_with_an_options_block() {
    let it = only_item("glue right, fine.left { traction bessel(points: 8) }");
    let ItemKind::Prop {
        key,
        values,
        block: Some(b),
    } = it.kind
    else {
        panic!("not a property with a block: {:?}", it.kind);
    };
    assert_eq!(key.name, "glue");
    let values: Vec<String> = values.iter().map(common::sexpr).collect();
    assert_eq!(values, ["right", "(. fine left)"]);
    assert_eq!(b.items.len(), 1);
    assert!(
        matches!(&b.items[0].kind, ItemKind::Prop { key, block: None, .. } if key.name == "traction")
    );
    // Over several lines, with a comment inside, and an empty block.
    let f =
        parse_ok("glue a, m.b {\n  // why\n  traction polynomial(degree: 2)\n}\nglue a, m.c {}\n");
    assert_eq!(f.items.len(), 2);
    match &f.items[0].kind {
        ItemKind::Prop { block: Some(b), .. } => {
            assert_eq!(b.items[0].comments[0].text, "// why");
        }
        other => panic!("{other:?}"),
    }
    assert!(
        matches!(&f.items[1].kind, ItemKind::Prop { block: Some(b), .. } if b.items.is_empty())
    );
    // With one plain name before the block it is a declaration, as always; after one
    // value of another form a block is an error.
    assert!(matches!(
        only_item("glue right { a 1 }").kind,
        ItemKind::Decl { .. }
    ));
    assert!(mbdc_dsl::parse("glue m.b { a 1 }").is_err());
    // The block starts on the line of the property.
    assert!(mbdc_dsl::parse("glue a, m.b\n{ traction x }").is_err());
}

#[test]
fn items_are_separated_by_newlines_or_semicolons() {
    let f = parse_ok("a 1; b 2\n\n\nc 3 ;; d 4\r\ne 5\n");
    let keys: Vec<String> = f
        .items
        .iter()
        .map(|i| match &i.kind {
            ItemKind::Prop { key, .. } => key.name.clone(),
            _ => panic!(),
        })
        .collect();
    assert_eq!(keys, ["a", "b", "c", "d", "e"]);
    let f = parse_ok("body a { mass 1 }; body b { mass 2 }");
    assert_eq!(f.items.len(), 2);
}

#[test]
fn newlines_inside_brackets_and_after_operators_or_commas_continue() {
    assert_eq!(prop("position (1,\n  2,\n  3)").1, ["(tuple 1 2 3)"]);
    assert_eq!(prop("points [\n  1\n  , 2\n]").1, ["(list 1 2)"]);
    assert_eq!(prop("x a +\n  b").1, ["(+ a b)"]);
    assert_eq!(prop("x a @ // comment\n  b").1, ["(@ a b)"]);
    assert_eq!(prop("x a and\n b or\n c").1, ["(or (and a b) c)"]);
    assert_eq!(prop("include a,\n  b").1, ["a", "b"]);
    let item = only_item("joint j = f(\n  a,\n  b\n)");
    assert!(matches!(item.kind, ItemKind::Decl { .. }));
    // A line that *starts* with an operator is a new item (and so an error here).
    let e = common::first_error("x a\n- b");
    assert_eq!(e.span, Span::new(4, 5));
    assert!(e
        .help
        .unwrap_or_default()
        .contains("end the previous line with the operator"));
}

#[test]
fn a_unit_never_crosses_a_line_break() {
    let f = parse_ok("every 10\nsteps");
    assert_eq!(f.items.len(), 2);
    let f = parse_ok("every 10 // note\nsteps");
    assert_eq!(f.items.len(), 2);
    // Inside parentheses the newline is whitespace but still ends the number.
    assert!(mbdc_dsl::parse("x (1\n m)").is_err());
    assert_eq!(sx("(1 m\n)"), "(paren 1[m])");
}

// ------------------------------------------------------------------ expressions

#[test]
fn numbers_keep_their_text() {
    for (src, text, value) in [
        ("1", "1", 1.0),
        ("2.5", "2.5", 2.5),
        ("1e-6", "1e-6", 1e-6),
        ("6.02E23", "6.02E23", 6.02e23),
        ("1e+3", "1e+3", 1e3),
    ] {
        let e = mbdc_dsl::parse_expr(src).unwrap_or_else(|e| panic!("{e:?}"));
        let ExprKind::Number {
            value: v,
            text: t,
            unit,
        } = e.kind
        else {
            panic!()
        };
        assert_eq!((t.as_str(), v, unit), (text, value, None));
    }
}

#[test]
fn units_after_numbers() {
    assert_eq!(sx("9.81 m/s^2"), "9.81[m/s^2]");
    assert_eq!(sx("2m"), "2[m]");
    assert_eq!(sx("2\tm"), "2[m]");
    assert_eq!(sx("1e-6"), "1e-6");
    assert_eq!(sx("1e-6 m"), "1e-6[m]");
    assert_eq!(sx("1e-6m"), "1e-6[m]");
    assert_eq!(sx("2e"), "2[e]");
    assert_eq!(sx("1 kg*m^2"), "1[kg*m^2]");
    assert_eq!(sx("0.1 N*s/m"), "0.1[N*s/m]");
    assert_eq!(sx("10 1/s"), "10[1/s]");
    assert_eq!(sx("3 s^-1"), "3[s^-1]");
    assert_eq!(sx("3 in"), "3[in]");
    // A space ends the unit.
    assert_eq!(sx("1 m * L"), "(* 1[m] L)");
    assert_eq!(sx("9.81 m / s^2"), "(/ 9.81[m] (^ s 2))");
    assert_eq!(sx("2 m ^ 2"), "(^ 2[m] 2)");
    // `20/s` is a division by the name `s`, not a unit.
    assert_eq!(sx("20/s"), "(/ 20 s)");
    assert_eq!(sx("1/L"), "(/ 1 L)");
    // `and`/`or` after a number are operators.
    assert_eq!(sx("x > 1 and y"), "(and (> x 1) y)");
    assert_eq!(sx("1 or 2"), "(or 1 2)");
}

#[test]
fn unit_factors_and_exponents() {
    let unit = |src: &str| {
        let e = mbdc_dsl::parse_expr(src).unwrap_or_else(|e| panic!("{e:?}"));
        let ExprKind::Number { unit: Some(u), .. } = e.kind else {
            panic!("{src}")
        };
        (
            u.text.clone(),
            u.factors
                .iter()
                .map(|(i, p)| (i.name.clone(), *p))
                .collect::<Vec<_>>(),
        )
    };
    let f = |v: &[(&str, i32)]| {
        v.iter()
            .map(|(n, p)| (n.to_string(), *p))
            .collect::<Vec<_>>()
    };
    assert_eq!(unit("1 m/s^2"), ("m/s^2".into(), f(&[("m", 1), ("s", -2)])));
    assert_eq!(
        unit("1 kg*m^2"),
        ("kg*m^2".into(), f(&[("kg", 1), ("m", 2)]))
    );
    assert_eq!(
        unit("1 N*s/m"),
        ("N*s/m".into(), f(&[("N", 1), ("s", 1), ("m", -1)]))
    );
    assert_eq!(unit("1 1/s"), ("1/s".into(), f(&[("s", -1)])));
    assert_eq!(unit("1 s^-1"), ("s^-1".into(), f(&[("s", -1)])));
    assert_eq!(
        unit("1 kg/m/s^-2"),
        ("kg/m/s^-2".into(), f(&[("kg", 1), ("m", -1), ("s", 2)]))
    );
    assert_eq!(unit("1 1/m^3"), ("1/m^3".into(), f(&[("m", -3)])));
    // The unit's span covers its text only.
    let e = mbdc_dsl::parse_expr("12   kg*m^2").unwrap_or_else(|e| panic!("{e:?}"));
    let ExprKind::Number { unit: Some(u), .. } = e.kind else {
        panic!()
    };
    assert_eq!((u.span, e.span), (Span::new(5, 11), Span::new(0, 11)));
}

#[test]
fn units_after_closing_parentheses() {
    assert_eq!(
        sx("(0, 0, -9.81) m/s^2"),
        "(unit m/s^2 (tuple 0 0 (neg 9.81)))"
    );
    assert_eq!(sx("(L/2) m"), "(unit m (paren (/ L 2)))");
    assert_eq!(sx("(L/2)m"), "(unit m (paren (/ L 2)))");
    assert_eq!(
        sx("diag(1, 2, 3) kg*m^2"),
        "(unit kg*m^2 (call diag 1 2 3))"
    );
    assert_eq!(sx("a @ (0, 0, 20) cm"), "(@ a (unit cm (tuple 0 0 20)))");
}

#[test]
fn precedence_and_associativity() {
    let cases = [
        ("a + b * c", "(+ a (* b c))"),
        ("a * b + c", "(+ (* a b) c)"),
        ("a - b - c", "(- (- a b) c)"),
        ("a / b / c", "(/ (/ a b) c)"),
        ("a % b * c", "(* (% a b) c)"),
        ("a ^ b ^ c", "(^ a (^ b c))"),
        ("-x^2", "(neg (^ x 2))"),
        ("-x * y", "(* (neg x) y)"),
        ("2^-1", "(^ 2 (neg 1))"),
        ("2^-x^2", "(^ 2 (neg (^ x 2)))"),
        ("2^-x*3", "(* (^ 2 (neg x)) 3)"),
        ("--x", "(neg (neg x))"),
        ("a - -b", "(- a (neg b))"),
        ("a * -b", "(* a (neg b))"),
        ("a < b + 1", "(< a (+ b 1))"),
        ("a == b and c != d", "(and (== a b) (!= c d))"),
        ("a or b and c", "(or a (and b c))"),
        ("not a and b", "(and (not a) b)"),
        ("not a == b", "(not (== a b))"),
        ("not not a", "(not (not a))"),
        ("a and not b or c", "(or (and a (not b)) c)"),
        ("x <= 1 or x >= 2", "(or (<= x 1) (>= x 2))"),
        ("a @ b + c", "(@ a (+ b c))"),
        ("a or b @ c", "(@ (or a b) c)"),
        (
            "link[i - 1] @ (L / 2, 0, 0)",
            "(@ (index link (- i 1)) (tuple (/ L 2) 0 0))",
        ),
        ("a @ not b", "(@ a (not b))"),
        ("f(x)^2", "(^ (call f x) 2)"),
        ("(a + b)^2", "(^ (paren (+ a b)) 2)"),
        ("-(a)", "(neg (paren a))"),
    ];
    for (src, want) in cases {
        assert_eq!(sx(src), want, "{src}");
    }
}

#[test]
fn parentheses_tuples_and_lists() {
    assert_eq!(sx("(x)"), "(paren x)");
    assert_eq!(sx("((x))"), "(paren (paren x))");
    assert_eq!(sx("(a, b)"), "(tuple a b)");
    assert_eq!(sx("(a, b,)"), "(tuple a b)");
    assert_eq!(
        sx("((1, 0, 0), (0, 1, 0), (0, 0, 1))"),
        "(tuple (tuple 1 0 0) (tuple 0 1 0) (tuple 0 0 1))"
    );
    assert_eq!(sx("[]"), "(list )");
    assert_eq!(sx("[1]"), "(list 1)");
    assert_eq!(sx("[1, 2,]"), "(list 1 2)");
    assert_eq!(sx("[(0, 0), (1, 2)]"), "(list (tuple 0 0) (tuple 1 2))");
}

#[test]
fn calls_with_positional_and_named_arguments() {
    assert_eq!(sx("sin(x)"), "(call sin x)");
    assert_eq!(sx("f()"), "(call f)");
    assert_eq!(
        sx("rod(length: 40 cm, radius: 5 mm,)"),
        "(call rod length:40[cm] radius:5[mm])"
    );
    assert_eq!(sx("f(a, radius: 1 cm)"), "(call f a radius:1[cm])");
    assert_eq!(
        sx("table(x, [(0, 0), (1, 2)])"),
        "(call table x (list (tuple 0 0) (tuple 1 2)))"
    );
    // A named argument's value may itself be an attachment.
    assert_eq!(
        sx("P(parent: ground @ (0, 0, 0))"),
        "(call P parent:(@ ground (tuple 0 0 0)))"
    );
}

#[test]
fn indexing_and_member_access() {
    assert_eq!(sx("link[i]"), "(index link i)");
    assert_eq!(sx("grid[i][j]"), "(index (index grid i) j)");
    assert_eq!(sx("arm.upper"), "(. arm upper)");
    assert_eq!(sx("a.b.c"), "(. (. a b) c)");
    assert_eq!(sx("arm.link[2].x"), "(. (index (. arm link) 2) x)");
    assert_eq!(sx("f(x).y"), "(. (call f x) y)");
    assert_eq!(sx("(a, b)[0]"), "(index (tuple a b) 0)");
    assert_eq!(sx("[a, b][1]"), "(index (list a b) 1)");
}

#[test]
fn strings_booleans_and_names() {
    assert_eq!(sx(r#""models/link.mbd""#), r#""models/link.mbd""#);
    assert_eq!(sx(r#""a \"q\" \\ b\nc""#), r#""a \"q\" \\ b\nc""#);
    assert_eq!(sx(r#""héllo""#), r#""héllo""#);
    assert_eq!(sx("true"), "true");
    assert_eq!(sx("false"), "false");
    assert_eq!(sx("_x1"), "_x1");
    assert_eq!(sx("t"), "t");
    // Reserved words are whole words only.
    assert_eq!(
        sx("iffy + notable + android + order + inner"),
        "(+ (+ (+ (+ iffy notable) android) order) inner)"
    );
}

#[test]
fn parse_expr_for_command_line_overrides() {
    assert_eq!(sx("2m"), "2[m]");
    assert_eq!(sx("(0,0,1) m/s"), "(unit m/s (tuple 0 0 1))");
    assert_eq!(sx("  1 kg  "), "1[kg]");
    assert_eq!(sx("1 +\n 2"), "(+ 1 2)");
    assert_eq!(sx("1\n+ 2 // newlines are whitespace here"), "(+ 1 2)");
    assert!(mbdc_dsl::parse_expr("").is_err());
    assert!(mbdc_dsl::parse_expr("1 2").is_err());
    assert!(mbdc_dsl::parse_expr("mass 1 kg").is_err());
}

// ------------------------------------------------------------------ spans

#[test]
fn spans_are_byte_ranges_of_the_text() {
    let src = "model m {\n  joint j = f(a @ (0, 0, 1) m, axis: x) // note\n}\n";
    let f = parse_ok(src);
    common::check_spans(src, &f);
    let ItemKind::Decl { body: Some(b), .. } = &f.items[0].kind else {
        panic!()
    };
    let item = &b.items[0];
    assert_eq!(
        &src[item.span.start..item.span.end],
        "joint j = f(a @ (0, 0, 1) m, axis: x)"
    );
    let Some(c) = &item.trailing_comment else {
        panic!()
    };
    assert_eq!(&src[c.span.start..c.span.end], "// note");
    let ItemKind::Decl {
        value: Some(v),
        name: Some(n),
        keyword,
        ..
    } = &item.kind
    else {
        panic!()
    };
    assert_eq!(&src[keyword.span.start..keyword.span.end], "joint");
    assert_eq!(&src[n.span.start..n.span.end], "j");
    let ExprKind::Call { args, .. } = &v.kind else {
        panic!()
    };
    let a0 = &args[0].value;
    assert_eq!(&src[a0.span.start..a0.span.end], "a @ (0, 0, 1) m");
    let ExprKind::Binary { rhs, .. } = &a0.kind else {
        panic!()
    };
    assert_eq!(&src[rhs.span.start..rhs.span.end], "(0, 0, 1) m");
    assert_eq!(&src[b.span.start..b.span.end], &src[8..src.len() - 1]);
}

#[test]
fn spans_are_tight_on_a_scene_with_every_construct() {
    let src = r#"
import "a.mbd"
param L = 1 m // length
const k = -x^2 + f(a, b: 2)[0].y
component C(p, q = 2 kg) {
  for i in 0..N {
    body link[i][j] { mass 1 kg; position (i * L, 0, 0) m }
    if i == 0 { a 1 } else if not b { c (1) s } else { d [1, "s"] }
  }
  /* end */
}
model m {
  simulate { duration 1 s }
}
// bye
"#;
    let f = parse_ok(src);
    common::check_spans(src, &f);
    common::check_format_roundtrip(src, &f);
}

// ------------------------------------------------------------------ comments

#[test]
fn comments_attach_to_items() {
    let src = "// lead m\nmodel m { // on brace\n  // lead a\n  a 1 // trail a\n  /* lead b */ b 2; c 3 /* trail c */\n  // end of m\n} // trail m\n// end of file\n";
    let f = parse_ok(src);
    let m = &f.items[0];
    assert_eq!(
        m.comments
            .iter()
            .map(|c| c.text.as_str())
            .collect::<Vec<_>>(),
        ["// lead m"]
    );
    assert_eq!(
        m.trailing_comment.as_ref().map(|c| c.text.as_str()),
        Some("// trail m")
    );
    let ItemKind::Decl { body: Some(b), .. } = &m.kind else {
        panic!()
    };
    let texts = |i: &Item| {
        (
            i.comments
                .iter()
                .map(|c| c.text.clone())
                .collect::<Vec<_>>(),
            i.trailing_comment.as_ref().map(|c| c.text.clone()),
        )
    };
    assert_eq!(
        texts(&b.items[0]),
        (
            vec!["// on brace".into(), "// lead a".into()],
            Some("// trail a".into())
        )
    );
    assert_eq!(texts(&b.items[1]), (vec!["/* lead b */".into()], None));
    assert_eq!(texts(&b.items[2]), (vec![], Some("/* trail c */".into())));
    assert_eq!(
        b.trailing_comments
            .iter()
            .map(|c| c.text.as_str())
            .collect::<Vec<_>>(),
        ["// end of m"]
    );
    assert_eq!(
        f.trailing_comments
            .iter()
            .map(|c| c.text.as_str())
            .collect::<Vec<_>>(),
        ["// end of file"]
    );
}

#[test]
fn comments_inside_an_item_move_above_it() {
    let src = "joint j = f( // first\n  a, /* second */\n  b\n) // trail\n";
    let item = only_item(src);
    assert_eq!(
        item.comments
            .iter()
            .map(|c| c.text.as_str())
            .collect::<Vec<_>>(),
        ["// first", "/* second */"]
    );
    assert_eq!(
        item.trailing_comment.map(|c| c.text),
        Some("// trail".into())
    );
    let item = only_item("body /* kind */ rod {\n  mass 1 // m\n}");
    assert_eq!(item.comments.len(), 1);
    let ItemKind::Decl { body: Some(b), .. } = item.kind else {
        panic!()
    };
    assert_eq!(
        b.items[0]
            .trailing_comment
            .as_ref()
            .map(|c| c.text.as_str()),
        Some("// m")
    );
}

#[test]
fn comment_text_excludes_the_carriage_return_of_crlf_lines() {
    let f = parse_ok("a 1 // x\r\nb 2\r\n");
    assert_eq!(
        f.items[0]
            .trailing_comment
            .as_ref()
            .map(|c| c.text.as_str()),
        Some("// x")
    );
}

#[test]
fn comment_markers_inside_strings_are_text() {
    let item = only_item(r#"import "a//b/*c*/""#);
    let ItemKind::Import { path } = item.kind else {
        panic!()
    };
    assert_eq!(path.value, "a//b/*c*/");
    assert!(item.comments.is_empty());
}
