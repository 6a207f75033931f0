//! Parse + lower never panic, whatever the input.
//!
//! The parser alone is fuzzed in `mbdc-dsl`; here every case goes through the whole
//! front end (`load_str`: parse, expand, lower, validate, summary). Inputs are the
//! repository's models, the language reference's examples and the failure corpus,
//! mutated by a few random edits (deleted, duplicated or swapped ranges, inserted tokens,
//! replaced numbers), plus random token soup: 100,000 cases in all, about ten seconds at the test profile.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

fn seeds() -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut out = Vec::new();
    for dir in ["models", "tests/failures"] {
        if let Ok(rd) = std::fs::read_dir(root.join(dir)) {
            let mut paths: Vec<_> = rd.filter_map(|e| e.ok().map(|e| e.path())).collect();
            paths.sort();
            for p in paths {
                if p.extension().is_some_and(|e| e == "mbd") {
                    if let Ok(t) = std::fs::read_to_string(&p) {
                        out.push(t);
                    }
                }
            }
        }
    }
    if let Ok(doc) = std::fs::read_to_string(root.join("docs/language.md")) {
        let mut cur: Option<String> = None;
        for line in doc.lines() {
            match &mut cur {
                None if line.trim() == "```mbd" => cur = Some(String::new()),
                None => {}
                Some(s) if line.trim() == "```" => {
                    out.push(std::mem::take(s));
                    cur = None;
                }
                Some(s) => {
                    s.push_str(line);
                    s.push('\n');
                }
            }
        }
    }
    assert!(out.len() > 20, "too few seed files");
    out
}

const TOKENS: &[&str] = &[
    "{",
    "}",
    "(",
    ")",
    "[",
    "]",
    ",",
    ";",
    "\n",
    "@",
    "+",
    "-",
    "*",
    "/",
    "%",
    "^",
    "..",
    "==",
    "<",
    "and",
    "not",
    "0",
    "1",
    "-1",
    "2.5",
    "1e-300",
    "1e300",
    "100",
    "0.5",
    "t",
    "x",
    "pi",
    "ground",
    "m",
    "kg",
    "s",
    "deg",
    "N",
    "rad/s",
    "m/s^2",
    "kg*m^2",
    "1/s",
    "GPa",
    " m",
    "body",
    "joint",
    "force",
    "mesh",
    "beam",
    "material",
    "instance",
    "for i in 0..3 {",
    "if true {",
    "} else {",
    "const c = 1 m\n",
    "param p = 2\n",
    "component C(a) {",
    "model m {",
    "import \"x.mbd\"\n",
    "simulate { duration 1 s; step 1 ms }",
    "sin(",
    "table(t, [(0 s, 0), (1 s, 1)])",
    "world((0, 0, 0) m)",
    "diag(1, 2, 3) kg*m^2",
    "rod(length: 1 m, radius: 1 cm)",
    "axis: (0, 0, 0)",
    "link[i - 1]",
    "a.b",
    "x == 0",
    "nodes(x == 0)",
    "free",
    "\"str\"",
    "true",
    "false",
];

#[derive(Clone, Debug)]
enum Edit {
    Delete(usize, usize),
    Duplicate(usize, usize, usize),
    Insert(usize, usize),
    SwapLines(usize, usize),
    Number(usize, usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<usize>(), 1usize..40).prop_map(|(a, n)| Edit::Delete(a, n)),
        (any::<usize>(), 1usize..60, any::<usize>()).prop_map(|(a, n, b)| Edit::Duplicate(a, n, b)),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(a, t)| Edit::Insert(a, t)),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Edit::SwapLines(a, b)),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(a, t)| Edit::Number(a, t)),
    ]
}

