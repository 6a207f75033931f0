//! Every parse error the grammar can produce, in plain words, at the right place.

mod common;

use common::first_error;
use mbdc_dsl::ast::Span;

/// (input, start of the expected message, text under the error span)
const CASES: &[(&str, &str, &str)] = &[
    // items
    (
        "param L =\nbody b { mass 1 }",
        "expected an expression after `=`, found the end of the line",
        "",
    ),
    (
        "param L\n",
        "expected `=` after `L`, found the end of the line",
        "",
    ),
    (
        "const",
        "expected a name after `const`, found the end of the file",
        "",
    ),
    ("import models", "expected a string in quotes", "models"),
    (
        "mass = 1 kg",
        "`mass = ...` has no name: a declaration without a name needs a block",
        "mass = 1 kg",
    ),
    (
        "body rod\n{ mass 1 }",
        "expected a declaration or a property, found `{`",
        "{",
    ),
    (
        "x a\n+ b",
        "expected a declaration or a property, found `+`",
        "+",
    ),
    (
        "model m {\n  5 kg\n}",
        "expected a declaration or a property, found `5`",
        "5",
    ),
    (
        "mass 1 kg m^2",
        "expected `,`, a new line or `;` after `kg`, found `m`",
        "m",
    ),
    (
        "a 1 2",
        "expected `,`, a new line or `;` after `1`, found `2`",
        "2",
    ),
    (
        "const y = sin (x)",
        "expected a new line or `;` after `sin`, found `(`",
        "(",
    ),
    (
        "body link [i] { }",
        "expected `=`, `{`, `,`, a new line or `;` after `link`, found `[`",
        "[",
    ),
    (
        "body rod x {\n}",
        "expected `,`, a new line or `;` after `x`, found `{`",
        "{",
    ),
    (
        "mass: 1 kg",
        "expected `=`, `{`, a new line or `;` after `mass`, found `:`",
        ":",
    ),
    (
        "a {} b {}",
        "expected a new line or `;` after `}`, found `b`",
        "b",
    ),
    (
        "body for { }",
        "`for` is a reserved word and cannot be used as a name",
        "for",
    ),
    (
        "param if = 1",
        "`if` is a reserved word and cannot be used as a name",
        "if",
    ),
    (
        "component C(a, in) { }",
        "`in` is a reserved word and cannot be used as a name",
        "in",
    ),
    ("else { }", "`else` without `if`", "else"),
    (
        "if x\n{ }",
        "expected `{` after `x`, found the end of the line",
        "",
    ),
    ("for i 0..N { }", "expected `in` after `i`, found `0`", "0"),
    (
        "for i in 0 N { }",
        "expected `..` after `N`, found `{`",
        "{",
    ),
    ("component C { }", "expected `(` after `C`, found `{`", "{"),
    // brackets, strings, comments
    (
        "model m {\n  body a {\n    mass 1\n  body b { mass 2 }\n}\n",
        "unclosed `{` opened here",
        "{",
    ),
    ("x y = f(a, b", "unclosed `(` opened here", "("),
    ("x y = [1, 2", "unclosed `[` opened here", "["),
    (
        "model m { mass (1, 2 }",
        "expected `)` to close the `(` on line 1, found `}`",
        "}",
    ),
    ("x }", "unexpected `}`: there is no open `{` to close", "}"),
    (
        "x y = (1]",
        "expected `)` to close the `(` on line 1, found `]`",
        "]",
    ),
    ("x y = \"abc\nz 1", "unterminated string", "\"abc"),
    ("x y = \"abc\\", "unterminated string", "\"abc\\"),
    ("/* never closed", "unterminated block comment", "/*"),
    ("x y = \"a\\qb\"", "unknown escape `\\q` in a string", "\\q"),
    // expressions
    ("x y = a == b == c", "comparisons cannot be chained", "=="),
    ("x y = a < b > c", "comparisons cannot be chained", ">"),
    (
        "x y = a @ b @ c",
        "only one `@` is allowed in an expression",
        "@",
    ),
    (
        "x y = a == not b",
        "`not` must be put in parentheses after `==`",
        "not",
    ),
    (
        "x y = a + not b",
        "`not` must be put in parentheses after `+`",
        "not",
    ),
    (
        "x y = a ^ not b",
        "`not` must be put in parentheses after `^`",
        "not",
    ),
    ("x y = -not b", "`not` cannot follow a unary `-`", "not"),
    (
        "x y = L m",
        "a unit must follow a number or a closing parenthesis directly, e.g. `2 m`",
        "m",
    ),
    (
        "x y = a[1] kg",
        "a unit must follow a number or a closing parenthesis directly",
        "kg",
    ),
    (
        "x y = [1, 2] m",
        "a unit must follow a number or a closing parenthesis directly",
        "m",
    ),
    (
        "x y = f(a b)",
        "a unit must follow a number or a closing parenthesis directly",
        "b",
    ),
    ("x y = (a,)", "a tuple needs at least two elements", "(a,)"),
    ("x y = ()", "empty parentheses", "()"),
    ("x y = 1e999", "the number `1e999` is too large", "1e999"),
    (
        "x y = 2 m^99999999999",
        "the unit exponent `99999999999` is too large",
        "99999999999",
    ),
    (
        "x y = 1N*sin(t)",
        "expected `{`, a new line or `;` after `sin`, found `(`",
        "(",
    ),
    ("x y = a.b(c)", "only a plain name can be called", "("),
    ("x y = 2 $ 3", "unexpected character `$`", "$"),
    ("x y = 2 ° 3", "unexpected character `°`", "°"),
    (
        "x y = 1 +",
        "expected an expression after `+`, found the end of the file",
        "",
    ),
    (
        "x y = f(1,,2)",
        "expected an expression after `,`, found `,`",
        ",",
    ),
    (
        "x y = f(a:)",
        "expected an expression after `:`, found `)`",
        ")",
    ),
    (
        "x y = (1 2)",
        "expected `,` or `)` after `1`, found `2`",
        "2",
    ),
    ("x y = a.", "expected a name after `.`", ""),
    (
        "x y = .5",
        "expected an expression after `=`, found `.`",
        ".",
    ),
    (
        "x y = 5.",
        "expected `{`, a new line or `;` after `5`, found `.`",
        ".",
    ),
    (
        "body rod = {\n}",
        "expected an expression after `=`, found `{`",
        "{",
    ),
    ("x y = a.1", "expected a name after `.`, found `1`", "1"),
];

