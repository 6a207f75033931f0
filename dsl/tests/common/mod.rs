//! Helpers shared by the integration tests.
#![allow(dead_code)]

use mbdc_dsl::ast::*;

/// Parses, panicking with rendered errors on failure.
pub fn parse_ok(src: &str) -> File {
    match mbdc_dsl::parse(src) {
        Ok(f) => f,
        Err(errors) => {
            let rendered: Vec<String> = errors.iter().map(|e| e.render(src)).collect();
            panic!("parse failed:\n{}\nsource:\n{src}", rendered.join("\n"));
        }
    }
}

/// The tree with all spans reset.
pub fn stripped(mut f: File) -> File {
    mbdc_dsl::strip_spans(&mut f);
    f
}

/// Checks the formatter's two promises on a parsed file: the output parses back to the same
/// tree modulo spans, and formatting the output again changes nothing.
pub fn check_format_roundtrip(src: &str, file: &File) {
    let out = mbdc_dsl::format(file);
    let reparsed = match mbdc_dsl::parse(&out) {
        Ok(f) => f,
        Err(errors) => {
            let rendered: Vec<String> = errors.iter().map(|e| e.render(&out)).collect();
            panic!(
                "formatted output does not parse:\n{}\n--- output:\n{out}\n--- input:\n{src}",
                rendered.join("\n")
            );
        }
    };
    let again = mbdc_dsl::format(&reparsed);
    assert_eq!(out, again, "format is not idempotent\n--- input:\n{src}");
    let a = stripped(file.clone());
    let b = stripped(reparsed);
    assert!(a == b, "parse(format(x)) != x modulo spans\n--- input:\n{src}\n--- output:\n{out}\n--- before:\n{a:#?}\n--- after:\n{b:#?}");
}

/// Visits every span in the file with a description of its node.
pub fn for_each_span(file: &File, f: &mut dyn FnMut(&str, Span)) {
    fn block(b: &Block, f: &mut dyn FnMut(&str, Span)) {
        f("block", b.span);
        items(&b.items, f);
        for c in &b.trailing_comments {
            f("comment", c.span);
        }
    }
    fn ident(i: &Ident, f: &mut dyn FnMut(&str, Span)) {
        f("ident", i.span);
    }
    fn items(items: &[Item], f: &mut dyn FnMut(&str, Span)) {
        for it in items {
            f("item", it.span);
            for c in it.comments.iter().chain(it.trailing_comment.iter()) {
                f("comment", c.span);
            }
            match &it.kind {
                ItemKind::Import { path } => f("string", path.span),
                ItemKind::Param { name, value } | ItemKind::Const { name, value } => {
                    ident(name, f);
                    expr(value, f);
                }
                ItemKind::Component { name, params, body } => {
                    ident(name, f);
                    for p in params {
                        ident(&p.name, f);
                        if let Some(d) = &p.default {
                            expr(d, f);
                        }
                    }
                    block(body, f);
                }
                ItemKind::For {
                    var,
                    start,
                    end,
                    body,
                } => {
                    ident(var, f);
                    expr(start, f);
                    expr(end, f);
                    block(body, f);
                }
                ItemKind::If {
                    cond,
                    then,
                    otherwise,
                } => {
                    expr(cond, f);
                    block(then, f);
                    if let Some(o) = otherwise {
                        block(o, f);
                    }
                }
                ItemKind::Decl {
                    keyword,
                    name,
                    value,
                    body,
                } => {
                    ident(keyword, f);
                    if let Some(n) = name {
                        f("name", n.span);
                        ident(&n.base, f);
                        for i in &n.indices {
                            expr(i, f);
                        }
                    }
                    if let Some(v) = value {
                        expr(v, f);
                    }
                    if let Some(b) = body {
                        block(b, f);
                    }
                }
                ItemKind::Prop {
                    key,
                    values,
                    block: b,
                } => {
                    ident(key, f);
                    for v in values {
                        expr(v, f);
                    }
                    if let Some(b) = b {
                        block(b, f);
                    }
                }
            }
        }
    }
    fn unit(u: &Unit, f: &mut dyn FnMut(&str, Span)) {
        f("unit", u.span);
        for (i, _) in &u.factors {
            ident(i, f);
        }
    }
    fn expr(e: &Expr, f: &mut dyn FnMut(&str, Span)) {
        f("expr", e.span);
        match &e.kind {
            ExprKind::Number { unit: Some(u), .. } => unit(u, f),
            ExprKind::WithUnit { expr: x, unit: u } => {
                expr(x, f);
                unit(u, f);
            }
            ExprKind::Str(s) => f("string", s.span),
            ExprKind::Ident(i) => ident(i, f),
            ExprKind::Index { base, index } => {
                expr(base, f);
                expr(index, f);
            }
            ExprKind::Member { base, member } => {
                expr(base, f);
                ident(member, f);
            }
            ExprKind::Call { func, args } => {
                ident(func, f);
                for a in args {
                    if let Some(n) = &a.name {
                        ident(n, f);
                    }
                    expr(&a.value, f);
                }
            }
            ExprKind::Tuple(es) | ExprKind::List(es) => {
                for x in es {
                    expr(x, f);
                }
            }
            ExprKind::Paren(x) | ExprKind::Unary { expr: x, .. } => expr(x, f),
            ExprKind::Binary { lhs, rhs, .. } => {
                expr(lhs, f);
                expr(rhs, f);
            }
            _ => {}
        }
    }
    items(&file.items, f);
    for c in &file.trailing_comments {
        f("comment", c.span);
    }
}

