//! Property: for randomly generated syntax trees (in the form the parser produces),
//! `parse(format(tree)) == tree` modulo spans, and formatting is idempotent.

mod common;

use mbdc_dsl::ast::*;
use proptest::prelude::*;
use proptest::test_runner::Config;

const RESERVED: [&str; 13] = [
    "import",
    "param",
    "const",
    "component",
    "for",
    "in",
    "if",
    "else",
    "and",
    "or",
    "not",
    "true",
    "false",
];

fn sp() -> Span {
    Span::default()
}

fn ident(name: String) -> Ident {
    Ident { name, span: sp() }
}

fn name_str() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => "[a-z][a-z0-9_]{0,5}",
        1 => "[A-Z_][A-Za-z0-9_]{0,8}",
        1 => Just("model".to_string()),
        1 => Just("t".to_string()),
        1 => Just("e".to_string()),
        1 => Just("iffy".to_string()),
    ]
    .prop_filter("not reserved", |s| !RESERVED.contains(&s.as_str()))
}

fn name() -> impl Strategy<Value = Ident> {
    name_str().prop_map(ident)
}

fn unit_name() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => "[a-zA-Z][a-zA-Z]{0,3}",
        1 => Just("in".to_string()),
        1 => Just("e5".to_string()),
        1 => Just("_x".to_string()),
    ]
    .prop_filter("usable as a unit", |s| {
        s == "in" || !RESERVED.contains(&s.as_str())
    })
}

/// A unit as written, with the factors the parser computes from the text.
fn unit() -> impl Strategy<Value = Unit> {
    let atom = (unit_name(), prop::option::of(-3i32..=4), any::<bool>());
    (any::<bool>(), prop::collection::vec(atom, 1..4)).prop_map(|(one, atoms)| {
        let mut text = String::new();
        let mut factors = Vec::new();
        if one {
            text.push_str("1/");
        }
        for (i, (n, exp, div)) in atoms.into_iter().enumerate() {
            let sign = if i == 0 {
                if one {
                    -1
                } else {
                    1
                }
            } else {
                text.push(if div { '/' } else { '*' });
                if div {
                    -1
                } else {
                    1
                }
            };
            text.push_str(&n);
            if let Some(e) = exp {
                text.push_str(&format!("^{e}"));
            }
            factors.push((ident(n), sign * exp.unwrap_or(1)));
        }
        Unit {
            factors,
            text,
            span: sp(),
        }
    })
}

fn number() -> impl Strategy<Value = ExprKind> {
    (
        prop_oneof![
            "[0-9]{1,4}",
            "[0-9]{1,3}\\.[0-9]{1,3}",
            "[0-9]{1,2}(\\.[0-9]{1,2})?[eE][+-]?[0-9]{1,2}",
        ],
        prop::option::weighted(0.4, unit()),
    )
        .prop_map(|(text, unit)| ExprKind::Number {
            value: text.parse().unwrap_or(0.0),
            text,
            unit,
        })
}

fn string_value() -> impl Strategy<Value = String> {
    prop_oneof![
        "[ -~]{0,8}",
        "\\PC{0,6}",
        Just("a\"b\\c\nd\te\r".to_string()),
        Just("//x /* y */".to_string()),
    ]
}

fn leaf() -> impl Strategy<Value = Expr> {
    prop_oneof![
        4 => number(),
        1 => string_value().prop_map(|value| ExprKind::Str(StrLit { value, span: sp() })),
        1 => any::<bool>().prop_map(ExprKind::Bool),
        4 => name().prop_map(ExprKind::Ident),
    ]
    .prop_map(|kind| Expr { kind, span: sp() })
}

const BINOPS: [BinOp; 15] = [
    BinOp::Add,
    BinOp::Sub,
    BinOp::Mul,
    BinOp::Div,
    BinOp::Rem,
    BinOp::Pow,
    BinOp::Eq,
    BinOp::Ne,
    BinOp::Lt,
    BinOp::Le,
    BinOp::Gt,
    BinOp::Ge,
    BinOp::And,
    BinOp::Or,
    BinOp::At,
];

fn bx(e: Expr) -> Box<Expr> {
    Box::new(e)
}

fn e(kind: ExprKind) -> Expr {
    Expr { kind, span: sp() }
}

