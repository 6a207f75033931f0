//! Phase 1: expansion of imports, parameters, constants, loops, conditions and components
//! into flat lists of declarations.

use std::collections::HashMap;

use mbdc_dsl::ast::{Block, Expr, ExprKind, Item, ItemKind, Name, Span};
use mbdc_runtime::scene::ParamValue;

use super::{CompDef, EntKind, Lowerer, PDecl, Reported, Scope, Single, MAX_ITEMS, R};
use crate::diag::{codes, Diagnostic};
use crate::env::{BindKind, Env};
use crate::fn1;
use crate::load::ParsedFile;
use crate::source::FileId;
use crate::suggest;
use crate::value::{Value, Var, Q};

/// Deepest nesting of blocks (loops, conditions, instances).
pub const MAX_BLOCK_DEPTH: u32 = 64;

/// Declaration keywords allowed in a model or component.
const DECLS: &[&str] = &[
    "body",
    "joint",
    "force",
    "contact",
    "material",
    "beam",
    "mesh",
    "instance",
    "simulate",
    "reference",
];

/// Where items are being expanded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Ctx {
    /// Directly in the model block.
    ModelTop,
    /// Inside a loop or condition in the model.
    Model,
    /// Inside a component.
    Component,
}

impl<'a> Lowerer<'a> {
    /// Expands all files, starting with the main one.
    pub fn expand_program(&mut self, files: &'a [ParsedFile], main: usize) {
        self.file_envs = vec![None; files.len()];
        self.file_in_progress = vec![false; files.len()];
        // Register components of every file first (they are visible in all importers).
        for (idx, f) in files.iter().enumerate() {
            let Some(ast) = &f.ast else { continue };
            for it in &ast.items {
                if let ItemKind::Component { name, params, body } = &it.kind {
                    if let Some(prev) = self.components.get(&name.name) {
                        let (pf, ps) = (prev.file, prev.name_span);
                        self.report(
                            Diagnostic::error(
                                codes::DUPLICATE_NAME,
                                format!("component `{}` is declared twice", name.name),
                            )
                            .primary(f.id, name.span, "second declaration")
                            .secondary(pf, ps, "first declared here"),
                        );
                        continue;
                    }
                    if super::expand::DECLS.contains(&name.name.as_str()) || name.name == "model" {
                        self.report(
                            Diagnostic::error(
                                codes::DUPLICATE_NAME,
                                format!("`{}` is a keyword, not a component name", name.name),
                            )
                            .primary(f.id, name.span, "reserved"),
                        );
                        continue;
                    }
                    self.components.insert(
                        name.name.clone(),
                        CompDef {
                            params,
                            body,
                            file_idx: idx,
                            file: f.id,
                            name_span: name.span,
                        },
                    );
                }
            }
        }
        let env = self.process_file(files, main, main);
        // Imported files that nobody reached (cannot happen) are ignored.
        let Some((model_item, _, file)) = self.model.clone() else {
            if files.get(main).is_none_or(|f| f.ast.is_some()) {
                let id = files.get(main).map(|f| f.id).unwrap_or_default();
                self.report(
                    Diagnostic::error(codes::MODEL, "the file declares no model")
                        .primary(id, Span::new(0, 0), "")
                        .help("add `model NAME { ... }` with the bodies, joints and settings"),
                );
            }
            self.check_overrides();
            return;
        };
        if let ItemKind::Decl {
            body: Some(block), ..
        } = &model_item.kind
        {
            let mut sc = Scope::new(file, env);
            self.expand_items(&block.items, &mut sc, Ctx::ModelTop, 0);
        }
        self.check_overrides();
    }

    fn check_overrides(&mut self) {
        let unused: Vec<_> = self.overrides.iter().filter(|o| !o.used).cloned().collect();
        let names: Vec<String> = self.param_decls.keys().cloned().collect();
        for o in unused {
            let given = self.sources.text(o.file).trim().to_string();
            if let Some(&(cf, cs)) = self.const_decls.get(&o.name) {
                self.report(
                    Diagnostic::error(
                        codes::OVERRIDE,
                        format!(
                            "`--set {}={given}`: `{}` is a `const`, not a `param`",
                            o.name, o.name
                        ),
                    )
                    .primary(o.file, o.span, "the value given")
                    .secondary(
                        cf,
                        cs,
                        format!("`{}` is declared here as a `const`", o.name),
                    )
                    .help(format!(
                        "only a `param` can be set from the command line: declare it \
                         `param {} = ...` to make it settable",
                        o.name
                    )),
                );
                continue;
            }
            let help = unknown_param_help(&o.name, &names);
            self.report(
                Diagnostic::error(
                    codes::OVERRIDE,
                    format!(
                        "`--set {}={given}`: there is no parameter `{}`",
                        o.name, o.name
                    ),
                )
                .primary(o.file, o.span, "unknown parameter")
                .help(help),
            );
        }
    }

