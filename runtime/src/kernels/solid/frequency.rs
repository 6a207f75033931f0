//! The highest undamped frequency of one element with lumped mass, for the central
//! difference limit `h ≤ 2/ω_max` (notes D §1.1).
//!
//! By Irons' element-eigenvalue bound, the highest frequency of the assembled mesh is at most
//! the largest element value, `ω_max ≤ max_e ω_max^(e)`, so the global stable step is
//! `h ≤ 2 / max_e ω_max^(e)` (times a safety factor chosen by the integrator).
//!
//! - bar2: `2c/L` in closed form (exact with lumped mass).
//! - The others: the element stiffness `K_e` (small strain at the reference configuration,
//!   with the B-bar option and the hourglass *stiffness* of reduced elements; the viscous
//!   form adds no stiffness) is [`super::element_stiffness`] (formed column by column from
//!   `respond` with unit displacements: exact, not finite differences), then `ω² = λ_max(M^{-1/2} K M^{-1/2})` by nalgebra's symmetric
//!   eigenvalues on a stack matrix of the element's size (6, 8, 12 or 24; no heap). The
//!   result is raised by a relative 1e-10 so that eigen-solver round-off cannot make it an
//!   underestimate.

use super::stiffness::element_stiffness;
use super::{lumped_masses, Elastic, ElementOptions};
use crate::contract::scene::ElementKind;
use nalgebra::SMatrix;

/// Largest symmetric-eigenvalue of the leading `n × n` block of `a` (n ∈ {6, 8, 12, 24}).
fn largest_eigenvalue(a: &[[f64; 24]; 24], n: usize) -> f64 {
    macro_rules! eig {
        ($n:literal) => {
            SMatrix::<f64, $n, $n>::from_fn(|r, c| a[r][c])
                .symmetric_eigenvalues()
                .max()
        };
    }
    match n {
        6 => eig!(6),
        8 => eig!(8),
        12 => eig!(12),
        24 => eig!(24),
        _ => unreachable!("solid element with {n} degrees of freedom"),
    }
}

/// See the module doc.
pub(super) fn max_frequency(
    kind: ElementKind,
    opts: &ElementOptions,
    mat: &Elastic,
    x0: &[[f64; 3]],
) -> f64 {
    if kind == ElementKind::Bar2 {
        return super::bar2::max_frequency(mat, super::nodes(x0));
    }
    let (n, d) = (kind.nodes(), kind.dim());
    let dofs = n * d;
    let m = lumped_masses(kind, opts, mat.rho, x0);
    let k = element_stiffness(kind, opts, mat, x0);
    // Scale (K is symmetric): A = M^{-1/2} K M^{-1/2}.
    let mut s = [0.0; 24];
    for r in 0..dofs {
        s[r] = 1.0 / m[r / d].sqrt();
    }
    let mut a = [[0.0; 24]; 24];
    for r in 0..dofs {
        for c in 0..dofs {
            a[r][c] = k[r][c] * s[r] * s[c];
        }
    }
    largest_eigenvalue(&a, dofs).max(0.0).sqrt() * (1.0 + 1e-10)
}
