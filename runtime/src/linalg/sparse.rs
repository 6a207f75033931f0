//! Sparse symmetric factorization: faer's `LLᵀ` (AMD ordering, simplicial or supernodal
//! kernels chosen by faer from the flop count), symbolic analysis once, numeric
//! refactorization into preallocated storage with a preallocated `MemStack`.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError as DenseLltError, LltRegularization};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use super::{jacobi_scale, Definiteness, FactorStats, LinalgError};

/// Value a pivot `≤ tol` is replaced with in semidefinite mode (scaled matrix, unit
/// diagonal): its unknown then decouples to `O(10⁻¹⁰⁰)` and is set to zero.
const BIG_PIVOT: f64 = 1e100;
/// Any `L_kk` above this came from [`BIG_PIVOT`] (genuine ones are `≤ 1`).
const BIG_DETECT: f64 = 1e40;

/// Which faer kernel to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SparseKernel {
    /// faer decides from the flop count (supernodal for denser factors).
    #[default]
    Auto,
    /// Column-by-column (up-looking) kernel.
    Simplicial,
    /// Dense-block kernel.
    Supernodal,
}

/// Sparse `LLᵀ` of a symmetric matrix given by its upper triangle in compressed-column
/// form (rows sorted within each column, every diagonal entry present).
///
/// Fill the values through [`SparseCholesky::values_mut`] (aligned with the pattern),
/// then [`SparseCholesky::factor`] and [`SparseCholesky::solve_in_place`]; neither
/// allocates. The matrix is Jacobi-scaled before factoring (see the module doc of
/// [`crate::linalg`]); in [`Definiteness::SemiDefinite`] mode, pivots `≤ tol` mark
/// dependent rows, whose unknowns the solves set to zero.
pub struct SparseCholesky {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    scaled: Vec<f64>,
    diag_pos: Vec<usize>,
    scale: Vec<f64>,
    symbolic: SymbolicCholesky<usize>,
    /// Position of `L_kk` in `l_values` for each elimination step `k`.
    l_diag_pos: Vec<usize>,
    /// `perm[k]` = original row eliminated at step `k`.
    perm: Vec<usize>,
    l_values: Vec<f64>,
    mem: MemBuffer,
    mode: Definiteness,
    dependent: Vec<usize>,
    stats: Option<FactorStats>,
}

impl std::fmt::Debug for SparseCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseCholesky")
            .field("n", &self.n)
            .field("nnz", &self.row_idx.len())
            .field("l_nnz", &self.l_values.len())
            .field("supernodal", &self.is_supernodal())
            .field("mode", &self.mode)
            .field("stats", &self.stats)
            .finish()
    }
}

impl SparseCholesky {
    /// Symbolic analysis of the pattern (AMD ordering, elimination tree, storage of `L`)
    /// and allocation of every buffer. Errors: [`LinalgError::Symbolic`] for an invalid
    /// pattern (unsorted rows, entries below the diagonal, missing diagonal) or a failed
    /// analysis.
    pub fn new(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        mode: Definiteness,
    ) -> Result<SparseCholesky, LinalgError> {
        SparseCholesky::with_kernel(n, col_ptr, row_idx, mode, SparseKernel::Auto)
    }

