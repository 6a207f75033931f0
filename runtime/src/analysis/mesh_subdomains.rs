//! A system's meshes torn into subdomains for FETI (Farhat–Roux, shared/notes/E §2): the
//! data a FETI solver starts from, built once before a run.
//!
//! - **The cut.** The elements of every mesh are split into `p` parts by recursive
//!   coordinate bisection of their centroids ([`mesh_partition::bisect_centroids`], the
//!   partitioner of `mbdc check --partition`). Each part is a subdomain: its elements, the
//!   nodes they use, and its free dofs (three per node, less the layout's fixed and
//!   prescribed components), numbered locally in ascending global order.
//! - **Its stiffness.** `K_s` is assembled from its own elements only, with the same element
//!   kernel as the global stiffness ([`mesh_stiffness::element_stiffness`]); what sits on a node
//!   rather than on an element (foundation springs, the diagonal `c M` of an implicit
//!   method) is shared out among the subdomains that hold the node, each taking `1/μ` of it
//!   (μ the node's multiplicity), so that `Σ_s B_sᵀ K_s B_s` is the global matrix.
//! - **The multipliers** (notes E §2.3, signed form): one per pair of subdomains sharing a
//!   free dof, `+1` on the lower subdomain's copy and `−1` on the higher one's, so that
//!   `Σ_s B_s u_s = 0` is continuity. At a node shared by μ > 2 subdomains every pair gets
//!   one ("fully redundant" multipliers, notes E §5.5): `F` is then singular on the
//!   redundant combinations, on which conjugate gradients never move, and the
//!   displacements are unique. Subdomains touching only at a node still share it and get
//!   multipliers there (a node is the interface of a mesh of solids only when it is shared;
//!   the papers' zero-measure exemption concerns the continuous interface).
//! - **Rigid-body modes** (notes E §2.4, §2.9). A subdomain is floating when its stiffness
//!   has a kernel. The kernel is found from the geometry rather than from zero pivots (whose
//!   threshold would be a guess): per connected component of the subdomain, the six rigid
//!   motions about its centroid (rotations scaled by the component's size), less the
//!   combinations that move a constrained component, load a foundation spring or meet a
//!   positive diagonal term; what remains is checked against the stiffness (`‖K_s R_s‖`
//!   at round-off, else the subdomain has a mechanism and the solve is refused). The
//!   generalized inverse `K_s⁺` is the paper's `[K_pp⁻¹ 0; 0 0]` with the redundant set
//!   chosen as the `k_s` dofs that pin the modes best (pivoted Gram–Schmidt on the rows of
//!   `R_s`): `R_s` restricted to them is invertible, so `K_pp` is.
//!
//! Knows the layout and the element kernels; nothing of a solver, an integrator or a run.

use super::mesh_model::MeshError;
use super::mesh_partition::bisect_centroids;
use super::mesh_stiffness;
use crate::contract::mesh_layout::MeshLayout;
use crate::linalg::{ElementDofs, SymmetricAssembly};
use nalgebra::{DMatrix, DVector};

/// Relative size below which an eigenvalue of the constraint Gram matrix counts as zero:
/// the combination of rigid motions it belongs to meets no support.
const KERNEL_TOL: f64 = 1e-12;
/// Largest `‖K_s r‖ / (max |K_s,ii| ‖r‖)` a rigid mode `r` may have.
const MODE_CHECK_TOL: f64 = 1e-8;

/// One subdomain: its elements, nodes, free dofs, stiffness and rigid-body modes.
#[derive(Clone, Debug)]
pub struct Subdomain {
    /// Its elements, as (block, element in the block).
    pub elements: Vec<(u32, u32)>,
    /// The global nodes its elements use, ascending.
    pub nodes: Vec<u32>,
    /// Per local free dof (ascending global dof), its index among the global free dofs.
    pub free: Vec<u32>,
    /// Per local free dof, the multiplicity of its node (how many subdomains hold it).
    pub multiplicity: Vec<u8>,
    /// The local pattern (over `3 × nodes` dofs; constrained ones eliminated).
    pub assembly: SymmetricAssembly,
    /// `K_s` over the local free dofs (upper triangle, aligned with `assembly`), with the
    /// shared node terms.
    pub k: Vec<f64>,
    /// Number of rigid-body modes (0: the subdomain is held).
    pub modes: usize,
    /// The modes, column after column, each over the local free dofs.
    pub r: Vec<f64>,
    /// The local free dofs pinned to define `K_s⁺` (as many as modes).
    pub pinned: Vec<u32>,
    /// Connected components of its elements.
    pub components: usize,
}

