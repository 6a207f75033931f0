//! The work behind the proc-macros of `mbdc-macros`: `.mbd` text from Rust tokens with a map
//! back to the tokens, so that errors in an inline model point at the right token.
//!
//! The tokens of `model!{ … }` are laid out again at their original lines and columns
//! (available to proc-macros since Rust 1.88), so the text is the written model minus its
//! comments, newlines included (they separate statements in `.mbd`). Where positions are not
//! available, tokens are separated by single spaces. Each token's byte range in that text is
//! kept with its span: a diagnostic's byte range maps to the first and last token it covers,
//! and the error is reported across them.

use std::ops::Range;
use std::path::{Path, PathBuf};

use proc_macro2::{Delimiter, Ident, Span, TokenStream, TokenTree};
use quote::quote;

use crate::codegen::{self, Options, SceneJson};
use crate::{Diagnostic, FileId, Loaded};

/// `.mbd` text rebuilt from tokens, with the span of every token.
#[derive(Clone, Debug)]
pub struct TokenText {
    /// The text.
    pub text: String,
    spans: Vec<(Range<usize>, Span)>,
    line: usize,
    col: usize,
    positions: bool,
    joint: bool,
}

impl TokenText {
    /// Lay out `tokens` (see the module doc).
    pub fn new(tokens: TokenStream) -> TokenText {
        let positions = tokens
            .clone()
            .into_iter()
            .next()
            .is_some_and(|t| t.span().start().line > 0);
        let mut t = TokenText {
            text: String::new(),
            spans: Vec::new(),
            line: 0,
            col: 0,
            positions,
            joint: true,
        };
        t.stream(tokens);
        t
    }

    fn place(&mut self, span: Span, s: &str, joint: bool) {
        if self.positions {
            let (start, end) = (span.start(), span.end());
            if self.line == 0 {
                self.line = start.line;
                self.col = start.column;
            }
            if start.line > self.line {
                for _ in self.line..start.line {
                    self.text.push('\n');
                }
                for _ in 0..start.column {
                    self.text.push(' ');
                }
            } else if start.column > self.col {
                for _ in self.col..start.column {
                    self.text.push(' ');
                }
            } else if start.column < self.col && !self.text.is_empty() {
                self.text.push(' ');
            }
            let at = self.text.len();
            self.text.push_str(s);
            self.spans.push((at..self.text.len(), span));
            if end.line > 0 {
                self.line = end.line;
                self.col = end.column;
            }
        } else {
            if !self.joint {
                self.text.push(' ');
            }
            let at = self.text.len();
            self.text.push_str(s);
            self.spans.push((at..self.text.len(), span));
        }
        self.joint = joint;
    }

    fn stream(&mut self, tokens: TokenStream) {
        for t in tokens {
            match t {
                TokenTree::Group(g) => {
                    let (open, close) = match g.delimiter() {
                        Delimiter::Parenthesis => ("(", ")"),
                        Delimiter::Brace => ("{", "}"),
                        Delimiter::Bracket => ("[", "]"),
                        Delimiter::None => ("", ""),
                    };
                    if !open.is_empty() {
                        self.place(g.span_open(), open, false);
                    }
                    self.stream(g.stream());
                    if !close.is_empty() {
                        self.place(g.span_close(), close, false);
                    }
                }
                TokenTree::Punct(p) => {
                    let joint = p.spacing() == proc_macro2::Spacing::Joint;
                    self.place(p.span(), &p.as_char().to_string(), joint)
                }
                TokenTree::Ident(i) => self.place(i.span(), &i.to_string(), false),
                TokenTree::Literal(l) => self.place(l.span(), &l.to_string(), false),
            }
        }
    }

