//! The traction bases of reduced Lagrange multipliers (Farhat–Géradin; shared/notes/
//! E_feti_reduced_multipliers.md §3): the interface traction `λ(s)` along a glued interface,
//! parametrized by its abscissa `s` (normalized to `[0, 1]`, as the notes advise against
//! the raw `sᵏ` of the paper), is written with a few parameters instead of one multiplier
//! per interface dof, and the constraint matrices integrate the basis against each side's
//! shape functions.
//!
//! - **Global polynomials** (RLM §3, eq. 11): `φ_k(s) = sᵏ`, `k = 0 … p`. An edge with two
//!   linear shape functions has the closed form RLM (18) ([`monomial_edge_integrals`]).
//!   Their constraint matrices are ill-conditioned as `p` grows (notes §7: κ(B̄B̄ᵀ) ≈ 10¹³
//!   at ten terms).
//! - **Piecewise cubics with Bessel slopes** (RLM §4 and Appendix A): the traction takes
//!   the value `λ_m` at each of `n` points `s_0 < … < s_{n−1}`; between two points it is the
//!   cubic Hermite interpolant whose slope at `s_k` is the derivative of the parabola through
//!   `s_{k−1}, s_k, s_{k+1}` (Bessel); at the ends the parabola through the first (last)
//!   three points — the paper's end condition `s_{−1} = s_2`, `λ_{−1} = λ_2` (RLM (31), as
//!   the notes read it and verified). The basis function `φ_m` is the traction of
//!   `λ = e_m`. The paper's coefficient table (RLM (32)) has a wrong `ζ_3k`; this module
//!   builds the basis from the Hermite form and tests it against the corrected table
//!   ([`bessel_coefficients`]).
//!
//! [`edge_integrals`] gives `∫ N_l φ_m ds` over an edge by Gauss quadrature on each piece
//! between breakpoints (3 points: exact for a cubic times a linear function).
//!
//! Pure functions; no layout, no solver.

/// A traction basis along an interface abscissa `s ∈ [0, 1]`.
#[derive(Clone, Debug, PartialEq)]
pub enum TractionBasis {
    /// `sᵏ`, `k = 0 … degree`.
    Polynomial {
        /// Highest power.
        degree: usize,
    },
    /// Piecewise cubic Hermite with Bessel slopes through the given increasing points
    /// (at least 1; 1 point: a constant, 2: linear, ≥ 3: cubic pieces).
    Bessel {
        /// The traction locations, increasing, in `[0, 1]`.
        points: Vec<f64>,
    },
}

impl TractionBasis {
    /// Number of basis functions (traction parameters per direction).
    pub fn len(&self) -> usize {
        match self {
            TractionBasis::Polynomial { degree } => degree + 1,
            TractionBasis::Bessel { points } => points.len(),
        }
    }

    /// Whether the basis is empty (a Bessel basis without points).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The abscissae where the basis is not smooth (the Bessel points; none for
    /// polynomials).
    pub fn breakpoints(&self) -> &[f64] {
        match self {
            TractionBasis::Polynomial { .. } => &[],
            TractionBasis::Bessel { points } => points,
        }
    }

    /// `out[m] = φ_m(s)` for every basis function (`out.len() == self.len()`).
    pub fn eval(&self, s: f64, out: &mut [f64]) {
        match self {
            TractionBasis::Polynomial { .. } => {
                let mut p = 1.0;
                for o in out.iter_mut() {
                    *o = p;
                    p *= s;
                }
            }
            TractionBasis::Bessel { points } => bessel_eval(points, s, out),
        }
    }
}

/// The slope at point `k` as weights of the point values: the derivative at `x_k` of the
/// parabola through `k − 1, k, k + 1` (through the first or last three points at the ends;
/// the secant for two points): `(points, weights)`, unused entries with weight 0.
fn slope_weights(x: &[f64], k: usize) -> ([usize; 3], [f64; 3]) {
    let n = x.len();
    if n < 2 {
        return ([0; 3], [0.0; 3]);
    }
    if n == 2 {
        let w = 1.0 / (x[1] - x[0]);
        return ([0, 1, 0], [-w, w, 0.0]);
    }
    let a = k.saturating_sub(1).min(n - 3);
    let nodes = [a, a + 1, a + 2];
    let xk = x[k];
    let mut w = [0.0; 3];
    for j in 0..3 {
        // L_j'(x_k) = Σ_{m≠j} Π_{l≠j,m} (x_k − x_l) / Π_{l≠j} (x_j − x_l)
        let mut num = 0.0;
        for m in (0..3).filter(|&m| m != j) {
            let l = 3 - j - m;
            num += xk - x[nodes[l]];
        }
        let mut den = 1.0;
        for l in (0..3).filter(|&l| l != j) {
            den *= x[nodes[j]] - x[nodes[l]];
        }
        w[j] = num / den;
    }
    (nodes, w)
}

