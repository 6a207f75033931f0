//! Dense factorizations: Cholesky (faer), diagonally pivoted Cholesky (own), LU with
//! partial pivoting (faer), and column selection by complete pivoting (own).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::lu::partial_pivoting as plu;
use faer::perm::PermRef;
use faer::{MatMut, MatRef, Par};
use nalgebra::DMatrix;

use super::{jacobi_scale, FactorStats, LinalgError};

fn check_square(a: &DMatrix<f64>, n: usize) -> Result<(), LinalgError> {
    if a.nrows() != n {
        return Err(LinalgError::Dimension {
            expected: n,
            got: a.nrows(),
        });
    }
    if a.ncols() != n {
        return Err(LinalgError::Dimension {
            expected: n,
            got: a.ncols(),
        });
    }
    Ok(())
}

/// Copy the lower triangle of `a`, Jacobi-scaled, into the column-major `out`; fill
/// `scale`. Diagonals `≤ 0` get scale 0 (the caller decides whether that is an error).
fn scaled_lower(a: &DMatrix<f64>, scale: &mut [f64], out: &mut [f64]) -> Result<(), LinalgError> {
    let n = scale.len();
    for j in 0..n {
        let d = a[(j, j)];
        if !d.is_finite() {
            return Err(LinalgError::NonFinite { row: j });
        }
        scale[j] = jacobi_scale(d);
    }
    for j in 0..n {
        let col = &a.as_slice()[j * n..(j + 1) * n];
        let out = &mut out[j * n..(j + 1) * n];
        for i in j..n {
            let v = col[i];
            if !v.is_finite() {
                return Err(LinalgError::NonFinite { row: i });
            }
            out[i] = v * scale[i] * scale[j];
        }
    }
    Ok(())
}

/// One right-looking elimination step on the column-major lower triangle `a` (`n × n`):
/// column `j` is divided by `ljj` (already stored on the diagonal) and the trailing lower
/// triangle updated. Zero multipliers are skipped, which makes the kernel cheap on the
/// sparse-ish matrices of small multibody systems.
#[inline]
fn eliminate(a: &mut [f64], n: usize, j: usize) {
    let inv = 1.0 / a[j + j * n];
    for v in &mut a[j * n + j + 1..(j + 1) * n] {
        *v *= inv;
    }
    let (left, right) = a.split_at_mut((j + 1) * n);
    let colj = &left[j * n..(j + 1) * n];
    for c in j + 1..n {
        let f = colj[c];
        if f == 0.0 {
            continue;
        }
        let colc = &mut right[(c - j - 1) * n + c..(c - j) * n];
        for (x, l) in colc.iter_mut().zip(&colj[c..]) {
            *x -= l * f;
        }
    }
}

/// Solve `L₁₁ L₁₁ᵀ z = z` in place for the leading `r × r` block of the column-major
/// factor `a` (`n × n`).
fn llt_solve_leading(a: &[f64], n: usize, r: usize, z: &mut [f64]) {
    for k in 0..r {
        let zk = z[k] / a[k + k * n];
        z[k] = zk;
        if zk != 0.0 {
            for (zi, l) in z[k + 1..r].iter_mut().zip(&a[k * n + k + 1..k * n + r]) {
                *zi -= l * zk;
            }
        }
    }
    for k in (0..r).rev() {
        let col = &a[k * n + k + 1..k * n + r];
        let s: f64 = col.iter().zip(&z[k + 1..r]).map(|(l, v)| l * v).sum();
        z[k] = (z[k] - s) / a[k + k * n];
    }
}

/// Up to this size [`DenseCholesky`] uses its own unblocked kernel, whose call overhead
/// is lower than faer's (measured: 0.8 µs vs 2.5 µs for factor + solve at n = 6, and
/// about equal at n ≈ 100 on dense matrices); above, faer's blocked kernel (0.7 ms vs
/// 1.9 ms at n = 300).
const OWN_KERNEL_MAX: usize = 96;

/// Dense `LLᵀ` of a symmetric positive definite matrix on the Jacobi-scaled matrix: an
/// unblocked right-looking kernel up to 96 rows, faer's blocked kernel above. Only the
/// lower triangle of the input is read.
pub struct DenseCholesky {
    n: usize,
    l: Vec<f64>,
    scale: Vec<f64>,
    mem: MemBuffer,
    stats: Option<FactorStats>,
}

impl std::fmt::Debug for DenseCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DenseCholesky")
            .field("n", &self.n)
            .field("stats", &self.stats)
            .finish()
    }
}

