//! FETI-1 (Farhat–Roux; shared/notes/E_feti_reduced_multipliers.md §2, with its fixes): the
//! linear solver of the implicit mesh analyses when `simulate { solver feti { ... } }` asks
//! for it, in place of the direct factorization of the assembled matrix.
//!
//! The meshes are torn into subdomains ([`mesh_subdomains::tear`]); each subdomain's
//! `K_s` (its elements, its share of the node terms) is factored on its own, through the
//! generalized inverse `K_s⁺` when it floats. With the signed Boolean `B_s` of the
//! interface multipliers λ (the interaction forces), `K_s u_s = f_s − B_sᵀλ` and
//! `Σ B_s u_s = 0` give the interface problem
//!
//! ```text
//! F λ − G α = d,   Gᵀ λ = e,
//! F = Σ B_s K_s⁺ B_sᵀ,  d = Σ B_s K_s⁺ f_s,  G = [B_s R_s],  e = [R_sᵀ f_s]  (floating s)
//! ```
//!
//! solved by preconditioned conjugate projected gradients as the notes' §2.6 corrects the
//! paper's algorithm: the start `λ₀ = G (GᵀG)⁻¹ e` (the global form of Appendix B, §2.10,
//! which meets the constraint also when floating subdomains are neighbours), the residual
//! `r₀ = d − F λ₀` (FIX 1), and the ratios and the stopping test on the *projected*
//! residual `w = P r`, `P = I − G (GᵀG)⁻¹ Gᵀ` (FIX 2: the unprojected residual tends to
//! `−Gα`, not to zero). The coarse problem `GᵀG` (≤ 6 per floating subdomain) is factored
//! once. Then `α = −(GᵀG)⁻¹ Gᵀ r` and `u_s = K_s⁺ (f_s − B_sᵀ λ) + R_s α_s`; the global
//! displacement of a shared dof is the copy of its owner, the lowest-numbered subdomain
//! that holds it (the copies agree to the tolerance).
//!
//! **Preconditioners** (applied to `F` only, never to the saddle-point matrix, §2.8), with
//! multiplicity scaling `B̃_s = B_s D_s`, `D_s = diag(1/μ)` (μ the subdomains sharing the
//! node), which keeps them consistent with the redundant multipliers at cross points:
//! `lumped` — `Σ B̃_s K_s B̃_sᵀ`, the papers' `Σ K_j^I`: a product with each subdomain's
//! stiffness, no factorization; `dirichlet` — `Σ B̃_s S_s B̃_sᵀ` with the interface Schur
//! complement `S_s = K_bb − K_bi K_ii⁻¹ K_ib` (one more factorization per subdomain, of its
//! interior): the later literature's optimal choice, whose iteration count hardly grows
//! with the number of subdomains (docs/methods.md shows the measured counts).
//!
//! **Threads.** The subdomain work of every product (`K_s⁺` solves, `S_s` products) runs on
//! rayon's pool, one subdomain per task; the interface vectors are then gathered and every
//! sum taken in a fixed order, so a solve gives bitwise the same result on any number of
//! threads. A solve allocates nothing.
//!
//! **Ranks.** In a distributed run ([`Ranks`], more than one rank) each rank factors and
//! iterates only its own subdomains, a contiguous run of subdomain numbers balanced by
//! their stiffness entries ([`assign`]); the tearing (with every subdomain's rigid modes),
//! `G`, the coarse factor `GᵀG` and the multiplier-space iteration are replicated. A
//! vector that sums over subdomains — `d`, `F v`, the preconditioned residual, `e = Rᵀf`,
//! the displacement — is the rank's part (zero where it holds nothing) followed by one
//! [`Ranks::sum`]. Every multiplier joins two subdomains, so its entry of such a sum has
//! at most two non-zero terms and the rank-order sum is the difference a single process
//! takes; `e` and the displacement have one non-zero term per entry (a coarse column
//! belongs to one subdomain, a dof to its owner). Each rank therefore carries, bit for
//! bit, the multipliers, the iterations and the displacement of the run in one process,
//! on any number of ranks: the stopping tests are taken on the same values everywhere.

use std::ops::Range;
use std::sync::Arc;

use rayon::prelude::*;

use super::StepError;
use crate::analysis::mesh_subdomains::{self, Subdomain, Tearing};
use crate::contract::mesh_layout::MeshLayout;
use crate::contract::ranks::Ranks;
use crate::contract::scene::{FetiOptions, FetiPreconditioner};
use crate::linalg::{Definiteness, DenseCholesky, LinalgError, SparseCholesky, SymmetricAssembly};
use nalgebra::DMatrix;

/// What the last solve, and the solves so far, took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FetiSolveStats {
    /// Iterations of the last solve.
    pub iterations: u32,
    /// Most iterations of any solve so far.
    pub max_iterations: u32,
    /// Solves so far.
    pub solves: u64,
    /// Relative projected residual `‖P r‖/‖P r₀‖` at the end of the last solve.
    pub residual: f64,
    /// The condition number of the preconditioned, projected interface operator, estimated
    /// from the last solve's conjugate-gradient coefficients (the extreme eigenvalues of
    /// their Lanczos matrix: a lower bound, sharp once the iteration has converged; 1 when
    /// it took no iteration).
    pub condition: f64,
    /// Bytes this rank handed to [`Ranks::sum`] in the last solve (8 per value; 0 in one
    /// process).
    pub summed_bytes: u64,
}

/// Where one subdomain meets the multipliers and the coarse space (known for every
/// subdomain on every rank: `G` is replicated).
struct Part {
    /// `(multiplier, local free dof, sign)` of every multiplier touching the subdomain.
    entries: Vec<(u32, u32, f64)>,
    /// The subdomain's first column in `G` (its modes are the next `modes` columns).
    coarse: usize,
}

/// Factors and work vectors of one of this rank's subdomains.
struct Local {
    /// `K_pp` (the pinned dofs decoupled with a unit diagonal).
    kplus: SparseCholesky,
    /// `K_ii` for the Dirichlet preconditioner (the interface dofs decoupled).
    interior: Option<SparseCholesky>,
    /// Whether each local free dof is pinned.
    pinned: Vec<bool>,
    /// Whether each local free dof is on the interface.
    boundary: Vec<bool>,
    /// Whether this subdomain owns each local free dof (it is the lowest-numbered one that
    /// holds it): the owner's copy is the displacement.
    owns: Vec<bool>,
    /// Local force `f_s`.
    f: Vec<f64>,
    /// Work vectors over the local free dofs.
    x: Vec<f64>,
    y: Vec<f64>,
    t: Vec<f64>,
}

/// The sums over ranks of a solve, and the bytes they carried.
struct Comm {
    /// `None` in one process (or on one rank): the sums are the identity.
    ranks: Option<Arc<dyn Ranks>>,
    /// Bytes summed since the solve began.
    bytes: u64,
}

impl Comm {
    fn sum(&mut self, x: &mut [f64]) {
        if let Some(r) = &self.ranks {
            r.sum(x);
            self.bytes += 8 * x.len() as u64;
        }
    }
}