/// One Lagrange multiplier: dof `local_a` of subdomain `a` equals dof `local_b` of
/// subdomain `b` (`a < b`; `+1` on `a`, `−1` on `b`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Multiplier {
    /// Lower subdomain.
    pub a: u32,
    /// Its local free dof.
    pub local_a: u32,
    /// Higher subdomain.
    pub b: u32,
    /// Its local free dof.
    pub local_b: u32,
    /// Multiplicity of the node (subdomains that hold it).
    pub multiplicity: u8,
}

/// The meshes torn into subdomains.
#[derive(Clone, Debug)]
pub struct Tearing {
    /// The subdomains, in part order.
    pub subdomains: Vec<Subdomain>,
    /// The interface multipliers, ordered by global dof, then pair.
    pub multipliers: Vec<Multiplier>,
    /// Number of global free dofs.
    pub free_dofs: usize,
}

impl Tearing {
    /// Number of floating subdomains.
    pub fn floating(&self) -> usize {
        self.subdomains.iter().filter(|s| s.modes > 0).count()
    }

    /// Total number of rigid-body modes (the size of the coarse problem).
    pub fn modes(&self) -> usize {
        self.subdomains.iter().map(|s| s.modes).sum()
    }
}

/// Tear the meshes of `l` into `parts` subdomains. `global` is the global stiffness's
/// pattern (for the free numbering); `diagonal`, when given, is a term added to the
/// diagonal of every global free dof (`c M` of an implicit method), shared out like the
/// foundation springs.
///
/// # Errors
/// More parts than elements, a non-finite element stiffness, a subdomain whose stiffness
/// has a kernel other than rigid motions (a mechanism), named with its place.
pub fn tear(
    l: &MeshLayout,
    global: &SymmetricAssembly,
    diagonal: Option<&[f64]>,
    parts: usize,
) -> Result<Tearing, MeshError> {
    let first_mesh = || {
        l.blocks
            .first()
            .map_or_else(String::new, |b| b.name.clone())
    };
    let ne = l.elements();
    if parts == 0 || parts > ne {
        return Err(MeshError {
            mesh: first_mesh(),
            reason: format!(
                "the meshes have {ne} elements: they cannot be torn into {parts} subdomains"
            ),
        });
    }
    // Element centroids, in global element order.
    let mut centroids = Vec::with_capacity(ne);
    let mut owner = Vec::with_capacity(ne);
    for (bi, b) in l.blocks.iter().enumerate() {
        for e in 0..b.elements() {
            let nodes = b.element_nodes(e);
            let mut c = [0.0; 3];
            for &n in nodes {
                for (ck, xk) in c.iter_mut().zip(l.x0[n as usize]) {
                    *ck += xk / nodes.len() as f64;
                }
            }
            centroids.push(c);
            owner.push((bi as u32, e as u32));
        }
    }
    let mut part = bisect_centroids(&centroids, parts);
    face_connect(l, &owner, &mut part);
    tear_parts(l, global, diagonal, &part, parts)
}