    /// Processes a file's top level (imports, components, params, consts) and returns the
    /// names it makes visible.
    fn process_file(&mut self, files: &'a [ParsedFile], idx: usize, main: usize) -> Env {
        if let Some(Some(env)) = self.file_envs.get(idx) {
            return env.clone();
        }
        if self.file_in_progress.get(idx).copied().unwrap_or(true) {
            return Env::empty();
        }
        self.file_in_progress[idx] = true;
        let f = &files[idx];
        let Some(ast) = &f.ast else {
            self.file_envs[idx] = Some(Env::empty());
            return Env::empty();
        };
        let mut env = Env::empty();
        let mut bound: HashMap<String, (FileId, Span)> = HashMap::new();
        for imp in &f.imports {
            let Some(t) = imp.target else { continue };
            let ienv = self.process_file(files, t, main);
            let mut frames: Vec<_> = Vec::new();
            {
                let mut names_seen = std::collections::HashSet::new();
                for name in ienv.names() {
                    if names_seen.insert(name.to_string()) {
                        if let Some(fr) = ienv.get(name) {
                            frames.push((
                                name.to_string(),
                                fr.value.clone(),
                                fr.kind,
                                fr.file,
                                fr.span,
                            ));
                        }
                    }
                }
            }
            frames.reverse();
            for (name, value, kind, ffile, fspan) in frames {
                if let Some(&(pf, ps)) = bound.get(&name) {
                    if (pf, ps) == (ffile, fspan) {
                        continue;
                    }
                    self.report(
                        Diagnostic::error(
                            codes::DUPLICATE_NAME,
                            format!("`{name}` is defined by two imports"),
                        )
                        .primary(f.id, imp.span, "this import defines it again")
                        .secondary(pf, ps, "first definition")
                        .secondary(ffile, fspan, "second definition"),
                    );
                    continue;
                }
                bound.insert(name.clone(), (ffile, fspan));
                env = env.bind(name, value, kind, ffile, fspan);
            }
        }
        let mut sc = Scope::new(f.id, env);
        for it in &ast.items {
            match &it.kind {
                ItemKind::Import { .. } | ItemKind::Component { .. } => {}
                ItemKind::Param { name, value } => {
                    self.count_item(f.id, it.span);
                    if let Some(&(pf, ps)) = bound.get(&name.name) {
                        self.dup_value(&name.name, f.id, name.span, pf, ps);
                        continue;
                    }
                    // a value that failed is bound as failed: its uses are not reported again
                    let (v, kind) = match self.eval_param(&name.name, name.span, value, &sc) {
                        Ok(v) => (v, BindKind::Param),
                        Err(Reported) => (Value::Bool(false), BindKind::Failed),
                    };
                    bound.insert(name.name.clone(), (f.id, name.span));
                    sc.env = sc.env.bind(name.name.clone(), v, kind, f.id, name.span);
                }
                ItemKind::Const { name, value } => {
                    self.count_item(f.id, it.span);
                    self.const_decls
                        .entry(name.name.clone())
                        .or_insert((f.id, name.span));
                    if let Some(&(pf, ps)) = bound.get(&name.name) {
                        self.dup_value(&name.name, f.id, name.span, pf, ps);
                        continue;
                    }
                    // a value that failed is bound as failed: its uses are not reported again
                    let (v, kind) = match self.eval(value, &sc) {
                        Ok(v) => (v, BindKind::Const),
                        Err(Reported) => (Value::Bool(false), BindKind::Failed),
                    };
                    bound.insert(name.name.clone(), (f.id, name.span));
                    sc.env = sc.env.bind(name.name.clone(), v, kind, f.id, name.span);
                }
                ItemKind::Decl { keyword, name, .. } if keyword.name == "model" => {
                    if idx != main {
                        self.report(
                            Diagnostic::error(
                                codes::IMPORT,
                                "an imported file must not declare a model",
                            )
                            .primary(
                                f.id,
                                keyword
                                    .span
                                    .to(name.as_ref().map(|n| n.span).unwrap_or(keyword.span)),
                                "model in an imported file",
                            )
                            .help(
                                "imported files provide components, constants and parameters only",
                            ),
                        );
                        continue;
                    }
                    let Some(n) = name else {
                        self.report(
                            Diagnostic::error(codes::MODEL, "a model needs a name")
                                .primary(f.id, keyword.span, "")
                                .help("write `model NAME { ... }`"),
                        );
                        continue;
                    };
                    if !n.indices.is_empty() {
                        self.report(
                            Diagnostic::error(codes::MODEL, "a model name cannot be indexed")
                                .primary(f.id, n.span, ""),
                        );
                    }
                    if let ItemKind::Decl { value: Some(v), .. } = &it.kind {
                        self.report(
                            Diagnostic::error(
                                codes::MODEL,
                                "a model is declared with a block, not a value",
                            )
                            .primary(f.id, v.span, "unexpected value")
                            .help("write `model NAME { ... }`"),
                        );
                        continue;
                    }
                    if !matches!(&it.kind, ItemKind::Decl { body: Some(_), .. }) {
                        self.report(
                            Diagnostic::error(codes::MODEL, "a model needs a block")
                                .primary(f.id, it.span, "")
                                .help("write `model NAME { ... }`"),
                        );
                        continue;
                    }
                    if let Some((prev, _, pf)) = &self.model {
                        let pspan = match &prev.kind {
                            ItemKind::Decl { name: Some(pn), .. } => pn.span,
                            _ => prev.span,
                        };
                        let pf = *pf;
                        self.report(
                            Diagnostic::error(codes::MODEL, "a file declares one model")
                                .primary(f.id, n.span, "second model")
                                .secondary(pf, pspan, "first model"),
                        );
                        continue;
                    }
                    self.model = Some((it, n.base.name.clone(), f.id));
                }
                _ => {
                    let what = match &it.kind {
                        ItemKind::Decl { keyword, .. } => format!("`{}`", keyword.name),
                        ItemKind::Prop { key, .. } => format!("`{}`", key.name),
                        ItemKind::For { .. } => "a `for` loop".into(),
                        ItemKind::If { .. } => "an `if`".into(),
                        _ => "this item".into(),
                    };
                    self.report(
                        Diagnostic::error(codes::UNKNOWN_ITEM, format!("{what} must be inside the model"))
                            .primary(f.id, it.span, "at the top level of the file")
                            .help("the top level holds `import`, `param`, `const`, `component` and `model` only"),
                    );
                }
            }
        }
        self.file_envs[idx] = Some(sc.env.clone());
        sc.env
    }

