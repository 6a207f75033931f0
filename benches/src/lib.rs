//! Benchmarks of mbdc (see `BENCHMARKS.md`, section "Generated code"): the generated code of
//! three scenes (written by `build.rs` through the `build.rs` API, in both layouts) and the
//! hand-written [`yardstick`] for the 3-D double pendulum. The measurements are in the binary
//! (`cargo run --release -p mbdc-bench -- help`).

pub mod yardstick;

/// The generated models: `double_pendulum_3d_{unrolled,tables}`, `four_bar_…`, `chain32_…`,
/// `beam1000`.
pub mod generated {
    include!(concat!(env!("OUT_DIR"), "/models.rs"));
}
