//! Meshes split between the ranks of a distributed explicit run (notes D §5–§6, the
//! Connection Machine's element-per-processor layout brought to processes): every rank
//! evaluates its own elements and integrates the nodes they touch; the nodes on the
//! interface between ranks complete their force sums with the other ranks' element forces,
//! exchanged every step by a plan fixed before the run.
//!
//! **The split.** The elements go to the ranks by recursive coordinate bisection of their
//! centroids ([`super::mesh_partition::bisect_centroids`], the partitioner of
//! `mbdc check --partition`), a rank's part being its elements and every node they touch.
//! An interface node lives on every rank that touches it; each of them integrates it, from
//! the same complete force and so to the same bits, and the lowest of them *owns* it: it
//! counts it in the energies and reports it in the output.
//!
//! **Bitwise the run in one process.** A node's force is summed from its element slots in
//! the canonical order ([`crate::contract::mesh_plan`]). A part keeps that order: its node
//! → slot plan lists, for an interface node, its own elements' slots and, where another
//! rank's elements come, *ghost slots* that the exchange fills with those elements' forces
//! ([`MeshHalo`]). Nothing is summed before the exchange, so the sums, and the motion, are
//! bitwise those of the whole mesh on threads, for any number of ranks.
//!
//! **What each rank holds.** Only its part: its elements' connectivity, state and
//! integration points, its nodes' arrays. The global numbering of both is kept beside
//! ([`RankPart::nodes`], [`RankPart::elements`]) for the output, which rank 0 gathers.

use std::collections::HashMap;

use super::mesh_partition::bisect_centroids;
use crate::contract::mesh_layout::{MeshHalo, MeshLayout};
use crate::contract::mesh_plan::{Assembly, AssemblyPlan, BlockPlan};
use crate::contract::scene::MeshMethod;

/// Which rank each element and node belongs to.
#[derive(Clone, Debug, PartialEq)]
pub struct RankMap {
    /// Number of ranks.
    pub ranks: usize,
    /// Per element (global numbering: block after block): its rank.
    pub element_rank: Vec<u32>,
    /// Per node: the rank that owns it (the lowest that touches it; a node no element
    /// touches goes to rank 0).
    pub node_owner: Vec<u32>,
    /// Per node: the ranks that touch it, `node_ranks[node_first[n]..node_first[n + 1]]`,
    /// ascending.
    node_first: Vec<u32>,
    node_ranks: Vec<u32>,
    /// Per slot (global numbering): its element.
    slot_element: Vec<u32>,
}

impl RankMap {
    /// The ranks that touch node `n`, ascending.
    pub fn ranks_of_node(&self, n: usize) -> &[u32] {
        &self.node_ranks[self.node_first[n] as usize..self.node_first[n + 1] as usize]
    }
}

/// One rank's part of the meshes.
#[derive(Clone, Debug, PartialEq)]
pub struct RankPart {
    /// The part as a layout of its own: its elements (block by block, in the global
    /// order), the nodes they touch (in the global order), the loads and conditions on
    /// them, the node-centric gather's plan with ghost slots, and the exchange
    /// ([`MeshLayout::halo`]).
    pub layout: MeshLayout,
    /// Per node of the part: its global number.
    pub nodes: Vec<u32>,
    /// Per element of the part: its global number.
    pub elements: Vec<u32>,
}

/// Why meshes cannot be split between ranks.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RankError {
    /// More ranks than elements.
    #[error("{ranks} ranks for {elements} elements: every rank needs at least one element; run on fewer ranks")]
    TooManyRanks {
        /// Ranks asked for.
        ranks: usize,
        /// Elements of all meshes.
        elements: usize,
    },
    /// What the distributed explicit method does not do yet.
    #[error("{0}")]
    Unsupported(String),
}

