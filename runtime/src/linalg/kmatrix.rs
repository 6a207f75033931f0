//! Sparsity pattern and assembly of `K = s·B M⁻¹ Bᵀ + εI`, and the products `B x`, `Bᵀ y`,
//! `M⁻¹ x` on flat generalized-velocity vectors (6 numbers per body: `v` then `ω`).

use nalgebra::DMatrix;

use crate::contract::system::{Layout, MassProps, RowJac};

/// Side combinations of an entry `(r, s)`: bit 0 `a_r = a_s`, bit 1 `a_r = b_s`,
/// bit 2 `b_r = a_s`, bit 3 `b_r = b_s` (same body, not ground).
const AA: u8 = 1;
const AB: u8 = 2;
const BA: u8 = 4;
const BB: u8 = 8;

/// The sparsity pattern of `K = B M⁻¹ Bᵀ`: the upper triangle (diagonal included) in
/// compressed-column form, rows sorted within each column, the diagonal last.
///
/// Entry `(r, s)` is present iff rows `r` and `s` touch a common body (ground excluded).
/// Every diagonal entry is present, even for a row that touches only ground.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KPattern {
    /// Bodies of each row (side a, side b).
    row_bodies: Vec<(Option<usize>, Option<usize>)>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Per entry: which sides of the two rows meet on a common body.
    links: Vec<u8>,
}

impl KPattern {
    /// The pattern of a system's constraint rows.
    pub fn new(layout: &Layout) -> KPattern {
        let rb: Vec<_> = (0..layout.rows).map(|r| layout.row_bodies(r)).collect();
        KPattern::from_row_bodies(&rb, layout.bodies())
    }

    /// The pattern for rows touching the given bodies (side a, side b; `None` = ground),
    /// with `bodies` bodies in total.
    ///
    /// # Panics
    /// If a body index is `≥ bodies`.
    pub fn from_row_bodies(
        row_bodies: &[(Option<usize>, Option<usize>)],
        bodies: usize,
    ) -> KPattern {
        let m = row_bodies.len();
        // Rows touching each body (a row touching the same body twice is listed once).
        let mut body_rows: Vec<Vec<usize>> = vec![Vec::new(); bodies];
        for (r, &(a, b)) in row_bodies.iter().enumerate() {
            if let Some(a) = a {
                body_rows[a].push(r);
            }
            if let Some(b) = b {
                if Some(b) != a {
                    body_rows[b].push(r);
                }
            }
        }
        let mut col_ptr = Vec::with_capacity(m + 1);
        let mut row_idx = Vec::new();
        let mut links = Vec::new();
        let mut mark = vec![usize::MAX; m];
        let mut col: Vec<usize> = Vec::new();
        col_ptr.push(0);
        for s in 0..m {
            col.clear();
            let (a_s, b_s) = row_bodies[s];
            for body in [a_s, b_s].into_iter().flatten() {
                for &r in &body_rows[body] {
                    if r <= s && mark[r] != s {
                        mark[r] = s;
                        col.push(r);
                    }
                }
            }
            if mark[s] != s {
                col.push(s);
            }
            col.sort_unstable();
            for &r in &col {
                let (a_r, b_r) = row_bodies[r];
                let same = |x: Option<usize>, y: Option<usize>| x.is_some() && x == y;
                let mut l = 0u8;
                if same(a_r, a_s) {
                    l |= AA;
                }
                if same(a_r, b_s) {
                    l |= AB;
                }
                if same(b_r, a_s) {
                    l |= BA;
                }
                if same(b_r, b_s) {
                    l |= BB;
                }
                row_idx.push(r);
                links.push(l);
            }
            col_ptr.push(row_idx.len());
        }
        KPattern {
            row_bodies: row_bodies.to_vec(),
            col_ptr,
            row_idx,
            links,
        }
    }

    /// Number of rows (= columns) of `K`.
    pub fn rows(&self) -> usize {
        self.row_bodies.len()
    }

    /// Stored entries (upper triangle including the diagonal).
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Fraction of nonzero entries of the full symmetric matrix, `(2·nnz − rows)/rows²`.
    pub fn density(&self) -> f64 {
        let n = self.rows();
        if n == 0 {
            return 0.0;
        }
        (2 * self.nnz() - n) as f64 / (n as f64 * n as f64)
    }

    /// Column pointers (length `rows + 1`).
    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }

    /// Row indices of the stored entries, column by column.
    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }

    /// Bodies of row `r` (side a, side b).
    pub fn row_bodies(&self, r: usize) -> (Option<usize>, Option<usize>) {
        self.row_bodies[r]
    }
}

