//! The README's "Use mbdc from your crate" stays true: its Rust blocks are copies of this
//! example's files (which build and run in this crate's tests), and its Cargo.toml lines name
//! the crates this example depends on, in the same sections, at the repository's address.

use std::collections::BTreeSet;
use std::path::Path;

const SECTION: &str = "## Use mbdc from your crate";

fn read(rel: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The fenced blocks of the README's section: (language, text).
fn blocks() -> Vec<(String, String)> {
    let readme = read("../../README.md");
    let start = readme
        .find(SECTION)
        .unwrap_or_else(|| panic!("the README has no `{SECTION}` section"));
    let rest = &readme[start + SECTION.len()..];
    let section = &rest[..rest.find("\n## ").unwrap_or(rest.len())];
    let mut out = Vec::new();
    let mut open: Option<(String, String)> = None;
    for line in section.lines() {
        match (&mut open, line.strip_prefix("```")) {
            (None, Some(lang)) => open = Some((lang.to_string(), String::new())),
            (Some(_), Some(_)) => out.extend(open.take()),
            (Some((_, text)), None) => {
                text.push_str(line);
                text.push('\n');
            }
            (None, None) => {}
        }
    }
    assert!(open.is_none(), "an unclosed block in the README's section");
    out
}

/// The `mbdc-*` crates under `[header]` of a Cargo.toml text.
fn crates(toml: &str, header: &str) -> BTreeSet<String> {
    let mut inside = false;
    let mut out = BTreeSet::new();
    for line in toml.lines().map(str::trim) {
        if line.starts_with('[') {
            inside = line == header;
        } else if inside && line.starts_with("mbdc-") {
            let name = line.split(['=', '.', ' ']).next().unwrap_or("");
            out.insert(name.to_string());
        }
    }
    out
}

#[test]
fn the_rust_blocks_are_copies_of_the_example() {
    let rust: Vec<String> = blocks()
        .into_iter()
        .filter(|(lang, _)| lang == "rust")
        .map(|(_, text)| text)
        .collect();
    assert!(rust.len() >= 3, "{} Rust blocks", rust.len());
    let mut all = String::new();
    for text in &rust {
        let (first, body) = text.split_once('\n').unwrap_or((text, ""));
        let file = first
            .strip_prefix("// ")
            .unwrap_or_else(|| panic!("a Rust block must start with `// FILE`: {first}"));
        let source = read(file);
        assert!(
            source.contains(body),
            "the README's block from {file} is no longer in examples/embed/{file}:\n{body}"
        );
        all.push_str(body);
    }
    for route in [
        "mbdc_compiler::build(",
        "include!(concat!(env!(\"OUT_DIR\")",
        "mbdc_macros::include_model!(",
        "mbdc_macros::model! {",
        "run_loop::run(",
    ] {
        assert!(all.contains(route), "the README shows no `{route}`");
    }
}

#[test]
fn the_cargo_lines_name_the_example_s_dependencies() {
    let toml: Vec<String> = blocks()
        .into_iter()
        .filter(|(lang, _)| lang == "toml")
        .map(|(_, text)| text)
        .collect();
    assert_eq!(toml.len(), 1, "one Cargo.toml block");
    let readme = &toml[0];
    let example = read("Cargo.toml");
    for header in ["[dependencies]", "[build-dependencies]"] {
        let shown = crates(readme, header);
        assert!(!shown.is_empty(), "the README shows no {header}");
        assert_eq!(shown, crates(&example, header), "{header}");
    }
    // each at the repository's address, each a crate of this workspace
    let workspace = read("../../Cargo.toml");
    let repo = workspace
        .lines()
        .find_map(|l| l.trim().strip_prefix("repository = "))
        .expect("workspace repository")
        .trim_matches('"');
    for line in readme.lines().filter(|l| l.starts_with("mbdc-")) {
        assert!(line.contains(&format!("git = \"{repo}\"")), "{line}");
    }
    for name in crates(readme, "[dependencies]")
        .into_iter()
        .chain(crates(readme, "[build-dependencies]"))
    {
        assert!(
            workspace.contains(&format!("{name} = {{ path = ")),
            "{name} is not a crate of the workspace"
        );
    }
}
