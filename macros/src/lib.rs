//! # mbdc-macros: embed an mbdc scene in Rust
//!
//! A shim: parses the macro input, calls `mbdc-compiler`, and turns diagnostics into
//! `compile_error!` at the right span. All the work is in `mbdc-compiler`.
