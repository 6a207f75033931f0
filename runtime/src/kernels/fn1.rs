//! Scalar functions of one variable with their first two derivatives.
//!
//! [`Jet2`] is a second-order Taylor ("hyper-dual") number `{v, d1, d2}` representing a
//! quantity `g(x)` together with `g'(x)` and `g''(x)`. Arithmetic on jets applies the chain
//! and product rules exactly:
//!
//! ```text
//! (a·b)'' = a''b + 2a'b' + ab''        f(a)'' = f'(a) a'' + f''(a) a'²
//! ```
//!
//! [`eval`] evaluates a [`Fn1`] expression tree at `x` as a jet (value, `d/dx`, `d²/dx²`),
//! recursively and without allocation. Drivers use it with `x = t` to get `f(t), ḟ, f̈`;
//! the curve joint uses it with `x` a coordinate. Generated code builds the same jets
//! with the same operations (e.g. `(Jet2::var(t) * 2.0).sin()`), so both paths agree to
//! round-off.
//!
//! Non-smooth functions (`abs`, `step`, `ramp`, `min`, `max`, tables) use the one-sided
//! derivative on the side `x ≥ breakpoint` (the same side where `step(0) = 1`).
//!
//! The Jacobi elliptic functions [`sncndn`] (parameter `m = k²`) and the complete elliptic
//! integral [`ellipk`] are public so that the compiler can constant-fold them.

use crate::contract::scene::{Fn1, UnaryFn};

/// Deepest time-function expression tree (the compiler nests expressions at most 200
/// deep; evaluation is recursive, so this bounds the stack it uses).
pub const MAX_FN_DEPTH: usize = 256;

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A value with its first and second derivative with respect to one variable.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Jet2 {
    /// Value `g(x)`.
    pub v: f64,
    /// First derivative `g'(x)`.
    pub d1: f64,
    /// Second derivative `g''(x)`.
    pub d2: f64,
}

impl Jet2 {
    /// A jet from its three parts.
    #[inline]
    pub const fn new(v: f64, d1: f64, d2: f64) -> Jet2 {
        Jet2 { v, d1, d2 }
    }

    /// A constant (zero derivatives).
    #[inline]
    pub const fn constant(v: f64) -> Jet2 {
        Jet2 {
            v,
            d1: 0.0,
            d2: 0.0,
        }
    }

    /// The independent variable at `x` (`d1 = 1`, `d2 = 0`).
    #[inline]
    pub const fn var(x: f64) -> Jet2 {
        Jet2 {
            v: x,
            d1: 1.0,
            d2: 0.0,
        }
    }

    /// Apply a scalar function given its value `f`, first derivative `f1` and second
    /// derivative `f2` at `self.v` (chain rule). Terms multiplied by a zero derivative of
    /// `self` are skipped, so that constants stay finite where `f'` or `f''` is infinite
    /// (e.g. `sqrt(0)` of a constant).
    #[inline]
    pub fn chain(self, f: f64, f1: f64, f2: f64) -> Jet2 {
        let mut d1 = 0.0;
        let mut d2 = 0.0;
        if self.d1 != 0.0 {
            d1 = f1 * self.d1;
            d2 = f2 * self.d1 * self.d1;
        }
        if self.d2 != 0.0 {
            d2 += f1 * self.d2;
        }
        Jet2 { v: f, d1, d2 }
    }

