//! Tree → canonical text (see [`format()`] for the layout rules).

use crate::ast::*;

/// The width in columns up to which a block of properties is printed on one line.
pub const MAX_WIDTH: usize = 100;

/// Formats a file in the canonical layout. The result parses back to the same tree modulo
/// spans, and formatting is idempotent.
///
/// # Layout rules
///
/// * Two spaces of indentation per block level; one item per line; `{` on the line of its
///   item, `}` on its own line; an empty block without comments is `{}`.
/// * A block is printed on one line, `{ a 1; b 2 }`, when all its items are properties
///   without a block of their own (a property's options block is laid out like any block), it
///   has no comments and no blank lines between its items, and the whole line fits in
///   [`MAX_WIDTH`] columns (the item's own trailing comment is not counted).
/// * Blank lines of the source are kept where they separate two items, comments or an item
///   and a comment, a run of them as one; none is printed at the start or end of a block or
///   file. At the top level of a file, a blank line also separates two items when either of
///   them has a block.
/// * Leading comments are printed on their own lines above their item, a trailing comment
///   after its item, separated by one space; comments are printed verbatim. (The parser
///   has already moved comments written inside an item's expressions above the item.)
/// * `else if` is printed as such when the `else` block holds nothing but one `if` item
///   without comments; otherwise as `else { ... }`. An `if` chain is printed on one line
///   only if all its blocks can be and the whole chain fits in [`MAX_WIDTH`]; otherwise
///   every block of the chain is printed on several lines.
/// * Expressions: binary operators are surrounded by single spaces except `^`, which is
///   written tight (`x^2`) unless its left side ends with a unit (`2 m ^ 2`, since `2 m^2`
///   would be read as the unit `m^2`). A unit follows its number or `)` after one space.
///   Commas are followed by one space, named arguments are written `name: value`.
/// * Parentheses: [`ExprKind::Paren`] nodes are printed as written; beyond those, the
///   printer adds the fewest parentheses that make the text parse back to the same tree
///   (they are needed only for trees built by hand, which then parse back with extra
///   `Paren` nodes). Number literals keep their text (`1e-6` stays `1e-6`); units keep
///   their text.
/// * Long lines are not wrapped.
/// * For trees built by hand: a number whose `text` is not a literal is printed from its
///   value, a unit with empty `text` from its factors (`kg*s^-2`).
///
/// ```
/// let file = mbdc_dsl::parse("model m{body b{mass 1kg}\n}").unwrap();
/// assert_eq!(mbdc_dsl::format(&file), "model m {\n  body b { mass 1 kg }\n}\n");
/// ```
pub fn format(file: &File) -> String {
    let mut f = Fmt { out: String::new() };
    f.items(&file.items, &file.trailing_comments, 0, true);
    f.out
}

/// Formats one expression on one line, as [`format()`] would inside an item.
///
/// ```
/// let e = mbdc_dsl::parse_expr("-x ^2*( a+b )").unwrap();
/// assert_eq!(mbdc_dsl::format_expr(&e), "-x^2 * (a + b)");
/// ```
pub fn format_expr(expr: &Expr) -> String {
    let mut out = String::new();
    write_expr(&mut out, expr, 0);
    out
}

struct Fmt {
    out: String,
}

fn has_block(item: &Item) -> bool {
    match &item.kind {
        ItemKind::Component { .. } | ItemKind::For { .. } | ItemKind::If { .. } => true,
        ItemKind::Decl { body, .. } => body.is_some(),
        ItemKind::Prop { block, .. } => block.is_some(),
        _ => false,
    }
}

impl Fmt {
    fn indent(&mut self, level: usize) {
        for _ in 0..level {
            self.out.push_str("  ");
        }
    }

    /// The current column (characters since the last newline).
    fn col(&self) -> usize {
        let line_start = self.out.rfind('\n').map_or(0, |p| p + 1);
        self.out[line_start..].chars().count()
    }

    /// Prints the items of a block (or of the file, `top`) and then its trailing comments.
    /// A blank line of the source before an item or comment is kept (one for a run), except
    /// at the start of the block; at the top level a blank line also separates two items
    /// when either has a block.
    fn items(&mut self, items: &[Item], trailing: &[Comment], level: usize, top: bool) {
        let mut first = true;
        for (i, item) in items.iter().enumerate() {
            let mut blank = top && i > 0 && (has_block(item) || has_block(&items[i - 1]));
            for c in &item.comments {
                self.blank_line(first, blank || c.blank_before);
                blank = false;
                first = false;
                self.indent(level);
                self.out.push_str(&c.text);
                self.out.push('\n');
            }
            self.blank_line(first, blank || item.blank_before);
            first = false;
            self.indent(level);
            self.item(item, level);
            if let Some(c) = &item.trailing_comment {
                self.out.push(' ');
                self.out.push_str(&c.text);
            }
            self.out.push('\n');
        }
        for c in trailing {
            self.blank_line(first, c.blank_before);
            first = false;
            self.indent(level);
            self.out.push_str(&c.text);
            self.out.push('\n');
        }
    }