    /// [`SparseCholesky::new`] with a chosen kernel.
    ///
    /// In [`Definiteness::SemiDefinite`] mode the simplicial kernel is always used: faer
    /// 0.22's dense (and so supernodal) `LLᵀ` applies the dynamic regularization to its
    /// pivot but stores `d/√δ` instead of `√δ` on the diagonal of `L`, so a replaced
    /// pivot would blow up instead of decoupling its unknown. The simplicial kernel
    /// stores `√δ` (checked by `sparse_semidefinite_finds_redundant_rows`).
    pub fn with_kernel(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        mode: Definiteness,
        kernel: SparseKernel,
    ) -> Result<SparseCholesky, LinalgError> {
        let bad = |msg: String| Err(LinalgError::Symbolic(msg));
        if col_ptr.len() != n + 1 || col_ptr[0] != 0 || col_ptr[n] != row_idx.len() {
            return bad("column pointers do not match the dimension".into());
        }
        let mut diag_pos = Vec::with_capacity(n);
        for s in 0..n {
            let (lo, hi) = (col_ptr[s], col_ptr[s + 1]);
            if lo >= hi || row_idx[hi - 1] != s {
                return bad(format!(
                    "column {s} has no diagonal entry (it must be the last entry)"
                ));
            }
            if row_idx[lo..hi].windows(2).any(|w| w[0] >= w[1]) {
                return bad(format!("rows of column {s} are not strictly increasing"));
            }
            diag_pos.push(hi - 1);
        }
        let sym = SymbolicSparseColMatRef::new_checked(n, n, col_ptr, None, row_idx);
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: match kernel {
                _ if matches!(mode, Definiteness::SemiDefinite { .. }) => {
                    SupernodalThreshold::FORCE_SIMPLICIAL
                }
                SparseKernel::Auto => SupernodalThreshold::AUTO,
                SparseKernel::Simplicial => SupernodalThreshold::FORCE_SIMPLICIAL,
                SparseKernel::Supernodal => SupernodalThreshold::FORCE_SUPERNODAL,
            },
            ..Default::default()
        };
        let symbolic =
            factorize_symbolic_cholesky(sym, Side::Upper, SymmetricOrdering::Amd, params)
                .map_err(|e| LinalgError::Symbolic(format!("{e:?}")))?;
        let perm: Vec<usize> = match symbolic.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..n).collect(),
        };
        let l_diag_pos = match symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => {
                let (cp, ri) = (s.col_ptr(), s.row_idx());
                (0..n)
                    .map(|k| {
                        debug_assert_eq!(ri[cp[k]], k, "simplicial L stores the diagonal first");
                        cp[k]
                    })
                    .collect()
            }
            SymbolicCholeskyRaw::Supernodal(s) => {
                let mut pos = vec![0; n];
                for sn in 0..s.n_supernodes() {
                    let (b, e) = (s.supernode_begin()[sn], s.supernode_end()[sn]);
                    let pat = s.col_ptr_for_row_idx()[sn + 1] - s.col_ptr_for_row_idx()[sn];
                    let nrows = pat + (e - b);
                    for (k, p) in pos.iter_mut().enumerate().take(e).skip(b) {
                        *p = s.col_ptr_for_val()[sn] + (k - b) * nrows + (k - b);
                    }
                }
                pos
            }
        };
        let req = symbolic
            .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
        let nnz = row_idx.len();
        let mut c = SparseCholesky {
            n,
            col_ptr: col_ptr.to_vec(),
            row_idx: row_idx.to_vec(),
            values: vec![0.0; nnz],
            scaled: vec![0.0; nnz],
            diag_pos,
            scale: vec![0.0; n],
            l_values: vec![0.0; symbolic.len_val()],
            symbolic,
            l_diag_pos,
            perm,
            mem: MemBuffer::new(req),
            mode,
            dependent: Vec::with_capacity(n),
            stats: None,
        };
        // Warm up faer's lazily initialised kernels so that `factor` never allocates.
        for &d in &c.diag_pos {
            c.values[d] = 1.0;
        }
        c.factor().expect("identity is positive definite");
        let mut b = vec![0.0; n];
        c.solve_in_place(&mut b);
        c.values.fill(0.0);
        c.stats = None;
        Ok(c)
    }

    /// Dimension.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Whether faer chose (or was told to use) the supernodal kernel.
    pub fn is_supernodal(&self) -> bool {
        matches!(self.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_))
    }

    /// Stored entries of `L`.
    pub fn factor_nnz(&self) -> usize {
        self.l_values.len()
    }

    /// Column pointers of the pattern.
    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }

    /// Row indices of the pattern.
    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }

    /// The matrix values, aligned with the pattern; fill before [`SparseCholesky::factor`].
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }

    /// Numeric factorization of the current values. Allocation-free.
    ///
    /// Errors: [`LinalgError::NotPositiveDefinite`] (in `Positive` mode, a pivot `≤ 0`;
    /// in either mode a negative diagonal entry) with the elimination step and the
    /// original row; [`LinalgError::NonFinite`].
    pub fn factor(&mut self) -> Result<FactorStats, LinalgError> {
        self.stats = None;
        self.dependent.clear();
        let n = self.n;
        let semidefinite = matches!(self.mode, Definiteness::SemiDefinite { .. });
        let step_of =
            |perm: &[usize], row: usize| perm.iter().position(|&p| p == row).unwrap_or(row);
        for j in 0..n {
            let d = self.values[self.diag_pos[j]];
            if !d.is_finite() {
                return Err(LinalgError::NonFinite { row: j });
            }
            if d < 0.0 || (d == 0.0 && !semidefinite) {
                return Err(LinalgError::NotPositiveDefinite {
                    step: step_of(&self.perm, j),
                    row: j,
                });
            }
            self.scale[j] = jacobi_scale(d);
        }
        for s in 0..n {
            for e in self.col_ptr[s]..self.col_ptr[s + 1] {
                let r = self.row_idx[e];
                let v = self.values[e];
                if !v.is_finite() {
                    return Err(LinalgError::NonFinite { row: r });
                }
                self.scaled[e] = v * self.scale[r] * self.scale[s];
            }
        }
        let regularization = match self.mode {
            Definiteness::Positive => LltRegularization::default(),
            Definiteness::SemiDefinite { tol } => LltRegularization {
                dynamic_regularization_delta: BIG_PIVOT,
                dynamic_regularization_epsilon: tol,
            },
        };
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let a = SparseColMatRef::new(sym, &self.scaled);
        let simplicial = !self.is_supernodal();
        let res = self.symbolic.factorize_numeric_llt(
            &mut self.l_values,
            a,
            Side::Upper,
            regularization,
            Par::Seq,
            MemStack::new(&mut self.mem),
            Default::default(),
        );
        match res {
            Ok(_) => {}
            Err(DenseLltError::NonPositivePivot { index }) => {
                // faer reports the simplicial step 1-based and the supernodal one 0-based.
                let step = if simplicial {
                    index.saturating_sub(1)
                } else {
                    index
                };
                return Err(LinalgError::NotPositiveDefinite {
                    step,
                    row: self.perm[step.min(n - 1)],
                });
            }
        }
        let mut stats = FactorStats::empty(n);
        for k in 0..n {
            let lkk = self.l_values[self.l_diag_pos[k]];
            if semidefinite && lkk > BIG_DETECT {
                self.dependent.push(self.perm[k]);
            } else {
                stats.accept(lkk * lkk);
            }
        }
        self.dependent.sort_unstable();
        self.stats = Some(stats);
        Ok(stats)
    }

    /// Rows found dependent by the last factorization (semidefinite mode; sorted).
    pub fn dependent_rows(&self) -> &[usize] {
        &self.dependent
    }

    /// Statistics of the last successful factorization.
    pub fn stats(&self) -> Option<FactorStats> {
        self.stats
    }

    /// Solve `A x = b` in place (the basic solution in semidefinite mode). Allocation-free.
    ///
    /// # Panics
    /// If there is no successful factorization or `b` has the wrong length.
    pub fn solve_in_place(&mut self, b: &mut [f64]) {
        assert!(
            self.stats.is_some(),
            "solve without a successful factorization"
        );
        assert_eq!(b.len(), self.n);
        for (x, s) in b.iter_mut().zip(&self.scale) {
            *x *= s;
        }
        let llt = faer::sparse::linalg::cholesky::LltRef::new(&self.symbolic, &self.l_values);
        let n = self.n;
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(b, n, 1),
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
        for (x, s) in b.iter_mut().zip(&self.scale) {
            *x *= s;
        }
        for &d in &self.dependent {
            b[d] = 0.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;

    use super::*;
    use crate::contract::system::Layout;
    use crate::linalg::testutil::{
        chain_layout, ladder_layout, random_jac, random_layout, rel_residual, Rng,
    };
    use crate::linalg::{ConstraintMatrix, PivotedCholesky, DEFAULT_PIVOT_TOL};

    fn sparse_for(
        k: &ConstraintMatrix,
        mode: Definiteness,
        kernel: SparseKernel,
    ) -> SparseCholesky {
        let p = k.pattern();
        let mut s =
            SparseCholesky::with_kernel(p.rows(), p.col_ptr(), p.row_idx(), mode, kernel).unwrap();
        s.values_mut().copy_from_slice(k.values());
        s
    }

    fn layouts() -> Vec<(&'static str, Layout)> {
        let mut rng = Rng::new(21);
        vec![
            ("chain", chain_layout(60, 3)),
            ("chain5", chain_layout(40, 5)),
            ("tree", random_layout(&mut rng, 70, 0, false)),
            ("loops", random_layout(&mut rng, 70, 0, true)),
            ("ladder", ladder_layout(25, 3)),
        ]
    }

    /// Random SPD block-sparse `K = BM⁻¹Bᵀ + εI` on chains, trees, loops and ladders:
    /// sparse solutions match nalgebra's dense Cholesky to 1e-9 relative (κ of these
    /// matrices ≤ ~1e5), with both kernels.
    #[test]
    fn sparse_matches_dense() {
        let mut rng = Rng::new(22);
        for (name, layout) in layouts() {
            let jac = random_jac(&mut rng, layout.rows);
            let mut k = ConstraintMatrix::new(&layout);
            k.assemble(&jac, &layout.mass, 1.0, 1e-3, None);
            let mut dense = DMatrix::zeros(layout.rows, layout.rows);
            k.to_dense(&mut dense);
            let b: Vec<f64> = (0..layout.rows).map(|_| rng.normal()).collect();
            let expect = dense
                .clone()
                .cholesky()
                .unwrap()
                .solve(&nalgebra::DVector::from_column_slice(&b));
            for kernel in [
                SparseKernel::Simplicial,
                SparseKernel::Supernodal,
                SparseKernel::Auto,
            ] {
                let mut s = sparse_for(&k, Definiteness::Positive, kernel);
                let st = s.factor().unwrap();
                assert_eq!(st.rank, layout.rows);
                let mut x = b.clone();
                s.solve_in_place(&mut x);
                let err =
                    (nalgebra::DVector::from_column_slice(&x) - &expect).amax() / expect.amax();
                assert!(err < 1e-9, "{name} {kernel:?}: {err}");
                assert!(rel_residual(&dense, &x, &b) < 1e-14, "{name} {kernel:?}");
                // Refactorization with new values reuses the analysis.
                for v in s.values_mut() {
                    *v *= 2.0;
                }
                s.factor().unwrap();
                let mut x2 = b.clone();
                s.solve_in_place(&mut x2);
                for i in 0..x.len() {
                    assert!((x2[i] - 0.5 * x[i]).abs() <= 1e-12 * expect.amax());
                }
            }
        }
    }

    /// Redundant rows: a loop closed by a joint whose rows repeat rows of another joint on
    /// the same body pair. Semidefinite mode finds exactly the known number of dependent
    /// rows (as the dense pivoted factorization does), and solves consistent systems.
    #[test]
    fn sparse_semidefinite_finds_redundant_rows() {
        let mut rng = Rng::new(23);
        // Chain of 30 bodies (3 rows per joint) + a duplicate of joint 10 (3 rows) + a
        // duplicate of 2 rows of joint 20: 5 dependent rows.
        let base = chain_layout(30, 3);
        let mut joints: Vec<_> = base.joints.iter().map(|j| (j.a, j.b, j.rows)).collect();
        joints.push((Some(9), Some(10), 3));
        joints.push((Some(19), Some(20), 2));
        let layout = crate::linalg::testutil::layout_from_joints(&mut rng, 30, &joints);
        let mut jac = random_jac(&mut rng, layout.rows);
        let m0 = 90;
        for k in 0..3 {
            jac[m0 + k] = jac[30 + k];
        }
        for k in 0..2 {
            jac[m0 + 3 + k] = jac[60 + k];
        }
        let mut k = ConstraintMatrix::new(&layout);
        k.assemble(&jac, &layout.mass, 1.0, 0.0, None);
        let mut dense = DMatrix::zeros(layout.rows, layout.rows);
        k.to_dense(&mut dense);
        let mut piv = PivotedCholesky::new(layout.rows, DEFAULT_PIVOT_TOL);
        assert_eq!(piv.factor(&dense).unwrap().rank, layout.rows - 5);
        let lam0 = nalgebra::DVector::from_fn(layout.rows, |_, _| rng.normal());
        let rhs: Vec<f64> = (&dense * &lam0).iter().copied().collect();
        for kernel in [SparseKernel::Simplicial, SparseKernel::Supernodal] {
            let mut s = sparse_for(
                &k,
                Definiteness::SemiDefinite {
                    tol: DEFAULT_PIVOT_TOL,
                },
                kernel,
            );
            assert!(!s.is_supernodal(), "semidefinite mode is always simplicial");
            let st = s.factor().unwrap();
            assert_eq!(st.rank, layout.rows - 5, "{kernel:?}");
            assert_eq!(s.dependent_rows().len(), 5);
            let mut x = rhs.clone();
            s.solve_in_place(&mut x);
            for &d in s.dependent_rows() {
                assert_eq!(x[d], 0.0);
            }
            let res = rel_residual(&dense, &x, &rhs);
            assert!(res < 1e-12, "{kernel:?}: residual {res}");
            // In strict mode the same matrix is an error at a dependent row.
            let mut strict = sparse_for(&k, Definiteness::Positive, kernel);
            match strict.factor() {
                Err(LinalgError::NotPositiveDefinite { row, .. }) => assert!(row < layout.rows),
                other => panic!("{kernel:?}: expected failure, got {other:?}"),
            }
        }
    }

    /// The reported step and row of a failed strict factorization are consistent with the
    /// ordering, for both kernels (which number their steps differently inside faer): the
    /// zero pivot comes from an exactly singular 2×2 block on rows 2 and 3.
    #[test]
    fn strict_failure_names_the_row() {
        // Pattern: tridiagonal 6×6; rows 2 and 3 identical ([1 1; 1 1] block), others 1.
        let n = 6;
        let mut col_ptr = vec![0];
        let mut row_idx = vec![];
        for s in 0..n {
            if s > 0 {
                row_idx.push(s - 1);
            }
            row_idx.push(s);
            col_ptr.push(row_idx.len());
        }
        for kernel in [SparseKernel::Simplicial, SparseKernel::Supernodal] {
            let mut c =
                SparseCholesky::with_kernel(n, &col_ptr, &row_idx, Definiteness::Positive, kernel)
                    .unwrap();
            for s in 0..n {
                for (v, &r) in c.values_mut()[col_ptr[s]..col_ptr[s + 1]]
                    .iter_mut()
                    .zip(&row_idx[col_ptr[s]..col_ptr[s + 1]])
                {
                    *v = if r == s || s == 3 { 1.0 } else { 0.0 };
                }
            }
            match c.factor() {
                Err(LinalgError::NotPositiveDefinite { step, row }) => {
                    assert!(row == 2 || row == 3, "{kernel:?}: row {row}");
                    assert_eq!(c.perm[step], row);
                }
                other => panic!("{kernel:?}: {other:?}"),
            }
        }
    }

    #[test]
    fn invalid_patterns_are_rejected() {
        // Missing diagonal in column 1.
        let e = SparseCholesky::new(2, &[0, 1, 2], &[0, 0], Definiteness::Positive);
        assert!(matches!(e, Err(LinalgError::Symbolic(_))));
        // Unsorted rows.
        let e = SparseCholesky::new(2, &[0, 1, 3], &[0, 1, 1], Definiteness::Positive);
        assert!(matches!(e, Err(LinalgError::Symbolic(_))));
    }
}
