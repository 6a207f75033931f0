//! The finite-element meshes of a system, flattened for the explicit method: every node of
//! every mesh numbered once, one type-homogeneous element block per mesh with its
//! connectivity, the lumped nodal masses, and the boundary conditions and loads as tables
//! over nodes. Built once from a scene by [`crate::analysis::mesh_model`]; the topological
//! plan (which element slots each node sums, notes D §5: fixed in time) is precomputed, and
//! so are the plans of the other assembly strategies ([`super::mesh_plan`]).

use super::mesh_plan::AssemblyPlan;
use super::scene::{
    ElementKind, Fn1, GlueTraction, Material, MeshFormulation, MeshMethod, MeshSolver,
};

/// The meshes of a system (empty for a scene without meshes).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshLayout {
    /// One block per mesh, in scene order.
    pub blocks: Vec<ElementBlock>,
    /// Reference coordinates of every node (world, m), mesh after mesh.
    pub x0: Vec<[f64; 3]>,
    /// Lumped mass of every node (kg).
    pub mass: Vec<f64>,
    /// Per node and component: the displacement is fixed or prescribed (not integrated).
    pub constrained: Vec<[bool; 3]>,
    /// Prescribed displacements `u(t)` on node components.
    pub prescribed: Vec<Prescribed>,
    /// Loads: a force function times a per-node weight.
    pub loads: Vec<LoadGroup>,
    /// Constant nodal forces (body forces; N), empty when there are none.
    pub body_force: Vec<[f64; 3]>,
    /// Winkler foundation springs at nodes.
    pub foundation: Vec<FoundationSpring>,
    /// Node → element force slots, compressed rows: node `n` sums the element forces at
    /// slots `slots[first[n]..first[n + 1]]`, in the canonical order of
    /// [`super::mesh_plan`] (ascending colour, then element: a fixed summation order that
    /// every assembly strategy follows, so results do not depend on the strategy or on the
    /// number of threads).
    pub first: Vec<u32>,
    /// See `first`. A slot is `block.first_slot + element · nodes_per_element + local`.
    pub slots: Vec<u32>,
    /// Node sets tied to bodies (`tie SET, BODY`), in scene order. Their nodes are
    /// `constrained` in every component and have no mass here: it belongs to the body.
    pub ties: Vec<MeshTie>,
    /// The bodies that carry tied nodes, each once (empty without ties).
    pub tied_bodies: Vec<TiedBody>,
    /// Pairs of node sets of two meshes glued by reduced Lagrange multipliers, in scene
    /// order (empty without glues).
    pub glues: Vec<MeshGlue>,
    /// The assembly strategy and its plans (colours, partitions, interface).
    pub assembly: AssemblyPlan,
    /// How the meshes are analysed (the scene's `simulate { mesh_method }`).
    pub method: MeshMethod,
    /// The linear solver of the implicit analyses (the scene's `simulate { solver }`).
    pub solver: MeshSolver,
    /// One rank's part of a distributed explicit run (its elements, the nodes they touch
    /// and the exchange of interface forces with the other ranks,
    /// `crate::analysis::mesh_ranks`); `None` for a whole mesh in one process.
    pub halo: Option<MeshHalo>,
}

/// How one rank's part of a mesh (a [`MeshLayout`] of its own elements and the nodes they
/// touch) completes its interface nodes' force sums with the other ranks' element forces,
/// every step (notes D §5: the communication pattern is fixed in time).
///
/// A node on the interface between ranks sums, like every node, the forces of all the
/// elements around it in the canonical order ([`super::mesh_plan`]); the slots of the
/// elements of other ranks are *ghost slots*, numbered after the part's own slots
/// ([`MeshLayout::total_slots`]` + i`) and filled by the exchange before the node pass. The
/// part's sums, and so its motion, are bitwise those of the whole mesh in one process.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshHalo {
    /// The exchange: three values (a slot's force) per slot sent or received.
    pub exchange: super::ranks::Halo,
    /// The own slots sent, peer after peer (the order the peer's ghost slots expect).
    pub send_slots: Vec<u32>,
    /// Number of ghost slots (what is received, peer after peer).
    pub ghost_slots: usize,
    /// Per node: whether this rank reports it (in energies and output): each node is
    /// reported by the lowest rank that touches it.
    pub owned: Vec<bool>,
    /// Per node of the part: its number in its mesh (what reports name).
    pub node_ids: Vec<u32>,
    /// Per element of the part: its number in its mesh (what reports name).
    pub element_ids: Vec<u32>,
}