    /// A blank line when `wanted`, unless nothing of the block has been printed yet.
    fn blank_line(&mut self, first: bool, wanted: bool) {
        if wanted && !first {
            self.out.push('\n');
        }
    }

    fn item(&mut self, item: &Item, level: usize) {
        match &item.kind {
            ItemKind::Import { path } => {
                self.out.push_str("import ");
                write_str(&mut self.out, &path.value);
            }
            ItemKind::Param { name, value } | ItemKind::Const { name, value } => {
                self.out
                    .push_str(if matches!(item.kind, ItemKind::Param { .. }) {
                        "param "
                    } else {
                        "const "
                    });
                self.out.push_str(&name.name);
                self.out.push_str(" = ");
                write_expr(&mut self.out, value, 0);
            }
            ItemKind::Component { name, params, body } => {
                self.out.push_str("component ");
                self.out.push_str(&name.name);
                self.out.push('(');
                for (i, p) in params.iter().enumerate() {
                    if i > 0 {
                        self.out.push_str(", ");
                    }
                    self.out.push_str(&p.name.name);
                    if let Some(d) = &p.default {
                        self.out.push_str(" = ");
                        write_expr(&mut self.out, d, 0);
                    }
                }
                self.out.push_str(") ");
                self.block(body, level);
            }
            ItemKind::For {
                var,
                start,
                end,
                body,
            } => {
                self.out.push_str("for ");
                self.out.push_str(&var.name);
                self.out.push_str(" in ");
                write_expr(&mut self.out, start, 0);
                self.out.push_str("..");
                write_expr(&mut self.out, end, 0);
                self.out.push(' ');
                self.block(body, level);
            }
            ItemKind::If { .. } => {
                // A chain is printed on one line only if all its blocks fit on it;
                // otherwise every block of the chain is printed on several lines.
                // (The one-line attempt is only made when every block is a one-line block of
                // properties, so it is cheap: nested chains are never laid out twice.)
                if chain_may_be_inline(item) {
                    let start = self.out.len();
                    let col = self.col();
                    self.if_chain(item, level, true);
                    let line = &self.out[start..];
                    if !line.contains('\n') && col + line.chars().count() <= MAX_WIDTH {
                        return;
                    }
                    self.out.truncate(start);
                }
                self.if_chain(item, level, false);
            }
            ItemKind::Decl {
                keyword,
                name,
                value,
                body,
            } => {
                self.out.push_str(&keyword.name);
                if let Some(n) = name {
                    self.out.push(' ');
                    write_name(&mut self.out, n);
                }
                if let Some(v) = value {
                    self.out.push_str(" = ");
                    write_expr(&mut self.out, v, 0);
                }
                if let Some(b) = body {
                    self.out.push(' ');
                    self.block(b, level);
                }
            }
            ItemKind::Prop { block, .. } => {
                write_prop(&mut self.out, item);
                if let Some(b) = block {
                    self.out.push(' ');
                    self.block(b, level);
                }
            }
        }
    }

    /// `if ... { } else if ... { } else { }`; with `inline` false, no block of the chain is
    /// put on one line.
    fn if_chain(&mut self, item: &Item, level: usize, inline: bool) {
        let mut item = item;
        loop {
            let ItemKind::If {
                cond,
                then,
                otherwise,
            } = &item.kind
            else {
                return;
            };
            self.out.push_str("if ");
            write_expr(&mut self.out, cond, 0);
            self.out.push(' ');
            self.block_with(then, level, inline);
            let Some(other) = otherwise else { return };
            self.out.push_str(" else ");
            match else_if(other) {
                Some(nested) => item = nested,
                None => {
                    self.block_with(other, level, inline);
                    return;
                }
            }
        }
    }

    fn block(&mut self, block: &Block, level: usize) {
        self.block_with(block, level, true);
    }

    fn block_with(&mut self, block: &Block, level: usize, inline: bool) {
        if block.items.is_empty() && block.trailing_comments.is_empty() {
            self.out.push_str("{}");
            return;
        }
        if let Some(line) = inline_block(block).filter(|_| inline) {
            if self.col() + line.chars().count() <= MAX_WIDTH {
                self.out.push_str(&line);
                return;
            }
        }
        self.out.push_str("{\n");
        self.items(&block.items, &block.trailing_comments, level + 1, false);
        self.indent(level);
        self.out.push('}');
    }
}

