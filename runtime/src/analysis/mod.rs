//! Floor 3, analysis: what can be known about a scene before it runs.
//!
//! - [`topology`]: the joint graph — spanning tree, cut joints, branches, levels, degrees of
//!   freedom, redundant joints (rank of the constraint Jacobian at t = 0).
//! - [`beam_model`]: beams as bodies — nodes with their lumped inertia, clamps and pins as
//!   joints, and the table of elements between them.
//! - [`mesh_model`]: finite-element meshes flattened for the explicit method (nodes,
//!   element blocks, lumped masses, conditions as node tables) and their critical step;
//!   [`assembly_plan`]: the plans of the assembly strategies (colours, canonical order,
//!   partitions); [`mesh_stiffness`]: their assembled linear stiffness with the fixed and
//!   prescribed dofs eliminated, for the implicit analyses (Newmark, static);
//!   [`mesh_partition`]: a mesh split into subdomains (recursive coordinate bisection) and
//!   the papers' partition metrics (`mbdc check --partition P`); [`mesh_subdomains`]: the
//!   meshes torn into subdomains for FETI (their stiffness, interface multipliers and
//!   rigid-body modes); [`mesh_ranks`]: the meshes split between the ranks of a
//!   distributed explicit run (each rank's elements and nodes, the interface exchange).
//! - [`tie_model`]: node sets of meshes tied to bodies — the bodies with their tied nodes'
//!   inertia (reference point at the joint mass centre), the tied nodes as constrained,
//!   massless mesh nodes.
//! - [`coordinates`]: the independent coordinates natural partitioning uses, per tree joint
//!   (what `mbdc check --topology` prints).
//! - [`effects`]: the effects a scene uses (gravity, springs, contact, closed loops, …): the
//!   interpreter and the generated code contain only these.
//! - [`step_limits`]: the fastest motion of a scene and the step limits it sets (explicit
//!   stability `h·ω_max ≤ 2`, 20 steps per period for accuracy).
//! - [`constrained_modes`]: the fastest mode of the constrained system linearized at t = 0
//!   (mass and stiffness projected onto the constraint null space), which
//!   [`step_limits::estimate_system`] adds to the scene's sources.
//! - [`input_limits`]: the sizes and values the runtime accepts, checked before a run.
//!
//! Imports the contract, the kernels and linear algebra; knows no integrator and no writer.

pub mod assembly_plan;
pub mod beam_model;
pub mod constrained_modes;
pub mod coordinates;
pub mod effects;
pub mod input_limits;
pub mod mesh_model;
pub mod mesh_partition;
pub mod mesh_ranks;
pub mod mesh_stiffness;
pub mod mesh_subdomains;
pub mod step_limits;
pub mod tie_model;
pub mod topology;