    /// `sin`.
    #[inline]
    pub fn sin(self) -> Jet2 {
        let (s, c) = self.v.sin_cos();
        self.chain(s, c, -s)
    }
    /// `cos`.
    #[inline]
    pub fn cos(self) -> Jet2 {
        let (s, c) = self.v.sin_cos();
        self.chain(c, -s, -c)
    }
    /// `tan`.
    #[inline]
    pub fn tan(self) -> Jet2 {
        let t = self.v.tan();
        let s = 1.0 + t * t;
        self.chain(t, s, 2.0 * t * s)
    }
    /// `asin`.
    #[inline]
    pub fn asin(self) -> Jet2 {
        let x = self.v;
        let r = 1.0 / (1.0 - x * x).sqrt();
        self.chain(x.asin(), r, x * r * r * r)
    }
    /// `acos`.
    #[inline]
    pub fn acos(self) -> Jet2 {
        let x = self.v;
        let r = 1.0 / (1.0 - x * x).sqrt();
        self.chain(x.acos(), -r, -x * r * r * r)
    }
    /// `atan`.
    #[inline]
    pub fn atan(self) -> Jet2 {
        let x = self.v;
        let r = 1.0 / (1.0 + x * x);
        self.chain(x.atan(), r, -2.0 * x * r * r)
    }
    /// `sqrt`.
    #[inline]
    pub fn sqrt(self) -> Jet2 {
        let s = self.v.sqrt();
        self.chain(s, 0.5 / s, -0.25 / (s * s * s))
    }
    /// `exp`.
    #[inline]
    pub fn exp(self) -> Jet2 {
        let e = self.v.exp();
        self.chain(e, e, e)
    }
    /// Natural logarithm.
    #[inline]
    pub fn ln(self) -> Jet2 {
        let r = 1.0 / self.v;
        self.chain(self.v.ln(), r, -r * r)
    }
    /// `tanh`.
    #[inline]
    pub fn tanh(self) -> Jet2 {
        let t = self.v.tanh();
        let s = 1.0 - t * t;
        self.chain(t, s, -2.0 * t * s)
    }
    /// `|x|` (derivative `+1` at 0).
    #[inline]
    pub fn abs(self) -> Jet2 {
        if self.v >= 0.0 {
            self
        } else {
            -self
        }
    }
    /// Heaviside step: 0 for `x < 0`, 1 for `x ≥ 0`; derivatives 0.
    #[inline]
    pub fn step(self) -> Jet2 {
        Jet2::constant(if self.v >= 0.0 { 1.0 } else { 0.0 })
    }
    /// `max(0, x)` (derivative 1 at 0).
    #[inline]
    pub fn ramp(self) -> Jet2 {
        if self.v >= 0.0 {
            self
        } else {
            Jet2::constant(0.0)
        }
    }
    /// `x^n` for a constant exponent `n`. `n = 0` gives 1, `n = 1` the argument itself.
    #[inline]
    pub fn powf(self, n: f64) -> Jet2 {
        if n == 0.0 {
            return Jet2::constant(1.0);
        }
        if n == 1.0 {
            return self;
        }
        if n == 2.0 {
            return self * self;
        }
        let x = self.v;
        self.chain(
            x.powf(n),
            n * x.powf(n - 1.0),
            n * (n - 1.0) * x.powf(n - 2.0),
        )
    }
    /// `min(self, b)` (ties pick `self`).
    #[inline]
    pub fn min(self, b: Jet2) -> Jet2 {
        if b.v < self.v {
            b
        } else {
            self
        }
    }
    /// `max(self, b)` (ties pick `self`).
    #[inline]
    pub fn max(self, b: Jet2) -> Jet2 {
        if b.v > self.v {
            b
        } else {
            self
        }
    }
    /// `smoothstep(self, x0, x1)`: 0 for `x ≤ x0`, 1 for `x ≥ x1`, `3s² − 2s³` with
    /// `s = (x − x0)/(x1 − x0)` between. `x1 ≤ x0` degenerates to a step at `x0`.
    #[inline]
    pub fn smoothstep(self, x0: f64, x1: f64) -> Jet2 {
        if x1 <= x0 {
            return Jet2::constant(if self.v >= x0 { 1.0 } else { 0.0 });
        }
        if self.v <= x0 {
            return Jet2::constant(0.0);
        }
        if self.v >= x1 {
            return Jet2::constant(1.0);
        }
        let w = x1 - x0;
        let s = (self.v - x0) / w;
        let f = s * s * (3.0 - 2.0 * s);
        let f1 = 6.0 * s * (1.0 - s) / w;
        let f2 = (6.0 - 12.0 * s) / (w * w);
        self.chain(f, f1, f2)
    }
    /// Piecewise-linear interpolation in `table` (points `(x_i, y_i)` with increasing
    /// `x_i`), constant beyond the ends. The derivative is that of the segment containing
    /// `x` (the right segment at a breakpoint); the second derivative is 0. An empty table
    /// gives 0.
    #[inline]
    pub fn table(self, table: &[[f64; 2]]) -> Jet2 {
        let (y, slope) = table_eval(table, self.v);
        self.chain(y, slope, 0.0)
    }
    /// Jacobi `sn(self | m)`: `sn' = cn·dn`, `sn'' = −sn (dn² + m cn²)`.
    #[inline]
    pub fn jacobi_sn(self, m: f64) -> Jet2 {
        let (s, c, d) = sncndn(self.v, m);
        self.chain(s, c * d, -s * (d * d + m * c * c))
    }
    /// Jacobi `cn(self | m)`: `cn' = −sn·dn`, `cn'' = −cn (dn² − m sn²)`.
    #[inline]
    pub fn jacobi_cn(self, m: f64) -> Jet2 {
        let (s, c, d) = sncndn(self.v, m);
        self.chain(c, -s * d, -c * (d * d - m * s * s))
    }
    /// Jacobi `dn(self | m)`: `dn' = −m sn·cn`, `dn'' = −m dn (cn² − sn²)`.
    #[inline]
    pub fn jacobi_dn(self, m: f64) -> Jet2 {
        let (s, c, d) = sncndn(self.v, m);
        self.chain(d, -m * s * c, -m * d * (c * c - s * s))
    }
}

