//! Expression evaluation with dimensions.
//!
//! Every scalar is an [`Fn1`] in SI units with a [`Dim`]; constants fold as they are
//! built. `t` evaluates to the time variable, so an expression that uses it becomes a
//! function of time, and the consumer decides whether that is allowed. Names that are not
//! values in scope evaluate to [`Value::Name`] and are resolved by the consumer (as a
//! body, a joint, a set, or a unit such as the `s` in `20/s`).

use mbdc_dsl::ast::{Arg, BinOp, Expr, ExprKind, Span, UnOp, Unit};
use mbdc_runtime::scene::{Fn1, UnaryFn};

use super::{Lowerer, Reported, Scope, R};
use crate::diag::{codes, Diagnostic};
use crate::env::BindKind;
use crate::fn1;
use crate::suggest;
use crate::units::{self, Dim};
use crate::value::{Attach, NameRef, PointSpec, Value, Var, Q};

/// Deepest expression nesting the evaluator accepts.
pub const MAX_EXPR_DEPTH: u32 = 200;

/// Functions usable in expressions (for messages and suggestions).
pub const FUNCTIONS: &[&str] = &[
    "sin",
    "cos",
    "tan",
    "asin",
    "acos",
    "atan",
    "atan2",
    "sqrt",
    "exp",
    "ln",
    "abs",
    "min",
    "max",
    "floor",
    "ceil",
    "round",
    "dot",
    "cross",
    "norm",
    "normalize",
    "step",
    "ramp",
    "smoothstep",
    "table",
    "sn",
    "cn",
    "dn",
    "ellipk",
    "tanh",
    "diag",
    "world",
];

/// Names with a meaning only in a specific place, and where that is.
const PLACED: &[(&str, &str)] = &[
    ("rod", "an inertia (`inertia rod(length: L, radius: r)`)"),
    (
        "cylinder",
        "an inertia (`inertia cylinder(radius: r, length: L)`)",
    ),
    (
        "box",
        "an inertia (`inertia box(size: (a, b, c))`) or a mesh generator",
    ),
    ("sphere", "an inertia (`inertia sphere(radius: r)`)"),
    ("axis_angle", "an orientation"),
    ("quaternion", "an orientation"),
    ("euler_xyz", "an orientation"),
    ("matrix", "an orientation"),
    ("spherical", "the value of a `joint` declaration"),
    ("revolute", "the value of a `joint` declaration"),
    ("prismatic", "the value of a `joint` declaration"),
    ("cylindrical", "the value of a `joint` declaration"),
    ("universal", "the value of a `joint` declaration"),
    ("fixed", "the value of a `joint` declaration"),
    ("planar", "the value of a `joint` declaration"),
    ("distance", "the value of a `joint` declaration"),
    ("drive_angle", "the value of a `joint` declaration"),
    ("drive_displacement", "the value of a `joint` declaration"),
    ("rolling", "the value of a `joint` declaration"),
    ("point_velocity", "the value of a `joint` declaration"),
    ("curve", "the value of a `joint` declaration"),
    ("point", "the value of a `force` declaration"),
    ("torque", "the value of a `force` declaration"),
    ("spring", "the value of a `force` declaration"),
    ("damper", "the value of a `force` declaration"),
    ("rotational_spring", "the value of a `force` declaration"),
    ("rotational_damper", "the value of a `force` declaration"),
    ("sphere_plane", "the value of a `contact` declaration"),
    ("sphere_sphere", "the value of a `contact` declaration"),
    ("box_plane", "the value of a `contact` declaration"),
    ("rect", "a beam `shape` or a mesh `generate`"),
    ("circle", "a beam `shape`"),
    ("tube", "a beam `shape`"),
    ("nodes", "a mesh `set`"),
    ("group", "a mesh `set`"),
];

fn span_of_args(args: &[Arg], fallback: Span) -> Span {
    match (args.first(), args.last()) {
        (Some(a), Some(b)) => a.value.span.to(b.value.span),
        _ => fallback,
    }
}

