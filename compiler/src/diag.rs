//! Diagnostics: errors, warnings and notes with labelled spans, help text and a stable code.
//!
//! A [`Diagnostic`] knows file ids and byte ranges, not texts. To print one, pair it with
//! the [`Sources`] it was produced with: [`Diagnostic::render_plain`] gives a compact,
//! deterministic text (used by the failure-corpus snapshots), and
//! [`Diagnostic::with_sources`] gives a value that implements [`miette::Diagnostic`] with
//! its source code attached, for miette's graphical report handler.

use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::{self, Write as _};
use std::sync::Arc;

use mbdc_dsl::ast::Span;
use miette::{LabeledSpan, NamedSource, SourceCode};

use crate::source::{FileId, SourceFile, Sources};

/// Source lines longer than this many bytes are shown clipped around their labels: this many
/// characters at most, with `…` where text is left out. A generated one-line model can be
/// megabytes long: echoing it whole would flood the terminal, and miette's renderer panics
/// on a label past column 65 535 (Rust's formatting widths are 16-bit).
pub const MAX_SHOWN_LINE: usize = 200;
/// Characters kept before the labelled span on a clipped line.
const CLIP_LEAD: usize = 60;
/// Marks text left out of a clipped line.
const ELLIPSIS: &str = "…";

/// The byte window `[start, end)` of `line` shown for a label at byte `anchor` of it: the
/// whole line if it is short, else [`CLIP_LEAD`] characters before the anchor and at most
/// [`MAX_SHOWN_LINE`] characters in all.
fn clip_window(line: &str, anchor: usize) -> (usize, usize) {
    if line.len() <= MAX_SHOWN_LINE {
        return (0, line.len());
    }
    let mut anchor = anchor.min(line.len());
    while !line.is_char_boundary(anchor) {
        anchor -= 1;
    }
    let start = line[..anchor]
        .char_indices()
        .rev()
        .nth(CLIP_LEAD - 1)
        .map_or(0, |(i, _)| i);
    let end = line[start..]
        .char_indices()
        .nth(MAX_SHOWN_LINE)
        .map_or(line.len(), |(i, _)| start + i);
    (start, end)
}

/// The window of `line` (see [`clip_window`]) with `…` marks where text is left out, and
/// the byte position in it of the window's start.
fn clipped_line(line: &str, (start, end): (usize, usize)) -> (Cow<'_, str>, usize) {
    if start == 0 && end == line.len() {
        return (Cow::Borrowed(line), 0);
    }
    let lead = if start > 0 { ELLIPSIS } else { "" };
    let tail = if end < line.len() { ELLIPSIS } else { "" };
    (
        Cow::Owned(format!("{lead}{}{tail}", &line[start..end])),
        lead.len(),
    )
}

/// What miette is given of a file when a line it would show is too long to show whole: the
/// lines of the labels and one either side, each clipped, the other lines left empty so that
/// line numbers stay right.
struct ClippedSource {
    text: String,
    /// Per kept line, in order: its window in the original text (byte range) and where the
    /// window starts in `text`.
    pieces: Vec<(usize, usize, usize)>,
}

impl ClippedSource {
    /// `None` if every line shown for these byte ranges is short enough to show whole.
    /// A line's window is anchored at the first of `spans` (main label first) starting on it.
    fn new(file: &SourceFile, spans: &[(usize, usize)]) -> Option<ClippedSource> {
        let last = file.line_count().saturating_sub(1);
        let mut lines = BTreeSet::new();
        let mut anchors: BTreeMap<usize, usize> = BTreeMap::new();
        for &(start, end) in spans {
            let (first, past) = (file.line_index(start), file.line_index(end));
            anchors.entry(first).or_insert(start);
            lines.extend(first.saturating_sub(1)..=(past + 1).min(last));
        }
        if lines
            .iter()
            .all(|&l| file.line_range(l).len() <= MAX_SHOWN_LINE)
        {
            return None;
        }
        let mut text = String::new();
        let mut pieces = Vec::new();
        for l in 0..=last {
            if lines.contains(&l) {
                let range = file.line_range(l);
                let line = &file.text[range.clone()];
                let anchor = anchors.get(&l).map_or(0, |a| a - range.start);
                let window = clip_window(line, anchor);
                let (shown, at) = clipped_line(line, window);
                pieces.push((
                    range.start + window.0,
                    range.start + window.1,
                    text.len() + at,
                ));
                text.push_str(&shown);
            }
            if l < last {
                text.push('\n');
            }
        }
        Some(ClippedSource { text, pieces })
    }