impl Add for Jet2 {
    type Output = Jet2;
    #[inline]
    fn add(self, b: Jet2) -> Jet2 {
        Jet2 {
            v: self.v + b.v,
            d1: self.d1 + b.d1,
            d2: self.d2 + b.d2,
        }
    }
}
impl Sub for Jet2 {
    type Output = Jet2;
    #[inline]
    fn sub(self, b: Jet2) -> Jet2 {
        Jet2 {
            v: self.v - b.v,
            d1: self.d1 - b.d1,
            d2: self.d2 - b.d2,
        }
    }
}
impl Mul for Jet2 {
    type Output = Jet2;
    #[inline]
    fn mul(self, b: Jet2) -> Jet2 {
        Jet2 {
            v: self.v * b.v,
            d1: self.d1 * b.v + self.v * b.d1,
            d2: self.d2 * b.v + 2.0 * self.d1 * b.d1 + self.v * b.d2,
        }
    }
}
impl Div for Jet2 {
    type Output = Jet2;
    #[inline]
    fn div(self, b: Jet2) -> Jet2 {
        let v = self.v / b.v;
        let d1 = (self.d1 - v * b.d1) / b.v;
        let d2 = (self.d2 - 2.0 * d1 * b.d1 - v * b.d2) / b.v;
        Jet2 { v, d1, d2 }
    }
}
impl Neg for Jet2 {
    type Output = Jet2;
    #[inline]
    fn neg(self) -> Jet2 {
        Jet2 {
            v: -self.v,
            d1: -self.d1,
            d2: -self.d2,
        }
    }
}
impl Add<f64> for Jet2 {
    type Output = Jet2;
    #[inline]
    fn add(self, b: f64) -> Jet2 {
        Jet2 {
            v: self.v + b,
            ..self
        }
    }
}
impl Sub<f64> for Jet2 {
    type Output = Jet2;
    #[inline]
    fn sub(self, b: f64) -> Jet2 {
        Jet2 {
            v: self.v - b,
            ..self
        }
    }
}
impl Mul<f64> for Jet2 {
    type Output = Jet2;
    #[inline]
    fn mul(self, b: f64) -> Jet2 {
        Jet2 {
            v: self.v * b,
            d1: self.d1 * b,
            d2: self.d2 * b,
        }
    }
}
impl Div<f64> for Jet2 {
    type Output = Jet2;
    #[inline]
    fn div(self, b: f64) -> Jet2 {
        Jet2 {
            v: self.v / b,
            d1: self.d1 / b,
            d2: self.d2 / b,
        }
    }
}
impl Add<Jet2> for f64 {
    type Output = Jet2;
    #[inline]
    fn add(self, b: Jet2) -> Jet2 {
        b + self
    }
}
impl Sub<Jet2> for f64 {
    type Output = Jet2;
    #[inline]
    fn sub(self, b: Jet2) -> Jet2 {
        -b + self
    }
}
impl Mul<Jet2> for f64 {
    type Output = Jet2;
    #[inline]
    fn mul(self, b: Jet2) -> Jet2 {
        b * self
    }
}
impl Div<Jet2> for f64 {
    type Output = Jet2;
    #[inline]
    fn div(self, b: Jet2) -> Jet2 {
        Jet2::constant(self) / b
    }
}

