//! Every ```mbd block of docs/language.md is a complete file that lowers with no errors.

use std::path::Path;

fn blocks(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut cur: Option<(usize, String)> = None;
    for (i, line) in text.lines().enumerate() {
        match &mut cur {
            None if line.trim_start() == "```mbd" => cur = Some((i + 2, String::new())),
            None => {}
            Some(_) if line.trim_start() == "```" => out.push(cur.take().unwrap_or_default()),
            Some((_, s)) => {
                s.push_str(line);
                s.push('\n');
            }
        }
    }
    out
}

#[test]
fn every_example_checks() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/language.md");
    let text = std::fs::read_to_string(&path).expect("docs/language.md");
    let examples = blocks(&text);
    assert!(
        examples.len() >= 10,
        "only {} examples found",
        examples.len()
    );
    let mut failures = Vec::new();
    for (line, src) in &examples {
        let name = format!("docs/language.md:{line}");
        let loaded = mbdc_compiler::load_str(&name, src, &[]);
        if loaded.has_errors() || loaded.scene.is_none() {
            failures.push(loaded.render_plain());
        }
        // The formatter is stable on the examples: formatting twice changes nothing.
        let file = mbdc_dsl::parse(src).expect("parses");
        let once = mbdc_dsl::format(&file);
        let twice = mbdc_dsl::format(&mbdc_dsl::parse(&once).expect("formatted text parses"));
        assert_eq!(
            once, twice,
            "formatting is not idempotent for the example at line {line}"
        );
    }
    assert!(
        failures.is_empty(),
        "{} example(s) do not check:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