/// The FETI-1 solver of one matrix (see the module doc).
pub struct Feti {
    tearing: Tearing,
    /// Every subdomain's multipliers and coarse columns.
    parts: Vec<Part>,
    /// This rank's subdomains, `first .. first + locals.len()`.
    first: usize,
    locals: Vec<Local>,
    /// This rank and the number of ranks (0 and 1 in one process).
    rank: usize,
    size: usize,
    comm: Comm,
    opts: FetiOptions,
    /// `1/μ` per multiplier (the preconditioner's scaling).
    scale: Vec<f64>,
    /// The coarse problem `GᵀG` (none when no subdomain floats).
    gtg: Option<DenseCholesky>,
    /// Interface vectors: multipliers, residual, projected residual, preconditioned,
    /// projected again, direction, `F s`.
    lambda: Vec<f64>,
    r: Vec<f64>,
    w: Vec<f64>,
    z: Vec<f64>,
    y: Vec<f64>,
    s: Vec<f64>,
    q: Vec<f64>,
    /// Coarse vectors (`Gᵀ v`, α).
    c: Vec<f64>,
    alpha: Vec<f64>,
    /// The step lengths γ and ratios β of the last solve (for the condition estimate).
    gammas: Vec<f64>,
    betas: Vec<f64>,
    stats: FetiSolveStats,
}

impl std::fmt::Debug for Feti {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Feti")
            .field("subdomains", &self.tearing.subdomains.len())
            .field("here", &self.subdomains_here())
            .field("rank", &self.rank)
            .field("ranks", &self.size)
            .field("multipliers", &self.lambda.len())
            .field("coarse", &self.c.len())
            .field("stats", &self.stats)
            .finish()
    }
}

/// `values` with the rows and columns of `mask` decoupled (zero off the diagonal, one on it).
pub(super) fn decoupled(a: &SymmetricAssembly, values: &[f64], mask: &[bool]) -> Vec<f64> {
    let mut v = values.to_vec();
    let (cp, ri) = (a.col_ptr(), a.row_idx());
    for j in 0..cp.len() - 1 {
        for p in cp[j]..cp[j + 1] {
            let i = ri[p];
            if mask[i] || mask[j] {
                v[p] = if i == j { 1.0 } else { 0.0 };
            }
        }
    }
    v
}

/// Factor `values` over the pattern of `a`.
pub(super) fn factor(
    a: &SymmetricAssembly,
    values: Vec<f64>,
) -> Result<SparseCholesky, LinalgError> {
    let n = a.free().len();
    let mut c = SparseCholesky::new(n, a.col_ptr(), a.row_idx(), Definiteness::Positive)?;
    c.values_mut().copy_from_slice(&values);
    c.factor()?;
    Ok(c)
}

/// A readable place of local free dof `j` of subdomain `sd`.
pub(super) fn dof_place(l: &MeshLayout, sd: &Subdomain, j: usize) -> String {
    let d = sd.assembly.free().get(j).copied().unwrap_or(0) as usize;
    let node = sd.nodes.get(d / 3).copied().unwrap_or(0) as usize;
    let x = l.x0.get(node).copied().unwrap_or_default();
    format!(
        "node at ({:.4}, {:.4}, {:.4}) m, component {}",
        x[0],
        x[1],
        x[2],
        ["x", "y", "z"][d % 3]
    )
}

/// The subdomains of each of `ranks` ranks: contiguous runs of subdomain numbers, rank `r`
/// holding `first[r] .. first[r + 1]` (`ranks + 1` entries, `first[ranks] = weights.len()`),
/// each run at least one subdomain long and the runs' weights as even as contiguous cuts
/// allow (each cut at the prefix weight nearest to its share). Integer arithmetic: every
/// rank computes the same cuts. Needs `1 ≤ ranks ≤ weights.len()`.
pub fn assign(weights: &[u64], ranks: usize) -> Vec<usize> {
    let n = weights.len();
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0u128);
    for &w in weights {
        let last = prefix[prefix.len() - 1];
        prefix.push(last + u128::from(w));
    }
    let total = prefix[n];
    let mut first = vec![0; ranks + 1];
    first[ranks] = n;
    for r in 1..ranks {
        let (lo, hi) = (first[r - 1] + 1, n.saturating_sub(ranks - r));
        // distance of the cut before subdomain c from rank r's share, times `ranks`
        let dist = |c: usize| (prefix[c] * ranks as u128).abs_diff(total * r as u128);
        let mut c = lo.min(hi);
        while c < hi && dist(c + 1) < dist(c) {
            c += 1;
        }
        first[r] = c;
    }
    first
}

/// A subdomain factorization that failed: the subdomain, whether it was the interior
/// stiffness (Dirichlet's), the error.
struct Failure {
    subdomain: usize,
    interior: bool,
    error: LinalgError,
}

impl Failure {
    fn message(&self, l: &MeshLayout, t: &Tearing) -> String {
        let si = self.subdomain;
        let what = if self.interior {
            "its interior stiffness"
        } else {
            "its stiffness"
        };
        match &self.error {
            LinalgError::NotPositiveDefinite { row, .. } => format!(
                "FETI subdomain {si}: {what} is singular at the {} (the subdomain has a mechanism: a motion other than a rigid one that strains nothing); use fewer subdomains or `solver direct`",
                dof_place(l, &t.subdomains[si], *row)
            ),
            e => format!("FETI subdomain {si}: {what}: {e}"),
        }
    }

    /// Four numbers for a sum over ranks: subdomain + 1 (0: none), interior, the error's
    /// kind (0 not positive definite, 1 not finite, 2 other), its row.
    fn code(f: Option<&Failure>) -> [f64; 4] {
        let Some(f) = f else { return [0.0; 4] };
        let (kind, row) = match f.error {
            LinalgError::NotPositiveDefinite { row, .. } => (0.0, row),
            LinalgError::NonFinite { row } => (1.0, row),
            _ => (2.0, 0),
        };
        [
            (f.subdomain + 1) as f64,
            f64::from(u8::from(f.interior)),
            kind,
            row as f64,
        ]
    }
}

impl Feti {
    /// Tear the meshes of `l` and factor every subdomain and the coarse problem for the
    /// matrix `K + diag(diagonal)` over the global free dofs of `global`, in one process.
    ///
    /// # Errors
    /// What [`Feti::on_ranks`] refuses.
    pub fn new(
        l: &MeshLayout,
        global: &SymmetricAssembly,
        diagonal: Option<&[f64]>,
        opts: FetiOptions,
    ) -> Result<Feti, String> {
        Feti::on_ranks(l, global, diagonal, opts, None)
    }