    /// Whether a byte offset of the original text is inside a shown window.
    fn shows(&self, offset: usize) -> bool {
        self.pieces
            .iter()
            .any(|&(start, end, _)| (start..=end).contains(&offset))
    }

    /// Where a byte offset of the original text is shown (clamped into its line's window).
    fn map(&self, offset: usize) -> usize {
        let i = self.pieces.partition_point(|p| p.0 <= offset);
        match i.checked_sub(1).map(|i| self.pieces[i]) {
            Some((start, end, at)) => at + offset.min(end) - start,
            None => self.pieces.first().map_or(0, |p| p.2),
        }
    }
}

/// How serious a diagnostic is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// The file cannot be simulated.
    Error,
    /// Probably a mistake, but the scene is usable.
    Warning,
    /// Information (free bodies, degrees of freedom, ...).
    Note,
}

impl Severity {
    /// `error`, `warning` or `note`.
    pub fn as_str(self) -> &'static str {
        match self {
            Severity::Error => "error",
            Severity::Warning => "warning",
            Severity::Note => "note",
        }
    }
}

/// A labelled span.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Label {
    /// The file.
    pub file: FileId,
    /// Byte range in the file.
    pub span: Span,
    /// Text shown next to the underline (may be empty).
    pub message: String,
    /// The main location of the diagnostic (the first primary label is where it is reported).
    pub primary: bool,
}

/// A diagnostic message about a scene.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct Diagnostic {
    /// Error, warning or note.
    pub severity: Severity,
    /// Stable code, `mbdc::kebab-case` (see [`codes`]).
    pub code: &'static str,
    /// One-line message.
    pub message: String,
    /// Labelled spans; the first primary one is the main location. May be empty for
    /// diagnostics without a location (e.g. an unknown `--set` name given no text).
    pub labels: Vec<Label>,
    /// How to fix it.
    pub help: Option<String>,
}

