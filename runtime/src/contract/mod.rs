//! Floor 0, the contract: what a scene is and what the numerics may ask of it.
//!
//! - [`scene`]: the `Scene` data model, plain serde data in SI units (what the compiler
//!   produces and the interpreter and generated code read).
//! - [`system`]: the `System` trait and its plain data types (`Pose`, `Twist`, `Wrench`,
//!   `MassProps`, `Layout`, `ConstraintEval`, …), the contract between a scene (interpreted
//!   or generated) and the integrators, solvers and writers.
//! - [`joint_geom`]: the constant geometry of one joint (`JointGeom`), and
//!   [`joint_kernel`]: the one enum of joint kernels (`JointKernel`) that the interpreter,
//!   the compiled tables, the code generator and natural partitioning share.
//! - [`mesh_layout`]: finite-element meshes flattened for the explicit method (`MeshLayout`),
//!   and [`mesh_plan`]: the assembly strategies and their plans.
//! - [`math`]: rotation math (Euler parameters, rotation matrices, the Cayley update).
//! - [`fnv`]: FNV-1a, the stable hash of scene keys and checkpoint identities.
//! - [`ranks`]: the processes of a distributed run as the numerics see them (the `Ranks`
//!   trait: sum, neighbour exchange, gather), and [`thread_ranks`]: ranks as threads of one
//!   process, the engine that needs no MPI.
//! - [`persist`]: the state a run carries between steps, saved and loaded by one visitor
//!   (checkpoints and bit-identical restart).
//!
//! **Imports nothing else of the crate.** Everything above builds on these types; nothing
//! here may know a kernel, an integrator or a writer.

pub mod fnv;
pub mod joint_geom;
pub mod joint_kernel;
pub mod math;
pub mod mesh_layout;
pub mod mesh_plan;
pub mod persist;
pub mod ranks;
pub mod scene;
pub mod system;
pub mod thread_ranks;
