//! # mbdc-runtime: the numerics
//!
//! **What it is.** Everything a simulation needs once a scene is known: the [`scene::Scene`]
//! data model (plain serde data, SI units), the [`system::System`] trait that interpreted
//! and generated scenes implement, rotation math, joint, force and contact kernels, analysis
//! of a scene before it runs (topology, step limits, input limits), the integrators
//! (staggered explicit–implicit and the comparison methods), linear solvers, the run driver
//! with its watchdog and writers, the interpreter, the support generated code links to, and
//! the accuracy-study engine.
//!
//! **What it must never know.** Text. No `.mbd` syntax, no spans beyond the opaque
//! [`scene::Origin`] tags, no dependency on `mbdc-dsl` or `mbdc-compiler`, no terminal,
//! no command line. Generated code uses only this crate's public API, so anything it needs is
//! a documented item here.
//!
//! ## Floors
//!
//! The source is in floors, one folder each. A floor imports only the floors below it (and
//! itself); no two modules of a floor import each other in a circle. A test
//! (`tests/tests/architecture.rs`) enforces both. From the bottom:
//!
//! | floor | folder | what | may import |
//! |---|---|---|---|
//! | 0 | `contract/` | `scene` (plain data), `system` (the `System` trait and its plain data types, [`system::JointKernel`], [`system::JointGeom`]), `math` | nothing of the crate |
//! | 1 | `kernels/` | joints, tree joints (natural-partitioning blocks), forces, contact, time functions | contract |
//! | 2 | `linalg/` | dense and sparse symmetric solvers, LU, column selection | contract |
//! | 3 | `analysis/` | topology, independent coordinates, effects, step limits, input limits | the floors below |
//! | 4 | `integrators/` | the time-stepping methods | the floors below |
//! | 5 | `driver/` | run loop and watchdog, output writers, assembly, energy | the floors below |
//! | 6 | `interp/` | the interpreter: a `System` from a `Scene` at run time | the floors below |
//! | 7 | `compiled/` | what generated code links to: the structure/numbers split, `CompiledModel` | the floors below |
//! | 8 | `app/` | the program entry of a compiled scene (`mbdc run`'s protocol) | the floors below |
//! | 9 | `study/` | the accuracy study: step series, references, order fits | the floors below |
//!
//! (Linear algebra sits below analysis because the topology's rank test factors the
//! constraint Jacobian; it needs only the contract.)
//!
//! **Where new things go.** A flexible-beam or solid element's internal force: a kernel,
//! [`beam_element`] (`kernels/beam_element.rs`, there), `kernels/solid_element.rs`; its
//! data in `contract/scene.rs`;
//! its step limit in `analysis/step_limits.rs`. A new integrator: a file (or folder) in
//! `integrators/`, chosen in `integrators::make`. A new writer: `driver/output/`. A new joint
//! kind: its kernel in `kernels/joints.rs`, its `Scene` variant
//! ([`scene::JointKind`]), its [`system::JointKernel`] and the compiler's lowering; the
//! interpreter, the compiled tables and the code generator follow the kernel enum.
//!
//! ## API boundary
//!
//! The floors are private; this façade re-exports the modules that generated code, the
//! compiler and the `mbdc` program use, under one flat name each:
//!
//! - data in: [`scene`]; the contract: [`system`], [`math`];
//! - kernels (called by generated code): [`joints`], [`tree_joints`], [`forces`],
//!   [`contact`], [`fn1`], [`beam_element`];
//! - before a run: [`topology`], [`coordinates`], [`effects`], [`step_limits`] (with
//!   [`constrained_modes`], the constrained system's fastest mode),
//!   [`input_limits`], [`beam_model`] (beams as bodies), [`mesh_model`] (meshes for the
//!   explicit method), [`mesh_stiffness`] (their assembled stiffness for the implicit
//!   analyses), [`tie_model`] (meshes tied to bodies);
//! - running: [`linalg`], [`integrators`] (`integrators::make` builds the method a scene
//!   asks for), [`run_loop`] (advance a `System` and stream frames to writers), [`output`],
//!   [`assemble`], [`energy`];
//! - entry points: [`interp::Interp`] (a `System` from a `Scene`), [`compiled`] (the
//!   [`compiled::CompiledModel`] trait generated models implement), [`app`] (the program
//!   entry of a compiled scene), [`study`] (a work–precision study from Rust code).

mod analysis;
mod contract;
mod driver;
mod kernels;

pub mod app;
pub mod compiled;
pub mod integrators;
pub mod interp;
pub mod linalg;
pub mod study;

pub use analysis::{
    beam_model, constrained_modes, coordinates, effects, input_limits, mesh_model, mesh_partition,
    mesh_ranks, mesh_stiffness, mesh_subdomains, step_limits, tie_model, topology,
};
pub use contract::{math, mesh_layout, mesh_plan, persist, ranks, scene, system, thread_ranks};
pub use driver::{assemble, checkpoint, energy, output, ranked, run_loop};
pub use kernels::{beam_element, contact, fn1, forces, joints, solid, traction_basis, tree_joints};

/// The linear-algebra crate of the runtime's types ([`system::Pose`] etc.), re-exported so
/// that generated code depends on this crate only.
pub use nalgebra;