/// Tear the meshes of `l` into the given parts (`part[e]` for global element `e`, in
/// `0..parts`, every part non-empty): see [`tear`].
///
/// # Errors
/// What [`tear`] refuses, and an empty part.
pub fn tear_parts(
    l: &MeshLayout,
    global: &SymmetricAssembly,
    diagonal: Option<&[f64]>,
    part: &[u32],
    parts: usize,
) -> Result<Tearing, MeshError> {
    let mut owner = Vec::with_capacity(l.elements());
    for (bi, b) in l.blocks.iter().enumerate() {
        for e in 0..b.elements() {
            owner.push((bi as u32, e as u32));
        }
    }
    let mut elements: Vec<Vec<(u32, u32)>> = vec![Vec::new(); parts];
    for (ge, &p) in part.iter().enumerate() {
        elements[p as usize].push(owner[ge]);
    }
    // Which subdomains hold each node (ascending, deduplicated).
    let mut holders: Vec<Vec<u32>> = vec![Vec::new(); l.nodes()];
    for (s, els) in elements.iter().enumerate() {
        for &(bi, e) in els {
            for &n in l.blocks[bi as usize].element_nodes(e as usize) {
                let h = &mut holders[n as usize];
                if h.last() != Some(&(s as u32)) {
                    h.push(s as u32);
                }
            }
        }
    }
    if let Some(empty) = elements.iter().position(Vec::is_empty) {
        return Err(MeshError {
            mesh: l
                .blocks
                .first()
                .map_or_else(String::new, |b| b.name.clone()),
            reason: format!("subdomain {empty} has no element"),
        });
    }
    let mut subdomains = Vec::with_capacity(parts);
    for (s, els) in elements.into_iter().enumerate() {
        subdomains.push(subdomain(l, global, diagonal, &holders, s as u32, els)?);
    }
    // Multipliers: per shared free dof, every pair of holders.
    let mut multipliers = Vec::new();
    for (n, h) in holders.iter().enumerate() {
        if h.len() < 2 {
            continue;
        }
        for k in 0..3 {
            let g = 3 * n + k;
            if global.free_index(g).is_none() {
                continue;
            }
            let local = |s: u32| -> u32 {
                let sd = &subdomains[s as usize];
                let ln = sd.nodes.binary_search(&(n as u32)).unwrap_or(0);
                local_free(&sd.assembly, 3 * ln + k).unwrap_or(0) as u32
            };
            for (i, &a) in h.iter().enumerate() {
                for &b in &h[i + 1..] {
                    multipliers.push(Multiplier {
                        a,
                        local_a: local(a),
                        b,
                        local_b: local(b),
                        multiplicity: h.len().min(255) as u8,
                    });
                }
            }
        }
    }
    Ok(Tearing {
        subdomains,
        multipliers,
        free_dofs: global.free().len(),
    })
}

/// Make every part face-connected: a piece of a part that touches the rest of it only at
/// nodes or edges (recursive bisection leaves such pieces on the staircase boundaries of
/// unstructured or distorted meshes) would hinge there, a zero-energy motion that is not
/// rigid. Each such piece moves to the neighbouring part with which it shares the most
/// faces (edges of 2-D elements); a piece that shares a face with no other part stays (it
/// is a separate piece of the mesh). Repeated until no piece moves (at most 16 rounds).
fn face_connect(l: &MeshLayout, owner: &[(u32, u32)], part: &mut [u32]) {
    use std::collections::HashMap;
    // Face adjacency of the elements (global element numbers).
    let mut faces: HashMap<[u32; 4], Vec<u32>> = HashMap::new();
    for (ge, &(bi, e)) in owner.iter().enumerate() {
        let b = &l.blocks[bi as usize];
        let nodes = b.element_nodes(e as usize);
        for f in b.kind.faces() {
            let mut key = [u32::MAX; 4];
            for (k, &a) in f.iter().enumerate().take(4) {
                key[k] = nodes[a];
            }
            key.sort_unstable();
            faces.entry(key).or_default().push(ge as u32);
        }
    }
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); owner.len()];
    let mut keys: Vec<&[u32; 4]> = faces.keys().collect();
    keys.sort_unstable();
    for k in keys {
        let els = &faces[k];
        for (i, &a) in els.iter().enumerate() {
            for &b in &els[i + 1..] {
                adj[a as usize].push(b);
                adj[b as usize].push(a);
            }
        }
    }
    let parts = part.iter().map(|&p| p as usize + 1).max().unwrap_or(0);
    for _ in 0..16 {
        let mut moved = false;
        let mut comp = vec![u32::MAX; owner.len()];
        let mut pieces: Vec<Vec<Vec<u32>>> = vec![Vec::new(); parts];
        for start in 0..owner.len() {
            if comp[start] != u32::MAX {
                continue;
            }
            let p = part[start];
            let id = pieces[p as usize].len() as u32;
            let mut piece = vec![start as u32];
            comp[start] = id;
            let mut i = 0;
            while i < piece.len() {
                let e = piece[i] as usize;
                for &n in &adj[e] {
                    if part[n as usize] == p && comp[n as usize] == u32::MAX {
                        comp[n as usize] = id;
                        piece.push(n);
                    }
                }
                i += 1;
            }
            pieces[p as usize].push(piece);
        }
        for (p, ps) in pieces.iter().enumerate() {
            if ps.len() < 2 {
                continue;
            }
            let largest = (0..ps.len())
                .max_by(|&a, &b| ps[a].len().cmp(&ps[b].len()).then(b.cmp(&a)))
                .unwrap_or(0);
            for (k, piece) in ps.iter().enumerate() {
                if k == largest {
                    continue;
                }
                let mut shared = vec![0usize; parts];
                for &e in piece {
                    for &n in &adj[e as usize] {
                        let q = part[n as usize] as usize;
                        if q != p {
                            shared[q] += 1;
                        }
                    }
                }
                let best = (0..parts).max_by(|&a, &b| shared[a].cmp(&shared[b]).then(b.cmp(&a)));
                if let Some(q) = best.filter(|&q| shared[q] > 0) {
                    for &e in piece {
                        part[e as usize] = q as u32;
                    }
                    moved = true;
                }
            }
        }
        if !moved {
            break;
        }
    }
}

