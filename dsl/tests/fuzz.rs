//! Property: the parser never panics, whatever the input; its errors point inside the
//! input; and whenever it accepts an input, the formatter's promises hold for it.
//!
//! About 100 000 cases in total: arbitrary strings, soups of the language's tokens, and
//! random mutations (insertions, deletions, swaps, duplications) of the reference examples.

mod common;

use proptest::prelude::*;
use proptest::test_runner::Config;

/// Parses and checks everything that must hold for any input.
fn check(src: &str) -> Result<(), TestCaseError> {
    match mbdc_dsl::parse(src) {
        Ok(file) => {
            common::check_spans(src, &file);
            let out = mbdc_dsl::format(&file);
            let reparsed = mbdc_dsl::parse(&out).map_err(|e| {
                TestCaseError::fail(format!(
                    "formatted text does not parse: {e:?}\n--- input:\n{src:?}\n--- output:\n{out}"
                ))
            })?;
            prop_assert_eq!(
                &mbdc_dsl::format(&reparsed),
                &out,
                "format not idempotent for {:?}",
                src
            );
            let (a, b) = (common::stripped(file), common::stripped(reparsed));
            prop_assert!(
                a == b,
                "parse(format(x)) != x for {:?}\n--- output:\n{}",
                src,
                out
            );
        }
        Err(errors) => {
            prop_assert!(!errors.is_empty() && errors.len() <= 10);
            for e in &errors {
                prop_assert!(
                    e.span.start <= e.span.end && e.span.end <= src.len(),
                    "{:?} for {:?}",
                    e,
                    src
                );
                prop_assert!(
                    src.is_char_boundary(e.span.start) && src.is_char_boundary(e.span.end),
                    "{:?}",
                    e
                );
                prop_assert!(!e.message.is_empty());
                prop_assert!(
                    !e.message.contains("internal error"),
                    "{:?} for {:?}",
                    e,
                    src
                );
                let _ = e.render(src);
            }
        }
    }
    if let Ok(expr) = mbdc_dsl::parse_expr(src) {
        let text = mbdc_dsl::format_expr(&expr);
        let mut back = mbdc_dsl::parse_expr(&text).map_err(|e| {
            TestCaseError::fail(format!("{text:?} from {src:?} does not parse: {e:?}"))
        })?;
        let mut expr = expr;
        mbdc_dsl::strip_expr_spans(&mut expr);
        mbdc_dsl::strip_expr_spans(&mut back);
        prop_assert!(
            expr == back,
            "expression {:?} changes when formatted as {:?}",
            src,
            text
        );
    }
    Ok(())
}

const TOKENS: &[&str] = &[
    "model",
    "body",
    "joint",
    "m",
    "x",
    "link",
    "i",
    "N",
    "L",
    "kg",
    "s",
    "in",
    "e",
    "import",
    "param",
    "const",
    "component",
    "for",
    "if",
    "else",
    "and",
    "or",
    "not",
    "true",
    "false",
    "0",
    "1",
    "2.5",
    "1e-6",
    "6.02E23",
    "1e",
    "\"a.mbd\"",
    "\"q\\\"\"",
    "\"\\x\"",
    "\"",
    "(",
    ")",
    "[",
    "]",
    "{",
    "}",
    ",",
    ";",
    ":",
    "=",
    "==",
    "!=",
    "<",
    "<=",
    ">",
    ">=",
    "+",
    "-",
    "*",
    "/",
    "%",
    "^",
    "@",
    ".",
    "..",
    "!",
    "$",
    "é",
    "// c\n",
    "/* c */",
    "/*",
    "*/",
    "\n",
    "\r\n",
    "\t",
    " ",
    "m/s^2",
    "kg*m^2",
    "1/s",
    "s^-1",
    "f(",
    "a.b",
    "x[1]",
    "\u{0c}",
];

fn soup() -> impl Strategy<Value = String> {
    prop::collection::vec(
        (
            prop::sample::select(TOKENS),
            prop::sample::select(&["", " ", " ", "\n"][..]),
        ),
        0..40,
    )
    .prop_map(|v| v.into_iter().flat_map(|(t, s)| [t, s]).collect())
}

#[derive(Clone, Debug)]
enum Mutation {
    Insert(usize, String),
    Delete(usize, usize),
    Swap(usize, usize, usize),
    Duplicate(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let at = any::<usize>();
    prop_oneof![
        3 => (at, prop_oneof![prop::sample::select(TOKENS).prop_map(String::from), any::<char>().prop_map(String::from)])
            .prop_map(|(p, s)| Mutation::Insert(p, s)),
        3 => (at, 1..8usize).prop_map(|(p, n)| Mutation::Delete(p, n)),
        2 => (at, at, 1..6usize).prop_map(|(a, b, n)| Mutation::Swap(a, b, n)),
        1 => (at, 1..20usize).prop_map(|(p, n)| Mutation::Duplicate(p, n)),
    ]
}

/// Applies a mutation at character positions (so the text stays valid UTF-8).
fn apply(src: &str, m: &Mutation) -> String {
    let chars: Vec<char> = src.chars().collect();
    let n = chars.len();
    let pos = |p: usize| if n == 0 { 0 } else { p % (n + 1) };
    let mut out = chars.clone();
    match m {
        Mutation::Insert(p, s) => {
            let p = pos(*p);
            out.splice(p..p, s.chars());
        }
        Mutation::Delete(p, k) => {
            let p = pos(*p);
            out.drain(p..(p + k).min(n));
        }
        Mutation::Swap(a, b, k) => {
            let (a, b) = (pos(*a), pos(*b));
            let (a, b) = (a.min(b), a.max(b));
            let k = (*k).min(b - a).min(n - b);
            if k > 0 {
                for i in 0..k {
                    out.swap(a + i, b + i);
                }
            }
        }
        Mutation::Duplicate(p, k) => {
            let p = pos(*p);
            let seg: Vec<char> = chars[p..(p + k).min(n)].to_vec();
            out.splice(p..p, seg);
        }
    }
    out.into_iter().collect()
}

fn example() -> impl Strategy<Value = String> {
    let examples: Vec<String> = common::doc_examples().into_iter().map(|(_, s)| s).collect();
    prop::sample::select(examples)
}

proptest! {
    #![proptest_config(Config { cases: 25_000, failure_persistence: None, ..Config::default() })]

    #[test]
    fn arbitrary_strings(src in prop_oneof![".{0,60}", "[ -~\n]{0,80}"]) {
        check(&src)?;
    }
}

proptest! {
    #![proptest_config(Config { cases: 10_000, failure_persistence: None, ..Config::default() })]

    #[test]
    fn arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..100)) {
        check(&String::from_utf8_lossy(&bytes))?;
    }
}

proptest! {
    #![proptest_config(Config { cases: 40_000, failure_persistence: None, ..Config::default() })]

    #[test]
    fn token_soup(src in soup()) {
        check(&src)?;
    }
}

proptest! {
    #![proptest_config(Config { cases: 30_000, failure_persistence: None, ..Config::default() })]

    #[test]
    fn mutated_reference_examples(src in example(), muts in prop::collection::vec(mutation(), 1..4)) {
        let mutated = muts.iter().fold(src, |s, m| apply(&s, m));
        check(&mutated)?;
    }
}
