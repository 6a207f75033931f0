//! # mbdc-macros: embed an mbdc scene in Rust
//!
//! A shim: parses the macro input, calls `mbdc-compiler`, and turns diagnostics into
//! `compile_error!` at the right span. All the work is in `mbdc-compiler`
//! ([`mbdc_compiler::tokens`]).
//!
//! - `model! { model pendulum { … } }` — the model written inline. Errors point at the tokens
//!   they concern.
//! - `include_model!("models/pendulum.mbd")` — a model file, relative to the crate's
//!   `CARGO_MANIFEST_DIR`; cargo rebuilds when it or one of its imports changes. Errors show
//!   the rendered diagnostics.
//!
//! Both expand to `pub mod <scene name> { pub struct Model; … }` (see
//! [`mbdc_compiler::codegen`]): `Model::new()` is a `mbdc_runtime::system::System`. The
//! crate using them needs `mbdc-runtime` as a dependency.

use proc_macro::TokenStream;

/// A model written inline: `model! { model name { … } }`.
#[proc_macro]
pub fn model(input: TokenStream) -> TokenStream {
    mbdc_compiler::tokens::model_macro(input.into()).into()
}

/// A model file, relative to `CARGO_MANIFEST_DIR`: `include_model!("models/x.mbd")`.
#[proc_macro]
pub fn include_model(input: TokenStream) -> TokenStream {
    mbdc_compiler::tokens::include_model_macro(input.into()).into()
}