/// `K = s·B M⁻¹ Bᵀ + εI` stored on its [`KPattern`], with preallocated work space, so
/// that [`ConstraintMatrix::assemble`] does not allocate.
#[derive(Clone, Debug)]
pub struct ConstraintMatrix {
    pattern: KPattern,
    values: Vec<f64>,
    /// `M⁻¹ B_aᵀ` and `M⁻¹ B_bᵀ` per row.
    wa: Vec<[f64; 6]>,
    wb: Vec<[f64; 6]>,
}

#[inline]
fn dot6(x: &[f64; 6], y: &[f64; 6]) -> f64 {
    x[0] * y[0] + x[1] * y[1] + x[2] * y[2] + x[3] * y[3] + x[4] * y[4] + x[5] * y[5]
}

#[inline]
fn minv_row(mp: &MassProps, b: &[f64; 6]) -> [f64; 6] {
    let inv_m = 1.0 / mp.m;
    let j = &mp.j_inv;
    [
        b[0] * inv_m,
        b[1] * inv_m,
        b[2] * inv_m,
        j[(0, 0)] * b[3] + j[(0, 1)] * b[4] + j[(0, 2)] * b[5],
        j[(1, 0)] * b[3] + j[(1, 1)] * b[4] + j[(1, 2)] * b[5],
        j[(2, 0)] * b[3] + j[(2, 1)] * b[4] + j[(2, 2)] * b[5],
    ]
}

impl ConstraintMatrix {
    /// Storage for the constraint matrix of a system.
    pub fn new(layout: &Layout) -> ConstraintMatrix {
        ConstraintMatrix::with_pattern(KPattern::new(layout))
    }

    /// Storage on a given pattern.
    pub fn with_pattern(pattern: KPattern) -> ConstraintMatrix {
        let m = pattern.rows();
        let nnz = pattern.nnz();
        ConstraintMatrix {
            pattern,
            values: vec![0.0; nnz],
            wa: vec![[0.0; 6]; m],
            wb: vec![[0.0; 6]; m],
        }
    }

    /// The pattern.
    pub fn pattern(&self) -> &KPattern {
        &self.pattern
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.pattern.rows()
    }

    /// The stored values, aligned with [`KPattern::row_idx`].
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Assemble `K = scale · B M⁻¹ Bᵀ + shift · I` from the Jacobian rows and the bodies'
    /// mass properties. Rows with `active[r] == false` get a unit diagonal and no
    /// off-diagonal entries (their unknown then equals its right-hand side; callers set
    /// that to zero). Allocation-free.
    ///
    /// # Panics
    /// If `jac` (or `active`) does not have one entry per row, or a row refers to a body
    /// without mass properties.
    pub fn assemble(
        &mut self,
        jac: &[RowJac],
        mass: &[MassProps],
        scale: f64,
        shift: f64,
        active: Option<&[bool]>,
    ) {
        let m = self.rows();
        assert_eq!(jac.len(), m, "one Jacobian row per constraint row");
        if let Some(act) = active {
            assert_eq!(act.len(), m, "one activity flag per constraint row");
        }
        for (r, row) in jac.iter().enumerate() {
            let (a, b) = self.pattern.row_bodies[r];
            self.wa[r] = a.map_or([0.0; 6], |i| minv_row(&mass[i], &row.a));
            self.wb[r] = b.map_or([0.0; 6], |i| minv_row(&mass[i], &row.b));
        }
        let p = &self.pattern;
        for s in 0..m {
            let act_s = active.is_none_or(|act| act[s]);
            for e in p.col_ptr[s]..p.col_ptr[s + 1] {
                let r = p.row_idx[e];
                let act_r = active.is_none_or(|act| act[r]);
                let l = p.links[e];
                let mut k = 0.0;
                if l & AA != 0 {
                    k += dot6(&jac[r].a, &self.wa[s]);
                }
                if l & AB != 0 {
                    k += dot6(&jac[r].a, &self.wb[s]);
                }
                if l & BA != 0 {
                    k += dot6(&jac[r].b, &self.wa[s]);
                }
                if l & BB != 0 {
                    k += dot6(&jac[r].b, &self.wb[s]);
                }
                self.values[e] = if act_r && act_s {
                    scale * k + if r == s { shift } else { 0.0 }
                } else if r == s {
                    1.0
                } else {
                    0.0
                };
            }
        }
    }

    /// Add `d[r]` to the diagonal entry of every row `r` with `active[r]` (all rows when
    /// `active` is `None`): a per-row regularization such as the staggered method's
    /// `E = diag(ε, …, εh, …)`. Allocation-free.
    ///
    /// # Panics
    /// If `d` does not have one entry per row.
    pub fn add_diagonal(&mut self, d: &[f64], active: Option<&[bool]>) {
        let p = &self.pattern;
        assert_eq!(d.len(), p.rows(), "one diagonal entry per row");
        for (s, &ds) in d.iter().enumerate() {
            if active.is_none_or(|act| act[s]) {
                // The diagonal is the last entry of its column (see `KPattern`).
                self.values[p.col_ptr[s + 1] - 1] += ds;
            }
        }
    }

