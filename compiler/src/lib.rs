//! # mbdc-compiler: from `.mbd` syntax to a validated `Scene`, and from a `Scene` to Rust
//!
//! **What it is.** Lowering of the syntax tree (`mbdc-dsl`) to a [`mbdc_runtime::scene::Scene`]:
//! imports, name resolution, parameters, components and loops expanded, units checked and
//! converted to SI, physics validated; diagnostics with source spans. Then code generation
//! ([`codegen`]): from a `Scene` to Rust specialized to it, implementing the runtime's
//! `System`; and the `build.rs` API ([`build`], [`Builder`]) that writes that Rust into
//! `OUT_DIR`. The proc-macros of `mbdc-macros` and `mbdc run` use the same generator.
//!
//! **What it must never know.** How to integrate: no time stepping, no solvers. It produces
//! data (`Scene`) and source text; the runtime does the numerics. It has no command-line
//! concerns (argument parsing, terminals, progress bars) either: those live in `mbdc` (cli).
//!
//! ## API
//!
//! - [`load_file`] / [`load_str`] (and [`load_with`] for a custom file reader): text →
//!   [`Loaded`] = the [`Sources`] read, the [`Scene`] (present only when there is no
//!   error) and every [`Diagnostic`] (errors, warnings, notes), sorted by location.
//! - [`Override`]: a `--set NAME=VALUE` parameter override (`"L=2m".parse()`).
//! - [`summary()`]: a [`CheckSummary`] of a scene (bodies, joints and rows, degrees of
//!   freedom, Jacobian rank, effects, forces, beams/meshes, method and settings), with a
//!   readable `Display`.
//! - [`codegen::generate`]: a [`Scene`] → formatted Rust source (`pub mod <scene> { Model }`),
//!   with the structure key that identifies interchangeable programs ([`codegen::plan`]).
//! - [`build`] / [`Builder`] (module [`embed`]): generate a model file's Rust into `OUT_DIR`
//!   from a build script, with `cargo:rerun-if-changed` for every file read.
//! - [`tokens`]: the work of the `model!` and `include_model!` proc-macros (model text from
//!   tokens and errors back at the tokens).
//! - [`Diagnostic`]: severity, stable code ([`diag::codes`]), message, labelled spans, help.
//!   [`Diagnostic::render_plain`] renders one as text; [`Diagnostic::with_sources`] gives a
//!   [`miette::Diagnostic`] with its source attached.
//!
//! ```
//! let loaded = mbdc_compiler::load_str(
//!     "free_fall.mbd",
//!     "model free_fall {\n  body ball { mass 1 kg; inertia sphere(radius: 10 cm) }\n  simulate { duration 1 s; step 1 ms }\n}\n",
//!     &[],
//! );
//! assert!(!loaded.has_errors(), "{}", loaded.render_plain());
//! let scene = loaded.scene.unwrap();
//! assert_eq!(scene.bodies[0].mass, 1.0);
//! assert!((scene.bodies[0].inertia[0][0] - 0.004).abs() < 1e-15);
//! ```
//!
//! ## Module map
//!
//! `source` (file table, line/column), `diag` (diagnostics, rendering), `load` (reading,
//! parsing, imports), `units` and `value` (dimensions, quantities), `fn1` (time-function
//! trees), `env` (scopes), `lower` (expansion and lowering of every construct; its child
//! `lower::eval` evaluates expressions), `geom` (rotations, frames, inertia formulas),
//! `kinematics` (constraint residuals at t = 0), `validate` (post-lowering checks),
//! `summary`, `codegen` (Rust from a `Scene`), `embed` (the `build.rs` API).

#![warn(missing_docs)]

pub mod codegen;
pub mod diag;
pub mod embed;
pub mod env;
pub mod fn1;
pub mod geom;
pub mod kinematics;
pub mod load;
mod lower;
pub mod source;
pub mod suggest;
pub mod summary;
pub mod tokens;
pub mod units;
pub mod validate;
pub mod value;