impl MeshLayout {
    /// Whether the system has no mesh.
    pub fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }
    /// Number of nodes of all meshes.
    pub fn nodes(&self) -> usize {
        self.x0.len()
    }
    /// Number of element force slots (Σ elements × nodes per element).
    pub fn total_slots(&self) -> usize {
        self.blocks
            .last()
            .map_or(0, |b| b.first_slot + b.elements() * b.kind.nodes())
    }
    /// Number of elements of all meshes.
    pub fn elements(&self) -> usize {
        self.blocks.iter().map(|b| b.elements()).sum()
    }
    /// Whether some mesh has a plastic material.
    pub fn is_plastic(&self) -> bool {
        self.blocks.iter().any(|b| b.material.plastic.is_some())
    }
}

/// The elements of one mesh (one element type and material).
#[derive(Clone, Debug, PartialEq)]
pub struct ElementBlock {
    /// The mesh's name.
    pub name: String,
    /// Element type.
    pub kind: ElementKind,
    /// Material.
    pub material: Material,
    /// 2-D elements: thickness (m); bars: area (m²); solids: unused (1).
    pub thickness: f64,
    /// Quadrature and strain measure (from the mesh's `integration`, `hourglass` and
    /// `strain`).
    pub formulation: MeshFormulation,
    /// Global node index of the mesh's node 0 (its nodes are consecutive).
    pub first_node: usize,
    /// Number of the mesh's nodes.
    pub nodes: usize,
    /// Connectivity, `kind.nodes()` global node indices per element.
    pub conn: Vec<u32>,
    /// Index of the block's first element force slot.
    pub first_slot: usize,
    /// Index of the block's first element in the system's element numbering.
    pub first_element: usize,
}

impl ElementBlock {
    /// Number of elements.
    pub fn elements(&self) -> usize {
        self.conn.len() / self.kind.nodes()
    }
    /// The global node indices of element `e`.
    pub fn element_nodes(&self, e: usize) -> &[u32] {
        let n = self.kind.nodes();
        &self.conn[e * n..(e + 1) * n]
    }
}

/// A prescribed displacement component.
#[derive(Clone, Debug, PartialEq)]
pub struct Prescribed {
    /// Global node index.
    pub node: u32,
    /// Component (0, 1, 2).
    pub dof: u8,
    /// The displacement `u(t)` (m).
    pub value: Fn1,
}

/// A load over nodes: node `nodes[i]` gets `weights[i] · value(t)`.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadGroup {
    /// The force (nodal loads; N) or traction (Pa) components.
    pub value: [Fn1; 3],
    /// Global node indices.
    pub nodes: Vec<u32>,
    /// Weights: 1 for nodal loads, the node's share of the loaded area (m²) for tractions.
    pub weights: Vec<f64>,
}

/// Two node sets of two meshes glued along a common interface (`glue SET, MESH.SET`).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshGlue {
    /// The mesh that writes the glue, and its set.
    pub mesh: String,
    /// See `mesh`.
    pub set: String,
    /// The other mesh, and its set.
    pub other_mesh: String,
    /// See `other_mesh`.
    pub other_set: String,
    /// The set's global nodes.
    pub nodes: Vec<u32>,
    /// The other set's global nodes.
    pub other_nodes: Vec<u32>,
    /// The interface traction's approximation.
    pub traction: GlueTraction,
}

/// A Winkler foundation spring: force `−k (n·u) n` at a node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FoundationSpring {
    /// Global node index.
    pub node: u32,
    /// Stiffness (N/m): modulus × the node's share of the supported area.
    pub k: f64,
    /// Unit normal of the supported faces at the node (reference configuration).
    pub n: [f64; 3],
}

/// A node set tied to a body: its nodes move rigidly with the body, and the mesh's net force
/// on them acts on the body (docs/methods.md, "Meshes tied to bodies").
#[derive(Clone, Debug, PartialEq)]
pub struct MeshTie {
    /// The mesh's name.
    pub mesh: String,
    /// The set's name.
    pub set: String,
    /// The body's index in the layout.
    pub body: usize,
    /// The tied nodes (global indices, increasing).
    pub nodes: Vec<u32>,
    /// Per node: its offset from the body's reference point (the mass centre of the body
    /// with its tied nodes), body axes, m; the node is at `r + C·offset`.
    pub offsets: Vec<[f64; 3]>,
    /// Per node: its lumped mass (kg), which the body carries.
    pub mass: Vec<f64>,
    /// A 2-D mesh: the tie moves the nodes in the plane z = 0 only.
    pub plane: bool,
}

/// A body that carries tied nodes. The system integrates it as one rigid body with the
/// nodes' masses (its mass, inertia and reference point are those of the body with its
/// tied nodes); its own mass centre is `shift` away from that reference point
/// ([`crate::analysis::tie_model::own_centre`] converts a state back to it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TiedBody {
    /// The body's index in the layout.
    pub body: usize,
    /// The reference point (mass centre of body and tied nodes) from the body's own mass
    /// centre, body axes, m.
    pub shift: [f64; 3],
    /// The body's own mass, kg.
    pub own_mass: f64,
    /// The tied nodes' mass it carries, kg.
    pub tied_mass: f64,
}