/// The stable diagnostic codes.
pub mod codes {
    /// The text does not parse.
    pub const SYNTAX: &str = "mbdc::syntax";
    /// A file cannot be read.
    pub const IO: &str = "mbdc::io";
    /// A name is not declared.
    pub const UNKNOWN_NAME: &str = "mbdc::unknown-name";
    /// A name is declared twice.
    pub const DUPLICATE_NAME: &str = "mbdc::duplicate-name";
    /// A function is not known.
    pub const UNKNOWN_FUNCTION: &str = "mbdc::unknown-function";
    /// A unit is not known.
    pub const UNKNOWN_UNIT: &str = "mbdc::unknown-unit";
    /// Dimensions do not agree.
    pub const UNITS: &str = "mbdc::unit-mismatch";
    /// A value of the wrong kind (a vector where a number is expected, ...).
    pub const WRONG_KIND: &str = "mbdc::wrong-kind";
    /// A declaration or property keyword is not known here.
    pub const UNKNOWN_ITEM: &str = "mbdc::unknown-item";
    /// A property is not known for this declaration.
    pub const UNKNOWN_PROPERTY: &str = "mbdc::unknown-property";
    /// A required property is missing.
    pub const MISSING_PROPERTY: &str = "mbdc::missing-property";
    /// A property is given twice.
    pub const DUPLICATE_PROPERTY: &str = "mbdc::duplicate-property";
    /// A call argument is missing, unknown, repeated or of the wrong form.
    pub const ARGUMENT: &str = "mbdc::argument";
    /// A value is out of its allowed range (non-positive mass, negative stiffness, ...).
    pub const INVALID_VALUE: &str = "mbdc::invalid-value";
    /// An inertia tensor is not symmetric positive definite or violates the triangle inequality.
    pub const BAD_INERTIA: &str = "mbdc::bad-inertia";
    /// A rotation is not a rotation / a quaternion had to be normalised.
    pub const ORIENTATION: &str = "mbdc::orientation";
    /// A joint connects a body to itself.
    pub const SELF_JOINT: &str = "mbdc::self-joint";
    /// A joint axis is zero.
    pub const ZERO_AXIS: &str = "mbdc::zero-axis";
    /// Universal joint axes are not perpendicular.
    pub const NOT_PERPENDICULAR: &str = "mbdc::not-perpendicular";
    /// A joint of the wrong kind is referenced (driver of a spherical joint, ...).
    pub const JOINT_KIND: &str = "mbdc::joint-kind";
    /// An expression depends on `t` where it must be constant.
    pub const TIME_DEPENDENT: &str = "mbdc::time-dependent";
    /// Arithmetic that has no finite result (division by zero, sqrt of a negative, ...).
    pub const MATH: &str = "mbdc::math";
    /// Import cycle.
    pub const IMPORT_CYCLE: &str = "mbdc::import-cycle";
    /// Import problems (not found, too deep, model in an imported file).
    pub const IMPORT: &str = "mbdc::import";
    /// No model or more than one model.
    pub const MODEL: &str = "mbdc::model";
    /// A component instantiates itself.
    pub const RECURSIVE_COMPONENT: &str = "mbdc::recursive-component";
    /// Too many generated items, or nesting too deep.
    pub const LIMIT: &str = "mbdc::limit";
    /// Unknown integration method or mesh solver.
    pub const UNKNOWN_METHOD: &str = "mbdc::unknown-method";
    /// Unknown option of an integration method or a mesh solver.
    pub const UNKNOWN_METHOD_OPTION: &str = "mbdc::unknown-method-option";
    /// A command-line override is malformed or names no parameter.
    pub const OVERRIDE: &str = "mbdc::override";
    /// Mesh generation, import and set problems.
    pub const MESH: &str = "mbdc::mesh";
    /// Beam problems.
    pub const BEAM: &str = "mbdc::beam";
    /// A joint is not satisfied by the initial state.
    pub const INITIAL_VIOLATION: &str = "mbdc::initial-violation";
    /// Bodies not connected to ground.
    pub const FREE_BODIES: &str = "mbdc::free-bodies";
    /// Degree-of-freedom count / redundant constraints.
    pub const DOF: &str = "mbdc::dof";
    /// A construct has no effect (force on ground, ...).
    pub const NO_EFFECT: &str = "mbdc::no-effect";
}

