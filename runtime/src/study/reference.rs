//! What a reference solution is: for each body it knows, the mass-centre position and/or the
//! orientation at any time a run has a frame. The kinds: [`Analytic`](super::Analytic) (the
//! scene's functions of time), [`Table`](super::Table) (the scene's table),
//! [`Sampled`](super::Sampled) (a numerical reference run).

use super::error::ReferenceError;

/// What a reference knows about one body at one time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RefBody {
    /// Mass-centre position, world, m.
    pub r: Option<[f64; 3]>,
    /// Orientation, unit quaternion body → world.
    pub q: Option<[f64; 4]>,
}

/// A reference solution.
pub trait RefSolution {
    /// Fill `out` (one entry per scene body) with the reference at time `t`.
    ///
    /// # Errors
    /// If the reference does not cover `t` (a table that ends early, a time that was not
    /// sampled), or its value there is not a state (a zero quaternion).
    fn at(&self, t: f64, out: &mut [RefBody]) -> Result<(), ReferenceError>;
}

/// Times closer than this (relative to max(1, |t|)) are the same frame time.
pub(super) const SAME_TIME: f64 = 1e-9;
