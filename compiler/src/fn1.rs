//! Building `Fn1` trees with constant folding, and evaluating them.
//!
//! Every scalar the evaluator computes is an `Fn1`: a constant is `Fn1::Const`, and an
//! expression that uses the variable (`t`, or `x` in a curve) is a tree. The builders here
//! fold constant subtrees as they go, so a tree never contains an operation whose operands
//! are all constants.

use mbdc_runtime::scene::{Fn1, UnaryFn};

/// The constant value of a tree, if it is `Fn1::Const`.
pub fn as_const(f: &Fn1) -> Option<f64> {
    match f {
        Fn1::Const(c) => Some(*c),
        _ => None,
    }
}

fn b(f: Fn1) -> Box<Fn1> {
    Box::new(f)
}

/// `a + b`.
pub fn add(a: Fn1, c: Fn1) -> Fn1 {
    match (as_const(&a), as_const(&c)) {
        (Some(x), Some(y)) => Fn1::Const(x + y),
        (Some(0.0), None) => c,
        (None, Some(0.0)) => a,
        _ => Fn1::Add(b(a), b(c)),
    }
}

/// `a − b`.
pub fn sub(a: Fn1, c: Fn1) -> Fn1 {
    match (as_const(&a), as_const(&c)) {
        (Some(x), Some(y)) => Fn1::Const(x - y),
        (Some(0.0), None) => neg(c),
        (None, Some(0.0)) => a,
        _ => Fn1::Sub(b(a), b(c)),
    }
}

/// `a · b`.
pub fn mul(a: Fn1, c: Fn1) -> Fn1 {
    match (as_const(&a), as_const(&c)) {
        (Some(x), Some(y)) => Fn1::Const(x * y),
        (Some(0.0), None) => Fn1::Const(0.0),
        (None, Some(0.0)) => Fn1::Const(0.0),
        (Some(1.0), None) => c,
        (None, Some(1.0)) => a,
        _ => Fn1::Mul(b(a), b(c)),
    }
}

/// `a / b`.
pub fn div(a: Fn1, c: Fn1) -> Fn1 {
    match (as_const(&a), as_const(&c)) {
        (Some(x), Some(y)) => Fn1::Const(x / y),
        (None, Some(1.0)) => a,
        _ => Fn1::Div(b(a), b(c)),
    }
}

/// `−a`.
pub fn neg(a: Fn1) -> Fn1 {
    match a {
        Fn1::Const(x) => Fn1::Const(-x),
        Fn1::Neg(inner) => *inner,
        a => Fn1::Neg(b(a)),
    }
}

/// `a ^ p`.
pub fn powf(a: Fn1, p: f64) -> Fn1 {
    match as_const(&a) {
        Some(x) => Fn1::Const(pow_const(x, p)),
        None if p == 1.0 => a,
        None if p == 0.0 => Fn1::Const(1.0),
        None => Fn1::Powf(b(a), p),
    }
}

fn pow_const(x: f64, p: f64) -> f64 {
    if p.fract() == 0.0 && p.abs() < i32::MAX as f64 {
        x.powi(p as i32)
    } else {
        x.powf(p)
    }
}

/// A unary function.
pub fn unary(f: UnaryFn, a: Fn1) -> Fn1 {
    match as_const(&a) {
        Some(x) => Fn1::Const(unary_const(f, x)),
        None => Fn1::Unary(f, b(a)),
    }
}

/// `min(a, b)`.
pub fn min(a: Fn1, c: Fn1) -> Fn1 {
    match (as_const(&a), as_const(&c)) {
        (Some(x), Some(y)) => Fn1::Const(x.min(y)),
        _ => Fn1::Min(b(a), b(c)),
    }
}

/// `max(a, b)`.
pub fn max(a: Fn1, c: Fn1) -> Fn1 {
    match (as_const(&a), as_const(&c)) {
        (Some(x), Some(y)) => Fn1::Const(x.max(y)),
        _ => Fn1::Max(b(a), b(c)),
    }
}

/// `smoothstep(a, x0, x1)`.
pub fn smoothstep(a: Fn1, x0: f64, x1: f64) -> Fn1 {
    match as_const(&a) {
        Some(x) => Fn1::Const(smoothstep_const(x, x0, x1)),
        None => Fn1::Smoothstep(b(a), x0, x1),
    }
}

/// `table(a, points)`.
pub fn table(a: Fn1, pts: Vec<[f64; 2]>) -> Fn1 {
    match as_const(&a) {
        Some(x) => Fn1::Const(table_const(x, &pts)),
        None => Fn1::Table(b(a), pts),
    }
}

