//! Parse diagnostics.

use crate::ast::Span;

/// A syntax error: where, what was expected (in plain words), and possibly how to fix it.
///
/// Messages never mention grammar rule names. `Display` prints the message only; use
/// [`ParseError::render`] for a human-readable report with the source line.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct ParseError {
    /// The byte range the error points at (may be empty, e.g. at the end of a line).
    pub span: Span,
    /// What is wrong, e.g. "expected an expression after `=`, found the end of the line".
    pub message: String,
    /// How to fix it, when there is something useful to say.
    pub help: Option<String>,
}

impl ParseError {
    /// An error with a message and no help.
    pub fn new(span: Span, message: impl Into<String>) -> ParseError {
        ParseError {
            span,
            message: message.into(),
            help: None,
        }
    }

    /// The same error with a help text.
    pub fn with_help(mut self, help: impl Into<String>) -> ParseError {
        self.help = Some(help.into());
        self
    }

    /// Renders the error against its source text:
    ///
    /// ```text
    /// error: expected an expression after `=`, found the end of the line
    ///  --> 3:12
    ///   |
    /// 3 |   param L =
    ///   |            ^
    ///   = help: ...
    /// ```
    ///
    /// Line and column are 1-based; columns count characters. `src` must be the text that
    /// was parsed (offsets outside it are clamped).
    pub fn render(&self, src: &str) -> String {
        let start = crate::offsets::floor_char_boundary(src, self.span.start.min(src.len()));
        let end = crate::offsets::floor_char_boundary(src, self.span.end.clamp(start, src.len()));
        let (line, col) = crate::offsets::line_col(src, start);
        let line_start = src[..start].rfind('\n').map_or(0, |p| p + 1);
        let line_end = src[start..].find('\n').map_or(src.len(), |p| p + start);
        let text = src[line_start..line_end].trim_end_matches('\r');
        let width = src[start..end.min(line_end).max(start)]
            .chars()
            .count()
            .max(1);
        let gutter = line.to_string().len();
        let pad = " ".repeat(gutter);
        // Tabs are kept so that the caret lines up under them.
        let lead: String = src[line_start..start]
            .chars()
            .map(|c| if c == '\t' { '\t' } else { ' ' })
            .collect();
        let mut out = format!(
            "error: {}\n{pad}--> {line}:{col}\n{pad} |\n{line} | {text}\n{pad} | {lead}{}\n",
            self.message,
            "^".repeat(width)
        );
        if let Some(help) = &self.help {
            out.push_str(&format!("{pad} = help: {help}\n"));
        }
        out
    }
}
