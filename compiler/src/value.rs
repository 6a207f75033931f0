//! Values produced by evaluating expressions.

use std::fmt;

use mbdc_dsl::ast::Span;
use mbdc_runtime::scene::Fn1;

use crate::fn1;
use crate::source::FileId;
use crate::units::Dim;

/// Which variable `Fn1::Var` stands for in a scalar.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Var {
    /// The scalar is a constant.
    None,
    /// Time `t`, s.
    T,
    /// The curve coordinate `x`, m.
    X,
}

impl Var {
    /// The variable of a combination, `None` if two different variables meet.
    pub fn join(self, o: Var) -> Option<Var> {
        match (self, o) {
            (Var::None, v) | (v, Var::None) => Some(v),
            (a, b) if a == b => Some(a),
            _ => None,
        }
    }
}

/// A scalar quantity: an `Fn1` in SI units with its dimension.
#[derive(Clone, Debug, PartialEq)]
pub struct Q {
    /// Value (a constant, or a function of `var`).
    pub f: Fn1,
    /// Dimension.
    pub dim: Dim,
    /// A bare literal zero (no unit): fits any dimension.
    pub poly: bool,
    /// The variable `f` depends on.
    pub var: Var,
}

impl Q {
    /// A constant with a dimension.
    pub fn c(v: f64, dim: Dim) -> Q {
        Q {
            f: Fn1::Const(v),
            dim,
            poly: false,
            var: Var::None,
        }
    }

    /// A dimensionless constant.
    pub fn num(v: f64) -> Q {
        Q::c(v, Dim::NONE)
    }

    /// The constant value, if constant.
    pub fn constant(&self) -> Option<f64> {
        fn1::as_const(&self.f)
    }

    /// Whether the quantity fits dimension `d` (always true for a bare zero).
    pub fn fits(&self, d: Dim) -> bool {
        self.poly || self.dim == d
    }
}

/// A reference to a named thing (body, joint, set, material, ...) that is resolved when it
/// is used, so that declarations may refer to items declared later.
#[derive(Clone, Debug, PartialEq)]
pub struct NameRef {
    /// The path as written, with evaluated indices: `link[3]`, `left.bob`.
    pub path: String,
    /// The instance prefix in effect where it was written (`arm.` inside instance `arm`),
    /// tried first, then its parents, then the global name.
    pub prefix: String,
    /// Where it was written.
    pub file: FileId,
    /// Span of the reference.
    pub span: Span,
}

impl NameRef {
    /// Candidate full names, innermost prefix first.
    pub fn candidates(&self) -> Vec<String> {
        if self.path == "ground" {
            return vec!["ground".into()];
        }
        let mut out = Vec::new();
        let mut prefix = self.prefix.as_str();
        loop {
            out.push(format!("{prefix}{}", self.path));
            if prefix.is_empty() {
                break;
            }
            // Strip the last segment `name.` from the prefix.
            let trimmed = &prefix[..prefix.len() - 1];
            prefix = match trimmed.rfind('.') {
                Some(i) => &prefix[..i + 1],
                None => "",
            };
        }
        out
    }
}

/// Where an attachment point is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointSpec {
    /// In the body's axes relative to its mass centre (world for ground), m.
    Body([f64; 3]),
    /// In world coordinates at the initial configuration, m.
    World([f64; 3]),
}

/// `BODY @ POINT`.
#[derive(Clone, Debug, PartialEq)]
pub struct Attach {
    /// The body (or ground).
    pub body: NameRef,
    /// The point.
    pub point: PointSpec,
    /// Span of the whole attachment expression.
    pub span: Span,
}

/// A value.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A scalar quantity.
    Num(Q),
    /// A tuple `(a, b, ...)`: vectors, matrices (tuples of tuples), pairs.
    Tuple(Vec<Value>),
    /// A list `[a, b, ...]`.
    List(Vec<Value>),
    /// A string.
    Str(String),
    /// A boolean.
    Bool(bool),
    /// A name that is not a value in scope: a body, joint, set, ... (or a unit name, when
    /// used as a number, so that `20/s` means 20 per second).
    Name(NameRef),
    /// An attachment.
    Attach(Box<Attach>),
    /// `world(P)`: a point in world coordinates.
    World([f64; 3]),
}

impl Value {
    /// What kind of value this is, for messages: "a number", "a 3-vector", ...
    pub fn kind(&self) -> String {
        match self {
            Value::Num(q) if q.var == Var::T => "a function of time".into(),
            Value::Num(q) if q.var == Var::X => "a function of x".into(),
            Value::Num(q) => {
                if q.poly || q.dim.is_none() {
                    "a number".into()
                } else {
                    format!("a quantity in {}", q.dim.describe())
                }
            }
            Value::Tuple(v) => {
                if v.iter().all(|e| matches!(e, Value::Tuple(_))) {
                    "a matrix".into()
                } else {
                    format!("a {}-vector", v.len())
                }
            }
            Value::List(v) => format!("a list of {} items", v.len()),
            Value::Str(_) => "a string".into(),
            Value::Bool(_) => "a boolean".into(),
            Value::Name(n) => format!("the name `{}`", n.path),
            Value::Attach(_) => "an attachment (`body @ point`)".into(),
            Value::World(_) => "a world point".into(),
        }
    }
}

impl fmt::Display for Q {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.constant() {
            Some(c) if self.dim.is_none() || self.poly => write!(f, "{c}"),
            Some(c) => write!(f, "{c} {}", self.dim.unit_text()),
            None => write!(f, "<function> {}", self.dim.unit_text()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn name_candidates() {
        let n = NameRef {
            path: "bob".into(),
            prefix: "a.b.".into(),
            file: FileId(0),
            span: Span::default(),
        };
        assert_eq!(n.candidates(), vec!["a.b.bob", "a.bob", "bob"]);
        let g = NameRef {
            path: "ground".into(),
            prefix: "a.".into(),
            file: FileId(0),
            span: Span::default(),
        };
        assert_eq!(g.candidates(), vec!["ground"]);
    }
}