/// Arbitrary expression trees (not yet in parsed form: see [`canon`]).
fn raw_expr() -> impl Strategy<Value = Expr> {
    leaf().prop_recursive(5, 48, 4, |inner| {
        let args = prop::collection::vec((prop::option::weighted(0.3, name()), inner.clone()), 0..4)
            .prop_map(|v| v.into_iter().map(|(name, value)| Arg { name, value }).collect::<Vec<_>>());
        prop_oneof![
            3 => (prop::sample::select(BINOPS.to_vec()), inner.clone(), inner.clone())
                .prop_map(|(op, l, r)| e(ExprKind::Binary { op, lhs: bx(l), rhs: bx(r) })),
            1 => (prop::sample::select(vec![UnOp::Neg, UnOp::Not]), inner.clone())
                .prop_map(|(op, x)| e(ExprKind::Unary { op, expr: bx(x) })),
            1 => (name(), args).prop_map(|(func, args)| e(ExprKind::Call { func, args })),
            1 => prop::collection::vec(inner.clone(), 2..4).prop_map(|v| e(ExprKind::Tuple(v))),
            1 => prop::collection::vec(inner.clone(), 0..3).prop_map(|v| e(ExprKind::List(v))),
            1 => inner.clone().prop_map(|x| e(ExprKind::Paren(bx(x)))),
            1 => (inner.clone(), unit()).prop_map(|(x, unit)| e(ExprKind::WithUnit { expr: bx(x), unit })),
            1 => (inner.clone(), inner.clone()).prop_map(|(b, i)| e(ExprKind::Index { base: bx(b), index: bx(i) })),
            1 => (inner, name()).prop_map(|(b, member)| e(ExprKind::Member { base: bx(b), member })),
        ]
    })
}

/// Binding power, as the language reference defines it (independent of the crate).
fn prec(x: &Expr) -> u8 {
    match &x.kind {
        ExprKind::Binary { op, .. } => match op {
            BinOp::At => 1,
            BinOp::Or => 2,
            BinOp::And => 3,
            BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => 5,
            BinOp::Add | BinOp::Sub => 6,
            BinOp::Mul | BinOp::Div | BinOp::Rem => 7,
            BinOp::Pow => 9,
        },
        ExprKind::Unary { op: UnOp::Not, .. } => 4,
        ExprKind::Unary { op: UnOp::Neg, .. } => 8,
        _ => 10,
    }
}

fn paren(x: Expr) -> Expr {
    e(ExprKind::Paren(bx(x)))
}

fn at_least(x: Expr, min: u8) -> Expr {
    if prec(&x) < min {
        paren(x)
    } else {
        x
    }
}

/// Puts the tree in the form the parser produces: `Paren` wherever the grammar needs
/// parentheses (what a person would have had to write).
fn canon(x: Expr) -> Expr {
    let kind = match x.kind {
        ExprKind::WithUnit { expr, unit } => {
            let inner = canon(*expr);
            let inner = match inner.kind {
                ExprKind::Call { .. } | ExprKind::Paren(_) | ExprKind::Tuple(_) => inner,
                _ => paren(inner),
            };
            ExprKind::WithUnit {
                expr: bx(inner),
                unit,
            }
        }
        ExprKind::Index { base, index } => ExprKind::Index {
            base: bx(postfix_base(canon(*base))),
            index: bx(canon(*index)),
        },
        ExprKind::Member { base, member } => ExprKind::Member {
            base: bx(postfix_base(canon(*base))),
            member,
        },
        ExprKind::Call { func, args } => ExprKind::Call {
            func,
            args: args
                .into_iter()
                .map(|a| Arg {
                    name: a.name,
                    value: canon(a.value),
                })
                .collect(),
        },
        ExprKind::Tuple(v) => ExprKind::Tuple(v.into_iter().map(canon).collect()),
        ExprKind::List(v) => ExprKind::List(v.into_iter().map(canon).collect()),
        ExprKind::Paren(inner) => ExprKind::Paren(bx(canon(*inner))),
        ExprKind::Unary { op, expr } => {
            let min = if op == UnOp::Neg { 8 } else { 4 };
            ExprKind::Unary {
                op,
                expr: bx(at_least(canon(*expr), min)),
            }
        }
        ExprKind::Binary { op, lhs, rhs } => {
            let (lmin, rmin) = match op {
                BinOp::At => (2, 2),
                BinOp::Or => (2, 3),
                BinOp::And => (3, 4),
                BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => (6, 6),
                BinOp::Add | BinOp::Sub => (6, 7),
                BinOp::Mul | BinOp::Div | BinOp::Rem => (7, 8),
                BinOp::Pow => (10, 8),
            };
            ExprKind::Binary {
                op,
                lhs: bx(at_least(canon(*lhs), lmin)),
                rhs: bx(at_least(canon(*rhs), rmin)),
            }
        }
        other => other,
    };
    e(kind)
}