/// True if every block of the `if` chain starting at `item` is empty or may be printed on
/// one line.
fn chain_may_be_inline(item: &Item) -> bool {
    let mut item = item;
    loop {
        let ItemKind::If {
            then, otherwise, ..
        } = &item.kind
        else {
            return false;
        };
        let ok = |b: &Block| {
            b.items.is_empty() && b.trailing_comments.is_empty() || inline_block(b).is_some()
        };
        if !ok(then) {
            return false;
        }
        match otherwise {
            None => return true,
            Some(other) => match else_if(other) {
                Some(nested) => item = nested,
                None => return ok(other),
            },
        }
    }
}

/// The nested `if` of an `else` block that can be printed as `else if`.
fn else_if(block: &Block) -> Option<&Item> {
    match block.items.as_slice() {
        [item]
            if block.trailing_comments.is_empty()
                && item.comments.is_empty()
                && item.trailing_comment.is_none()
                && matches!(item.kind, ItemKind::If { .. }) =>
        {
            Some(item)
        }
        _ => None,
    }
}

/// `{ a 1; b 2 }` if the block may be printed on one line (all items are properties, no
/// comments), ignoring the width of what precedes it.
fn inline_block(block: &Block) -> Option<String> {
    if block.items.is_empty() || !block.trailing_comments.is_empty() {
        return None;
    }
    let mut s = String::from("{ ");
    for (i, item) in block.items.iter().enumerate() {
        if !item.comments.is_empty() || item.trailing_comment.is_some() {
            return None;
        }
        if i > 0 && item.blank_before {
            // the author grouped the properties: keep the lines
            return None;
        }
        if !matches!(item.kind, ItemKind::Prop { block: None, .. }) {
            return None;
        }
        if i > 0 {
            s.push_str("; ");
        }
        write_prop(&mut s, item);
        if s.len() > 4 * MAX_WIDTH {
            return None;
        }
    }
    s.push_str(" }");
    Some(s)
}

fn write_prop(out: &mut String, item: &Item) {
    if let ItemKind::Prop { key, values, .. } = &item.kind {
        out.push_str(&key.name);
        for (i, v) in values.iter().enumerate() {
            out.push_str(if i == 0 { " " } else { ", " });
            write_expr(out, v, 0);
        }
    }
}

fn write_name(out: &mut String, name: &Name) {
    out.push_str(&name.base.name);
    for i in &name.indices {
        out.push('[');
        write_expr(out, i, 0);
        out.push(']');
    }
}

fn write_str(out: &mut String, value: &str) {
    out.push('"');
    for c in value.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            c => out.push(c),
        }
    }
    out.push('"');
}

/// Binding power: how tightly an expression holds together (higher is tighter). Atoms and
/// postfix forms are 10.
fn prec(e: &Expr) -> u8 {
    match &e.kind {
        ExprKind::Binary { op, .. } => match op {
            BinOp::At => 1,
            BinOp::Or => 2,
            BinOp::And => 3,
            BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => 5,
            BinOp::Add | BinOp::Sub => 6,
            BinOp::Mul | BinOp::Div | BinOp::Rem => 7,
            BinOp::Pow => 9,
        },
        ExprKind::Unary { op: UnOp::Not, .. } => 4,
        ExprKind::Unary { op: UnOp::Neg, .. } => 8,
        _ => 10,
    }
}

/// True if the printed expression ends with a unit.
fn ends_with_unit(e: &Expr) -> bool {
    matches!(
        e.kind,
        ExprKind::Number { unit: Some(_), .. } | ExprKind::WithUnit { .. }
    )
}