#[test]
fn each_error_has_its_message_and_span() {
    for (src, message, under) in CASES {
        let e = first_error(src);
        assert!(
            e.message.starts_with(message),
            "for {src:?}\n  expected message starting with: {message}\n  got: {}",
            e.message
        );
        assert!(
            e.span.start <= e.span.end && e.span.end <= src.len(),
            "{src:?}: span {:?} out of range",
            e.span
        );
        assert_eq!(
            &src[e.span.start..e.span.end],
            *under,
            "{src:?}: span {:?}",
            e.span
        );
        assert!(
            !e.message.contains("Rule") && !e.message.contains("_item"),
            "rule name leaked: {}",
            e.message
        );
    }
}

#[test]
fn error_reports_snapshot() {
    let mut all = String::new();
    for (src, _, _) in CASES {
        all.push_str("----- input:\n");
        all.push_str(src);
        all.push('\n');
        for e in mbdc_dsl::parse(src).err().unwrap_or_default() {
            all.push_str(&e.render(src));
        }
    }
    insta::assert_snapshot!(all);
}

#[test]
fn several_errors_are_reported_after_recovery() {
    let src =
        "model m {\n  a 1 2\n  b = 1\n  body c {\n    mass 1 kg kg\n  }\n  d (1,)\n  e 3 3\n}\n";
    let errors = mbdc_dsl::parse(src).expect_err("must fail");
    let lines: Vec<usize> = errors
        .iter()
        .map(|e| src[..e.span.start].bytes().filter(|&b| b == b'\n').count() + 1)
        .collect();
    assert_eq!(lines, [2, 3, 5, 7, 8], "{errors:#?}");
}

#[test]
fn recovery_skips_a_broken_item_with_its_block() {
    let src = "model m {\n  body rod x {\n    mass 1 2\n  }\n  body ok { mass 1 }\n  f 1 1\n}\n";
    let errors = mbdc_dsl::parse(src).expect_err("must fail");
    // The error inside the broken declaration's block is not reported twice, the later
    // error is found.
    assert_eq!(errors.len(), 2, "{errors:#?}");
    assert!(src[errors[1].span.start..].starts_with("1\n}"));
}