/// The local free index of local dof `d`.
fn local_free(a: &SymmetricAssembly, d: usize) -> Option<usize> {
    a.free_index(d)
}

/// Build subdomain `s` from its elements.
fn subdomain(
    l: &MeshLayout,
    global: &SymmetricAssembly,
    diagonal: Option<&[f64]>,
    holders: &[Vec<u32>],
    s: u32,
    elements: Vec<(u32, u32)>,
) -> Result<Subdomain, MeshError> {
    let mut nodes: Vec<u32> = elements
        .iter()
        .flat_map(|&(bi, e)| l.blocks[bi as usize].element_nodes(e as usize).to_vec())
        .collect();
    nodes.sort_unstable();
    nodes.dedup();
    let local_node = |n: u32| nodes.binary_search(&n).unwrap_or(0) as u32;
    let constrained: Vec<bool> = nodes
        .iter()
        .flat_map(|&n| l.constrained[n as usize])
        .collect();
    // Element dof lists per block, and the springs on this subdomain's nodes.
    let mut lists: Vec<(Vec<u32>, usize)> = l
        .blocks
        .iter()
        .map(|b| (Vec::new(), b.kind.nodes() * b.kind.dim()))
        .collect();
    let mut block_elements: Vec<Vec<u32>> = vec![Vec::new(); l.blocks.len()];
    for &(bi, e) in &elements {
        let b = &l.blocks[bi as usize];
        let d = b.kind.dim() as u32;
        for &n in b.element_nodes(e as usize) {
            let ln = local_node(n);
            lists[bi as usize].0.extend((0..d).map(|i| 3 * ln + i));
        }
        block_elements[bi as usize].push(e);
    }
    let springs: Vec<usize> = (0..l.foundation.len())
        .filter(|&i| nodes.binary_search(&l.foundation[i].node).is_ok())
        .collect();
    lists.push((
        springs
            .iter()
            .flat_map(|&i| {
                let ln = local_node(l.foundation[i].node);
                (0..3).map(move |k| 3 * ln + k)
            })
            .collect(),
        3,
    ));
    let blocks: Vec<ElementDofs<'_>> = lists
        .iter()
        .map(|(dofs, per_element)| ElementDofs {
            dofs,
            per_element: *per_element,
        })
        .collect();
    let mesh_name = |bi: usize| {
        l.blocks
            .get(bi)
            .map_or_else(String::new, |b| b.name.clone())
    };
    let assembly =
        SymmetricAssembly::new(3 * nodes.len(), &constrained, &blocks).map_err(|e| MeshError {
            mesh: mesh_name(0),
            reason: format!("subdomain {s}: the stiffness pattern: {e}"),
        })?;
    let mut k = vec![0.0; assembly.nnz_free()];
    let mut kc = vec![0.0; assembly.nnz_constrained()];
    for (bi, els) in block_elements.iter().enumerate() {
        for (le, &e) in els.iter().enumerate() {
            let ke = mesh_stiffness::element_stiffness(l, &l.blocks[bi], e as usize)?;
            assembly.add_element(bi, le, |r, c| ke[r][c], &mut k, &mut kc);
        }
    }
    let mult = |n: u32| holders[n as usize].len().max(1) as f64;
    let fb = l.blocks.len();
    for (i, &si) in springs.iter().enumerate() {
        let sp = &l.foundation[si];
        let w = sp.k / mult(sp.node);
        assembly.add_element(fb, i, |r, c| w * sp.n[r] * sp.n[c], &mut k, &mut kc);
    }
    // Local free dofs → global free index, multiplicity; the shared diagonal.
    let nf = assembly.free().len();
    let mut free = Vec::with_capacity(nf);
    let mut multiplicity = Vec::with_capacity(nf);
    for (j, &d) in assembly.free().iter().enumerate() {
        let n = nodes[d as usize / 3];
        let g = 3 * n as usize + d as usize % 3;
        let gf = global.free_index(g).unwrap_or(0);
        free.push(gf as u32);
        multiplicity.push(holders[n as usize].len().min(255) as u8);
        if let Some(diag) = diagonal {
            k[assembly.diagonal(j)] += diag[gf] / mult(n);
        }
    }
    let mut sd = Subdomain {
        elements,
        nodes,
        free,
        multiplicity,
        assembly,
        k,
        modes: 0,
        r: Vec::new(),
        pinned: Vec::new(),
        components: 0,
    };
    rigid_modes(l, diagonal, &springs, &mut sd).map_err(|reason| MeshError {
        mesh: mesh_name(sd.elements.first().map_or(0, |&(bi, _)| bi as usize)),
        reason: format!("subdomain {s}: {reason}"),
    })?;
    Ok(sd)
}

