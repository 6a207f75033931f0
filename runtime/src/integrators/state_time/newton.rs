//! Newton's method on one window of the state-time method, for any reading of the scene
//! (planar or spatial): the residual and analytic Jacobian are assembled element by
//! element ([`Discretization::element`]) and the update solved with faer's sparse LU.
//!
//! **Assembly.** Each element's residual and Jacobian entries are computed independently
//! (in parallel with rayon) into the element's own buffer, then added in element order,
//! so that the result does not depend on the number of threads. The LU factorization runs
//! sequentially for the same reason.
//!
//! **Failure reports.** A window that does not converge, whose Newton matrix has an empty
//! row or column or a non-finite entry, or whose LU meets a zero pivot, fails with the
//! largest residual and where it is (body or joint, equation, time), in the words of the
//! discretization ([`Discretization::place_of_equation`]).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::lu::{factorize_symbolic_lu, LuSymbolicParams, NumericLu, SymbolicLu};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{Argsort, Pair, SparseColMat, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par};

/// An update this small relative to the unknowns that no longer shrinks ends Newton's
/// iteration as converged (the round-off floor; the discretization error is far larger).
const STALL: f64 = 1e-8;

/// One element's contributions: residual `(row, value)` and Jacobian `(row, col, value)`.
#[derive(Clone, Debug, Default)]
pub struct ElementBuffer {
    /// Residual entries (rows repeat across elements; they are summed).
    pub res: Vec<(usize, f64)>,
    /// Jacobian entries (duplicates are summed).
    pub jac: Vec<(usize, usize, f64)>,
}

/// Newton's statistics of one window.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NewtonStats {
    /// Iterations (linear solves).
    pub iterations: u32,
    /// Final residual, max norm.
    pub residual: f64,
    /// Wall time in the assembly of residuals and Jacobians (parallel over elements), s.
    pub assembly_seconds: f64,
    /// Wall time in the sparse LU: symbolic analysis, factorizations and solves
    /// (sequential), s.
    pub lu_seconds: f64,
}

/// Why a window's Newton iteration failed.
#[derive(Clone, Debug, PartialEq)]
pub struct Failure {
    /// Iterations made.
    pub iterations: u32,
    /// Largest residual at the end.
    pub residual: f64,
    /// Where it is: the body or joint, its equation and the time of its test function.
    pub place: String,
    /// The sparse LU's message, when the factorization itself failed.
    pub linear: Option<String>,
}

/// The equations of one window, element by element.
pub trait Discretization: Sync {
    /// Number of unknowns (= equations).
    fn unknowns(&self) -> usize;
    /// Number of time elements.
    fn elements(&self) -> usize;
    /// Element `e`'s residual and Jacobian entries at `u` into `buf` (cleared first). The
    /// entries must be the same in number and order at every `u` (the Jacobian's pattern
    /// is fixed).
    fn element(&self, e: usize, u: &[f64], buf: &mut ElementBuffer);
    /// The body or joint, equation and time of equation `i`.
    fn place_of_equation(&self, i: usize) -> String;
    /// The body or joint, field and time of unknown `i`.
    fn place_of_unknown(&self, i: usize) -> String;
}

/// Assemble the residual of `d` at `u` into `r` and the Jacobian's values into `vals` (in
/// the fixed entry order; `pairs`, if given, receives the entries' positions). `bufs` has
/// one buffer per element.
pub fn assemble<D: Discretization>(
    d: &D,
    u: &[f64],
    bufs: &mut [ElementBuffer],
    r: &mut [f64],
    vals: &mut Vec<f64>,
    pairs: Option<&mut Vec<Pair<usize, usize>>>,
) {
    use rayon::prelude::*;
    bufs.par_iter_mut()
        .enumerate()
        .with_min_len(4)
        .for_each(|(e, buf)| d.element(e, u, buf));
    r.fill(0.0);
    vals.clear();
    for buf in bufs.iter() {
        for &(i, v) in &buf.res {
            r[i] += v;
        }
        vals.extend(buf.jac.iter().map(|t| t.2));
    }
    if let Some(p) = pairs {
        p.clear();
        for buf in bufs.iter() {
            p.extend(buf.jac.iter().map(|t| Pair::new(t.0, t.1)));
        }
    }
}

/// The residual of `d` at `u`.
pub fn residual<D: Discretization>(d: &D, u: &[f64]) -> Vec<f64> {
    let mut bufs = vec![ElementBuffer::default(); d.elements()];
    let mut r = vec![0.0; d.unknowns()];
    assemble(d, u, &mut bufs, &mut r, &mut Vec::new(), None);
    r
}

