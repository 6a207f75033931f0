//! [`KSolver`]: assembly of `K = s·B M⁻¹ Bᵀ + εI` plus a dense or sparse factorization,
//! chosen once from the size and density of `K`.

use nalgebra::DMatrix;

use super::dense::{DenseCholesky, PivotedCholesky};
use super::kmatrix::ConstraintMatrix;
use super::sparse::SparseCholesky;
use super::{Definiteness, FactorStats, LinalgError};
use crate::contract::system::{Layout, MassProps, RowJac};

/// Rows from which [`Backend::Auto`] considers the sparse factorization (measured
/// crossover, see the module doc of [`crate::linalg`]).
pub const SPARSE_MIN_ROWS: usize = 40;
/// In semidefinite mode the dense diagonally pivoted factorization is kept up to this
/// many rows (it chooses better-conditioned independent rows).
pub const SPARSE_MIN_ROWS_SEMIDEFINITE: usize = 100;
/// Largest density of `K` (nonzeros of the full matrix over rows²) for which
/// [`Backend::Auto`] chooses the sparse factorization.
pub const SPARSE_MAX_DENSITY: f64 = 0.3;

/// Which factorization a [`KSolver`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Backend {
    /// Dense below [`SPARSE_MIN_ROWS`] rows (semidefinite: [`SPARSE_MIN_ROWS_SEMIDEFINITE`])
    /// or above [`SPARSE_MAX_DENSITY`], sparse otherwise.
    #[default]
    Auto,
    /// Always dense.
    Dense,
    /// Always sparse.
    Sparse,
}

/// The factorization a [`KSolver`] ended up with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendKind {
    /// [`DenseCholesky`].
    DenseCholesky,
    /// [`PivotedCholesky`].
    DensePivoted,
    /// [`SparseCholesky`].
    Sparse,
}

/// Options of a [`KSolver`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KSolverOptions {
    /// Dense, sparse or automatic.
    pub backend: Backend,
    /// Positive definite (e.g. `εI + δ²BM⁻¹Bᵀ` with `ε > 0`) or semidefinite (`BM⁻¹Bᵀ` with
    /// possibly redundant constraints).
    pub definiteness: Definiteness,
}

impl Default for KSolverOptions {
    fn default() -> Self {
        KSolverOptions {
            backend: Backend::Auto,
            definiteness: Definiteness::Positive,
        }
    }
}

enum Imp {
    Dense {
        a: DMatrix<f64>,
        chol: DenseCholesky,
    },
    Pivoted {
        a: DMatrix<f64>,
        chol: PivotedCholesky,
    },
    Sparse(Box<SparseCholesky>),
}

/// Solver for `K λ = r` with `K = scale · B M⁻¹ Bᵀ + shift · I`: the matrix the
/// constraint methods solve every step. All storage (pattern, values, factor, work
/// space) is allocated by [`KSolver::new`]; `assemble`, `factor` and `solve_in_place`
/// never allocate.
pub struct KSolver {
    k: ConstraintMatrix,
    imp: Imp,
    empty: Vec<usize>,
}

impl std::fmt::Debug for KSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("KSolver")
            .field("rows", &self.k.rows())
            .field("nnz", &self.k.pattern().nnz())
            .field("backend", &self.backend())
            .finish()
    }
}

impl KSolver {
    /// Build the pattern from the layout, choose the backend and allocate.
    ///
    /// # Errors
    /// [`LinalgError::Symbolic`] if the sparse analysis fails.
    pub fn new(layout: &Layout, options: KSolverOptions) -> Result<KSolver, LinalgError> {
        let k = ConstraintMatrix::new(layout);
        let n = k.rows();
        let semidefinite = matches!(options.definiteness, Definiteness::SemiDefinite { .. });
        let min_rows = if semidefinite {
            SPARSE_MIN_ROWS_SEMIDEFINITE
        } else {
            SPARSE_MIN_ROWS
        };
        let sparse = match options.backend {
            Backend::Dense => false,
            Backend::Sparse => true,
            Backend::Auto => n >= min_rows && k.pattern().density() <= SPARSE_MAX_DENSITY,
        };
        let imp = if sparse {
            let p = k.pattern();
            Imp::Sparse(Box::new(SparseCholesky::new(
                n,
                p.col_ptr(),
                p.row_idx(),
                options.definiteness,
            )?))
        } else {
            match options.definiteness {
                Definiteness::Positive => Imp::Dense {
                    a: DMatrix::zeros(n, n),
                    chol: DenseCholesky::new(n),
                },
                Definiteness::SemiDefinite { tol } => Imp::Pivoted {
                    a: DMatrix::zeros(n, n),
                    chol: PivotedCholesky::new(n, tol),
                },
            }
        };
        Ok(KSolver {
            k,
            imp,
            empty: Vec::new(),
        })
    }

