//! The reduced equations `AᵀMA q̈ = Aᵀ(F − M Ȧq̇)` without forming `AᵀMA`: per-position
//! data, the tree-exact `O(N)` solve, the matrix-free operator and a preconditioned
//! conjugate-gradient solver.
//!
//! # Arrowhead, Schur complement and the tree-exact solve (notes C §1.8)
//!
//! The paper augments `ü = A q̈ + Ȧq̇` and `AᵀM ü = AᵀF` into the arrowhead system
//! `[−M, MA; AᵀM, 0]`, whose Schur complement of the block-diagonal `−M` is
//! `+AᵀMA = Σⱼ Aⱼᵀ Mⱼ Aⱼ` (plus sign: SPD; the printed PPCG's two minus signs come from the
//! `−M` block and cancel, notes C §1.9). [`Solver::apply`] is that operator matrix-free:
//! `u = A p` root → leaf, `Mⱼ uⱼ` per body (the constant `Mⱼ`), `Aᵀ` leaf → root.
//!
//! [`Solver::factor`] / [`Solver::solve`] are the tree-exact solve used as the
//! preconditioner: block elimination of `AᵀMA` over the tree, leaf → root then root →
//! leaf, `O(N)` (the articulated-body recursion written for an arbitrary right-hand side).
//! With `u_c = X_c u_p + S_c x_c`, eliminating a subtree leaves on its parent the cost
//! `½ yᵀ P y − yᵀ z` of the transported twist `y = X_c u_p`:
//!
//! ```text
//! leaf → root:  I_c = M_c + Σ_k X_kᵀ P_k X_k          (articulated inertia)
//!               D_c = S_cᵀ I_c S_c = L Lᵀ,  W = I_c S_c L⁻ᵀ,  P_c = I_c − W Wᵀ
//!               β_c = f_c + Σ_k X_kᵀ z_k,  h_c = L⁻¹(b_c + S_cᵀ β_c),  z_c = β_c − W h_c
//! root → leaf:  y_c = X_c u_p,  x_c = L⁻ᵀ(h_c − Wᵀ y_c),  u_c = y_c + S_c x_c
//! ```
//!
//! for a right-hand side given as body forces `f` (`b = Aᵀ f`) and/or per-joint
//! generalized forces `b`. `x` solves `AᵀMA x = b + Aᵀf` exactly and `u = A x` comes for
//! free: the body accelerations of the back substitution (4.6). Only the `dof × dof`
//! blocks `D_c` are factorized (Cholesky, at most 6 × 6); the dependent blocks were
//! inverted analytically in [`crate::kernels::tree_joints`].
//!
//! # Preconditioned conjugate gradients
//!
//! [`pcg`] is the generic PCG of notes C §1.9 (with the sign corrections) on flat vectors;
//! [`Solver::pcg_reduced`] runs it on `AᵀMA` with a choice of preconditioner
//! ([`Precond`]): none, block-Jacobi (the diagonal blocks `S_cᵀ I^C_c S_c` with the
//! composite inertias `I^C`), or the tree-exact solve, for which it converges in one
//! iteration. The integrator uses the tree-exact solve directly; the measured iteration
//! counts of the three are in docs/methods.md.

use nalgebra::{Matrix3, Matrix6, Vector3};

use super::tree::{Tree, NONE};
use crate::contract::system::{MassProps, Twist, Wrench};
use crate::kernels::tree_joints::TreeJointKin;