/// Give every element and node of `l` a rank, `ranks` ≥ 1 of them.
///
/// # Errors
/// More ranks than elements.
pub fn rank_map(l: &MeshLayout, ranks: usize) -> Result<RankMap, RankError> {
    let ne = l.elements();
    if ranks == 0 || ranks > ne {
        return Err(RankError::TooManyRanks {
            ranks,
            elements: ne,
        });
    }
    let mut centroids = Vec::with_capacity(ne);
    let mut slot_element = vec![0u32; l.total_slots()];
    for b in &l.blocks {
        let npe = b.kind.nodes();
        for e in 0..b.elements() {
            let mut c = [0.0; 3];
            for &n in b.element_nodes(e) {
                for (ci, xi) in c.iter_mut().zip(l.x0[n as usize]) {
                    *ci += xi;
                }
            }
            centroids.push(c.map(|v| v / npe as f64));
            let s0 = b.first_slot + e * npe;
            slot_element[s0..s0 + npe].fill((b.first_element + e) as u32);
        }
    }
    let element_rank = bisect_centroids(&centroids, ranks);
    let n = l.nodes();
    let mut node_first = Vec::with_capacity(n + 1);
    let mut node_ranks = Vec::new();
    let mut node_owner = vec![0u32; n];
    node_first.push(0u32);
    for (node, owner) in node_owner.iter_mut().enumerate() {
        let start = node_ranks.len();
        for &s in &l.slots[l.first[node] as usize..l.first[node + 1] as usize] {
            node_ranks.push(element_rank[slot_element[s as usize] as usize]);
        }
        let mine = &mut node_ranks[start..];
        mine.sort_unstable();
        let mut k = 0;
        for i in 0..mine.len() {
            if i == 0 || mine[i] != mine[k - 1] {
                mine[k] = mine[i];
                k += 1;
            }
        }
        node_ranks.truncate(start + k);
        if k == 0 {
            node_ranks.push(0);
        }
        *owner = node_ranks[start];
        node_first.push(node_ranks.len() as u32);
    }
    Ok(RankMap {
        ranks,
        element_rank,
        node_owner,
        node_first,
        node_ranks,
        slot_element,
    })
}

/// Why the distributed explicit method refuses `l`, if it does.
pub fn refusal(l: &MeshLayout) -> Option<String> {
    if let Some(t) = l.ties.first() {
        return Some(format!(
            "mesh '{}' is tied to a body (set '{}'): meshes tied to bodies run in one process for now; run without --mpi",
            t.mesh, t.set
        ));
    }
    if let Some(g) = l.glues.first() {
        return Some(format!(
            "mesh '{}' is glued to '{}' (set '{}'): the explicit method does not glue meshes",
            g.mesh, g.other_mesh, g.set
        ));
    }
    if l.method != MeshMethod::CentralDifference {
        return Some(format!(
            "`mesh_method {}` runs across ranks through FETI, not by splitting the explicit method's elements",
            l.method.name()
        ));
    }
    None
}