    /// The factorization in use.
    pub fn backend(&self) -> BackendKind {
        match self.imp {
            Imp::Dense { .. } => BackendKind::DenseCholesky,
            Imp::Pivoted { .. } => BackendKind::DensePivoted,
            Imp::Sparse(_) => BackendKind::Sparse,
        }
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.k.rows()
    }

    /// The assembled matrix.
    pub fn matrix(&self) -> &ConstraintMatrix {
        &self.k
    }

    /// Assemble `K = scale · B M⁻¹ Bᵀ + shift · I` (see [`ConstraintMatrix::assemble`],
    /// including the treatment of inactive rows).
    pub fn assemble(
        &mut self,
        jac: &[RowJac],
        mass: &[MassProps],
        scale: f64,
        shift: f64,
        active: Option<&[bool]>,
    ) {
        self.k.assemble(jac, mass, scale, shift, active);
    }

    /// Add a per-row diagonal to the assembled matrix (see
    /// [`ConstraintMatrix::add_diagonal`]).
    pub fn add_diagonal(&mut self, d: &[f64], active: Option<&[bool]>) {
        self.k.add_diagonal(d, active);
    }

    /// Factor the assembled matrix.
    ///
    /// # Errors
    /// See [`DenseCholesky::factor`], [`PivotedCholesky::factor`], [`SparseCholesky::factor`].
    pub fn factor(&mut self) -> Result<FactorStats, LinalgError> {
        match &mut self.imp {
            Imp::Dense { a, chol } => {
                a.fill(0.0);
                self.k.scatter_lower(a);
                chol.factor(a)
            }
            Imp::Pivoted { a, chol } => {
                a.fill(0.0);
                self.k.scatter_lower(a);
                chol.factor(a)
            }
            Imp::Sparse(s) => {
                s.values_mut().copy_from_slice(self.k.values());
                s.factor()
            }
        }
    }

    /// Solve `K x = b` in place with the last factorization (dependent rows' unknowns are
    /// zero in semidefinite mode).
    ///
    /// # Panics
    /// If there is no successful factorization or `b` has the wrong length.
    pub fn solve_in_place(&mut self, b: &mut [f64]) {
        match &mut self.imp {
            Imp::Dense { chol, .. } => chol.solve_in_place(b),
            Imp::Pivoted { chol, .. } => chol.solve_in_place(b),
            Imp::Sparse(s) => s.solve_in_place(b),
        }
    }

    /// Rows found dependent by the last factorization (always empty in positive mode).
    pub fn dependent_rows(&self) -> &[usize] {
        match &self.imp {
            Imp::Dense { .. } => &self.empty,
            Imp::Pivoted { chol, .. } => chol.dependent_rows(),
            Imp::Sparse(s) => s.dependent_rows(),
        }
    }

