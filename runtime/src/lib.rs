//! # mbdc-runtime: the numerics
//!
//! **What it is.** Everything a simulation needs once a scene is known: the [`scene::Scene`]
//! data model (plain serde data, SI units), the [`system::System`] trait that interpreted
//! and generated scenes implement, rotation math, joint and force kernels, topology analysis,
//! the integrators (staggered explicit–implicit and the comparison methods), linear solvers,
//! output writers and the run driver.
//!
//! **What it must never know.** Text. No `.mbd` syntax, no spans beyond the opaque
//! [`scene::Origin`] tags, no dependency on `mbdc-dsl` or `mbdc-compiler`. Generated code
//! uses only this crate's public API, so anything it needs is a documented function here.
//!
//! **API boundary.** `scene` (data in), `system` (the contract), `interp::Interp` (a
//! `System` from a `Scene`), the integrators and `run` (advance a `System` and stream
//! frames to writers), `output` (CSV and `summary.json`), `compiled` (the split of a scene
//! into the structure generated code is specialized on and the numbers it loads, and the
//! [`compiled::CompiledModel`] trait generated models implement) and `app` (the program
//! entry of a compiled scene).

pub mod app;
pub mod assemble;
pub mod compiled;
pub mod contact;
pub mod energy;
pub mod fn1;
pub mod forces;
pub mod integrators;
pub mod interp;
pub mod joints;
pub mod limits;
pub mod linalg;
pub mod math;
pub mod output;
pub mod run;
pub mod scene;
pub mod stability;
pub mod study;
pub mod system;
pub mod topology;

/// The linear-algebra crate of the runtime's types ([`system::Pose`] etc.), re-exported so
/// that generated code depends on this crate only.
pub use nalgebra;