/// Rank `rank`'s part of `l` under `map`.
///
/// # Errors
/// What [`refusal`] names.
pub fn rank_part(l: &MeshLayout, map: &RankMap, rank: usize) -> Result<RankPart, RankError> {
    if let Some(why) = refusal(l) {
        return Err(RankError::Unsupported(why));
    }
    let me = rank as u32;
    let touches = |n: usize| map.ranks_of_node(n).contains(&me);
    // The part's nodes, in the global order, and the global → local map.
    let nodes: Vec<u32> = (0..l.nodes())
        .filter(|&n| touches(n))
        .map(|n| n as u32)
        .collect();
    let mut local = vec![u32::MAX; l.nodes()];
    for (i, &n) in nodes.iter().enumerate() {
        local[n as usize] = i as u32;
    }
    // The part's blocks: its elements, block by block, in the global order.
    let mut part = MeshLayout {
        method: l.method,
        solver: l.solver,
        ..MeshLayout::default()
    };
    let mut elements = Vec::new();
    // global slot → local slot, for the own elements
    let mut own_slot: HashMap<u32, u32> = HashMap::new();
    let (mut first_slot, mut first_element) = (0, 0);
    for b in &l.blocks {
        let npe = b.kind.nodes();
        let mut conn = Vec::new();
        for e in 0..b.elements() {
            let ge = b.first_element + e;
            if map.element_rank[ge] != me {
                continue;
            }
            for (a, &n) in b.element_nodes(e).iter().enumerate() {
                own_slot.insert(
                    (b.first_slot + e * npe + a) as u32,
                    (first_slot + conn.len()) as u32,
                );
                conn.push(local[n as usize]);
            }
            elements.push(ge as u32);
        }
        let first_node = nodes.partition_point(|&n| (n as usize) < b.first_node);
        let end_node = nodes.partition_point(|&n| (n as usize) < b.first_node + b.nodes);
        let ne = conn.len() / npe;
        part.blocks
            .push(crate::contract::mesh_layout::ElementBlock {
                conn,
                first_node,
                nodes: end_node - first_node,
                first_slot,
                first_element,
                ..b.clone()
            });
        first_slot += ne * npe;
        first_element += ne;
    }
    // Ghost slots: per peer, the peer's element slots at my nodes, ascending (global slot
    // numbers); and what I send: my element slots at each peer's nodes, ascending.
    let mut recv: Vec<Vec<u32>> = vec![Vec::new(); map.ranks];
    let mut send: Vec<Vec<u32>> = vec![Vec::new(); map.ranks];
    for &n in &nodes {
        let n = n as usize;
        for &s in &l.slots[l.first[n] as usize..l.first[n + 1] as usize] {
            let q = map.element_rank[map.slot_element[s as usize] as usize];
            if q != me {
                recv[q as usize].push(s);
            } else {
                for &p in map.ranks_of_node(n) {
                    if p != me {
                        send[p as usize].push(s);
                    }
                }
            }
        }
    }
    let mut halo = MeshHalo::default();
    let mut ghost: HashMap<u32, u32> = HashMap::new();
    halo.exchange.send_first.push(0);
    halo.exchange.recv_first.push(0);
    for q in 0..map.ranks {
        let (r, s) = (&mut recv[q], &mut send[q]);
        if r.is_empty() && s.is_empty() {
            continue;
        }
        r.sort_unstable();
        s.sort_unstable();
        halo.exchange.peers.push(q as u32);
        for &g in r.iter() {
            ghost.insert(g, (first_slot + halo.ghost_slots) as u32);
            halo.ghost_slots += 1;
        }
        halo.send_slots.extend(s.iter().map(|g| own_slot[g]));
        halo.exchange
            .send_first
            .push(3 * halo.send_slots.len() as u32);
        halo.exchange.recv_first.push(3 * halo.ghost_slots as u32);
    }
    // The node → slot plan, in the global (canonical) order.
    part.first.push(0);
    for &n in &nodes {
        let n = n as usize;
        for &s in &l.slots[l.first[n] as usize..l.first[n + 1] as usize] {
            part.slots
                .push(own_slot.get(&s).copied().unwrap_or_else(|| ghost[&s]));
        }
        part.first.push(part.slots.len() as u32);
    }
    halo.owned = nodes
        .iter()
        .map(|&n| map.node_owner[n as usize] == me)
        .collect();
    halo.node_ids = nodes
        .iter()
        .map(|&n| {
            let b = l.blocks.partition_point(|b| b.first_node <= n as usize) - 1;
            n - l.blocks[b].first_node as u32
        })
        .collect();
    halo.element_ids = elements
        .iter()
        .map(|&e| {
            let b = l.blocks.partition_point(|b| b.first_element <= e as usize) - 1;
            e - l.blocks[b].first_element as u32
        })
        .collect();
    // The nodes' arrays and conditions.
    let pick = |v: &[[f64; 3]]| -> Vec<[f64; 3]> { nodes.iter().map(|&n| v[n as usize]).collect() };
    part.x0 = pick(&l.x0);
    part.mass = nodes.iter().map(|&n| l.mass[n as usize]).collect();
    part.constrained = nodes.iter().map(|&n| l.constrained[n as usize]).collect();
    if !l.body_force.is_empty() {
        part.body_force = pick(&l.body_force);
    }
    let at = |n: u32| local[n as usize];
    part.prescribed = l
        .prescribed
        .iter()
        .filter(|p| at(p.node) != u32::MAX)
        .map(|p| crate::contract::mesh_layout::Prescribed {
            node: at(p.node),
            ..p.clone()
        })
        .collect();
    part.foundation = l
        .foundation
        .iter()
        .filter(|s| at(s.node) != u32::MAX)
        .map(|s| crate::contract::mesh_layout::FoundationSpring {
            node: at(s.node),
            ..*s
        })
        .collect();
    for g in &l.loads {
        let (mut ns, mut ws) = (Vec::new(), Vec::new());
        for (&n, &w) in g.nodes.iter().zip(&g.weights) {
            if at(n) != u32::MAX {
                ns.push(at(n));
                ws.push(w);
            }
        }
        part.loads.push(crate::contract::mesh_layout::LoadGroup {
            value: g.value.clone(),
            nodes: ns,
            weights: ws,
        });
    }
    part.assembly = AssemblyPlan {
        options: crate::contract::mesh_plan::AssemblyOptions {
            strategy: Assembly::Gather,
            ..l.assembly.options
        },
        blocks: vec![BlockPlan::default(); l.blocks.len()],
        interface_nodes: Vec::new(),
        interface_first: Vec::new(),
    };
    part.halo = Some(halo);
    Ok(RankPart {
        layout: part,
        nodes,
        elements,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::mesh_model::build;
    use crate::contract::scene::{ElementKind, Material, Mesh, MeshFormulation};

    /// A 6×3 quad4 plate (2-D).
    fn plate() -> MeshLayout {
        let (nx, ny) = (6, 3);
        let mut nodes = Vec::new();
        for j in 0..=ny {
            for i in 0..=nx {
                nodes.push([i as f64 * 0.1, j as f64 * 0.1, 0.0]);
            }
        }
        let id = |i: usize, j: usize| j * (nx + 1) + i;
        let mut elements = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                elements.push(vec![id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        let m = Mesh {
            name: "plate".into(),
            kind: ElementKind::Quad4PlaneStress,
            material: Material {
                e: 200e9,
                nu: 0.3,
                rho: 7800.0,
                plastic: None,
            },
            thickness: 0.01,
            nodes,
            elements,
            node_sets: vec![],
            conditions: vec![],
            formulation: MeshFormulation::default(),
            origin: Default::default(),
        };
        build(&[m]).expect("a valid plate")
    }

    #[test]
    fn every_element_on_one_rank_and_interfaces_exchanged_both_ways() {
        let l = plate();
        for ranks in [1, 2, 3, 4] {
            let map = rank_map(&l, ranks).unwrap();
            let parts: Vec<RankPart> = (0..ranks)
                .map(|r| rank_part(&l, &map, r).unwrap())
                .collect();
            let mut seen = vec![0; l.elements()];
            for p in &parts {
                for &e in &p.elements {
                    seen[e as usize] += 1;
                }
                assert_eq!(p.layout.elements(), p.elements.len());
            }
            assert!(seen.iter().all(|&k| k == 1), "{ranks} ranks: {seen:?}");
            // each node owned once; every slot of every node present in its part's plan
            let mut owned = vec![0; l.nodes()];
            for p in &parts {
                let h = p.layout.halo.as_ref().unwrap();
                for (i, &n) in p.nodes.iter().enumerate() {
                    owned[n as usize] += h.owned[i] as usize;
                    let k = (p.layout.first[i + 1] - p.layout.first[i]) as usize;
                    let g = n as usize;
                    assert_eq!(k, (l.first[g + 1] - l.first[g]) as usize);
                }
                // what r sends q is what q expects from r
                let me = parts.iter().position(|x| std::ptr::eq(x, p)).unwrap() as u32;
                for (i, &q) in h.exchange.peers.iter().enumerate() {
                    let other = parts[q as usize].layout.halo.as_ref().unwrap();
                    let j = other.exchange.peers.iter().position(|&x| x == me).unwrap();
                    let sent = h.exchange.send_first[i + 1] - h.exchange.send_first[i];
                    let got = other.exchange.recv_first[j + 1] - other.exchange.recv_first[j];
                    assert_eq!(sent, got);
                }
            }
            assert!(owned.iter().all(|&k| k == 1));
        }
    }

    #[test]
    fn too_many_ranks_are_refused() {
        let l = plate();
        let e = rank_map(&l, l.elements() + 1).unwrap_err();
        assert!(e.to_string().contains("19 ranks for 18 elements"), "{e}");
    }
}