    /// [`Feti::new`] as one rank of `ranks` (collective: every rank calls it with the same
    /// layout, matrix and options): the tearing and the coarse problem are made on every
    /// rank, the factors of this rank's subdomains only ([`assign`]). `None`, or one rank,
    /// is the solver of one process.
    ///
    /// # Errors
    /// Fewer subdomains than ranks; what [`mesh_subdomains::tear`] refuses; a subdomain
    /// whose pinned stiffness is not positive definite (a mechanism), or a coarse problem
    /// that is singular (the meshes are not held as a whole: a static analysis needs
    /// supports), each named. Every rank fails alike (a subdomain's failure is agreed by a
    /// sum, and every rank names it).
    pub fn on_ranks(
        l: &MeshLayout,
        global: &SymmetricAssembly,
        diagonal: Option<&[f64]>,
        opts: FetiOptions,
        ranks: Option<Arc<dyn Ranks>>,
    ) -> Result<Feti, String> {
        let (rank, size) = ranks.as_ref().map_or((0, 1), |r| (r.rank(), r.size()));
        let ranks = ranks.filter(|_| size > 1);
        if size > opts.subdomains as usize {
            let names: Vec<&str> = l.blocks.iter().map(|b| b.name.as_str()).collect();
            return Err(format!(
                "FETI across ranks: the mesh{} '{}' {} torn into {} subdomains for {size} ranks, and every rank needs at least one subdomain; ask for `subdomains {size}` or more, or run on at most {} ranks",
                if names.len() > 1 { "es" } else { "" },
                names.join("', '"),
                if names.len() > 1 { "are" } else { "is" },
                opts.subdomains,
                opts.subdomains
            ));
        }
        let tearing = mesh_subdomains::tear(l, global, diagonal, opts.subdomains as usize)
            .map_err(|e| e.to_string())?;
        let subs = &tearing.subdomains;
        let nl = tearing.multipliers.len();
        let mut parts: Vec<Part> = subs
            .iter()
            .map(|_| Part {
                entries: Vec::new(),
                coarse: 0,
            })
            .collect();
        for (m, mu) in tearing.multipliers.iter().enumerate() {
            parts[mu.a as usize]
                .entries
                .push((m as u32, mu.local_a, 1.0));
            parts[mu.b as usize]
                .entries
                .push((m as u32, mu.local_b, -1.0));
        }
        let mut nc = 0;
        for (p, sd) in parts.iter_mut().zip(subs) {
            p.coarse = nc;
            nc += sd.modes;
        }
        let weights: Vec<u64> = subs.iter().map(|sd| sd.k.len() as u64).collect();
        let cuts = assign(&weights, size);
        let mine = cuts[rank]..cuts[rank + 1];
        // The owner of every global free dof: the first subdomain that holds it.
        let mut owned = vec![false; tearing.free_dofs];
        let mut owns: Vec<Vec<bool>> = Vec::with_capacity(mine.len());
        for (si, sd) in subs.iter().enumerate() {
            let mut o = vec![false; sd.free.len()];
            for (oj, &g) in o.iter_mut().zip(&sd.free) {
                if let Some(taken) = owned.get_mut(g as usize) {
                    *oj = !*taken;
                    *taken = true;
                }
            }
            if mine.contains(&si) {
                owns.push(o);
            }
        }
        let built: Vec<Result<Local, Failure>> = subs[mine.clone()]
            .par_iter()
            .zip(parts[mine.clone()].par_iter())
            .zip(owns.into_par_iter())
            .enumerate()
            .map(|(i, ((sd, part), owns))| {
                let si = mine.start + i;
                let nf = sd.free.len();
                let mut pinned = vec![false; nf];
                for &p in &sd.pinned {
                    pinned[p as usize] = true;
                }
                let mut boundary = vec![false; nf];
                for &(_, j, _) in &part.entries {
                    boundary[j as usize] = true;
                }
                let fail = |interior: bool| {
                    move |error: LinalgError| Failure {
                        subdomain: si,
                        interior,
                        error,
                    }
                };
                let kplus = factor(&sd.assembly, decoupled(&sd.assembly, &sd.k, &pinned))
                    .map_err(fail(false))?;
                let interior = match opts.preconditioner {
                    FetiPreconditioner::Dirichlet => Some(
                        factor(&sd.assembly, decoupled(&sd.assembly, &sd.k, &boundary))
                            .map_err(fail(true))?,
                    ),
                    _ => None,
                };
                Ok(Local {
                    kplus,
                    interior,
                    pinned,
                    boundary,
                    owns,
                    f: vec![0.0; nf],
                    x: vec![0.0; nf],
                    y: vec![0.0; nf],
                    t: vec![0.0; nf],
                })
            })
            .collect();
        let mut locals = Vec::with_capacity(built.len());
        let mut failure = None;
        for b in built {
            match b {
                Ok(loc) => locals.push(loc),
                Err(f) => {
                    failure = Some(f);
                    break;
                }
            }
        }
        if let Some(r) = &ranks {
            // Agree on a failure, and name the lowest-ranked one on every rank (a rank that
            // went on alone would wait for ever in the first sum of a solve).
            let mut codes = vec![0.0; 4 * size];
            codes[4 * rank..4 * rank + 4].copy_from_slice(&Failure::code(failure.as_ref()));
            r.sum(&mut codes);
            if let Some((who, c)) = codes.chunks_exact(4).enumerate().find(|(_, c)| c[0] > 0.0) {
                if let Some(f) = failure.as_ref().filter(|_| who == rank) {
                    return Err(f.message(l, &tearing));
                }
                let (subdomain, row) = (c[0] as usize - 1, c[3] as usize);
                let error = match c[2] as u8 {
                    0 => LinalgError::NotPositiveDefinite { step: 0, row },
                    1 => LinalgError::NonFinite { row },
                    _ => {
                        return Err(format!(
                            "FETI subdomain {subdomain}: {} could not be factored on rank {who} (its error says why)",
                            if c[1] > 0.0 { "its interior stiffness" } else { "its stiffness" }
                        ))
                    }
                };
                let f = Failure {
                    subdomain,
                    interior: c[1] > 0.0,
                    error,
                };
                return Err(f.message(l, &tearing));
            }
        } else if let Some(f) = failure {
            return Err(f.message(l, &tearing));
        }
        let scale = tearing
            .multipliers
            .iter()
            .map(|m| 1.0 / f64::from(m.multiplicity.max(1)))
            .collect();
        let mut feti = Feti {
            parts,
            first: mine.start,
            locals,
            rank,
            size,
            comm: Comm { ranks, bytes: 0 },
            opts,
            scale,
            gtg: None,
            lambda: vec![0.0; nl],
            r: vec![0.0; nl],
            w: vec![0.0; nl],
            z: vec![0.0; nl],
            y: vec![0.0; nl],
            s: vec![0.0; nl],
            q: vec![0.0; nl],
            c: vec![0.0; nc],
            alpha: vec![0.0; nc],
            gammas: vec![0.0; opts.max_iterations as usize + 1],
            betas: vec![0.0; opts.max_iterations as usize + 1],
            stats: FetiSolveStats::default(),
            tearing,
        };
        if nc > 0 {
            // GᵀG, column by column: G e_k, then Gᵀ of it (from the replicated tearing:
            // the same bits on every rank, no communication).
            let mut a = DMatrix::<f64>::zeros(nc, nc);
            let mut col = vec![0.0; nc];
            for k in 0..nc {
                feti.alpha.iter_mut().for_each(|v| *v = 0.0);
                feti.alpha[k] = 1.0;
                g_mul(&feti.tearing, &feti.parts, &feti.alpha, &mut feti.r);
                gt_mul(&feti.tearing, &feti.parts, &feti.r, &mut col);
                for (i, v) in col.iter().enumerate() {
                    a[(i, k)] = *v;
                }
            }
            let mut chol = DenseCholesky::new(nc);
            chol.factor(&a).map_err(|_| {
                "FETI: the coarse problem GᵀG is singular: the rigid-body motions of the floating subdomains are not held by their interfaces (the meshes float as a whole, or a subdomain's interface cannot hold its rotations); a static analysis needs supports — fix or `displace` enough components".to_string()
            })?;
            feti.gtg = Some(chol);
            feti.alpha.iter_mut().for_each(|v| *v = 0.0);
            feti.r.iter_mut().for_each(|v| *v = 0.0);
        }
        Ok(feti)
    }

    /// The tearing (subdomains, multipliers, modes).
    pub fn tearing(&self) -> &Tearing {
        &self.tearing
    }

    /// Number of interface multipliers.
    pub fn multipliers(&self) -> usize {
        self.lambda.len()
    }

    /// This rank (0 in one process).
    pub fn rank(&self) -> usize {
        self.rank
    }

    /// Number of ranks the solver runs on (1 in one process).
    pub fn ranks(&self) -> usize {
        self.size
    }

