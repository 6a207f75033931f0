//! Linear algebra for constrained dynamics: assembly of `K = B M⁻¹ Bᵀ`, dense and sparse
//! symmetric solvers, LU, and column selection. Every solver allocates its buffers at
//! construction; `factor` and `solve_in_place` never allocate.
//!
//! # What is solved (notes A §1.2–1.6, C §1)
//!
//! All constraint methods need a symmetric matrix built from the row-wise Jacobian `B`
//! (`m × 6n`, one [`RowJac`](crate::contract::system::RowJac) per row) and the block-diagonal mass
//! matrix `M = diag(mᵢ I₃, Jᵢ)`:
//!
//! - index-1 / Baumgarte / implicit trapezoid: `K = B M⁻¹ Bᵀ` (eqs. 5, 11);
//! - staggered stabilization (LINT): `K = εI + δ² B M⁻¹ Bᵀ` (eq. 32);
//! - coordinate partitioning: `B = [B_i B_e]` with `B_i` nonsingular (eq. 14), see
//!   [`ColumnSelector`].
//!
//! # Assembly ([`ConstraintMatrix`])
//!
//! Each row touches at most two bodies, so `K_rs ≠ 0` only when rows `r` and `s` share a
//! body. [`KPattern::new`] derives that sparsity pattern once from the [`Layout`] (for each
//! body the rows touching it; every pair of those rows is an entry) together with, for
//! each entry, which sides (a/b) of the two rows meet on a common body. Assembly then
//! computes `W = M⁻¹ Bᵀ` per row side (6 numbers) and each entry as a sum of at most four
//! 6-term dot products. Cost: `O(nnz(K))`.
//!
//! # Scaling and the meaning of a pivot
//!
//! Every symmetric factorization here works on the Jacobi-scaled matrix
//! `K̃ = S K S`, `S = diag(K_ii^{-1/2})`, so `K̃` has a unit diagonal. A Cholesky pivot of
//! `K̃` is then `d_k = K_kk⁻¹ · (Schur-complement diagonal of row k)`, which equals
//! `sin² θ_k`, θ_k being the angle (in the `M⁻¹` metric) between row `k` and the span of the
//! rows eliminated before it. This makes the dependence test scale-free (translational
//! and rotational rows, heavy and light bodies are treated alike) and gives
//! [`FactorStats::pivot_ratio`] — smallest over largest accepted pivot — as a cheap
//! conditioning indicator (`κ(K̃) ≳ 1/pivot_ratio`).
//!
//! # Solvers
//!
//! | Type | Matrix | Algorithm |
//! |---|---|---|
//! | [`DenseCholesky`] | SPD | `LLᵀ` of the scaled matrix: own unblocked kernel up to 96 rows, faer's blocked kernel above |
//! | [`PivotedCholesky`] | PSD | diagonally pivoted right-looking `LLᵀ` (own code), stops when the largest remaining pivot `≤ tol`; reports rank, dependent rows and pivot ratio; solves return the basic solution (dependent rows' unknowns = 0) |
//! | [`SparseCholesky`] | SPD or PSD | faer sparse `LLᵀ`: AMD ordering and symbolic analysis once, numeric refactorization into preallocated storage with a preallocated `MemStack`. PSD mode: pivots `≤ tol` of the scaled matrix are replaced by `10¹⁰⁰` (faer's dynamic regularization), which decouples that unknown (simplicial kernel only, see [`SparseCholesky::with_kernel`]); those rows are reported dependent and their unknowns set to 0 |
//! | [`DenseLu`] | general square | faer's partial-pivoting LU (Newton systems) |
//! | [`ColumnSelector`] | `m × n` | Gaussian elimination with complete pivoting (own code): independent columns, dependent columns, rank, dependent rows |
//! | [`KSolver`] | `εI + s·BM⁻¹Bᵀ` | assembly + one of the above, dense or sparse chosen by size and density |
//!
//! Finite-element matrices (the meshes' implicit analyses): [`SymmetricAssembly`]
//! ([`assembled`]) holds the pattern of an assembled stiffness with its constrained dofs
//! eliminated and the element → global scatter, for [`SparseCholesky`].
//!
//! Why faer for the sparse path: its numeric refactorization takes the value array, the
//! output array and a `MemStack` from the caller, so a factorization per step performs no
//! allocation (checked by `runtime/tests/alloc_free_solvers_output.rs` with a counting allocator), and its AMD
//! ordering and supernodal kernels are better than a hand-written envelope solver. Its
//! only gap — no rank-revealing sparse factorization — is covered by the static-order
//! threshold test above: for a PSD matrix a zero Schur diagonal implies a zero Schur
//! row, so static-order elimination with a relative threshold finds the rank exactly in
//! exact arithmetic; diagonal pivoting is only better at ordering *which* of several
//! nearly-dependent rows is dropped, which the dense path does.
//!
//! # Dense or sparse ([`Backend::Auto`])
//!
//! Measured with `cargo test -p mbdc-runtime --lib measure_dense_sparse_crossover --
//! --ignored --nocapture` (test profile, opt-level 2, one core of a shared 2-core VM, best
//! of 20): assemble + factor + solve of `K = BM⁻¹Bᵀ + εI` with random Jacobian rows
//! (3 rows per joint), in ms.
//!
//! | pattern | rows | density | dense | sparse | dense pivoted | sparse semidefinite |
//! |---|---|---|---|---|---|---|
//! | chain | 12 | 0.63 | 0.0014 | 0.0020 | 0.0018 | 0.0020 |
//! | chain | 36 | 0.24 | 0.0066 | 0.0061 | 0.0103 | 0.0061 |
//! | tree | 40 | 0.30 | 0.0093 | 0.0086 | 0.0129 | 0.0086 |
//! | chain | 120 | 0.074 | 0.127 | 0.021 | 0.099 | 0.020 |
//! | ladder | 357 | 0.041 | 1.04 | 0.16 | 1.79 | 0.16 |
//! | tree | 540 | 0.028 | 3.85 | 0.25 | 2.37 | 0.15 |
//! | star (dense K) | 51 | 1 | 0.024 | 0.048 | 0.031 | 0.048 |
//! | star (dense K) | 303 | 1 | 0.95 | 2.34 | 2.40 | 8.0 |
//! | chain | 30 000 | 1e-4 | — | 5.6 | — | 5.7 |
//!
//! A dense 300 × 300 SPD matrix: factor + solve 0.65 ms ([`DenseCholesky`]), 1.8 ms
//! ([`PivotedCholesky`]). The 30 000-row chain split up (another, busier run): assembly
//! 1.0 ms, factor + solve 4.6 ms. Timings on this shared machine vary by up to ~1.5×
//! between runs; the ratios are stable.
//!
//! Sparse wins from about 40 rows for multibody patterns (which have density ≲ 0.3 there
//! and fall as 1/rows); dense wins on dense `K` (one body carrying every joint) at every
//! size, by about 2×. `Auto` therefore picks sparse when `rows ≥ 40` and
//! `density ≤ 0.3`. In semidefinite mode it keeps the dense diagonally pivoted
//! factorization up to 100 rows (≤ 0.1 ms): pivoting chooses better-conditioned
//! independent rows when several are nearly dependent.
//!
//! [`Layout`]: crate::contract::system::Layout

