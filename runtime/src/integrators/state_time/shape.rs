//! Shape functions of one time element on τ ∈ [0, 1] (notes F §1.3): quadratic Lagrange
//! ψ for the kinematic unknowns (nodes 0, ½, 1), linear Lagrange φ for the joint forces,
//! and the six-point Gauss–Legendre rule that integrates every element integrand of the
//! formulation exactly (highest degree 5).

/// Quadratic Lagrange functions at τ: `[ψ₁, ψ₂, ψ₃]` (nodes 0, ½, 1).
#[inline]
pub fn psi(t: f64) -> [f64; 3] {
    [
        (1.0 - t) * (1.0 - 2.0 * t),
        4.0 * t * (1.0 - t),
        t * (2.0 * t - 1.0),
    ]
}

/// Their derivatives with respect to τ.
#[inline]
pub fn dpsi(t: f64) -> [f64; 3] {
    [4.0 * t - 3.0, 4.0 - 8.0 * t, 4.0 * t - 1.0]
}

/// Linear Lagrange functions at τ: `[φ₁, φ₂]` (nodes 0, 1).
#[inline]
pub fn phi(t: f64) -> [f64; 2] {
    [1.0 - t, t]
}

/// Six-point Gauss–Legendre rule on [0, 1]: `(τ, weight)`; exact to degree 11.
pub const GAUSS6: [(f64, f64); 6] = {
    const X: [f64; 3] = [
        0.238_619_186_083_196_9,
        0.661_209_386_466_264_5,
        0.932_469_514_203_152,
    ];
    const W: [f64; 3] = [
        0.467_913_934_572_691_04,
        0.360_761_573_048_138_6,
        0.171_324_492_379_170_35,
    ];
    [
        (0.5 - 0.5 * X[2], 0.5 * W[2]),
        (0.5 - 0.5 * X[1], 0.5 * W[1]),
        (0.5 - 0.5 * X[0], 0.5 * W[0]),
        (0.5 + 0.5 * X[0], 0.5 * W[0]),
        (0.5 + 0.5 * X[1], 0.5 * W[1]),
        (0.5 + 0.5 * X[2], 0.5 * W[2]),
    ]
};

/// `∫₀¹ f(τ) dτ` by [`GAUSS6`].
pub fn integrate(f: impl Fn(f64) -> f64) -> f64 {
    GAUSS6.iter().map(|&(t, w)| w * f(t)).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) {
        assert!((a - b).abs() < 1e-14, "{a} vs {b}");
    }

    /// The exact element integrals of notes F §1.3 (rationals), by the Gauss rule.
    #[test]
    fn element_integral_table_of_notes_f_1_3() {
        let s = [1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0];
        for a in 0..3 {
            close(integrate(|t| psi(t)[a]), s[a]);
        }
        for e in 0..2 {
            close(integrate(|t| phi(t)[e]), 0.5);
        }
        let m = [
            [2.0 / 15.0, 1.0 / 15.0, -1.0 / 30.0],
            [1.0 / 15.0, 8.0 / 15.0, 1.0 / 15.0],
            [-1.0 / 30.0, 1.0 / 15.0, 2.0 / 15.0],
        ];
        let k = [
            [7.0 / 3.0, -8.0 / 3.0, 1.0 / 3.0],
            [-8.0 / 3.0, 16.0 / 3.0, -8.0 / 3.0],
            [1.0 / 3.0, -8.0 / 3.0, 7.0 / 3.0],
        ];
        let g = [
            [-0.5, -2.0 / 3.0, 1.0 / 6.0],
            [2.0 / 3.0, 0.0, -2.0 / 3.0],
            [-1.0 / 6.0, 2.0 / 3.0, 0.5],
        ];
        for a in 0..3 {
            for b in 0..3 {
                close(integrate(|t| psi(t)[a] * psi(t)[b]), m[a][b]);
                close(integrate(|t| dpsi(t)[a] * dpsi(t)[b]), k[a][b]);
                close(integrate(|t| dpsi(t)[a] * psi(t)[b]), g[a][b]);
            }
        }
        let fp = [[1.0 / 6.0, 1.0 / 3.0, 0.0], [0.0, 1.0 / 3.0, 1.0 / 6.0]];
        let dpf = [
            [-5.0 / 6.0, -1.0 / 6.0],
            [2.0 / 3.0, -2.0 / 3.0],
            [1.0 / 6.0, 5.0 / 6.0],
        ];
        for e in 0..2 {
            for b in 0..3 {
                close(integrate(|t| phi(t)[e] * psi(t)[b]), fp[e][b]);
                close(integrate(|t| dpsi(t)[b] * phi(t)[e]), dpf[b][e]);
            }
        }
        assert_eq!(psi(0.0), [1.0, 0.0, 0.0]);
        assert_eq!(psi(1.0), [0.0, 0.0, 1.0]);
        assert_eq!(dpsi(0.0), [-3.0, 4.0, -1.0]);
        assert_eq!(dpsi(1.0), [1.0, -4.0, 3.0]);
        let fpp = [[1.0 / 15.0, 4.0 / 15.0, 0.0], [0.0, 4.0 / 15.0, 1.0 / 15.0]];
        for e in 0..2 {
            for g_ in 0..3 {
                close(
                    integrate(|t| phi(t)[e] * psi(t)[g_] * psi(t)[1]),
                    fpp[e][g_],
                );
            }
        }
        let dpp = [
            [-0.2, -8.0 / 15.0, 1.0 / 15.0],
            [4.0 / 15.0, 0.0, -4.0 / 15.0],
            [-1.0 / 15.0, 8.0 / 15.0, 0.2],
        ];
        for a in 0..3 {
            for p in 0..3 {
                close(integrate(|t| dpsi(t)[a] * psi(t)[p] * psi(t)[1]), dpp[a][p]);
            }
        }
    }
}