impl Diagnostic {
    /// A new diagnostic without labels.
    pub fn new(severity: Severity, code: &'static str, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            severity,
            code,
            message: message.into(),
            labels: Vec::new(),
            help: None,
        }
    }

    /// A new error.
    pub fn error(code: &'static str, message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Severity::Error, code, message)
    }

    /// A new warning.
    pub fn warning(code: &'static str, message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Severity::Warning, code, message)
    }

    /// A new note.
    pub fn note(code: &'static str, message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Severity::Note, code, message)
    }

    /// Adds the primary label.
    pub fn primary(mut self, file: FileId, span: Span, message: impl Into<String>) -> Diagnostic {
        self.labels.push(Label {
            file,
            span,
            message: message.into(),
            primary: true,
        });
        self
    }

    /// Adds a secondary label.
    pub fn secondary(mut self, file: FileId, span: Span, message: impl Into<String>) -> Diagnostic {
        self.labels.push(Label {
            file,
            span,
            message: message.into(),
            primary: false,
        });
        self
    }

    /// Sets the help text.
    pub fn help(mut self, help: impl Into<String>) -> Diagnostic {
        self.help = Some(help.into());
        self
    }

    /// Sets the help text if there is one.
    pub fn maybe_help(mut self, help: Option<String>) -> Diagnostic {
        if help.is_some() {
            self.help = help;
        }
        self
    }

    /// Whether this is an error.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// The main label (first primary, else first).
    pub fn main_label(&self) -> Option<&Label> {
        self.labels
            .iter()
            .find(|l| l.primary)
            .or_else(|| self.labels.first())
    }

    /// A compact, deterministic text rendering:
    ///
    /// ```text
    /// error[mbdc::unknown-name]: unknown body `rdo1`
    ///   --> pendulum.mbd:12:23
    ///    |
    /// 12 |   joint j = spherical(rdo1 @ (0, 0, 0), ...)
    ///    |                       ^^^^ not declared
    ///    = help: did you mean `rod1`?
    /// ```
    pub fn render_plain(&self, sources: &Sources) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "{}[{}]: {}",
            self.severity.as_str(),
            self.code,
            self.message
        );
        let mut labels: Vec<&Label> = self.labels.iter().collect();
        // Primary label first, the others in source order.
        labels.sort_by_key(|l| (!l.primary, l.file, l.span.start));
        for l in labels {
            let Some(f) = sources.get(l.file) else {
                continue;
            };
            let (line, col) = f.line_col(l.span.start);
            let full = f.line_text(line);
            // byte offsets in the line of the span's start and (on this line) end
            let line_start = f.line_range(line - 1).start;
            let from = l.span.start.clamp(line_start, line_start + full.len()) - line_start;
            let to = l.span.end.clamp(line_start + from, line_start + full.len()) - line_start;
            let window = clip_window(full, from);
            let (text, at) = clipped_line(full, window);
            let chars = |a: usize, b: usize| full.get(a..b).map_or(b - a, |s| s.chars().count());
            // the column and width of the underline in the shown text
            let shown_col = text[..at].chars().count() + chars(window.0, from.max(window.0)) + 1;
            let width = chars(from.max(window.0), to.min(window.1)).max(1);
            let gutter = line.to_string().len();
            let pad = " ".repeat(gutter);
            let _ = writeln!(out, "{pad}--> {}:{}:{}", f.name, line, col);
            let _ = writeln!(out, "{pad} |");
            let _ = writeln!(out, "{line} | {text}");
            let mark = if l.primary { '^' } else { '-' };
            let under: String = std::iter::repeat_n(mark, width).collect();
            let lead: String = text
                .chars()
                .take(shown_col - 1)
                .map(|c| if c == '\t' { '\t' } else { ' ' })
                .collect();
            if l.message.is_empty() {
                let _ = writeln!(out, "{pad} | {lead}{under}");
            } else {
                let _ = writeln!(out, "{pad} | {lead}{under} {}", l.message);
            }
        }
        if let Some(h) = &self.help {
            let _ = writeln!(out, "  = help: {h}");
        }
        out
    }

    /// Pairs the diagnostic with its source texts, for miette's report handlers.
    pub fn with_sources(&self, sources: &Sources) -> SourcedDiagnostic {
        SourcedDiagnostic::new(self, sources)
    }
}

fn miette_severity(s: Severity) -> miette::Severity {
    match s {
        Severity::Error => miette::Severity::Error,
        Severity::Warning => miette::Severity::Warning,
        Severity::Note => miette::Severity::Advice,
    }
}

impl miette::Diagnostic for Diagnostic {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new(self.code))
    }
    fn severity(&self) -> Option<miette::Severity> {
        Some(miette_severity(self.severity))
    }
    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.help
            .as_ref()
            .map(|h| Box::new(h) as Box<dyn fmt::Display>)
    }
}

/// A [`Diagnostic`] with its source text attached (labels in the main label's file).
/// Labels in other files become related diagnostics, each with its own source.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct SourcedDiagnostic {
    severity: Severity,
    code: Option<&'static str>,
    message: String,
    help: Option<String>,
    src: Option<NamedSource<Arc<str>>>,
    labels: Vec<LabeledSpan>,
    related: Vec<SourcedDiagnostic>,
}