impl DenseCholesky {
    /// Buffers for `n × n` matrices.
    pub fn new(n: usize) -> DenseCholesky {
        let req = llt::factor::cholesky_in_place_scratch::<f64>(n, Par::Seq, Default::default())
            .or(llt::solve::solve_in_place_scratch::<f64>(n, 1, Par::Seq));
        let mut c = DenseCholesky {
            n,
            l: vec![0.0; n * n],
            scale: vec![0.0; n],
            mem: MemBuffer::new(req),
            stats: None,
        };
        // faer initialises its kernels (CPU dispatch, caches) lazily on first use, which
        // allocates; do it here so that `factor` never does.
        let id = DMatrix::identity(n, n);
        c.factor(&id).expect("identity is positive definite");
        let mut b = vec![0.0; n];
        c.solve_in_place(&mut b);
        c.stats = None;
        c
    }

    /// Dimension.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Factor `a` (lower triangle read). Errors: [`LinalgError::NotPositiveDefinite`] with
    /// the failing row, [`LinalgError::NonFinite`], [`LinalgError::Dimension`].
    pub fn factor(&mut self, a: &DMatrix<f64>) -> Result<FactorStats, LinalgError> {
        self.stats = None;
        check_square(a, self.n)?;
        scaled_lower(a, &mut self.scale, &mut self.l)?;
        if let Some(j) = self.scale.iter().position(|&s| s == 0.0) {
            return Err(LinalgError::NotPositiveDefinite { step: j, row: j });
        }
        let n = self.n;
        if n <= OWN_KERNEL_MAX {
            for j in 0..n {
                let d = self.l[j + j * n];
                if d.is_nan() || d <= 0.0 {
                    return Err(LinalgError::NotPositiveDefinite { step: j, row: j });
                }
                self.l[j + j * n] = d.sqrt();
                eliminate(&mut self.l, n, j);
            }
        } else {
            let view = MatMut::from_column_major_slice_mut(&mut self.l, n, n);
            let stack = MemStack::new(&mut self.mem);
            llt::factor::cholesky_in_place(
                view,
                Default::default(),
                Par::Seq,
                stack,
                Default::default(),
            )
            .map_err(|llt::factor::LltError::NonPositivePivot { index }| {
                LinalgError::NotPositiveDefinite {
                    step: index,
                    row: index,
                }
            })?;
        }
        let mut stats = FactorStats::empty(n);
        for k in 0..n {
            let lkk = self.l[k + k * n];
            stats.accept(lkk * lkk);
        }
        self.stats = Some(stats);
        Ok(stats)
    }

    /// Solve `A x = b` in place with the last successful factorization.
    ///
    /// # Panics
    /// If there is no successful factorization or `b` has the wrong length.
    pub fn solve_in_place(&mut self, b: &mut [f64]) {
        assert!(
            self.stats.is_some(),
            "solve without a successful factorization"
        );
        assert_eq!(b.len(), self.n);
        let n = self.n;
        for (x, s) in b.iter_mut().zip(&self.scale) {
            *x *= s;
        }
        if n <= OWN_KERNEL_MAX {
            llt_solve_leading(&self.l, n, n, b);
        } else {
            let l = MatRef::from_column_major_slice(&self.l, n, n);
            let rhs = MatMut::from_column_major_slice_mut(b, n, 1);
            llt::solve::solve_in_place(l, rhs, Par::Seq, MemStack::new(&mut self.mem));
        }
        for (x, s) in b.iter_mut().zip(&self.scale) {
            *x *= s;
        }
    }

    /// Statistics of the last successful factorization.
    pub fn stats(&self) -> Option<FactorStats> {
        self.stats
    }
}

/// Diagonally pivoted `LLᵀ` for positive *semi*definite matrices (redundant
/// constraints). Works on the Jacobi-scaled matrix; at each step takes the largest
/// remaining Schur diagonal and stops when it is `≤ tol`: the rows not eliminated are
/// dependent. Solves return the basic solution with the dependent rows' unknowns zero,
/// which solves the system exactly when the right-hand side is consistent.
#[derive(Clone, Debug)]
pub struct PivotedCholesky {
    n: usize,
    tol: f64,
    a: Vec<f64>,
    scale: Vec<f64>,
    /// `perm[k]` = original row eliminated at step `k`.
    perm: Vec<usize>,
    dependent: Vec<usize>,
    work: Vec<f64>,
    stats: Option<FactorStats>,
}

impl PivotedCholesky {
    /// Buffers for `n × n` matrices, relative pivot tolerance `tol`
    /// (see [`super::DEFAULT_PIVOT_TOL`]).
    pub fn new(n: usize, tol: f64) -> PivotedCholesky {
        PivotedCholesky {
            n,
            tol,
            a: vec![0.0; n * n],
            scale: vec![0.0; n],
            perm: (0..n).collect(),
            dependent: Vec::with_capacity(n),
            work: vec![0.0; n],
            stats: None,
        }
    }