/// Eigenvalues and eigenvectors of a small symmetric matrix by cyclic Jacobi rotations
/// (robust for the repeated and zero eigenvalues that rigid-mode Gram matrices have, where
/// nalgebra 0.33's `SymmetricEigen` was measured to return a wrong basis).
struct Eigen {
    eigenvalues: DVector<f64>,
    eigenvectors: DMatrix<f64>,
}

fn jacobi_eigen(mut a: DMatrix<f64>) -> Eigen {
    let n = a.nrows();
    let mut v = DMatrix::<f64>::identity(n, n);
    for _sweep in 0..64 {
        let mut off = 0.0;
        let mut diag = 0.0;
        for p in 0..n {
            diag += a[(p, p)] * a[(p, p)];
            for q in p + 1..n {
                off += a[(p, q)] * a[(p, q)];
            }
        }
        if off <= 1e-32 * diag || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[(p, q)];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[(q, q)] - a[(p, p)]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[(k, p)], a[(k, q)]);
                    a[(k, p)] = c * akp - s * akq;
                    a[(k, q)] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[(p, k)], a[(q, k)]);
                    a[(p, k)] = c * apk - s * aqk;
                    a[(q, k)] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[(k, p)], v[(k, q)]);
                    v[(k, p)] = c * vkp - s * vkq;
                    v[(k, q)] = s * vkp + c * vkq;
                }
            }
        }
    }
    Eigen {
        eigenvalues: DVector::from_fn(n, |i, _| a[(i, i)]),
        eigenvectors: v,
    }
}

