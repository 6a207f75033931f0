//! Property tests of the Gmsh reader ([`super::msh::parse`]): on mutated and arbitrary text it
//! never panics, never allocates for a count the file cannot hold, and every error names a
//! line of the file. Bounded to about a second in debug builds.

use std::sync::atomic::{AtomicUsize, Ordering};

use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

use super::msh::parse;

/// A small valid mesh with every section the reader knows: names, entities, two node blocks,
/// a line and a quadrangle block.
const SEED: &str = r#"$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
2
1 1 "left"
2 2 "plate"
$EndPhysicalNames
$Entities
0 1 1 0
1 0 0 0 0 1 0 1 1 0 0
1 0 0 0 1 1 0 1 2 0
$EndEntities
$Nodes
2 4 1 4
1 1 0 2
1
4
0 0 0
0 1 0
2 1 0 2
2
3
1 0 0
1 1 0
$EndNodes
$Elements
2 2 1 2
1 1 1 1
1 1 4
2 1 3 1
2 1 2 3 4
$EndElements
"#;

/// Words a mutation writes in place of a token: counts at and past every limit, signs,
/// floats where integers go, non-numbers.
const WORDS: &[&str] = &[
    "0",
    "1",
    "2",
    "-1",
    "3",
    "15",
    "17",
    "99",
    "4294967296",
    "99999999999999999",
    "18446744073709551616",
    "-99999999999999999",
    "50000001",
    "1e308",
    "nan",
    "inf",
    "0.5",
    "x",
    "\"",
    "\"name",
    "$Nodes",
    "$EndNodes",
    "$Elements",
    "$EndElements",
    "$PhysicalNames",
    "$Entities",
    "$MeshFormat",
];

/// One edit of the text's lines.
#[derive(Clone, Debug)]
enum Edit {
    /// Replace the `tok`-th token of line `line` by a word.
    Token {
        line: usize,
        tok: usize,
        word: usize,
    },
    /// Delete a line.
    Delete(usize),
    /// Repeat a line.
    Duplicate(usize),
    /// Swap two lines.
    Swap(usize, usize),
    /// Cut the text at a byte (rounded down to a character boundary).
    Truncate(usize),
    /// Insert arbitrary text as a line.
    Insert(usize, String),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        4 => (any::<usize>(), any::<usize>(), 0..WORDS.len())
            .prop_map(|(line, tok, word)| Edit::Token { line, tok, word }),
        1 => any::<usize>().prop_map(Edit::Delete),
        1 => any::<usize>().prop_map(Edit::Duplicate),
        1 => (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Edit::Swap(a, b)),
        1 => any::<usize>().prop_map(Edit::Truncate),
        1 => (any::<usize>(), "\\PC{0,24}").prop_map(|(at, s)| Edit::Insert(at, s)),
    ]
}

fn apply(text: &str, e: &Edit) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let n = lines.len().max(1);
    match e {
        Edit::Token { line, tok, word } => {
            if let Some(l) = lines.get_mut(line % n) {
                let mut toks: Vec<&str> = l.split_whitespace().collect();
                if !toks.is_empty() {
                    let k = tok % toks.len();
                    toks[k] = WORDS[*word];
                    *l = toks.join(" ");
                }
            }
        }
        Edit::Delete(i) => {
            if !lines.is_empty() {
                lines.remove(i % n);
            }
        }
        Edit::Duplicate(i) => {
            if let Some(l) = lines.get(i % n).cloned() {
                lines.insert(i % n, l);
            }
        }
        Edit::Swap(a, b) => {
            if !lines.is_empty() {
                lines.swap(a % n, b % n);
            }
        }
        Edit::Truncate(at) => {
            let mut cut = at % (text.len() + 1);
            while !text.is_char_boundary(cut) {
                cut -= 1;
            }
            return text[..cut].to_string();
        }
        Edit::Insert(at, s) => lines.insert(at % (lines.len() + 1), s.clone()),
    }
    let mut out = lines.join("\n");
    out.push('\n');
    out
}

/// The property: no panic (a panic fails the case), and an error's line is a line of the
/// text, with a message. Returns whether the text was read.
fn check(text: &str) -> Result<bool, TestCaseError> {
    match parse(text) {
        Ok(_) => Ok(true),
        Err(e) => {
            let lines = text.lines().count().max(1);
            prop_assert!(
                (1..=lines).contains(&e.line),
                "line {} outside 1..={lines}: {}",
                e.line,
                e.message
            );
            prop_assert!(!e.message.is_empty());
            Ok(false)
        }
    }
}

#[test]
fn the_seed_is_read() {
    assert_eq!(check(SEED).ok(), Some(true));
}

#[test]
fn mutated_meshes_never_panic_and_errors_name_a_line() {
    static READ: AtomicUsize = AtomicUsize::new(0);
    let mut runner = TestRunner::new(Config {
        cases: 10_000,
        failure_persistence: None,
        ..Config::default()
    });
    runner
        .run(&proptest::collection::vec(edit(), 1..4), |edits| {
            let text = edits.iter().fold(SEED.to_string(), |t, e| apply(&t, e));
            if check(&text)? {
                READ.fetch_add(1, Ordering::Relaxed);
            }
            Ok(())
        })
        .unwrap();
    // some mutants must still be read, or the later sections would go untested
    let read = READ.load(Ordering::Relaxed);
    assert!(read > 40, "only {read} of 10 000 mutated meshes were read");
}

#[test]
fn arbitrary_text_never_panics() {
    let mut runner = TestRunner::new(Config {
        cases: 2000,
        failure_persistence: None,
        ..Config::default()
    });
    let section = prop_oneof![
        Just(String::new()),
        Just("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n".to_string()),
    ];
    let head = prop_oneof![
        Just("$Nodes\n"),
        Just("$Elements\n"),
        Just("$Entities\n"),
        Just("$PhysicalNames\n"),
        Just(""),
    ];
    runner
        .run(
            &(section, head, "[0-9 \\-\n.e$\"a-z]{0,120}"),
            |(s, h, body)| {
                check(&format!("{s}{h}{body}"))?;
                Ok(())
            },
        )
        .unwrap();
}
