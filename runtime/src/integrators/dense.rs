//! Interim dense kernels for the integrators (to be replaced by `crate::linalg`).

use nalgebra::DMatrix;

use crate::integrators::common::accel;
use crate::system::{ConstraintEval, Layout, Twist, Wrench};

/// Assembles `K = B M⁻¹ Bᵀ` using the rows-per-body sparsity.
pub struct KAssembler {
    body_rows: Vec<Vec<(usize, bool)>>,
    minv_bt: Vec<([f64; 6], [f64; 6])>,
}

impl KAssembler {
    /// Sparsity from the layout.
    pub fn new(layout: &Layout) -> KAssembler {
        let mut body_rows = vec![Vec::new(); layout.bodies()];
        for r in 0..layout.rows {
            let (a, b) = layout.row_bodies(r);
            if let Some(a) = a {
                body_rows[a].push((r, true));
            }
            if let Some(b) = b {
                body_rows[b].push((r, false));
            }
        }
        KAssembler { body_rows, minv_bt: vec![([0.0; 6], [0.0; 6]); layout.rows] }
    }

    /// `k = scale · B M⁻¹ Bᵀ`, with inactive rows replaced by identity rows.
    pub fn assemble(&mut self, layout: &Layout, ce: &ConstraintEval, active: &[bool], scale: f64, k: &mut DMatrix<f64>) {
        k.fill(0.0);
        for (r, m) in self.minv_bt.iter_mut().enumerate() {
            let (a, b) = layout.row_bodies(r);
            let row = &ce.jac[r];
            if let Some(a) = a {
                m.0 = six(&accel(&layout.mass[a], &wrench(&row.a)));
            }
            if let Some(b) = b {
                m.1 = six(&accel(&layout.mass[b], &wrench(&row.b)));
            }
        }
        for rows in &self.body_rows {
            for &(r, ra) in rows {
                if !active[r] {
                    continue;
                }
                let br = if ra { &ce.jac[r].a } else { &ce.jac[r].b };
                for &(s, sa) in rows {
                    if !active[s] {
                        continue;
                    }
                    let ms = if sa { &self.minv_bt[s].0 } else { &self.minv_bt[s].1 };
                    let mut d = 0.0;
                    for c in 0..6 {
                        d += br[c] * ms[c];
                    }
                    k[(r, s)] += scale * d;
                }
            }
        }
        for r in 0..layout.rows {
            if !active[r] {
                k[(r, r)] = 1.0;
            }
        }
    }
}

fn wrench(x: &[f64; 6]) -> Wrench {
    Wrench { f: nalgebra::Vector3::new(x[0], x[1], x[2]), t: nalgebra::Vector3::new(x[3], x[4], x[5]) }
}

fn six(t: &Twist) -> [f64; 6] {
    [t.v.x, t.v.y, t.v.z, t.w.x, t.w.y, t.w.z]
}

/// Dense symmetric solver with diagonal pivoting.
pub struct SymSolver {
    l: DMatrix<f64>,
    perm: Vec<usize>,
    rank: usize,
    y: Vec<f64>,
    ratio: f64,
}

impl SymSolver {
    /// Buffers for `n` unknowns.
    pub fn new(n: usize) -> SymSolver {
        SymSolver { l: DMatrix::zeros(n, n), perm: (0..n).collect(), rank: 0, y: vec![0.0; n], ratio: 1.0 }
    }