    /// Write the full symmetric matrix into `out` (`rows × rows`, overwritten).
    ///
    /// # Panics
    /// If `out` has the wrong shape.
    pub fn to_dense(&self, out: &mut DMatrix<f64>) {
        let n = self.rows();
        assert_eq!(out.shape(), (n, n));
        out.fill(0.0);
        self.scatter_lower(out);
        for s in 0..n {
            for e in self.pattern.col_ptr[s]..self.pattern.col_ptr[s + 1] {
                out[(self.pattern.row_idx[e], s)] = self.values[e];
            }
        }
    }

    /// Write the stored entries into the lower triangle of `out` (entry `(r, s)`, `r ≤ s`,
    /// goes to `(s, r)`); other entries are left untouched.
    pub(crate) fn scatter_lower(&self, out: &mut DMatrix<f64>) {
        for s in 0..self.rows() {
            for e in self.pattern.col_ptr[s]..self.pattern.col_ptr[s + 1] {
                out[(s, self.pattern.row_idx[e])] = self.values[e];
            }
        }
    }
}

/// `y = B x`: `x` has 6 entries per body (`v`, `ω`), `y` one per row. Allocation-free.
///
/// # Panics
/// On size mismatch.
pub fn jac_mul(layout: &Layout, jac: &[RowJac], x: &[f64], y: &mut [f64]) {
    assert_eq!(x.len(), 6 * layout.bodies());
    assert_eq!(y.len(), layout.rows);
    assert_eq!(jac.len(), layout.rows);
    for (r, yr) in y.iter_mut().enumerate() {
        let (a, b) = layout.row_bodies(r);
        let mut acc = 0.0;
        if let Some(a) = a {
            acc += dot6(
                &jac[r].a,
                x[6 * a..6 * a + 6].try_into().expect("6 entries"),
            );
        }
        if let Some(b) = b {
            acc += dot6(
                &jac[r].b,
                x[6 * b..6 * b + 6].try_into().expect("6 entries"),
            );
        }
        *yr = acc;
    }
}

/// `x = Bᵀ y` (overwrites `x`, 6 entries per body). Allocation-free.
///
/// # Panics
/// On size mismatch.
pub fn jac_t_mul(layout: &Layout, jac: &[RowJac], y: &[f64], x: &mut [f64]) {
    assert_eq!(x.len(), 6 * layout.bodies());
    assert_eq!(y.len(), layout.rows);
    assert_eq!(jac.len(), layout.rows);
    x.fill(0.0);
    for (r, &yr) in y.iter().enumerate() {
        if yr == 0.0 {
            continue;
        }
        let (a, b) = layout.row_bodies(r);
        if let Some(a) = a {
            for k in 0..6 {
                x[6 * a + k] += jac[r].a[k] * yr;
            }
        }
        if let Some(b) = b {
            for k in 0..6 {
                x[6 * b + k] += jac[r].b[k] * yr;
            }
        }
    }
}

