//! The page: the template `cli/assets/viewer.html` with the data, the frames and the viewer
//! bundle (`cli/assets/viewer.js`, three.js inlined; built from `cli/viewer/src`) put in
//! its four places.

use base64::Engine as _;

use super::{ViewData, ViewError};

/// The page template.
const TEMPLATE: &str = include_str!("../../assets/viewer.html");
/// The viewer's scripts, one minified bundle.
pub(crate) const BUNDLE: &str = include_str!("../../assets/viewer.js");

/// Text safe inside a `<script>` element: `</` cannot end it early.
fn script_safe(s: &str) -> String {
    s.replace("</", "<\\/")
}

/// Text safe inside an HTML element.
fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The page of `data` and its frames' values.
pub(crate) fn render(data: &ViewData, values: &[f32]) -> Result<String, ViewError> {
    let json = serde_json::to_string(data)
        .map_err(|e| ViewError(format!("encoding the page's data: {e}")))?;
    let mut bytes = Vec::with_capacity(4 * values.len());
    for v in values {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    let frames = base64::engine::general_purpose::STANDARD.encode(&bytes);
    fill(&html_escape(&data.model), &script_safe(&json), &frames)
}

/// The template with its places filled (each is in the template once).
fn fill(title: &str, json: &str, frames: &str) -> Result<String, ViewError> {
    let mut out = String::with_capacity(TEMPLATE.len() + BUNDLE.len() + json.len() + frames.len());
    let mut rest = TEMPLATE;
    for (key, value) in [
        ("{{TITLE}}", title),
        ("{{DATA}}", json),
        ("{{FRAMES}}", frames),
        ("{{VIEWER}}", BUNDLE),
    ] {
        let Some(at) = rest.find(key) else {
            return Err(ViewError(format!(
                "the viewer template has no {key} after the previous place (cli/assets/viewer.html)"
            )));
        };
        out.push_str(&rest[..at]);
        out.push_str(value);
        rest = &rest[at + key.len()..];
    }
    out.push_str(rest);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_place_is_filled_once_and_scripts_cannot_end_early() {
        let page = fill(
            "m &lt;1&gt;",
            &script_safe(r#"{"report":"</script><b>"}"#),
            "AAAA",
        )
        .unwrap();
        for key in ["{{TITLE}}", "{{DATA}}", "{{FRAMES}}", "{{VIEWER}}"] {
            assert!(!page.contains(key), "{key} left");
        }
        assert!(page.contains(r#"{"report":"<\/script><b>"}"#));
        assert_eq!(page.matches("<\\/script><b>").count(), 1);
        assert!(page.contains("AAAA"));
    }

    #[test]
    fn the_bundle_is_the_build_of_its_sources() {
        // the bundle's first line names the hash of the sources it was built from
        // and the page template (cli/viewer/build.mjs); a source edited without rebuilding
        // fails here
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("viewer");
        let mut files: Vec<_> = std::fs::read_dir(dir.join("src"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "js"))
            .collect();
        files.sort();
        // the page template is part of the sources
        let mut rels: Vec<String> = files
            .iter()
            .map(|f| {
                f.strip_prefix(&dir)
                    .unwrap()
                    .to_string_lossy()
                    .replace('\\', "/")
            })
            .collect();
        rels.push("../assets/viewer.html".into());
        let mut text = Vec::new();
        for rel in &rels {
            let f = dir.join(rel);
            text.extend_from_slice(rel.as_bytes());
            text.push(b'\n');
            text.extend_from_slice(&std::fs::read(&f).unwrap());
            text.push(b'\n');
        }
        let hash = sha256_hex(&text);
        let first = BUNDLE.lines().next().unwrap_or("");
        assert!(
            first.contains(&hash),
            "cli/assets/viewer.js was not built from cli/viewer/src as it is (sources hash {hash}); rebuild: cd cli/viewer && npm ci && node build.mjs"
        );
    }

    fn sha256_hex(data: &[u8]) -> String {
        use sha2::Digest as _;
        sha2::Sha256::digest(data)
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    }

    #[test]
    fn sha256_of_abc() {
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