pub mod assembled;
mod dense;
mod kmatrix;
mod solver;
mod sparse;

#[cfg(test)]
pub(crate) mod testutil;

pub use assembled::{ElementDofs, SymmetricAssembly};
pub use dense::{
    ColumnSelection, ColumnSelector, DenseCholesky, DenseLu, LuStats, PivotedCholesky,
};
pub use kmatrix::{jac_mul, jac_t_mul, mass_inv_mul, ConstraintMatrix, KPattern};
pub use solver::{
    Backend, BackendKind, KSolver, KSolverOptions, SPARSE_MAX_DENSITY, SPARSE_MIN_ROWS,
    SPARSE_MIN_ROWS_SEMIDEFINITE,
};
pub use sparse::{SparseCholesky, SparseKernel};

/// Default relative pivot tolerance of the semidefinite factorizations: a row whose scaled
/// pivot `sin² θ` is at most this is dependent (θ ≲ 1e-6 rad). Rounding puts exactly
/// dependent rows at `≲ n·ε ≈ 1e-13` for `n ≤ 1000`, so this leaves a margin of ~10.
pub const DEFAULT_PIVOT_TOL: f64 = 1e-12;

/// Errors of the factorizations.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LinalgError {
    /// A Cholesky factorization met a pivot that is not positive.
    #[error("matrix is not positive definite: elimination step {step} failed at row {row}")]
    NotPositiveDefinite {
        /// Elimination step (0-based) at which the pivot was not positive.
        step: usize,
        /// The row (original numbering) whose pivot failed.
        row: usize,
    },
    /// An LU factorization met a zero pivot.
    #[error("matrix is singular: LU pivot {pivot} is zero")]
    Singular {
        /// Pivot index (0-based elimination step).
        pivot: usize,
    },
    /// The matrix contains NaN or infinity.
    #[error("matrix has a non-finite entry in row {row}")]
    NonFinite {
        /// A row containing the entry.
        row: usize,
    },
    /// A matrix or vector has the wrong size.
    #[error("dimension mismatch: expected {expected}, got {got}")]
    Dimension {
        /// Expected size.
        expected: usize,
        /// Given size.
        got: usize,
    },
    /// The sparse symbolic analysis failed (index overflow, out of memory).
    #[error("sparse symbolic analysis failed: {0}")]
    Symbolic(String),
}