/// Everything the recursions keep per tree position.
///
/// Only what the sweeps of a step read or write, packed: one set of joint blocks, the
/// factorization in [`Node::wl`] (`W` and `L` sized for at most 3 rates; a free root's
/// `W` equals its `L`), and fields that share storage where their lifetimes do not
/// overlap ([`Node::f`] holds the input force, then the subtree bias; [`Node::x`] the
/// input generalized force, then the solution; [`Node::a0`] the joint's velocity-product
/// term `κ`, then the free acceleration): 1544 bytes of fields (3312 with the two sets of
/// joint blocks of the old two-sequence integrator), 1600 in memory: a node starts on a
/// cache line, so every node has its fields on the same lines, a constant stride the
/// hardware prefetcher follows through a sweep.
#[derive(Clone, Debug)]
#[repr(align(64))]
pub struct Node {
    /// Mass.
    pub m: f64,
    /// Inertia (body).
    pub j: Matrix3<f64>,
    /// Joint blocks at the current positions.
    pub kin: TreeJointKin,
    /// `P_c` handed to the parent (leaf → root factorization; the composite inertia for
    /// block-Jacobi), stored only at a branch's first position: within a branch it is
    /// handed over in a local ([`Solver::up_handing`]). Meaningless elsewhere.
    pub pm: Matrix6<f64>,
    /// The factorization of `D = SᵀIS = L Lᵀ` and `W = I S L⁻ᵀ`, packed by the number of
    /// rates `n`: for `n ≤ 3` the columns of `W` (`6n` entries) then the lower triangle
    /// of `L` by rows from entry 18; for a free root (`n = 6`, `S = I₆`, so `W = L`) the
    /// lower triangle of `L` by rows from entry 0.
    pub wl: [f64; 24],
    /// Input body force of a backward sweep; after it, the subtree bias `z` handed to
    /// the parent.
    pub f: Wrench,
    /// `L⁻¹ g`.
    pub hh: [f64; 6],
    /// Input generalized force on this joint's rates (solves with `with_b`); after a
    /// forward sweep, the solution: this joint's `x`.
    pub x: [f64; 6],
    /// Solution: the body's `(A x)` (acceleration).
    pub acc: Twist,
    /// The velocity-product term `κ` of the joint (input of [`Solver::backward_bias`]);
    /// after the forward half of the free solve, the acceleration without cut forces
    /// `Ȧq̇ + A x`.
    pub a0: Twist,
    /// Scratch twist (projected velocity).
    pub tw: Twist,
    /// Scratch twist (unprojected velocity).
    pub raw: Twist,
    /// Scratch displacement (position correction).
    pub dq: Twist,
    /// Scratch pose.
    pub pose: crate::contract::system::Pose,
}

impl Node {
    /// A node for a body of mass properties `mp`.
    pub fn new(mp: &MassProps) -> Node {
        Node {
            m: mp.m,
            j: mp.j,
            kin: TreeJointKin::default(),
            pm: Matrix6::zeros(),
            wl: [0.0; 24],
            f: Wrench::default(),
            hh: [0.0; 6],
            x: [0.0; 6],
            acc: Twist::default(),
            a0: Twist::default(),
            tw: Twist::default(),
            raw: Twist::default(),
            dq: Twist::default(),
            pose: crate::contract::system::Pose::default(),
        }
    }

    /// Visit the node's blocks and scratch values for a checkpoint
    /// ([`crate::contract::persist`]): the joint blocks, the factorization, the sweep's
    /// forces and solutions. A step remakes them before it reads them; they are carried so
    /// that nothing of the node is left to the restart state.
    pub fn persist(&mut self, v: &mut dyn crate::contract::persist::StateVisitor) {
        use crate::contract::persist;
        persist::f64(v, "node.m", &mut self.m);
        v.f64s("node.j", self.j.as_mut_slice());
        let k = &mut self.kin;
        persist::usize(v, "node.kin.dof", &mut k.dof);
        persist::f64(v, "node.kin.sigma", &mut k.sigma);
        persist::bool(v, "node.kin.absolute", &mut k.absolute);
        v.f64s("node.kin.xv", k.xv.as_mut_slice());
        v.f64s("node.kin.xw", k.xw.as_mut_slice());
        for c in k.s.iter_mut() {
            v.f64s("node.kin.s", c);
        }
        v.f64s("node.kin.lever_p", k.lever_p.as_mut_slice());
        v.f64s("node.kin.lever_c", k.lever_c.as_mut_slice());
        for a in k.rot.iter_mut().chain(k.trans.iter_mut()) {
            v.f64s("node.kin.axis", a.as_mut_slice());
        }
        v.bools("node.kin.rot_on_a", &mut k.rot_on_a);
        persist::usize(v, "node.kin.nrot", &mut k.nrot);
        persist::usize(v, "node.kin.ntrans", &mut k.ntrans);
        v.f64s("node.pm", self.pm.as_mut_slice());
        v.f64s("node.wl", &mut self.wl);
        persist::wrenches(v, "node.f", std::slice::from_mut(&mut self.f));
        v.f64s("node.hh", &mut self.hh);
        v.f64s("node.x", &mut self.x);
        for t in [
            &mut self.acc,
            &mut self.a0,
            &mut self.tw,
            &mut self.raw,
            &mut self.dq,
        ] {
            persist::twists(v, "node.twist", std::slice::from_mut(t));
        }
        persist::poses(v, "node.pose", std::slice::from_mut(&mut self.pose));
    }

    /// `M u` for a twist.
    #[inline]
    pub fn mass_mul(&self, u: &Twist) -> Wrench {
        Wrench {
            f: u.v * self.m,
            t: self.j * u.w,
        }
    }

    /// The body's mass matrix `diag(m I, J)`.
    #[inline]
    fn mass6(&self) -> Matrix6<f64> {
        let mut ia = Matrix6::zeros();
        for d in 0..3 {
            ia[(d, d)] = self.m;
        }
        ia.fixed_view_mut::<3, 3>(3, 3).copy_from(&self.j);
        ia
    }
}

