//! The assembly plans of a mesh layout ([`crate::contract::mesh_plan`]), built once with the
//! layout: the node → element-slot plan of the gather, the colouring, the canonical
//! summation order every strategy follows, and the partitions with their interface.
//!
//! 1. **Slots per node**: every node's element slots, ascending.
//! 2. **Colouring** (per block): runs of `colour_group` consecutive elements ("groups"),
//!    greedily in order, each take the smallest colour that no earlier group sharing a
//!    node has. Greedy colouring uses at most (the most groups sharing a node with one
//!    group) + 1 colours; no two groups of a colour share a node.
//! 3. **Canonical order**: each node's slots sorted by (colour of the element's group,
//!    element). Colouring reaches a node in this order (colour after colour; a group's
//!    elements in order), so summing the slots in this order gives bitwise what colouring
//!    gives.
//! 4. **Partitions** (per block): contiguous runs of elements, as many as a power of two
//!    that keeps at least `partition_elements` elements per partition, at most
//!    `max_partitions`, and at most `max_interface` of the nodes on the interface (the
//!    number depends on the mesh and the options, never on the threads). A node whose
//!    elements all lie in one partition is interior to it, any other an interface node. Each partition evaluates its elements in the canonical order, so its
//!    interior nodes receive their forces in that order; an interface node's forces go to
//!    its interface slots, one per incidence in the canonical order, and are summed after.

use crate::contract::mesh_layout::{ElementBlock, MeshLayout};
use crate::contract::mesh_plan::{AssemblyOptions, AssemblyPlan, BlockPlan, INTERFACE};

/// Build the gather plan (`first`, `slots`) and the assembly plans of `l` (its blocks,
/// nodes and connectivity already set).
///
/// # Panics
/// More than 2³¹ nodes or interface slots (the plans index them with 31 bits).
pub fn build(l: &mut MeshLayout, options: AssemblyOptions) {
    assert!(
        l.nodes() < INTERFACE as usize && l.total_slots() < INTERFACE as usize,
        "a mesh layout of more than 2^31 nodes or element slots"
    );
    let (first, mut slots) = node_slots(l);
    let group = options.colour_group.max(1);
    let mut blocks: Vec<BlockPlan> = l
        .blocks
        .iter()
        .map(|b| {
            let (group_colour, colours) = colour(b, &first, &slots, group);
            BlockPlan {
                group,
                colours,
                group_colour,
                ..BlockPlan::default()
            }
        })
        .collect();
    // The canonical order: each node's slots (all of one block) by colour, then slot.
    for (b, p) in l.blocks.iter().zip(&blocks) {
        let npe = b.kind.nodes();
        for n in b.first_node..b.first_node + b.nodes {
            slots[first[n] as usize..first[n + 1] as usize]
                .sort_by_key(|&s| (p.colour((s as usize - b.first_slot) / npe), s));
        }
    }
    // Partitions and their interface.
    let mut interface_nodes = Vec::new();
    let mut interface_first = vec![0u32];
    for (b, p) in l.blocks.iter().zip(blocks.iter_mut()) {
        let npe = b.kind.nodes();
        let ne = b.elements();
        let count = partition_count(b, &first, &slots, &options);
        p.parts = bounds(ne, count);
        let part_of = parts_of(&p.parts);
        let mut order: Vec<u32> = (0..ne as u32).collect();
        for k in 0..count {
            order[p.parts[k] as usize..p.parts[k + 1] as usize]
                .sort_by_key(|&e| (p.colour(e as usize), e));
        }
        p.order = order;
        p.targets = vec![0; ne * npe];
        for n in b.first_node..b.first_node + b.nodes {
            let row = &slots[first[n] as usize..first[n + 1] as usize];
            let element = |s: u32| (s as usize - b.first_slot) / npe;
            let interior = row
                .iter()
                .all(|&s| part_of[element(s)] == part_of[element(row[0])]);
            if interior {
                for &s in row {
                    p.targets[s as usize - b.first_slot] = n as u32;
                }
            } else {
                let base = *interface_first.last().expect("starts with 0");
                for (k, &s) in row.iter().enumerate() {
                    p.targets[s as usize - b.first_slot] = INTERFACE | (base + k as u32);
                }
                interface_nodes.push(n as u32);
                interface_first.push(base + row.len() as u32);
            }
        }
    }
    l.first = first;
    l.slots = slots;
    l.assembly = AssemblyPlan {
        options,
        blocks,
        interface_nodes,
        interface_first,
    };
}