/// Find the rigid-body modes of `sd` and the dofs that pin them (see the module doc).
fn rigid_modes(
    l: &MeshLayout,
    diagonal: Option<&[f64]>,
    springs: &[usize],
    sd: &mut Subdomain,
) -> Result<(), String> {
    let nn = sd.nodes.len();
    // Connected components of the elements (union-find over local nodes).
    let mut parent: Vec<u32> = (0..nn as u32).collect();
    fn find(p: &mut [u32], mut i: u32) -> u32 {
        while p[i as usize] != i {
            p[i as usize] = p[p[i as usize] as usize];
            i = p[i as usize];
        }
        i
    }
    for &(bi, e) in &sd.elements {
        let en = l.blocks[bi as usize].element_nodes(e as usize);
        let r0 = find(
            &mut parent,
            sd.nodes.binary_search(&en[0]).unwrap_or(0) as u32,
        );
        for &n in &en[1..] {
            let ri = find(&mut parent, sd.nodes.binary_search(&n).unwrap_or(0) as u32);
            if ri != r0 {
                parent[ri as usize] = r0;
            }
        }
    }
    let mut comp_of = vec![u32::MAX; nn];
    let mut roots: Vec<u32> = Vec::new();
    for (i, ci) in comp_of.iter_mut().enumerate() {
        let r = find(&mut parent, i as u32);
        let c = match roots.iter().position(|&x| x == r) {
            Some(c) => c,
            None => {
                roots.push(r);
                roots.len() - 1
            }
        };
        *ci = c as u32;
    }
    sd.components = roots.len();
    let asm = &sd.assembly;
    let nf = asm.free().len();
    let mut spring_at = vec![Vec::new(); nn];
    for &si in springs {
        let sp = &l.foundation[si];
        if let Ok(ln) = sd.nodes.binary_search(&sp.node) {
            spring_at[ln].push(sp.n);
        }
    }
    let mut modes: Vec<Vec<f64>> = Vec::new();
    for c in 0..roots.len() as u32 {
        let members: Vec<usize> = (0..nn).filter(|&i| comp_of[i] == c).collect();
        let mut xc = [0.0; 3];
        for &i in &members {
            for (a, x) in xc.iter_mut().zip(l.x0[sd.nodes[i] as usize]) {
                *a += x / members.len() as f64;
            }
        }
        let mut size: f64 = 0.0;
        for &i in &members {
            let x = l.x0[sd.nodes[i] as usize];
            size = size.max(
                ((x[0] - xc[0]).powi(2) + (x[1] - xc[1]).powi(2) + (x[2] - xc[2]).powi(2)).sqrt(),
            );
        }
        let size = if size > 0.0 { size } else { 1.0 };
        // The six rigid motions at local node i, component k.
        let motion = |i: usize| -> [[f64; 6]; 3] {
            let x = l.x0[sd.nodes[i] as usize];
            let d = [
                (x[0] - xc[0]) / size,
                (x[1] - xc[1]) / size,
                (x[2] - xc[2]) / size,
            ];
            // e_m × d for m = x, y, z
            [
                [1.0, 0.0, 0.0, 0.0, d[2], -d[1]],
                [0.0, 1.0, 0.0, -d[2], 0.0, d[0]],
                [0.0, 0.0, 1.0, d[1], -d[0], 0.0],
            ]
        };
        let mut phi = DMatrix::<f64>::zeros(6, 6);
        let mut cons = DMatrix::<f64>::zeros(6, 6);
        let add_row = |m: &mut DMatrix<f64>, row: &[f64; 6]| {
            for p in 0..6 {
                for q in 0..6 {
                    m[(p, q)] += row[p] * row[q];
                }
            }
        };
        for &i in &members {
            let rm = motion(i);
            for (k, row) in rm.iter().enumerate() {
                add_row(&mut phi, row);
                let d = 3 * i + k;
                let held = match asm.free_index(d) {
                    None => true,
                    Some(j) => diagonal.is_some_and(|dg| dg[sd.free[j] as usize] > 0.0),
                };
                if held {
                    add_row(&mut cons, row);
                }
            }
            for n in &spring_at[i] {
                let mut row = [0.0; 6];
                for (k, r) in rm.iter().enumerate() {
                    for p in 0..6 {
                        row[p] += n[k] * r[p];
                    }
                }
                add_row(&mut cons, &row);
            }
        }
        // The motions that are displacements at all (a straight bar has no rotation about
        // itself), then those among them that nothing holds.
        let e = jacobi_eigen(phi);
        let top = e.eigenvalues.iter().cloned().fold(0.0, f64::max);
        let keep: Vec<usize> = (0..6)
            .filter(|&i| e.eigenvalues[i] > KERNEL_TOL * top)
            .collect();
        let v = DMatrix::from_fn(6, keep.len(), |p, q| {
            e.eigenvectors[(p, keep[q])] / e.eigenvalues[keep[q]].sqrt()
        });
        let a = v.transpose() * &cons * &v;
        let ea = jacobi_eigen(a);
        let scale = ea.eigenvalues.iter().cloned().fold(1.0, f64::max);
        for q in 0..keep.len() {
            if ea.eigenvalues[q] > KERNEL_TOL * scale {
                continue;
            }
            let coef = &v * ea.eigenvectors.column(q);
            let mut col = vec![0.0; nf];
            for &i in &members {
                let rm = motion(i);
                for (k, row) in rm.iter().enumerate() {
                    if let Some(j) = asm.free_index(3 * i + k) {
                        col[j] = (0..6).map(|p| row[p] * coef[p]).sum();
                    }
                }
            }
            modes.push(col);
        }
    }
    // Orthonormalize the modes (they have disjoint supports across components and are
    // Φ-orthonormal within one; make them Euclidean-orthonormal for a well-conditioned
    // coarse problem).
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for mut m in modes {
        for b in &basis {
            let d: f64 = m.iter().zip(b).map(|(x, y)| x * y).sum();
            m.iter_mut().zip(b).for_each(|(x, y)| *x -= d * y);
        }
        let norm = m.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm > 1e-8 {
            m.iter_mut().for_each(|x| *x /= norm);
            basis.push(m);
        }
    }
    // Check K r ≈ 0 for each.
    let kmax = (0..nf)
        .map(|j| sd.k[asm.diagonal(j)].abs())
        .fold(0.0, f64::max);
    let mut kr = vec![0.0; nf];
    for m in &basis {
        asm.mul_free(&sd.k, m, &mut kr);
        let res = kr.iter().map(|x| x * x).sum::<f64>().sqrt();
        if res.is_nan() || res > MODE_CHECK_TOL * kmax {
            return Err(format!(
                "a rigid-body motion of the subdomain strains it (‖K r‖/‖K‖ = {:.1e}): its stiffness does not come from solid elements alone",
                res / kmax.max(f64::MIN_POSITIVE)
            ));
        }
    }
    // Pin the dofs that hold the modes best: pivoted Gram–Schmidt on the rows of R.
    let nm = basis.len();
    let mut rows: Vec<f64> = vec![0.0; nf * nm];
    for (q, m) in basis.iter().enumerate() {
        for j in 0..nf {
            rows[j * nm + q] = m[j];
        }
    }
    let mut pinned = Vec::with_capacity(nm);
    for _ in 0..nm {
        let (mut best, mut bn) = (0, -1.0);
        for j in 0..nf {
            if pinned.contains(&(j as u32)) {
                continue;
            }
            let n2: f64 = rows[j * nm..(j + 1) * nm].iter().map(|x| x * x).sum();
            if n2 > bn {
                best = j;
                bn = n2;
            }
        }
        if bn <= 0.0 {
            return Err("its rigid-body modes cannot be pinned by its dofs".into());
        }
        let q: Vec<f64> = rows[best * nm..(best + 1) * nm]
            .iter()
            .map(|x| x / bn.sqrt())
            .collect();
        for j in 0..nf {
            let row = &mut rows[j * nm..(j + 1) * nm];
            let d: f64 = row.iter().zip(&q).map(|(x, y)| x * y).sum();
            row.iter_mut().zip(&q).for_each(|(x, y)| *x -= d * y);
        }
        pinned.push(best as u32);
    }
    pinned.sort_unstable();
    sd.modes = nm;
    sd.r = basis.into_iter().flatten().collect();
    sd.pinned = pinned;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Jacobi's eigenpairs of a matrix with a repeated zero eigenvalue: `A V = V Λ`,
    /// `VᵀV = I` to round-off.
    #[test]
    fn jacobi_eigen_of_a_degenerate_gram_matrix() {
        // Rank 3 in 6: three unit rows, a combination, zeros.
        let rows = DMatrix::from_row_slice(
            4,
            6,
            &[
                1.0, 0.0, 0.0, 0.0, 0.3, -0.2, //
                0.0, 0.0, 1.0, 0.4, 0.0, 0.0, //
                0.0, 0.0, 0.0, 1.0, 0.0, 0.5, //
                1.0, 0.0, 1.0, 1.4, 0.3, 0.3,
            ],
        );
        let a = rows.transpose() * &rows;
        let e = jacobi_eigen(a.clone());
        let v = &e.eigenvectors;
        let lam = DMatrix::from_diagonal(&e.eigenvalues);
        assert!((&a * v - v * lam).norm() < 1e-13 * a.norm());
        assert!((v.transpose() * v - DMatrix::<f64>::identity(6, 6)).norm() < 1e-13);
        let zeros = e.eigenvalues.iter().filter(|x| x.abs() < 1e-12).count();
        assert_eq!(zeros, 3);
    }
}