    /// Statistics of the last successful factorization.
    pub fn stats(&self) -> Option<FactorStats> {
        match &self.imp {
            Imp::Dense { chol, .. } => chol.stats(),
            Imp::Pivoted { chol, .. } => chol.stats(),
            Imp::Sparse(s) => s.stats(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::testutil::{
        chain_layout, dense_b, dense_minv, ladder_layout, random_jac, rel_residual, Rng,
    };
    use crate::linalg::DEFAULT_PIVOT_TOL;

    /// Every backend solves `(εI + δ²BM⁻¹Bᵀ) λ = r` like nalgebra on the dense product
    /// (relative difference < 1e-9).
    #[test]
    fn backends_agree_with_dense_reference() {
        let mut rng = Rng::new(31);
        for layout in [chain_layout(80, 3), ladder_layout(30, 5)] {
            let jac = random_jac(&mut rng, layout.rows);
            let (eps, d2) = (1e-6, 2.5e-7);
            let b = dense_b(&layout, &jac);
            let k = &b * dense_minv(&layout) * b.transpose() * d2
                + DMatrix::identity(layout.rows, layout.rows) * eps;
            let r: Vec<f64> = (0..layout.rows).map(|_| rng.normal()).collect();
            let expect = k
                .clone()
                .cholesky()
                .unwrap()
                .solve(&nalgebra::DVector::from_column_slice(&r));
            for backend in [Backend::Dense, Backend::Sparse, Backend::Auto] {
                for definiteness in [
                    Definiteness::Positive,
                    Definiteness::SemiDefinite {
                        tol: DEFAULT_PIVOT_TOL,
                    },
                ] {
                    let mut s = KSolver::new(
                        &layout,
                        KSolverOptions {
                            backend,
                            definiteness,
                        },
                    )
                    .unwrap();
                    s.assemble(&jac, &layout.mass, d2, eps, None);
                    let st = s.factor().unwrap();
                    assert_eq!(st.rank, layout.rows);
                    let mut x = r.clone();
                    s.solve_in_place(&mut x);
                    let err =
                        (nalgebra::DVector::from_column_slice(&x) - &expect).amax() / expect.amax();
                    assert!(
                        err < 1e-9,
                        "{backend:?} {definiteness:?} ({:?}): {err}",
                        s.backend()
                    );
                    assert!(rel_residual(&k, &x, &r) < 1e-13);
                }
            }
        }
    }

    /// Systems without constraints (free bodies) get a working 0 × 0 solver.
    #[test]
    fn zero_rows() {
        let layout = chain_layout(3, 0);
        assert_eq!(layout.rows, 0);
        for backend in [Backend::Dense, Backend::Sparse] {
            for definiteness in [
                Definiteness::Positive,
                Definiteness::SemiDefinite { tol: 1e-12 },
            ] {
                let mut s = KSolver::new(
                    &layout,
                    KSolverOptions {
                        backend,
                        definiteness,
                    },
                )
                .unwrap();
                s.assemble(&[], &layout.mass, 1.0, 0.0, None);
                assert_eq!(s.factor().unwrap().rank, 0);
                s.solve_in_place(&mut []);
            }
        }
    }

    #[test]
    fn auto_chooses_by_size() {
        let kind = |layout: &Layout, options| KSolver::new(layout, options).unwrap().backend();
        let pos = KSolverOptions::default();
        assert_eq!(kind(&chain_layout(10, 3), pos), BackendKind::DenseCholesky);
        assert_eq!(kind(&chain_layout(20, 3), pos), BackendKind::Sparse);
        // Dense K (all rows share the hub body) stays dense.
        assert_eq!(
            kind(&crate::linalg::testutil::star_layout(40, 3), pos),
            BackendKind::DenseCholesky
        );
        let semi = KSolverOptions {
            backend: Backend::Auto,
            definiteness: Definiteness::SemiDefinite { tol: 1e-12 },
        };
        assert_eq!(kind(&chain_layout(30, 3), semi), BackendKind::DensePivoted);
        assert_eq!(kind(&chain_layout(40, 3), semi), BackendKind::Sparse);
    }

    /// Masked rows: their unknown equals the right-hand side, the rest is the solution of
    /// the system without them.
    #[test]
    fn inactive_rows() {
        let mut rng = Rng::new(32);
        let layout = chain_layout(6, 3);
        let jac = random_jac(&mut rng, layout.rows);
        let mut active = vec![true; layout.rows];
        active[7] = false;
        let mut s = KSolver::new(&layout, KSolverOptions::default()).unwrap();
        s.assemble(&jac, &layout.mass, 1.0, 0.0, Some(&active));
        s.factor().unwrap();
        let mut r: Vec<f64> = (0..layout.rows).map(|_| rng.normal()).collect();
        r[7] = 0.0;
        let mut x = r.clone();
        s.solve_in_place(&mut x);
        assert_eq!(x[7], 0.0);
        let b = dense_b(&layout, &jac);
        let k = &b * dense_minv(&layout) * b.transpose();
        let keep: Vec<usize> = (0..layout.rows).filter(|&i| i != 7).collect();
        let kr = DMatrix::from_fn(keep.len(), keep.len(), |i, j| k[(keep[i], keep[j])]);
        let xr = kr
            .cholesky()
            .unwrap()
            .solve(&nalgebra::DVector::from_fn(keep.len(), |i, _| r[keep[i]]));
        for (i, &row) in keep.iter().enumerate() {
            assert!((x[row] - xr[i]).abs() < 1e-10 * xr.amax());
        }
    }

    /// Timing of factor + solve per backend and size (run with `--ignored --nocapture`);
    /// the numbers in the module doc come from here.
    #[test]
    #[ignore]
    fn measure_dense_sparse_crossover() {
        use std::time::Instant;
        let mut rng = Rng::new(33);
        let cases: Vec<(&str, Layout)> = [2usize, 4, 8, 12, 20, 40, 80, 160]
            .iter()
            .flat_map(|&n| {
                [
                    ("chain", chain_layout(n, 3)),
                    ("ladder", ladder_layout(n / 2, 3)),
                    (
                        "tree",
                        crate::linalg::testutil::random_layout(
                            &mut Rng::new(n as u64),
                            n,
                            0,
                            false,
                        ),
                    ),
                ]
            })
            .chain(
                [4usize, 8, 16, 32, 64, 100]
                    .iter()
                    .map(|&n| ("star", crate::linalg::testutil::star_layout(n, 3))),
            )
            .chain([("chain", chain_layout(10_000, 3))])
            .collect();
        for (name, layout) in cases {
            let jac = random_jac(&mut rng, layout.rows);
            let mut line = format!(
                "{name:>7} m = {:>5}, density {:.3}:",
                layout.rows,
                ConstraintMatrix::new(&layout).pattern().density()
            );
            for (label, backend, def) in [
                ("dense", Backend::Dense, Definiteness::Positive),
                ("sparse", Backend::Sparse, Definiteness::Positive),
                (
                    "dense-piv",
                    Backend::Dense,
                    Definiteness::SemiDefinite { tol: 1e-12 },
                ),
                (
                    "sparse-semi",
                    Backend::Sparse,
                    Definiteness::SemiDefinite { tol: 1e-12 },
                ),
            ] {
                if backend == Backend::Dense && layout.rows > 3000 {
                    continue;
                }
                let mut s = KSolver::new(
                    &layout,
                    KSolverOptions {
                        backend,
                        definiteness: def,
                    },
                )
                .unwrap();
                let mut x = vec![1.0; layout.rows];
                let reps = 20;
                let mut best = f64::INFINITY;
                for _ in 0..reps {
                    let t = Instant::now();
                    s.assemble(&jac, &layout.mass, 1.0, 1e-6, None);
                    s.factor().unwrap();
                    s.solve_in_place(&mut x);
                    best = best.min(t.elapsed().as_secs_f64());
                }
                line += &format!("  {label} {:.4} ms", best * 1e3);
            }
            println!("{line}");
        }
        // The 30 000-row chain split into assembly and factor + solve.
        let layout = chain_layout(10_000, 3);
        let jac = random_jac(&mut rng, layout.rows);
        let mut s = KSolver::new(
            &layout,
            KSolverOptions {
                backend: Backend::Sparse,
                ..Default::default()
            },
        )
        .unwrap();
        let mut x = vec![1.0; layout.rows];
        let (mut best_a, mut best_f) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..20 {
            let t = Instant::now();
            s.assemble(&jac, &layout.mass, 1.0, 1e-6, None);
            best_a = best_a.min(t.elapsed().as_secs_f64());
            let t = Instant::now();
            s.factor().unwrap();
            s.solve_in_place(&mut x);
            best_f = best_f.min(t.elapsed().as_secs_f64());
        }
        println!(
            "chain 30000 rows: assemble {:.3} ms, factor + solve {:.3} ms",
            best_a * 1e3,
            best_f * 1e3
        );
        // Dense 300×300 factor + solve, any pattern.
        let n = 300;
        let a = crate::linalg::testutil::spd_with_eigenvalues(
            &mut rng,
            &(0..n).map(|i| 1.0 + i as f64).collect::<Vec<_>>(),
        );
        let mut c = DenseCholesky::new(n);
        let mut p = PivotedCholesky::new(n, 1e-12);
        let mut x = vec![1.0; n];
        let (mut best_c, mut best_p) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..20 {
            let t = Instant::now();
            c.factor(&a).unwrap();
            c.solve_in_place(&mut x);
            best_c = best_c.min(t.elapsed().as_secs_f64());
            let t = Instant::now();
            p.factor(&a).unwrap();
            p.solve_in_place(&mut x);
            best_p = best_p.min(t.elapsed().as_secs_f64());
        }
        println!(
            "dense 300x300: cholesky {:.3} ms, pivoted {:.3} ms",
            best_c * 1e3,
            best_p * 1e3
        );
    }
}