/// The number of partitions of block `b`: the most, as a power of two, that leaves every
/// partition at least `partition_elements` elements, is at most `max_partitions`, and
/// makes at most `max_interface` of the block's nodes interface nodes; at least 1 (0
/// without elements). It depends on the mesh and the options only.
fn partition_count(b: &ElementBlock, first: &[u32], slots: &[u32], o: &AssemblyOptions) -> usize {
    let ne = b.elements();
    if ne == 0 {
        return 0;
    }
    let most = (ne / o.partition_elements.max(1)).clamp(1, o.max_partitions.max(1));
    let mut count = 1 << most.ilog2();
    while count > 1 {
        let part_of = parts_of(&bounds(ne, count));
        let npe = b.kind.nodes();
        let interface = (b.first_node..b.first_node + b.nodes)
            .filter(|&n| {
                let row = &slots[first[n] as usize..first[n + 1] as usize];
                let part = |s: u32| part_of[(s as usize - b.first_slot) / npe];
                row.iter().any(|&s| part(s) != part(row[0]))
            })
            .count();
        if interface as f64 <= o.max_interface * b.nodes as f64 {
            break;
        }
        count /= 2;
    }
    count
}

/// The bounds of `count` contiguous partitions of `ne` elements, as equal as can be.
fn bounds(ne: usize, count: usize) -> Vec<u32> {
    (0..=count)
        .map(|k| (k * ne / count.max(1)) as u32)
        .collect()
}

/// The partition of every element, from the partitions' bounds.
fn parts_of(bounds: &[u32]) -> Vec<u32> {
    let mut part_of = vec![0u32; *bounds.last().unwrap_or(&0) as usize];
    for (k, w) in bounds.windows(2).enumerate() {
        part_of[w[0] as usize..w[1] as usize].fill(k as u32);
    }
    part_of
}

/// Every node's element slots, ascending, as compressed rows.
fn node_slots(l: &MeshLayout) -> (Vec<u32>, Vec<u32>) {
    let n = l.nodes();
    let mut first = vec![0u32; n + 1];
    for b in &l.blocks {
        for &g in &b.conn {
            first[g as usize + 1] += 1;
        }
    }
    for i in 0..n {
        first[i + 1] += first[i];
    }
    let mut next = first.clone();
    let mut slots = vec![0u32; l.total_slots()];
    for b in &l.blocks {
        for (i, &g) in b.conn.iter().enumerate() {
            let at = &mut next[g as usize];
            slots[*at as usize] = (b.first_slot + i) as u32;
            *at += 1;
        }
    }
    (first, slots)
}