    /// Dimension.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// The pivot tolerance.
    pub fn tol(&self) -> f64 {
        self.tol
    }

    /// Swap indices `j < p` of the partially factored matrix held in the lower triangle.
    fn sym_swap(&mut self, j: usize, p: usize) {
        let n = self.n;
        let a = &mut self.a;
        for c in 0..j {
            a.swap(j + c * n, p + c * n);
        }
        a.swap(j + j * n, p + p * n);
        for i in j + 1..p {
            a.swap(i + j * n, p + i * n);
        }
        for i in p + 1..n {
            a.swap(i + j * n, i + p * n);
        }
        self.perm.swap(j, p);
    }

    /// Factor `a` (lower triangle read). Errors: [`LinalgError::NonFinite`], a negative
    /// diagonal entry ([`LinalgError::NotPositiveDefinite`] with `step` 0),
    /// [`LinalgError::Dimension`]. Rank deficiency is not an error: see
    /// [`FactorStats::rank`] and [`PivotedCholesky::dependent_rows`].
    pub fn factor(&mut self, k: &DMatrix<f64>) -> Result<FactorStats, LinalgError> {
        self.stats = None;
        self.dependent.clear();
        check_square(k, self.n)?;
        let n = self.n;
        if let Some(j) = (0..n).find(|&j| k[(j, j)] < 0.0) {
            return Err(LinalgError::NotPositiveDefinite { step: 0, row: j });
        }
        scaled_lower(k, &mut self.scale, &mut self.a)?;
        for (i, p) in self.perm.iter_mut().enumerate() {
            *p = i;
        }
        let mut stats = FactorStats::empty(n);
        let mut j = 0;
        while j < n {
            // Largest remaining pivot (first one on ties: keeps the original order).
            let mut p = j;
            let mut dmax = self.a[j + j * n];
            for i in j + 1..n {
                let d = self.a[i + i * n];
                if d > dmax {
                    dmax = d;
                    p = i;
                }
            }
            if dmax.is_nan() {
                return Err(LinalgError::NonFinite { row: self.perm[p] });
            }
            if dmax <= self.tol {
                break;
            }
            if p != j {
                self.sym_swap(j, p);
            }
            self.a[j + j * n] = dmax.sqrt();
            eliminate(&mut self.a, n, j);
            stats.accept(dmax);
            j += 1;
        }
        self.dependent.extend_from_slice(&self.perm[j..]);
        self.dependent.sort_unstable();
        self.stats = Some(stats);
        Ok(stats)
    }

    /// Rows found dependent by the last factorization (sorted, original numbering).
    pub fn dependent_rows(&self) -> &[usize] {
        &self.dependent
    }

    /// Statistics of the last successful factorization.
    pub fn stats(&self) -> Option<FactorStats> {
        self.stats
    }

    /// Solve `A x = b` in place: the basic solution, zero in the dependent rows.
    ///
    /// # Panics
    /// If there is no successful factorization or `b` has the wrong length.
    pub fn solve_in_place(&mut self, b: &mut [f64]) {
        let stats = self
            .stats
            .expect("solve without a successful factorization");
        assert_eq!(b.len(), self.n);
        let (n, r) = (self.n, stats.rank);
        let z = &mut self.work;
        for (zk, &i) in z.iter_mut().zip(&self.perm) {
            *zk = b[i] * self.scale[i];
        }
        llt_solve_leading(&self.a, n, r, z);
        for v in &mut z[r..n] {
            *v = 0.0;
        }
        for (zk, &i) in z.iter().zip(&self.perm) {
            b[i] = zk * self.scale[i];
        }
    }
}

/// What an LU factorization found: the extreme absolute pivots of `U`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LuStats {
    /// Smallest `|U_kk|`.
    pub min_abs_pivot: f64,
    /// Largest `|U_kk|`.
    pub max_abs_pivot: f64,
}

impl LuStats {
    /// `min |U_kk| / max |U_kk|`: a (rough) reciprocal condition indicator.
    pub fn pivot_ratio(&self) -> f64 {
        self.min_abs_pivot / self.max_abs_pivot
    }
}

/// Dense LU with partial (row) pivoting, `PA = LU` (faer's recursive blocked kernel), for
/// the Newton systems of the implicit methods.
pub struct DenseLu {
    n: usize,
    lu: Vec<f64>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    mem: MemBuffer,
    stats: Option<LuStats>,
}

impl std::fmt::Debug for DenseLu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DenseLu")
            .field("n", &self.n)
            .field("stats", &self.stats)
            .finish()
    }
}