/// The joint blocks of a free root: `S = I₆`, no parent.
pub fn free_kin() -> TreeJointKin {
    TreeJointKin {
        dof: 6,
        xw: Matrix3::zeros(),
        ..TreeJointKin::default()
    }
}

#[inline]
fn wrench6(w: &Wrench) -> [f64; 6] {
    [w.f.x, w.f.y, w.f.z, w.t.x, w.t.y, w.t.z]
}

#[inline]
fn twist6(t: &Twist) -> [f64; 6] {
    [t.v.x, t.v.y, t.v.z, t.w.x, t.w.y, t.w.z]
}

#[inline]
fn add_wrench(a: &mut Wrench, b: &Wrench) {
    a.f += b.f;
    a.t += b.t;
}

/// `Xᵀ P X` for `X = [[I, xv], [0, xw]]`, by 3 × 3 blocks (`P` symmetric).
#[inline]
fn xtpx(k: &TreeJointKin, p: &Matrix6<f64>) -> Matrix6<f64> {
    let a = p.fixed_view::<3, 3>(0, 0).into_owned();
    let b = p.fixed_view::<3, 3>(0, 3).into_owned();
    let d = p.fixed_view::<3, 3>(3, 3).into_owned();
    let t1 = a * k.xv + b * k.xw;
    let br = k.xv.transpose() * t1 + k.xw.transpose() * (b.transpose() * k.xv + d * k.xw);
    let mut o = Matrix6::zeros();
    o.fixed_view_mut::<3, 3>(0, 0).copy_from(&a);
    o.fixed_view_mut::<3, 3>(0, 3).copy_from(&t1);
    o.fixed_view_mut::<3, 3>(3, 0).copy_from(&t1.transpose());
    o.fixed_view_mut::<3, 3>(3, 3).copy_from(&br);
    o
}

/// Start of row `i` of a packed lower triangle.
#[inline(always)]
const fn tri(i: usize) -> usize {
    i * (i + 1) / 2
}

/// Where `L` starts in [`Node::wl`] for `N` rates.
#[inline(always)]
const fn l_start<const N: usize>() -> usize {
    if N == 6 {
        0
    } else {
        18
    }
}

/// `L[i][j]` (`j ≤ i`) of the packed factorization.
#[inline(always)]
fn l_at<const N: usize>(wl: &[f64; 24], i: usize, j: usize) -> f64 {
    wl[l_start::<N>() + tri(i) + j]
}

/// `W[i][c]` (row `i`, column `c`) of the packed factorization.
#[inline(always)]
fn w_at<const N: usize>(wl: &[f64; 24], c: usize, i: usize) -> f64 {
    if N == 6 {
        if i >= c {
            wl[tri(i) + c]
        } else {
            0.0
        }
    } else {
        wl[6 * c + i]
    }
}

/// `L⁻¹ g` (forward substitution, `N × N` lower `L` of `wl`).
#[inline]
fn lsolve<const N: usize>(wl: &[f64; 24], g: &[f64; 6]) -> [f64; 6] {
    let mut y = [0.0; 6];
    for i in 0..N {
        let mut s = g[i];
        for k in 0..i {
            s -= l_at::<N>(wl, i, k) * y[k];
        }
        y[i] = s / l_at::<N>(wl, i, i);
    }
    y
}

/// `L⁻ᵀ g` (back substitution).
#[inline]
fn ltsolve<const N: usize>(wl: &[f64; 24], g: &[f64; 6]) -> [f64; 6] {
    let mut x = [0.0; 6];
    for i in (0..N).rev() {
        let mut s = g[i];
        for k in i + 1..N {
            s -= l_at::<N>(wl, k, i) * x[k];
        }
        x[i] = s / l_at::<N>(wl, i, i);
    }
    x
}

/// Dispatch on the number of rates (0..=3 for a tree joint, 6 for a free root) to a
/// const-generic kernel.
macro_rules! by_dof {
    ($n:expr, $f:ident ( $($a:expr),* )) => {
        match $n {
            0 => $f::<0>($($a),*),
            1 => $f::<1>($($a),*),
            2 => $f::<2>($($a),*),
            3 => $f::<3>($($a),*),
            6 => $f::<6>($($a),*),
            n => unreachable!("{n} rates: a tree joint has at most 3, a free root 6"),
        }
    };
}