    /// The subdomains this rank factors and iterates (all of them in one process).
    pub fn subdomains_here(&self) -> Range<usize> {
        self.first..self.first + self.locals.len()
    }

    /// Bytes a rank hands to [`Ranks::sum`] per iteration of the interface problem: `F s`
    /// and the preconditioned residual, 8 per multiplier each (0 in one process).
    pub fn summed_bytes_per_iteration(&self) -> u64 {
        if self.comm.ranks.is_none() {
            return 0;
        }
        let sums = match self.opts.preconditioner {
            FetiPreconditioner::None => 1,
            _ => 2,
        };
        sums * 8 * self.lambda.len() as u64
    }

    /// Stored entries of this rank's subdomain factors (all of them in one process).
    pub fn factor_nnz(&self) -> usize {
        self.locals
            .iter()
            .map(|l| l.kplus.factor_nnz() + l.interior.as_ref().map_or(0, |c| c.factor_nnz()))
            .sum()
    }

    /// Statistics of the solves so far.
    pub fn stats(&self) -> FetiSolveStats {
        self.stats
    }

    /// Solve `(K + diag) x = b` over the global free dofs in place (collective across
    /// ranks: every rank passes the same `b` and receives the whole `x`).
    ///
    /// # Errors
    /// [`StepError::NoConvergence`] when the projected residual has not fallen by the
    /// tolerance in `max_iterations` (on every rank alike).
    pub fn solve_in_place(&mut self, b: &mut [f64]) -> Result<FetiSolveStats, StepError> {
        let Feti {
            tearing,
            parts,
            first,
            locals,
            comm,
            opts,
            scale,
            gtg,
            lambda,
            r,
            w,
            z,
            y,
            s,
            q,
            c,
            alpha,
            gammas,
            betas,
            stats,
            ..
        } = self;
        let first = *first;
        let parts = &**parts;
        let here = first..first + locals.len();
        let subs = &tearing.subdomains[here.clone()];
        let my_parts = &parts[here];
        comm.bytes = 0;
        // Local forces (each shared dof's force split by its multiplicity) and d.
        locals
            .par_iter_mut()
            .zip(subs.par_iter())
            .for_each(|(loc, sd)| {
                for (j, fj) in loc.f.iter_mut().enumerate() {
                    *fj = b[sd.free[j] as usize] / f64::from(sd.multiplicity[j].max(1));
                }
                loc.x.copy_from_slice(&loc.f);
                kplus_solve(loc);
            });
        gather_x(tearing, first, locals, r);
        comm.sum(r);
        // λ₀ = G (GᵀG)⁻¹ e, r₀ = d − F λ₀.
        lambda.iter_mut().for_each(|v| *v = 0.0);
        if let Some(chol) = gtg.as_mut() {
            c.iter_mut().for_each(|v| *v = 0.0);
            for ((loc, sd), part) in locals.iter().zip(subs).zip(my_parts) {
                for i in 0..sd.modes {
                    let ri = &sd.r[i * sd.free.len()..(i + 1) * sd.free.len()];
                    c[part.coarse + i] = ri.iter().zip(&loc.f).map(|(a, b)| a * b).sum();
                }
            }
            comm.sum(c);
            chol.solve_in_place(c);
            g_mul(tearing, parts, c, lambda);
            apply_f(tearing, parts, first, locals, comm, lambda, q);
            r.iter_mut().zip(q.iter()).for_each(|(ri, qi)| *ri -= qi);
        }
        // Projected preconditioned conjugate gradients.
        project(tearing, parts, gtg, c, r, w);
        let w0 = norm(w);
        let (mut rho_prev, mut it, mut rel) = (0.0, 0u32, 0.0);
        if w0 > 0.0 {
            loop {
                let wn = norm(w);
                rel = wn / w0;
                if rel <= opts.tolerance {
                    break;
                }
                if it >= opts.max_iterations {
                    stats.summed_bytes = comm.bytes;
                    return Err(StepError::NoConvergence {
                        what: "FETI interface problem (projected conjugate gradients)",
                        iterations: it,
                        residual: rel,
                        row: None,
                    });
                }
                match opts.preconditioner {
                    FetiPreconditioner::None => z.copy_from_slice(w),
                    p => precondition(tearing, parts, first, locals, comm, scale, p, w, z),
                }
                project(tearing, parts, gtg, c, z, y);
                let rho = dot(w, y);
                let beta = if it == 0 { 0.0 } else { rho / rho_prev };
                s.iter_mut()
                    .zip(y.iter())
                    .for_each(|(si, yi)| *si = yi + beta * *si);
                apply_f(tearing, parts, first, locals, comm, s, q);
                let sq = dot(s, q);
                if !(sq > 0.0 && rho > 0.0) {
                    // F is positive on ker Gᵀ except in the redundant directions, which a
                    // consistent residual never has: a breakdown is round-off at the end.
                    break;
                }
                let gamma = rho / sq;
                gammas[it as usize] = gamma;
                betas[it as usize] = beta;
                lambda
                    .iter_mut()
                    .zip(s.iter())
                    .for_each(|(l, si)| *l += gamma * si);
                r.iter_mut()
                    .zip(q.iter())
                    .for_each(|(ri, qi)| *ri -= gamma * qi);
                project(tearing, parts, gtg, c, r, w);
                rho_prev = rho;
                it += 1;
            }
        }
        // α = −(GᵀG)⁻¹ Gᵀ r.
        if let Some(chol) = gtg.as_mut() {
            gt_mul(tearing, parts, r, alpha);
            chol.solve_in_place(alpha);
            alpha.iter_mut().for_each(|a| *a = -*a);
        }
        // u_s = K_s⁺ (f_s − B_sᵀ λ) + R_s α_s; each dof from its owner.
        let lam = &*lambda;
        let al = &*alpha;
        locals
            .par_iter_mut()
            .zip(subs.par_iter())
            .zip(my_parts.par_iter())
            .for_each(|((loc, sd), part)| {
                loc.x.copy_from_slice(&loc.f);
                for &(m, j, sign) in &part.entries {
                    loc.x[j as usize] -= sign * lam[m as usize];
                }
                kplus_solve(loc);
                let nf = sd.free.len();
                for i in 0..sd.modes {
                    let a = al[part.coarse + i];
                    for (x, ri) in loc.x.iter_mut().zip(&sd.r[i * nf..(i + 1) * nf]) {
                        *x += a * ri;
                    }
                }
            });
        b.iter_mut().for_each(|v| *v = 0.0);
        for (loc, sd) in locals.iter().zip(subs) {
            for ((x, &g), &own) in loc.x.iter().zip(&sd.free).zip(&loc.owns) {
                if own {
                    b[g as usize] = *x;
                }
            }
        }
        comm.sum(b);
        stats.iterations = it;
        stats.max_iterations = stats.max_iterations.max(it);
        stats.solves += 1;
        stats.residual = rel;
        stats.condition = lanczos_condition(&gammas[..it as usize], &betas[..it as usize]);
        stats.summed_bytes = comm.bytes;
        Ok(*stats)
    }
}

/// `x ← K⁺ x` in place (the pinned dofs zero on entry and exit).
fn kplus_solve(loc: &mut Local) {
    for (x, &p) in loc.x.iter_mut().zip(&loc.pinned) {
        if p {
            *x = 0.0;
        }
    }
    loc.kplus.solve_in_place(&mut loc.x);
    for (x, &p) in loc.x.iter_mut().zip(&loc.pinned) {
        if p {
            *x = 0.0;
        }
    }
}