impl DenseLu {
    /// Buffers for `n × n` matrices.
    pub fn new(n: usize) -> DenseLu {
        let req =
            plu::factor::lu_in_place_scratch::<usize, f64>(n, n, Par::Seq, Default::default())
                .or(plu::solve::solve_in_place_scratch::<usize, f64>(
                    n,
                    1,
                    Par::Seq,
                ))
                .or(plu::solve::solve_transpose_in_place_scratch::<usize, f64>(
                    n,
                    1,
                    Par::Seq,
                ));
        let mut lu = DenseLu {
            n,
            lu: vec![0.0; n * n],
            perm: vec![0; n],
            perm_inv: vec![0; n],
            mem: MemBuffer::new(req),
            stats: None,
        };
        // Warm up faer's lazily initialised kernels (see DenseCholesky::new).
        lu.factor(&DMatrix::identity(n, n))
            .expect("identity is regular");
        let mut b = vec![0.0; n];
        lu.solve_in_place(&mut b);
        lu.solve_transpose_in_place(&mut b);
        lu.stats = None;
        lu
    }

    /// Dimension.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Factor `a`. Errors: [`LinalgError::Singular`] when a pivot is exactly zero,
    /// [`LinalgError::NonFinite`], [`LinalgError::Dimension`]. A tiny nonzero pivot is
    /// not an error; check [`LuStats::pivot_ratio`].
    pub fn factor(&mut self, a: &DMatrix<f64>) -> Result<LuStats, LinalgError> {
        self.stats = None;
        check_square(a, self.n)?;
        let n = self.n;
        for (idx, (dst, &src)) in self.lu.iter_mut().zip(a.as_slice()).enumerate() {
            if !src.is_finite() {
                return Err(LinalgError::NonFinite { row: idx % n });
            }
            *dst = src;
        }
        let view = MatMut::from_column_major_slice_mut(&mut self.lu, n, n);
        plu::factor::lu_in_place(
            view,
            &mut self.perm,
            &mut self.perm_inv,
            Par::Seq,
            MemStack::new(&mut self.mem),
            Default::default(),
        );
        let mut st = LuStats {
            min_abs_pivot: f64::INFINITY,
            max_abs_pivot: 0.0,
        };
        for k in 0..n {
            let u = self.lu[k + k * n].abs();
            if u == 0.0 {
                return Err(LinalgError::Singular { pivot: k });
            }
            st.min_abs_pivot = st.min_abs_pivot.min(u);
            st.max_abs_pivot = st.max_abs_pivot.max(u);
        }
        if n == 0 {
            st = LuStats {
                min_abs_pivot: 1.0,
                max_abs_pivot: 1.0,
            };
        }
        self.stats = Some(st);
        Ok(st)
    }

    /// Statistics of the last successful factorization.
    pub fn stats(&self) -> Option<LuStats> {
        self.stats
    }

    /// Solve `A x = b` in place.
    ///
    /// # Panics
    /// If there is no successful factorization or `b` has the wrong length.
    pub fn solve_in_place(&mut self, b: &mut [f64]) {
        assert!(
            self.stats.is_some(),
            "solve without a successful factorization"
        );
        assert_eq!(b.len(), self.n);
        let n = self.n;
        let lu = MatRef::from_column_major_slice(&self.lu, n, n);
        let perm = PermRef::new_checked(&self.perm, &self.perm_inv, n);
        let rhs = MatMut::from_column_major_slice_mut(b, n, 1);
        plu::solve::solve_in_place(lu, lu, perm, rhs, Par::Seq, MemStack::new(&mut self.mem));
    }

    /// Solve `Aᵀ x = b` in place.
    ///
    /// # Panics
    /// If there is no successful factorization or `b` has the wrong length.
    pub fn solve_transpose_in_place(&mut self, b: &mut [f64]) {
        assert!(
            self.stats.is_some(),
            "solve without a successful factorization"
        );
        assert_eq!(b.len(), self.n);
        let n = self.n;
        let lu = MatRef::from_column_major_slice(&self.lu, n, n);
        let perm = PermRef::new_checked(&self.perm, &self.perm_inv, n);
        let rhs = MatMut::from_column_major_slice_mut(b, n, 1);
        plu::solve::solve_transpose_in_place(
            lu,
            lu,
            perm,
            rhs,
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
    }
}

/// Result of [`ColumnSelector::select`]: a split of the columns of an `m × n` matrix `B`
/// into linearly independent columns and the rest.
///
/// For coordinate partitioning (notes A §1.3, eq. 14) the independent columns form the
/// nonsingular `B_i`: their coordinates are the *dependent* coordinates `u_i`, solved
/// from the constraints; the other columns form `B_e`, the independent coordinates `u_e`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ColumnSelection {
    /// Numerical rank of `B`.
    pub rank: usize,
    /// `rank` linearly independent columns, ascending.
    pub independent: Vec<usize>,
    /// The other columns, ascending.
    pub dependent: Vec<usize>,
    /// Rows of `B` that are (numerically) combinations of the others, ascending
    /// (empty when `B` has full row rank).
    pub dependent_rows: Vec<usize>,
}

