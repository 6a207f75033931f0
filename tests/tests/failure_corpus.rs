//! Every file in tests/failures/ is an invalid scene: lowering it must report errors (and
//! never panic), and the rendered diagnostics are compared with a snapshot per file
//! (tests/failures/snapshots/). Rendering is the compiler's plain renderer:
//! `severity[code]: message`, then `--> file:line:column`, the source line and an
//! underline per label, then the help.
//!
//! Update the snapshots with `INSTA_UPDATE=always cargo test -p mbdc-tests --test failure_corpus`
//! (or `cargo insta review`).

use std::path::{Path, PathBuf};

fn corpus() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("failures");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("tests/failures")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "mbd"))
        .collect();
    v.sort();
    v
}

#[test]
fn every_failure_is_reported() {
    // Paths relative to the crate directory, so that snapshots do not depend on where the
    // repository is.
    std::env::set_current_dir(env!("CARGO_MANIFEST_DIR")).expect("cd");
    let files = corpus();
    assert!(
        files.len() >= 40,
        "expected at least 40 failure files, found {}",
        files.len()
    );
    let mut codes = std::collections::BTreeSet::new();
    for f in files {
        let stem = f
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("?")
            .to_string();
        let rel = Path::new("failures").join(f.file_name().unwrap_or_default());
        let loaded = mbdc_compiler::load_file(&rel, &[]);
        assert!(
            loaded.has_errors(),
            "{stem}: expected an error, got:\n{}",
            loaded.render_plain()
        );
        assert!(loaded.scene.is_none(), "{stem}: a scene despite errors");
        for d in loaded.errors() {
            assert!(
                !d.labels.is_empty(),
                "{stem}: error without a span: {}",
                d.message
            );
            codes.insert(d.code);
        }
        let text = loaded.render_plain();
        insta::with_settings!({
            snapshot_path => "../failures/snapshots",
            prepend_module_to_snapshot => false,
            omit_expression => true,
        }, {
            insta::assert_snapshot!(stem, text);
        });
    }
    assert!(
        codes.len() >= 25,
        "the corpus exercises only {} codes: {codes:?}",
        codes.len()
    );
}
