//! A mesh split into `p` subdomains, and the partition metrics of the Connection Machine
//! papers (shared/notes/D_parallel_fe_io.md §6.4): what `mbdc check --partition P` prints,
//! and what a domain decomposition (FETI, MPI ranks) starts from.
//!
//! **The partitioner** is recursive coordinate bisection (RCB) of the element centroids:
//! a set of elements to be split into `p` parts is cut across the longest side of its
//! centroids' bounding box, at the element count that gives the two sides `⌊p/2⌋` and
//! `⌈p/2⌉` parts in proportion, and each side is split again. It is pure Rust and
//! deterministic (ties in the sort are broken by the other coordinates, then by element
//! number), balances the parts to one element (`n·k/p` rounded at every cut), costs
//! `O(n log n log p)`, and gives compact parts whose interfaces are planes on structured
//! meshes — on the papers' 16 × 16 grid into 16 parts it finds their "D2" decomposition,
//! the interface-minimizing one (93 interface nodes, against 255 for strips). A graph
//! partitioner (METIS's multilevel bisection) would cut fewer nodes on irregular meshes
//! whose thin features do not follow the coordinate axes; RCB needs nothing beyond
//! crates.io and no graph, and its cuts are what the measured mesh scenes need. The choice is
//! recorded in docs/methods.md.
//!
//! **The metrics** (per part, and their extremes): the elements, the interface nodes (nodes
//! of its elements that elements of another part also use), the neighbouring parts (parts
//! sharing at least one node with it: a message partner; their largest number is the
//! papers' communication "bandwidth"), the elements on its periphery (elements with a node
//! on an interface), and over the mesh the largest incidence (how many parts share one node)
//! and `P_cm = d × Σ incidence` over the interface nodes (`d` the degrees of freedom per
//! node: the values exchanged per interface sum).
//!
//! Knows only the scene's meshes (nodes and elements): no layout, no kernel, no integrator.

use crate::contract::scene::{Mesh, Vec3};

/// Why a mesh cannot be split as asked.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PartitionError {
    /// Zero parts were asked for.
    #[error("a partition needs at least 1 part")]
    NoParts,
    /// More parts than elements.
    #[error("mesh '{mesh}' has {elements} elements: it cannot be split into {parts} parts")]
    TooManyParts {
        /// The mesh.
        mesh: String,
        /// Its elements.
        elements: usize,
        /// The parts asked for.
        parts: usize,
    },
}

/// The part of every element.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Partition {
    /// Number of parts.
    pub parts: usize,
    /// Per element, its part (`0..parts`).
    pub element_part: Vec<u32>,
}

/// Split the elements of `mesh` into `parts` parts by recursive coordinate bisection of
/// their centroids (see the module doc).
///
/// # Errors
/// No parts, or more parts than elements.
pub fn bisect(mesh: &Mesh, parts: usize) -> Result<Partition, PartitionError> {
    if parts == 0 {
        return Err(PartitionError::NoParts);
    }
    if parts > mesh.elements.len() {
        return Err(PartitionError::TooManyParts {
            mesh: mesh.name.clone(),
            elements: mesh.elements.len(),
            parts,
        });
    }
    let centroids: Vec<Vec3> = mesh
        .elements
        .iter()
        .map(|e| {
            let mut c = [0.0; 3];
            for &n in e {
                for (ci, xi) in c.iter_mut().zip(mesh.nodes[n]) {
                    *ci += xi;
                }
            }
            c.map(|v| v / e.len().max(1) as f64)
        })
        .collect();
    Ok(Partition {
        parts,
        element_part: bisect_centroids(&centroids, parts),
    })
}

/// The part (`0..parts`) of every point of `centroids` by recursive coordinate bisection
/// (see the module doc). `parts` must lie in `1..=centroids.len()` (checked by the
/// callers, which know what to name in the error); outside it every point gets part 0.
pub fn bisect_centroids(centroids: &[Vec3], parts: usize) -> Vec<u32> {
    let mut element_part = vec![0u32; centroids.len()];
    if parts == 0 || parts > centroids.len() {
        return element_part;
    }
    let mut ids: Vec<u32> = (0..centroids.len() as u32).collect();
    split(centroids, &mut ids, 0, parts, &mut element_part);
    element_part
}