/// Value and slope of the piecewise-linear table at `x` (see [`Jet2::table`]).
pub fn table_eval(table: &[[f64; 2]], x: f64) -> (f64, f64) {
    let n = table.len();
    if n == 0 {
        return (0.0, 0.0);
    }
    if x.is_nan() {
        return (f64::NAN, f64::NAN);
    }
    if x < table[0][0] {
        return (table[0][1], 0.0);
    }
    if x >= table[n - 1][0] {
        return (table[n - 1][1], 0.0);
    }
    // Largest i with x_i ≤ x (binary search); then x_i ≤ x < x_{i+1}.
    let i = table.partition_point(|p| p[0] <= x) - 1;
    let ([x0, y0], [x1, y1]) = (table[i], table[i + 1]);
    let slope = (y1 - y0) / (x1 - x0);
    (y0 + slope * (x - x0), slope)
}

/// Evaluate `f` at `x` with its first and second derivative with respect to `x`.
/// Recursive over the expression tree; no allocation.
pub fn eval(f: &Fn1, x: f64) -> Jet2 {
    match f {
        Fn1::Const(c) => Jet2::constant(*c),
        Fn1::Var => Jet2::var(x),
        Fn1::Add(a, b) => eval(a, x) + eval(b, x),
        Fn1::Sub(a, b) => eval(a, x) - eval(b, x),
        Fn1::Mul(a, b) => eval(a, x) * eval(b, x),
        Fn1::Div(a, b) => eval(a, x) / eval(b, x),
        Fn1::Neg(a) => -eval(a, x),
        Fn1::Powf(a, n) => eval(a, x).powf(*n),
        Fn1::Unary(u, a) => unary(*u, eval(a, x)),
        Fn1::Min(a, b) => eval(a, x).min(eval(b, x)),
        Fn1::Max(a, b) => eval(a, x).max(eval(b, x)),
        Fn1::Smoothstep(a, x0, x1) => eval(a, x).smoothstep(*x0, *x1),
        Fn1::Table(a, t) => eval(a, x).table(t),
        Fn1::JacobiSn(a, m) => eval(a, x).jacobi_sn(*m),
        Fn1::JacobiCn(a, m) => eval(a, x).jacobi_cn(*m),
        Fn1::JacobiDn(a, m) => eval(a, x).jacobi_dn(*m),
    }
}

/// The value of `f` at `x` (the `v` part of [`eval`]).
#[inline]
pub fn value(f: &Fn1, x: f64) -> f64 {
    eval(f, x).v
}

/// Apply a [`UnaryFn`] to a jet.
#[inline]
pub fn unary(u: UnaryFn, a: Jet2) -> Jet2 {
    match u {
        UnaryFn::Sin => a.sin(),
        UnaryFn::Cos => a.cos(),
        UnaryFn::Tan => a.tan(),
        UnaryFn::Asin => a.asin(),
        UnaryFn::Acos => a.acos(),
        UnaryFn::Atan => a.atan(),
        UnaryFn::Sqrt => a.sqrt(),
        UnaryFn::Exp => a.exp(),
        UnaryFn::Ln => a.ln(),
        UnaryFn::Abs => a.abs(),
        UnaryFn::Step => a.step(),
        UnaryFn::Ramp => a.ramp(),
        UnaryFn::Tanh => a.tanh(),
    }
}

/// Check that `f` can be evaluated: tables non-empty with strictly increasing `x`,
/// finite constants and parameters, elliptic parameters in `[0, 1]`, and the tree at most
/// [`MAX_FN_DEPTH`] deep (evaluation is recursive). Returns a description
/// of the first problem.
pub fn validate(f: &Fn1) -> Result<(), String> {
    validate_at(f, 1)
}