fn postfix_base(b: Expr) -> Expr {
    match b.kind {
        ExprKind::Ident(_)
        | ExprKind::Call { .. }
        | ExprKind::Paren(_)
        | ExprKind::Tuple(_)
        | ExprKind::List(_)
        | ExprKind::Index { .. }
        | ExprKind::Member { .. } => b,
        _ => paren(b),
    }
}

fn expr() -> impl Strategy<Value = Expr> {
    raw_expr().prop_map(canon)
}

fn comment() -> impl Strategy<Value = Comment> {
    let text = prop_oneof![
        "[ -~]{0,12}".prop_map(|t| format!("//{t}")),
        "[ -~\n]{0,12}"
            .prop_filter("no end marker", |t| !t.contains("*/"))
            .prop_map(|t| format!("/*{t}*/")),
    ];
    // blank lines are layout: formatted where they may be, forgotten by the comparison
    (text, any::<bool>()).prop_map(|(text, blank_before)| Comment {
        text,
        span: sp(),
        blank_before,
    })
}

fn comments(max: usize) -> impl Strategy<Value = Vec<Comment>> {
    prop::collection::vec(comment(), 0..=max)
}

fn block(item: BoxedStrategy<Item>) -> impl Strategy<Value = Block> {
    (
        prop::collection::vec(item, 0..4),
        prop::option::weighted(0.2, comments(2)),
    )
        .prop_map(|(items, tc)| Block {
            items,
            trailing_comments: tc.unwrap_or_default(),
            span: sp(),
        })
}

fn decl_name() -> impl Strategy<Value = Name> {
    (name(), prop::collection::vec(expr(), 0..3)).prop_map(|(base, indices)| Name {
        base,
        indices,
        span: sp(),
    })
}

fn item_kind(inner: BoxedStrategy<Item>) -> impl Strategy<Value = ItemKind> {
    let blk = || block(inner.clone());
    let leafy = prop_oneof![
        string_value().prop_map(|value| ItemKind::Import {
            path: StrLit { value, span: sp() }
        }),
        (name(), expr()).prop_map(|(name, value)| ItemKind::Param { name, value }),
        (name(), expr()).prop_map(|(name, value)| ItemKind::Const { name, value }),
        (name(), prop::collection::vec(expr(), 0..4)).prop_map(|(key, values)| ItemKind::Prop {
            key,
            values,
            block: None
        }),
        (name(), decl_name(), expr()).prop_map(|(keyword, n, v)| ItemKind::Decl {
            keyword,
            name: Some(n),
            value: Some(v),
            body: None
        }),
    ];
    let if_kind = (expr(), blk(), 0..3u8, blk(), expr(), blk()).prop_map(
        |(cond, then, form, other, c2, b2)| {
            let otherwise = match form {
                0 => None,
                1 => Some(other),
                _ => {
                    // `else if`: a block holding only an `if` item.
                    let nested = Item {
                        comments: Vec::new(),
                        trailing_comment: None,
                        kind: ItemKind::If {
                            cond: c2,
                            then: b2,
                            otherwise: Some(other),
                        },
                        span: sp(),
                        blank_before: false,
                    };
                    Some(Block {
                        items: vec![nested],
                        trailing_comments: Vec::new(),
                        span: sp(),
                    })
                }
            };
            ItemKind::If {
                cond,
                then,
                otherwise,
            }
        },
    );
    prop_oneof![
        6 => leafy,
        1 => (name(), prop::collection::vec((name(), prop::option::of(expr())), 0..3), blk()).prop_map(
            |(name, ps, body)| ItemKind::Component {
                name,
                params: ps.into_iter().map(|(name, default)| ComponentParam { name, default }).collect(),
                body
            }
        ),
        1 => (name(), expr(), expr(), blk()).prop_map(|(var, start, end, body)| ItemKind::For { var, start, end, body }),
        1 => if_kind,
        2 => (name(), prop::option::of(decl_name()), prop::option::of(expr()), blk()).prop_map(
            |(keyword, name, value, body)| ItemKind::Decl { keyword, name, value, body: Some(body) }
        ),
        // An options block after two or more values (`KEY NAME { ... }` is a declaration).
        1 => (name(), prop::collection::vec(expr(), 2..4), blk()).prop_map(
            |(key, values, b)| ItemKind::Prop { key, values, block: Some(b) }
        ),
    ]
}

