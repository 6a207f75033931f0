//! An assembled symmetric matrix of a finite-element model: the compressed pattern of its
//! free–free block, the element → global scatter, and the rows of the constrained degrees
//! of freedom, which are eliminated from the solve.
//!
//! Degrees of freedom are numbered globally (`0..n_dofs`); each is either *free* (an unknown
//! of the solve, numbered `0..n_free` in increasing global order) or *constrained* (its
//! value is given: fixed, prescribed). With `u = (u_f, u_c)` the system `K u = f` splits
//! into
//!
//! ```text
//! K_ff u_f = f_f − K_fc u_c          (solved)
//! r_c      = K_cf u_f + K_cc u_c − f_c  (the reactions on the constrained dofs)
//! ```
//!
//! [`SymmetricAssembly`] stores `K_ff` as its upper triangle in compressed columns (rows
//! sorted, every diagonal present: the input of [`super::SparseCholesky`]), and the rows of
//! the constrained dofs, `[K_cf K_cc]`, in compressed rows over the global numbering (from
//! which `K_fc u_c` follows by symmetry). Elements are given by their global dof lists, in
//! blocks of one size; the scatter of every element entry to its place in either store is
//! computed once, so assembling values is one pass without searching, and the pattern is
//! reused for every factorization (and, later, by each subdomain of a decomposition).
//!
//! Built once before a run (it allocates); [`SymmetricAssembly::add_element`], the
//! products and [`SymmetricAssembly::reactions`] never allocate.

use super::LinalgError;

/// In a scatter map: the entry has no place (a constrained dof's column of `K_ff`, or the
/// lower triangle of `K_ff`).
pub const ELIMINATED: u32 = u32::MAX;

/// The global dof lists of one block of elements of equal size.
#[derive(Clone, Copy, Debug)]
pub struct ElementDofs<'a> {
    /// `per_element` global dofs per element, element after element.
    pub dofs: &'a [u32],
    /// Dofs per element (> 0).
    pub per_element: usize,
}

/// The pattern and scatter of an assembled symmetric matrix with constrained dofs
/// eliminated (see the module doc).
#[derive(Clone, Debug)]
pub struct SymmetricAssembly {
    n_dofs: usize,
    free_of: Vec<u32>,
    free: Vec<u32>,
    constrained: Vec<u32>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    c_ptr: Vec<usize>,
    c_col: Vec<u32>,
    /// Per block: per element entry `(r, c)` (row-major) its position in the `K_ff` values
    /// (upper triangle, both free), else [`ELIMINATED`].
    to_ff: Vec<Vec<u32>>,
    /// Per block: per element entry its position in the constrained rows' values (row `r`
    /// constrained), else [`ELIMINATED`].
    to_c: Vec<Vec<u32>>,
    per_element: Vec<usize>,
}

