//! Time-function shapes as Rust expressions on `Jet2`, with the operations of
//! `mbdc_runtime::fn1::eval` in the same order (so the values are bit-identical).

use mbdc_runtime::compiled::FnShape;
use mbdc_runtime::scene::UnaryFn;
use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use super::lit_usize;

/// The expression of a shape over `x` (the variable), `c` (its constants) and `tb` (its
/// tables).
pub fn expr(s: &FnShape) -> TokenStream {
    let k = |i: &usize| lit_usize(*i);
    match s {
        FnShape::Const(i) => {
            let i = k(i);
            quote!(Jet2::constant(c[#i]))
        }
        FnShape::Var => quote!(Jet2::var(x)),
        FnShape::Add(a, b) => bin(a, b, quote!(+)),
        FnShape::Sub(a, b) => bin(a, b, quote!(-)),
        FnShape::Mul(a, b) => bin(a, b, quote!(*)),
        FnShape::Div(a, b) => bin(a, b, quote!(/)),
        FnShape::Neg(a) => {
            let a = expr(a);
            quote!((-#a))
        }
        FnShape::Powf(a, i) => {
            let (a, i) = (expr(a), k(i));
            quote!(#a.powf(c[#i]))
        }
        FnShape::Unary(u, a) => {
            let a = expr(a);
            let m = format_ident!("{}", unary_method(*u));
            quote!(#a.#m())
        }
        FnShape::Min(a, b) => {
            let (a, b) = (expr(a), expr(b));
            quote!(#a.min(#b))
        }
        FnShape::Max(a, b) => {
            let (a, b) = (expr(a), expr(b));
            quote!(#a.max(#b))
        }
        FnShape::Smoothstep(a, i) => {
            let a = expr(a);
            let (i0, i1) = (k(i), lit_usize(i + 1));
            quote!(#a.smoothstep(c[#i0], c[#i1]))
        }
        FnShape::Table(a, i) => {
            let (a, i) = (expr(a), k(i));
            quote!(#a.table(&tb[#i]))
        }
        FnShape::JacobiSn(a, i) => {
            let (a, i) = (expr(a), k(i));
            quote!(#a.jacobi_sn(c[#i]))
        }
        FnShape::JacobiCn(a, i) => {
            let (a, i) = (expr(a), k(i));
            quote!(#a.jacobi_cn(c[#i]))
        }
        FnShape::JacobiDn(a, i) => {
            let (a, i) = (expr(a), k(i));
            quote!(#a.jacobi_dn(c[#i]))
        }
    }
}

fn bin(a: &FnShape, b: &FnShape, op: TokenStream) -> TokenStream {
    let (a, b) = (expr(a), expr(b));
    quote!((#a #op #b))
}

/// The `Jet2` method of a unary function (as `mbdc_runtime::fn1::unary`).
pub fn unary_method(u: UnaryFn) -> &'static str {
    match u {
        UnaryFn::Sin => "sin",
        UnaryFn::Cos => "cos",
        UnaryFn::Tan => "tan",
        UnaryFn::Asin => "asin",
        UnaryFn::Acos => "acos",
        UnaryFn::Atan => "atan",
        UnaryFn::Sqrt => "sqrt",
        UnaryFn::Exp => "exp",
        UnaryFn::Ln => "ln",
        UnaryFn::Abs => "abs",
        UnaryFn::Step => "step",
        UnaryFn::Ramp => "ramp",
        UnaryFn::Tanh => "tanh",
    }
}

/// The function item `f<i>` of shape `i`.
pub fn item(i: usize, s: &FnShape) -> TokenStream {
    let name = format_ident!("f{}", i);
    let body = expr(s);
    let doc = format!(" Time function shape {i}: `c` its constants, `tb` its tables.");
    quote! {
        #[doc = #doc]
        #[inline]
        fn #name(x: f64, c: &[f64], tb: &[Vec<[f64; 2]>]) -> Jet2 {
            #body
        }
    }
}