fn item() -> impl Strategy<Value = Item> {
    let leaf_item =
        (name(), prop::collection::vec(expr(), 0..3)).prop_map(|(key, values)| ItemKind::Prop {
            key,
            values,
            block: None,
        });
    let wrap = |kind: BoxedStrategy<ItemKind>| {
        (
            prop::option::weighted(0.3, comments(2)),
            prop::option::weighted(0.2, comment()),
            kind,
            any::<bool>(),
        )
            .prop_map(|(c, trailing_comment, kind, blank_before)| Item {
                comments: c.unwrap_or_default(),
                trailing_comment,
                kind,
                span: sp(),
                blank_before,
            })
    };
    wrap(leaf_item.boxed()).prop_recursive(3, 24, 4, move |inner| {
        wrap(item_kind(inner.boxed()).boxed())
    })
}

fn file() -> impl Strategy<Value = File> {
    (
        prop::collection::vec(item(), 0..5),
        prop::option::weighted(0.2, comments(2)),
    )
        .prop_map(|(items, tc)| File {
            items,
            trailing_comments: tc.unwrap_or_default(),
        })
}

fn check_file(f: &File) -> Result<(), TestCaseError> {
    let text = mbdc_dsl::format(f);
    let parsed = mbdc_dsl::parse(&text).map_err(|errors| {
        let rendered: Vec<String> = errors.iter().map(|e| e.render(&text)).collect();
        TestCaseError::fail(format!(
            "formatted tree does not parse:\n{}\n--- text:\n{text}",
            rendered.join("\n")
        ))
    })?;
    common::check_spans(&text, &parsed);
    let again = mbdc_dsl::format(&parsed);
    prop_assert_eq!(&again, &text, "format is not idempotent");
    // blank lines are layout (the formatter drops one at the start of a block and adds one
    // between top-level blocks): compared modulo layout, like spans; that they are kept is
    // the formatter's unit tests' and `models_formatted`'s business
    let parsed = common::stripped(parsed);
    let f = &common::stripped(f.clone());
    prop_assert!(
        parsed == *f,
        "parse(format(tree)) != tree\n--- text:\n{}\n--- parsed:\n{:#?}\n--- tree:\n{:#?}",
        text,
        parsed,
        f
    );
    Ok(())
}

proptest! {
    #![proptest_config(Config { cases: 3000, failure_persistence: None, ..Config::default() })]

    #[test]
    fn generated_expressions_round_trip(x in expr()) {
        let text = mbdc_dsl::format_expr(&x);
        let mut parsed = mbdc_dsl::parse_expr(&text).map_err(|errors| {
            TestCaseError::fail(format!("{text:?} does not parse: {}", errors.iter().map(|e| e.render(&text)).collect::<String>()))
        })?;
        mbdc_dsl::strip_expr_spans(&mut parsed);
        prop_assert!(parsed == x, "{} != tree\n{:#?}\n{:#?}", text, parsed, x);
        prop_assert_eq!(mbdc_dsl::format_expr(&parsed), text);
    }
}

proptest! {
    #![proptest_config(Config { cases: 2000, failure_persistence: None, ..Config::default() })]

    /// Trees built by hand need not contain the `Paren` nodes precedence requires: the
    /// formatter adds exactly those parentheses, so the text parses to the canonical tree.
    #[test]
    fn formatting_adds_exactly_the_needed_parentheses(raw in raw_expr()) {
        let text = mbdc_dsl::format_expr(&raw);
        let mut parsed = mbdc_dsl::parse_expr(&text).map_err(|errors| {
            TestCaseError::fail(format!("{text:?} does not parse: {}", errors.iter().map(|e| e.render(&text)).collect::<String>()))
        })?;
        mbdc_dsl::strip_expr_spans(&mut parsed);
        let want = canon(raw);
        prop_assert!(parsed == want, "{} parsed differently from the canonical tree\n{:#?}\n{:#?}", text, parsed, want);
    }
}