    fn dup_value(&mut self, name: &str, file: FileId, span: Span, pf: FileId, ps: Span) {
        self.report(
            Diagnostic::error(codes::DUPLICATE_NAME, format!("`{name}` is declared twice"))
                .primary(file, span, "second declaration")
                .secondary(pf, ps, "first declared here"),
        );
    }

    fn count_item(&mut self, file: FileId, span: Span) -> bool {
        self.generated += 1;
        if self.generated > MAX_ITEMS {
            if !self.limit_hit {
                self.limit_hit = true;
                self.report(
                    Diagnostic::error(
                        codes::LIMIT,
                        format!(
                            "the model generates more than {} items",
                            fmt_count(MAX_ITEMS)
                        ),
                    )
                    .primary(file, span, "the limit was reached here")
                    .help("reduce the loop counts or the component nesting"),
                );
            }
            return false;
        }
        true
    }

    /// Evaluates a parameter, applying a command-line override.
    fn eval_param(&mut self, name: &str, span: Span, value: &Expr, sc: &Scope) -> R<Value> {
        if let Some(&(pf, ps)) = self.param_decls.get(name) {
            self.dup_value(name, sc.file, span, pf, ps);
            return Err(Reported);
        }
        self.param_decls.insert(name.to_string(), (sc.file, span));
        let default = self.eval(value, sc)?;
        self.check_param_value(&default, name, value.span, sc)?;
        let mut v = default.clone();
        let mut overridden = false;
        if let Some(pos) = self.overrides.iter().position(|o| o.name == name) {
            self.overrides[pos].used = true;
            let o = self.overrides[pos].clone();
            if let Some(expr) = &o.expr {
                let osc = Scope {
                    file: o.file,
                    ..sc.clone()
                };
                let ov = self.eval(expr, &osc)?;
                let given = self.sources.text(o.file).trim().to_string();
                let default_text = self
                    .sources
                    .text(sc.file)
                    .get(value.span.start..value.span.end)
                    .unwrap_or("")
                    .to_string();
                let declared = format!("`{name}` is declared here, `{default_text}`");
                let problem = if is_constant_value(&ov) {
                    same_shape(&default, &ov).err()
                } else {
                    Some(format!(
                        "expected {}, found {}",
                        expected(&default),
                        ov.kind()
                    ))
                };
                if let Some(msg) = problem {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::OVERRIDE,
                            format!("`--set {name}={given}`: {msg}"),
                        )
                        .primary(o.file, expr.span, "the value given")
                        .secondary(sc.file, value.span, declared)
                        .help(override_help(name, &default, &default_text)),
                    ));
                }
                v = ov;
                overridden = true;
            }
        }
        record_param(&mut self.params, name, &v, overridden);
        Ok(v)
    }

    fn check_param_value(&mut self, v: &Value, name: &str, span: Span, sc: &Scope) -> R<()> {
        if is_constant_value(v) {
            Ok(())
        } else {
            Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!("parameter `{name}` must be a constant number, vector, boolean or string, found {}", v.kind()),
                )
                .primary(sc.file, span, "")
                .help("use `const` for functions of time and names"),
            ))
        }
    }

    /// Expands the items of a block.
    pub(crate) fn expand_items(&mut self, items: &'a [Item], sc: &mut Scope, ctx: Ctx, depth: u32) {
        if depth > MAX_BLOCK_DEPTH {
            if let Some(first) = items.first() {
                self.report(
                    Diagnostic::error(
                        codes::LIMIT,
                        format!("blocks nest more than {MAX_BLOCK_DEPTH} deep"),
                    )
                    .primary(sc.file, first.span, "too deep"),
                );
            }
            return;
        }
        let mut local: HashMap<String, Span> = HashMap::new();
        for it in items {
            if self.limit_hit {
                return;
            }
            match &it.kind {
                ItemKind::Import { .. } => {
                    self.report(
                        Diagnostic::error(
                            codes::UNKNOWN_ITEM,
                            "`import` must be at the top level of the file",
                        )
                        .primary(sc.file, it.span, "")
                        .help("move it before the model"),
                    );
                }
                ItemKind::Component { name, .. } => {
                    self.report(
                        Diagnostic::error(
                            codes::UNKNOWN_ITEM,
                            "components are declared at the top level of a file",
                        )
                        .primary(sc.file, name.span, "")
                        .help("move the component out of the model"),
                    );
                }
                ItemKind::Param { name, value } => {
                    if !self.count_item(sc.file, it.span) {
                        return;
                    }
                    if ctx != Ctx::ModelTop {
                        self.report(
                            Diagnostic::error(
                                codes::UNKNOWN_ITEM,
                                "`param` is only allowed at the top level of a file or model",
                            )
                            .primary(sc.file, it.span, "")
                            .help(if ctx == Ctx::Component {
                                "use a component parameter or a `const`"
                            } else {
                                "use a `const` inside loops and conditions"
                            }),
                        );
                        // Bind it as a constant so that its uses do not cascade.
                        let (v, kind) = match self.eval(value, sc) {
                            Ok(v) => (v, BindKind::Const),
                            Err(Reported) => (Value::Bool(false), BindKind::Failed),
                        };
                        sc.env = sc.env.bind(name.name.clone(), v, kind, sc.file, name.span);
                        continue;
                    }
                    if let Some(&ps) = local.get(&name.name) {
                        self.dup_value(&name.name, sc.file, name.span, sc.file, ps);
                        continue;
                    }
                    // a value that failed is bound as failed: its uses are not reported again
                    let (v, kind) = match self.eval_param(&name.name, name.span, value, sc) {
                        Ok(v) => (v, BindKind::Param),
                        Err(Reported) => (Value::Bool(false), BindKind::Failed),
                    };
                    local.insert(name.name.clone(), name.span);
                    sc.env = sc.env.bind(name.name.clone(), v, kind, sc.file, name.span);
                }
                ItemKind::Const { name, value } => {
                    if !self.count_item(sc.file, it.span) {
                        return;
                    }
                    if let Some(&ps) = local.get(&name.name) {
                        self.dup_value(&name.name, sc.file, name.span, sc.file, ps);
                        continue;
                    }
                    if ctx == Ctx::ModelTop {
                        self.const_decls
                            .entry(name.name.clone())
                            .or_insert((sc.file, name.span));
                    }
                    // a value that failed is bound as failed: its uses are not reported again
                    let (v, kind) = match self.eval(value, sc) {
                        Ok(v) => (v, BindKind::Const),
                        Err(Reported) => (Value::Bool(false), BindKind::Failed),
                    };
                    local.insert(name.name.clone(), name.span);
                    sc.env = sc.env.bind(name.name.clone(), v, kind, sc.file, name.span);
                }
                ItemKind::For {
                    var,
                    start,
                    end,
                    body,
                } => {
                    let (Ok(a), Ok(b)) = (
                        self.int(start, sc, "a loop bound"),
                        self.int(end, sc, "a loop bound"),
                    ) else {
                        continue;
                    };
                    let n = (b as i128 - a as i128).max(0);
                    if n == 0 {
                        continue;
                    }
                    let per = self.estimate(body, sc, 0).max(1) as i128;
                    let remaining = (MAX_ITEMS - self.generated.min(MAX_ITEMS)) as i128;
                    if n * per > remaining {
                        self.limit_hit = true;
                        self.report(
                            Diagnostic::error(
                                codes::LIMIT,
                                format!(
                                    "this loop would create {} items, more than the limit of {}",
                                    fmt_count_i128(n * per),
                                    fmt_count(MAX_ITEMS)
                                ),
                            )
                            .primary(
                                sc.file,
                                start.span.to(end.span),
                                format!("{} iterations", fmt_count_i128(n)),
                            )
                            .help("reduce the range, or split the model"),
                        );
                        return;
                    }
                    for i in a..b {
                        let mut sub = sc.clone();
                        sub.env = sub.env.bind(
                            var.name.clone(),
                            Value::Num(Q::num(i as f64)),
                            BindKind::LoopVar,
                            sc.file,
                            var.span,
                        );
                        self.expand_items(
                            &body.items,
                            &mut sub,
                            if ctx == Ctx::ModelTop {
                                Ctx::Model
                            } else {
                                ctx
                            },
                            depth + 1,
                        );
                        if self.limit_hit {
                            return;
                        }
                    }
                }
                ItemKind::If {
                    cond,
                    then,
                    otherwise,
                } => {
                    let Ok(c) = self.boolean(cond, sc) else {
                        continue;
                    };
                    let inner = if ctx == Ctx::ModelTop {
                        Ctx::Model
                    } else {
                        ctx
                    };
                    if c {
                        let mut sub = sc.clone();
                        self.expand_items(&then.items, &mut sub, inner, depth + 1);
                    } else if let Some(o) = otherwise {
                        let mut sub = sc.clone();
                        self.expand_items(&o.items, &mut sub, inner, depth + 1);
                    }
                }
                ItemKind::Decl {
                    keyword,
                    name,
                    value,
                    body,
                } => {
                    if !self.count_item(sc.file, it.span) {
                        return;
                    }
                    self.expand_decl(
                        it,
                        keyword,
                        name.as_ref(),
                        value.as_ref(),
                        body.as_ref(),
                        sc,
                        ctx,
                        depth,
                    );
                }
                ItemKind::Prop { key, values, .. } => {
                    if !self.count_item(sc.file, it.span) {
                        return;
                    }
                    if key.name == "gravity" {
                        if ctx == Ctx::Component {
                            self.report(
                                Diagnostic::error(
                                    codes::UNKNOWN_ITEM,
                                    "`gravity` is a property of the model, not of a component",
                                )
                                .primary(sc.file, it.span, "")
                                .help("move it into the model"),
                            );
                            continue;
                        }
                        let _ = values;
                        self.set_single(
                            Single {
                                item: it,
                                sc: sc.clone(),
                            },
                            "gravity",
                        );
                        continue;
                    }
                    let mut known: Vec<&str> = DECLS.to_vec();
                    known.push("gravity");
                    let help = suggest::did_you_mean(&key.name, known.iter().copied()).unwrap_or_else(|| {
                        "a model holds `gravity`, declarations (body, joint, force, contact, material, beam, mesh, instance, simulate, reference), `param`, `const`, `for` and `if`".into()
                    });
                    let what = if ctx == Ctx::Component {
                        "a component"
                    } else {
                        "the model"
                    };
                    self.report(
                        Diagnostic::error(
                            codes::UNKNOWN_ITEM,
                            format!("`{}` is not allowed in {what}", key.name),
                        )
                        .primary(sc.file, key.span, "unknown here")
                        .help(help),
                    );
                }
            }
        }
    }

    fn set_single(&mut self, s: Single<'a>, which: &str) {
        let slot = match which {
            "gravity" => &mut self.gravity,
            "simulate" => &mut self.simulate,
            _ => &mut self.reference,
        };
        if let Some(prev) = slot {
            let (pf, ps) = (prev.sc.file, prev.item.span);
            let (f, sp) = (s.sc.file, s.item.span);
            self.report(
                Diagnostic::error(
                    codes::DUPLICATE_PROPERTY,
                    format!("`{which}` is given twice"),
                )
                .primary(f, sp, "second")
                .secondary(pf, ps, "first"),
            );
            return;
        }
        *slot = Some(s);
    }

    /// A lower bound on the items a block generates: nested loops whose bounds can be
    /// evaluated here multiply; anything else counts as one. Evaluates silently.
    fn estimate(&mut self, b: &Block, sc: &Scope, depth: u32) -> u128 {
        if depth > 8 {
            return b.items.len() as u128;
        }
        let mut n: u128 = 0;
        for it in &b.items {
            n = n.saturating_add(match &it.kind {
                ItemKind::For {
                    start, end, body, ..
                } => {
                    let mark = self.diags.len();
                    let r = (
                        self.int(start, sc, "a loop bound"),
                        self.int(end, sc, "a loop bound"),
                    );
                    self.diags.truncate(mark);
                    match r {
                        (Ok(a), Ok(z)) if z > a => ((z as i128 - a as i128) as u128)
                            .saturating_mul(self.estimate(body, sc, depth + 1).max(1)),
                        _ => 1,
                    }
                }
                _ => 1,
            });
        }
        n
    }

    /// The evaluated name of a declaration: `link[3]`, prefixed with the instance path.
    fn decl_name(&mut self, name: &Name, sc: &Scope) -> R<String> {
        let mut s = format!("{}{}", sc.prefix, name.base.name);
        for ix in &name.indices {
            let i = self.int(ix, sc, "an index")?;
            s.push_str(&format!("[{i}]"));
        }
        Ok(s)
    }

    #[allow(clippy::too_many_arguments)]
    fn expand_decl(
        &mut self,
        it: &'a Item,
        keyword: &'a mbdc_dsl::ast::Ident,
        name: Option<&'a Name>,
        value: Option<&'a Expr>,
        block: Option<&'a Block>,
        sc: &Scope,
        ctx: Ctx,
        depth: u32,
    ) {
        let kw = keyword.name.as_str();
        let file = sc.file;
        let kind = match kw {
            "body" => EntKind::Body,
            "joint" => EntKind::Joint,
            "force" => EntKind::Force,
            "contact" => EntKind::Contact,
            "material" => EntKind::Material,
            "beam" => EntKind::Beam,
            "mesh" => EntKind::Mesh,
            "instance" => EntKind::Instance,
            "simulate" | "reference" => {
                if ctx == Ctx::Component {
                    self.report(
                        Diagnostic::error(
                            codes::UNKNOWN_ITEM,
                            format!("`{kw}` belongs to the model, not to a component"),
                        )
                        .primary(file, keyword.span, "")
                        .help("move it into the model"),
                    );
                    return;
                }
                if let Some(n) = name {
                    self.report(
                        Diagnostic::error(codes::UNKNOWN_ITEM, format!("`{kw}` takes no name"))
                            .primary(file, n.span, "remove this name")
                            .help(format!("write `{kw} {{ ... }}`")),
                    );
                    return;
                }
                if block.is_none() || value.is_some() {
                    self.report(
                        Diagnostic::error(
                            codes::UNKNOWN_ITEM,
                            format!("`{kw}` is written with a block"),
                        )
                        .primary(file, it.span, "")
                        .help(format!("write `{kw} {{ ... }}`")),
                    );
                    return;
                }
                self.set_single(
                    Single {
                        item: it,
                        sc: sc.clone(),
                    },
                    kw,
                );
                return;
            }
            "model" => {
                self.report(
                    Diagnostic::error(codes::MODEL, "a model cannot contain another model")
                        .primary(file, keyword.span, ""),
                );
                return;
            }
            _ => {
                let mut d =
                    Diagnostic::error(codes::UNKNOWN_ITEM, format!("unknown declaration `{kw}`"))
                        .primary(file, keyword.span, "not a declaration keyword");
                if self.components.contains_key(kw) {
                    d = d.help(format!(
                        "to place a component, write `instance NAME = {kw}(...)`"
                    ));
                } else if let Some(s) = suggest::closest(kw, DECLS.iter().copied()) {
                    d = d.help(format!("did you mean `{s}`?"));
                } else if kw == "gravity" {
                    d = d.help("write `gravity (0, 0, -9.81) m/s^2`");
                } else {
                    d = d.help(format!("declarations: {}", DECLS.join(", ")));
                }
                self.report(d);
                return;
            }
        };
        let Some(name) = name else {
            self.report(
                Diagnostic::error(
                    codes::UNKNOWN_ITEM,
                    format!("a {} needs a name", kind.noun()),
                )
                .primary(file, keyword.span, "")
                .help(match kind {
                    EntKind::Joint | EntKind::Force | EntKind::Contact | EntKind::Instance => {
                        format!("write `{kw} NAME = ...`")
                    }
                    _ => format!("write `{kw} NAME {{ ... }}`"),
                }),
            );
            return;
        };
        let wants_block = matches!(
            kind,
            EntKind::Body | EntKind::Material | EntKind::Beam | EntKind::Mesh
        );
        if wants_block && (block.is_none() || value.is_some()) {
            self.report(
                Diagnostic::error(
                    codes::UNKNOWN_ITEM,
                    format!("a {} is declared with a block", kind.noun()),
                )
                .primary(file, value.map(|v| v.span).unwrap_or(it.span), "")
                .help(format!("write `{kw} {} {{ ... }}`", name.base.name)),
            );
            return;
        }
        if !wants_block && (value.is_none() || block.is_some()) {
            let example = match kind {
                EntKind::Joint => "revolute(a @ (0, 0, 0), b @ (0, 0, 0), axis: (0, 0, 1))",
                EntKind::Force => "point(b @ (0, 0, 0), (1, 0, 0) N)",
                EntKind::Contact => "sphere_plane(ball @ (0, 0, 0), ground @ (0, 0, 0), radius: 0.1 m, normal: (0, 0, 1), stiffness: 1e5 N/m)",
                _ => "Component(...)",
            };
            self.report(
                Diagnostic::error(
                    codes::UNKNOWN_ITEM,
                    format!("a {} is declared with `=` and a value", kind.noun()),
                )
                .primary(file, block.map(|b| b.span).unwrap_or(it.span), "")
                .help(format!("write `{kw} {} = {example}`", name.base.name)),
            );
            return;
        }
        let Ok(full) = self.decl_name(name, sc) else {
            return;
        };
        let Ok(_) = self.register(kind, &full, file, name.span) else {
            return;
        };
        if kind == EntKind::Instance {
            if let Some(v) = value {
                self.expand_instance(&full, v, sc, depth);
            }
            return;
        }
        let d = PDecl {
            name: full,
            name_span: name.span,
            span: it.span,
            value,
            block,
            sc: sc.clone(),
        };
        match kind {
            EntKind::Body => self.bodies.push(d),
            EntKind::Joint => self.joints.push(d),
            EntKind::Force => self.forces.push(d),
            EntKind::Contact => self.contacts.push(d),
            EntKind::Material => self.materials.push(d),
            EntKind::Beam => self.beams.push(d),
            EntKind::Mesh => self.meshes.push(d),
            EntKind::Instance => {}
        }
    }

    fn expand_instance(&mut self, full: &str, value: &'a Expr, sc: &Scope, depth: u32) {
        let file = sc.file;
        let ExprKind::Call { func, args } = &value.kind else {
            self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    "an instance places a component: `instance NAME = Component(args)`",
                )
                .primary(file, value.span, "not a component call"),
            );
            return;
        };
        let Some(comp) = self.components.get(&func.name).cloned() else {
            let names: Vec<String> = self.components.keys().cloned().collect();
            let help = suggest::did_you_mean(&func.name, names.iter().map(|s| s.as_str())).unwrap_or_else(|| {
                if names.is_empty() {
                    "no component is declared; declare one with `component NAME(params) { ... }`".into()
                } else {
                    let mut n = names.clone();
                    n.sort();
                    format!("components: {}", n.join(", "))
                }
            });
            self.report(
                Diagnostic::error(
                    codes::UNKNOWN_NAME,
                    format!("unknown component `{}`", func.name),
                )
                .primary(file, func.span, "not declared")
                .help(help),
            );
            return;
        };
        if self.comp_stack.contains(&func.name) {
            let mut chain = self.comp_stack.clone();
            chain.push(func.name.clone());
            let start = chain.iter().position(|c| *c == func.name).unwrap_or(0);
            self.report(
                Diagnostic::error(
                    codes::RECURSIVE_COMPONENT,
                    format!(
                        "component `{}` instantiates itself: {}",
                        func.name,
                        chain[start..].join(" → ")
                    ),
                )
                .primary(file, value.span, "recursive instance")
                .secondary(comp.file, comp.name_span, "component declared here")
                .help("components may instantiate other components, but not themselves"),
            );
            return;
        }
        // Match arguments to parameters.
        let mut given: Vec<Option<(Value, Span)>> = vec![None; comp.params.len()];
        let mut positional = 0usize;
        let mut ok = true;
        for a in args {
            let slot = match &a.name {
                None => {
                    let p = positional;
                    positional += 1;
                    if p >= comp.params.len() {
                        self.report(
                            Diagnostic::error(
                                codes::ARGUMENT,
                                format!(
                                    "component `{}` takes {} parameters",
                                    func.name,
                                    comp.params.len()
                                ),
                            )
                            .primary(
                                file,
                                a.value.span,
                                "extra argument",
                            ),
                        );
                        ok = false;
                        continue;
                    }
                    p
                }
                Some(n) => match comp.params.iter().position(|p| p.name.name == n.name) {
                    Some(p) => p,
                    None => {
                        let help = suggest::did_you_mean(
                            &n.name,
                            comp.params.iter().map(|p| p.name.name.as_str()),
                        )
                        .unwrap_or_else(|| {
                            format!(
                                "parameters of `{}`: {}",
                                func.name,
                                comp.params
                                    .iter()
                                    .map(|p| p.name.name.as_str())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            )
                        });
                        self.report(
                            Diagnostic::error(
                                codes::ARGUMENT,
                                format!("component `{}` has no parameter `{}`", func.name, n.name),
                            )
                            .primary(file, n.span, "unknown parameter")
                            .help(help),
                        );
                        ok = false;
                        continue;
                    }
                },
            };
            if given[slot].is_some() {
                self.report(
                    Diagnostic::error(
                        codes::ARGUMENT,
                        format!("parameter `{}` is given twice", comp.params[slot].name.name),
                    )
                    .primary(file, a.value.span, "second value"),
                );
                ok = false;
                continue;
            }
            match self.eval(&a.value, sc) {
                Ok(v) => given[slot] = Some((v, a.value.span)),
                Err(_) => ok = false,
            }
        }
        let mut env = self
            .file_envs
            .get(comp.file_idx)
            .cloned()
            .flatten()
            .unwrap_or_default();
        let prefix = format!("{full}.");
        for (i, p) in comp.params.iter().enumerate() {
            let v = match given[i].take() {
                Some((v, _)) => v,
                None => match &p.default {
                    Some(d) => {
                        let dsc = Scope {
                            file: comp.file,
                            env: env.clone(),
                            prefix: prefix.clone(),
                            eq_tol: 0.0,
                        };
                        match self.eval(d, &dsc) {
                            Ok(v) => v,
                            Err(_) => {
                                ok = false;
                                continue;
                            }
                        }
                    }
                    None => {
                        self.report(
                            Diagnostic::error(
                                codes::ARGUMENT,
                                format!(
                                    "missing argument `{}` of component `{}`",
                                    p.name.name, func.name
                                ),
                            )
                            .primary(file, value.span, format!("`{}` is required", p.name.name))
                            .secondary(comp.file, p.name.span, "parameter declared here")
                            .help(format!(
                                "write `{}(..., {}: VALUE)`",
                                func.name, p.name.name
                            )),
                        );
                        ok = false;
                        continue;
                    }
                },
            };
            env = env.bind(
                p.name.name.clone(),
                v,
                BindKind::ComponentParam,
                comp.file,
                p.name.span,
            );
        }
        if !ok {
            return;
        }
        self.comp_stack.push(func.name.clone());
        let mut csc = Scope {
            file: comp.file,
            env,
            prefix,
            eq_tol: 0.0,
        };
        self.expand_items(&comp.body.items, &mut csc, Ctx::Component, depth + 1);
        self.comp_stack.pop();
    }
}