/// The slope at point `k` of the traction `λ` ([`slope_weights`]).
#[cfg(test)]
fn bessel_slope(x: &[f64], lam: &[f64], k: usize) -> f64 {
    let (nodes, w) = slope_weights(x, k);
    nodes.iter().zip(w).map(|(&m, w)| w * lam[m]).sum()
}

/// The Hermite cubic coefficients `[c1, c2, c3, c4]` of the traction `λ` on the piece
/// `[x_k, x_{k+1}]`, in powers of `s − x_k`.
#[cfg(test)]
fn hermite_piece(x: &[f64], lam: &[f64], k: usize) -> [f64; 4] {
    let h = x[k + 1] - x[k];
    let (dk, dk1) = (bessel_slope(x, lam, k), bessel_slope(x, lam, k + 1));
    let delta = (lam[k + 1] - lam[k]) / h;
    [
        lam[k],
        dk,
        (3.0 * delta - 2.0 * dk - dk1) / h,
        (dk + dk1 - 2.0 * delta) / (h * h),
    ]
}

/// `φ_m(s)` of the Bessel basis through `x`, every `m` (constant extension outside
/// `[x_0, x_{n−1}]`): the Hermite form `λ_k H₀₀ + λ_{k+1} H₀₁ + h (d_k H₁₀ + d_{k+1} H₁₁)`
/// on the piece that holds `s`, with the slopes as weights of the point values.
fn bessel_eval(x: &[f64], s: f64, out: &mut [f64]) {
    let n = x.len();
    out.iter_mut().for_each(|o| *o = 0.0);
    if n == 0 {
        return;
    }
    if n == 1 {
        out[0] = 1.0;
        return;
    }
    let s = s.clamp(x[0], x[n - 1]);
    let k = x[..n - 1]
        .partition_point(|&xi| xi <= s)
        .saturating_sub(1)
        .min(n - 2);
    let h = x[k + 1] - x[k];
    let t = (s - x[k]) / h;
    let (t2, t3) = (t * t, t * t * t);
    let h00 = 2.0 * t3 - 3.0 * t2 + 1.0;
    let h01 = -2.0 * t3 + 3.0 * t2;
    let h10 = t3 - 2.0 * t2 + t;
    let h11 = t3 - t2;
    out[k] += h00;
    out[k + 1] += h01;
    for (kk, hh) in [(k, h10), (k + 1, h11)] {
        let (nodes, w) = slope_weights(x, kk);
        for (&m, w) in nodes.iter().zip(w) {
            out[m] += h * hh * w;
        }
    }
}

/// The paper's Appendix A coefficients (RLM (32), with the notes' corrected `ζ_3k`):
/// for a piece of length `h` between pieces of lengths `h_minus` and `h_plus`, the rows
/// `c2, c3, c4` as coefficients of `[λ_{k+2}, λ_{k+1}, λ_k, λ_{k−1}]`.
pub fn bessel_coefficients(h_minus: f64, h: f64, h_plus: f64) -> [[f64; 4]; 3] {
    let (hm, hp) = (h_minus, h_plus);
    let d = hm + h;
    let dp = h + hp;
    [
        [
            0.0,
            hm / (h * d),
            h / (hm * d) - hm / (h * d),
            -h / (hm * d),
        ],
        [
            -1.0 / (hp * dp),
            3.0 / (h * h) - 2.0 * hm / (h * h * d) + 1.0 / (hp * dp) - hp / (h * h * dp),
            -3.0 / (h * h) - 2.0 / (hm * d) + 2.0 * hm / (h * h * d) + hp / (h * h * dp),
            2.0 / (hm * d),
        ],
        [
            1.0 / (h * hp * dp),
            -1.0 / (h * hp * dp) + hp / (h * h * h * dp) + hm / (h * h * h * d) - 2.0 / (h * h * h),
            -hp / (h * h * h * dp) - hm / (h * h * h * d) + 1.0 / (h * hm * d) + 2.0 / (h * h * h),
            -1.0 / (hm * h * d),
        ],
    ]
}