/// Give the elements `ids` the parts `first..first + parts`.
fn split(c: &[Vec3], ids: &mut [u32], first: usize, parts: usize, out: &mut [u32]) {
    if parts == 1 {
        for &e in ids.iter() {
            out[e as usize] = first as u32;
        }
        return;
    }
    // The longest side of the centroids' box (the first of equal sides).
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for &e in ids.iter() {
        for k in 0..3 {
            lo[k] = lo[k].min(c[e as usize][k]);
            hi[k] = hi[k].max(c[e as usize][k]);
        }
    }
    let mut axis = 0;
    for k in 1..3 {
        if hi[k] - lo[k] > hi[axis] - lo[axis] {
            axis = k;
        }
    }
    let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
    ids.sort_unstable_by(|&p, &q| {
        let (x, y) = (c[p as usize], c[q as usize]);
        x[axis]
            .total_cmp(&y[axis])
            .then(x[a1].total_cmp(&y[a1]))
            .then(x[a2].total_cmp(&y[a2]))
            .then(p.cmp(&q))
    });
    let left = parts / 2;
    // n·left/parts, rounded to nearest: each side gets its share to one element
    let cut = (ids.len() * left * 2 + parts) / (2 * parts);
    let (l, r) = ids.split_at_mut(cut);
    split(c, l, first, left, out);
    split(c, r, first + left, parts - left, out);
}

/// The partition metrics of notes D §6.4 (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct PartitionMetrics {
    /// Per part: its elements.
    pub elements: Vec<usize>,
    /// Per part: its interface nodes (its nodes that another part also uses).
    pub interface_nodes: Vec<usize>,
    /// Nodes shared by two or more parts, over the mesh.
    pub interface_total: usize,
    /// Nodes of the mesh used by some element.
    pub nodes: usize,
    /// Per part: the parts sharing at least one node with it.
    pub neighbours: Vec<usize>,
    /// Per part: its elements with a node on an interface.
    pub periphery: Vec<usize>,
    /// The most parts sharing one node.
    pub max_incidence: usize,
    /// `Σ` over the interface nodes of the parts sharing each.
    pub incidence_sum: usize,
    /// Degrees of freedom per node (2 for plane elements, 3 otherwise).
    pub dofs_per_node: usize,
}

impl PartitionMetrics {
    /// The metrics of `partition` on `mesh`.
    ///
    /// # Panics
    /// If `partition` is not one of `mesh` (another number of elements).
    pub fn of(mesh: &Mesh, partition: &Partition) -> PartitionMetrics {
        assert_eq!(partition.element_part.len(), mesh.elements.len());
        let p = partition.parts;
        // The parts of every node, sorted and unique (a node is in few parts).
        let mut node_parts: Vec<Vec<u32>> = vec![Vec::new(); mesh.nodes.len()];
        for (e, nodes) in mesh.elements.iter().enumerate() {
            let part = partition.element_part[e];
            for &n in nodes {
                if let Err(at) = node_parts[n].binary_search(&part) {
                    node_parts[n].insert(at, part);
                }
            }
        }
        let mut elements = vec![0; p];
        for &part in &partition.element_part {
            elements[part as usize] += 1;
        }
        let mut interface_nodes = vec![0; p];
        let mut neighbour_sets: Vec<Vec<u32>> = vec![Vec::new(); p];
        let (mut interface_total, mut nodes, mut max_incidence, mut incidence_sum) = (0, 0, 0, 0);
        for parts in &node_parts {
            if parts.is_empty() {
                continue;
            }
            nodes += 1;
            max_incidence = max_incidence.max(parts.len());
            if parts.len() < 2 {
                continue;
            }
            interface_total += 1;
            incidence_sum += parts.len();
            for &a in parts {
                interface_nodes[a as usize] += 1;
                for &b in parts {
                    let set = &mut neighbour_sets[a as usize];
                    if a != b {
                        if let Err(at) = set.binary_search(&b) {
                            set.insert(at, b);
                        }
                    }
                }
            }
        }
        let mut periphery = vec![0; p];
        for (e, en) in mesh.elements.iter().enumerate() {
            if en.iter().any(|&n| node_parts[n].len() > 1) {
                periphery[partition.element_part[e] as usize] += 1;
            }
        }
        PartitionMetrics {
            elements,
            interface_nodes,
            interface_total,
            nodes,
            neighbours: neighbour_sets.iter().map(Vec::len).collect(),
            periphery,
            max_incidence,
            incidence_sum,
            dofs_per_node: mesh.kind.dim(),
        }
    }