proptest! {
    #![proptest_config(Config { cases: 2000, failure_persistence: None, ..Config::default() })]

    #[test]
    fn generated_files_round_trip(f in file()) {
        check_file(&f)?;
    }
}

/// Trees built by hand may lack the parentheses precedence needs: the formatter adds them,
/// and the text means the same tree (with explicit `Paren` nodes).
#[test]
fn hand_built_trees_get_the_parentheses_they_need() {
    let id = |n: &str| e(ExprKind::Ident(ident(n.into())));
    let bin = |op, l, r| {
        e(ExprKind::Binary {
            op,
            lhs: bx(l),
            rhs: bx(r),
        })
    };
    let un = |op, x| e(ExprKind::Unary { op, expr: bx(x) });
    let cases = [
        (
            bin(BinOp::Mul, bin(BinOp::Add, id("a"), id("b")), id("c")),
            "(a + b) * c",
        ),
        (
            bin(BinOp::Sub, id("a"), bin(BinOp::Sub, id("b"), id("c"))),
            "a - (b - c)",
        ),
        (
            bin(BinOp::Pow, bin(BinOp::Pow, id("a"), id("b")), id("c")),
            "(a^b)^c",
        ),
        (bin(BinOp::Pow, un(UnOp::Neg, id("a")), id("b")), "(-a)^b"),
        (un(UnOp::Neg, bin(BinOp::Pow, id("a"), id("b"))), "-a^b"),
        (
            bin(BinOp::Eq, bin(BinOp::Lt, id("a"), id("b")), id("c")),
            "(a < b) == c",
        ),
        (
            bin(BinOp::Eq, un(UnOp::Not, id("a")), id("b")),
            "(not a) == b",
        ),
        (
            bin(BinOp::At, bin(BinOp::At, id("a"), id("b")), id("c")),
            "(a @ b) @ c",
        ),
        (un(UnOp::Neg, un(UnOp::Not, id("a"))), "-(not a)"),
        (
            e(ExprKind::WithUnit {
                expr: bx(id("L")),
                unit: Unit {
                    factors: vec![],
                    text: "m".into(),
                    span: sp(),
                },
            }),
            "(L) m",
        ),
        (
            e(ExprKind::Member {
                base: bx(bin(BinOp::Add, id("a"), id("b"))),
                member: ident("x".into()),
            }),
            "(a + b).x",
        ),
        (
            e(ExprKind::Index {
                base: bx(e(ExprKind::Number {
                    value: 1.0,
                    text: "1".into(),
                    unit: None,
                })),
                index: bx(id("i")),
            }),
            "(1)[i]",
        ),
        (
            bin(
                BinOp::Pow,
                e(ExprKind::Number {
                    value: 2.0,
                    text: "2".into(),
                    unit: Some(Unit {
                        factors: vec![(ident("m".into()), 1)],
                        text: "m".into(),
                        span: sp(),
                    }),
                }),
                id("k"),
            ),
            "2 m ^ k",
        ),
        (
            e(ExprKind::Number {
                value: 0.5,
                text: String::new(),
                unit: None,
            }),
            "0.5",
        ),
        (
            e(ExprKind::Number {
                value: 1.0,
                text: "1".into(),
                unit: Some(Unit {
                    factors: vec![(ident("kg".into()), 1), (ident("s".into()), -2)],
                    text: String::new(),
                    span: sp(),
                }),
            }),
            "1 kg*s^-2",
        ),
    ];
    for (tree, text) in cases {
        assert_eq!(mbdc_dsl::format_expr(&tree), text);
        let mut back = mbdc_dsl::parse_expr(text).unwrap_or_else(|e| panic!("{text}: {e:?}"));
        mbdc_dsl::strip_expr_spans(&mut back);
        // Same text again: the parenthesized tree is the canonical form of the hand-built one.
        assert_eq!(mbdc_dsl::format_expr(&back), text);
    }
}
