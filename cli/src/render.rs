//! Rendering diagnostics on the terminal with miette.

use std::io::IsTerminal;

use mbdc_compiler::{Diagnostic, Sources};
use miette::{GraphicalReportHandler, GraphicalTheme};

/// A report handler: unicode and colours on a terminal, plain ASCII otherwise.
pub fn handler() -> GraphicalReportHandler {
    let theme = if std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none() {
        GraphicalTheme::unicode()
    } else {
        GraphicalTheme::unicode_nocolor()
    };
    GraphicalReportHandler::new_themed(theme).with_context_lines(1)
}

/// Renders diagnostics, one after the other.
pub fn diagnostics(diags: &[Diagnostic], sources: &Sources) -> String {
    let h = handler();
    let mut out = String::new();
    for d in diags {
        let sd = d.with_sources(sources);
        if h.render_report(&mut out, &sd).is_err() {
            out.push_str(&d.render_plain(sources));
        }
    }
    out
}

/// `2 errors, 1 warning`
pub fn counts(diags: &[Diagnostic]) -> String {
    let e = diags
        .iter()
        .filter(|d| d.severity == mbdc_compiler::Severity::Error)
        .count();
    let w = diags
        .iter()
        .filter(|d| d.severity == mbdc_compiler::Severity::Warning)
        .count();
    let plural = |n: usize, s: &str| format!("{n} {s}{}", if n == 1 { "" } else { "s" });
    format!("{}, {}", plural(e, "error"), plural(w, "warning"))
}