/// Jacobi elliptic functions: `which` is 0 (sn), 1 (cn) or 2 (dn).
pub fn jacobi(which: u8, a: Fn1, m: f64) -> Fn1 {
    match as_const(&a) {
        Some(u) => {
            let (sn, cn, dn) = mbdc_runtime::fn1::sncndn(u, m);
            Fn1::Const([sn, cn, dn][which.min(2) as usize])
        }
        None => match which {
            0 => Fn1::JacobiSn(b(a), m),
            1 => Fn1::JacobiCn(b(a), m),
            _ => Fn1::JacobiDn(b(a), m),
        },
    }
}

/// Value of a unary function at a constant.
pub fn unary_const(f: UnaryFn, x: f64) -> f64 {
    match f {
        UnaryFn::Sin => x.sin(),
        UnaryFn::Cos => x.cos(),
        UnaryFn::Tan => x.tan(),
        UnaryFn::Asin => x.asin(),
        UnaryFn::Acos => x.acos(),
        UnaryFn::Atan => x.atan(),
        UnaryFn::Sqrt => x.sqrt(),
        UnaryFn::Exp => x.exp(),
        UnaryFn::Ln => x.ln(),
        UnaryFn::Abs => x.abs(),
        UnaryFn::Step => {
            if x >= 0.0 {
                1.0
            } else {
                0.0
            }
        }
        UnaryFn::Ramp => x.max(0.0),
        UnaryFn::Tanh => x.tanh(),
    }
}

/// `smoothstep(x, x0, x1)` at a constant.
pub fn smoothstep_const(x: f64, x0: f64, x1: f64) -> f64 {
    if x <= x0 {
        0.0
    } else if x >= x1 {
        1.0
    } else {
        let s = (x - x0) / (x1 - x0);
        s * s * (3.0 - 2.0 * s)
    }
}

/// Piecewise-linear table at a constant (points sorted by x, at least one).
pub fn table_const(x: f64, pts: &[[f64; 2]]) -> f64 {
    let (Some(first), Some(last)) = (pts.first(), pts.last()) else {
        return 0.0;
    };
    if x <= first[0] {
        return first[1];
    }
    if x >= last[0] {
        return last[1];
    }
    for w in pts.windows(2) {
        let (p, q) = (w[0], w[1]);
        if x <= q[0] {
            let dx = q[0] - p[0];
            if dx <= 0.0 {
                return q[1];
            }
            return p[1] + (q[1] - p[1]) * (x - p[0]) / dx;
        }
    }
    last[1]
}

/// Evaluates a tree at a value of its variable (the runtime's evaluator).
pub fn eval(f: &Fn1, x: f64) -> f64 {
    mbdc_runtime::fn1::value(f, x)
}

/// Depth of a tree (for limits).
pub fn depth(f: &Fn1) -> usize {
    match f {
        Fn1::Const(_) | Fn1::Var => 1,
        Fn1::Add(a, c)
        | Fn1::Sub(a, c)
        | Fn1::Mul(a, c)
        | Fn1::Div(a, c)
        | Fn1::Min(a, c)
        | Fn1::Max(a, c) => 1 + depth(a).max(depth(c)),
        Fn1::Neg(a)
        | Fn1::Powf(a, _)
        | Fn1::Unary(_, a)
        | Fn1::Smoothstep(a, ..)
        | Fn1::Table(a, _)
        | Fn1::JacobiSn(a, _)
        | Fn1::JacobiCn(a, _)
        | Fn1::JacobiDn(a, _) => 1 + depth(a),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folding() {
        assert_eq!(add(Fn1::Const(1.0), Fn1::Const(2.0)), Fn1::Const(3.0));
        assert_eq!(mul(Fn1::Const(0.0), Fn1::Var), Fn1::Const(0.0));
        assert_eq!(mul(Fn1::Const(1.0), Fn1::Var), Fn1::Var);
        assert_eq!(neg(neg(Fn1::Var)), Fn1::Var);
        let f = unary(UnaryFn::Sin, mul(Fn1::Const(2.0), Fn1::Var));
        assert!((eval(&f, 0.25) - 0.5f64.sin()).abs() < 1e-15);
        assert_eq!(unary(UnaryFn::Sqrt, Fn1::Const(4.0)), Fn1::Const(2.0));
    }

    #[test]
    fn tables_and_steps() {
        let pts = vec![[0.0, 0.0], [1.0, 2.0], [3.0, 2.0]];
        assert_eq!(table_const(-1.0, &pts), 0.0);
        assert_eq!(table_const(0.5, &pts), 1.0);
        assert_eq!(table_const(10.0, &pts), 2.0);
        assert_eq!(smoothstep_const(0.5, 0.0, 1.0), 0.5);
        assert_eq!(unary_const(UnaryFn::Step, 0.0), 1.0);
    }
}
