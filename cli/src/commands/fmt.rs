//! `mbdc fmt FILE...`: rewrite files in the canonical layout of `mbdc_dsl::format`.

use std::path::PathBuf;
use std::process::ExitCode;

use mbdc_compiler::{Diagnostic, Sources};

use crate::render;

/// Arguments of `mbdc fmt`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The .mbd files.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Do not write; exit with an error and name the files that would change.
    #[arg(long)]
    pub check: bool,
}

/// Runs `mbdc fmt`.
pub fn run(args: Args) -> ExitCode {
    let mut failed = false;
    let mut unformatted = Vec::new();
    for path in &args.files {
        let text =
            match mbdc_compiler::load::read_input(path, mbdc_compiler::load::MAX_SOURCE_BYTES) {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("error: cannot read `{}`: {e}", path.display());
                    failed = true;
                    continue;
                }
            };
        let file = match mbdc_dsl::parse(&text) {
            Ok(f) => f,
            Err(errs) => {
                let mut sources = Sources::new();
                let id = sources.add(path.display().to_string(), Some(path.clone()), text.clone());
                let diags: Vec<Diagnostic> = errs
                    .iter()
                    .map(|e| mbdc_compiler::load::parse_diagnostic(e, id))
                    .collect();
                eprint!("{}", render::diagnostics(&diags, &sources));
                failed = true;
                continue;
            }
        };
        let formatted = mbdc_dsl::format(&file);
        if formatted == text {
            continue;
        }
        if args.check {
            println!("{}", path.display());
            unformatted.push(path.clone());
        } else if let Err(e) = std::fs::write(path, formatted) {
            eprintln!("error: cannot write `{}`: {e}", path.display());
            failed = true;
        }
    }
    if args.check && !unformatted.is_empty() {
        eprintln!(
            "{} file{} would be reformatted; run `mbdc fmt` to fix",
            unformatted.len(),
            if unformatted.len() == 1 { "" } else { "s" }
        );
        failed = true;
    }
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