#[test]
fn at_most_ten_errors_are_reported() {
    let src = "a 1 1\n".repeat(50);
    let errors = mbdc_dsl::parse(&src).expect_err("must fail");
    assert_eq!(errors.len(), 10);
    assert!(errors.windows(2).all(|w| w[0].span.start < w[1].span.start));
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    let n = mbdc_dsl::MAX_NESTING;
    let ok = format!("x y = {}1{}", "(".repeat(n - 1), ")".repeat(n - 1));
    common::parse_ok(&ok);
    for (open, close) in [("(", ")"), ("[", "]"), ("f(", ")"), ("a {", "}")] {
        let src = format!("x y = {}1{}", open.repeat(n + 1), close.repeat(n + 1));
        let src = if open == "a {" {
            format!("{}{}", open.repeat(n + 1), close.repeat(n + 1))
        } else {
            src
        };
        let e = first_error(&src);
        assert!(
            e.message.starts_with("nested too deeply"),
            "{open}: {}",
            e.message
        );
    }
    // Deep trees without brackets: prefix runs, `^` chains (right-associative), else-if
    // chains.
    for src in [
        format!("x y = {}1", "-".repeat(100_000)),
        format!("x y = {}a", "not ".repeat(10_000)),
        format!("x y = {}", vec!["a"; 300].join("^")),
        format!("if a {{}} {}", "else if b {} ".repeat(5_000)),
    ] {
        let e = first_error(&src);
        assert!(e.message.starts_with("nested too deeply"), "{}", e.message);
    }
    // A chain of left-associative operators is one level deep however long; its length has
    // its own limit, reported at the first operator past it.
    let n = mbdc_dsl::MAX_OPERATORS;
    let src = format!("x y = {}", vec!["a"; 100_000].join("+"));
    let e = first_error(&src);
    assert_eq!(
        e.message,
        format!("more than {n} operators in one expression")
    );
    assert_eq!(e.span.start, "x y = ".len() + 2 * n + 1);
    // nested expressions count together
    let src = format!(
        "x y = ({}) * ({})",
        vec!["a"; n / 2 + 1].join("+"),
        vec!["a"; n / 2 + 1].join("+")
    );
    let e = first_error(&src);
    assert!(e.message.starts_with("more than"), "{}", e.message);
    // At the limit, a long chain parses and formats, and so do sums of products.
    let chain = format!("x y = {}", vec!["a"; n + 1].join(" + "));
    let f = common::parse_ok(&chain);
    assert_eq!(mbdc_dsl::format(&f), format!("{chain}\n"));
    let mixed = format!("x y = {}", vec!["2 * a - b / c"; n / 4].join(" + "));
    let f = common::parse_ok(&mixed);
    assert_eq!(mbdc_dsl::format(&f), format!("{mixed}\n"));
    // Wide is fine: long lists and many items.
    let wide = format!("x y = [{}]", vec!["(1, 2) m"; 100_000].join(", "));
    common::parse_ok(&wide);
}

#[test]
fn deep_nesting_within_the_limit_works_on_a_small_stack() {
    // Parsing at the depth limit must not depend on the caller's stack size.
    let n = mbdc_dsl::MAX_NESTING - 1;
    let handle = std::thread::Builder::new()
        .stack_size(256 * 1024)
        .spawn(move || {
            let src = format!("{}{}", "a {".repeat(n), "}".repeat(n));
            mbdc_dsl::parse(&src).map(|f| f.items.len())
        })
        .expect("thread");
    assert_eq!(handle.join().expect("no stack overflow"), Ok(1));
}

/// A chain at the operator limit is as tall a tree as any input can build: parsing,
/// formatting, comparing, cloning and dropping it must fit a small stack.
#[test]
fn the_longest_chain_works_on_a_small_stack() {
    let handle = std::thread::Builder::new()
        .stack_size(512 * 1024)
        .spawn(|| {
            let n = mbdc_dsl::MAX_OPERATORS;
            let src = format!("x y = {}", vec!["a"; n + 1].join(" + "));
            let f = mbdc_dsl::parse(&src).expect("parses");
            let text = mbdc_dsl::format(&f);
            let mut a = f.clone();
            let mut b = mbdc_dsl::parse(&text).expect("parses again");
            mbdc_dsl::strip_spans(&mut a);
            mbdc_dsl::strip_spans(&mut b);
            assert!(a == b);
            drop((a, b, f));
            text.len()
        })
        .expect("thread");
    assert!(handle.join().expect("no stack overflow") > 2 * mbdc_dsl::MAX_OPERATORS);
}

#[test]
fn oversized_input_is_refused() {
    let src = " ".repeat(mbdc_dsl::MAX_INPUT_LEN + 1);
    let e = first_error(&src);
    assert!(
        e.message.starts_with("the input is too large"),
        "{}",
        e.message
    );
    assert_eq!(e.span, Span::new(0, 0));
    let e = mbdc_dsl::parse_expr(&src).expect_err("too large");
    assert!(e[0].message.starts_with("the input is too large"));
}

#[test]
fn display_is_the_message_and_render_points_at_the_line() {
    let src = "model m {\n  param L =\n}\n";
    let e = first_error(src);
    assert_eq!(e.to_string(), e.message);
    let r = e.render(src);
    assert!(
        r.starts_with("error: expected an expression after `=`"),
        "{r}"
    );
    assert!(r.contains(" --> 2:12\n"), "{r}");
    assert!(r.contains("2 |   param L =\n"), "{r}");
    assert!(r.contains("  |            ^\n"), "{r}");
}

#[test]
fn parse_expr_errors() {
    for (src, msg) in [
        ("", "expected an expression, found the end of the file"),
        ("1 2", "expected the end of the input"),
        ("2 *", "expected an expression after `*`"),
        ("(1", "unclosed `(` opened here"),
    ] {
        let e = mbdc_dsl::parse_expr(src).expect_err(src);
        assert!(e[0].message.starts_with(msg), "{src:?}: {}", e[0].message);
    }
}