/// `1,000,000`
pub(crate) fn fmt_count(n: usize) -> String {
    fmt_count_i128(n as i128)
}

fn fmt_count_i128(n: i128) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) && c != '-' {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// Records scalar (and vector, component-wise) parameter values.
fn record_param(params: &mut Vec<ParamValue>, name: &str, v: &Value, overridden: bool) {
    match v {
        Value::Num(q) => {
            if let Some(c) = fn1::as_const(&q.f) {
                params.push(ParamValue {
                    name: name.to_string(),
                    value: c,
                    overridden,
                });
            }
        }
        Value::Tuple(items) => {
            for (i, it) in items.iter().enumerate() {
                let suffix = ["x", "y", "z"]
                    .get(i)
                    .map(|s| s.to_string())
                    .unwrap_or_else(|| i.to_string());
                record_param(params, &format!("{name}.{suffix}"), it, overridden);
            }
        }
        Value::Bool(b) => params.push(ParamValue {
            name: name.to_string(),
            value: f64::from(u8::from(*b)),
            overridden,
        }),
        _ => {}
    }
}

/// Whether an override has the same shape and dimensions as the default.
/// Most parameter names listed in the help of an unknown `--set` name.
const MAX_LISTED_PARAMS: usize = 8;

/// The help of a `--set` of an unknown name: the closest name, then the parameters, nearest
/// first (at most [`MAX_LISTED_PARAMS`]).
fn unknown_param_help(name: &str, params: &[String]) -> String {
    if params.is_empty() {
        return "the model declares no parameters".into();
    }
    let mut by_distance: Vec<(usize, &str)> = params
        .iter()
        .map(|p| (suggest::distance(name, p, usize::MAX - 1), p.as_str()))
        .collect();
    by_distance.sort();
    let listed: Vec<String> = by_distance
        .iter()
        .take(MAX_LISTED_PARAMS)
        .map(|(_, p)| format!("`{p}`"))
        .collect();
    let list = if params.len() > MAX_LISTED_PARAMS {
        format!(
            "the nearest of its {} parameters: {}",
            params.len(),
            listed.join(", ")
        )
    } else {
        format!("its parameters: {}", listed.join(", "))
    };
    // the candidates in a fixed order, so that ties go to the same name every time
    match suggest::did_you_mean(name, by_distance.iter().map(|(_, p)| *p)) {
        Some(d) => format!("{d} {list}"),
        None => format!("the model has no parameter of that name; {list}"),
    }
}

/// Whether a value may be a parameter's: a constant number, a vector of them, a boolean or
/// a string.
fn is_constant_value(v: &Value) -> bool {
    match v {
        Value::Num(q) => q.var == Var::None,
        Value::Tuple(items) => items
            .iter()
            .all(|i| matches!(i, Value::Num(q) if q.var == Var::None)),
        Value::Bool(_) | Value::Str(_) => true,
        _ => false,
    }
}

/// What a parameter with this default expects, in words: "a quantity in kg (mass)", "a
/// dimensionless number" (counts, angles), "a 3-vector in m/s^2 (acceleration)", "a boolean".
fn expected(default: &Value) -> String {
    match default {
        Value::Num(q) if q.poly || q.dim.is_none() => "a dimensionless number".into(),
        Value::Num(q) => format!("a quantity in {}", q.dim.describe()),
        Value::Tuple(items) => match items.first() {
            Some(Value::Num(q)) if !(q.poly || q.dim.is_none()) => {
                format!("a {}-vector in {}", items.len(), q.dim.describe())
            }
            _ => format!("a {}-vector", items.len()),
        },
        v => v.kind(),
    }
}

/// The help of a refused override: what to write, shown with the default as written.
fn override_help(name: &str, default: &Value, default_text: &str) -> String {
    let what = match default {
        Value::Num(q) if q.poly || q.dim.is_none() => "a dimensionless number".to_string(),
        Value::Num(q) => format!("a number with a unit of {}", q.dim.describe()),
        Value::Tuple(items) => format!("a {}-vector", items.len()),
        Value::Bool(_) => "`true` or `false`".to_string(),
        Value::Str(_) => "a quoted string".to_string(),
        v => v.kind(),
    };
    format!("give `{name}` {what}, as its default is written: `--set {name}={default_text}`")
}

fn same_shape(default: &Value, ov: &Value) -> Result<(), String> {
    match (default, ov) {
        (Value::Num(a), Value::Num(b)) => {
            if a.poly || b.poly || a.dim == b.dim {
                Ok(())
            } else {
                Err(format!(
                    "expected {}, found {}",
                    expected(default),
                    ov.kind()
                ))
            }
        }
        (Value::Tuple(a), Value::Tuple(b)) if a.len() == b.len() => {
            match a.iter().zip(b).try_for_each(|(x, y)| same_shape(x, y)) {
                Ok(()) => Ok(()),
                Err(_) => Err(format!(
                    "expected {}, found {}",
                    expected(default),
                    ov.kind()
                )),
            }
        }
        (Value::Bool(_), Value::Bool(_)) | (Value::Str(_), Value::Str(_)) => Ok(()),
        (a, b) => Err(format!("expected {}, found {}", expected(a), b.kind())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts() {
        assert_eq!(fmt_count(1_000_000), "1,000,000");
        assert_eq!(fmt_count(12), "12");
        assert_eq!(fmt_count_i128(1234), "1,234");
    }
}
