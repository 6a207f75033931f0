//! # mbdc-dsl: the `.mbd` language, as text
//!
//! **What it is.** The grammar of `.mbd` files (a pest grammar), the syntax tree with byte
//! spans ([`ast`]), parse diagnostics ([`ParseError`]), and the formatter that prints a tree
//! back as text.
//!
//! **What it must never know.** Physics. The parser knows the *shape* of declarations
//! (`KEYWORD NAME = VALUE { ... }`), properties (`KEY values`), expressions, units as written
//! and a few structural forms (`import`, `param`, `const`, `component`, `for`, `if`); it does
//! not know what a body or a joint is, which units exist, or which properties a body takes.
//! That is `mbdc-compiler`'s job. It never depends on `mbdc-runtime`.
//!
//! **API boundary.** [`parse`] (text → [`ast::File`] or [`ParseError`]s), [`format()`]
//! ([`ast::File`] → canonical text), [`parse_expr`] (for command-line overrides),
//! [`format_expr`] (one expression → text, for messages), [`strip_spans`] /
//! [`strip_expr_spans`] (compare trees modulo layout). Nothing here does I/O.
//!
//! ## Lexical decisions the grammar makes
//!
//! * Items end at a newline or `;`. Newlines inside `( )` and `[ ]`, after a line that ends
//!   with a binary operator (`+ - * / % ^ == != < <= > >= @ and or`) or a comma, and before
//!   `else` do not end an item.
//! * A unit is one word without spaces, written after a number (spaces allowed, a line break
//!   not) or after the `)` of a call, a tuple or a parenthesized expression: `9.81 m/s^2`,
//!   `2m`, `(0, 0, 1) m/s`, `diag(1, 2, 3) kg*m^2`, `10 1/s`. A space ends the unit, so
//!   `1 m * L` is `(1 m) * L`. `20/s` is a division by the name `s`, not a unit.
//! * Reserved words: `import param const component for in if else and or not true false`
//!   (`model` and `instance` are ordinary declaration keywords). `in` may still be used as a
//!   unit (inch).
//! * No space is allowed between a name and the `(` of a call, the `[` of an index, or the
//!   `.` of a member access: `sin(x)`, `link[i]`, `arm.upper`. (`position (0, 0, 1)` is a
//!   property with a tuple value.)
//! * A block may follow a property's values only when it has two or more
//!   (`glue right, fine.left { traction bessel(points: 8) }`): `KEY NAME { ... }` is a
//!   declaration, and after one value a `{` is reported as a misplaced block.
//! * Comments directly above an item, or inside its header, become its
//!   [`ast::Item::comments`]; a comment on the same line after it is its
//!   [`ast::Item::trailing_comment`]; comments after the last item of a block or file trail
//!   the block or file. Comments inside expressions move above their item.
//!
//! ## Limits
//!
//! Inputs longer than [`MAX_INPUT_LEN`] bytes are refused, and so is nesting deeper than
//! [`MAX_NESTING`] (brackets, blocks, or the height of an expression tree) and an expression
//! of more than [`MAX_OPERATORS`] binary operators, so that no input can overflow the stack
//! of the parser, the formatter or a consumer walking the tree. A chain of binary operators
//! written without brackets (`a + b + c + …`, a left-deep tree) counts as one level of
//! nesting however long it is: a consumer must walk the left operands of such a chain in a
//! loop, recursing only into the right ones (as the formatter and the compiler's evaluator
//! do); `^` is right-associative and counts per operator.

#![warn(missing_docs)]

pub mod ast;
mod error;
mod format;
mod lexer;
mod offsets;
mod parser;
mod strip;

pub use error::ParseError;
pub use format::{format, format_expr, MAX_WIDTH};
pub use strip::{strip_expr_spans, strip_spans};

/// The largest accepted input, in bytes (16 MiB).
pub const MAX_INPUT_LEN: usize = 16 << 20;

/// The deepest accepted nesting: of brackets in the text, and the height of any block or
/// expression tree built from it, where a chain of binary operators written without
/// brackets (`a + b + c + …`) counts as one level (consumers walk it in a loop).
pub const MAX_NESTING: usize = 256;

/// The most binary operators in one expression (with the expressions nested in it): a
/// chain's length, bounded so that the tree's true height (which the derived `Clone`,
/// `PartialEq` and `Drop` recurse to) stays small.
pub const MAX_OPERATORS: usize = 1024;

/// Parses a `.mbd` file.
///
/// On failure returns every syntax error that could be found cheaply (at least one, at most
/// ten, sorted by position): after an error the parser skips the offending item and goes on.
///
/// ```
/// let file = mbdc_dsl::parse("model m {\n  gravity (0, 0, -9.81) m/s^2\n}\n").unwrap();
/// assert_eq!(file.items.len(), 1);
/// ```
pub fn parse(src: &str) -> Result<ast::File, Vec<ParseError>> {
    parser::parse_file(src)
}

/// Parses one expression, e.g. a command-line override such as `2m` or `(0, 0, 1) m/s`.
/// Newlines are whitespace; comments are allowed and dropped.
///
/// ```
/// let e = mbdc_dsl::parse_expr("(0, 0, 1) m/s").unwrap();
/// assert!(matches!(e.kind, mbdc_dsl::ast::ExprKind::WithUnit { .. }));
/// ```
pub fn parse_expr(src: &str) -> Result<ast::Expr, Vec<ParseError>> {
    parser::parse_expression(src)
}
