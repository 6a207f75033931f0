//! Four-node tetrahedron (constant strain).
//!
//! With the edge vectors `a = X₁ − X₀`, `b = X₂ − X₀`, `c = X₃ − X₀`, `det J = (a × b)·c = 6V`
//! (positive for the orientation of [`ElementKind::faces`](crate::contract::scene::ElementKind::faces)),
//! the gradients are the rows of `J⁻¹`: `∇N₁ = (b × c)/det J`, `∇N₂ = (c × a)/det J`,
//! `∇N₃ = (a × b)/det J`, `∇N₀ = −Σ`; one point of weight V.

use super::continuum::{current, finish, integrate, ElasticLaw, PointLaw, V3};
use super::{Elastic, ElementOptions, ElementResponse};

#[inline]
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline]
fn edges(x: &[V3; 4]) -> [V3; 3] {
    let mut e = [[0.0; 3]; 3];
    for (k, ek) in e.iter_mut().enumerate() {
        for i in 0..3 {
            ek[i] = x[k + 1][i] - x[0][i];
        }
    }
    e
}

/// `det J = 6V`: positive for a positively oriented tetrahedron.
#[inline]
pub fn jacobian(x: &[[f64; 3]; 4]) -> f64 {
    let [a, b, c] = edges(x);
    let n = cross(a, b);
    n[0] * c[0] + n[1] * c[1] + n[2] * c[2]
}

/// Reference gradients and volume.
#[inline]
pub(super) fn gradients(x0: &[V3; 4]) -> ([V3; 4], f64) {
    let [a, b, c] = edges(x0);
    let (bc, ca, ab) = (cross(b, c), cross(c, a), cross(a, b));
    let det = ab[0] * c[0] + ab[1] * c[1] + ab[2] * c[2];
    let mut g = [[0.0; 3]; 4];
    for i in 0..3 {
        g[1][i] = bc[i] / det;
        g[2][i] = ca[i] / det;
        g[3][i] = ab[i] / det;
        g[0][i] = -g[1][i] - g[2][i] - g[3][i];
    }
    (g, det / 6.0)
}

/// Internal forces and stress of one tetrahedron.
pub fn respond(
    opts: &ElementOptions,
    mat: &Elastic,
    x0: &[[f64; 3]; 4],
    u: &[[f64; 3]; 4],
    v: &[[f64; 3]; 4],
    out: &mut ElementResponse,
) {
    let mut law = ElasticLaw {
        lambda: mat.lambda,
        mu: mat.mu,
    };
    respond_with(opts, &mut law, x0, u, v, out);
}

/// [`respond`] with the stress from `law` at the one point; returns the volume.
pub(super) fn respond_with<L: PointLaw>(
    opts: &ElementOptions,
    law: &mut L,
    x0: &[[f64; 3]; 4],
    u: &[[f64; 3]; 4],
    _v: &[[f64; 3]; 4],
    out: &mut ElementResponse,
) -> f64 {
    let (g, vol) = gradients(x0);
    let mut f = [[0.0; 3]; 4];
    let sums = integrate(opts.kinematics, law, &[g], &[vol], u, false, &mut f);
    finish(&f, &sums, out);
    out.hourglass_energy = 0.0;
    out.hourglass_power = 0.0;
    out.min_jacobian = jacobian(&current(x0, u));
    sums.volume
}

/// Equal quarters of `ρ V`.
pub fn lumped_masses(rho: f64, x0: &[[f64; 3]; 4]) -> [f64; 4] {
    [rho * jacobian(x0).abs() / 24.0; 4]
}
