//! # mbdc-compiler: from `.mbd` syntax to a validated `Scene`, and from a `Scene` to Rust
//!
//! **What it is.** Lowering of the syntax tree (`mbdc-dsl`) to a [`mbdc_runtime::scene::Scene`]:
//! imports, name resolution, parameters, components and loops expanded, units checked and
//! converted to SI, physics validated; diagnostics with source spans. Code generation from a
//! `Scene` to specialized Rust (quote + prettyplease), and the `build.rs` API.
//!
//! **What it must never know.** How to integrate: no time stepping, no solvers. It produces
//! data (`Scene`) and source text; the runtime does the numerics. It has no command-line
//! concerns (argument parsing, terminals, progress bars) either: those live in `mbdc` (cli).
//!
//! **API boundary.** `load`/`lower` (file or text → `Scene` + diagnostics), `Diagnostic`,
//! `codegen` (Scene → Rust source), `build` (for build scripts).