impl SourcedDiagnostic {
    fn new(d: &Diagnostic, sources: &Sources) -> SourcedDiagnostic {
        let main_file = d.main_label().map(|l| l.file);
        let text_len = main_file.map_or(0, |f| sources.text(f).len());
        let span_of = |l: &Label| {
            let start = l.span.start.min(text_len);
            (start, l.span.end.clamp(start, text_len))
        };
        // the main label first: it anchors the window of its line
        let in_main: Vec<(usize, usize)> = d
            .main_label()
            .into_iter()
            .chain(&d.labels)
            .filter(|l| Some(l.file) == main_file)
            .map(span_of)
            .collect();
        // a line too long to show whole: give miette the clipped lines instead
        let clipped = main_file
            .and_then(|f| sources.get(f))
            .and_then(|sf| ClippedSource::new(sf, &in_main).map(|c| (sf, c)));
        let mut labels = Vec::new();
        let mut others: Vec<&Label> = Vec::new();
        for l in &d.labels {
            if Some(l.file) == main_file {
                let (mut start, mut end) = span_of(l);
                if let Some((_, c)) = &clipped {
                    if !c.shows(start) {
                        // left out of the clipped line: shown on its own, as a related note
                        others.push(l);
                        continue;
                    }
                    (start, end) = (c.map(start), c.map(end));
                }
                let msg = if l.message.is_empty() {
                    None
                } else {
                    Some(l.message.clone())
                };
                labels.push(if l.primary {
                    LabeledSpan::new_primary_with_span(msg, (start, end - start))
                } else {
                    LabeledSpan::new_with_span(msg, (start, end - start))
                });
            } else {
                others.push(l);
            }
        }
        let mut help = d.help.clone();
        let src = match &clipped {
            Some((sf, c)) => {
                // miette's column is one in the clipped text: say where the label really is
                let main = d.main_label().map(|l| (l, sf.line_col(l.span.start)));
                let long = main.map_or(0, |(_, (line, _))| sf.line_range(line - 1).len());
                if let Some((_, (line, col))) = main.filter(|_| long > MAX_SHOWN_LINE) {
                    let note = format!(
                        "line {line} is {long} bytes long and shown clipped; the label is at {}:{line}:{col}",
                        sf.name
                    );
                    help = Some(match help {
                        Some(h) => format!("{h}\n{note}"),
                        None => note,
                    });
                }
                let text = Arc::<str>::from(c.text.as_str());
                Some(NamedSource::new(sf.name.clone(), text).with_language("mbd"))
            }
            None => main_file.and_then(|f| {
                sources.get(f).map(|sf| {
                    NamedSource::new(sf.name.clone(), sf.text.clone()).with_language("mbd")
                })
            }),
        };
        let related = others
            .into_iter()
            .map(|l| {
                let sub = Diagnostic {
                    severity: Severity::Note,
                    code: "",
                    message: if l.message.is_empty() {
                        "see also".into()
                    } else {
                        l.message.clone()
                    },
                    labels: vec![Label {
                        message: String::new(),
                        primary: true,
                        ..l.clone()
                    }],
                    help: None,
                };
                let mut s = SourcedDiagnostic::new(&sub, sources);
                s.code = None;
                s
            })
            .collect();
        SourcedDiagnostic {
            severity: d.severity,
            code: if d.code.is_empty() {
                None
            } else {
                Some(d.code)
            },
            message: d.message.clone(),
            help,
            src,
            labels,
            related,
        }
    }
}

impl miette::Diagnostic for SourcedDiagnostic {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.code.map(|c| Box::new(c) as Box<dyn fmt::Display>)
    }
    fn severity(&self) -> Option<miette::Severity> {
        Some(miette_severity(self.severity))
    }
    fn help<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        self.help
            .as_ref()
            .map(|h| Box::new(h) as Box<dyn fmt::Display>)
    }
    fn source_code(&self) -> Option<&dyn SourceCode> {
        self.src.as_ref().map(|s| s as &dyn SourceCode)
    }
    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        if self.labels.is_empty() {
            None
        } else {
            Some(Box::new(self.labels.iter().cloned()))
        }
    }
    fn related<'a>(&'a self) -> Option<Box<dyn Iterator<Item = &'a dyn miette::Diagnostic> + 'a>> {
        if self.related.is_empty() {
            None
        } else {
            Some(Box::new(
                self.related.iter().map(|r| r as &dyn miette::Diagnostic),
            ))
        }
    }
}