impl Lowerer<'_> {
    // ----------------------------------------------------------------------------------
    // Expressions
    // ----------------------------------------------------------------------------------

    /// Evaluates an expression.
    pub(crate) fn eval(&mut self, e: &Expr, sc: &Scope) -> R<Value> {
        if self.depth >= MAX_EXPR_DEPTH {
            return Err(self.report(
                Diagnostic::error(codes::LIMIT, "expression nested too deeply")
                    .primary(
                        sc.file,
                        e.span,
                        format!("more than {MAX_EXPR_DEPTH} levels"),
                    )
                    .help("split it with `const` declarations"),
            ));
        }
        self.depth += 1;
        let r = self.eval_inner(e, sc);
        self.depth -= 1;
        r
    }

    fn eval_inner(&mut self, e: &Expr, sc: &Scope) -> R<Value> {
        match &e.kind {
            ExprKind::Number { value, unit, .. } => {
                if !value.is_finite() {
                    return Err(self.report(
                        Diagnostic::error(codes::MATH, "number out of range").primary(
                            sc.file,
                            e.span,
                            "too large",
                        ),
                    ));
                }
                let q = Q {
                    f: Fn1::Const(*value),
                    dim: Dim::NONE,
                    poly: *value == 0.0,
                    var: Var::None,
                };
                match unit {
                    None => Ok(Value::Num(q)),
                    Some(u) => self.apply_unit(Value::Num(q), u, sc, e.span),
                }
            }
            ExprKind::WithUnit { expr, unit } => {
                let v = self.eval(expr, sc)?;
                self.apply_unit(v, unit, sc, e.span)
            }
            ExprKind::Str(s) => Ok(Value::Str(s.value.clone())),
            ExprKind::Bool(b) => Ok(Value::Bool(*b)),
            ExprKind::Ident(id) => {
                if sc
                    .env
                    .get(&id.name)
                    .is_some_and(|f| f.kind == BindKind::Failed)
                {
                    // the value's own error is reported where it was declared
                    return Err(Reported);
                }
                Ok(self.lookup(&id.name, id.span, sc))
            }
            ExprKind::Paren(inner) => self.eval(inner, sc),
            ExprKind::Tuple(items) => {
                let mut out = Vec::with_capacity(items.len());
                let mut bad = false;
                for it in items {
                    match self.eval(it, sc) {
                        Ok(v) => out.push(v),
                        Err(_) => bad = true,
                    }
                }
                if bad {
                    Err(Reported)
                } else {
                    Ok(Value::Tuple(out))
                }
            }
            ExprKind::List(items) => {
                let mut out = Vec::with_capacity(items.len());
                let mut bad = false;
                for it in items {
                    match self.eval(it, sc) {
                        Ok(v) => out.push(v),
                        Err(_) => bad = true,
                    }
                }
                if bad {
                    Err(Reported)
                } else {
                    Ok(Value::List(out))
                }
            }
            ExprKind::Index { base, index } => {
                let b = self.eval(base, sc)?;
                let i = self.int(index, sc, "an index")?;
                match b {
                    Value::Name(mut n) => {
                        n.path = format!("{}[{}]", n.path, i);
                        n.span = e.span;
                        Ok(Value::Name(n))
                    }
                    Value::Tuple(items) | Value::List(items) => {
                        let len = items.len();
                        if i < 0 || i as usize >= len {
                            return Err(self.report(
                                Diagnostic::error(
                                    codes::INVALID_VALUE,
                                    format!("index {i} is out of range"),
                                )
                                .primary(
                                    sc.file,
                                    index.span,
                                    format!("valid indices are 0 to {}", len as i64 - 1),
                                ),
                            ));
                        }
                        Ok(items
                            .into_iter()
                            .nth(i as usize)
                            .unwrap_or(Value::Bool(false)))
                    }
                    other => Err(self.report(
                        Diagnostic::error(
                            codes::WRONG_KIND,
                            format!("cannot index {}", other.kind()),
                        )
                        .primary(
                            sc.file,
                            base.span,
                            "not a list, vector or indexed name",
                        ),
                    )),
                }
            }
            ExprKind::Member { base, member } => {
                let b = self.eval(base, sc)?;
                match b {
                    Value::Name(mut n) => {
                        n.path = format!("{}.{}", n.path, member.name);
                        n.span = e.span;
                        Ok(Value::Name(n))
                    }
                    Value::Tuple(items) => {
                        let k = match member.name.as_str() {
                            "x" => 0,
                            "y" => 1,
                            "z" => 2,
                            _ => usize::MAX,
                        };
                        if k >= items.len() {
                            return Err(self.report(
                                Diagnostic::error(
                                    codes::WRONG_KIND,
                                    format!(
                                        "a {}-vector has no component `{}`",
                                        items.len(),
                                        member.name
                                    ),
                                )
                                .primary(
                                    sc.file,
                                    member.span,
                                    "use x, y or z",
                                ),
                            ));
                        }
                        Ok(items.into_iter().nth(k).unwrap_or(Value::Bool(false)))
                    }
                    other => Err(self.report(
                        Diagnostic::error(
                            codes::WRONG_KIND,
                            format!("{} has no member `{}`", other.kind(), member.name),
                        )
                        .primary(sc.file, member.span, ""),
                    )),
                }
            }
            ExprKind::Call { func, args } => self.call(&func.name, func.span, args, e.span, sc),
            ExprKind::Unary {
                op: UnOp::Neg,
                expr,
            } => {
                let v = self.eval(expr, sc)?;
                self.map_num(v, expr.span, sc, &mut |q| {
                    Ok(Q {
                        f: fn1::neg(q.f),
                        ..q
                    })
                })
            }
            ExprKind::Unary {
                op: UnOp::Not,
                expr,
            } => {
                let b = self.boolean(expr, sc)?;
                Ok(Value::Bool(!b))
            }
            ExprKind::Binary { .. } => self.binary_chain(e, sc),
        }
    }

    /// The value of an identifier.
    fn lookup(&mut self, name: &str, span: Span, sc: &Scope) -> Value {
        if let Some(f) = sc.env.get(name) {
            return f.value.clone();
        }
        match name {
            "t" => Value::Num(Q {
                f: Fn1::Var,
                dim: Dim::TIME,
                poly: false,
                var: Var::T,
            }),
            "pi" => Value::Num(Q::num(std::f64::consts::PI)),
            _ => Value::Name(NameRef {
                path: name.to_string(),
                prefix: sc.prefix.clone(),
                file: sc.file,
                span,
            }),
        }
    }

    fn apply_unit(&mut self, v: Value, u: &Unit, sc: &Scope, span: Span) -> R<Value> {
        let (factor, dim) =
            match units::combine(u.factors.iter().map(|(id, e)| (id.name.as_str(), *e))) {
                Ok(x) => x,
                Err("") => {
                    return Err(self.report(
                        Diagnostic::error(codes::UNKNOWN_UNIT, "unit exponent too large")
                            .primary(sc.file, u.span, ""),
                    ))
                }
                Err(name) => {
                    let span = u
                        .factors
                        .iter()
                        .find(|(id, _)| id.name == name)
                        .map(|(id, _)| id.span)
                        .unwrap_or(u.span);
                    let mut d =
                        Diagnostic::error(codes::UNKNOWN_UNIT, format!("unknown unit `{name}`"))
                            .primary(sc.file, span, "not a unit");
                    d = d.help(match suggest::closest(name, units::unit_names()) {
                        Some(c) => format!(
                            "did you mean `{c}`? Units: {}",
                            units::unit_names().collect::<Vec<_>>().join(" ")
                        ),
                        None => format!(
                            "units: {}",
                            units::unit_names().collect::<Vec<_>>().join(" ")
                        ),
                    });
                    return Err(self.report(d));
                }
            };
        let _ = span;
        self.map_num(v, span, sc, &mut |q| {
            let d = q.dim.times(dim).ok_or(())?;
            Ok(Q {
                f: fn1::mul(q.f, Fn1::Const(factor)),
                dim: d,
                poly: false,
                var: q.var,
            })
        })
    }

    /// Applies `f` to every scalar of a value (numbers, tuples, lists).
    fn map_num(
        &mut self,
        v: Value,
        span: Span,
        sc: &Scope,
        f: &mut dyn FnMut(Q) -> Result<Q, ()>,
    ) -> R<Value> {
        match v {
            Value::Num(q) => match f(q) {
                Ok(q) => Ok(Value::Num(q)),
                Err(()) => Err(self.report(
                    Diagnostic::error(codes::UNITS, "unit exponent too large")
                        .primary(sc.file, span, ""),
                )),
            },
            Value::Tuple(items) => {
                let mut out = Vec::with_capacity(items.len());
                for it in items {
                    out.push(self.map_num(it, span, sc, f)?);
                }
                Ok(Value::Tuple(out))
            }
            Value::List(items) => {
                let mut out = Vec::with_capacity(items.len());
                for it in items {
                    out.push(self.map_num(it, span, sc, f)?);
                }
                Ok(Value::List(out))
            }
            Value::Name(n) if self.unit_name(&n).is_some() => {
                let q = self.unit_name(&n).unwrap_or(Q::num(1.0));
                self.map_num(Value::Num(q), span, sc, f)
            }
            other => {
                let q = self.scalar_of(other, span, sc)?;
                self.map_num(Value::Num(q), span, sc, f)
            }
        }
    }

    /// A unit used as a value (`s` in `20/s`).
    fn unit_name(&self, n: &NameRef) -> Option<Q> {
        units::unit(&n.path).map(|u| Q::c(u.factor, u.dim))
    }

    /// Converts a value to a scalar, or reports why it is not one.
    pub(crate) fn scalar_of(&mut self, v: Value, span: Span, sc: &Scope) -> R<Q> {
        match v {
            Value::Num(q) => Ok(q),
            Value::Name(n) => {
                if let Some(q) = self.unit_name(&n) {
                    return Ok(q);
                }
                if self.resolve_any(&n).is_some() {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::WRONG_KIND,
                            format!("expected a number, found the name `{}`", n.path),
                        )
                        .primary(
                            n.file,
                            n.span,
                            "this names a declared item, not a value",
                        ),
                    ));
                }
                Err(self.unknown_value(&n, sc))
            }
            other => Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!("expected a number, found {}", other.kind()),
                )
                .primary(sc.file, span, "not a number"),
            )),
        }
    }

    /// Reports an unknown name used as a value.
    pub(crate) fn unknown_value(&mut self, n: &NameRef, sc: &Scope) -> Reported {
        let mut cands: Vec<String> = sc.env.names().into_iter().map(String::from).collect();
        cands.extend(["t", "pi"].iter().map(|s| s.to_string()));
        cands.extend(self.entity_names());
        let help = suggest::did_you_mean(&n.path, cands.iter().map(|s| s.as_str()));
        let d = Diagnostic::error(codes::UNKNOWN_NAME, format!("unknown name `{}`", n.path))
            .primary(n.file, n.span, "not declared")
            .maybe_help(help);
        self.report(d)
    }

    /// A binary operation. A chain `a + b - c …` (a left-deep tree, as deep as it is long)
    /// is evaluated from its leftmost operand in a loop, so that only the right operands
    /// count against [`MAX_EXPR_DEPTH`] (as the parser counts them against its nesting
    /// limit); `^` ends the walk (it is right-associative).
    fn binary_chain(&mut self, e: &Expr, sc: &Scope) -> R<Value> {
        let mut spine: Vec<&Expr> = Vec::new();
        let mut cur = e;
        while let ExprKind::Binary { op, lhs, .. } = &cur.kind {
            spine.push(cur);
            cur = lhs;
            if *op == BinOp::Pow {
                break;
            }
        }
        let mut value = self.eval(cur, sc)?;
        for node in spine.into_iter().rev() {
            if let ExprKind::Binary { op, lhs, rhs } = &node.kind {
                value = self.binary(*op, value, lhs, rhs, node.span, sc)?;
            }
        }
        Ok(value)
    }

    /// `lhs op rhs`, where `a` is the value of `lhs` (already evaluated).
    fn binary(
        &mut self,
        op: BinOp,
        a: Value,
        lhs: &Expr,
        rhs: &Expr,
        span: Span,
        sc: &Scope,
    ) -> R<Value> {
        match op {
            BinOp::At => {
                let body = match a {
                    Value::Name(n) => n,
                    other => {
                        return Err(self.report(
                            Diagnostic::error(
                                codes::WRONG_KIND,
                                format!(
                                    "the left side of `@` must be a body, found {}",
                                    other.kind()
                                ),
                            )
                            .primary(
                                sc.file,
                                lhs.span,
                                "expected a body name or `ground`",
                            ),
                        ))
                    }
                };
                let point = match self.eval(rhs, sc)? {
                    Value::World(p) => PointSpec::World(p),
                    v => PointSpec::Body(self.vec3_of(
                        v,
                        rhs.span,
                        sc,
                        Dim::LENGTH,
                        "an attachment point",
                    )?),
                };
                Ok(Value::Attach(Box::new(Attach { body, point, span })))
            }
            BinOp::And | BinOp::Or => {
                let a = self.boolean_of(a, lhs, sc)?;
                if op == BinOp::And && !a {
                    return Ok(Value::Bool(false));
                }
                if op == BinOp::Or && a {
                    return Ok(Value::Bool(true));
                }
                let b = self.boolean(rhs, sc)?;
                Ok(Value::Bool(b))
            }
            BinOp::Eq | BinOp::Ne | BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => {
                let b = self.eval(rhs, sc)?;
                match (&a, &b, op) {
                    (Value::Bool(x), Value::Bool(y), BinOp::Eq) => return Ok(Value::Bool(x == y)),
                    (Value::Bool(x), Value::Bool(y), BinOp::Ne) => return Ok(Value::Bool(x != y)),
                    (Value::Str(x), Value::Str(y), BinOp::Eq) => return Ok(Value::Bool(x == y)),
                    (Value::Str(x), Value::Str(y), BinOp::Ne) => return Ok(Value::Bool(x != y)),
                    _ => {}
                }
                let qa = self.scalar_of(a, lhs.span, sc)?;
                let qb = self.scalar_of(b, rhs.span, sc)?;
                self.same_dims(&qa, &qb, lhs.span, rhs.span, sc, "compare")?;
                let x = self.constant_of(&qa, lhs.span, sc, "a comparison operand")?;
                let y = self.constant_of(&qb, rhs.span, sc, "a comparison operand")?;
                let tol = sc.eq_tol;
                let r = match op {
                    BinOp::Eq => (x - y).abs() <= tol,
                    BinOp::Ne => (x - y).abs() > tol,
                    BinOp::Lt => x < y - tol,
                    BinOp::Le => x <= y + tol,
                    BinOp::Gt => x > y + tol,
                    _ => x >= y - tol,
                };
                Ok(Value::Bool(r))
            }
            BinOp::Add | BinOp::Sub => {
                let b = self.eval(rhs, sc)?;
                self.add_values(a, b, op == BinOp::Sub, lhs.span, rhs.span, span, sc)
            }
            BinOp::Mul => {
                let b = self.eval(rhs, sc)?;
                match (a, b) {
                    (Value::Tuple(x), Value::Tuple(_)) => Err(self.report(
                        Diagnostic::error(
                            codes::WRONG_KIND,
                            format!("cannot multiply two vectors ({} items)", x.len()),
                        )
                        .primary(sc.file, span, "")
                        .help("use `dot(a, b)` or `cross(a, b)`"),
                    )),
                    (Value::Tuple(x), b) => {
                        let qb = self.scalar_of(b, rhs.span, sc)?;
                        self.map_num(Value::Tuple(x), lhs.span, sc, &mut |q| mul_q(q, qb.clone()))
                            .and_then(|v| self.check_finite(v, span, sc))
                    }
                    (a, Value::Tuple(y)) => {
                        let qa = self.scalar_of(a, lhs.span, sc)?;
                        self.map_num(Value::Tuple(y), rhs.span, sc, &mut |q| mul_q(qa.clone(), q))
                            .and_then(|v| self.check_finite(v, span, sc))
                    }
                    (a, b) => {
                        let qa = self.scalar_of(a, lhs.span, sc)?;
                        let qb = self.scalar_of(b, rhs.span, sc)?;
                        self.join_var(&qa, &qb, span, sc)?;
                        let q = mul_q(qa, qb).map_err(|_| self.exponent_error(span, sc))?;
                        self.finite(q, span, sc).map(Value::Num)
                    }
                }
            }
            BinOp::Div => {
                let b = self.eval(rhs, sc)?;
                let qb = self.scalar_of(b, rhs.span, sc)?;
                if qb.constant() == Some(0.0) {
                    return Err(self.report(
                        Diagnostic::error(codes::MATH, "division by zero").primary(
                            sc.file,
                            rhs.span,
                            "this is zero",
                        ),
                    ));
                }
                match a {
                    Value::Tuple(x) => self
                        .map_num(Value::Tuple(x), lhs.span, sc, &mut |q| div_q(q, qb.clone()))
                        .and_then(|v| self.check_finite(v, span, sc)),
                    a => {
                        let qa = self.scalar_of(a, lhs.span, sc)?;
                        self.join_var(&qa, &qb, span, sc)?;
                        let q = div_q(qa, qb).map_err(|_| self.exponent_error(span, sc))?;
                        self.finite(q, span, sc).map(Value::Num)
                    }
                }
            }
            BinOp::Rem => {
                let qa = self.scalar_of(a, lhs.span, sc)?;
                let qb = self.num(rhs, sc)?;
                self.same_dims(&qa, &qb, lhs.span, rhs.span, sc, "take the remainder of")?;
                let x = self.constant_of(&qa, lhs.span, sc, "an operand of `%`")?;
                let y = self.constant_of(&qb, rhs.span, sc, "an operand of `%`")?;
                if y == 0.0 {
                    return Err(self.report(
                        Diagnostic::error(codes::MATH, "remainder by zero").primary(
                            sc.file,
                            rhs.span,
                            "this is zero",
                        ),
                    ));
                }
                let r = x - y * (x / y).floor();
                let dim = if qa.poly { qb.dim } else { qa.dim };
                Ok(Value::Num(Q {
                    f: Fn1::Const(r),
                    dim,
                    poly: qa.poly && qb.poly,
                    var: Var::None,
                }))
            }
            BinOp::Pow => {
                let qa = self.scalar_of(a, lhs.span, sc)?;
                let qe = self.num(rhs, sc)?;
                if !qe.dim.is_none() && !qe.poly {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::UNITS,
                            format!(
                                "an exponent must be dimensionless, this is {}",
                                qe.dim.describe()
                            ),
                        )
                        .primary(sc.file, rhs.span, ""),
                    ));
                }
                let p = self.constant_of(&qe, rhs.span, sc, "an exponent")?;
                let dim = if qa.dim.is_none() || qa.poly {
                    Some(Dim::NONE)
                } else {
                    (1..=4).find_map(|den| {
                        let num = p * den as f64;
                        if (num - num.round()).abs() < 1e-9 && num.abs() < 1e6 {
                            qa.dim.pow_ratio(num.round() as i64, den)
                        } else {
                            None
                        }
                    })
                };
                let Some(dim) = dim else {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::UNITS,
                            format!("cannot raise {} to the power {p}", qa.dim.describe()),
                        )
                        .primary(
                            sc.file,
                            span,
                            "the result would have a fractional unit",
                        ),
                    ));
                };
                let dim = if qa.poly { Dim::NONE } else { dim };
                let q = Q {
                    f: fn1::powf(qa.f, p),
                    dim,
                    poly: qa.poly && p > 0.0,
                    var: qa.var,
                };
                self.finite(q, span, sc).map(Value::Num)
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn add_values(
        &mut self,
        a: Value,
        b: Value,
        sub: bool,
        ls: Span,
        rs: Span,
        span: Span,
        sc: &Scope,
    ) -> R<Value> {
        match (a, b) {
            (Value::Tuple(x), Value::Tuple(y)) => {
                if x.len() != y.len() {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::WRONG_KIND,
                            format!(
                                "cannot {} vectors of {} and {} items",
                                if sub { "subtract" } else { "add" },
                                x.len(),
                                y.len()
                            ),
                        )
                        .primary(sc.file, span, ""),
                    ));
                }
                let mut out = Vec::with_capacity(x.len());
                for (p, q) in x.into_iter().zip(y) {
                    out.push(self.add_values(p, q, sub, ls, rs, span, sc)?);
                }
                Ok(Value::Tuple(out))
            }
            (Value::Tuple(x), other) | (other, Value::Tuple(x)) => Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!(
                        "cannot {} a {}-vector and {}",
                        if sub { "subtract" } else { "add" },
                        x.len(),
                        other.kind()
                    ),
                )
                .primary(sc.file, span, ""),
            )),
            (a, b) => {
                let qa = self.scalar_of(a, ls, sc)?;
                let qb = self.scalar_of(b, rs, sc)?;
                self.same_dims(&qa, &qb, ls, rs, sc, if sub { "subtract" } else { "add" })?;
                self.join_var(&qa, &qb, span, sc)?;
                let dim = if qa.poly { qb.dim } else { qa.dim };
                let f = if sub {
                    fn1::sub(qa.f, qb.f)
                } else {
                    fn1::add(qa.f, qb.f)
                };
                let var = qa.var.join(qb.var).unwrap_or(Var::T);
                let q = Q {
                    f,
                    dim,
                    poly: qa.poly && qb.poly,
                    var,
                };
                self.finite(q, span, sc).map(Value::Num)
            }
        }
    }

    fn same_dims(&mut self, a: &Q, b: &Q, ls: Span, rs: Span, sc: &Scope, verb: &str) -> R<()> {
        if a.poly || b.poly || a.dim == b.dim {
            return Ok(());
        }
        Err(self.report(
            Diagnostic::error(
                codes::UNITS,
                format!(
                    "cannot {verb} {} and {}",
                    a.dim.unit_text(),
                    b.dim.unit_text()
                ),
            )
            .primary(sc.file, ls, format!("this is {}", a.dim.describe()))
            .primary(sc.file, rs, format!("this is {}", b.dim.describe())),
        ))
    }

    fn join_var(&mut self, a: &Q, b: &Q, span: Span, sc: &Scope) -> R<Var> {
        a.var.join(b.var).ok_or_else(|| {
            self.report(
                Diagnostic::error(
                    codes::TIME_DEPENDENT,
                    "an expression cannot depend on both `t` and `x`",
                )
                .primary(sc.file, span, ""),
            )
        })
    }

    fn exponent_error(&mut self, span: Span, sc: &Scope) -> Reported {
        self.report(
            Diagnostic::error(codes::UNITS, "unit exponent too large").primary(sc.file, span, ""),
        )
    }

    fn finite(&mut self, q: Q, span: Span, sc: &Scope) -> R<Q> {
        match q.constant() {
            Some(c) if !c.is_finite() => Err(self.report(
                Diagnostic::error(codes::MATH, "the result is not a finite number").primary(
                    sc.file,
                    span,
                    if c.is_nan() {
                        "undefined (NaN)"
                    } else {
                        "infinite"
                    },
                ),
            )),
            _ => Ok(q),
        }
    }

    fn check_finite(&mut self, v: Value, span: Span, sc: &Scope) -> R<Value> {
        match v {
            Value::Num(q) => self.finite(q, span, sc).map(Value::Num),
            Value::Tuple(items) => {
                let mut out = Vec::with_capacity(items.len());
                for it in items {
                    out.push(self.check_finite(it, span, sc)?);
                }
                Ok(Value::Tuple(out))
            }
            v => Ok(v),
        }
    }

    // ----------------------------------------------------------------------------------
    // Function calls
    // ----------------------------------------------------------------------------------

    fn call(&mut self, name: &str, fspan: Span, args: &[Arg], span: Span, sc: &Scope) -> R<Value> {
        if !FUNCTIONS.contains(&name) {
            if let Some((_, place)) = PLACED.iter().find(|(n, _)| *n == name) {
                return Err(self.report(
                    Diagnostic::error(
                        codes::UNKNOWN_FUNCTION,
                        format!("`{name}` is not a function"),
                    )
                    .primary(sc.file, fspan, "not usable in an expression")
                    .help(format!("`{name}(...)` can only be {place}")),
                ));
            }
            let help = suggest::did_you_mean(name, FUNCTIONS.iter().copied());
            return Err(self.report(
                Diagnostic::error(
                    codes::UNKNOWN_FUNCTION,
                    format!("unknown function `{name}`"),
                )
                .primary(sc.file, fspan, "not a function")
                .help(help.unwrap_or_else(|| format!("functions: {}", FUNCTIONS.join(" ")))),
            ));
        }
        if let Some(a) = args.iter().find(|a| a.name.is_some()) {
            let n = a.name.as_ref().map(|n| n.span).unwrap_or(span);
            return Err(self.report(
                Diagnostic::error(
                    codes::ARGUMENT,
                    format!("`{name}` takes no named arguments"),
                )
                .primary(sc.file, n, "remove the name"),
            ));
        }
        let arity: (usize, usize) = match name {
            "atan2" | "dot" | "cross" | "sn" | "cn" | "dn" | "table" => (2, 2),
            "smoothstep" | "diag" => (3, 3),
            "min" | "max" => (2, usize::MAX),
            _ => (1, 1),
        };
        if args.len() < arity.0 || args.len() > arity.1 {
            let want = if arity.0 == arity.1 {
                format!(
                    "{} argument{}",
                    arity.0,
                    if arity.0 == 1 { "" } else { "s" }
                )
            } else {
                format!("at least {} arguments", arity.0)
            };
            return Err(self.report(
                Diagnostic::error(
                    codes::ARGUMENT,
                    format!("`{name}` takes {want}, found {}", args.len()),
                )
                .primary(sc.file, span_of_args(args, span), ""),
            ));
        }
        let a0 = &args[0].value;
        let unary_dimless = |f: UnaryFn| f;
        match name {
            "sin" | "cos" | "tan" | "asin" | "acos" | "atan" | "exp" | "ln" | "tanh" => {
                let q = self.num(a0, sc)?;
                if !q.fits(Dim::NONE) {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::UNITS,
                            format!(
                                "`{name}` needs a dimensionless argument, found {}",
                                q.dim.describe()
                            ),
                        )
                        .primary(sc.file, a0.span, "")
                        .help("angles are dimensionless: write `30 deg` or `0.5 rad`"),
                    ));
                }
                let f = unary_dimless(match name {
                    "sin" => UnaryFn::Sin,
                    "cos" => UnaryFn::Cos,
                    "tan" => UnaryFn::Tan,
                    "asin" => UnaryFn::Asin,
                    "acos" => UnaryFn::Acos,
                    "atan" => UnaryFn::Atan,
                    "exp" => UnaryFn::Exp,
                    "ln" => UnaryFn::Ln,
                    _ => UnaryFn::Tanh,
                });
                let out = Q {
                    f: fn1::unary(f, q.f),
                    dim: Dim::NONE,
                    poly: false,
                    var: q.var,
                };
                self.finite(out, span, sc).map(Value::Num)
            }
            "sqrt" => {
                let q = self.num(a0, sc)?;
                let Some(dim) = (if q.poly {
                    Some(Dim::NONE)
                } else {
                    q.dim.pow_ratio(1, 2)
                }) else {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::UNITS,
                            format!("cannot take the square root of {}", q.dim.describe()),
                        )
                        .primary(
                            sc.file,
                            a0.span,
                            "the result would have a fractional unit",
                        ),
                    ));
                };
                let out = Q {
                    f: fn1::unary(UnaryFn::Sqrt, q.f),
                    dim,
                    poly: q.poly,
                    var: q.var,
                };
                self.finite(out, span, sc).map(Value::Num)
            }
            "abs" => {
                let q = self.num(a0, sc)?;
                Ok(Value::Num(Q {
                    f: fn1::unary(UnaryFn::Abs, q.f),
                    ..q
                }))
            }
            "ramp" => {
                let q = self.num(a0, sc)?;
                Ok(Value::Num(Q {
                    f: fn1::unary(UnaryFn::Ramp, q.f),
                    ..q
                }))
            }
            "step" => {
                let q = self.num(a0, sc)?;
                Ok(Value::Num(Q {
                    f: fn1::unary(UnaryFn::Step, q.f),
                    dim: Dim::NONE,
                    poly: false,
                    var: q.var,
                }))
            }
            "floor" | "ceil" | "round" => {
                let q = self.num(a0, sc)?;
                let c = self.constant_of(&q, a0.span, sc, &format!("the argument of `{name}`"))?;
                let r = match name {
                    "floor" => c.floor(),
                    "ceil" => c.ceil(),
                    _ => c.round(),
                };
                Ok(Value::Num(Q {
                    f: Fn1::Const(r),
                    ..q
                }))
            }
            "min" | "max" => {
                let mut acc = self.num(a0, sc)?;
                for a in &args[1..] {
                    let q = self.num(&a.value, sc)?;
                    self.same_dims(
                        &acc,
                        &q,
                        a0.span,
                        a.value.span,
                        sc,
                        &format!("take the {name} of"),
                    )?;
                    let var = self.join_var(&acc, &q, span, sc)?;
                    let dim = if acc.poly { q.dim } else { acc.dim };
                    let f = if name == "min" {
                        fn1::min(acc.f, q.f)
                    } else {
                        fn1::max(acc.f, q.f)
                    };
                    acc = Q {
                        f,
                        dim,
                        poly: acc.poly && q.poly,
                        var,
                    };
                }
                Ok(Value::Num(acc))
            }
            "atan2" => {
                let y = self.num(a0, sc)?;
                let x = self.num(&args[1].value, sc)?;
                self.same_dims(&y, &x, a0.span, args[1].value.span, sc, "take atan2 of")?;
                let yc = self.constant_of(&y, a0.span, sc, "an argument of `atan2`")?;
                let xc = self.constant_of(&x, args[1].value.span, sc, "an argument of `atan2`")?;
                Ok(Value::Num(Q::num(yc.atan2(xc))))
            }
            "dot" | "cross" => {
                let a = self.vector(a0, sc)?;
                let b = self.vector(&args[1].value, sc)?;
                if a.len() != b.len() || (name == "cross" && a.len() != 3) {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::WRONG_KIND,
                            format!(
                                "`{name}` needs two {} vectors, found {} and {} items",
                                if name == "cross" {
                                    "3-"
                                } else {
                                    "equal-length"
                                },
                                a.len(),
                                b.len()
                            ),
                        )
                        .primary(sc.file, span_of_args(args, span), ""),
                    ));
                }
                if name == "dot" {
                    let mut acc: Option<Q> = None;
                    for (p, q) in a.into_iter().zip(b) {
                        let m = mul_q(p, q).map_err(|_| self.exponent_error(span, sc))?;
                        acc = Some(match acc {
                            None => m,
                            Some(s) => {
                                self.same_dims(&s, &m, a0.span, args[1].value.span, sc, "add")?;
                                let var = self.join_var(&s, &m, span, sc)?;
                                let dim = if s.poly { m.dim } else { s.dim };
                                Q {
                                    f: fn1::add(s.f, m.f),
                                    dim,
                                    poly: s.poly && m.poly,
                                    var,
                                }
                            }
                        });
                    }
                    Ok(Value::Num(acc.unwrap_or(Q::num(0.0))))
                } else {
                    let term = |i: usize, j: usize| -> Result<Q, ()> {
                        let p = mul_q(a[i].clone(), b[j].clone())?;
                        let q = mul_q(a[j].clone(), b[i].clone())?;
                        let dim = if p.poly { q.dim } else { p.dim };
                        Ok(Q {
                            f: fn1::sub(p.f, q.f),
                            dim,
                            poly: p.poly && q.poly,
                            var: p.var.join(q.var).unwrap_or(Var::T),
                        })
                    };
                    let mut out = Vec::new();
                    for (i, j) in [(1, 2), (2, 0), (0, 1)] {
                        out.push(Value::Num(
                            term(i, j).map_err(|_| self.exponent_error(span, sc))?,
                        ));
                    }
                    Ok(Value::Tuple(out))
                }
            }
            "norm" | "normalize" => {
                let a = self.vector(a0, sc)?;
                let mut acc: Option<Q> = None;
                for p in &a {
                    let m =
                        mul_q(p.clone(), p.clone()).map_err(|_| self.exponent_error(span, sc))?;
                    // the components must agree; compare their squares with the running sum
                    if let Some(s) = &acc {
                        self.same_dims(s, &m, a0.span, a0.span, sc, "combine")?;
                    }
                    acc = Some(match acc {
                        None => m,
                        Some(s) => {
                            let var = s.var.join(m.var).unwrap_or(Var::T);
                            let dim = if s.poly { m.dim } else { s.dim };
                            Q {
                                f: fn1::add(s.f, m.f),
                                dim,
                                poly: s.poly && m.poly,
                                var,
                            }
                        }
                    });
                }
                let sq = acc.unwrap_or(Q::num(0.0));
                let dim = if sq.poly {
                    Dim::NONE
                } else {
                    sq.dim.pow_ratio(1, 2).unwrap_or(Dim::NONE)
                };
                let n = Q {
                    f: fn1::unary(UnaryFn::Sqrt, sq.f),
                    dim,
                    poly: sq.poly,
                    var: sq.var,
                };
                if name == "norm" {
                    return Ok(Value::Num(n));
                }
                if n.constant() == Some(0.0) {
                    return Err(self.report(
                        Diagnostic::error(codes::MATH, "cannot normalize a zero vector").primary(
                            sc.file,
                            a0.span,
                            "this is zero",
                        ),
                    ));
                }
                let mut out = Vec::new();
                for p in a {
                    out.push(Value::Num(
                        div_q(p, n.clone()).map_err(|_| self.exponent_error(span, sc))?,
                    ));
                }
                Ok(Value::Tuple(out))
            }
            "smoothstep" => {
                let x = self.num(a0, sc)?;
                let x0 = self.num(&args[1].value, sc)?;
                let x1 = self.num(&args[2].value, sc)?;
                self.same_dims(&x, &x0, a0.span, args[1].value.span, sc, "compare")?;
                self.same_dims(&x, &x1, a0.span, args[2].value.span, sc, "compare")?;
                let c0 =
                    self.constant_of(&x0, args[1].value.span, sc, "the start of a smoothstep")?;
                let c1 =
                    self.constant_of(&x1, args[2].value.span, sc, "the end of a smoothstep")?;
                if c1 <= c0 {
                    return Err(self.report(
                        Diagnostic::error(codes::INVALID_VALUE, "smoothstep needs x0 < x1")
                            .primary(
                                sc.file,
                                args[1].value.span.to(args[2].value.span),
                                format!("{c0} and {c1}"),
                            ),
                    ));
                }
                Ok(Value::Num(Q {
                    f: fn1::smoothstep(x.f, c0, c1),
                    dim: Dim::NONE,
                    poly: false,
                    var: x.var,
                }))
            }
            "table" => {
                let x = self.num(a0, sc)?;
                let list_expr = &args[1].value;
                let items = match self.eval(list_expr, sc)? {
                    Value::List(items) if !items.is_empty() => items,
                    other => {
                        return Err(self.report(
                            Diagnostic::error(
                                codes::WRONG_KIND,
                                format!(
                                    "a table needs a non-empty list of (x, y) pairs, found {}",
                                    other.kind()
                                ),
                            )
                            .primary(sc.file, list_expr.span, "")
                            .help("write `table(t, [(0 s, 0), (1 s, 2)])`"),
                        ))
                    }
                };
                let mut pts = Vec::with_capacity(items.len());
                let mut ydim: Option<Q> = None;
                for it in items {
                    let pair = match it {
                        Value::Tuple(p) if p.len() == 2 => p,
                        other => {
                            return Err(self.report(
                                Diagnostic::error(
                                    codes::WRONG_KIND,
                                    format!(
                                        "a table entry must be a pair (x, y), found {}",
                                        other.kind()
                                    ),
                                )
                                .primary(
                                    sc.file,
                                    list_expr.span,
                                    "",
                                ),
                            ))
                        }
                    };
                    let mut it = pair.into_iter();
                    let (Some(px), Some(py)) = (it.next(), it.next()) else {
                        return Err(Reported);
                    };
                    let qx = self.scalar_of(px, list_expr.span, sc)?;
                    let qy = self.scalar_of(py, list_expr.span, sc)?;
                    self.same_dims(&x, &qx, a0.span, list_expr.span, sc, "compare")?;
                    if let Some(y0) = &ydim {
                        self.same_dims(y0, &qy, list_expr.span, list_expr.span, sc, "tabulate")?;
                    }
                    let cx = self.constant_of(&qx, list_expr.span, sc, "a table entry")?;
                    let cy = self.constant_of(&qy, list_expr.span, sc, "a table entry")?;
                    if let Some(last) = pts.last() {
                        let last: &[f64; 2] = last;
                        if cx <= last[0] {
                            return Err(self.report(
                                Diagnostic::error(
                                    codes::INVALID_VALUE,
                                    "table x values must increase strictly",
                                )
                                .primary(
                                    sc.file,
                                    list_expr.span,
                                    format!("{cx} follows {}", last[0]),
                                ),
                            ));
                        }
                    }
                    pts.push([cx, cy]);
                    if ydim.as_ref().is_none_or(|y: &Q| y.poly) {
                        ydim = Some(qy);
                    }
                }
                let yd = ydim
                    .map(|q| if q.poly { Dim::NONE } else { q.dim })
                    .unwrap_or(Dim::NONE);
                Ok(Value::Num(Q {
                    f: fn1::table(x.f, pts),
                    dim: yd,
                    poly: false,
                    var: x.var,
                }))
            }
            "sn" | "cn" | "dn" => {
                let u = self.num(a0, sc)?;
                let m = self.num(&args[1].value, sc)?;
                self.expect_dim(
                    &u,
                    Dim::NONE,
                    a0.span,
                    sc,
                    "the argument of a Jacobi function",
                )?;
                self.expect_dim(&m, Dim::NONE, args[1].value.span, sc, "the parameter m")?;
                let mc = self.constant_of(&m, args[1].value.span, sc, "the parameter m")?;
                if !(0.0..=1.0).contains(&mc) {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::INVALID_VALUE,
                            format!("the parameter m = {mc} is outside [0, 1]"),
                        )
                        .primary(sc.file, args[1].value.span, ""),
                    ));
                }
                let which = match name {
                    "sn" => 0,
                    "cn" => 1,
                    _ => 2,
                };
                Ok(Value::Num(Q {
                    f: fn1::jacobi(which, u.f, mc),
                    dim: Dim::NONE,
                    poly: false,
                    var: u.var,
                }))
            }
            "ellipk" => {
                let m = self.num(a0, sc)?;
                self.expect_dim(&m, Dim::NONE, a0.span, sc, "the parameter m")?;
                let mc = self.constant_of(&m, a0.span, sc, "the parameter m")?;
                if !(0.0..1.0).contains(&mc) {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::INVALID_VALUE,
                            format!("ellipk(m) needs 0 ≤ m < 1, found {mc}"),
                        )
                        .primary(sc.file, a0.span, ""),
                    ));
                }
                Ok(Value::Num(Q::num(mbdc_runtime::fn1::ellipk(mc))))
            }
            "diag" => {
                let mut d = Vec::new();
                for a in args {
                    d.push(self.num(&a.value, sc)?);
                }
                let zero = || {
                    Value::Num(Q {
                        f: Fn1::Const(0.0),
                        dim: Dim::NONE,
                        poly: true,
                        var: Var::None,
                    })
                };
                let mut rows = Vec::new();
                for (i, q) in d.into_iter().enumerate() {
                    let mut row = vec![zero(), zero(), zero()];
                    row[i] = Value::Num(q);
                    rows.push(Value::Tuple(row));
                }
                Ok(Value::Tuple(rows))
            }
            "world" => {
                let v = self.eval(a0, sc)?;
                let p = self.vec3_of(v, a0.span, sc, Dim::LENGTH, "a world point")?;
                Ok(Value::World(p))
            }
            _ => Err(self.report(
                Diagnostic::error(
                    codes::UNKNOWN_FUNCTION,
                    format!("unknown function `{name}`"),
                )
                .primary(sc.file, fspan, ""),
            )),
        }
    }

    // ----------------------------------------------------------------------------------
    // Typed extraction
    // ----------------------------------------------------------------------------------

    /// Evaluates a scalar.
    pub(crate) fn num(&mut self, e: &Expr, sc: &Scope) -> R<Q> {
        let v = self.eval(e, sc)?;
        self.scalar_of(v, e.span, sc)
    }

    /// Evaluates a vector of scalars (any length ≥ 1).
    pub(crate) fn vector(&mut self, e: &Expr, sc: &Scope) -> R<Vec<Q>> {
        let v = self.eval(e, sc)?;
        self.vector_of(v, e.span, sc)
    }

    fn vector_of(&mut self, v: Value, span: Span, sc: &Scope) -> R<Vec<Q>> {
        match v {
            Value::Tuple(items) => {
                let mut out = Vec::with_capacity(items.len());
                for it in items {
                    out.push(self.scalar_of(it, span, sc)?);
                }
                Ok(out)
            }
            other => Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!("expected a vector, found {}", other.kind()),
                )
                .primary(sc.file, span, "")
                .help("write a vector as `(x, y, z)`"),
            )),
        }
    }

    /// Checks a scalar's dimension.
    pub(crate) fn expect_dim(
        &mut self,
        q: &Q,
        d: Dim,
        span: Span,
        sc: &Scope,
        what: &str,
    ) -> R<()> {
        if q.fits(d) {
            return Ok(());
        }
        let mut diag = Diagnostic::error(
            codes::UNITS,
            format!(
                "{what} must be in {}, found {}",
                d.unit_text(),
                q.dim.unit_text()
            ),
        )
        .primary(sc.file, span, format!("this is {}", q.dim.describe()));
        if q.dim.is_none() {
            if let Some(c) = q.constant() {
                diag = diag.help(format!("add a unit: `{c} {}`", d.unit_text()));
            }
        } else if d.is_none() {
            diag = diag.help(format!("{what} is a plain number"));
        }
        Err(self.report(diag))
    }

    /// The constant value of a scalar, or an error saying it depends on `t` (or `x`).
    pub(crate) fn constant_of(&mut self, q: &Q, span: Span, sc: &Scope, what: &str) -> R<f64> {
        match q.constant() {
            Some(c) => Ok(c),
            None => {
                let var = if q.var == Var::X { "x" } else { "t" };
                Err(self.report(
                    Diagnostic::error(codes::TIME_DEPENDENT, format!("{what} must be constant, but it depends on `{var}`"))
                        .primary(sc.file, span, format!("depends on `{var}`"))
                        .help("functions of time are allowed in forces, drivers, prescribed velocities, mesh loads and reference solutions"),
                ))
            }
        }
    }

    /// A constant scalar of dimension `d`.
    pub(crate) fn const_num(&mut self, e: &Expr, sc: &Scope, d: Dim, what: &str) -> R<f64> {
        let q = self.num(e, sc)?;
        self.expect_dim(&q, d, e.span, sc, what)?;
        self.constant_of(&q, e.span, sc, what)
    }

    /// A scalar of dimension `d` that may depend on `t`.
    pub(crate) fn fn_num(&mut self, e: &Expr, sc: &Scope, d: Dim, what: &str) -> R<Fn1> {
        let q = self.num(e, sc)?;
        self.expect_dim(&q, d, e.span, sc, what)?;
        if q.var == Var::X {
            return Err(self.report(
                Diagnostic::error(
                    codes::TIME_DEPENDENT,
                    format!("{what} cannot depend on `x`"),
                )
                .primary(sc.file, e.span, ""),
            ));
        }
        Ok(q.f)
    }

    /// A dimensionless integer.
    pub(crate) fn int(&mut self, e: &Expr, sc: &Scope, what: &str) -> R<i64> {
        let c = self.const_num(e, sc, Dim::NONE, what)?;
        if c.fract() != 0.0 || c.abs() > 9.0e15 {
            return Err(self.report(
                Diagnostic::error(
                    codes::INVALID_VALUE,
                    format!("{what} must be an integer, found {c}"),
                )
                .primary(sc.file, e.span, "not an integer"),
            ));
        }
        Ok(c as i64)
    }

    /// A boolean.
    pub(crate) fn boolean(&mut self, e: &Expr, sc: &Scope) -> R<bool> {
        let v = self.eval(e, sc)?;
        self.boolean_of(v, e, sc)
    }

    /// The value `v` of `e` as a condition.
    fn boolean_of(&mut self, v: Value, e: &Expr, sc: &Scope) -> R<bool> {
        match v {
            Value::Bool(b) => Ok(b),
            other => Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!(
                        "expected a condition (true or false), found {}",
                        other.kind()
                    ),
                )
                .primary(sc.file, e.span, "")
                .help("compare with `==`, `<`, ... or use `true`/`false`"),
            )),
        }
    }

    /// A constant 3-vector of dimension `d`.
    pub(crate) fn vec3(&mut self, e: &Expr, sc: &Scope, d: Dim, what: &str) -> R<[f64; 3]> {
        let v = self.eval(e, sc)?;
        self.vec3_of(v, e.span, sc, d, what)
    }

    /// A constant vector with 2 or 3 components of dimension `d` (2-D vectors get z = 0).
    pub(crate) fn vec23(&mut self, e: &Expr, sc: &Scope, d: Dim, what: &str) -> R<[f64; 3]> {
        let v = self.eval(e, sc)?;
        let items = self.vector_of(v, e.span, sc)?;
        if items.len() != 2 && items.len() != 3 {
            return Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!("{what} must have 2 or 3 components, found {}", items.len()),
                )
                .primary(sc.file, e.span, ""),
            ));
        }
        let mut out = [0.0; 3];
        for (i, q) in items.iter().enumerate() {
            self.expect_dim(q, d, e.span, sc, what)?;
            out[i] = self.constant_of(q, e.span, sc, what)?;
        }
        Ok(out)
    }

    pub(crate) fn vec3_of(
        &mut self,
        v: Value,
        span: Span,
        sc: &Scope,
        d: Dim,
        what: &str,
    ) -> R<[f64; 3]> {
        let f = self.fvec3_of(v, span, sc, d, what)?;
        let mut out = [0.0; 3];
        for (i, c) in f.iter().enumerate() {
            out[i] = match fn1::as_const(c) {
                Some(x) => x,
                None => {
                    return Err(self.report(
                        Diagnostic::error(codes::TIME_DEPENDENT, format!("{what} must be constant, but it depends on a variable"))
                            .primary(sc.file, span, "depends on `t` or `x`")
                            .help("functions of time are allowed in forces, drivers, prescribed velocities, mesh loads and reference solutions"),
                    ))
                }
            };
        }
        Ok(out)
    }

    /// A 3-vector of dimension `d` whose components may depend on `t`.
    pub(crate) fn fvec3(&mut self, e: &Expr, sc: &Scope, d: Dim, what: &str) -> R<[Fn1; 3]> {
        let v = self.eval(e, sc)?;
        self.fvec3_of(v, e.span, sc, d, what)
    }

    pub(crate) fn fvec3_of(
        &mut self,
        v: Value,
        span: Span,
        sc: &Scope,
        d: Dim,
        what: &str,
    ) -> R<[Fn1; 3]> {
        let items = self.vector_of(v, span, sc)?;
        if items.len() != 3 {
            return Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!(
                        "{what} must be a 3-vector, found {} components",
                        items.len()
                    ),
                )
                .primary(sc.file, span, "")
                .help("write `(x, y, z)`"),
            ));
        }
        let mut out: [Fn1; 3] = [Fn1::Const(0.0), Fn1::Const(0.0), Fn1::Const(0.0)];
        for (i, q) in items.into_iter().enumerate() {
            self.expect_dim(&q, d, span, sc, what)?;
            if q.var == Var::X {
                return Err(self.report(
                    Diagnostic::error(
                        codes::TIME_DEPENDENT,
                        format!("{what} cannot depend on `x`"),
                    )
                    .primary(sc.file, span, ""),
                ));
            }
            out[i] = q.f;
        }
        Ok(out)
    }

    /// A constant 3×3 matrix of dimension `d`.
    pub(crate) fn mat3_of(
        &mut self,
        v: Value,
        span: Span,
        sc: &Scope,
        d: Dim,
        what: &str,
    ) -> R<[[f64; 3]; 3]> {
        let rows = match v {
            Value::Tuple(rows) if rows.len() == 3 => rows,
            other => {
                return Err(self.report(
                    Diagnostic::error(
                        codes::WRONG_KIND,
                        format!("{what} must be a 3×3 matrix, found {}", other.kind()),
                    )
                    .primary(sc.file, span, "")
                    .help("write `((a, b, c), (d, e, f), (g, h, i))` or `diag(a, b, c)`"),
                ))
            }
        };
        let mut out = [[0.0; 3]; 3];
        for (i, r) in rows.into_iter().enumerate() {
            if !matches!(&r, Value::Tuple(x) if x.len() == 3) {
                return Err(self.report(
                    Diagnostic::error(
                        codes::WRONG_KIND,
                        format!("{what} must be a 3×3 matrix: row {} is {}", i + 1, r.kind()),
                    )
                    .primary(sc.file, span, ""),
                ));
            }
            out[i] = self.vec3_of(r, span, sc, d, what)?;
        }
        Ok(out)
    }

    /// A string.
    pub(crate) fn string(&mut self, e: &Expr, sc: &Scope, what: &str) -> R<String> {
        match self.eval(e, sc)? {
            Value::Str(s) => Ok(s),
            other => Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!("{what} must be a string, found {}", other.kind()),
                )
                .primary(sc.file, e.span, "")
                .help("write it in double quotes"),
            )),
        }
    }
}

fn mul_q(a: Q, b: Q) -> Result<Q, ()> {
    let dim = a.dim.times(b.dim).ok_or(())?;
    let var = a.var.join(b.var).unwrap_or(Var::T);
    Ok(Q {
        f: fn1::mul(a.f, b.f),
        dim,
        poly: a.poly || b.poly,
        var,
    })
}

fn div_q(a: Q, b: Q) -> Result<Q, ()> {
    let dim = a.dim.per(b.dim).ok_or(())?;
    let var = a.var.join(b.var).unwrap_or(Var::T);
    Ok(Q {
        f: fn1::div(a.f, b.f),
        dim,
        poly: a.poly,
        var,
    })
}

/// A bare identifier's name, if the expression is one (keyword-like values: `body`,
/// `world`, `start`, `free`, `x`, ...).
pub fn ident_of(e: &Expr) -> Option<&str> {
    match &e.kind {
        ExprKind::Ident(id) => Some(id.name.as_str()),
        _ => None,
    }
}