    /// The spans of the first and last tokens that overlap `range` (the nearest token when
    /// none does); `None` when there are no tokens.
    pub fn spans_for(&self, range: Range<usize>) -> Option<(Span, Span)> {
        let hit: Vec<&Span> = self
            .spans
            .iter()
            .filter(|(r, _)| r.start < range.end.max(range.start + 1) && range.start < r.end)
            .map(|(_, s)| s)
            .collect();
        match (hit.first(), hit.last()) {
            (Some(a), Some(b)) => Some((**a, **b)),
            _ => {
                let near = self
                    .spans
                    .iter()
                    .min_by_key(|(r, _)| r.start.abs_diff(range.start))?;
                Some((near.1, near.1))
            }
        }
    }
}

/// A diagnostic as the text of a `compile_error!`: code, message, label messages, help.
fn message(d: &Diagnostic) -> String {
    let mut m = format!("{}: {}", d.code, d.message);
    for l in &d.labels {
        if !l.message.is_empty() {
            m.push_str(&format!("\n  {}", l.message));
        }
    }
    if let Some(h) = &d.help {
        m.push_str(&format!("\nhelp: {h}"));
    }
    m
}

fn error_between(first: Span, last: Span, msg: &str) -> syn::Error {
    let ts: TokenStream = [
        TokenTree::Ident(Ident::new("start", first)),
        TokenTree::Ident(Ident::new("end", last)),
    ]
    .into_iter()
    .collect();
    syn::Error::new_spanned(ts, msg)
}