use std::path::{Path, PathBuf};
use std::str::FromStr;

pub use diag::{Diagnostic, Label, Severity};
pub use embed::{build, Builder};
pub use lower::msh;
pub use mbdc_runtime::scene::Scene;
pub use source::{FileId, Sources};
pub use summary::{summary, CheckSummary};

use lower::OverrideState;

/// A command-line parameter override, `NAME=VALUE` (`L=2m`, `g=(0, 0, -9.81) m/s^2`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Override {
    /// Parameter name.
    pub name: String,
    /// Value text, parsed as an `.mbd` expression.
    pub value: String,
}

impl Override {
    /// An override from its parts.
    pub fn new(name: impl Into<String>, value: impl Into<String>) -> Override {
        Override {
            name: name.into(),
            value: value.into(),
        }
    }
}

impl FromStr for Override {
    type Err = String;
    /// Parses `NAME=VALUE`.
    fn from_str(s: &str) -> Result<Override, String> {
        let Some((n, v)) = s.split_once('=') else {
            return Err(format!("expected NAME=VALUE, found `{s}`"));
        };
        let n = n.trim();
        let ok = !n.is_empty()
            && n.chars()
                .next()
                .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !ok {
            return Err(format!("`{n}` is not a parameter name"));
        }
        if v.trim().is_empty() {
            return Err(format!("no value given for `{n}`"));
        }
        Ok(Override {
            name: n.to_string(),
            value: v.trim().to_string(),
        })
    }
}

/// The result of loading a scene.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// Every text read (the main file is [`FileId`] 0).
    pub sources: Sources,
    /// The scene, if there was no error.
    pub scene: Option<Scene>,
    /// All diagnostics, sorted by file and position (those without a location first).
    pub diagnostics: Vec<Diagnostic>,
}

impl Loaded {
    /// Whether any diagnostic is an error.
    pub fn has_errors(&self) -> bool {
        self.diagnostics.iter().any(Diagnostic::is_error)
    }

    /// The errors.
    pub fn errors(&self) -> impl Iterator<Item = &Diagnostic> {
        self.diagnostics.iter().filter(|d| d.is_error())
    }

    /// All diagnostics rendered with [`Diagnostic::render_plain`].
    pub fn render_plain(&self) -> String {
        diag::render_all_plain(&self.diagnostics, &self.sources)
    }
}

/// Reads and lowers a `.mbd` file (imports resolved relative to it).
pub fn load_file(path: impl AsRef<Path>, overrides: &[Override]) -> Loaded {
    let path = path.as_ref();
    let name = path.to_string_lossy().replace('\\', "/");
    match load::read_input(path, load::MAX_SOURCE_BYTES) {
        Ok(text) => {
            let canonical = path.canonicalize().ok();
            load_with(&name, &text, canonical, overrides, &|p: &Path| {
                load::read_input(p, load::MAX_SOURCE_BYTES)
            })
        }
        Err(e) => {
            let reason = if e.kind() == std::io::ErrorKind::NotFound {
                "no such file".to_string()
            } else {
                e.to_string()
            };
            Loaded {
                sources: Sources::new(),
                scene: None,
                diagnostics: vec![Diagnostic::error(
                    diag::codes::IO,
                    format!("cannot read `{name}`: {reason}"),
                )],
            }
        }
    }
}

/// Lowers a text. `name` is used in messages; imports are resolved relative to its
/// directory.
pub fn load_str(name: &str, text: &str, overrides: &[Override]) -> Loaded {
    load_with(name, text, None, overrides, &|p: &Path| {
        load::read_input(p, load::MAX_SOURCE_BYTES)
    })
}

