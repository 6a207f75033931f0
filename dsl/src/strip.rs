//! Comparing trees modulo layout: reset every span to [`Span::default`] and every
//! `blank_before` to `false`.

use crate::ast::*;

/// Sets every span in the file (items, blocks, names, expressions, units, comments) to
/// [`Span::default`] and forgets blank lines (`blank_before`), so that two parses of
/// differently laid-out text compare equal with `==` when they have the same structure, text of literals, and comments.
///
/// ```
/// let mut a = mbdc_dsl::parse("body b { mass 1 kg }").unwrap();
/// let mut b = mbdc_dsl::parse("body   b {\n  mass 1   kg\n}\n").unwrap();
/// mbdc_dsl::strip_spans(&mut a);
/// mbdc_dsl::strip_spans(&mut b);
/// assert_eq!(a, b);
/// ```
pub fn strip_spans(file: &mut File) {
    items(&mut file.items);
    comments(&mut file.trailing_comments);
}

/// Sets every span in the expression to [`Span::default`] (see [`strip_spans`]).
pub fn strip_expr_spans(expr: &mut Expr) {
    self::expr(expr);
}

fn comments(cs: &mut [Comment]) {
    for c in cs {
        c.span = Span::default();
        c.blank_before = false;
    }
}

fn ident(i: &mut Ident) {
    i.span = Span::default();
}

fn block(b: &mut Block) {
    b.span = Span::default();
    items(&mut b.items);
    comments(&mut b.trailing_comments);
}

fn items(its: &mut [Item]) {
    for it in its {
        it.span = Span::default();
        it.blank_before = false;
        comments(&mut it.comments);
        if let Some(c) = &mut it.trailing_comment {
            c.span = Span::default();
            c.blank_before = false;
        }
        match &mut it.kind {
            ItemKind::Import { path } => path.span = Span::default(),
            ItemKind::Param { name, value } | ItemKind::Const { name, value } => {
                ident(name);
                expr(value);
            }
            ItemKind::Component { name, params, body } => {
                ident(name);
                for p in params {
                    ident(&mut p.name);
                    if let Some(d) = &mut p.default {
                        expr(d);
                    }
                }
                block(body);
            }
            ItemKind::For {
                var,
                start,
                end,
                body,
            } => {
                ident(var);
                expr(start);
                expr(end);
                block(body);
            }
            ItemKind::If {
                cond,
                then,
                otherwise,
            } => {
                expr(cond);
                block(then);
                if let Some(o) = otherwise {
                    block(o);
                }
            }
            ItemKind::Decl {
                keyword,
                name,
                value,
                body,
            } => {
                ident(keyword);
                if let Some(n) = name {
                    n.span = Span::default();
                    ident(&mut n.base);
                    for i in &mut n.indices {
                        expr(i);
                    }
                }
                if let Some(v) = value {
                    expr(v);
                }
                if let Some(b) = body {
                    block(b);
                }
            }
            ItemKind::Prop {
                key,
                values,
                block: b,
            } => {
                ident(key);
                for v in values {
                    expr(v);
                }
                if let Some(b) = b {
                    block(b);
                }
            }
        }
    }
}

fn unit(u: &mut Unit) {
    u.span = Span::default();
    for (i, _) in &mut u.factors {
        ident(i);
    }
}

fn expr(e: &mut Expr) {
    e.span = Span::default();
    match &mut e.kind {
        ExprKind::Number { unit: u, .. } => {
            if let Some(u) = u {
                unit(u);
            }
        }
        ExprKind::WithUnit {
            expr: inner,
            unit: u,
        } => {
            expr(inner);
            unit(u);
        }
        ExprKind::Str(s) => s.span = Span::default(),
        ExprKind::Bool(_) => {}
        ExprKind::Ident(i) => ident(i),
        ExprKind::Index { base, index } => {
            expr(base);
            expr(index);
        }
        ExprKind::Member { base, member } => {
            expr(base);
            ident(member);
        }
        ExprKind::Call { func, args } => {
            ident(func);
            for a in args {
                if let Some(n) = &mut a.name {
                    ident(n);
                }
                expr(&mut a.value);
            }
        }
        ExprKind::Tuple(es) | ExprKind::List(es) => {
            for x in es {
                expr(x);
            }
        }
        ExprKind::Paren(inner) => expr(inner),
        ExprKind::Unary { expr: inner, .. } => expr(inner),
        ExprKind::Binary { lhs, rhs, .. } => {
            // a chain `a + b + …` is as deep as it is long: walk its left operands in a loop
            expr(rhs);
            let mut left: &mut Expr = lhs;
            loop {
                let cur = left;
                if !matches!(cur.kind, ExprKind::Binary { .. }) {
                    expr(cur);
                    break;
                }
                cur.span = Span::default();
                let ExprKind::Binary { lhs, rhs, .. } = &mut cur.kind else {
                    break;
                };
                expr(rhs);
                left = lhs;
            }
        }
    }
}
