//! How the element forces of the meshes are summed at the nodes (notes D §6.3): the
//! strategies, the options that fix their plans, and the plans themselves, built once with
//! the layout by [`crate::analysis::mesh_model`] (the communication pattern is fixed in
//! time, notes D §5) and executed every step by the integrator's assembly.
//!
//! **One summation order for all.** Every strategy computes, per node and component,
//! `f = (f_ext + f_foundation) − f_e₁ − f_e₂ − …` one subtraction at a time, with the
//! contributing elements in the *canonical order*: ascending colour of the element's colour
//! group, then ascending element index. The node-centric gather's plan lists each node's
//! slots in that order, colouring reaches the node colour after colour, and a partition
//! evaluates its elements in that order (interface nodes are summed from their slots in
//! that order). So the strategies give **bitwise the same forces**, and each gives bitwise
//! the same for any number of threads: nothing depends on which thread runs what.

/// A race-free assembly strategy (notes D §6.3). All give bitwise the same results; they
/// differ in memory traffic and in how the work divides between threads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Assembly {
    /// Node-centric gather (strategy B): every element writes its nodal forces into its own
    /// slots, then every node sums its slots in the plan's order. Two passes over
    /// `Σ nodes per element` slots; no shared writes; both passes split evenly for any
    /// number of threads. The default: in BENCHMARKS.md "The assembly strategies side by
    /// side" the others are no faster beyond the noise, and slower where the step is
    /// bandwidth-bound.
    #[default]
    Gather,
    /// Colouring (strategy D): colour after colour, the elements of a colour (node-disjoint
    /// groups) evaluate in parallel and subtract their forces from the nodal sums directly.
    /// No slots, but every colour is a sweep over the mesh.
    Colouring,
    /// Per-thread partitions with an interface sum (strategy E, substructuring): the
    /// elements split into a fixed number of contiguous partitions (fixed by the mesh, not
    /// by the threads); each partition, in parallel, subtracts its forces from
    /// its interior nodes directly and writes those at interface nodes to interface slots,
    /// which are then summed per node in partition-independent fixed order.
    Partitions,
}

impl Assembly {
    /// Every strategy, the default first.
    pub const ALL: [Assembly; 3] = [Assembly::Gather, Assembly::Colouring, Assembly::Partitions];

    /// A short name (`gather`, `colouring`, `partitions`).
    pub fn name(self) -> &'static str {
        match self {
            Assembly::Gather => "gather",
            Assembly::Colouring => "colouring",
            Assembly::Partitions => "partitions",
        }
    }
}

/// What fixes the assembly plans of a layout. The plans, and so the canonical summation
/// order, depend on these options and on the mesh only — never on the number of threads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AssemblyOptions {
    /// The strategy the integrator runs (every plan is built whatever it is, so that a
    /// layout's strategy can be switched on a copy).
    pub strategy: Assembly,
    /// Elements per colour group: runs of this many consecutive elements are coloured as
    /// one (1: plain element colouring). Larger groups keep the neighbouring elements of a
    /// run together (their shared nodes stay in cache) and need fewer colours, at the price
    /// of coarser parallel work.
    pub colour_group: usize,
    /// The fewest elements per partition.
    pub partition_elements: usize,
    /// The most partitions of a block.
    pub max_partitions: usize,
    /// The largest share of a block's nodes that may lie on the partitions' interface: a
    /// block gets the most partitions (a power of two, within the two limits above) that
    /// keeps its interface nodes within this share.
    pub max_interface: f64,
}

impl Default for AssemblyOptions {
    /// The measured choice (BENCHMARKS.md "The assembly strategies side by side").
    fn default() -> Self {
        AssemblyOptions {
            strategy: Assembly::default(),
            colour_group: 256,
            partition_elements: 2048,
            max_partitions: 64,
            max_interface: 0.1,
        }
    }
}

/// The assembly plans of a layout.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AssemblyPlan {
    /// The options the plans were built with (and the strategy to run).
    pub options: AssemblyOptions,
    /// One plan per element block, in block order.
    pub blocks: Vec<BlockPlan>,
    /// Partitions: the interface nodes (global indices, ascending), those touched by the
    /// elements of more than one partition of their block.
    pub interface_nodes: Vec<u32>,
    /// Partitions: interface node `i` sums interface slots
    /// `interface_first[i]..interface_first[i + 1]`, in that (the canonical) order.
    pub interface_first: Vec<u32>,
}

impl AssemblyPlan {
    /// The strategy to run.
    pub fn strategy(&self) -> Assembly {
        self.options.strategy
    }
    /// Number of interface slots (the partitions' forces at interface nodes).
    pub fn interface_slots(&self) -> usize {
        self.interface_first.last().map_or(0, |&s| s as usize)
    }
}

/// Marks an interface slot in [`BlockPlan::targets`].
pub const INTERFACE: u32 = 1 << 31;

/// The plans of one element block (its nodes belong to no other block).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BlockPlan {
    /// Elements per colour group (the last group may be shorter).
    pub group: usize,
    /// Number of colours.
    pub colours: usize,
    /// The colour of each group: no two groups of one colour share a node.
    pub group_colour: Vec<u32>,
    /// Partitions: element `parts[p]..parts[p + 1]` (block numbering) form partition `p`.
    pub parts: Vec<u32>,
    /// Partitions: the block's elements partition after partition, each partition's in the
    /// canonical order (ascending colour, then element).
    pub order: Vec<u32>,
    /// Partitions: where slot `e · nodes_per_element + a` (block numbering) goes: the
    /// global index of an interior node, or [`INTERFACE`] `|` an interface slot.
    pub targets: Vec<u32>,
}

impl BlockPlan {
    /// The colour of element `e` (block numbering).
    pub fn colour(&self, e: usize) -> u32 {
        self.group_colour[e / self.group]
    }
    /// Number of partitions.
    pub fn partitions(&self) -> usize {
        self.parts.len().saturating_sub(1)
    }
}
