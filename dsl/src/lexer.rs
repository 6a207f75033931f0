//! The pass that runs before the pest grammar.
//!
//! It walks the text once (linear time, no recursion) and produces a *masked* copy of the
//! same byte length for the grammar:
//!
//! * comments are collected (with their spans) and replaced by spaces;
//! * newlines that do not end an item are replaced by a form feed (`\x0C`), which the
//!   grammar treats as whitespace: newlines inside `( )` and `[ ]`, after a line that ends
//!   with a binary operator or a comma, and before `else`;
//! * brackets are matched, so that unclosed or mismatched brackets get a precise message
//!   ("unclosed `{` opened here") and so that nesting deeper than [`crate::MAX_NESTING`]
//!   is refused before the (recursive) grammar sees it;
//! * strings and block comments are checked for termination.
//!
//! The matched bracket pairs are kept for error recovery (see `parser.rs`).

use crate::ast::{Comment, Span};
use crate::error::ParseError;
use crate::offsets::line_col;
use crate::MAX_NESTING;

/// The result of the pre-pass.
#[derive(Debug)]
pub(crate) struct Lexed {
    /// The masked text (same length as the source).
    pub masked: String,
    /// All comments, in source order.
    pub comments: Vec<Comment>,
    /// Matched bracket pairs `(open, close)` byte offsets, in order of their closing.
    pub pairs: Vec<(usize, usize)>,
    /// The deepest bracket nesting seen.
    pub max_depth: usize,
}

/// What the last token before a newline says about the line's continuation.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Last {
    /// Start of input, or a token after which a newline ends the item.
    Ends,
    /// A binary operator or a comma: the item continues on the next line.
    Continues,
}

const FORM_FEED: u8 = 0x0C;