/// Lowers a text with a custom reader for imported files. `path` is the main file's
/// canonical path, if it has one (for import-cycle detection).
pub fn load_with(
    name: &str,
    text: &str,
    path: Option<PathBuf>,
    overrides: &[Override],
    reader: load::Reader<'_>,
) -> Loaded {
    let mut sources = Sources::new();
    let (files, mut diags, main) = {
        let mut loader = load::Loader::new(&mut sources, reader);
        let main = loader.load_root(name, path, text.to_string());
        (
            std::mem::take(&mut loader.files),
            std::mem::take(&mut loader.diags),
            main,
        )
    };
    // Overrides: each value is a small source of its own.
    let mut states = Vec::new();
    for o in overrides {
        let fid = sources.add(format!("--set {}", o.name), None, o.value.clone());
        let expr = match mbdc_dsl::parse_expr(&o.value) {
            Ok(e) => Some(e),
            Err(errs) => {
                for e in &errs {
                    let mut d = load::parse_diagnostic(e, fid);
                    // the value is not a file
                    d.message = d
                        .message
                        .replace("the end of the file", "the end of the value");
                    d.message = format!("`--set {}={}`: {}", o.name, o.value, d.message);
                    diags.push(d);
                }
                None
            }
        };
        if let Some(prev) = states.iter().position(|s: &OverrideState| s.name == o.name) {
            let pf = states[prev].file;
            diags.push(
                Diagnostic::error(
                    diag::codes::OVERRIDE,
                    format!("`--set {}` is given twice", o.name),
                )
                .primary(
                    fid,
                    mbdc_dsl::ast::Span::new(0, o.value.len()),
                    "second value",
                )
                .secondary(pf, mbdc_dsl::ast::Span::new(0, 0), "first value"),
            );
            continue;
        }
        states.push(OverrideState {
            name: o.name.clone(),
            expr,
            file: fid,
            span: mbdc_dsl::ast::Span::new(0, o.value.len()),
            used: false,
        });
    }
    let parse_failed = diags.iter().any(|d| d.code == diag::codes::SYNTAX);
    if parse_failed {
        sort(&mut diags);
        return Loaded {
            sources,
            scene: None,
            diagnostics: diags,
        };
    }
    let override_files: Vec<(FileId, String)> =
        states.iter().map(|s| (s.file, s.name.clone())).collect();
    let (sources, scene, mut lowered) = lower::lower(sources, &files, main, states);
    diags.append(&mut lowered);
    if let Some(s) = &scene {
        if !diags.iter().any(Diagnostic::is_error) {
            diags.extend(validate::validate(s, &sources));
        }
    }
    note_overrides(&mut diags, &sources, &override_files);
    sort(&mut diags);
    diags.dedup();
    let scene = if diags.iter().any(Diagnostic::is_error) {
        None
    } else {
        scene
    };
    Loaded {
        sources,
        scene,
        diagnostics: diags,
    }
}

/// When a model with overrides has errors in the model itself (none at an override), a note
/// per override saying it is in effect: `--set L=-1 m` can make the model's own lines fail
/// (a negative length, a non-integer loop bound), and those errors point at the model.
fn note_overrides(diags: &mut Vec<Diagnostic>, sources: &Sources, files: &[(FileId, String)]) {
    let at_override = |d: &Diagnostic| {
        d.labels
            .iter()
            .any(|l| files.iter().any(|(f, _)| *f == l.file))
    };
    if files.is_empty()
        || !diags.iter().any(Diagnostic::is_error)
        || diags.iter().any(|d| d.is_error() && at_override(d))
    {
        return;
    }
    for (file, name) in files {
        let value = sources.text(*file);
        diags.push(
            Diagnostic::note(
                diag::codes::OVERRIDE,
                format!("the errors above are with `--set {name}={}`", value.trim()),
            )
            .primary(*file, mbdc_dsl::ast::Span::new(0, value.len()), "in effect")
            .help(format!(
                "check the model without `--set {name}` to see whether it is the cause"
            )),
        );
    }
}

fn sort(d: &mut [Diagnostic]) {
    d.sort_by_key(|d| {
        d.main_label()
            .map(|l| (1, l.file, l.span.start))
            .unwrap_or((0, FileId(0), 0))
    });
}