/// Renders all diagnostics with [`Diagnostic::render_plain`], separated by blank lines.
pub fn render_all_plain(diags: &[Diagnostic], sources: &Sources) -> String {
    let mut s = String::new();
    for (i, d) in diags.iter().enumerate() {
        if i > 0 {
            s.push('\n');
        }
        s.push_str(&d.render_plain(sources));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_rendering() {
        let mut s = Sources::new();
        let f = s.add("x.mbd", None, "model m {\n  mass 1 s\n}\n");
        let d = Diagnostic::error(codes::UNITS, "mass must be in kg")
            .primary(f, Span::new(17, 20), "this is a time")
            .help("write `1 kg`");
        let r = d.render_plain(&s);
        assert_eq!(
            r,
            "error[mbdc::unit-mismatch]: mass must be in kg\n --> x.mbd:2:8\n  |\n2 |   mass 1 s\n  |        ^^^ this is a time\n  = help: write `1 kg`\n"
        );
    }

    /// A one-line model long enough to put its error past column 65 535: miette's renderer
    /// used to panic there (formatting widths are 16-bit) and both renderings echoed the
    /// whole line.
    fn long_line() -> (Sources, Diagnostic) {
        let mut text = String::from("model m { ");
        for i in 0..2000 {
            text.push_str(&format!(
                "body b{i} {{ mass 1 kg; inertia sphere(radius: 1 cm) }} "
            ));
        }
        let at = text.len();
        text.push_str("joint j = spherical(ground @ (0, 0, 0), bXX @ (0, 0, 0)) }\nmodel n {}\n");
        assert!(at > 70_000);
        let mut s = Sources::new();
        let f = s.add("long.mbd", None, text);
        let d = Diagnostic::error(codes::UNKNOWN_NAME, "unknown body `bXX`")
            .primary(f, Span::new(at + 40, at + 43), "not declared")
            .secondary(f, Span::new(10, 14), "bodies start here")
            .help("did you mean `b0`?");
        (s, d)
    }

    #[test]
    fn a_label_far_along_a_long_line_renders_clipped() {
        let (s, d) = long_line();
        let mut out = String::new();
        miette::GraphicalReportHandler::new_themed(miette::GraphicalTheme::unicode_nocolor())
            .with_context_lines(1)
            .render_report(&mut out, &d.with_sources(&s))
            .expect("renders");
        assert!(out.len() < 2048, "{} bytes:\n{out}", out.len());
        assert!(out.contains("unknown body `bXX`"), "{out}");
        assert!(out.contains("bXX @ (0, 0, 0)"), "{out}");
        assert!(out.contains('…'), "{out}");
        assert!(out.contains("not declared"), "{out}");
        assert!(out.contains("long.mbd:1:"), "{out}");
        // the real column, since miette's own is one in the clipped text
        let (_, col) = s
            .get(FileId(0))
            .expect("file")
            .line_col(d.labels[0].span.start);
        assert!(out.contains(&format!("long.mbd:1:{col}")), "{out}");

        let plain = d.render_plain(&s);
        assert!(plain.len() < 2048, "{} bytes:\n{plain}", plain.len());
        assert!(plain.contains(&format!("--> long.mbd:1:{col}")), "{plain}");
        let lines: Vec<&str> = plain.lines().collect();
        // the underline sits under `bXX` in the clipped line
        let (shown, under) = (lines[3], lines[4]);
        let caret = under.chars().position(|c| c == '^').expect("underline");
        let marked: String = shown.chars().skip(caret).take(3).collect();
        assert_eq!(marked, "bXX", "{plain}");
        // the secondary label, far from the first, is shown on its own
        assert!(out.contains("bodies start here"), "{out}");
        assert!(under.ends_with("^^^ not declared"), "{plain}");
    }
}