/// Runs the pre-pass. `as_expression` treats the whole input as if inside parentheses
/// (newlines are whitespace), for [`crate::parse_expr`].
pub(crate) fn prelex(src: &str, as_expression: bool) -> Result<Lexed, ParseError> {
    let bytes = src.as_bytes();
    let n = bytes.len();
    let mut out = bytes.to_vec();
    let mut comments = Vec::new();
    let mut pairs = Vec::new();
    let mut stack: Vec<(u8, usize)> = Vec::new();
    let mut max_depth = 0;
    let mut last = Last::Ends;
    // Significant newlines seen since the last token (turned into whitespace if the next
    // token is `else`).
    let mut pending_newlines: Vec<usize> = Vec::new();
    let in_brackets =
        |stack: &Vec<(u8, usize)>| as_expression || matches!(stack.last(), Some((b'(' | b'[', _)));

    // A byte-order mark (as some Windows editors write) is whitespace.
    let mut i = 0;
    if bytes.starts_with("\u{feff}".as_bytes()) {
        out[..3].fill(b' ');
        i = 3;
    }
    while i < n {
        let b = bytes[i];
        match b {
            b' ' | b'\t' | b'\r' | FORM_FEED => {
                i += 1;
                continue;
            }
            b'\n' => {
                if in_brackets(&stack) || last == Last::Continues {
                    out[i] = FORM_FEED;
                } else {
                    pending_newlines.push(i);
                }
                i += 1;
                continue;
            }
            b'/' if bytes.get(i + 1) == Some(&b'/') => {
                let mut end = i;
                while end < n && bytes[end] != b'\n' {
                    end += 1;
                }
                // Keep a CR of a CRLF line ending out of the comment text.
                let text_end = if end > i && bytes[end - 1] == b'\r' {
                    end - 1
                } else {
                    end
                };
                comments.push(Comment {
                    text: src[i..text_end].to_string(),
                    span: Span::new(i, text_end),
                    blank_before: false,
                });
                out[i..end].fill(b' ');
                i = end;
                continue;
            }
            b'/' if bytes.get(i + 1) == Some(&b'*') => {
                let close = find(bytes, i + 2, b"*/").ok_or_else(|| {
                    ParseError::new(Span::new(i, i + 2), "unterminated block comment")
                        .with_help("close it with `*/` (block comments do not nest)")
                })?;
                let end = close + 2;
                comments.push(Comment {
                    text: src[i..end].to_string(),
                    span: Span::new(i, end),
                    blank_before: false,
                });
                for j in i..end {
                    if bytes[j] == b'\n' {
                        if in_brackets(&stack) || last == Last::Continues {
                            out[j] = FORM_FEED;
                        } else {
                            pending_newlines.push(j);
                        }
                    } else {
                        out[j] = b' ';
                    }
                }
                i = end;
                continue;
            }
            _ => {}
        }

        // A token starts here.
        if !pending_newlines.is_empty() {
            if starts_word(bytes, i, b"else") {
                for &p in &pending_newlines {
                    out[p] = FORM_FEED;
                }
            }
            pending_newlines.clear();
        }
        match b {
            b'"' => {
                let mut j = i + 1;
                loop {
                    match bytes.get(j) {
                        None | Some(b'\n') => {
                            return Err(ParseError::new(Span::new(i, j), "unterminated string")
                                .with_help("close the string with `\"` on the same line"));
                        }
                        Some(b'"') => break,
                        Some(b'\\') => {
                            if matches!(bytes.get(j + 1), None | Some(b'\n')) {
                                return Err(ParseError::new(
                                    Span::new(i, j + 1),
                                    "unterminated string",
                                )
                                .with_help("close the string with `\"` on the same line"));
                            }
                            j += 2;
                        }
                        Some(_) => j += 1,
                    }
                }
                last = Last::Ends;
                i = j + 1;
            }
            b'(' | b'[' | b'{' => {
                stack.push((b, i));
                max_depth = max_depth.max(stack.len());
                if stack.len() > MAX_NESTING {
                    return Err(ParseError::new(
                        Span::new(i, i + 1),
                        format!("nested too deeply (more than {MAX_NESTING} levels of brackets)"),
                    )
                    .with_help("split the expression or the block, e.g. with `const` values"));
                }
                last = Last::Ends;
                i += 1;
            }
            b')' | b']' | b'}' => {
                let want = match b {
                    b')' => b'(',
                    b']' => b'[',
                    _ => b'{',
                };
                match stack.pop() {
                    Some((open, at)) if open == want => pairs.push((at, i)),
                    Some((open, at)) => {
                        let (line, _) = line_col(src, at);
                        return Err(ParseError::new(
                            Span::new(i, i + 1),
                            format!(
                                "expected `{}` to close the `{}` on line {line}, found `{}`",
                                closing(open) as char,
                                open as char,
                                b as char
                            ),
                        )
                        .with_help(format!(
                            "add the missing `{}`, or remove this `{}`",
                            closing(open) as char,
                            b as char
                        )));
                    }
                    None => {
                        return Err(ParseError::new(
                            Span::new(i, i + 1),
                            format!(
                                "unexpected `{}`: there is no open `{}` to close",
                                b as char, want as char
                            ),
                        )
                        .with_help("remove it, or add the opening bracket it belongs to"));
                    }
                }
                last = Last::Ends;
                i += 1;
            }
            b'a'..=b'z' | b'A'..=b'Z' | b'_' | b'0'..=b'9' => {
                let start = i;
                while i < n && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                    i += 1;
                }
                let word = &bytes[start..i];
                last = if word == b"and" || word == b"or" {
                    Last::Continues
                } else {
                    Last::Ends
                };
            }
            b'=' | b'!' | b'<' | b'>' => {
                let two = bytes.get(i + 1) == Some(&b'=');
                last = if (b == b'=' || b == b'!') && !two {
                    // `=` alone (declarations) does not continue a line; `!` alone is an error
                    // the grammar reports.
                    Last::Ends
                } else {
                    Last::Continues
                };
                i += if two { 2 } else { 1 };
            }
            b'+' | b'-' | b'*' | b'/' | b'%' | b'^' | b'@' | b',' => {
                last = Last::Continues;
                i += 1;
            }
            _ => {
                last = Last::Ends;
                // Skip a whole UTF-8 character so that the loop stays on char boundaries.
                i += utf8_len(b);
            }
        }
    }

    if let Some(&(open, at)) = stack.last() {
        let mut err = ParseError::new(
            Span::new(at, at + 1),
            format!("unclosed `{}` opened here", open as char),
        )
        .with_help(format!("add a matching `{}`", closing(open) as char));
        if open == b'{' {
            if let Some(hint) = misindented_brace(src, &pairs) {
                err = err.with_help(format!("add a matching `}}`; {hint}"));
            }
        }
        return Err(err);
    }

    let masked = String::from_utf8(out).map_err(|_| {
        ParseError::new(
            Span::new(0, 0),
            "internal error: masking produced invalid UTF-8",
        )
    })?;
    Ok(Lexed {
        masked,
        comments,
        pairs,
        max_depth,
    })
}