/// Factor one position given its articulated inertia `ia`: `Node::wl`, and `P` into `p`.
/// Returns false when `D = SᵀIS` is not positive definite.
#[inline]
fn factor_n<const N: usize>(node: &mut Node, ia: &Matrix6<f64>, p: &mut Matrix6<f64>) -> bool {
    let s = node.kin.cols();
    // U = I S (columns; S = I₆ for a free root), then D = Sᵀ U factorized into l
    let mut u = [[0.0; 6]; 6];
    for c in 0..N {
        for i in 0..6 {
            u[c][i] = if N == 6 {
                ia[(i, c)]
            } else {
                let mut acc = 0.0;
                for j in 0..6 {
                    acc += ia[(i, j)] * s[c][j];
                }
                acc
            };
        }
    }
    let mut l = [[0.0; 6]; 6];
    for i in 0..N {
        for j in 0..=i {
            let mut d = 0.0;
            if N == 6 {
                d = u[j][i];
            } else {
                for r in 0..6 {
                    d += s[i][r] * u[j][r];
                }
            }
            for q in 0..j {
                d -= l[i][q] * l[j][q];
            }
            if i == j {
                if d.is_nan() || d <= 0.0 {
                    return false;
                }
                l[i][i] = d.sqrt();
            } else {
                l[i][j] = d / l[j][j];
            }
        }
    }
    // W = U L⁻ᵀ
    let mut w = [[0.0; 6]; 6];
    for c in 0..N {
        let inv = 1.0 / l[c][c];
        for i in 0..6 {
            let mut acc = u[c][i];
            for q in 0..c {
                acc -= w[q][i] * l[c][q];
            }
            w[c][i] = acc * inv;
        }
    }
    // P = I − W Wᵀ
    for j in 0..6 {
        for i in 0..6 {
            let mut acc = ia[(i, j)];
            for c in 0..N {
                acc -= w[c][i] * w[c][j];
            }
            p[(i, j)] = acc;
        }
    }
    let wl = &mut node.wl;
    if N != 6 {
        for c in 0..N {
            wl[6 * c..6 * c + 6].copy_from_slice(&w[c]);
        }
    }
    for i in 0..N {
        for j in 0..=i {
            wl[l_start::<N>() + tri(i) + j] = l[i][j];
        }
    }
    true
}

#[inline]
fn factor_node(node: &mut Node, ia: &Matrix6<f64>, p: &mut Matrix6<f64>) -> bool {
    by_dof!(node.kin.dof, factor_n(node, ia, p))
}

/// Backward step of the solve at one position: `g = b + Sᵀβ` (`b` in [`Node::x`] when
/// `with_b`), `h = L⁻¹g`, `z = β − W h` (into [`Node::f`]).
#[inline]
fn back_n<const N: usize>(node: &mut Node, beta: &Wrench, with_b: bool) {
    let s = node.kin.cols();
    let b6 = wrench6(beta);
    let mut g = [0.0; 6];
    for q in 0..N {
        let mut acc = if with_b { node.x[q] } else { 0.0 };
        for r in 0..6 {
            acc += s[q][r] * b6[r];
        }
        g[q] = acc;
    }
    let hh = lsolve::<N>(&node.wl, &g);
    let mut z = b6;
    for q in 0..N {
        for r in 0..6 {
            z[r] -= w_at::<N>(&node.wl, q, r) * hh[q];
        }
    }
    node.hh = hh;
    node.f = Wrench {
        f: Vector3::new(z[0], z[1], z[2]),
        t: Vector3::new(z[3], z[4], z[5]),
    };
}

#[inline]
fn back_node(node: &mut Node, beta: &Wrench, with_b: bool) {
    by_dof!(node.kin.dof, back_n(node, beta, with_b))
}

/// Forward step of the solve at one position: `x = L⁻ᵀ(h − Wᵀy)`, `acc = y + S x`.
#[inline]
fn fwd_n<const N: usize>(node: &mut Node, y: &Twist) {
    let y6 = twist6(y);
    let mut rhs = node.hh;
    for q in 0..N {
        let mut acc = 0.0;
        for r in 0..6 {
            acc += w_at::<N>(&node.wl, q, r) * y6[r];
        }
        rhs[q] -= acc;
    }
    let x = ltsolve::<N>(&node.wl, &rhs);
    let s = node.kin.cols();
    let mut a = y6;
    for q in 0..N {
        for r in 0..6 {
            a[r] += s[q][r] * x[q];
        }
    }
    node.x = x;
    node.acc = Twist {
        v: Vector3::new(a[0], a[1], a[2]),
        w: Vector3::new(a[3], a[4], a[5]),
    };
}

/// The forward step of the tree-exact solve at one position, given the transported
/// parent acceleration `y = X u_p`: `x = L⁻ᵀ(h − Wᵀy)`, `Node::acc = y + S x`.
#[inline]
pub fn fwd(node: &mut Node, y: &Twist) {
    by_dof!(node.kin.dof, fwd_n(node, y))
}

/// Whether [`Solver::backward_bias`] factors `AᵀMA`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Factor {
    /// Factor; keep `P` only where a branch starts (what the sweep needs).
    Make,
    /// Factor and keep `P` at every position, for a later [`Factor::Kept`].
    MakeAndKeep,
    /// Use the factorization and the `P`s the last [`Factor::MakeAndKeep`] left.
    Kept,
}

