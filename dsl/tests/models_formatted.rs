//! Every model in `models/` (subfolders included) is in the canonical layout of
//! `mbdc_dsl::format`, so `mbdc fmt --check models/**/*.mbd` passes and a newcomer's first
//! `mbdc fmt` on a copied model changes nothing but their own edits.

use std::path::{Path, PathBuf};

fn models(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            models(&p, out);
        } else if p.extension().is_some_and(|x| x == "mbd") {
            out.push(p);
        }
    }
}

#[test]
fn every_model_is_canonically_formatted() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models");
    let mut files = Vec::new();
    models(&root, &mut files);
    assert!(files.len() >= 20, "models/ has {} models", files.len());
    let mut unformatted = Vec::new();
    for p in &files {
        let text = std::fs::read_to_string(p).expect("model");
        let file = mbdc_dsl::parse(&text)
            .unwrap_or_else(|e| panic!("{} does not parse: {e:?}", p.display()));
        if mbdc_dsl::format(&file) != text {
            unformatted.push(p.strip_prefix(&root).unwrap_or(p).display().to_string());
        }
    }
    assert!(
        unformatted.is_empty(),
        "not in the canonical layout (run `cargo mbdc fmt` on them): {}",
        unformatted.join(", ")
    );
}