fn generated(loaded: &Loaded, at: Span, tracked: &[PathBuf]) -> TokenStream {
    let Some(scene) = &loaded.scene else {
        return syn::Error::new(at, loaded.render_plain()).to_compile_error();
    };
    let g = match codegen::generate(
        scene,
        &Options {
            scene_json: SceneJson::Inline,
            ..Options::default()
        },
    ) {
        Ok(g) => g,
        Err(e) => return syn::Error::new(at, e.to_string()).to_compile_error(),
    };
    let code: TokenStream = match g.source.parse() {
        Ok(c) => c,
        Err(e) => return syn::Error::new(at, format!("internal error: {e}")).to_compile_error(),
    };
    let tracks = tracked.iter().map(|p| {
        let p = p.to_string_lossy().to_string();
        quote!(
            const _: &str = include_str!(#p);
        )
    });
    quote! {
        #code
        #(#tracks)*
    }
}

/// `model!{ … }`: the model's Rust, or its errors at the tokens they concern.
pub fn model_macro(input: TokenStream) -> TokenStream {
    let all = input.clone().into_iter().next().map(|t| t.span());
    let tt = TokenText::new(input);
    let loaded = crate::load_str("model!", &tt.text, &[]);
    let at = all.unwrap_or_else(Span::call_site);
    if loaded.has_errors() {
        let mut err: Option<syn::Error> = None;
        for d in loaded.errors() {
            let e = match d.main_label() {
                Some(l) if l.file == FileId(0) => {
                    let (a, b) = tt.spans_for(l.span.start..l.span.end).unwrap_or((at, at));
                    error_between(a, b, &message(d))
                }
                _ => syn::Error::new(at, d.render_plain(&loaded.sources)),
            };
            match &mut err {
                Some(x) => x.combine(e),
                None => err = Some(e),
            }
        }
        return err.map(|e| e.to_compile_error()).unwrap_or_default();
    }
    let files: Vec<PathBuf> = loaded
        .sources
        .files()
        .filter_map(|(_, f)| f.path.clone())
        .collect();
    generated(&loaded, at, &files)
}

/// `include_model!("path.mbd")`: the Rust of the model file at `path` (relative to the
/// crate's `CARGO_MANIFEST_DIR`), tracked so that cargo rebuilds when it (or an import)
/// changes; errors are reported on the path with the rendered diagnostics.
pub fn include_model_macro(input: TokenStream) -> TokenStream {
    let lit: syn::LitStr = match syn::parse2(input) {
        Ok(l) => l,
        Err(e) => {
            return syn::Error::new(
                e.span(),
                "expected the model's path: include_model!(\"models/x.mbd\")",
            )
            .to_compile_error()
        }
    };
    let rel = lit.value();
    let path = match std::env::var_os("CARGO_MANIFEST_DIR") {
        Some(d) => Path::new(&d).join(&rel),
        None => PathBuf::from(&rel),
    };
    // Read the file here so that messages name it as written in the macro.
    let loaded = match crate::load::read_input(&path, crate::load::MAX_SOURCE_BYTES) {
        Ok(text) => crate::load_with(&rel, &text, path.canonicalize().ok(), &[], &|p: &Path| {
            crate::load::read_input(p, crate::load::MAX_SOURCE_BYTES)
        }),
        Err(e) => {
            return syn::Error::new(
                lit.span(),
                format!(
                    "cannot read `{rel}` (relative to CARGO_MANIFEST_DIR, {}): {e}",
                    path.parent()
                        .map(|p| p.display().to_string())
                        .unwrap_or_default()
                ),
            )
            .to_compile_error()
        }
    };
    let mut files: Vec<PathBuf> = loaded
        .sources
        .files()
        .filter_map(|(_, f)| f.path.clone())
        .collect();
    if files.is_empty() && path.is_file() {
        files.push(path.clone());
    }
    if loaded.has_errors() {
        let tracks = files.iter().map(|p| {
            let p = p.to_string_lossy().to_string();
            quote!(
                const _: &str = include_str!(#p);
            )
        });
        let e = syn::Error::new(
            lit.span(),
            format!("{} has errors:\n{}", rel, loaded.render_plain()),
        )
        .to_compile_error();
        return quote!(#e #(#tracks)*);
    }
    generated(&loaded, lit.span(), &files)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(src: &str) -> String {
        TokenText::new(src.parse().expect("tokens")).text
    }

    #[test]
    fn layout_is_kept() {
        let src = "model m {\n  body b { mass 1 kg; inertia sphere(radius: 10 cm) }\n  gravity (0, 0, -9.81) m/s^2\n  simulate { duration 1 s; step 1 ms }\n}";
        assert_eq!(text(src), src);
        assert_eq!(text("a.b link[i] 0..N"), "a.b link[i] 0..N");
    }

    #[test]
    fn every_model_lays_out_to_the_same_syntax_tree() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models");
        for e in std::fs::read_dir(dir).expect("models") {
            let p = e.expect("entry").path();
            if p.extension().is_none_or(|x| x != "mbd") {
                continue;
            }
            let src = std::fs::read_to_string(&p).expect("read");
            let Ok(tokens) = src.parse::<TokenStream>() else {
                continue; // not Rust tokens (e.g. a degree sign): unusable in model! anyway
            };
            // named by its path: imports (.msh) resolve next to it
            let name = p.to_string_lossy();
            let a = crate::load_str(&name, &src, &[]);
            let b = crate::load_str(&name, &TokenText::new(tokens).text, &[]);
            // equal up to the source offsets (comments are not tokens)
            fn strip(v: &mut serde_json::Value) {
                match v {
                    serde_json::Value::Object(m) => {
                        m.remove("origin");
                        m.values_mut().for_each(strip);
                    }
                    serde_json::Value::Array(a) => a.iter_mut().for_each(strip),
                    _ => {}
                }
            }
            let mut ja = serde_json::to_value(&a.scene).expect("json");
            let mut jb = serde_json::to_value(&b.scene).expect("json");
            strip(&mut ja);
            strip(&mut jb);
            assert!(a.scene.is_some(), "{}", p.display());
            assert_eq!(ja, jb, "{}", p.display());
        }
    }

    #[test]
    fn errors_map_to_their_tokens() {
        let src = "model m {\n  body b { mass 1 kgg; inertia sphere(radius: 10 cm) }\n}";
        let tt = TokenText::new(src.parse().expect("tokens"));
        let at = tt.text.find("kgg").expect("kgg");
        let (a, b) = tt.spans_for(at..at + 3).expect("a token");
        assert_eq!(a.start().line, 2);
        assert_eq!(
            a.start().column,
            tt.text[..at].len() - tt.text[..at].rfind('\n').unwrap() - 1
        );
        assert_eq!(b.end().column, a.start().column + 3);
    }
}