/// Which preconditioner [`Solver::pcg_reduced`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precond {
    /// None (plain CG).
    Identity,
    /// Block-Jacobi: the diagonal blocks `S_cᵀ I^C_c S_c` of `AᵀMA` (composite inertias).
    BlockJacobi,
    /// The tree-exact solve ([`Solver::solve`]).
    TreeExact,
}

/// Result of a PCG solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PcgStats {
    /// Iterations made.
    pub iterations: u32,
    /// Final residual norm relative to the right-hand side's.
    pub relative_residual: f64,
    /// Whether the tolerance was met.
    pub converged: bool,
}

/// The operator, preconditioner and observer of [`pcg`].
pub trait PcgOps {
    /// `out = A p`.
    fn apply(&mut self, p: &[f64], out: &mut [f64]);
    /// `z ≈ A⁻¹ r`.
    fn precond(&mut self, r: &[f64], z: &mut [f64]);
    /// Called after each update `x += α p`, right after [`PcgOps::apply`] computed `A p`
    /// (lets a caller accumulate quantities linear in `x`).
    fn step(&mut self, _alpha: f64) {}
}

/// Preconditioned conjugate gradients for an SPD operator (notes C §1.9, with the plus
/// sign of the Schur complement): solves `A x = b` from `x = 0`, stopping when
/// `|r|₂ ≤ rtol |b|₂` or `|r|_∞ ≤ atol`. `work` holds four vectors of `b`'s length.
pub fn pcg<O: PcgOps>(
    ops: &mut O,
    b: &[f64],
    x: &mut [f64],
    work: &mut [Vec<f64>; 4],
    rtol: f64,
    atol: f64,
    max_iter: u32,
) -> PcgStats {
    let n = b.len();
    let [r, z, p, q] = work;
    x.iter_mut().for_each(|v| *v = 0.0);
    r[..n].copy_from_slice(b);
    let bnorm = b.iter().map(|v| v * v).sum::<f64>().sqrt();
    let inf = |v: &[f64]| v.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    if bnorm == 0.0 || inf(&r[..n]) <= atol {
        return PcgStats {
            iterations: 0,
            relative_residual: 0.0,
            converged: true,
        };
    }
    ops.precond(&r[..n], &mut z[..n]);
    p[..n].copy_from_slice(&z[..n]);
    let mut rz: f64 = (0..n).map(|i| r[i] * z[i]).sum();
    let mut it = 0;
    loop {
        it += 1;
        ops.apply(&p[..n], &mut q[..n]);
        let pq: f64 = (0..n).map(|i| p[i] * q[i]).sum();
        if pq.is_nan() || pq <= 0.0 {
            let rn = r[..n].iter().map(|v| v * v).sum::<f64>().sqrt();
            return PcgStats {
                iterations: it,
                relative_residual: rn / bnorm,
                converged: false,
            };
        }
        let alpha = rz / pq;
        for i in 0..n {
            x[i] += alpha * p[i];
            r[i] -= alpha * q[i];
        }
        ops.step(alpha);
        let rn = r[..n].iter().map(|v| v * v).sum::<f64>().sqrt();
        if rn <= rtol * bnorm || inf(&r[..n]) <= atol {
            return PcgStats {
                iterations: it,
                relative_residual: rn / bnorm,
                converged: true,
            };
        }
        if it >= max_iter {
            return PcgStats {
                iterations: it,
                relative_residual: rn / bnorm,
                converged: false,
            };
        }
        ops.precond(&r[..n], &mut z[..n]);
        let rz_new: f64 = (0..n).map(|i| r[i] * z[i]).sum();
        let beta = rz_new / rz;
        rz = rz_new;
        for i in 0..n {
            p[i] = z[i] + beta * p[i];
        }
    }
}

/// The children visitor of [`Solver::up_handing`]: calls its argument with each child and
/// the matrix it hands over.
type Handing<'a> = dyn FnMut(&mut dyn FnMut(&Node, &Matrix6<f64>)) + 'a;

/// The recursions over a [`Tree`]; the per-position data lives in a `[Node]` the caller
/// owns (so an integrator can keep one per use).
pub struct Solver<'t> {
    /// The tree.
    pub tree: &'t Tree,
}