impl SymmetricAssembly {
    /// The pattern of the elements of `blocks` over `n_dofs` dofs, of which those with
    /// `constrained[g]` are eliminated. Every free dof gets a diagonal entry (zero when no
    /// element touches it: the factorization then reports that row).
    ///
    /// # Errors
    /// [`LinalgError::Dimension`]: `constrained` not of length `n_dofs`, a dof list not a
    /// multiple of its block's size, or a dof out of range; a pattern above `u32::MAX`
    /// entries.
    pub fn new(
        n_dofs: usize,
        constrained: &[bool],
        blocks: &[ElementDofs<'_>],
    ) -> Result<SymmetricAssembly, LinalgError> {
        if constrained.len() != n_dofs {
            return Err(LinalgError::Dimension {
                expected: n_dofs,
                got: constrained.len(),
            });
        }
        let mut free_of = vec![ELIMINATED; n_dofs];
        let mut free = Vec::new();
        let mut fixed = Vec::new();
        for (g, &c) in constrained.iter().enumerate() {
            if c {
                fixed.push(g as u32);
            } else {
                free_of[g] = free.len() as u32;
                free.push(g as u32);
            }
        }
        let mut constrained_of = vec![ELIMINATED; n_dofs];
        for (i, &g) in fixed.iter().enumerate() {
            constrained_of[g as usize] = i as u32;
        }
        // The entries: K_ff upper as (column, row) in free numbering, the constrained rows
        // as (constrained row, global column).
        let mut ff: Vec<u64> = (0..free.len() as u64).map(|j| (j << 32) | j).collect();
        let mut cr: Vec<u64> = Vec::new();
        for b in blocks {
            let d = b.per_element;
            if d == 0 || b.dofs.len() % d != 0 {
                return Err(LinalgError::Dimension {
                    expected: d.max(1) * (b.dofs.len() / d.max(1) + 1),
                    got: b.dofs.len(),
                });
            }
            if let Some(&g) = b.dofs.iter().find(|&&g| g as usize >= n_dofs) {
                return Err(LinalgError::Dimension {
                    expected: n_dofs,
                    got: g as usize + 1,
                });
            }
            for el in b.dofs.chunks_exact(d) {
                for &r in el {
                    let (fr, cr_r) = (free_of[r as usize], constrained_of[r as usize]);
                    for &c in el {
                        let fc = free_of[c as usize];
                        if fr != ELIMINATED && fc != ELIMINATED && fr <= fc {
                            ff.push(((fc as u64) << 32) | fr as u64);
                        }
                        if cr_r != ELIMINATED {
                            cr.push(((cr_r as u64) << 32) | c as u64);
                        }
                    }
                }
            }
        }
        ff.sort_unstable();
        ff.dedup();
        cr.sort_unstable();
        cr.dedup();
        if ff.len() >= u32::MAX as usize || cr.len() >= u32::MAX as usize {
            return Err(LinalgError::Dimension {
                expected: u32::MAX as usize - 1,
                got: ff.len().max(cr.len()),
            });
        }
        let compress = |keys: &[u64], n: usize| {
            let mut ptr = vec![0usize; n + 1];
            let mut idx = Vec::with_capacity(keys.len());
            for &k in keys {
                ptr[(k >> 32) as usize + 1] += 1;
                idx.push((k & 0xffff_ffff) as usize);
            }
            let mut total = 0;
            for p in ptr.iter_mut() {
                total += *p;
                *p = total;
            }
            (ptr, idx)
        };
        let (col_ptr, row_idx) = compress(&ff, free.len());
        let (c_ptr, c_idx) = compress(&cr, fixed.len());
        let c_col: Vec<u32> = c_idx.iter().map(|&g| g as u32).collect();
        let mut to_ff = Vec::with_capacity(blocks.len());
        let mut to_c = Vec::with_capacity(blocks.len());
        for b in blocks {
            let d = b.per_element;
            let mut sf = Vec::with_capacity(b.dofs.len() * d);
            let mut sc = Vec::with_capacity(b.dofs.len() * d);
            for el in b.dofs.chunks_exact(d) {
                for &r in el {
                    let (fr, cr_r) = (free_of[r as usize], constrained_of[r as usize]);
                    for &c in el {
                        let fc = free_of[c as usize];
                        sf.push(if fr != ELIMINATED && fc != ELIMINATED && fr <= fc {
                            let (lo, hi) = (col_ptr[fc as usize], col_ptr[fc as usize + 1]);
                            let k = row_idx[lo..hi].partition_point(|&x| x < fr as usize);
                            (lo + k) as u32
                        } else {
                            ELIMINATED
                        });
                        sc.push(if cr_r != ELIMINATED {
                            let (lo, hi) = (c_ptr[cr_r as usize], c_ptr[cr_r as usize + 1]);
                            let k = c_col[lo..hi].partition_point(|&x| x < c);
                            (lo + k) as u32
                        } else {
                            ELIMINATED
                        });
                    }
                }
            }
            to_ff.push(sf);
            to_c.push(sc);
        }
        Ok(SymmetricAssembly {
            n_dofs,
            free_of,
            free,
            constrained: fixed,
            col_ptr,
            row_idx,
            c_ptr,
            c_col,
            to_ff,
            to_c,
            per_element: blocks.iter().map(|b| b.per_element).collect(),
        })
    }

    /// Number of dofs (free and constrained).
    pub fn dofs(&self) -> usize {
        self.n_dofs
    }

    /// The free dofs' global numbers, in free order.
    pub fn free(&self) -> &[u32] {
        &self.free
    }

    /// The constrained dofs' global numbers, in increasing order (the order of the
    /// constrained rows and of [`SymmetricAssembly::reactions`]).
    pub fn constrained(&self) -> &[u32] {
        &self.constrained
    }

    /// The free index of global dof `g` (`None`: constrained or out of range).
    pub fn free_index(&self, g: usize) -> Option<usize> {
        self.free_of
            .get(g)
            .filter(|&&f| f != ELIMINATED)
            .map(|&f| f as usize)
    }

    /// Column pointers of `K_ff`'s upper triangle.
    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }

