//! Butcher tableaux of the explicit Runge–Kutta methods: the classical RK4 and the
//! Dormand–Prince 5(4) pair with its continuous extension (Hairer–Nørsett–Wanner I,
//! §II.5 and §II.6, the coefficients of their `DOPRI5` code).

/// An explicit Runge–Kutta method (strictly lower-triangular `a`).
#[derive(Debug)]
pub struct Tableau {
    /// The method's name, as written in `.mbd` files.
    pub name: &'static str,
    /// Stage nodes `c_i`.
    pub c: &'static [f64],
    /// Stage coefficients, row `i` holding `a_i1 … a_i(i−1)`.
    pub a: &'static [&'static [f64]],
    /// Weights `b_i` of the propagated solution.
    pub b: &'static [f64],
    /// Weights of the error estimate `b_i − b̂_i` (empty: no embedded method).
    pub e: &'static [f64],
    /// Order of the propagated solution.
    pub order: u32,
    /// Order of the embedded solution (0 without).
    pub embedded_order: u32,
    /// The last stage is evaluated at the new solution (first same as last), so a step
    /// after an accepted one costs one stage less.
    pub fsal: bool,
}

impl Tableau {
    /// Number of stages.
    pub fn stages(&self) -> usize {
        self.c.len()
    }
}

/// The classical fourth-order Runge–Kutta method.
pub static RK4: Tableau = Tableau {
    name: "rk4",
    c: &[0.0, 0.5, 0.5, 1.0],
    a: &[&[], &[0.5], &[0.0, 0.5], &[0.0, 0.0, 1.0]],
    b: &[1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0],
    e: &[],
    order: 4,
    embedded_order: 0,
    fsal: false,
};

const B5: [f64; 7] = [
    35.0 / 384.0,
    0.0,
    500.0 / 1113.0,
    125.0 / 192.0,
    -2187.0 / 6784.0,
    11.0 / 84.0,
    0.0,
];
const B4: [f64; 7] = [
    5179.0 / 57600.0,
    0.0,
    7571.0 / 16695.0,
    393.0 / 640.0,
    -92097.0 / 339200.0,
    187.0 / 2100.0,
    1.0 / 40.0,
];
const E5: [f64; 7] = [
    B5[0] - B4[0],
    B5[1] - B4[1],
    B5[2] - B4[2],
    B5[3] - B4[3],
    B5[4] - B4[4],
    B5[5] - B4[5],
    B5[6] - B4[6],
];

/// The Dormand–Prince 5(4) pair: fifth order propagated (local extrapolation), fourth
/// order embedded for the error estimate, seven stages of which the last is the first of
/// the next step.
pub static DOPRI5: Tableau = Tableau {
    name: "dopri5",
    c: &[0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0],
    a: &[
        &[],
        &[1.0 / 5.0],
        &[3.0 / 40.0, 9.0 / 40.0],
        &[44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0],
        &[
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
        ],
        &[
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
        ],
        &B5_ROW,
    ],
    b: &B5,
    e: &E5,
    order: 5,
    embedded_order: 4,
    fsal: true,
};

const B5_ROW: [f64; 6] = [B5[0], B5[1], B5[2], B5[3], B5[4], B5[5]];

/// The coefficients `d_i` of the Dormand–Prince continuous extension (Hairer's `CONTD5`):
/// with `θ = (t − t₀)/h`, `θ₁ = 1 − θ`, `Δ = y₁ − y₀`, `r₃ = h k₁ − Δ`,
/// `r₄ = Δ − h k₇ − r₃`, `r₅ = h Σ dᵢ kᵢ`,
///
/// ```text
/// y(θ) = y₀ + θ (Δ + θ₁ (r₃ + θ (r₄ + θ₁ r₅))),
/// ```
///
/// fourth order uniformly in the step, continuous with its derivative at both ends.
pub const DOPRI5_DENSE: [f64; 7] = [
    -12715105075.0 / 11282082432.0,
    0.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
];

#[cfg(test)]
mod tests {
    use super::*;

    /// A rooted tree as the list of its children (each a tree).
    #[derive(Clone, Debug)]
    struct Tree(Vec<Tree>);

    impl Tree {
        fn order(&self) -> usize {
            1 + self.0.iter().map(Tree::order).sum::<usize>()
        }
        /// The density γ(t) = |t| Π γ(children).
        fn gamma(&self) -> f64 {
            self.order() as f64 * self.0.iter().map(Tree::gamma).product::<f64>()
        }
        /// Per stage `i`: Π over the children of `Σ_j a_ij Φ_j(child)`.
        fn phi(&self, t: &Tableau) -> Vec<f64> {
            let s = t.stages();
            let mut out = vec![1.0; s];
            for child in &self.0 {
                let pc = child.phi(t);
                for i in 0..s {
                    let sum: f64 = t.a[i].iter().zip(&pc).map(|(a, p)| a * p).sum();
                    out[i] *= sum;
                }
            }
            out
        }
    }