fn closing(open: u8) -> u8 {
    match open {
        b'(' => b')',
        b'[' => b']',
        _ => b'}',
    }
}

fn utf8_len(first: u8) -> usize {
    match first {
        0xF0..=0xFF => 4,
        0xE0..=0xEF => 3,
        0xC0..=0xDF => 2,
        _ => 1,
    }
}

fn find(hay: &[u8], from: usize, needle: &[u8]) -> Option<usize> {
    if from > hay.len() {
        return None;
    }
    hay[from..]
        .windows(needle.len())
        .position(|w| w == needle)
        .map(|p| p + from)
}

fn starts_word(bytes: &[u8], i: usize, word: &[u8]) -> bool {
    bytes[i..].starts_with(word)
        && !bytes
            .get(i + word.len())
            .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_')
}

/// Indentation (in bytes of spaces/tabs) of the line containing `offset`, and whether
/// `offset` is the first non-blank character of its line.
fn indentation(src: &str, offset: usize) -> (usize, bool) {
    let line_start = src[..offset].rfind('\n').map_or(0, |p| p + 1);
    let indent = src[line_start..]
        .bytes()
        .take_while(|&b| b == b' ' || b == b'\t')
        .count();
    (indent, line_start + indent == offset)
}

/// For an unclosed `{`: the first matched `{ }` pair whose closing brace starts a line with
/// a different indentation than the line of its opening brace is the likely culprit.
fn misindented_brace(src: &str, pairs: &[(usize, usize)]) -> Option<String> {
    let mut candidates: Vec<&(usize, usize)> = pairs
        .iter()
        .filter(|(o, _)| src.as_bytes()[*o] == b'{')
        .collect();
    candidates.sort_unstable();
    for &&(open, close) in &candidates {
        let (open_indent, _) = indentation(src, open);
        let (close_indent, first) = indentation(src, close);
        if first && open_indent != close_indent {
            let (ol, _) = line_col(src, open);
            let (cl, _) = line_col(src, close);
            return Some(format!(
                "perhaps the `{{` on line {ol} is missing its `}}` (the `}}` on line {cl} that closes it is indented differently)"
            ));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn masked(src: &str) -> String {
        prelex(src, false)
            .map(|l| l.masked)
            .unwrap_or_else(|e| panic!("{e:?}"))
    }

    #[test]
    fn masked_text_has_the_same_length_and_marks_item_ends() {
        // Newlines that end items stay; the others become form feeds.
        assert_eq!(masked("a 1\nb (1,\n2)\n"), "a 1\nb (1,\u{c}2)\n");
        assert_eq!(masked("a [\n1\n]\n"), "a [\u{c}1\u{c}]\n");
        assert_eq!(masked("x a +\nb\n"), "x a +\u{c}b\n");
        assert_eq!(masked("x a and\nb or\nc\n"), "x a and\u{c}b or\u{c}c\n");
        assert_eq!(masked("x a,\nb\n"), "x a,\u{c}b\n");
        assert_eq!(masked("x a ==\nb\n"), "x a ==\u{c}b\n");
        // `=` alone does not continue a line, nor does a word that merely starts like an
        // operator.
        assert_eq!(masked("x a =\nb\n"), "x a =\nb\n");
        assert_eq!(masked("x android\nb\n"), "x android\nb\n");
        // Before `else`, even across blank lines and comments.
        assert_eq!(
            masked("if a {\n}\n\nelse {\n}\n"),
            "if a {\n}\u{c}\u{c}else {\n}\n"
        );
        assert_eq!(
            masked("if a {\n} // c\nelse {}"),
            "if a {\n}     \u{c}else {}"
        );
        assert_eq!(masked("if a {}\nelsewhere 1"), "if a {}\nelsewhere 1");
    }

    #[test]
    fn comments_are_collected_and_blanked() {
        let l = prelex("a 1 // one\n/* two\nlines */ b 2 // é\r\n", false)
            .unwrap_or_else(|e| panic!("{e:?}"));
        let src = "a 1 // one\n/* two\nlines */ b 2 // é\r\n";
        assert_eq!(l.masked, "a 1       \n      \n         b 2       \n");
        let texts: Vec<&str> = l.comments.iter().map(|c| c.text.as_str()).collect();
        assert_eq!(texts, ["// one", "/* two\nlines */", "// é"]);
        for c in &l.comments {
            assert_eq!(&src[c.span.start..c.span.end], c.text);
        }
        // Comment markers inside strings are text; escaped quotes do not end a string.
        let l = prelex(r#"import "a//b\"/*c""#, false).unwrap_or_else(|e| panic!("{e:?}"));
        assert!(l.comments.is_empty());
        assert_eq!(l.masked, r#"import "a//b\"/*c""#);
    }

    #[test]
    fn newlines_inside_a_block_comment_follow_the_same_rules() {
        assert_eq!(masked("a 1 /* x\ny */ b 2"), "a 1     \n     b 2");
        assert_eq!(masked("f(1, /* x\ny */ 2)"), "f(1,     \u{c}     2)");
    }

    #[test]
    fn byte_order_mark_is_whitespace() {
        assert_eq!(masked("\u{feff}a 1"), "   a 1");
    }

    #[test]
    fn brackets_are_matched_and_depth_is_measured() {
        let l = prelex("a {\n  b (1, [2])\n}\n", false).unwrap_or_else(|e| panic!("{e:?}"));
        assert_eq!(l.max_depth, 3);
        assert_eq!(l.pairs, vec![(12, 14), (8, 15), (2, 17)]);
        let e = prelex("(((", false).expect_err("unclosed");
        assert_eq!(
            (e.span, e.message.as_str()),
            (Span::new(2, 3), "unclosed `(` opened here")
        );
        let deep = "(".repeat(MAX_NESTING + 1);
        let e = prelex(&deep, false).expect_err("too deep");
        assert_eq!(e.span, Span::new(MAX_NESTING, MAX_NESTING + 1));
        assert!(prelex(&"(".repeat(MAX_NESTING), false)
            .is_err_and(|e| e.message.starts_with("unclosed")));
    }

    #[test]
    fn expression_mode_treats_every_newline_as_whitespace() {
        let l = prelex("1\n+ 2\n", true).unwrap_or_else(|e| panic!("{e:?}"));
        assert_eq!(l.masked, "1\u{c}+ 2\u{c}");
    }

    #[test]
    fn line_and_column_count_characters() {
        let src = "ab\nçd\n";
        assert_eq!(line_col(src, 0), (1, 1));
        assert_eq!(line_col(src, 3), (2, 1));
        assert_eq!(line_col(src, 5), (2, 2));
        assert_eq!(line_col(src, 4), (2, 1), "inside a character: its start");
        assert_eq!(line_col(src, 99), (3, 1));
    }
}