/// Every span of a parsed file is non-empty, inside the text, on character boundaries, and
/// tight (no leading or trailing whitespace).
pub fn check_spans(src: &str, file: &File) {
    for_each_span(file, &mut |what, span| {
        assert!(
            span.start < span.end && span.end <= src.len(),
            "{what} span {span:?} out of range in\n{src}"
        );
        assert!(src.is_char_boundary(span.start) && src.is_char_boundary(span.end));
        let text = &src[span.start..span.end];
        if what == "comment" {
            // A comment's text is what follows `//` up to the line end, spaces included.
            assert!(
                text.starts_with("//") || text.starts_with("/*") && text.ends_with("*/"),
                "{text:?}"
            );
        } else {
            assert_eq!(
                text,
                text.trim(),
                "{what} span {span:?} is not tight: {text:?}"
            );
        }
    });
}

/// The fenced ```mbd blocks of docs/language.md.
pub fn doc_examples() -> Vec<(usize, String)> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/language.md");
    let doc = std::fs::read_to_string(path).expect("docs/language.md is readable");
    let mut out = Vec::new();
    let mut current: Option<(usize, String)> = None;
    for (n, line) in doc.lines().enumerate() {
        let fence = line.trim_start().starts_with("```");
        match current.take() {
            None if line.trim_start().starts_with("```mbd") => {
                current = Some((n + 2, String::new()))
            }
            None => {}
            Some(block) if fence => out.push(block),
            Some((start, mut text)) => {
                text.push_str(line);
                text.push('\n');
                current = Some((start, text));
            }
        }
    }
    out
}

/// A compact prefix rendering of an expression, for precedence tests:
/// `-x^2` is `(neg (^ x 2))`, `(0, 1) m` is `(unit m (tuple 0 1))`.
pub fn sexpr(e: &Expr) -> String {
    match &e.kind {
        ExprKind::Number { text, unit, .. } => match unit {
            Some(u) => format!("{text}[{}]", u.text),
            None => text.clone(),
        },
        ExprKind::WithUnit { expr, unit } => format!("(unit {} {})", unit.text, sexpr(expr)),
        ExprKind::Str(s) => format!("{:?}", s.value),
        ExprKind::Bool(b) => b.to_string(),
        ExprKind::Ident(i) => i.name.clone(),
        ExprKind::Index { base, index } => format!("(index {} {})", sexpr(base), sexpr(index)),
        ExprKind::Member { base, member } => format!("(. {} {})", sexpr(base), member.name),
        ExprKind::Call { func, args } => {
            let mut s = format!("(call {}", func.name);
            for a in args {
                s.push(' ');
                if let Some(n) = &a.name {
                    s.push_str(&n.name);
                    s.push(':');
                }
                s.push_str(&sexpr(&a.value));
            }
            s.push(')');
            s
        }
        ExprKind::Tuple(es) => format!(
            "(tuple {})",
            es.iter().map(sexpr).collect::<Vec<_>>().join(" ")
        ),
        ExprKind::List(es) => format!(
            "(list {})",
            es.iter().map(sexpr).collect::<Vec<_>>().join(" ")
        ),
        ExprKind::Paren(x) => format!("(paren {})", sexpr(x)),
        ExprKind::Unary { op, expr } => {
            let o = match op {
                UnOp::Neg => "neg",
                UnOp::Not => "not",
            };
            format!("({o} {})", sexpr(expr))
        }
        ExprKind::Binary { op, lhs, rhs } => {
            format!("({} {} {})", op.as_str(), sexpr(lhs), sexpr(rhs))
        }
    }
}

/// `parse_expr` then [`sexpr`], panicking with the rendered errors on failure.
pub fn sx(src: &str) -> String {
    match mbdc_dsl::parse_expr(src) {
        Ok(e) => sexpr(&e),
        Err(errors) => panic!(
            "{src:?} does not parse: {}",
            errors
                .iter()
                .map(|e| e.render(src))
                .collect::<Vec<_>>()
                .join("\n")
        ),
    }
}

/// The first error message for a file that must not parse.
pub fn first_error(src: &str) -> mbdc_dsl::ParseError {
    match mbdc_dsl::parse(src) {
        Ok(f) => panic!("{src:?} parsed but should not: {f:#?}"),
        Err(mut errors) => {
            assert!(!errors.is_empty());
            errors.remove(0)
        }
    }
}