    /// Every rooted tree of order `n` (by multisets of smaller trees, in canonical order).
    fn trees(n: usize) -> Vec<Tree> {
        // all trees of each order up to n − 1, indexed
        let mut all: Vec<Vec<Tree>> = vec![Vec::new(), vec![Tree(Vec::new())]];
        for k in 2..=n {
            let mut level = Vec::new();
            // children: a non-increasing sequence of (order, index) with orders summing
            // to k − 1
            fn grow(
                all: &[Vec<Tree>],
                left: usize,
                max: (usize, usize),
                acc: &mut Vec<Tree>,
                out: &mut Vec<Tree>,
            ) {
                if left == 0 {
                    out.push(Tree(acc.clone()));
                    return;
                }
                for o in (1..=left.min(max.0)).rev() {
                    let top = if o == max.0 { max.1 } else { all[o].len() - 1 };
                    for i in (0..=top).rev() {
                        acc.push(all[o][i].clone());
                        grow(all, left - o, (o, i), acc, out);
                        acc.pop();
                    }
                }
            }
            let top = (k - 1, all[k - 1].len() - 1);
            grow(&all, k - 1, top, &mut Vec::new(), &mut level);
            all.push(level);
        }
        all.swap_remove(n)
    }

    fn residual(t: &Tableau, b: &[f64], tree: &Tree) -> f64 {
        let phi: f64 = b.iter().zip(tree.phi(t)).map(|(b, p)| b * p).sum();
        phi - 1.0 / tree.gamma()
    }

    #[test]
    fn tree_counts() {
        // 1, 1, 2, 4, 9, 20 rooted trees of orders 1..6 (OEIS A000081)
        let counts: Vec<usize> = (1..=6).map(|n| trees(n).len()).collect();
        assert_eq!(counts, [1, 1, 2, 4, 9, 20]);
    }

    /// The order conditions `Σ bᵢ Φᵢ(t) = 1/γ(t)` over every rooted tree up to the
    /// method's order hold to round-off, and at least one of the next order fails (the
    /// order is exact); the same for the embedded weights `b − e`.
    #[test]
    fn order_conditions() {
        for t in [&RK4, &DOPRI5] {
            assert_eq!(t.a.len(), t.stages());
            assert_eq!(t.b.len(), t.stages());
            for (i, row) in t.a.iter().enumerate() {
                assert_eq!(row.len(), i, "{}: row {i}", t.name);
                let sum: f64 = row.iter().sum();
                assert!((sum - t.c[i]).abs() < 1e-15, "{}: c_{i}", t.name);
            }
            let mut weights = vec![(t.b.to_vec(), t.order)];
            if !t.e.is_empty() {
                let bh: Vec<f64> = t.b.iter().zip(t.e).map(|(b, e)| b - e).collect();
                weights.push((bh, t.embedded_order));
            }
            for (b, p) in weights {
                for n in 1..=p as usize {
                    for tree in trees(n) {
                        let r = residual(t, &b, &tree);
                        assert!(r.abs() < 1e-14, "{} order {p}: {tree:?}: {r:e}", t.name);
                    }
                }
                let next = trees(p as usize + 1)
                    .iter()
                    .map(|tree| residual(t, &b, tree).abs())
                    .fold(0.0, f64::max);
                assert!(next > 1e-6, "{}: order above {p}", t.name);
            }
        }
    }

    /// FSAL: the last stage row of DOPRI5 is its weights.
    #[test]
    fn dopri5_is_fsal() {
        let last = DOPRI5.a[6];
        for (a, b) in last.iter().zip(DOPRI5.b) {
            assert_eq!(a, b);
        }
        assert_eq!(DOPRI5.b[6], 0.0);
    }

    /// The continuous extension reproduces `t^k`, k ≤ 4, for `y' = k t^(k−1)` (exact
    /// stage derivatives), at interior points: its order conditions `Σ bᵢ(θ) cᵢ^(k−1) =
    /// θ^k/k` on the quadrature trees.
    #[test]
    fn dense_output_quadrature_order() {
        let t = &DOPRI5;
        for &theta in &[0.1, 0.37, 0.5, 0.81] {
            for k in 1..=5 {
                // y = t^k on [0, 1], h = 1, y0 = 0, y1 = 1
                let f: Vec<f64> = t.c.iter().map(|c| k as f64 * c.powi(k - 1)).collect();
                let y0 = 0.0;
                let y1: f64 = t.b.iter().zip(&f).map(|(b, f)| b * f).sum();
                let d = y1 - y0;
                let dk: f64 = DOPRI5_DENSE.iter().zip(&f).map(|(d, f)| d * f).sum();
                let th1 = 1.0 - theta;
                let r3 = f[0] - d;
                let r4 = d - f[6] - r3;
                let y = y0 + theta * (d + th1 * (r3 + theta * (r4 + th1 * dk)));
                let want = theta.powi(k);
                if k <= 4 {
                    assert!((y - want).abs() < 1e-14, "θ {theta}, k {k}: {y} vs {want}");
                }
            }
        }
    }
}