/// RLM (18): `∫_{s1}^{s2} N_l sᵏ ds` for the two linear shape functions of an edge
/// (`N_1 = (s2 − s)/(s2 − s1)`, `N_2 = (s − s1)/(s2 − s1)`), closed form.
pub fn monomial_edge_integrals(k: usize, s1: f64, s2: f64) -> [f64; 2] {
    let (k1, k2) = ((k + 1) as i32, (k + 2) as i32);
    let inv = 1.0 / (s2 - s1);
    [
        inv * ((s1.powi(k2) - s2.powi(k2)) / f64::from(k2)
            + (s2.powi(k2) - s1.powi(k1) * s2) / f64::from(k1)),
        inv * ((s2.powi(k2) - s1.powi(k2)) / f64::from(k2)
            + (s1.powi(k2) - s2.powi(k1) * s1) / f64::from(k1)),
    ]
}

/// `out[l][m] = ∫_{s1}^{s2} N_l φ_m ds` (`l` = 0 at `s1`, 1 at `s2`; `s1 < s2`): Gauss
/// quadrature with 3 points on every piece between the basis's breakpoints, exact for
/// the cubic pieces times the linear shape functions. `scratch` holds `basis.len()` values.
pub fn edge_integrals(
    basis: &TractionBasis,
    s1: f64,
    s2: f64,
    scratch: &mut [f64],
    out: &mut [Vec<f64>; 2],
) {
    const G: [(f64, f64); 3] = [
        (-0.774_596_669_241_483_4, 5.0 / 9.0),
        (0.0, 8.0 / 9.0),
        (0.774_596_669_241_483_4, 5.0 / 9.0),
    ];
    for o in out.iter_mut() {
        o.iter_mut().for_each(|v| *v = 0.0);
    }
    let len = s2 - s1;
    let bp = basis.breakpoints();
    let mut a = s1;
    loop {
        let next = bp.iter().copied().find(|&b| b > a && b < s2).unwrap_or(s2);
        let (mid, half) = (0.5 * (a + next), 0.5 * (next - a));
        for (xi, w) in G {
            let s = mid + half * xi;
            basis.eval(s, scratch);
            let n2 = (s - s1) / len;
            let n = [1.0 - n2, n2];
            for (o, nl) in out.iter_mut().zip(n) {
                for (v, phi) in o.iter_mut().zip(scratch.iter()) {
                    *v += w * half * nl * phi;
                }
            }
        }
        if next >= s2 {
            break;
        }
        a = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RLM (18) against 3-point Gauss quadrature (exact for degree ≤ 5), k = 0 … 4.
    #[test]
    #[allow(clippy::needless_range_loop)] // k is the power and the basis index
    fn rlm_18_matches_quadrature() {
        let basis = TractionBasis::Polynomial { degree: 4 };
        let (s1, s2) = (0.23, 0.61);
        let mut scratch = vec![0.0; 5];
        let mut out = [vec![0.0; 5], vec![0.0; 5]];
        edge_integrals(&basis, s1, s2, &mut scratch, &mut out);
        for k in 0..=3 {
            let c = monomial_edge_integrals(k, s1, s2);
            for l in 0..2 {
                assert!(
                    (c[l] - out[l][k]).abs() < 1e-15,
                    "k {k} l {l}: {} vs {}",
                    c[l],
                    out[l][k]
                );
            }
        }
    }

    /// The Hermite–Bessel pieces equal the corrected Appendix A table at random spacing;
    /// each row sums to zero (a constant has no slope or curvature); uniform spacing gives
    /// the notes' values; the paper's printed ζ₃ fails the sum.
    #[test]
    fn bessel_pieces_match_the_corrected_table() {
        let x = [0.0, 0.13, 0.37, 0.52, 0.9, 1.0];
        let k = 2;
        let (hm, h, hp) = (x[k] - x[k - 1], x[k + 1] - x[k], x[k + 2] - x[k + 1]);
        let table = bessel_coefficients(hm, h, hp);
        // λ = e_{k+2}, e_{k+1}, e_k, e_{k−1}: the pieces' coefficients c2, c3, c4.
        for (col, m) in [k + 2, k + 1, k, k - 1].into_iter().enumerate() {
            let mut lam = [0.0; 6];
            lam[m] = 1.0;
            let c = hermite_piece(&x, &lam, k);
            for row in 0..3 {
                assert!(
                    (c[row + 1] - table[row][col]).abs() < 1e-9 * table[row][col].abs().max(1.0),
                    "row {row} col {col}: {} vs {}",
                    c[row + 1],
                    table[row][col]
                );
            }
        }
        for row in &table {
            assert!(row.iter().sum::<f64>().abs() < 1e-9, "{row:?}");
        }
        let u = bessel_coefficients(1.0, 1.0, 1.0);
        assert_eq!(u[1], [-0.5, 2.0, -2.5, 1.0]);
        assert_eq!(u[2], [0.5, -1.5, 1.5, -0.5]);
        // The printed ζ₃: −3/h² − 2/(h₋h) + h₋/(h²D) + h₊/(h²D) + h₊/(h²D₊) + h₋/(h²D).
        let d = hm + h;
        let printed = -3.0 / (h * h) - 2.0 / (hm * h)
            + hm / (h * h * d)
            + hp / (h * h * d)
            + hp / (h * h * (h + hp))
            + hm / (h * h * d);
        let sum = table[1][0] + table[1][1] + printed + table[1][3];
        assert!(sum.abs() > 1.0, "the printed ζ₃ would sum to {sum}");
    }

    /// The Bessel basis reproduces quadratics exactly (its slopes are exact for them),
    /// including the end pieces (the end condition takes the parabola through the last
    /// three points), and interpolates: `φ_m(s_j) = δ_mj`.
    #[test]
    fn bessel_basis_reproduces_quadratics() {
        let points = vec![0.0, 0.1, 0.35, 0.5, 0.8, 1.0];
        let b = TractionBasis::Bessel {
            points: points.clone(),
        };
        let q = |s: f64| 0.3 - 1.2 * s + 2.5 * s * s;
        let mut phi = vec![0.0; 6];
        for i in 0..=100 {
            let s = f64::from(i) / 100.0;
            b.eval(s, &mut phi);
            let v: f64 = phi.iter().zip(&points).map(|(p, &x)| p * q(x)).sum();
            assert!((v - q(s)).abs() < 1e-13, "s {s}: {v} vs {}", q(s));
        }
        for (j, &x) in points.iter().enumerate() {
            b.eval(x, &mut phi);
            for (m, p) in phi.iter().enumerate() {
                assert!((p - f64::from(u8::from(m == j))).abs() < 1e-14);
            }
        }
    }

    /// The notes' §7 conditioning check: κ(B̄B̄ᵀ) of the interface matrix of 31 equally
    /// spaced nodes (the 30-element cut of the RLM cantilever) grows explosively with the
    /// number of monomials and stays moderate with the Bessel basis. The notes' prototype:
    /// 2·10¹, 1.9·10⁴, 2.1·10⁷ and 3.5·10¹³ at 2, 4, 6 and 10 monomials per direction, 6.5 …
    /// 1.3·10³ for Bessel (the larger for clustered points). Measured here: 19.9, 1.7·10⁴,
    /// 1.8·10⁷, 2.4·10¹³; Bessel with 4, 8, 16 equally spaced points 6.1, 6.3, 9.5.
    #[test]
    fn bessel_constraints_are_better_conditioned_than_monomials() {
        use nalgebra::DMatrix;
        let kappa = |basis: &TractionBasis| {
            let n = basis.len();
            let nodes = 31;
            let mut bbar = DMatrix::<f64>::zeros(n, nodes);
            let mut scratch = vec![0.0; n];
            let mut out = [vec![0.0; n], vec![0.0; n]];
            for e in 0..nodes - 1 {
                let (s1, s2) = (e as f64 / 30.0, (e + 1) as f64 / 30.0);
                edge_integrals(basis, s1, s2, &mut scratch, &mut out);
                for m in 0..n {
                    bbar[(m, e)] += out[0][m];
                    bbar[(m, e + 1)] += out[1][m];
                }
            }
            let ev = (&bbar * bbar.transpose()).symmetric_eigenvalues();
            ev.max() / ev.min()
        };
        let poly: Vec<f64> = [2, 4, 6, 10]
            .iter()
            .map(|&n| kappa(&TractionBasis::Polynomial { degree: n - 1 }))
            .collect();
        let bessel: Vec<f64> = [4, 8, 16]
            .iter()
            .map(|&n| {
                let points = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
                kappa(&TractionBasis::Bessel { points })
            })
            .collect();
        assert!(poly.windows(2).all(|w| w[1] > 10.0 * w[0]), "{poly:?}");
        assert!(poly[3] > 1e13, "{poly:?}");
        assert!(bessel.iter().all(|&k| k < 20.0), "{bessel:?}");
    }
}