/// `out = Σ_s B_s v_s` over this rank's subdomains (`locals`, the first being subdomain
/// `first`), `v_s` its `x` or its `y`: per multiplier the copy on `a` less the copy on `b`,
/// a zero for a copy on another rank — whose sum over ranks is then exactly the
/// difference of one process.
fn gather(
    t: &Tearing,
    first: usize,
    locals: &[Local],
    v: impl Fn(&Local) -> &[f64],
    out: &mut [f64],
) {
    let at = |s: u32, j: u32| {
        (s as usize)
            .checked_sub(first)
            .and_then(|i| locals.get(i))
            .map_or(0.0, |loc| v(loc)[j as usize])
    };
    for (o, m) in out.iter_mut().zip(&t.multipliers) {
        *o = at(m.a, m.local_a) - at(m.b, m.local_b);
    }
}

/// `out = Σ_s B_s x_s` from this rank's subdomains' `x` (before the sum over ranks).
fn gather_x(t: &Tearing, first: usize, locals: &[Local], out: &mut [f64]) {
    gather(t, first, locals, |l| l.x.as_slice(), out);
}

/// `q = F v = Σ_s B_s K_s⁺ B_sᵀ v` (summed over ranks).
fn apply_f(
    t: &Tearing,
    parts: &[Part],
    first: usize,
    locals: &mut [Local],
    comm: &mut Comm,
    v: &[f64],
    q: &mut [f64],
) {
    let mine = &parts[first..first + locals.len()];
    locals
        .par_iter_mut()
        .zip(mine.par_iter())
        .for_each(|(loc, part)| {
            loc.x.iter_mut().for_each(|x| *x = 0.0);
            for &(m, j, sign) in &part.entries {
                loc.x[j as usize] += sign * v[m as usize];
            }
            kplus_solve(loc);
        });
    gather_x(t, first, locals, q);
    comm.sum(q);
}

/// `z = Σ_s B̃_s A_s B̃_sᵀ w` with `A_s` the stiffness (lumped) or the interface Schur
/// complement (Dirichlet) (summed over ranks).
#[allow(clippy::too_many_arguments)]
fn precondition(
    t: &Tearing,
    parts: &[Part],
    first: usize,
    locals: &mut [Local],
    comm: &mut Comm,
    scale: &[f64],
    p: FetiPreconditioner,
    w: &[f64],
    z: &mut [f64],
) {
    let n = locals.len();
    locals
        .par_iter_mut()
        .zip(t.subdomains[first..first + n].par_iter())
        .zip(parts[first..first + n].par_iter())
        .for_each(|((loc, sd), part)| {
            loc.x.iter_mut().for_each(|x| *x = 0.0);
            for &(m, j, sign) in &part.entries {
                loc.x[j as usize] += sign * scale[m as usize] * w[m as usize];
            }
            if p == FetiPreconditioner::Dirichlet {
                // x_i = −K_ii⁻¹ K_ib x_b
                sd.assembly.mul_free(&sd.k, &loc.x, &mut loc.t);
                for (ti, &bd) in loc.t.iter_mut().zip(&loc.boundary) {
                    if bd {
                        *ti = 0.0;
                    }
                }
                if let Some(ch) = loc.interior.as_mut() {
                    ch.solve_in_place(&mut loc.t);
                }
                for ((x, ti), &bd) in loc.x.iter_mut().zip(&loc.t).zip(&loc.boundary) {
                    if !bd {
                        *x = -ti;
                    }
                }
            }
            sd.assembly.mul_free(&sd.k, &loc.x, &mut loc.y);
        });
    gather(t, first, locals, |l| l.y.as_slice(), z);
    comm.sum(z);
    z.iter_mut().zip(scale).for_each(|(o, sc)| *o *= sc);
}

/// `out = G c` (every subdomain: replicated).
fn g_mul(t: &Tearing, parts: &[Part], c: &[f64], out: &mut [f64]) {
    out.iter_mut().for_each(|v| *v = 0.0);
    for (part, sd) in parts.iter().zip(&t.subdomains) {
        let nf = sd.free.len();
        for i in 0..sd.modes {
            let ci = c[part.coarse + i];
            let ri = &sd.r[i * nf..(i + 1) * nf];
            for &(m, j, sign) in &part.entries {
                out[m as usize] += sign * ri[j as usize] * ci;
            }
        }
    }
}

/// `out = Gᵀ v` (every subdomain: replicated).
fn gt_mul(t: &Tearing, parts: &[Part], v: &[f64], out: &mut [f64]) {
    for (part, sd) in parts.iter().zip(&t.subdomains) {
        let nf = sd.free.len();
        for i in 0..sd.modes {
            let ri = &sd.r[i * nf..(i + 1) * nf];
            out[part.coarse + i] = part
                .entries
                .iter()
                .map(|&(m, j, sign)| sign * ri[j as usize] * v[m as usize])
                .sum();
        }
    }
}

/// `out = P v = v − G (GᵀG)⁻¹ Gᵀ v` (`c` is scratch of the coarse size; replicated).
fn project(
    t: &Tearing,
    parts: &[Part],
    gtg: &mut Option<DenseCholesky>,
    c: &mut [f64],
    v: &[f64],
    out: &mut [f64],
) {
    let Some(chol) = gtg.as_mut() else {
        out.copy_from_slice(v);
        return;
    };
    gt_mul(t, parts, v, c);
    chol.solve_in_place(c);
    // out = v − G c, without a second buffer: G c first, then subtract from v.
    g_mul(t, parts, c, out);
    out.iter_mut().zip(v).for_each(|(o, vi)| *o = vi - *o);
}