/// The Jacobian of `d` at `u` as `(row, col, value)` entries (duplicates to be summed).
pub fn jacobian_entries<D: Discretization>(d: &D, u: &[f64]) -> Vec<(usize, usize, f64)> {
    let mut bufs = vec![ElementBuffer::default(); d.elements()];
    bufs.iter_mut()
        .enumerate()
        .flat_map(|(e, buf)| {
            d.element(e, u, buf);
            std::mem::take(&mut buf.jac)
        })
        .collect()
}

/// Newton's method on `d` from `u`: stops when the update is below `tol` relative to the
/// unknowns (max norm), or below [`STALL`] and no longer shrinking (round-off), at most
/// `max_iterations` linear solves. `bufs` has one buffer per element.
///
/// The pattern of the Jacobian, its column ordering and the LU's symbolic analysis are
/// computed once per call; each iteration refactors numerically (faer allocates the
/// matrix's value array and its factors' storage there).
pub fn solve<D: Discretization>(
    d: &D,
    u: &mut [f64],
    bufs: &mut [ElementBuffer],
    tol: f64,
    max_iterations: u32,
) -> Result<NewtonStats, Failure> {
    // not `d.unknowns()`: a window hands its unknowns over by taking them out of itself
    let n = u.len();
    let mut r = vec![0.0; n];
    let mut vals = Vec::new();
    let mut pairs = Vec::new();
    let clock = std::time::Instant::now();
    assemble(d, u, bufs, &mut r, &mut vals, Some(&mut pairs));
    let mut assembly_seconds = clock.elapsed().as_secs_f64();
    let mut lu_seconds = 0.0;
    let fail = |r: &[f64], it: u32, linear: Option<String>| Failure {
        iterations: it,
        residual: r.iter().fold(0.0, |a: f64, x| a.max(x.abs())),
        place: match crate::integrators::worst_entry(r) {
            Some((i, _)) => d.place_of_equation(i),
            None => "no equations".into(),
        },
        linear,
    };
    let clock = std::time::Instant::now();
    let (sym, argsort): (SymbolicSparseColMat<usize>, Argsort<usize>) =
        match SymbolicSparseColMat::try_new_from_indices(n, n, &pairs) {
            Ok(x) => x,
            Err(e) => return Err(fail(&r, 0, Some(format!("{e:?}")))),
        };
    // The supernodal factorization pivots by dense partial pivoting within its panels and
    // lets a zero pivot through as a non-finite solution (checked below); the simplicial
    // one panics on it.
    let params = LuSymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    };
    let symbolic: SymbolicLu<usize> = match factorize_symbolic_lu(sym.as_ref(), params) {
        Ok(s) => s,
        Err(e) => return Err(fail(&r, 0, Some(format!("{e:?}")))),
    };
    let par = Par::Seq;
    let req = symbolic
        .factorize_numeric_lu_scratch::<f64>(par, Default::default())
        .or(symbolic.solve_in_place_scratch::<f64>(1, par));
    let mut mem = MemBuffer::new(req);
    let mut numeric = NumericLu::<usize, f64>::new();
    lu_seconds += clock.elapsed().as_secs_f64();
    let mut it = 0;
    let mut du_prev = f64::INFINITY;
    let mut row_used = vec![false; n];
    loop {
        if r.iter().any(|x| !x.is_finite()) || it >= max_iterations {
            return Err(fail(&r, it, None));
        }
        let clock = std::time::Instant::now();
        let mat = match SparseColMat::new_from_argsort(sym.clone(), &argsort, &vals) {
            Ok(m) => m,
            Err(e) => return Err(fail(&r, it, Some(format!("{e:?}")))),
        };
        // an empty row or column (a massless body, a joint that acts on nothing) is
        // reported naming its equation or unknown, which the LU's zero pivot cannot
        if let Some(why) = singular_line(d, mat.as_ref(), &mut row_used) {
            return Err(fail(&r, it, Some(why)));
        }
        let lu = match symbolic.factorize_numeric_lu(
            &mut numeric,
            mat.as_ref(),
            par,
            MemStack::new(&mut mem),
            Default::default(),
        ) {
            Ok(lu) => lu,
            Err(e) => return Err(fail(&r, it, Some(format!("{e:?}")))),
        };
        for x in r.iter_mut() {
            *x = -*x;
        }
        lu.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut r, n, 1),
            par,
            MemStack::new(&mut mem),
        );
        lu_seconds += clock.elapsed().as_secs_f64();
        if r.iter().any(|x| !x.is_finite()) {
            // the unknowns are left as they were: report the residual there
            assemble(d, u, bufs, &mut r, &mut vals, None);
            let why =
                "the Newton matrix is singular to working precision (its LU has a zero pivot)";
            return Err(fail(&r, it, Some(why.into())));
        }
        it += 1;
        let mut du = 0.0f64;
        let mut um = 1.0f64;
        for (u, d) in u.iter_mut().zip(&r) {
            *u += d;
            du = du.max(d.abs());
            um = um.max(u.abs());
        }
        let clock = std::time::Instant::now();
        assemble(d, u, bufs, &mut r, &mut vals, None);
        assembly_seconds += clock.elapsed().as_secs_f64();
        // converged: the update is below the tolerance, or Newton has stalled at the
        // round-off floor of an ill-scaled window (short elements: updates of 1e-10 that
        // no longer shrink) far below the solution's own error
        let stalled = it >= 3 && du <= STALL * um && du > 0.25 * du_prev;
        du_prev = du;
        if (du <= tol * um || stalled) && r.iter().all(|x| x.is_finite()) {
            return Ok(NewtonStats {
                iterations: it,
                residual: r.iter().fold(0.0, |a: f64, x| a.max(x.abs())),
                assembly_seconds,
                lu_seconds,
            });
        }
    }
}

