//! # mbdc-dsl: the `.mbd` language, as text
//!
//! **What it is.** The grammar of `.mbd` files (a pest grammar), the syntax tree with byte
//! spans ([`ast`]), parse diagnostics, and the formatter that prints a tree back as text.
//!
//! **What it must never know.** Physics. The parser knows the *shape* of declarations
//! (`KEYWORD NAME = VALUE { ... }`), properties (`KEY values`), expressions, units as written
//! and a few structural forms (`import`, `param`, `const`, `component`, `for`, `if`); it does
//! not know what a body or a joint is, which units exist, or which properties a body takes.
//! That is `mbdc-compiler`'s job. It never depends on `mbdc-runtime`.
//!
//! **API boundary.** [`parse`] (text → [`ast::File`] or [`ParseError`]s), [`format`]
//! ([`ast::File`] → canonical text), [`parse_expr`] (for command-line overrides),
//! [`strip_spans`] (compare trees modulo layout). Nothing here does I/O.

pub mod ast;
