//! Every ```mbd block of docs/language.md parses, has tight spans, and formats
//! idempotently to text that parses back to the same tree.

mod common;

#[test]
fn every_mbd_block_of_the_language_reference_parses_and_formats() {
    let examples = common::doc_examples();
    assert!(
        examples.len() >= 12,
        "expected the reference to hold at least 12 mbd blocks, found {}",
        examples.len()
    );
    for (line, src) in &examples {
        let file = match mbdc_dsl::parse(src) {
            Ok(f) => f,
            Err(errors) => {
                let rendered: Vec<String> = errors.iter().map(|e| e.render(src)).collect();
                panic!(
                    "docs/language.md block at line {line} does not parse:\n{}",
                    rendered.join("\n")
                );
            }
        };
        assert!(!file.items.is_empty(), "block at line {line} is empty");
        common::check_spans(src, &file);
        common::check_format_roundtrip(src, &file);
    }
}

#[test]
fn every_model_of_the_repository_parses_and_formats() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../models");
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.extension().and_then(|e| e.to_str()) != Some("mbd") {
            continue;
        }
        let Ok(src) = std::fs::read_to_string(&path) else {
            continue;
        };
        let file = match mbdc_dsl::parse(&src) {
            Ok(f) => f,
            Err(errors) => {
                let rendered: Vec<String> = errors.iter().map(|e| e.render(&src)).collect();
                panic!(
                    "{} does not parse:\n{}",
                    path.display(),
                    rendered.join("\n")
                );
            }
        };
        common::check_spans(&src, &file);
        common::check_format_roundtrip(&src, &file);
    }
}
