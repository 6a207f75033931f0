//! Helpers for property blocks (`body { mass ...; inertia ... }`) and call arguments
//! (`revolute(a @ p, b @ q, axis: (0, 0, 1))`).

use mbdc_dsl::ast::{Arg, Block, Expr, Ident, Item, ItemKind, Span};

use super::{Lowerer, Reported, Scope, R};
use crate::diag::{codes, Diagnostic};
use crate::suggest;

/// A property key accepted in a block.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Key {
    pub name: &'static str,
    /// Minimum number of values.
    pub min: usize,
    /// Maximum number of values.
    pub max: usize,
    /// May appear more than once.
    pub repeat: bool,
}

/// `Key` shorthand: exactly one value, not repeatable.
pub(crate) const fn one(name: &'static str) -> Key {
    Key {
        name,
        min: 1,
        max: 1,
        repeat: false,
    }
}

/// The keys whose values may be followed by an options block (`glue a, m.b { ... }`);
/// [`Lowerer::props`] refuses a block after any other.
const BLOCK_KEYS: &[&str] = &["glue"];

/// One property occurrence.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Prop<'a> {
    pub key: &'a Ident,
    pub values: &'a [Expr],
    /// The options block after the values (only for [`BLOCK_KEYS`]).
    pub block: Option<&'a Block>,
    pub span: Span,
}

/// The properties of a block, checked against the accepted keys.
#[derive(Clone, Debug, Default)]
pub(crate) struct Props<'a> {
    pub list: Vec<Prop<'a>>,
    /// Nested declarations that were accepted.
    pub decls: Vec<&'a Item>,
    /// Known keys suggested for unknown ones (a missing key that was suggested is not
    /// reported again).
    pub typos: Vec<&'static str>,
}

impl<'a> Props<'a> {
    /// The (first) occurrence of a key.
    pub fn get(&self, key: &str) -> Option<Prop<'a>> {
        self.list.iter().find(|p| p.key.name == key).copied()
    }

    /// The single value of a key, if present.
    pub fn value(&self, key: &str) -> Option<&'a Expr> {
        self.get(key).and_then(|p| p.values.first())
    }
}

/// One argument slot of a call.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ArgSpec {
    pub name: &'static str,
    /// May be given without a name, in order.
    pub positional: bool,
    pub required: bool,
}

/// Positional required argument.
pub(crate) const fn pos(name: &'static str) -> ArgSpec {
    ArgSpec {
        name,
        positional: true,
        required: true,
    }
}

/// Named required argument.
pub(crate) const fn req(name: &'static str) -> ArgSpec {
    ArgSpec {
        name,
        positional: false,
        required: true,
    }
}

/// Named optional argument.
pub(crate) const fn opt(name: &'static str) -> ArgSpec {
    ArgSpec {
        name,
        positional: false,
        required: false,
    }
}