/// The ratio of the extreme eigenvalues of the Lanczos matrix of a conjugate-gradient run
/// with step lengths `gamma` and ratios `beta` (`beta[0]` unused):
/// `T_kk = 1/γ_k + β_k/γ_{k−1}`, `T_{k,k−1} = √β_k / γ_{k−1}`. Its eigenvalues come from
/// Sturm-sequence bisection (no allocation).
fn lanczos_condition(gamma: &[f64], beta: &[f64]) -> f64 {
    let n = gamma.len();
    if n == 0 {
        return 1.0;
    }
    let diag = |k: usize| {
        if k == 0 {
            1.0 / gamma[0]
        } else {
            1.0 / gamma[k] + beta[k] / gamma[k - 1]
        }
    };
    let off = |k: usize| beta[k].max(0.0).sqrt() / gamma[k - 1];
    // Eigenvalues below x: the negative pivots of T − x I.
    let below = |x: f64| {
        let mut count = 0;
        let mut d = 1.0;
        for k in 0..n {
            let e2 = if k == 0 { 0.0 } else { off(k) * off(k) };
            d = diag(k) - x - if k == 0 { 0.0 } else { e2 / d };
            if d == 0.0 {
                d = f64::MIN_POSITIVE;
            }
            if d < 0.0 {
                count += 1;
            }
        }
        count
    };
    // Gershgorin bounds.
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..n {
        let r = if k > 0 { off(k) } else { 0.0 } + if k + 1 < n { off(k + 1) } else { 0.0 };
        lo = lo.min(diag(k) - r);
        hi = hi.max(diag(k) + r);
    }
    let lo = lo.max(0.0);
    let bisect = |index: usize| {
        let (mut a, mut b) = (lo, hi);
        for _ in 0..200 {
            let m = 0.5 * (a + b);
            if m <= a || m >= b {
                break;
            }
            if below(m) > index {
                b = m;
            } else {
                a = m;
            }
        }
        0.5 * (a + b)
    };
    let (min, max) = (bisect(0), bisect(n - 1));
    if min > 0.0 {
        max / min
    } else {
        f64::INFINITY
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    //! FETI against the direct factorization of the assembled matrix (the notes' anchor 1:
    //! tearing is exact, so the displacements agree to the solver tolerance), in 2-D and
    //! 3-D, with floating subdomains and subdomains on the supports, for 2 to 32
    //! subdomains; the algebra of the tearing (rigid modes in the kernel, the start on the
    //! constraint); thread independence; the refusals.

    use std::sync::Arc;

    use super::*;
    use crate::analysis::mesh_model;
    use crate::contract::mesh_layout::LoadGroup;
    use crate::contract::ranks::Ranks;
    use crate::contract::scene::{
        ElementKind, Fn1, Material, Mesh, MeshFormulation, MeshMethod, MeshSolver,
    };
    use crate::integrators::mesh_dynamics::MeshState;
    use crate::integrators::mesh_implicit::MeshImplicit;

    const STEEL: Material = Material {
        e: 200e9,
        nu: 0.3,
        rho: 7800.0,
        plastic: None,
    };

    /// A regular grid of `n[0] × n[1]` quad4 (or `n[0] × n[1] × n[2]` hex8) elements over
    /// the box `len`, interior nodes moved by up to 0.15 of a cell (a generic geometry).
    fn grid(kind: ElementKind, n: [usize; 3], len: [f64; 3]) -> Mesh {
        let dim = kind.dim();
        let nz = if dim == 3 { n[2] } else { 0 };
        let id = |i: usize, j: usize, k: usize| (k * (n[1] + 1) + j) * (n[0] + 1) + i;
        let mut nodes = Vec::new();
        for k in 0..=nz {
            for j in 0..=n[1] {
                for i in 0..=n[0] {
                    let h = [
                        len[0] / n[0] as f64,
                        len[1] / n[1] as f64,
                        len[2] / n[2].max(1) as f64,
                    ];
                    let mut x = [i as f64 * h[0], j as f64 * h[1], k as f64 * h[2]];
                    let inside = |m: usize, top: usize| m > 0 && m < top;
                    if inside(i, n[0]) && inside(j, n[1]) && (dim == 2 || inside(k, nz)) {
                        let s = (i * 7 + j * 13 + k * 5) as f64;
                        x[0] += 0.15 * h[0] * s.sin();
                        x[1] += 0.15 * h[1] * (1.3 * s).cos();
                        if dim == 3 {
                            x[2] += 0.15 * h[2] * (0.7 * s).sin();
                        }
                    }
                    nodes.push(x);
                }
            }
        }
        let mut elements = Vec::new();
        for k in 0..nz.max(1) {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    let q = [
                        id(i, j, k),
                        id(i + 1, j, k),
                        id(i + 1, j + 1, k),
                        id(i, j + 1, k),
                    ];
                    let mut e = q.to_vec();
                    if dim == 3 {
                        e.extend(q.iter().map(|&a| a + (n[0] + 1) * (n[1] + 1)));
                    }
                    elements.push(e);
                }
            }
        }
        Mesh {
            name: "m".into(),
            kind,
            material: STEEL,
            thickness: 0.01,
            nodes,
            elements,
            node_sets: vec![],
            conditions: vec![],
            formulation: MeshFormulation::default(),
            origin: Default::default(),
        }
    }

    /// A cantilever: the grid clamped at x = 0, under its weight and a load at the far
    /// end pointing along (0.3, −1, 0.5) (its z part only in 3-D).
    fn cantilever(kind: ElementKind, n: [usize; 3], len: [f64; 3]) -> MeshLayout {
        let dim = kind.dim();
        let mut l = mesh_model::build(&[grid(kind, n, len)]).unwrap();
        let mut tip = Vec::new();
        for i in 0..l.nodes() {
            let x = l.x0[i];
            if x[0].abs() < 1e-12 {
                l.constrained[i] = [true; 3];
            }
            if (x[0] - len[0]).abs() < 1e-12 {
                tip.push(i as u32);
            }
        }
        l.body_force = l.mass.iter().map(|m| [0.0, -9.81 * m, 0.0]).collect();
        let w = vec![1.0 / tip.len() as f64; tip.len()];
        l.loads.push(LoadGroup {
            value: [
                Fn1::Const(300.0),
                Fn1::Const(-1000.0),
                Fn1::Const(if dim == 3 { 500.0 } else { 0.0 }),
            ],
            nodes: tip,
            weights: w,
        });
        l
    }

    fn feti(p: u32, pre: FetiPreconditioner, tol: f64) -> MeshSolver {
        MeshSolver::Feti(FetiOptions {
            subdomains: p,
            preconditioner: pre,
            tolerance: tol,
            max_iterations: 2000,
        })
    }

    /// Displacements of the analysis `method` of `l` with `solver` at t = 0 (Newmark: one
    /// step of `h`), and the integrator.
    fn run(l: &MeshLayout, method: MeshMethod, solver: MeshSolver) -> (Vec<f64>, MeshImplicit) {
        let mut l = l.clone();
        l.method = method;
        l.solver = solver;
        let mut s = MeshImplicit::new(Arc::new(l), method, 1e-4, 0.0, &MeshState::default())
            .unwrap_or_else(|e| panic!("{e}"));
        if method == MeshMethod::Newmark {
            s.advance().unwrap();
        }
        let mut st = MeshState::default();
        s.mesh_state(&mut st);
        (st.u.as_flattened().to_vec(), s)
    }

    /// A FETI run stopped loosely (interface tolerance 10⁻²) leaves a global residual
    /// above the warning threshold, and the run says so at its end; at the default
    /// tolerance it does not.
    #[test]
    fn a_loose_feti_tolerance_is_reported() {
        let l = cantilever(ElementKind::Quad4PlaneStress, [32, 8, 0], [4.0, 1.0, 0.0]);
        let (_, loose) = run(
            &l,
            MeshMethod::Static,
            feti(8, FetiPreconditioner::None, 1e-2),
        );
        let w = loose.residual_warning().expect("a warning");
        assert!(loose.residual() > super::super::mesh_implicit::RESIDUAL_WARNING);
        assert!(w.contains("lower `tolerance`"), "{w}");
        let (_, tight) = run(
            &l,
            MeshMethod::Static,
            feti(8, FetiPreconditioner::Dirichlet, 1e-10),
        );
        assert_eq!(
            tight.residual_warning(),
            None,
            "residual {}",
            tight.residual()
        );
    }

    fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
        let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
            / scale
    }

    /// Check 1 of the issue: FETI equals the direct solution to 1e-8 relative, 2-D and
    /// 3-D, floating subdomains and subdomains on the support, 2 to 32 subdomains, every
    /// preconditioner.
    #[test]
    fn feti_equals_the_direct_solution() {
        for (kind, n, len) in [
            (ElementKind::Quad4PlaneStress, [32, 8, 0], [4.0, 1.0, 0.0]),
            (ElementKind::Hex8, [16, 4, 4], [4.0, 1.0, 1.0]),
        ] {
            let l = cantilever(kind, n, len);
            let (direct, _) = run(&l, MeshMethod::Static, MeshSolver::Direct);
            for p in [2, 3, 4, 8, 16, 32] {
                for pre in [
                    FetiPreconditioner::Dirichlet,
                    FetiPreconditioner::Lumped,
                    FetiPreconditioner::None,
                ] {
                    let (u, s) = run(&l, MeshMethod::Static, feti(p, pre, 1e-11));
                    let f = s.feti().unwrap();
                    let t = f.tearing();
                    assert_eq!(t.subdomains.len(), p as usize);
                    // Subdomains away from the clamp float: 3 modes in 2-D, 6 in 3-D.
                    let per = if kind.dim() == 2 { 3 } else { 6 };
                    assert!(
                        t.floating() >= 1 && t.floating() < p as usize,
                        "{p}: {}",
                        t.floating()
                    );
                    assert_eq!(t.modes(), per * t.floating());
                    let e = rel_diff(&u, &direct);
                    assert!(
                        e < 1e-8,
                        "{kind:?} p = {p} {pre:?}: relative difference {e:.2e} ({} iterations)",
                        f.stats().iterations
                    );
                    assert!(
                        s.residual() < 1e-8,
                        "{kind:?} p = {p} {pre:?}: residual {:.2e}",
                        s.residual()
                    );
                }
            }
        }
    }

    /// Check 2 of the issue: at a fixed subdomain size (H/h = 4 elements), 4 to 256 square
    /// subdomains of a square plate clamped on one side (most of them floating). The
    /// condition number of the preconditioned interface operator (from the Lanczos
    /// coefficients of the run) levels off as the subdomains multiply — measured 6.1, 7.2,
    /// 7.7, 7.8 with the Dirichlet preconditioner, 13, 18, 19.7, 19.9 lumped, 52, 80, 86,
    /// 86.5 without (docs/methods.md has the table with the iterations): the method is
    /// scalable, and the Dirichlet preconditioner divides κ by 11 and the lumped one by 4.
    #[test]
    fn the_condition_number_levels_off_as_subdomains_multiply() {
        let m = 4;
        let (mut table, mut kappa) = (Vec::new(), Vec::new());
        for k in [2usize, 4, 8, 16] {
            let n = k * m;
            let l = cantilever(ElementKind::Quad4PlaneStrain, [n, n, 0], [1.0, 1.0, 0.0]);
            let mut conds = Vec::new();
            let row: Vec<u32> = [
                FetiPreconditioner::Dirichlet,
                FetiPreconditioner::Lumped,
                FetiPreconditioner::None,
            ]
            .iter()
            .map(|&pre| {
                let (_, s) = run(&l, MeshMethod::Static, feti((k * k) as u32, pre, 1e-8));
                conds.push(s.feti().unwrap().stats().condition);
                s.feti().unwrap().stats().iterations
            })
            .collect();
            eprintln!(
                "subdomains {:3}  dirichlet {:3} (κ {:6.1})  lumped {:3} (κ {:6.1})  none {:3} (κ {:7.1})",
                k * k,
                row[0],
                conds[0],
                row[1],
                conds[1],
                row[2],
                conds[2]
            );
            table.push(row);
            kappa.push(conds);
        }
        for (row, k) in table.iter().zip(&kappa) {
            assert!(row[0] < row[1] && row[1] < row[2], "{row:?}");
            assert!(
                4.0 * k[0] < k[2] && 2.0 * k[1] < k[2] && 2.0 * k[0] < k[1],
                "{k:?}"
            );
        }
        for c in 0..3 {
            let (k64, k256) = (kappa[2][c], kappa[3][c]);
            assert!(k256 < 1.05 * k64, "κ levels off: {kappa:?}");
        }
        assert!(kappa[3][0] < 10.0, "{kappa:?}");
    }

    /// Newmark's matrix `K + 4/h² M` holds every subdomain (no floating one, no coarse
    /// problem); FETI's step equals the direct step.
    #[test]
    fn newmark_step_equals_the_direct_step() {
        let l = cantilever(ElementKind::Hex8, [8, 2, 2], [2.0, 0.5, 0.5]);
        let (direct, _) = run(&l, MeshMethod::Newmark, MeshSolver::Direct);
        let (u, s) = run(
            &l,
            MeshMethod::Newmark,
            feti(4, FetiPreconditioner::Dirichlet, 1e-12),
        );
        assert_eq!(s.feti().unwrap().tearing().floating(), 0);
        let e = rel_diff(&u, &direct);
        assert!(e < 1e-9, "relative difference {e:.2e}");
    }

    /// The subdomain work runs on rayon's pool and every sum is taken in a fixed order: one
    /// thread and three give bitwise the same displacements.
    #[test]
    fn threads_do_not_change_a_bit() {
        let l = cantilever(ElementKind::Quad4PlaneStress, [16, 8, 0], [2.0, 1.0, 0.0]);
        let solve = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                run(
                    &l,
                    MeshMethod::Static,
                    feti(8, FetiPreconditioner::Dirichlet, 1e-10),
                )
                .0
            })
        };
        let (a, b) = (solve(1), solve(3));
        assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
    }

    /// The tearing's algebra: every rigid mode is in its subdomain's kernel, the modes are
    /// orthonormal, the pinned rows of `R_s` are invertible (`K_pp` is then regular).
    #[test]
    fn rigid_modes_span_the_kernels() {
        use crate::analysis::mesh_stiffness;
        let l = cantilever(ElementKind::Hex8, [8, 4, 2], [2.0, 1.0, 0.5]);
        let k = mesh_stiffness::assemble(&l).unwrap();
        let t = mesh_subdomains::tear(&l, &k.assembly, None, 8).unwrap();
        for sd in &t.subdomains {
            let nf = sd.free.len();
            let kmax = (0..nf)
                .map(|j| sd.k[sd.assembly.diagonal(j)])
                .fold(0.0, f64::max);
            let mut kr = vec![0.0; nf];
            for i in 0..sd.modes {
                let ri = &sd.r[i * nf..(i + 1) * nf];
                sd.assembly.mul_free(&sd.k, ri, &mut kr);
                assert!(norm(&kr) < 1e-10 * kmax);
                for j in 0..sd.modes {
                    let d = dot(ri, &sd.r[j * nf..(j + 1) * nf]);
                    assert!((d - f64::from(u8::from(i == j))).abs() < 1e-12);
                }
            }
            let pinned = DMatrix::from_fn(sd.modes, sd.modes, |a, b| {
                sd.r[b * nf + sd.pinned[a] as usize]
            });
            if sd.modes > 0 {
                let sv = pinned.singular_values();
                assert!(sv.min() > 1e-3 * sv.max(), "{sv}");
            }
        }
    }

    /// A mesh held nowhere floats as a whole: the coarse problem is singular and the
    /// solver says so instead of returning a displacement.
    #[test]
    fn a_floating_structure_is_refused() {
        let mut l = cantilever(ElementKind::Quad4PlaneStress, [8, 2, 0], [2.0, 0.5, 0.0]);
        for c in &mut l.constrained {
            c[0] = false;
            c[1] = false;
        }
        l.method = MeshMethod::Static;
        l.solver = feti(4, FetiPreconditioner::Dirichlet, 1e-10);
        let Err(e) = MeshImplicit::new(
            Arc::new(l),
            MeshMethod::Static,
            1e-3,
            0.0,
            &MeshState::default(),
        ) else {
            panic!("a floating structure was solved");
        };
        let msg = e.to_string();
        assert!(
            msg.contains("coarse problem") && msg.contains("supports"),
            "{msg}"
        );
    }

    /// Displacements after each of `steps` steps (static: the solve at t = 0 only) of the
    /// analysis `method` of `l` with `solver`, as one rank of `ranks` (`None`: one
    /// process), and the FETI statistics of the last solve.
    fn run_on(
        l: &MeshLayout,
        method: MeshMethod,
        solver: MeshSolver,
        steps: usize,
        ranks: Option<Arc<dyn Ranks>>,
    ) -> Result<(Vec<f64>, FetiSolveStats, usize), String> {
        let mut l = l.clone();
        l.method = method;
        l.solver = solver;
        let mut s =
            MeshImplicit::on_ranks(Arc::new(l), method, 1e-4, 0.0, &MeshState::default(), ranks)
                .map_err(|e| e.to_string())?;
        let mut st = MeshState::default();
        let mut out = Vec::new();
        s.mesh_state(&mut st);
        out.extend_from_slice(st.u.as_flattened());
        if method == MeshMethod::Newmark {
            for _ in 0..steps {
                s.advance().map_err(|e| e.to_string())?;
                s.mesh_state(&mut st);
                out.extend_from_slice(st.u.as_flattened());
            }
        }
        let f = s.feti().ok_or("no FETI")?;
        Ok((out, f.stats(), f.subdomains_here().len()))
    }

    /// FETI across ranks (ranks as threads) gives the bits of FETI in one process — the
    /// multipliers' sums over ranks have at most two non-zero terms per entry, the
    /// displacement one — on 1, 2, 3 and 4 ranks: 2-D quad4 and 3-D hex8, static (with
    /// floating subdomains) and three Newmark steps, Dirichlet and lumped preconditioners,
    /// 7 subdomains (uneven runs per rank). Checked: every rank's displacements equal the
    /// one-process displacements bit for bit (hence within the 1e-12 relative asked, which
    /// is asserted too), the same iteration count on every rank, and every subdomain held
    /// by exactly one rank.
    #[test]
    fn ranks_give_the_bits_of_one_process() {
        use crate::contract::thread_ranks::ThreadRanks;
        for (kind, n, len) in [
            (ElementKind::Quad4PlaneStress, [14, 4, 0], [3.5, 1.0, 0.0]),
            (ElementKind::Hex8, [7, 2, 2], [3.5, 1.0, 1.0]),
        ] {
            let l = cantilever(kind, n, len);
            for (method, pre) in [
                (MeshMethod::Static, FetiPreconditioner::Dirichlet),
                (MeshMethod::Static, FetiPreconditioner::Lumped),
                (MeshMethod::Newmark, FetiPreconditioner::Dirichlet),
            ] {
                let solver = feti(7, pre, 1e-10);
                let (one, st, held) = run_on(&l, method, solver, 3, None).unwrap();
                assert_eq!(held, 7);
                assert!(st.iterations > 0);
                assert_eq!(st.summed_bytes, 0);
                for ranks in 1..=4 {
                    let out = ThreadRanks::run(ranks, |r| {
                        run_on(&l, method, solver, 3, Some(r)).unwrap()
                    });
                    let held: usize = out.iter().map(|o| o.2).sum();
                    assert_eq!(held, 7, "{ranks} ranks hold every subdomain once");
                    for (rank, (u, s, _)) in out.iter().enumerate() {
                        let what = format!("{kind:?} {method:?} {pre:?}, rank {rank} of {ranks}");
                        assert!(rel_diff(u, &one) <= 1e-12, "{what}");
                        assert!(
                            u.iter().zip(&one).all(|(a, b)| a.to_bits() == b.to_bits()),
                            "{what}: not the bits of one process ({:.2e})",
                            rel_diff(u, &one)
                        );
                        assert_eq!(s.iterations, st.iterations, "{what}");
                        assert_eq!(s.summed_bytes > 0, ranks > 1, "{what}");
                    }
                }
            }
        }
    }

    /// The floating subdomains of the static cantilever above are spread over the ranks:
    /// the test runs the coarse problem across ranks, not only held subdomains.
    #[test]
    fn the_rank_test_has_floating_subdomains_on_several_ranks() {
        let l = cantilever(ElementKind::Quad4PlaneStress, [14, 4, 0], [3.5, 1.0, 0.0]);
        let k = crate::analysis::mesh_stiffness::assemble(&l).unwrap();
        let t = mesh_subdomains::tear(&l, &k.assembly, None, 7).unwrap();
        let weights: Vec<u64> = t.subdomains.iter().map(|s| s.k.len() as u64).collect();
        let cuts = assign(&weights, 4);
        let floating_ranks = (0..4)
            .filter(|&r| (cuts[r]..cuts[r + 1]).any(|s| t.subdomains[s].modes > 0))
            .count();
        assert!(floating_ranks >= 3, "{cuts:?}");
    }

    /// A rank's sums carry `F s` and the preconditioned residual per iteration, plus `d`,
    /// `F λ₀`, `e` and the displacement once per solve: the count the stats report.
    #[test]
    fn the_summed_bytes_are_counted() {
        use crate::contract::thread_ranks::ThreadRanks;
        let l = cantilever(ElementKind::Quad4PlaneStress, [8, 2, 0], [2.0, 0.5, 0.0]);
        let solver = feti(4, FetiPreconditioner::Dirichlet, 1e-10);
        let out = ThreadRanks::run(2, |r| {
            let mut l = l.clone();
            l.method = MeshMethod::Static;
            l.solver = solver;
            let s = MeshImplicit::on_ranks(
                Arc::new(l),
                MeshMethod::Static,
                1e-4,
                0.0,
                &MeshState::default(),
                Some(r),
            )
            .unwrap();
            let f = s.feti().unwrap();
            let (nl, nc) = (f.multipliers() as u64, f.tearing().modes() as u64);
            let nf = f.tearing().free_dofs as u64;
            let it = u64::from(f.stats().iterations);
            assert!(nc > 0);
            assert_eq!(f.summed_bytes_per_iteration(), 16 * nl);
            assert_eq!(
                f.stats().summed_bytes,
                8 * (2 * nl + nc + nf) + it * f.summed_bytes_per_iteration()
            );
            f.ranks()
        });
        assert_eq!(out, vec![2, 2]);
    }

    /// More ranks than subdomains is refused on every rank (before any sum), naming the
    /// mesh and the numbers.
    #[test]
    fn fewer_subdomains_than_ranks_is_refused() {
        use crate::contract::thread_ranks::ThreadRanks;
        let l = cantilever(ElementKind::Quad4PlaneStress, [8, 2, 0], [2.0, 0.5, 0.0]);
        let solver = feti(2, FetiPreconditioner::Dirichlet, 1e-10);
        let out = ThreadRanks::run(3, |r| {
            run_on(&l, MeshMethod::Static, solver, 0, Some(r))
                .err()
                .unwrap_or_default()
        });
        for msg in out {
            assert!(
                msg.contains("'m'") && msg.contains("2 subdomains") && msg.contains("3 ranks"),
                "{msg}"
            );
        }
    }

    /// The assignment: contiguous, every rank at least one subdomain, balanced by weight.
    #[test]
    fn subdomains_are_assigned_in_balanced_runs() {
        assert_eq!(assign(&[1, 1, 1, 1], 2), vec![0, 2, 4]);
        assert_eq!(assign(&[5, 1, 1, 1, 1, 1], 2), vec![0, 1, 6]);
        assert_eq!(assign(&[1, 1, 1, 1, 1, 1, 9], 3), vec![0, 5, 6, 7]);
        assert_eq!(assign(&[2, 1, 1, 2, 1, 1], 3), vec![0, 2, 4, 6]);
        assert_eq!(assign(&[9, 9, 9], 3), vec![0, 1, 2, 3]);
        assert_eq!(assign(&[100, 0, 0, 0], 4), vec![0, 1, 2, 3, 4]);
        assert_eq!(assign(&[3, 2, 7], 1), vec![0, 3]);
    }
}