    /// Pivoted Cholesky of a symmetric positive semidefinite matrix; pivots below
    /// `rel_tol · max pivot` end the factorization (rank deficiency). Returns the rank.
    pub fn factor_semidefinite(&mut self, k: &DMatrix<f64>, rel_tol: f64) -> usize {
        let n = k.nrows();
        self.l.copy_from(k);
        for (i, p) in self.perm.iter_mut().enumerate() {
            *p = i;
        }
        let mut maxpiv: f64 = 0.0;
        for i in 0..n {
            maxpiv = maxpiv.max(k[(i, i)]);
        }
        let a = &mut self.l;
        let mut rank = n;
        for j in 0..n {
            // choose the largest remaining diagonal
            let mut best = j;
            for i in j + 1..n {
                if a[(i, i)] > a[(best, best)] {
                    best = i;
                }
            }
            if a[(best, best)] <= rel_tol * maxpiv || a[(best, best)] <= 0.0 {
                rank = j;
                break;
            }
            if best != j {
                a.swap_rows(j, best);
                a.swap_columns(j, best);
                self.perm.swap(j, best);
            }
            let d = a[(j, j)].sqrt();
            a[(j, j)] = d;
            for i in j + 1..n {
                a[(i, j)] /= d;
            }
            for c in j + 1..n {
                let ljc = a[(c, j)];
                if ljc == 0.0 {
                    continue;
                }
                for i in c..n {
                    a[(i, c)] -= a[(i, j)] * ljc;
                }
                // keep symmetric upper part consistent for pivot search on the diagonal
            }
            for c in j + 1..n {
                for i in c + 1..n {
                    a[(c, i)] = a[(i, c)];
                }
            }
        }
        self.rank = rank;
        self.ratio = if rank == 0 { 0.0 } else { (self.l[(rank - 1, rank - 1)] / self.l[(0, 0)]).powi(2) };
        rank
    }

    /// Smallest over largest accepted pivot of the last factorization (an estimate of
    /// 1/cond for diagonally dominant matrices).
    pub fn pivot_ratio(&self) -> f64 {
        self.ratio
    }

    /// Solve with the last factorization; unknowns beyond the rank are zero.
    pub fn solve(&mut self, rhs: &[f64], x: &mut [f64]) {
        let r = self.rank;
        let n = rhs.len();
        let l = &self.l;
        for i in 0..r {
            let mut s = rhs[self.perm[i]];
            for k in 0..i {
                s -= l[(i, k)] * self.y[k];
            }
            self.y[i] = s / l[(i, i)];
        }
        for i in (0..r).rev() {
            let mut s = self.y[i];
            for k in i + 1..r {
                s -= l[(k, i)] * self.y[k];
            }
            self.y[i] = s / l[(i, i)];
        }
        for v in x.iter_mut().take(n) {
            *v = 0.0;
        }
        for i in 0..r {
            x[self.perm[i]] = self.y[i];
        }
    }
}

/// Dense LU with partial pivoting, allocation-free after construction.
pub struct Lu {
    a: DMatrix<f64>,
    piv: Vec<usize>,
    n: usize,
}

impl Lu {
    /// Buffers for an `n × n` matrix.
    pub fn new(n: usize) -> Lu {
        Lu { a: DMatrix::zeros(n, n), piv: vec![0; n], n }
    }

    /// Factor `m` (copied). Returns the index of a zero pivot if singular.
    pub fn factor(&mut self, m: &DMatrix<f64>) -> Result<(), usize> {
        let n = self.n;
        self.a.copy_from(m);
        let a = &mut self.a;
        let mut scale: f64 = 0.0;
        for v in a.iter() {
            scale = scale.max(v.abs());
        }
        for k in 0..n {
            let mut p = k;
            let mut best = a[(k, k)].abs();
            for i in k + 1..n {
                if a[(i, k)].abs() > best {
                    best = a[(i, k)].abs();
                    p = i;
                }
            }
            if best <= 1e-300_f64.max(scale * 1e-15) {
                return Err(k);
            }
            self.piv[k] = p;
            if p != k {
                a.swap_rows(p, k);
            }
            let d = a[(k, k)];
            for i in k + 1..n {
                a[(i, k)] /= d;
            }
            for j in k + 1..n {
                let akj = a[(k, j)];
                if akj == 0.0 {
                    continue;
                }
                for i in k + 1..n {
                    a[(i, j)] -= a[(i, k)] * akj;
                }
            }
        }
        Ok(())
    }

    /// Diagonal entry `k` of U (the k-th pivot) of the last factorization.
    pub fn diag(&self, k: usize) -> f64 {
        self.a[(k, k)]
    }

    /// Solve in place with the last factorization.
    pub fn solve(&self, b: &mut [f64]) {
        let n = self.n;
        let a = &self.a;
        for k in 0..n {
            b.swap(k, self.piv[k]);
        }
        for i in 0..n {
            let mut s = b[i];
            for k in 0..i {
                s -= a[(i, k)] * b[k];
            }
            b[i] = s;
        }
        for i in (0..n).rev() {
            let mut s = b[i];
            for k in i + 1..n {
                s -= a[(i, k)] * b[k];
            }
            b[i] = s / a[(i, i)];
        }
    }
}