fn validate_at(f: &Fn1, depth: usize) -> Result<(), String> {
    let max = MAX_FN_DEPTH;
    if depth > max {
        return Err(format!(
            "the expression is nested too deeply (more than {max} levels)"
        ));
    }
    let sub = |a: &Fn1| validate_at(a, depth + 1);
    let finite = |c: f64, what: &str| {
        if c.is_finite() {
            Ok(())
        } else {
            Err(format!("{what} {c} is not finite"))
        }
    };
    match f {
        Fn1::Const(c) => finite(*c, "constant"),
        Fn1::Var => Ok(()),
        Fn1::Add(a, b)
        | Fn1::Sub(a, b)
        | Fn1::Mul(a, b)
        | Fn1::Div(a, b)
        | Fn1::Min(a, b)
        | Fn1::Max(a, b) => sub(a).and_then(|_| sub(b)),
        Fn1::Neg(a) | Fn1::Unary(_, a) => sub(a),
        Fn1::Powf(a, n) => finite(*n, "exponent").and_then(|_| sub(a)),
        Fn1::Smoothstep(a, x0, x1) => {
            finite(*x0, "smoothstep start")?;
            finite(*x1, "smoothstep end")?;
            sub(a)
        }
        Fn1::Table(a, t) => {
            if t.is_empty() {
                return Err("table has no points".into());
            }
            for p in t {
                finite(p[0], "table x")?;
                finite(p[1], "table y")?;
            }
            if let Some(w) = t.windows(2).find(|w| w[1][0] <= w[0][0]) {
                return Err(format!(
                    "table x values must increase strictly ({} is followed by {})",
                    w[0][0], w[1][0]
                ));
            }
            sub(a)
        }
        Fn1::JacobiSn(a, m) | Fn1::JacobiCn(a, m) | Fn1::JacobiDn(a, m) => {
            if !(0.0..=1.0).contains(m) {
                return Err(format!("elliptic parameter m = {m} must lie in [0, 1]"));
            }
            sub(a)
        }
    }
}

/// Jacobi elliptic functions `(sn, cn, dn)` of argument `u` and parameter `m = k²`.
///
/// Bulirsch's descending Landen (Gauss) transformation, as in Numerical Recipes'
/// `sncndn`: the arithmetic–geometric mean of `1` and `k' = √(1 − m)` is iterated until
/// the terms agree to `1e-8` (after which the next quadratic step is exact to
/// round-off), then `sn, cn, dn` are recovered by the descending recursion. Accurate to
/// a few ulps times `|u|` for `0 ≤ m ≤ 1`. Special cases: `m = 0` gives `(sin, cos, 1)`,
/// `m = 1` gives `(tanh, sech, sech)`. `m > 1` uses the reciprocal-modulus
/// transformation; `m < 0` is handled by the same iteration.
pub fn sncndn(u: f64, m: f64) -> (f64, f64, f64) {
    const CA: f64 = 1.0e-8;
    let mut emc = 1.0 - m;
    if m == 0.0 {
        let (s, c) = u.sin_cos();
        return (s, c, 1.0);
    }
    if emc == 0.0 {
        let c = 1.0 / u.cosh();
        return (u.tanh(), c, c);
    }
    let mut u = u;
    let bo = emc < 0.0;
    let mut d = 0.0;
    if bo {
        d = 1.0 - emc;
        emc /= -1.0 / d;
        d = d.sqrt();
        u *= d;
    }
    let mut em = [0.0f64; 14];
    let mut en = [0.0f64; 14];
    let mut a = 1.0;
    let mut dn = 1.0;
    let mut c = 1.0;
    let mut l = 0;
    for i in 1..14 {
        l = i;
        em[i] = a;
        emc = emc.sqrt();
        en[i] = emc;
        c = 0.5 * (a + emc);
        if (a - emc).abs() <= CA * a {
            break;
        }
        emc *= a;
        a = c;
    }
    u *= c;
    let (mut sn, mut cn) = u.sin_cos();
    if sn != 0.0 {
        let mut a = cn / sn;
        c *= a;
        for ii in (1..=l).rev() {
            let b = em[ii];
            a *= c;
            c *= dn;
            dn = (en[ii] + a) / (b + a);
            a = c / b;
        }
        let a = 1.0 / (c * c + 1.0).sqrt();
        sn = if sn >= 0.0 { a } else { -a };
        cn = c * sn;
    }
    if bo {
        std::mem::swap(&mut dn, &mut cn);
        sn /= d;
    }
    (sn, cn, dn)
}

/// Jacobi `sn(u | m)`.
#[inline]
pub fn jacobi_sn(u: f64, m: f64) -> f64 {
    sncndn(u, m).0
}
/// Jacobi `cn(u | m)`.
#[inline]
pub fn jacobi_cn(u: f64, m: f64) -> f64 {
    sncndn(u, m).1
}
/// Jacobi `dn(u | m)`.
#[inline]
pub fn jacobi_dn(u: f64, m: f64) -> f64 {
    sncndn(u, m).2
}

