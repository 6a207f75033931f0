//! What emitted code uses: the identifiers of a token stream, and parameter names that
//! follow from them (`_name` for a parameter the body does not read). The emitter and the
//! time-function shapes both decide from these, so generated code carries no unused item.

use std::collections::HashSet;

use proc_macro2::{Ident, TokenStream, TokenTree};
use quote::format_ident;

/// Every identifier in `ts` (at any depth).
pub(crate) fn idents(ts: &TokenStream) -> HashSet<String> {
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
pub(crate) fn param(name: &str, used: &HashSet<String>) -> Ident {
    if used.contains(name) {
        format_ident!("{}", name)
    } else {
        format_ident!("_{}", name)
    }
}