/// Selects independent columns of an `m × n` matrix by Gaussian elimination with
/// complete pivoting (at each step the largest remaining entry in magnitude). Elimination
/// stops when that entry is `≤ tol · max|B|`. Buffers are allocated at construction.
#[derive(Clone, Debug)]
pub struct ColumnSelector {
    m: usize,
    n: usize,
    tol: f64,
    a: Vec<f64>,
    rowp: Vec<usize>,
    colp: Vec<usize>,
    sel: ColumnSelection,
}

impl ColumnSelector {
    /// Buffers for `m × n` matrices, relative tolerance `tol` (e.g. `1e-10`).
    pub fn new(m: usize, n: usize, tol: f64) -> ColumnSelector {
        ColumnSelector {
            m,
            n,
            tol,
            a: vec![0.0; m * n],
            rowp: vec![0; m],
            colp: vec![0; n],
            sel: ColumnSelection {
                rank: 0,
                independent: Vec::with_capacity(n),
                dependent: Vec::with_capacity(n),
                dependent_rows: Vec::with_capacity(m),
            },
        }
    }

    /// Select the columns of `b`. Allocation-free.
    ///
    /// # Errors
    /// [`LinalgError::Dimension`] on a shape mismatch, [`LinalgError::NonFinite`].
    pub fn select(&mut self, b: &DMatrix<f64>) -> Result<&ColumnSelection, LinalgError> {
        let (m, n) = (self.m, self.n);
        if b.nrows() != m {
            return Err(LinalgError::Dimension {
                expected: m,
                got: b.nrows(),
            });
        }
        if b.ncols() != n {
            return Err(LinalgError::Dimension {
                expected: n,
                got: b.ncols(),
            });
        }
        let mut amax0 = 0.0f64;
        for (idx, (dst, &src)) in self.a.iter_mut().zip(b.as_slice()).enumerate() {
            if !src.is_finite() {
                return Err(LinalgError::NonFinite {
                    row: idx % m.max(1),
                });
            }
            *dst = src;
            amax0 = amax0.max(src.abs());
        }
        for (i, p) in self.rowp.iter_mut().enumerate() {
            *p = i;
        }
        for (j, p) in self.colp.iter_mut().enumerate() {
            *p = j;
        }
        let a = &mut self.a;
        let thresh = self.tol * amax0;
        let mut k = 0;
        while k < m.min(n) {
            let (mut pi, mut pj, mut pv) = (k, k, 0.0f64);
            for j in k..n {
                for i in k..m {
                    let v = a[i + j * m].abs();
                    if v > pv {
                        (pi, pj, pv) = (i, j, v);
                    }
                }
            }
            if pv <= thresh || pv == 0.0 {
                break;
            }
            if pi != k {
                for j in 0..n {
                    a.swap(k + j * m, pi + j * m);
                }
                self.rowp.swap(k, pi);
            }
            if pj != k {
                for i in 0..m {
                    a.swap(i + k * m, i + pj * m);
                }
                self.colp.swap(k, pj);
            }
            let inv = 1.0 / a[k + k * m];
            for v in &mut a[k * m + k + 1..(k + 1) * m] {
                *v *= inv;
            }
            let (left, right) = a.split_at_mut((k + 1) * m);
            let colk = &left[k * m..(k + 1) * m];
            for j in k + 1..n {
                let colj = &mut right[(j - k - 1) * m..(j - k) * m];
                let f = colj[k];
                if f != 0.0 {
                    for (x, l) in colj[k + 1..].iter_mut().zip(&colk[k + 1..]) {
                        *x -= l * f;
                    }
                }
            }
            k += 1;
        }
        let sel = &mut self.sel;
        sel.rank = k;
        sel.independent.clear();
        sel.independent.extend_from_slice(&self.colp[..k]);
        sel.independent.sort_unstable();
        sel.dependent.clear();
        sel.dependent.extend_from_slice(&self.colp[k..]);
        sel.dependent.sort_unstable();
        sel.dependent_rows.clear();
        sel.dependent_rows.extend_from_slice(&self.rowp[k..]);
        sel.dependent_rows.sort_unstable();
        Ok(&self.sel)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::testutil::{rel_residual, spd_with_eigenvalues, Rng};
    use crate::linalg::DEFAULT_PIVOT_TOL;

    fn random_spd(rng: &mut Rng, n: usize, lo: f64, hi: f64) -> DMatrix<f64> {
        let eig: Vec<f64> = (0..n)
            .map(|i| lo * (hi / lo).powf(i as f64 / (n.max(2) - 1) as f64))
            .collect();
        let mut a = spd_with_eigenvalues(rng, &eig);
        // Unequal row scales (units differ between rows).
        let s: Vec<f64> = (0..n)
            .map(|_| 10f64.powf(3.0 * rng.uniform() - 1.5))
            .collect();
        for i in 0..n {
            for j in 0..n {
                a[(i, j)] *= s[i] * s[j];
            }
        }
        a
    }

    /// Cholesky solutions agree with nalgebra's to 1e-10 relative (κ ≤ 1e3 before row
    /// scaling; both are backward stable, so the difference is ≲ κ·ε·n).
    #[test]
    fn cholesky_matches_nalgebra() {
        let mut rng = Rng::new(1);
        for &n in &[1usize, 2, 5, 31, 64, 130, 300] {
            let a = random_spd(&mut rng, n, 1.0, 1e3);
            let b: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
            let mut c = DenseCholesky::new(n);
            let st = c.factor(&a).unwrap();
            assert_eq!(st.rank, n);
            let mut x = b.clone();
            c.solve_in_place(&mut x);
            let expect = a
                .clone()
                .cholesky()
                .unwrap()
                .solve(&nalgebra::DVector::from_column_slice(&b));
            let err = (nalgebra::DVector::from_column_slice(&x) - &expect).amax() / expect.amax();
            assert!(err < 1e-10, "n={n}: relative difference {err}");
            assert!(rel_residual(&a, &x, &b) < 1e-14, "n={n}");
        }
    }

    #[test]
    fn cholesky_reports_failing_pivot() {
        // Indefinite: the third pivot is 1 − 4 = −3 < 0.
        let a = DMatrix::from_row_slice(
            4,
            4,
            &[
                1.0, 0.0, 2.0, 0.0, //
                0.0, 1.0, 0.0, 0.0, //
                2.0, 0.0, 1.0, 0.0, //
                0.0, 0.0, 0.0, 1.0,
            ],
        );
        let mut c = DenseCholesky::new(4);
        assert_eq!(
            c.factor(&a),
            Err(LinalgError::NotPositiveDefinite { step: 2, row: 2 })
        );
        assert!(c.stats().is_none());
        // A zero diagonal.
        let mut z = DMatrix::identity(3, 3);
        z[(1, 1)] = 0.0;
        assert_eq!(
            c_factor(&z),
            Err(LinalgError::NotPositiveDefinite { step: 1, row: 1 })
        );
        // Non-finite entries.
        let mut nf = DMatrix::identity(3, 3);
        nf[(2, 0)] = f64::NAN;
        assert_eq!(c_factor(&nf), Err(LinalgError::NonFinite { row: 2 }));
        // Above the own-kernel size, faer's kernel reports the step 0-based too: rows 110
        // and 111 form a singular block.
        let mut big = DMatrix::identity(120, 120);
        big[(110, 111)] = 1.0;
        big[(111, 110)] = 1.0;
        assert_eq!(
            c_factor(&big),
            Err(LinalgError::NotPositiveDefinite {
                step: 111,
                row: 111
            })
        );
        // Wrong size.
        assert_eq!(
            c_factor_n(&DMatrix::identity(2, 2), 3),
            Err(LinalgError::Dimension {
                expected: 3,
                got: 2
            })
        );
    }

    fn c_factor(a: &DMatrix<f64>) -> Result<FactorStats, LinalgError> {
        c_factor_n(a, a.nrows())
    }
    fn c_factor_n(a: &DMatrix<f64>, n: usize) -> Result<FactorStats, LinalgError> {
        DenseCholesky::new(n).factor(a)
    }

    /// A PSD matrix `G Gᵀ` (G: n × r, random) has rank r: the pivoted factorization finds
    /// exactly `n − r` dependent rows, and solves consistent systems to 1e-12 (relative
    /// residual), with zeros in the dependent rows.
    #[test]
    fn pivoted_cholesky_finds_known_rank() {
        let mut rng = Rng::new(2);
        for &(n, r) in &[
            (1usize, 0usize),
            (4, 1),
            (10, 7),
            (40, 25),
            (120, 119),
            (200, 150),
        ] {
            let g = DMatrix::from_fn(n, r, |_, _| rng.normal());
            let a = &g * g.transpose();
            let mut p = PivotedCholesky::new(n, DEFAULT_PIVOT_TOL);
            let st = p.factor(&a).unwrap();
            assert_eq!(st.rank, r, "n={n}");
            assert_eq!(p.dependent_rows().len(), n - r);
            // Consistent right-hand side.
            let x0 = nalgebra::DVector::from_fn(n, |_, _| rng.normal());
            let b: Vec<f64> = (&a * &x0).iter().copied().collect();
            let mut x = b.clone();
            p.solve_in_place(&mut x);
            for &d in p.dependent_rows() {
                assert_eq!(x[d], 0.0);
            }
            if r > 0 {
                let res = rel_residual(&a, &x, &b);
                assert!(res < 1e-12, "n={n} r={r}: residual {res}");
            }
        }
    }

    /// Redundant constraints in the multibody sense: K = B M⁻¹ Bᵀ with a row of B
    /// repeated and a row equal to a combination of two others. The later copies are the
    /// ones reported (ties keep the original order), and the solution of a consistent
    /// system matches nalgebra's solution of the reduced (independent) system.
    #[test]
    fn pivoted_cholesky_on_redundant_jacobian() {
        let mut rng = Rng::new(3);
        let (m, n) = (8, 12);
        let mut b = DMatrix::from_fn(m, n, |_, _| rng.normal());
        let r1 = b.row(1).clone_owned();
        b.set_row(5, &r1);
        let r7 = b.row(2) * 2.0 - b.row(3);
        b.set_row(7, &r7);
        let minv =
            DMatrix::from_diagonal(&nalgebra::DVector::from_fn(n, |_, _| 0.5 + rng.uniform()));
        let k = &b * &minv * b.transpose();
        let mut p = PivotedCholesky::new(m, DEFAULT_PIVOT_TOL);
        let st = p.factor(&k).unwrap();
        assert_eq!(st.rank, 6);
        assert_eq!(p.dependent_rows().len(), 2);
        // One of {1, 5} and one of {2, 3, 7} are dependent.
        let dep = p.dependent_rows().to_vec();
        assert!(dep.iter().any(|d| [1, 5].contains(d)));
        assert!(dep.iter().any(|d| [2, 3, 7].contains(d)));
        let lam0 = nalgebra::DVector::from_fn(m, |_, _| rng.normal());
        let rhs: Vec<f64> = (&k * &lam0).iter().copied().collect();
        let mut lam = rhs.clone();
        p.solve_in_place(&mut lam);
        // Reference: drop the dependent rows and solve with nalgebra.
        let keep: Vec<usize> = (0..m).filter(|i| !dep.contains(i)).collect();
        let kr = DMatrix::from_fn(keep.len(), keep.len(), |i, j| k[(keep[i], keep[j])]);
        let br = nalgebra::DVector::from_fn(keep.len(), |i, _| rhs[keep[i]]);
        let xr = kr.cholesky().unwrap().solve(&br);
        for (i, &row) in keep.iter().enumerate() {
            assert!((lam[row] - xr[i]).abs() <= 1e-10 * xr.amax(), "row {row}");
        }
        // Constraint forces Bᵀλ are unique even though λ is not.
        let f = b.transpose() * nalgebra::DVector::from_column_slice(&lam);
        let f0 = b.transpose() * &lam0;
        assert!((f - &f0).amax() <= 1e-10 * f0.amax());
    }

    /// κ = 1e12: the strict factorization succeeds and its pivot ratio exposes the
    /// conditioning; the pivoted one accepts the small pivot with tol 1e-15 and rejects it
    /// (rank n − 1) with tol 1e-9.
    #[test]
    fn near_singular_is_reported() {
        let mut rng = Rng::new(4);
        let n = 30;
        let mut eig = vec![1.0; n];
        for (i, e) in eig.iter_mut().enumerate() {
            *e = 1.0 + i as f64 / n as f64;
        }
        eig[0] = 1e-12;
        let a = spd_with_eigenvalues(&mut rng, &eig);
        let st = DenseCholesky::new(n).factor(&a).unwrap();
        assert!(
            st.pivot_ratio() < 1e-10 && st.pivot_ratio() > 1e-14,
            "strict ratio {}",
            st.pivot_ratio()
        );
        let mut p = PivotedCholesky::new(n, 1e-15);
        let st = p.factor(&a).unwrap();
        assert_eq!(st.rank, n);
        assert!(
            st.pivot_ratio() < 1e-10 && st.pivot_ratio() > 1e-14,
            "pivoted ratio {}",
            st.pivot_ratio()
        );
        let mut p = PivotedCholesky::new(n, 1e-9);
        let st = p.factor(&a).unwrap();
        assert_eq!(st.rank, n - 1);
        assert_eq!(p.dependent_rows().len(), 1);
        assert!(st.pivot_ratio() > 1e-3);
    }

    #[test]
    fn pivoted_cholesky_errors() {
        let mut p = PivotedCholesky::new(2, 1e-12);
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, -1.0]);
        assert_eq!(
            p.factor(&a),
            Err(LinalgError::NotPositiveDefinite { step: 0, row: 1 })
        );
        let a = DMatrix::from_row_slice(2, 2, &[1.0, f64::INFINITY, f64::INFINITY, 1.0]);
        assert_eq!(p.factor(&a), Err(LinalgError::NonFinite { row: 1 }));
        // Zero rows are dependent, not errors.
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 0.0, 0.0, 2.0]);
        let st = p.factor(&a).unwrap();
        assert_eq!((st.rank, p.dependent_rows()), (1, &[0usize][..]));
        let mut x = vec![0.0, 4.0];
        p.solve_in_place(&mut x);
        assert_eq!(x[0], 0.0);
        assert!((x[1] - 2.0).abs() < 1e-15);
    }

    /// LU solutions agree with nalgebra's LU to 1e-10 relative on random matrices
    /// (κ ~ 1e2–1e3), both `A x = b` and `Aᵀ x = b`.
    #[test]
    fn lu_matches_nalgebra() {
        let mut rng = Rng::new(5);
        for &n in &[1usize, 3, 17, 64, 150] {
            let a = DMatrix::from_fn(n, n, |i, j| rng.normal() + if i == j { 3.0 } else { 0.0 });
            let b: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
            let mut lu = DenseLu::new(n);
            lu.factor(&a).unwrap();
            let mut x = b.clone();
            lu.solve_in_place(&mut x);
            let bv = nalgebra::DVector::from_column_slice(&b);
            let expect = a.clone().lu().solve(&bv).unwrap();
            let err = (nalgebra::DVector::from_column_slice(&x) - &expect).amax() / expect.amax();
            assert!(err < 1e-10, "n={n}: {err}");
            let mut xt = b.clone();
            lu.solve_transpose_in_place(&mut xt);
            let expect = a.transpose().lu().solve(&bv).unwrap();
            let err = (nalgebra::DVector::from_column_slice(&xt) - &expect).amax() / expect.amax();
            assert!(err < 1e-10, "n={n} transpose: {err}");
        }
    }

    #[test]
    fn lu_detects_singularity() {
        let mut lu = DenseLu::new(3);
        let a = DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 0.0, 3.0, 4.0, 0.0, 5.0, 6.0, 0.0]);
        assert_eq!(lu.factor(&a), Err(LinalgError::Singular { pivot: 2 }));
        let mut a = DMatrix::identity(3, 3);
        a[(2, 2)] = 1e-13;
        let st = lu.factor(&a).unwrap();
        assert!((st.pivot_ratio() - 1e-13).abs() < 1e-20);
        a[(0, 1)] = f64::NAN;
        assert_eq!(lu.factor(&a), Err(LinalgError::NonFinite { row: 0 }));
    }

    /// Full row rank: m independent columns are chosen and `B_i` is well conditioned
    /// (smallest singular value ≥ 1e-3 of the largest, checked with nalgebra's SVD).
    /// Rank-deficient rows and zero columns are reported.
    #[test]
    fn column_selection() {
        let mut rng = Rng::new(6);
        let (m, n) = (6, 15);
        let mut b = DMatrix::from_fn(m, n, |_, _| rng.normal());
        b.column_mut(4).fill(0.0);
        let mut sel = ColumnSelector::new(m, n, 1e-10);
        let s = sel.select(&b).unwrap().clone();
        assert_eq!(s.rank, m);
        assert_eq!(s.independent.len(), m);
        assert_eq!(s.dependent.len(), n - m);
        assert!(s.dependent.contains(&4));
        assert!(s.dependent_rows.is_empty());
        let bi = DMatrix::from_fn(m, m, |i, j| b[(i, s.independent[j])]);
        let sv = bi.singular_values();
        assert!(sv.min() > 1e-3 * sv.max(), "B_i singular values {sv}");
        // A dependent row: row 5 = row 0 − 3·row 2.
        let r5 = b.row(0) - b.row(2) * 3.0;
        b.set_row(5, &r5);
        let s = sel.select(&b).unwrap();
        assert_eq!(s.rank, m - 1);
        assert_eq!(s.dependent_rows.len(), 1);
        assert!([0, 2, 5].contains(&s.dependent_rows[0]));
        assert_eq!(s.independent.len() + s.dependent.len(), n);
    }
}