/// Complete elliptic integral of the first kind `K(m) = ∫₀^{π/2} dθ / √(1 − m sin²θ)`
/// (parameter `m = k²`), by the arithmetic–geometric mean `K = π / (2 AGM(1, √(1 − m)))`.
/// `K(0) = π/2`; `K(1) = +∞`; `m > 1` gives NaN.
pub fn ellipk(m: f64) -> f64 {
    if m == 1.0 {
        return f64::INFINITY;
    }
    if m > 1.0 || m.is_nan() {
        return f64::NAN;
    }
    let mut a = 1.0f64;
    let mut b = (1.0 - m).sqrt();
    for _ in 0..40 {
        if (a - b).abs() <= 1e-15 * a {
            break;
        }
        let an = 0.5 * (a + b);
        b = (a * b).sqrt();
        a = an;
    }
    std::f64::consts::PI / (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bx(f: Fn1) -> Box<Fn1> {
        Box::new(f)
    }

    /// Check a jet against 4th-order central finite differences of its value.
    fn check_fd(f: &Fn1, x: f64, tol: f64) {
        let h = 1e-3;
        let v = |x: f64| value(f, x);
        let j = eval(f, x);
        let d1 = (v(x - 2.0 * h) - 8.0 * v(x - h) + 8.0 * v(x + h) - v(x + 2.0 * h)) / (12.0 * h);
        let d2 = (-v(x - 2.0 * h) + 16.0 * v(x - h) - 30.0 * v(x) + 16.0 * v(x + h)
            - v(x + 2.0 * h))
            / (12.0 * h * h);
        let s = 1.0 + j.d1.abs() + j.d2.abs();
        assert!(
            (j.d1 - d1).abs() < tol * s,
            "{f:?} at {x}: d1 {} vs fd {}",
            j.d1,
            d1
        );
        assert!(
            (j.d2 - d2).abs() < tol * s,
            "{f:?} at {x}: d2 {} vs fd {}",
            j.d2,
            d2
        );
    }

    #[test]
    fn unary_functions_match_finite_differences() {
        use UnaryFn::*;
        // inner argument 0.3 x² + 0.2 x + 0.1 exercises the chain rule
        let inner = || {
            Fn1::Add(
                bx(Fn1::Mul(
                    bx(Fn1::Const(0.3)),
                    bx(Fn1::Powf(bx(Fn1::Var), 2.0)),
                )),
                bx(Fn1::Add(
                    bx(Fn1::Mul(bx(Fn1::Const(0.2)), bx(Fn1::Var))),
                    bx(Fn1::Const(0.1)),
                )),
            )
        };
        for u in [
            Sin, Cos, Tan, Asin, Acos, Atan, Sqrt, Exp, Ln, Tanh, Abs, Ramp,
        ] {
            let f = Fn1::Unary(u, bx(inner()));
            for x in [0.1, 0.5, 0.9] {
                check_fd(&f, x, 1e-7);
            }
        }
        // closed forms
        let j = Jet2::var(0.7).sin();
        assert_eq!(j, Jet2::new(0.7f64.sin(), 0.7f64.cos(), -(0.7f64.sin())));
        let j = Jet2::var(2.0).exp();
        assert!((j.d2 - 2.0f64.exp()).abs() < 1e-15);
    }

    #[test]
    fn arithmetic_rules() {
        let x = Jet2::var(1.3);
        let f = (x * x * x) / (x + 1.0) - 2.0 * x + 3.0;
        // g = x³/(x+1) − 2x + 3; g' = (2x³+3x²)/(x+1)² − 2; g'' = (2x³+6x²+6x)/(x+1)³
        let xv: f64 = 1.3;
        let g1 = (2.0 * xv.powi(3) + 3.0 * xv * xv) / (xv + 1.0).powi(2) - 2.0;
        let g2 = (2.0 * xv.powi(3) + 6.0 * xv * xv + 6.0 * xv) / (xv + 1.0).powi(3);
        assert!((f.d1 - g1).abs() < 1e-13);
        assert!((f.d2 - g2).abs() < 1e-13);
        let p = x.powf(2.5);
        assert!((p.d2 - 2.5 * 1.5 * xv.powf(0.5)).abs() < 1e-13);
        assert_eq!(Jet2::constant(0.0).sqrt(), Jet2::constant(0.0));
        assert_eq!((1.0 / Jet2::var(2.0)).d1, -0.25);
    }

    #[test]
    fn nonsmooth_functions() {
        assert_eq!(Jet2::var(-1e-300).step().v, 0.0);
        assert_eq!(Jet2::var(0.0).step().v, 1.0);
        assert_eq!(Jet2::var(0.0).ramp(), Jet2::var(0.0));
        assert_eq!(Jet2::var(-2.0).ramp(), Jet2::constant(0.0));
        assert_eq!(Jet2::var(-2.0).abs(), Jet2::new(2.0, -1.0, 0.0));
        let a = Jet2::var(1.0);
        let b = Jet2::constant(2.0);
        assert_eq!(a.min(b), a);
        assert_eq!(a.max(b), b);
        // smoothstep: endpoints, midpoint, derivatives against FD
        let f = Fn1::Smoothstep(bx(Fn1::Var), 1.0, 3.0);
        assert_eq!(value(&f, 0.5), 0.0);
        assert_eq!(value(&f, 3.5), 1.0);
        assert!((value(&f, 2.0) - 0.5).abs() < 1e-15);
        assert!((eval(&f, 2.0).d1 - 0.75).abs() < 1e-15); // 6 s(1−s)/w = 6·¼/2
        for x in [1.2, 1.7, 2.6] {
            check_fd(&f, x, 1e-7);
        }
        assert_eq!(Jet2::var(1.0).smoothstep(1.0, 1.0).v, 1.0);
    }

    #[test]
    fn tables() {
        let t = vec![[0.0, 1.0], [1.0, 3.0], [3.0, 2.0]];
        let f = Fn1::Table(bx(Fn1::Mul(bx(Fn1::Const(2.0)), bx(Fn1::Var))), t.clone());
        assert_eq!(eval(&f, -1.0), Jet2::constant(1.0));
        assert_eq!(eval(&f, 5.0), Jet2::constant(2.0));
        let j = eval(&f, 0.25); // at 0.5: 1 + 2·0.5 = 2, slope 2 · inner slope 2
        assert!((j.v - 2.0).abs() < 1e-15 && (j.d1 - 4.0).abs() < 1e-15 && j.d2 == 0.0);
        let j = eval(&f, 0.5); // breakpoint x=1: right segment, slope −0.5
        assert!((j.v - 3.0).abs() < 1e-15 && (j.d1 + 1.0).abs() < 1e-15);
        assert_eq!(table_eval(&t, 3.0), (2.0, 0.0));
        assert_eq!(table_eval(&[[1.0, 4.0]], 7.0), (4.0, 0.0));
        assert_eq!(table_eval(&[], 7.0), (0.0, 0.0));
        assert!(table_eval(&t, f64::NAN).0.is_nan());
        // NaN propagates through everything without panicking
        assert!(sncndn(f64::NAN, 0.5).0.is_nan() && ellipk(f64::NAN).is_nan());
        assert!(validate(&f).is_ok());
        assert!(validate(&Fn1::Table(bx(Fn1::Var), vec![[1.0, 0.0], [1.0, 2.0]])).is_err());
        assert!(validate(&Fn1::Table(bx(Fn1::Var), vec![])).is_err());
        assert!(validate(&Fn1::JacobiSn(bx(Fn1::Var), 1.5)).is_err());
        assert!(validate(&Fn1::Const(f64::NAN)).is_err());
    }

    /// Incomplete elliptic integral F(φ|m) by composite Simpson (independent of sncndn).
    fn ellip_f(phi: f64, m: f64) -> f64 {
        let n = 20000;
        let h = phi / n as f64;
        let g = |t: f64| 1.0 / (1.0 - m * t.sin().powi(2)).sqrt();
        let mut s = g(0.0) + g(phi);
        for i in 1..n {
            s += g(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    }

    #[test]
    fn jacobi_against_inverse_by_quadrature() {
        for &m in &[0.0, 0.1, 0.5, 0.8, 0.95] {
            for &phi in &[0.1, 0.7, 1.2, 1.5, 2.5, 4.0] {
                let u = ellip_f(phi, m);
                let (s, c, d) = sncndn(u, m);
                assert!((s - phi.sin()).abs() < 1e-13, "m={m} phi={phi}: sn {s}");
                assert!((c - phi.cos()).abs() < 1e-13, "m={m} phi={phi}: cn {c}");
                let de = (1.0 - m * phi.sin().powi(2)).sqrt();
                assert!((d - de).abs() < 1e-13, "m={m} phi={phi}: dn {d} vs {de}");
            }
        }
    }

    #[test]
    #[allow(clippy::excessive_precision)] // reference digits as printed by mpmath
    fn jacobi_known_values_and_identities() {
        // Reference values from mpmath (ellipfun), 20 digits.
        let cases = [
            (
                0.5,
                0.3,
                0.474_215_622_711_820_63,
                0.880_408_736_426_462_43,
                0.965_678_964_745_951_2,
            ),
            (
                1.7,
                0.9,
                0.952_230_542_108_018_65,
                0.305_380_082_318_197_24,
                0.428_872_119_878_410_85,
            ),
            (
                -2.3,
                0.5,
                -0.949_089_886_417_601_04,
                -0.315_005_376_937_958_23,
                0.741_359_692_558_148_57,
            ),
            (
                10.0,
                0.7,
                0.978_073_280_357_512_39,
                0.208_261_033_923_043_24,
                0.574_770_267_824_881_94,
            ),
            (
                3.0,
                0.999,
                0.995_293_128_337_884_36,
                0.096_910_209_386_770_212,
                0.101_893_066_960_928_5,
            ),
        ];
        for (u, m, s, c, d) in cases {
            let (s2, c2, d2) = sncndn(u, m);
            assert!((s2 - s).abs() < 1e-14, "sn({u}|{m}) = {s2}, want {s}");
            assert!((c2 - c).abs() < 1e-14, "cn({u}|{m}) = {c2}, want {c}");
            assert!((d2 - d).abs() < 1e-14, "dn({u}|{m}) = {d2}, want {d}");
        }
        for i in 0..=20 {
            let m = i as f64 / 20.0;
            let k = ellipk(m);
            if m < 1.0 {
                let (s, c, d) = sncndn(k, m);
                assert!((s - 1.0).abs() < 1e-15, "sn(K|{m}) = {s}");
                assert!(c.abs() < 1e-14, "cn(K|{m}) = {c}");
                assert!((d - (1.0 - m).sqrt()).abs() < 1e-14);
                // period 4K
                let (s4, c4, _) = sncndn(0.3 + 4.0 * k, m);
                let (s0, c0, _) = sncndn(0.3, m);
                assert!((s4 - s0).abs() < 1e-13 && (c4 - c0).abs() < 1e-13);
            }
            for j in 0..30 {
                let u = -5.0 + j as f64 * 0.37;
                let (s, c, d) = sncndn(u, m);
                assert!((s * s + c * c - 1.0).abs() < 1e-15);
                assert!((d * d + m * s * s - 1.0).abs() < 1e-15);
            }
        }
        // limits
        let (s, c, d) = sncndn(0.8, 1.0);
        assert_eq!(
            (s, c, d),
            (0.8f64.tanh(), 1.0 / 0.8f64.cosh(), 1.0 / 0.8f64.cosh())
        );
        let (s, c, d) = sncndn(0.8, 0.0);
        assert_eq!((s, c, d), (0.8f64.sin(), 0.8f64.cos(), 1.0));
        let (s, _, _) = sncndn(0.8, 1.0 - 1e-14);
        assert!((s - 0.8f64.tanh()).abs() < 1e-13);
        assert_eq!(sncndn(0.0, 0.4), (0.0, 1.0, 1.0));
    }

    #[test]
    fn ellipk_values() {
        assert!((ellipk(0.0) - std::f64::consts::FRAC_PI_2).abs() < 1e-16);
        assert!((ellipk(0.5) - 1.8540746773013719).abs() < 1e-15);
        assert!((ellipk(0.9) - 2.5780921133481733).abs() < 2e-15);
        assert!(ellipk(1.0).is_infinite());
        for &m in &[0.2, 0.7, 0.99] {
            let q = ellip_f(std::f64::consts::FRAC_PI_2, m);
            assert!((ellipk(m) - q).abs() < 1e-11, "K({m}) {} vs {q}", ellipk(m));
        }
    }

    #[test]
    fn jacobi_derivatives() {
        for &m in &[0.0, 0.3, 0.9, 1.0] {
            for f in [
                Fn1::JacobiSn(bx(Fn1::Var), m),
                Fn1::JacobiCn(bx(Fn1::Var), m),
                Fn1::JacobiDn(bx(Fn1::Var), m),
            ] {
                for x in [-1.1, 0.2, 0.9, 2.8] {
                    check_fd(&f, x, 1e-7);
                }
            }
        }
    }
}
