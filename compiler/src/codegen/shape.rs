//! Time-function shapes as Rust expressions on `Jet2`, with the operations of
//! `mbdc_runtime::fn1::eval` in the same order (so the values are bit-identical).

use mbdc_runtime::compiled::FnShape;
use mbdc_runtime::scene::UnaryFn;
use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use super::lit_usize;

/// How an expression binds, for parenthesizing it only where Rust needs it (so that the
/// generated code has no `unused_parens`).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Binds {
    /// A call, method call or path: never needs parentheses.
    Atom,
    /// A negation or a binary operation.
    Op,
}

/// The expression of a shape over `x` (the variable), `c` (its constants) and `tb` (its
/// tables), in a position that needs no parentheses (a function body or argument).
pub fn expr(s: &FnShape) -> TokenStream {
    expr_binds(s).0
}

/// `s` as the operand of an operator or the receiver of a method call: parenthesized
/// unless it is an atom. Operands that are operations keep their parentheses even where
/// precedence would allow dropping them: the tree is evaluated exactly as written, in the
/// order of `mbdc_runtime::fn1::eval`.
fn operand(s: &FnShape) -> TokenStream {
    match expr_binds(s) {
        (e, Binds::Atom) => e,
        (e, Binds::Op) => quote!((#e)),
    }
}

fn expr_binds(s: &FnShape) -> (TokenStream, Binds) {
    let k = |i: &usize| lit_usize(*i);
    let atom = |t: TokenStream| (t, Binds::Atom);
    match s {
        FnShape::Const(i) => {
            let i = k(i);
            atom(quote!(Jet2::constant(c[#i])))
        }
        FnShape::Var => atom(quote!(Jet2::var(x))),
        FnShape::Add(a, b) => bin(a, b, quote!(+)),
        FnShape::Sub(a, b) => bin(a, b, quote!(-)),
        FnShape::Mul(a, b) => bin(a, b, quote!(*)),
        FnShape::Div(a, b) => bin(a, b, quote!(/)),
        FnShape::Neg(a) => {
            let a = operand(a);
            (quote!(-#a), Binds::Op)
        }
        FnShape::Powf(a, i) => {
            let (a, i) = (operand(a), k(i));
            atom(quote!(#a.powf(c[#i])))
        }
        FnShape::Unary(u, a) => {
            let a = operand(a);
            let m = format_ident!("{}", unary_method(*u));
            atom(quote!(#a.#m()))
        }
        FnShape::Min(a, b) => {
            let (a, b) = (operand(a), expr(b));
            atom(quote!(#a.min(#b)))
        }
        FnShape::Max(a, b) => {
            let (a, b) = (operand(a), expr(b));
            atom(quote!(#a.max(#b)))
        }
        FnShape::Smoothstep(a, i) => {
            let a = operand(a);
            let (i0, i1) = (k(i), lit_usize(i + 1));
            atom(quote!(#a.smoothstep(c[#i0], c[#i1])))
        }
        FnShape::Table(a, i) => {
            let (a, i) = (operand(a), k(i));
            atom(quote!(#a.table(&tb[#i])))
        }
        FnShape::JacobiSn(a, i) => {
            let (a, i) = (operand(a), k(i));
            atom(quote!(#a.jacobi_sn(c[#i])))
        }
        FnShape::JacobiCn(a, i) => {
            let (a, i) = (operand(a), k(i));
            atom(quote!(#a.jacobi_cn(c[#i])))
        }
        FnShape::JacobiDn(a, i) => {
            let (a, i) = (operand(a), k(i));
            atom(quote!(#a.jacobi_dn(c[#i])))
        }
    }
}

fn bin(a: &FnShape, b: &FnShape, op: TokenStream) -> (TokenStream, Binds) {
    let (a, b) = (operand(a), operand(b));
    (quote!(#a #op #b), Binds::Op)
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

/// The function item `f<i>` of shape `i`. A parameter the shape does not read (`x` of a
/// constant, `c` of the variable, `tb` of a shape without tables) is named with a leading
/// `_`, so that the generated code has no unused variables.
pub fn item(i: usize, s: &FnShape) -> TokenStream {
    let name = format_ident!("f{}", i);
    let body = expr(s);
    let used = super::names::idents(&body);
    let [x, c, tb] = ["x", "c", "tb"].map(|p| super::names::param(p, &used));
    let doc = format!(" Time function shape {i}: `c` its constants, `tb` its tables.");
    quote! {
        #[doc = #doc]
        #[inline]
        fn #name(#x: f64, #c: &[f64], #tb: &[Vec<[f64; 2]>]) -> Jet2 {
            #body
        }
    }
}
