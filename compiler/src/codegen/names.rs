//! Identifier helpers shared by the emitter and the shape emitter: which names a generated
//! body uses, and parameter names that are `_`-prefixed when unused (so the generated code
//! is warning-free). Below both, so that neither has to know the other for them.

use std::collections::HashSet;

use proc_macro2::{Ident, TokenStream, TokenTree};
use quote::format_ident;

/// Every identifier in `ts` (at any depth).
pub(super) fn idents(ts: &TokenStream) -> HashSet<String> {
    fn walk(ts: &TokenStream, out: &mut HashSet<String>) {
        for t in ts.clone() {
            match t {
                TokenTree::Ident(i) => {
                    out.insert(i.to_string());
                }
                TokenTree::Group(g) => walk(&g.stream(), out),
                _ => {}
            }
        }
    }
    let mut out = HashSet::new();
    walk(ts, &mut out);
    out
}

/// A parameter named `name`, or `_name` if `used` (the body's identifiers) does not have it.
pub(super) fn param(name: &str, used: &HashSet<String>) -> Ident {
    if used.contains(name) {
        format_ident!("{}", name)
    } else {
        format_ident!("_{}", name)
    }
}