/// Greedy colouring of the groups of `group` consecutive elements of block `b`: the colour
/// of each group and the number of colours.
fn colour(b: &ElementBlock, first: &[u32], slots: &[u32], group: usize) -> (Vec<u32>, usize) {
    let npe = b.kind.nodes();
    let ne = b.elements();
    let groups = ne.div_ceil(group);
    let mut colour = vec![u32::MAX; groups];
    // taken[c] == g + 1: colour c is used by a group that shares a node with group g.
    let mut taken: Vec<usize> = Vec::new();
    for g in 0..groups {
        for e in g * group..((g + 1) * group).min(ne) {
            for &n in b.element_nodes(e) {
                for &s in &slots[first[n as usize] as usize..first[n as usize + 1] as usize] {
                    let other = (s as usize - b.first_slot) / npe / group;
                    let c = colour[other];
                    if other != g && c != u32::MAX {
                        taken[c as usize] = g + 1;
                    }
                }
            }
        }
        let c = taken.iter().position(|&t| t != g + 1).unwrap_or_else(|| {
            taken.push(0);
            taken.len() - 1
        });
        colour[g] = c as u32;
    }
    (colour, taken.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::scene::{ElementKind, Material, MeshFormulation};

    /// A quad4 block of `nx × ny` unit cells with its elements in the order `perm`.
    fn grid(nx: usize, ny: usize, perm: impl Fn(usize) -> usize) -> MeshLayout {
        let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
        let mut cells = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                cells.push([id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let conn = (0..cells.len()).flat_map(|e| cells[perm(e)]).collect();
        let mut l = MeshLayout {
            x0: (0..(nx + 1) * (ny + 1))
                .map(|n| [(n % (nx + 1)) as f64, (n / (nx + 1)) as f64, 0.0])
                .collect(),
            ..MeshLayout::default()
        };
        l.blocks.push(ElementBlock {
            name: "g".into(),
            kind: ElementKind::Quad4PlaneStress,
            material: Material {
                e: 1.0,
                nu: 0.3,
                rho: 1.0,
                plastic: None,
            },
            thickness: 1.0,
            formulation: MeshFormulation::default(),
            first_node: 0,
            nodes: l.x0.len(),
            conn,
            first_slot: 0,
            first_element: 0,
        });
        l
    }

    /// Checks every property the strategies rely on; returns the number of colours.
    fn check(l: &MeshLayout) -> usize {
        let b = &l.blocks[0];
        let p = &l.assembly.blocks[0];
        let npe = b.kind.nodes();
        let element = |s: u32| s as usize / npe;
        // Colour classes are node-disjoint (groups of one colour never share a node).
        for n in 0..l.nodes() {
            let row = &l.slots[l.first[n] as usize..l.first[n + 1] as usize];
            assert!(!row.is_empty());
            for (i, &s) in row.iter().enumerate() {
                for &t in &row[..i] {
                    let (ge, gt) = (element(s) / p.group, element(t) / p.group);
                    assert!(ge == gt || p.colour(element(s)) != p.colour(element(t)));
                    // ... and the row is in the canonical order
                    assert!(
                        (p.colour(element(t)), t) < (p.colour(element(s)), s),
                        "node {n}: slots out of the canonical order"
                    );
                }
            }
        }
        // Every slot is some node's exactly once.
        let mut seen = l.slots.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..l.total_slots() as u32).collect::<Vec<_>>());
        // Partitions cover the elements; the order is a permutation of each partition,
        // in the canonical order.
        assert_eq!(p.parts[0], 0);
        assert_eq!(*p.parts.last().unwrap() as usize, b.elements());
        for k in 0..p.partitions() {
            let (a, z) = (p.parts[k] as usize, p.parts[k + 1] as usize);
            assert!(a < z);
            let mut part: Vec<u32> = p.order[a..z].to_vec();
            assert!(part
                .windows(2)
                .all(|w| (p.colour(w[0] as usize), w[0]) < (p.colour(w[1] as usize), w[1])));
            part.sort_unstable();
            assert_eq!(part, (a as u32..z as u32).collect::<Vec<_>>());
        }
        // Interior targets name the element's own node; interface slots are that node's
        // slots in its canonical order; every interface node is touched by two partitions.
        let part_of = |e: usize| p.parts.partition_point(|&x| x as usize <= e) - 1;
        for (e, nodes) in b.conn.chunks(npe).enumerate() {
            for (a, &n) in nodes.iter().enumerate() {
                let t = p.targets[e * npe + a];
                if t & INTERFACE == 0 {
                    assert_eq!(t, n);
                } else {
                    let i = l
                        .assembly
                        .interface_nodes
                        .binary_search(&n)
                        .expect("listed");
                    let s0 = l.assembly.interface_first[i];
                    let k = (t & !INTERFACE) - s0;
                    assert_eq!(
                        l.slots[(l.first[n as usize] + k) as usize] as usize,
                        e * npe + a
                    );
                }
            }
        }
        for &n in &l.assembly.interface_nodes {
            let row = &l.slots[l.first[n as usize] as usize..l.first[n as usize + 1] as usize];
            let parts: std::collections::BTreeSet<usize> =
                row.iter().map(|&s| part_of(element(s))).collect();
            assert!(parts.len() > 1, "node {n} is interior");
        }
        p.colours
    }

    /// A 30 × 20 grid in natural and in shuffled element order, with element colouring and
    /// with groups: every plan property holds; a structured quad grid in natural order
    /// takes 4 element colours (the 2 × 2 parity pattern).
    #[test]
    fn plans_hold_their_invariants() {
        let (nx, ny) = (30, 20);
        let ne = nx * ny;
        // a fixed shuffle: multiplication by a unit modulo the element count
        let shuffled = move |e: usize| (e * 7 + 3) % ne;
        for (perm, name) in [
            (Box::new(|e| e) as Box<dyn Fn(usize) -> usize>, "natural"),
            (Box::new(shuffled), "shuffled"),
        ] {
            for (group, parts, interface) in [
                (1, 100, 1.0),
                (8, 64, 1.0),
                (5, 1000, 1.0),
                (1, 1, 1.0),
                (4, 50, 0.2),
            ] {
                let mut l = grid(nx, ny, &perm);
                let opts = AssemblyOptions {
                    colour_group: group,
                    partition_elements: parts,
                    max_partitions: 64,
                    max_interface: interface,
                    ..AssemblyOptions::default()
                };
                build(&mut l, opts);
                let colours = check(&l);
                let p = &l.assembly.blocks[0];
                // the most partitions (a power of two) allowed by the size and the interface
                let most = (ne / parts).clamp(1, 64);
                let count = p.partitions();
                assert!(count.is_power_of_two() && count <= most);
                let share =
                    |l: &MeshLayout| l.assembly.interface_nodes.len() as f64 / l.nodes() as f64;
                assert!(share(&l) <= interface, "{}", share(&l));
                if 2 * count <= most {
                    let mut twice = grid(nx, ny, &perm);
                    build(
                        &mut twice,
                        AssemblyOptions {
                            max_partitions: 2 * count,
                            max_interface: 1.0,
                            ..opts
                        },
                    );
                    assert_eq!(twice.assembly.blocks[0].partitions(), 2 * count);
                    assert!(share(&twice) > interface, "{name}: more partitions fit");
                }
                if name == "natural" && group == 1 {
                    assert_eq!(colours, 4);
                }
                if interface < 1.0 {
                    // the interface limit, not the size, sets the count here
                    assert!(count < 8, "{name}: {count}");
                }
                if p.partitions() > 1 {
                    assert!(!l.assembly.interface_nodes.is_empty());
                } else {
                    assert!(l.assembly.interface_nodes.is_empty());
                }
            }
        }
    }
}