fn floor_boundary(s: &str, i: usize) -> usize {
    let mut i = i.min(s.len());
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

fn apply(text: &str, e: &Edit) -> String {
    let len = text.len().max(1);
    match *e {
        Edit::Delete(a, n) => {
            let a = floor_boundary(text, a % len);
            let b = floor_boundary(text, a + n);
            format!("{}{}", &text[..a], &text[b..])
        }
        Edit::Duplicate(a, n, at) => {
            let a = floor_boundary(text, a % len);
            let b = floor_boundary(text, a + n);
            let at = floor_boundary(text, at % len);
            format!("{}{}{}", &text[..at], &text[a..b], &text[at..])
        }
        Edit::Insert(a, t) => {
            let a = floor_boundary(text, a % len);
            format!("{} {} {}", &text[..a], TOKENS[t], &text[a..])
        }
        Edit::SwapLines(a, b) => {
            let mut lines: Vec<&str> = text.lines().collect();
            if lines.len() > 1 {
                let (i, j) = (a % lines.len(), b % lines.len());
                lines.swap(i, j);
            }
            lines.join("\n")
        }
        Edit::Number(a, t) => {
            // Replace the first number at or after a position.
            let a = floor_boundary(text, a % len);
            let bytes = text.as_bytes();
            let Some(start) = (a..text.len()).find(|&i| bytes[i].is_ascii_digit()) else {
                return text.to_string();
            };
            let end = (start..text.len())
                .find(|&i| !(bytes[i].is_ascii_digit() || bytes[i] == b'.'))
                .unwrap_or(text.len());
            let rep = match TOKENS[t] {
                r @ ("0" | "1" | "-1" | "2.5" | "1e-300" | "1e300" | "100" | "0.5") => r,
                _ => "0",
            };
            format!("{}{}{}", &text[..start], rep, &text[end..])
        }
    }
}

static PARSED: AtomicUsize = AtomicUsize::new(0);
static LOWERED: AtomicUsize = AtomicUsize::new(0);

fn check(text: &str) {
    let t0 = std::time::Instant::now();
    let loaded = mbdc_compiler::load_str("fuzz.mbd", text, &[]);
    if t0.elapsed().as_secs_f64() > 2.0 {
        eprintln!("SLOW {:.2}s:\n{text}\n----", t0.elapsed().as_secs_f64());
    }
    if !loaded.diagnostics.iter().any(|d| d.code == "mbdc::syntax") {
        PARSED.fetch_add(1, Ordering::Relaxed);
    }
    if loaded.scene.is_some() {
        LOWERED.fetch_add(1, Ordering::Relaxed);
    }
    // Rendering must not panic either, and every error must have a location.
    let _ = loaded.render_plain();
    for d in &loaded.diagnostics {
        let _ = d.with_sources(&loaded.sources);
    }
    if let Some(scene) = &loaded.scene {
        let _ = mbdc_compiler::summary(scene).to_string();
        assert!(!loaded.has_errors());
    }
}

#[test]
fn mutated_models_never_panic() {
    let seeds = seeds();
    let mut runner = TestRunner::new(Config {
        cases: 90_000,
        failure_persistence: None,
        ..Config::default()
    });
    let strategy = (0..seeds.len(), proptest::collection::vec(edit(), 1..5));
    runner
        .run(&strategy, |(i, edits)| {
            let mut text = seeds[i].clone();
            for e in &edits {
                text = apply(&text, e);
            }
            check(&text);
            Ok(())
        })
        .unwrap();
    // Most mutations must still parse, so that lowering is what is being exercised.
    let (parsed, lowered) = (
        PARSED.load(Ordering::Relaxed),
        LOWERED.load(Ordering::Relaxed),
    );
    eprintln!("parsed {parsed}, lowered to a scene {lowered}");
    assert!(parsed > 5_000, "only {parsed} mutated inputs parsed");
}

#[test]
fn token_soup_never_panics() {
    let mut runner = TestRunner::new(Config {
        cases: 10_000,
        failure_persistence: None,
        ..Config::default()
    });
    let strategy = proptest::collection::vec(0..TOKENS.len(), 0..80);
    runner
        .run(&strategy, |toks| {
            let body: Vec<&str> = toks.iter().map(|&t| TOKENS[t]).collect();
            check(&format!("model m {{\n{}\n}}\n", body.join(" ")));
            Ok(())
        })
        .unwrap();
}

#[test]
fn deep_nesting_is_an_error_not_a_crash() {
    for depth in [50, 150, 199, 200, 250, 300] {
        let e = format!("{}1{}", "(".repeat(depth), ")".repeat(depth));
        check(&format!("model m {{ const c = {e} }}"));
        let neg = format!("{}1", "-".repeat(depth));
        check(&format!("model m {{ const c = {neg} }}"));
        let sum = vec!["1"; depth].join(" + ");
        check(&format!("model m {{ const c = {sum} }}"));
        let blocks = format!(
            "{}{}",
            "if true { ".repeat(depth.min(100)),
            "}".repeat(depth.min(100))
        );
        check(&format!("model m {{ {blocks} }}"));
    }
}

/// Imports nested deeper than `MAX_IMPORT_DEPTH` (a chain of 300 files) are refused with an
/// error at the import that goes too deep, not followed to the end of the chain.
#[test]
fn deep_imports_are_refused() {
    let dir = std::env::temp_dir().join(format!("mbdc-deep-imports-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let n = 300;
    for i in 0..n {
        std::fs::write(
            dir.join(format!("m{i}.mbd")),
            format!("import \"m{}.mbd\"\n", i + 1),
        )
        .unwrap();
    }
    std::fs::write(dir.join(format!("m{n}.mbd")), "const x = 1\n").unwrap();
    std::fs::write(
        dir.join("top.mbd"),
        "import \"m0.mbd\"\nmodel deep { body b { mass 1 kg; inertia sphere(radius: 1 cm) } }\n",
    )
    .unwrap();
    let loaded = mbdc_compiler::load_file(dir.join("top.mbd"), &[]);
    assert!(loaded.has_errors());
    let text = loaded.render_plain();
    let max = mbdc_compiler::load::MAX_IMPORT_DEPTH;
    assert!(
        text.contains(&format!("imports nest more than {max} files deep")),
        "{text}"
    );
    // the chain was cut where it became too deep: far fewer files read than written
    assert!(
        loaded.sources.files().count() <= max + 2,
        "{}",
        loaded.sources.files().count()
    );
    let _ = std::fs::remove_dir_all(&dir);
}