    /// Row indices of `K_ff`'s upper triangle (sorted per column, diagonal last).
    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }

    /// Stored entries of `K_ff` (upper triangle).
    pub fn nnz_free(&self) -> usize {
        self.row_idx.len()
    }

    /// Stored entries of the constrained rows.
    pub fn nnz_constrained(&self) -> usize {
        self.c_col.len()
    }

    /// Position of the diagonal entry of free column `j` in the `K_ff` values.
    pub fn diagonal(&self, j: usize) -> usize {
        self.col_ptr[j + 1] - 1
    }

    /// Add element `e` of block `block` with entries `ke(r, c)` (local dofs, in the order
    /// of its dof list) into the `K_ff` values `k_ff` ([`SymmetricAssembly::nnz_free`]) and
    /// the constrained rows' values `k_c` ([`SymmetricAssembly::nnz_constrained`]).
    ///
    /// # Panics
    /// When the block or element does not exist or a value slice is too short.
    pub fn add_element(
        &self,
        block: usize,
        e: usize,
        ke: impl Fn(usize, usize) -> f64,
        k_ff: &mut [f64],
        k_c: &mut [f64],
    ) {
        let d = self.per_element[block];
        let base = e * d * d;
        let (sf, sc) = (
            &self.to_ff[block][base..base + d * d],
            &self.to_c[block][base..base + d * d],
        );
        for r in 0..d {
            for c in 0..d {
                let (pf, pc) = (sf[r * d + c], sc[r * d + c]);
                if pf == ELIMINATED && pc == ELIMINATED {
                    continue;
                }
                let v = ke(r, c);
                if pf != ELIMINATED {
                    k_ff[pf as usize] += v;
                }
                if pc != ELIMINATED {
                    k_c[pc as usize] += v;
                }
            }
        }
    }

    /// `y = K_ff x` (free vectors) from the upper-triangle values `k_ff`.
    #[allow(clippy::needless_range_loop)] // j is the column of x, y and the pointers
    pub fn mul_free(&self, k_ff: &[f64], x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..self.free.len() {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                let (i, v) = (self.row_idx[p], k_ff[p]);
                y[i] += v * x[j];
                if i != j {
                    y[j] += v * x[i];
                }
            }
        }
    }

    /// `y −= K_fc u_c` (free vector `y`) from the constrained rows' values `k_c` and the
    /// global vector `u` (its constrained entries are read).
    pub fn sub_coupling(&self, k_c: &[f64], u: &[f64], y: &mut [f64]) {
        for (ci, &g) in self.constrained.iter().enumerate() {
            let uc = u[g as usize];
            if uc == 0.0 {
                continue;
            }
            let row = self.c_ptr[ci]..self.c_ptr[ci + 1];
            for (&col, &k) in self.c_col[row.clone()].iter().zip(&k_c[row]) {
                let f = self.free_of[col as usize];
                if f != ELIMINATED {
                    y[f as usize] -= k * uc;
                }
            }
        }
    }

    /// `r_c = [K_cf K_cc] u` for every constrained dof (in [`SymmetricAssembly::constrained`]
    /// order), from the global vector `u`.
    pub fn reactions(&self, k_c: &[f64], u: &[f64], r: &mut [f64]) {
        for (ci, rc) in r.iter_mut().enumerate().take(self.constrained.len()) {
            *rc = (self.c_ptr[ci]..self.c_ptr[ci + 1])
                .map(|p| k_c[p] * u[self.c_col[p] as usize])
                .sum();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::{Definiteness, SparseCholesky};

    /// A chain of three springs (stiffness 1, 2, 3) over 4 dofs, dof 0 fixed and dof 3
    /// prescribed to 1: the pattern, the eliminated solve and the reactions against the
    /// hand solution.
    #[test]
    fn spring_chain_with_fixed_and_prescribed_ends() {
        let dofs = [0u32, 1, 1, 2, 2, 3];
        let a = SymmetricAssembly::new(
            4,
            &[true, false, false, true],
            &[ElementDofs {
                dofs: &dofs,
                per_element: 2,
            }],
        )
        .unwrap();
        assert_eq!(a.free(), &[1, 2]);
        assert_eq!(a.constrained(), &[0, 3]);
        assert_eq!(a.col_ptr(), &[0, 1, 3]);
        assert_eq!(a.row_idx(), &[0, 0, 1]);
        let (mut kf, mut kc) = (vec![0.0; a.nnz_free()], vec![0.0; a.nnz_constrained()]);
        for (e, k) in [1.0, 2.0, 3.0].into_iter().enumerate() {
            let ke = |r: usize, c: usize| if r == c { k } else { -k };
            a.add_element(0, e, ke, &mut kf, &mut kc);
        }
        assert_eq!(kf, vec![3.0, -2.0, 5.0]);
        let mut ch =
            SparseCholesky::new(2, a.col_ptr(), a.row_idx(), Definiteness::Positive).unwrap();
        ch.values_mut().copy_from_slice(&kf);
        ch.factor().unwrap();
        let mut u = [0.0, 0.0, 0.0, 1.0];
        let mut rhs = [0.0; 2];
        a.sub_coupling(&kc, &u, &mut rhs);
        ch.solve_in_place(&mut rhs);
        // springs in series: flexibility 1 + 1/2 + 1/3 = 11/6, force 6/11
        let f = 6.0 / 11.0;
        assert!((rhs[0] - f).abs() < 1e-15 && (rhs[1] - f * 1.5).abs() < 1e-15);
        u[1] = rhs[0];
        u[2] = rhs[1];
        let mut r = [0.0; 2];
        a.reactions(&kc, &u, &mut r);
        assert!(
            (r[0] + f).abs() < 1e-15 && (r[1] - f).abs() < 1e-15,
            "{r:?}"
        );
        let mut y = [0.0; 2];
        a.mul_free(&kf, &u[1..3], &mut y);
        assert!(
            (y[0] - 0.0).abs() < 1e-15 && (y[1] - 3.0).abs() < 1e-15,
            "{y:?}"
        );
    }

    #[test]
    fn bad_input_is_an_error() {
        let ok = SymmetricAssembly::new(2, &[false], &[]);
        assert!(matches!(ok, Err(LinalgError::Dimension { .. })));
        let out = SymmetricAssembly::new(
            2,
            &[false, false],
            &[ElementDofs {
                dofs: &[0, 5],
                per_element: 2,
            }],
        );
        assert!(matches!(out, Err(LinalgError::Dimension { .. })));
        let ragged = SymmetricAssembly::new(
            2,
            &[false, false],
            &[ElementDofs {
                dofs: &[0, 1, 1],
                per_element: 2,
            }],
        );
        assert!(matches!(ragged, Err(LinalgError::Dimension { .. })));
    }
}