/// Why the Newton matrix `mat` cannot be factorized without a zero pivot, when a whole row
/// or column of it is zero or one of its entries is not finite (`row_used`: scratch of one
/// flag per row).
fn singular_line<D: Discretization>(
    d: &D,
    mat: faer::sparse::SparseColMatRef<'_, usize, f64>,
    row_used: &mut [bool],
) -> Option<String> {
    let n = mat.nrows();
    let (col_ptr, row_idx, val) = (mat.col_ptr(), mat.row_idx(), mat.val());
    row_used.fill(false);
    for j in 0..n {
        let mut col_used = false;
        for k in col_ptr[j]..col_ptr[j + 1] {
            let v = val[k];
            if !v.is_finite() {
                return Some(format!(
                    "the Newton matrix has a non-finite entry ({v}) in {}",
                    d.place_of_equation(row_idx[k])
                ));
            }
            if v != 0.0 {
                col_used = true;
                row_used[row_idx[k]] = true;
            }
        }
        if !col_used {
            return Some(format!(
                "the Newton matrix is singular: no equation depends on {}",
                d.place_of_unknown(j)
            ));
        }
    }
    let i = row_used.iter().position(|u| !u)?;
    Some(format!(
        "the Newton matrix is singular: {} depends on no unknown",
        d.place_of_equation(i)
    ))
}

/// Names the place of an equation or unknown of a window: the body or joint it belongs
/// to, its field and its time.
pub struct Places<'a> {
    /// Start time of the window and element length.
    pub t0: f64,
    /// Element length.
    pub h: f64,
    /// Body names.
    pub body_names: &'a [String],
    /// Joint names.
    pub joint_names: &'a [String],
}

impl Places<'_> {
    /// The place of line `i`: body blocks (`offsets`, the nodes `nodes`, field names
    /// `names`), then joint blocks (`joints`, `joint_line`, component names
    /// `joint_fields`).
    pub fn find(
        &self,
        i: usize,
        (offsets, nodes, names): (&[usize], std::ops::Range<usize>, &[&str]),
        (joints, joint_line, joint_fields): (&[usize], &str, &[&str]),
    ) -> String {
        let (nb, nj) = (self.body_names.len(), self.joint_names.len());
        let (fb, fj) = (names.len(), joint_fields.len());
        for j in nodes {
            let o = offsets[j];
            if (o..o + fb * nb).contains(&i) {
                let (b, f) = ((i - o) / fb, (i - o) % fb);
                return format!(
                    "body '{}', {} at t = {:.6} s",
                    self.body_names[b],
                    names[f],
                    self.t0 + j as f64 * self.h / 2.0
                );
            }
        }
        for (n, &o) in joints.iter().enumerate() {
            if (o..o + fj * nj).contains(&i) {
                let (k, c) = ((i - o) / fj, (i - o) % fj);
                return format!(
                    "joint '{}', {joint_line} ({}) at t = {:.6} s",
                    self.joint_names[k],
                    joint_fields[c],
                    self.t0 + n as f64 * self.h
                );
            }
        }
        format!("line {i}")
    }
}