impl<'a> Lowerer<'a> {
    /// Collects the properties of a block. `what` names the block in messages ("body `rod`").
    /// Nested declarations whose keyword is in `decls` are returned in `Props::decls`.
    pub(crate) fn props(
        &mut self,
        block: &'a Block,
        sc: &Scope,
        what: &str,
        keys: &[Key],
        decls: &[&str],
    ) -> Props<'a> {
        let mut out = Props::default();
        for it in &block.items {
            match &it.kind {
                ItemKind::Prop { key, values, block } => {
                    let Some(k) = keys.iter().find(|k| k.name == key.name) else {
                        let names: Vec<&str> = keys
                            .iter()
                            .map(|k| k.name)
                            .chain(
                                decls
                                    .iter()
                                    .copied()
                                    .filter(|d| !keys.iter().any(|k| k.name == *d)),
                            )
                            .collect();
                        let close = suggest::closest(&key.name, names.iter().copied());
                        if let Some(c) = &close {
                            if let Some(k) = keys.iter().find(|k| k.name == c) {
                                out.typos.push(k.name);
                            }
                        }
                        let help = match close {
                            Some(s) => {
                                format!("did you mean `{s}`? {what} takes: {}", names.join(", "))
                            }
                            None => format!("{what} takes: {}", names.join(", ")),
                        };
                        self.report(
                            Diagnostic::error(
                                codes::UNKNOWN_PROPERTY,
                                format!("unknown property `{}` in {what}", key.name),
                            )
                            .primary(sc.file, key.span, "unknown property")
                            .help(help),
                        );
                        continue;
                    };
                    if values.len() < k.min || values.len() > k.max {
                        let want = if k.min == k.max {
                            match k.min {
                                0 => "no value".to_string(),
                                1 => "one value".to_string(),
                                n => format!("{n} values"),
                            }
                        } else {
                            format!("{} to {} values", k.min, k.max)
                        };
                        self.report(
                            Diagnostic::error(
                                codes::WRONG_KIND,
                                format!("`{}` takes {want}, found {}", key.name, values.len()),
                            )
                            .primary(sc.file, it.span, "")
                            .help("separate values with commas"),
                        );
                        continue;
                    }
                    if let Some(b) = block.as_ref().filter(|_| !BLOCK_KEYS.contains(&k.name)) {
                        self.report(
                            Diagnostic::error(
                                codes::WRONG_KIND,
                                format!("`{}` takes no options block", key.name),
                            )
                            .primary(sc.file, b.span, "")
                            .help(format!(
                                "remove the block after the values of `{}`",
                                key.name
                            )),
                        );
                        continue;
                    }
                    if !k.repeat {
                        if let Some(prev) = out.get(&key.name) {
                            self.report(
                                Diagnostic::error(
                                    codes::DUPLICATE_PROPERTY,
                                    format!("`{}` is given twice in {what}", key.name),
                                )
                                .primary(sc.file, it.span, "second")
                                .secondary(sc.file, prev.span, "first"),
                            );
                            continue;
                        }
                    }
                    out.list.push(Prop {
                        key,
                        values,
                        block: block.as_ref(),
                        span: it.span,
                    });
                }
                ItemKind::Decl { keyword, .. } if decls.contains(&keyword.name.as_str()) => {
                    out.decls.push(it)
                }
                ItemKind::Import { .. } if decls.contains(&"import") => out.decls.push(it),
                _ => {
                    let desc = match &it.kind {
                        ItemKind::Decl { keyword, .. } => format!("`{}`", keyword.name),
                        ItemKind::For { .. } => "a `for` loop".into(),
                        ItemKind::If { .. } => "an `if`".into(),
                        ItemKind::Const { .. } => "a `const`".into(),
                        ItemKind::Param { .. } => "a `param`".into(),
                        ItemKind::Import { .. } => "an `import`".into(),
                        ItemKind::Component { .. } => "a component".into(),
                        ItemKind::Prop { .. } => "this".into(),
                    };
                    let names: Vec<&str> = keys
                        .iter()
                        .map(|k| k.name)
                        .chain(
                            decls
                                .iter()
                                .copied()
                                .filter(|d| !keys.iter().any(|k| k.name == *d)),
                        )
                        .collect();
                    let mut d = Diagnostic::error(
                        codes::UNKNOWN_ITEM,
                        format!("{desc} is not allowed in {what}"),
                    )
                    .primary(sc.file, it.span, "not a property here");
                    if let ItemKind::Decl { keyword, .. } = &it.kind {
                        if let Some(k) = keys.iter().find(|k| k.name == keyword.name) {
                            // a property written as a declaration (`glue right { ... }`)
                            let block = if BLOCK_KEYS.contains(&k.name) {
                                ", and its block follows its values"
                            } else {
                                ""
                            };
                            d = d.help(format!(
                                "`{}` is a property of {what}: its values are separated by commas, without `=`{block}",
                                k.name
                            ));
                        } else if let Some(s) =
                            suggest::closest(&keyword.name, names.iter().copied())
                        {
                            d = d.help(format!("did you mean `{s}`?"));
                        } else {
                            d = d.help(format!("{what} takes: {}", names.join(", ")));
                        }
                    } else {
                        d = d.help(format!("{what} takes: {}", names.join(", ")));
                    }
                    self.report(d);
                }
            }
        }
        out
    }

    /// Reports a missing required property.
    pub(crate) fn missing(
        &mut self,
        props: &Props<'_>,
        key: &str,
        what: &str,
        sc: &Scope,
        span: Span,
        example: &str,
    ) -> Reported {
        if props.typos.contains(&key) {
            return Reported;
        }
        self.report(
            Diagnostic::error(codes::MISSING_PROPERTY, format!("{what} has no `{key}`"))
                .primary(sc.file, span, format!("`{key}` is required"))
                .help(format!("add `{example}`")),
        )
    }

    /// Matches call arguments to slots; returns the expression of each slot.
    pub(crate) fn call_args(
        &mut self,
        func: &Ident,
        args: &'a [Arg],
        spec: &[ArgSpec],
        sc: &Scope,
        call_span: Span,
    ) -> R<Vec<Option<&'a Expr>>> {
        let mut out: Vec<Option<&'a Expr>> = vec![None; spec.len()];
        let mut next_pos = 0usize;
        let mut ok = true;
        let mut typos: Vec<&str> = Vec::new();
        for a in args {
            let slot = match &a.name {
                None => {
                    while next_pos < spec.len()
                        && (!spec[next_pos].positional || out[next_pos].is_some())
                    {
                        next_pos += 1;
                    }
                    if next_pos >= spec.len() {
                        let npos = spec.iter().filter(|s| s.positional).count();
                        let named: Vec<&str> = spec
                            .iter()
                            .filter(|s| !s.positional)
                            .map(|s| s.name)
                            .collect();
                        let mut d = Diagnostic::error(
                            codes::ARGUMENT,
                            format!(
                                "`{}` takes {} positional argument{}",
                                func.name,
                                npos,
                                if npos == 1 { "" } else { "s" }
                            ),
                        )
                        .primary(sc.file, a.value.span, "extra argument");
                        if !named.is_empty() {
                            d = d.help(format!(
                                "other arguments are named: {}",
                                named
                                    .iter()
                                    .map(|n| format!("`{n}:`"))
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            ));
                        }
                        self.report(d);
                        ok = false;
                        continue;
                    }
                    next_pos
                }
                Some(n) => match spec.iter().position(|s| s.name == n.name) {
                    Some(p) => {
                        if out[p].is_some() {
                            self.report(
                                Diagnostic::error(
                                    codes::ARGUMENT,
                                    format!("argument `{}` is given twice", n.name),
                                )
                                .primary(
                                    sc.file,
                                    n.span,
                                    "second value",
                                ),
                            );
                            ok = false;
                            continue;
                        }
                        p
                    }
                    None => {
                        let names: Vec<&str> = spec.iter().map(|s| s.name).collect();
                        let close = suggest::closest(&n.name, names.iter().copied());
                        if let Some(c) = &close {
                            if let Some(sp) = spec.iter().find(|s| s.name == c) {
                                typos.push(sp.name);
                            }
                        }
                        let help = match close {
                            Some(s) => format!("did you mean `{s}`?"),
                            None => format!("`{}` takes: {}", func.name, names.join(", ")),
                        };
                        self.report(
                            Diagnostic::error(
                                codes::ARGUMENT,
                                format!("`{}` has no argument `{}`", func.name, n.name),
                            )
                            .primary(sc.file, n.span, "unknown argument")
                            .help(help),
                        );
                        ok = false;
                        continue;
                    }
                },
            };
            out[slot] = Some(&a.value);
        }
        for (i, s) in spec.iter().enumerate() {
            if s.required && out[i].is_none() && typos.contains(&s.name) {
                ok = false;
                continue;
            }
            if s.required && out[i].is_none() {
                let how = if s.positional {
                    format!("`{}` (positional)", s.name)
                } else {
                    format!("`{}:`", s.name)
                };
                self.report(
                    Diagnostic::error(
                        codes::ARGUMENT,
                        format!("`{}` needs the argument {how}", func.name),
                    )
                    .primary(sc.file, call_span, format!("missing `{}`", s.name))
                    .help(format!(
                        "`{}` takes: {}",
                        func.name,
                        spec.iter()
                            .map(|s| if s.positional {
                                s.name.to_string()
                            } else {
                                format!("{}:", s.name)
                            })
                            .collect::<Vec<_>>()
                            .join(", ")
                    )),
                );
                ok = false;
            }
        }
        if ok {
            Ok(out)
        } else {
            Err(Reported)
        }
    }
}