impl Solver<'_> {
    /// Leaf → root over the tree: at each position `f(node, children)` where the children
    /// (already processed) are visited by the callback's second argument.
    #[inline]
    fn up<F>(&self, nodes: &mut [Node], f: &F)
    where
        F: Fn(&mut Node, usize, &mut dyn FnMut(&mut dyn FnMut(&Node))) + Sync,
    {
        self.tree
            .sched
            .levels(nodes, true, &|start, br: &mut [Node], view| {
                for i in (0..br.len()).rev() {
                    let (head, tail) = br.split_at_mut(i + 1);
                    let node = &mut head[i];
                    let tail = &*tail;
                    let p = start + i;
                    let mut kids = |g: &mut dyn FnMut(&Node)| {
                        if !tail.is_empty() {
                            g(&tail[0]);
                        } else {
                            for &c in self.tree.children(p) {
                                g(view.get(c));
                            }
                        }
                    };
                    f(node, p, &mut kids);
                }
            });
    }

    /// Leaf → root over the tree for the sweeps that hand a `6 × 6` matrix to the parent
    /// (`P`, or the composite inertia): at each position `f(node, children, out)` where the
    /// children are visited with their matrices and `f` writes the position's own into
    /// `out`. Within a branch the matrix passes to the parent (the previous entry) in a
    /// local; only a branch's first position, whose parent lies in another branch, stores
    /// it in [`Node::pm`], so a step neither writes nor reads back 288 bytes per body for
    /// it (BENCHMARKS.md, "Natural partitioning: scaling"). With `keep_all` every position
    /// stores its matrix, for a later sweep that reuses them.
    #[inline]
    fn up_handing<F>(&self, nodes: &mut [Node], keep_all: bool, f: &F)
    where
        F: Fn(&mut Node, usize, &mut Handing<'_>, &mut Matrix6<f64>) + Sync,
    {
        self.tree
            .sched
            .levels(nodes, true, &|start, br: &mut [Node], view| {
                // the matrix of br[i + 1]
                let mut carry = Matrix6::zeros();
                for i in (0..br.len()).rev() {
                    let (head, tail) = br.split_at_mut(i + 1);
                    let node = &mut head[i];
                    let tail = &*tail;
                    let p = start + i;
                    let mut out = Matrix6::zeros();
                    {
                        let carry = &carry;
                        let mut kids = |g: &mut dyn FnMut(&Node, &Matrix6<f64>)| {
                            if !tail.is_empty() {
                                g(&tail[0], carry);
                            } else {
                                for &c in self.tree.children(p) {
                                    let n = view.get(c);
                                    g(n, &n.pm);
                                }
                            }
                        };
                        f(node, p, &mut kids, &mut out);
                    }
                    if i == 0 || keep_all {
                        node.pm = out;
                    }
                    if i > 0 {
                        carry = out;
                    }
                }
            });
    }

    /// Factor `AᵀMA` at the joint blocks `Node::kin` (leaf → root) and, when `with_f` or
    /// `with_b`, run the backward half of the solve in the same sweep. Returns the first
    /// position whose `D = SᵀIS` is not positive definite, if any.
    pub fn factor_backward(&self, nodes: &mut [Node], with_f: bool, with_b: bool) -> Option<usize> {
        let bad = std::sync::atomic::AtomicUsize::new(NONE);
        let solve = with_f || with_b;
        self.up_handing(nodes, false, &|node, p, kids, pm| {
            let mut ia = node.mass6();
            let mut beta = if with_f { node.f } else { Wrench::default() };
            kids(&mut |c: &Node, cp: &Matrix6<f64>| {
                ia += xtpx(&c.kin, cp);
                if solve {
                    add_wrench(&mut beta, &c.kin.transport_t(&c.f));
                }
            });
            if !factor_node(node, &ia, pm) {
                bad.fetch_min(p, std::sync::atomic::Ordering::Relaxed);
                return;
            }
            if solve {
                back_node(node, &beta, with_b);
            }
        });
        let b = bad.into_inner();
        (b != NONE).then_some(b)
    }

    /// Leaf → root, the backward half of the solve with a velocity-product term, optionally
    /// fused with the factorization (`factor`; else the existing one is used). At each
    /// position `pre(node, p)` first fills the node's inputs: its joint blocks if they
    /// change, the body force `Node::f` and the velocity-product acceleration `κ` of its
    /// joint in `Node::a0`. With `u̇_c = X u̇_p + κ_c + S x_c` (the accelerations, `Ȧq̇`
    /// included, in the same recursion: articulated-body style) a child hands its parent
    /// `z − P κ` instead of `z`; [`fwd`] with `y = X u̇_p + κ_c` then gives the total
    /// acceleration. Returns the first position whose `D = SᵀIS` is not positive
    /// definite, if any.
    ///
    /// `factor`: [`Factor::Make`] factors (and [`Factor::MakeAndKeep`] also stores `P` at
    /// every position, so that a later sweep can use [`Factor::Kept`]); [`Factor::Kept`]
    /// uses the factorization and the `P` of every position the last `MakeAndKeep` left.
    pub fn backward_bias<F>(&self, nodes: &mut [Node], factor: Factor, pre: &F) -> Option<usize>
    where
        F: Fn(&mut Node, usize) + Sync,
    {
        let bad = std::sync::atomic::AtomicUsize::new(NONE);
        let make = factor != Factor::Kept;
        let step = |node: &mut Node, p: usize, kids: &mut Handing<'_>, pm: &mut Matrix6<f64>| {
            pre(node, p);
            let mut ia = if make { node.mass6() } else { Matrix6::zeros() };
            let mut beta = node.f;
            kids(&mut |c: &Node, cp: &Matrix6<f64>| {
                if make {
                    ia += xtpx(&c.kin, cp);
                }
                add_wrench(&mut beta, &c.kin.transport_t(&c.f));
            });
            if make && !factor_node(node, &ia, pm) {
                bad.fetch_min(p, std::sync::atomic::Ordering::Relaxed);
                return;
            }
            back_node(node, &beta, false);
            // z − P κ for the parent
            let k6 = twist6(&node.a0);
            let pk = *pm * nalgebra::Vector6::from_column_slice(&k6);
            node.f.f -= Vector3::new(pk[0], pk[1], pk[2]);
            node.f.t -= Vector3::new(pk[3], pk[4], pk[5]);
        };
        match factor {
            Factor::Make => self.up_handing(nodes, false, &step),
            Factor::MakeAndKeep => self.up_handing(nodes, true, &step),
            Factor::Kept => self.up(nodes, &|node, p, kids| {
                let mut pm = node.pm;
                step(
                    node,
                    p,
                    &mut |g: &mut dyn FnMut(&Node, &Matrix6<f64>)| {
                        kids(&mut |c: &Node| g(c, &c.pm))
                    },
                    &mut pm,
                )
            }),
        }
        let b = bad.into_inner();
        (b != NONE).then_some(b)
    }

    /// Factor `AᵀMA` at `Node::kin` only.
    pub fn factor(&self, nodes: &mut [Node]) -> Option<usize> {
        self.factor_backward(nodes, false, false)
    }

    /// Backward half of the solve with an existing factorization (inputs `Node::f` if
    /// `with_f`, `Node::x` if `with_b`).
    pub fn backward_solve(&self, nodes: &mut [Node], with_f: bool, with_b: bool) {
        self.up(nodes, &|node, _, kids| {
            let mut beta = if with_f { node.f } else { Wrench::default() };
            kids(&mut |c: &Node| add_wrench(&mut beta, &c.kin.transport_t(&c.f)));
            back_node(node, &beta, with_b);
        });
    }

    /// Forward half of the solve: `Node::x` and `Node::acc = A x`.
    pub fn forward_solve(&self, nodes: &mut [Node]) {
        self.tree
            .sched
            .levels(nodes, false, &|start, br: &mut [Node], view| {
                for i in 0..br.len() {
                    let y = match view.parent(i, self.tree.links[start].parent, br) {
                        Some(p) => br[i].kin.transport(&p.acc),
                        None => Twist::default(),
                    };
                    fwd(&mut br[i], &y);
                }
            });
    }

    /// Solve `AᵀMA x = [b] + Aᵀ[f]` with the factorization of [`Solver::factor`]: the
    /// inputs are `Node::x` (if `with_b`) and `Node::f` (if `with_f`); the outputs
    /// `Node::x` and `Node::acc = (A x)`.
    pub fn solve(&self, nodes: &mut [Node], with_f: bool, with_b: bool) {
        self.backward_solve(nodes, with_f, with_b);
        self.forward_solve(nodes);
    }

    /// `Node::acc = A x` for `x` in `Node::x` (root → leaf).
    pub fn forward(&self, nodes: &mut [Node]) {
        self.tree
            .sched
            .levels(nodes, false, &|start, br: &mut [Node], view| {
                for i in 0..br.len() {
                    let y = match view.parent(i, self.tree.links[start].parent, br) {
                        Some(p) => br[i].kin.transport(&p.acc),
                        None => Twist::default(),
                    };
                    let node = &mut br[i];
                    let s = node.kin.s_mul(&node.x);
                    node.acc = Twist {
                        v: y.v + s.v,
                        w: y.w + s.w,
                    };
                }
            });
    }

    /// `Node::x = Aᵀ f` for the body forces in `Node::f` (leaf → root; `Node::f` then
    /// holds the subtree forces).
    pub fn backward(&self, nodes: &mut [Node]) {
        self.up(nodes, &|node, _, kids| {
            let mut tot = node.f;
            kids(&mut |c: &Node| add_wrench(&mut tot, &c.kin.transport_t(&c.f)));
            node.f = tot;
            let mut x = [0.0; 6];
            node.kin.s_t(&tot, &mut x);
            node.x = x;
        });
    }

    /// The operator `AᵀMA` matrix-free: `Node::x ← AᵀMA Node::x` (forward `A`, the
    /// constant body blocks `M_j`, backward `Aᵀ`).
    pub fn apply(&self, nodes: &mut [Node]) {
        self.forward(nodes);
        self.tree
            .sched
            .nodes(nodes, &|_, n: &mut Node| n.f = n.mass_mul(&n.acc));
        self.backward(nodes);
    }

    /// Gather `Node::x` into the flat coordinate vector `out`.
    pub fn gather_x(&self, nodes: &[Node], out: &mut [f64]) {
        for (p, l) in self.tree.links.iter().enumerate() {
            out[l.off..l.off + l.dof].copy_from_slice(&nodes[p].x[..l.dof]);
        }
    }

    /// Scatter the flat coordinate vector `v` into `Node::x` (the solution of a forward
    /// sweep, or the input `b` of a solve `with_b`).
    pub fn scatter(&self, nodes: &mut [Node], v: &[f64]) {
        for (p, l) in self.tree.links.iter().enumerate() {
            nodes[p].x[..l.dof].copy_from_slice(&v[l.off..l.off + l.dof]);
        }
    }

    /// Block-Jacobi preconditioner data: the Cholesky factors of `S_cᵀ I^C_c S_c` (composite
    /// inertias), stored in `Node::wl` (overwrites the factorization).
    pub fn factor_block_jacobi(&self, nodes: &mut [Node]) {
        self.up_handing(nodes, false, &|node, _, kids, out| {
            let mut ic = node.mass6();
            kids(&mut |c: &Node, cp: &Matrix6<f64>| ic += xtpx(&c.kin, cp));
            let mut p = Matrix6::zeros();
            let ok = factor_node(node, &ic, &mut p);
            debug_assert!(ok);
            // the composite inertia is handed up unchanged (no projection)
            *out = ic;
        });
    }

    /// Solve `AᵀMA x = b` by PCG with preconditioner `pc` (for measurements and tests;
    /// the integrator applies the tree-exact solve directly). `b` and `x` are flat
    /// coordinate vectors. Factorizes as needed.
    #[allow(clippy::too_many_arguments)]
    pub fn pcg_reduced(
        &self,
        nodes: &mut [Node],
        pc: Precond,
        b: &[f64],
        x: &mut [f64],
        rtol: f64,
        max_iter: u32,
    ) -> PcgStats {
        match pc {
            Precond::TreeExact => {
                let bad = self.factor(nodes);
                assert!(bad.is_none(), "AᵀMA not positive definite");
            }
            Precond::BlockJacobi => self.factor_block_jacobi(nodes),
            Precond::Identity => {}
        }
        let n = b.len();
        let mut work = [vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut ops = ReducedOps {
            solver: self,
            nodes,
            pc,
        };
        pcg(&mut ops, b, x, &mut work, rtol, 0.0, max_iter)
    }
}