/// Writes `e`, in parentheses if it binds looser than `min`.
fn write_expr(out: &mut String, e: &Expr, min: u8) {
    if prec(e) < min {
        out.push('(');
        write_expr(out, e, 0);
        out.push(')');
        return;
    }
    match &e.kind {
        ExprKind::Number { value, text, unit } => {
            if is_number_literal(text) {
                out.push_str(text);
            } else {
                out.push_str(&format!("{value:?}"));
            }
            if let Some(u) = unit {
                out.push(' ');
                write_unit(out, u);
            }
        }
        ExprKind::WithUnit { expr, unit } => {
            if matches!(
                expr.kind,
                ExprKind::Call { .. } | ExprKind::Paren(_) | ExprKind::Tuple(_)
            ) {
                write_expr(out, expr, 0);
            } else {
                out.push('(');
                write_expr(out, expr, 0);
                out.push(')');
            }
            out.push(' ');
            write_unit(out, unit);
        }
        ExprKind::Str(s) => write_str(out, &s.value),
        ExprKind::Bool(b) => out.push_str(if *b { "true" } else { "false" }),
        ExprKind::Ident(i) => out.push_str(&i.name),
        ExprKind::Index { base, index } => {
            write_postfix_base(out, base);
            out.push('[');
            write_expr(out, index, 0);
            out.push(']');
        }
        ExprKind::Member { base, member } => {
            write_postfix_base(out, base);
            out.push('.');
            out.push_str(&member.name);
        }
        ExprKind::Call { func, args } => {
            out.push_str(&func.name);
            out.push('(');
            for (i, a) in args.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                if let Some(n) = &a.name {
                    out.push_str(&n.name);
                    out.push_str(": ");
                }
                write_expr(out, &a.value, 0);
            }
            out.push(')');
        }
        ExprKind::Tuple(es) => write_seq(out, es, '(', ')'),
        ExprKind::List(es) => write_seq(out, es, '[', ']'),
        ExprKind::Paren(inner) => {
            out.push('(');
            write_expr(out, inner, 0);
            out.push(')');
        }
        ExprKind::Unary { op, expr } => match op {
            UnOp::Neg => {
                out.push('-');
                write_expr(out, expr, 8);
            }
            UnOp::Not => {
                out.push_str("not ");
                write_expr(out, expr, 4);
            }
        },
        ExprKind::Binary { op, lhs, rhs } => {
            let (lmin, rmin) = operand_mins(*op);
            if *op == BinOp::Pow {
                // Postfix level on the left; only some atoms may carry postfix operators,
                // but all atoms may stand left of `^`.
                write_expr(out, lhs, lmin);
                out.push_str(if ends_with_unit(lhs) { " ^ " } else { "^" });
                write_expr(out, rhs, rmin);
            } else {
                // A chain `a + b - c …` is a left-deep tree as long as the chain: walk its
                // left operands in a loop (the parser bounds only the right ones' depth).
                let mut spine = vec![(*op, &**rhs)];
                let mut left = &**lhs;
                let mut min = lmin;
                while let ExprKind::Binary {
                    op: o,
                    lhs: l,
                    rhs: r,
                } = &left.kind
                {
                    if *o == BinOp::Pow || prec(left) < min {
                        break;
                    }
                    spine.push((*o, &**r));
                    min = operand_mins(*o).0;
                    left = l;
                }
                write_expr(out, left, min);
                for (o, r) in spine.into_iter().rev() {
                    out.push(' ');
                    out.push_str(o.as_str());
                    out.push(' ');
                    write_expr(out, r, operand_mins(o).1);
                }
            }
        }
    }
}

/// The binding power each operand of `op` needs to be printed without parentheses.
fn operand_mins(op: BinOp) -> (u8, u8) {
    match op {
        BinOp::At => (2, 2),
        BinOp::Or => (2, 3),
        BinOp::And => (3, 4),
        BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => (6, 6),
        BinOp::Add | BinOp::Sub => (6, 7),
        BinOp::Mul | BinOp::Div | BinOp::Rem => (7, 8),
        BinOp::Pow => (10, 8),
    }
}

/// The base of an index or member access: a name, call, parenthesized expression, tuple,
/// list, or another index or member access; anything else gets parentheses.
fn write_postfix_base(out: &mut String, base: &Expr) {
    match base.kind {
        ExprKind::Ident(_)
        | ExprKind::Call { .. }
        | ExprKind::Paren(_)
        | ExprKind::Tuple(_)
        | ExprKind::List(_)
        | ExprKind::Index { .. }
        | ExprKind::Member { .. } => write_expr(out, base, 0),
        _ => {
            out.push('(');
            write_expr(out, base, 0);
            out.push(')');
        }
    }
}

fn write_seq(out: &mut String, es: &[Expr], open: char, close: char) {
    out.push(open);
    for (i, e) in es.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        write_expr(out, e, 0);
    }
    out.push(close);
}

fn write_unit(out: &mut String, unit: &Unit) {
    if !unit.text.is_empty() {
        out.push_str(&unit.text);
        return;
    }
    // A unit built by hand without text: spell out the factors.
    for (i, (name, exp)) in unit.factors.iter().enumerate() {
        if i > 0 {
            out.push('*');
        }
        out.push_str(&name.name);
        if *exp != 1 {
            out.push('^');
            out.push_str(&exp.to_string());
        }
    }
}

/// True if `text` is a number literal as the grammar reads it (`12`, `2.5`, `1e-6`).
fn is_number_literal(text: &str) -> bool {
    let b = text.as_bytes();
    let mut i = 0;
    let digits = |i: &mut usize| {
        let s = *i;
        while *i < b.len() && b[*i].is_ascii_digit() {
            *i += 1;
        }
        *i > s
    };
    if !digits(&mut i) {
        return false;
    }
    if i < b.len() && b[i] == b'.' {
        i += 1;
        if !digits(&mut i) {
            return false;
        }
    }
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        i += 1;
        if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
            i += 1;
        }
        if !digits(&mut i) {
            return false;
        }
    }
    i == b.len()
}