/// `y = M⁻¹ x` per body: `v ← f/m`, `ω ← J⁻¹ t`. `x` and `y` have 6 entries per body.
///
/// # Panics
/// On size mismatch.
pub fn mass_inv_mul(mass: &[MassProps], x: &[f64], y: &mut [f64]) {
    assert_eq!(x.len(), 6 * mass.len());
    assert_eq!(y.len(), 6 * mass.len());
    for (i, mp) in mass.iter().enumerate() {
        let xi: &[f64; 6] = x[6 * i..6 * i + 6].try_into().expect("6 entries");
        y[6 * i..6 * i + 6].copy_from_slice(&minv_row(mp, xi));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::testutil::{chain_layout, dense_b, dense_minv, random_jac, Rng};

    #[test]
    fn pattern_of_a_chain_is_block_tridiagonal() {
        // 4 bodies, spherical chain from ground: joint j between body j−1 (or ground) and j.
        let layout = chain_layout(4, 3);
        let p = KPattern::new(&layout);
        assert_eq!(p.rows(), 12);
        for s in 0..12 {
            let col = &p.row_idx()[p.col_ptr()[s]..p.col_ptr()[s + 1]];
            let js = s / 3;
            let expect: Vec<usize> = (0..=s).filter(|&r| r / 3 + 1 >= js).collect();
            assert_eq!(col, &expect[..], "column {s}");
        }
    }

    #[test]
    fn assembly_matches_dense_product() {
        let mut rng = Rng::new(7);
        for &(bodies, with_ground_loops) in &[(5usize, false), (8, true)] {
            let layout = crate::linalg::testutil::random_layout(
                &mut rng,
                bodies,
                3 * bodies,
                with_ground_loops,
            );
            let jac = random_jac(&mut rng, layout.rows);
            let b = dense_b(&layout, &jac);
            let minv = dense_minv(&layout);
            let (scale, shift) = (0.7, 0.3);
            let expect = &b * &minv * b.transpose() * scale
                + DMatrix::identity(layout.rows, layout.rows) * shift;
            let mut k = ConstraintMatrix::new(&layout);
            k.assemble(&jac, &layout.mass, scale, shift, None);
            let mut got = DMatrix::zeros(layout.rows, layout.rows);
            k.to_dense(&mut got);
            let err = (&got - &expect).amax();
            assert!(err <= 1e-13 * expect.amax(), "assembly error {err}");
            // Every structurally nonzero entry of the product is in the pattern.
            for r in 0..layout.rows {
                for s in 0..layout.rows {
                    if expect[(r, s)].abs() > 1e-14 && r != s {
                        let (lo, hi) = (r.min(s), r.max(s));
                        let col = &k.pattern().row_idx()
                            [k.pattern().col_ptr()[hi]..k.pattern().col_ptr()[hi + 1]];
                        assert!(col.contains(&lo), "entry ({lo},{hi}) missing");
                    }
                }
            }
        }
    }

    #[test]
    fn inactive_rows_are_decoupled() {
        let layout = chain_layout(3, 3);
        let mut rng = Rng::new(3);
        let jac = random_jac(&mut rng, layout.rows);
        let mut active = vec![true; layout.rows];
        active[4] = false;
        let mut k = ConstraintMatrix::new(&layout);
        k.assemble(&jac, &layout.mass, 1.0, 0.0, Some(&active));
        let mut d = DMatrix::zeros(9, 9);
        k.to_dense(&mut d);
        for j in 0..9 {
            let expect = if j == 4 { 1.0 } else { 0.0 };
            assert_eq!(d[(4, j)], expect);
            assert_eq!(d[(j, 4)], expect);
        }
        assert!(d[(3, 3)] > 0.0);
    }

    /// A per-row diagonal lands on the diagonal of active rows only.
    #[test]
    fn add_diagonal_on_active_rows() {
        let layout = chain_layout(3, 3);
        let mut rng = Rng::new(5);
        let jac = random_jac(&mut rng, layout.rows);
        let mut active = vec![true; 9];
        active[2] = false;
        let mut k = ConstraintMatrix::new(&layout);
        k.assemble(&jac, &layout.mass, 1.0, 0.0, Some(&active));
        let mut before = DMatrix::zeros(9, 9);
        k.to_dense(&mut before);
        let d: Vec<f64> = (0..9).map(|i| 0.1 * (i + 1) as f64).collect();
        k.add_diagonal(&d, Some(&active));
        let mut after = DMatrix::zeros(9, 9);
        k.to_dense(&mut after);
        let tol = 1e-14 * before.amax();
        let diff = after - before;
        for i in 0..9 {
            for j in 0..9 {
                let expect = if i == j && i != 2 { d[i] } else { 0.0 };
                assert!((diff[(i, j)] - expect).abs() <= tol, "({i},{j})");
            }
        }
    }

    #[test]
    fn products_match_dense() {
        let mut rng = Rng::new(11);
        let layout = crate::linalg::testutil::random_layout(&mut rng, 6, 20, true);
        let jac = random_jac(&mut rng, layout.rows);
        let b = dense_b(&layout, &jac);
        let minv = dense_minv(&layout);
        let x: Vec<f64> = (0..36).map(|_| rng.normal()).collect();
        let y: Vec<f64> = (0..layout.rows).map(|_| rng.normal()).collect();
        let mut bx = vec![0.0; layout.rows];
        jac_mul(&layout, &jac, &x, &mut bx);
        let expect = &b * nalgebra::DVector::from_column_slice(&x);
        for r in 0..layout.rows {
            assert!((bx[r] - expect[r]).abs() <= 1e-14 * (1.0 + expect[r].abs()));
        }
        let mut bty = vec![1.0; 36];
        jac_t_mul(&layout, &jac, &y, &mut bty);
        let expect = b.transpose() * nalgebra::DVector::from_column_slice(&y);
        for i in 0..36 {
            assert!((bty[i] - expect[i]).abs() <= 1e-13 * (1.0 + expect[i].abs()));
        }
        let mut mx = vec![0.0; 36];
        mass_inv_mul(&layout.mass, &x, &mut mx);
        let expect = &minv * nalgebra::DVector::from_column_slice(&x);
        for i in 0..36 {
            assert!((mx[i] - expect[i]).abs() <= 1e-14 * (1.0 + expect[i].abs()));
        }
    }
}