/// [`PcgOps`] of `AᵀMA` on flat coordinate vectors.
struct ReducedOps<'s, 't, 'n> {
    solver: &'s Solver<'t>,
    nodes: &'n mut [Node],
    pc: Precond,
}

impl PcgOps for ReducedOps<'_, '_, '_> {
    fn apply(&mut self, p: &[f64], out: &mut [f64]) {
        self.solver.scatter(self.nodes, p);
        self.solver.apply(self.nodes);
        self.solver.gather_x(self.nodes, out);
    }

    fn precond(&mut self, r: &[f64], z: &mut [f64]) {
        let s = self.solver;
        match self.pc {
            Precond::Identity => z.copy_from_slice(r),
            Precond::BlockJacobi => {
                for (p, l) in s.tree.links.iter().enumerate() {
                    let mut g = [0.0; 6];
                    g[..l.dof].copy_from_slice(&r[l.off..l.off + l.dof]);
                    let lp = &self.nodes[p].wl;
                    let y = by_dof!(l.dof, lsolve(lp, &g));
                    let x = by_dof!(l.dof, ltsolve(lp, &y));
                    z[l.off..l.off + l.dof].copy_from_slice(&x[..l.dof]);
                }
            }
            Precond::TreeExact => {
                s.scatter(self.nodes, r);
                s.solve(self.nodes, false, true);
                s.gather_x(self.nodes, z);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The per-body working set stays small (one set of joint blocks, packed
    /// factorization): the sweeps of a step stream it (BENCHMARKS.md).
    #[test]
    fn node_is_compact() {
        let n = std::mem::size_of::<Node>();
        let k = std::mem::size_of::<TreeJointKin>();
        eprintln!("Node: {n} bytes (TreeJointKin {k})");
        assert!(n <= 1600, "Node is {n} bytes");
    }
}