    /// The papers' communication bandwidth: the most neighbours of any part.
    pub fn bandwidth(&self) -> usize {
        self.neighbours.iter().copied().max().unwrap_or(0)
    }

    /// `P_cm = d × Σ incidence`: the values an interface sum exchanges.
    pub fn p_cm(&self) -> usize {
        self.dofs_per_node * self.incidence_sum
    }

    /// The largest part's elements over the mean (1: perfectly balanced).
    pub fn imbalance(&self) -> f64 {
        let n: usize = self.elements.iter().sum();
        let max = self.elements.iter().copied().max().unwrap_or(0);
        if n == 0 {
            1.0
        } else {
            max as f64 * self.elements.len() as f64 / n as f64
        }
    }

    /// The report `mbdc check --partition P` prints for `mesh`.
    pub fn render(&self, mesh: &str) -> String {
        use std::fmt::Write as _;
        let p = self.elements.len();
        let range = |v: &[usize]| {
            let (lo, hi) = (
                v.iter().copied().min().unwrap_or(0),
                v.iter().copied().max().unwrap_or(0),
            );
            if lo == hi {
                format!("{lo}")
            } else {
                format!("{lo}–{hi}")
            }
        };
        let mut s = String::new();
        let _ = writeln!(
            s,
            "partition of mesh '{mesh}' into {p} parts (recursive coordinate bisection):"
        );
        let _ = writeln!(
            s,
            "  elements per part        {} (largest / mean {:.3})",
            range(&self.elements),
            self.imbalance()
        );
        let _ = writeln!(
            s,
            "  interface nodes          {} of {} ({:.1} %); per part {}",
            self.interface_total,
            self.nodes,
            100.0 * self.interface_total as f64 / self.nodes.max(1) as f64,
            range(&self.interface_nodes)
        );
        let _ = writeln!(
            s,
            "  neighbouring parts       {}; bandwidth (most of any part) {}",
            range(&self.neighbours),
            self.bandwidth()
        );
        let _ = writeln!(
            s,
            "  elements on the periphery {} per part",
            range(&self.periphery)
        );
        let _ = writeln!(
            s,
            "  largest incidence        {} parts at one node; Σ incidence {}; P_cm = {} × {} = {}",
            self.max_incidence,
            self.incidence_sum,
            self.dofs_per_node,
            self.incidence_sum,
            self.p_cm()
        );
        let _ = writeln!(
            s,
            "  {:<4} {:>9} {:>10} {:>10} {:>9}",
            "part", "elements", "interface", "neighbours", "periphery"
        );
        for k in 0..p {
            let _ = writeln!(
                s,
                "  {:<4} {:>9} {:>10} {:>10} {:>9}",
                k, self.elements[k], self.interface_nodes[k], self.neighbours[k], self.periphery[k]
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::scene::{ElementKind, Material, MeshFormulation, Origin};

    /// An n × m grid of unit quads (plane stress), nodes row by row.
    fn grid(n: usize, m: usize) -> Mesh {
        let mut nodes = Vec::new();
        for j in 0..=m {
            for i in 0..=n {
                nodes.push([i as f64, j as f64, 0.0]);
            }
        }
        let id = |i: usize, j: usize| j * (n + 1) + i;
        let mut elements = Vec::new();
        for j in 0..m {
            for i in 0..n {
                elements.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        Mesh {
            name: "grid".into(),
            kind: ElementKind::Quad4PlaneStress,
            material: Material {
                e: 1.0,
                nu: 0.0,
                rho: 1.0,
                plastic: None,
            },
            thickness: 1.0,
            nodes,
            elements,
            node_sets: Vec::new(),
            conditions: Vec::new(),
            formulation: MeshFormulation::default(),
            origin: Origin::default(),
        }
    }

    /// The papers' D1/D2 example (notes D §3, "D1 vs D2", verified there by script): a
    /// 16 × 16 grid of quads in 16 parts. Strips of 1 × 16 elements (D1): 255 interface
    /// nodes, bandwidth 2, every element on the periphery. Blocks of 4 × 4 (D2): 93 interface
    /// nodes, bandwidth 8, 12 of the 16 elements of an interior block on the periphery.
    /// Exact.
    #[test]
    fn the_papers_d1_and_d2_metrics() {
        let g = grid(16, 16);
        let strips = Partition {
            parts: 16,
            element_part: (0..256).map(|e| (e % 16) as u32).collect(),
        };
        let d1 = PartitionMetrics::of(&g, &strips);
        assert_eq!(d1.interface_total, 255);
        assert_eq!(d1.bandwidth(), 2);
        assert!(d1.periphery.iter().all(|&k| k == 16));
        assert_eq!(d1.nodes, 289);
        assert_eq!(d1.max_incidence, 2);
        let blocks = Partition {
            parts: 16,
            element_part: (0..256)
                .map(|e| ((e / 16 / 4) * 4 + (e % 16) / 4) as u32)
                .collect(),
        };
        let d2 = PartitionMetrics::of(&g, &blocks);
        assert_eq!(d2.interface_total, 93);
        assert_eq!(d2.bandwidth(), 8);
        // blocks 5, 6, 9, 10 are interior
        for k in [5, 6, 9, 10] {
            assert_eq!(d2.periphery[k], 12, "block {k}");
            assert_eq!(d2.neighbours[k], 8, "block {k}");
        }
        assert_eq!(d2.max_incidence, 4);
        // 9 crossings shared by 4 parts, the other 84 interface nodes by 2
        assert_eq!(d2.incidence_sum, 9 * 4 + 84 * 2);
        assert_eq!(d2.p_cm(), 2 * d2.incidence_sum);
    }

    /// Bisection of the 16 × 16 grid into 16 parts finds D2, the interface-minimizing
    /// decomposition (93 interface nodes), with 16 elements in every part.
    #[test]
    fn bisection_finds_the_interface_minimizing_blocks() {
        let g = grid(16, 16);
        let p = bisect(&g, 16).unwrap();
        let m = PartitionMetrics::of(&g, &p);
        assert_eq!(m.interface_total, 93);
        assert!(m.elements.iter().all(|&k| k == 16));
        assert_eq!(m.bandwidth(), 8);
    }

    /// Any number of parts: each gets its share of the elements to one, every part is
    /// used, and the result does not depend on the order the elements are listed in
    /// beyond their numbering (the same mesh twice gives the same partition).
    #[test]
    fn parts_are_balanced_to_one_element_for_any_count() {
        let g = grid(13, 7);
        for p in 1..=20 {
            let part = bisect(&g, p).unwrap();
            let m = PartitionMetrics::of(&g, &part);
            let (lo, hi) = (
                *m.elements.iter().min().unwrap(),
                *m.elements.iter().max().unwrap(),
            );
            assert!(hi - lo <= 1, "{p} parts: {lo}..{hi}");
            assert_eq!(m.elements.iter().sum::<usize>(), 91);
            assert_eq!(part, bisect(&g, p).unwrap());
            if p == 1 {
                assert_eq!(m.interface_total, 0);
                assert_eq!(m.bandwidth(), 0);
            }
        }
        assert_eq!(bisect(&g, 0), Err(PartitionError::NoParts));
        assert!(matches!(
            bisect(&g, 92),
            Err(PartitionError::TooManyParts { elements: 91, .. })
        ));
    }
}