/// Whether a symmetric factorization must find a positive definite matrix or accepts a
/// semidefinite one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Definiteness {
    /// Strictly positive definite: a pivot `≤ 0` is an error
    /// ([`LinalgError::NotPositiveDefinite`]).
    Positive,
    /// Positive semidefinite: scaled pivots `≤ tol` mark dependent rows (see the module
    /// doc), whose unknowns are set to zero by the solves.
    SemiDefinite {
        /// Relative pivot tolerance, e.g. [`DEFAULT_PIVOT_TOL`].
        tol: f64,
    },
}

/// What a symmetric factorization found. Pivots are those of the Jacobi-scaled matrix
/// (see the module doc), so they lie in `(0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FactorStats {
    /// Matrix dimension.
    pub dim: usize,
    /// Numerical rank (accepted pivots).
    pub rank: usize,
    /// Smallest accepted scaled pivot (1 when `rank == 0`).
    pub min_pivot: f64,
    /// Largest accepted scaled pivot (1 when `rank == 0`).
    pub max_pivot: f64,
}

impl FactorStats {
    /// Ratio of the smallest to the largest accepted pivot: a conditioning indicator,
    /// `κ(K̃) ≳ 1 / pivot_ratio`.
    pub fn pivot_ratio(&self) -> f64 {
        self.min_pivot / self.max_pivot
    }

    /// Number of dependent rows (`dim − rank`).
    pub fn deficiency(&self) -> usize {
        self.dim - self.rank
    }

    pub(crate) fn empty(dim: usize) -> FactorStats {
        FactorStats {
            dim,
            rank: 0,
            min_pivot: 1.0,
            max_pivot: 1.0,
        }
    }

    /// Accumulate an accepted pivot.
    pub(crate) fn accept(&mut self, d: f64) {
        if self.rank == 0 {
            self.min_pivot = d;
            self.max_pivot = d;
        } else {
            self.min_pivot = self.min_pivot.min(d);
            self.max_pivot = self.max_pivot.max(d);
        }
        self.rank += 1;
    }
}

/// Jacobi scale factor of a diagonal entry: `1/√d` for `d > 0`, 0 otherwise (a zero or
/// negative diagonal makes the row dependent or the matrix indefinite; callers decide).
#[inline]
pub(crate) fn jacobi_scale(d: f64) -> f64 {
    if d > 0.0 {
        1.0 / d.sqrt()
    } else {
        0.0
    }
}
