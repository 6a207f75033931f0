//! Floor 5, the driver: running a `System` with an integrator from start to end.
//!
//! - [`run_loop`]: the run loop and its watchdog (stops a run that goes wrong, naming the
//!   body or joint and the time), frames streamed to observers.
//! - [`output`]: the writers (CSV time series, `summary.json`).
//! - [`assemble`]: assembly of a consistent initial state (Newton on the position and
//!   velocity constraints).
//! - [`energy`]: kinetic energy and momenta of a state.
//! - [`work`]: the work of non-conservative forces and drivers, for the energy balance.
//! - [`checkpoint`]: checkpoint files (identity, atomic write, CRC) for bit-identical
//!   restart.
//! - [`ranked`]: a run across the ranks of a distributed engine: a rank's part of a system,
//!   and rank 0 gathering the parts into the one output folder.
//!
//! Imports every floor below (contract, kernels, linalg, analysis, integrators); knows
//! neither the interpreter nor generated code: it drives any `System`.

pub mod assemble;
pub mod checkpoint;
pub mod energy;
pub mod output;
pub mod ranked;
pub mod run_loop;
pub mod work;
