//! Three-node triangle (constant strain), plane stress or plane strain, thickness `t`.
//!
//! Gradients from the reference coordinates: with `a = X₁ − X₀`, `b = X₂ − X₀` and
//! `det J = a_x b_y − a_y b_x = 2A` (positive for counter-clockwise nodes),
//! `∇N₁ = (b_y, −b_x)/det J`, `∇N₂ = (−a_y, a_x)/det J`, `∇N₀ = −∇N₁ − ∇N₂`; one point of
//! weight `A t`. z components of the inputs are ignored and the z forces are 0.

use super::continuum::{
    current, finish, flatten, integrate, plane_law, plane_outputs, PointLaw, V3,
};
use super::{Elastic, ElementOptions, ElementResponse, Plane};

/// `det J = 2A` of the triangle (x, y only): positive when counter-clockwise.
#[inline]
pub fn jacobian(x: &[[f64; 3]; 3]) -> f64 {
    let (a, b) = edges(x);
    a[0] * b[1] - a[1] * b[0]
}

#[inline]
fn edges(x: &[[f64; 3]; 3]) -> (V3, V3) {
    (
        [x[1][0] - x[0][0], x[1][1] - x[0][1], 0.0],
        [x[2][0] - x[0][0], x[2][1] - x[0][1], 0.0],
    )
}

/// Reference gradients and area.
#[inline]
pub(super) fn gradients(x0: &[[f64; 3]; 3]) -> ([V3; 3], f64) {
    let (a, b) = edges(x0);
    let det = a[0] * b[1] - a[1] * b[0];
    let g1 = [b[1] / det, -b[0] / det, 0.0];
    let g2 = [-a[1] / det, a[0] / det, 0.0];
    ([[-g1[0] - g2[0], -g1[1] - g2[1], 0.0], g1, g2], 0.5 * det)
}

/// Internal forces and stress of one triangle; `plane` is authoritative (`opts.plane` is
/// not read).
pub fn respond(
    opts: &ElementOptions,
    mat: &Elastic,
    plane: Plane,
    x0: &[[f64; 3]; 3],
    u: &[[f64; 3]; 3],
    v: &[[f64; 3]; 3],
    out: &mut ElementResponse,
) {
    respond_with(opts, mat, plane, &mut plane_law(plane, mat), x0, u, v, out);
}

/// [`respond`] with the stress from `law` at the one point; returns the element's volume
/// (area × thickness).
#[allow(clippy::too_many_arguments)] // respond's arguments and the law
pub(super) fn respond_with<L: PointLaw>(
    opts: &ElementOptions,
    mat: &Elastic,
    plane: Plane,
    law: &mut L,
    x0: &[[f64; 3]; 3],
    u: &[[f64; 3]; 3],
    _v: &[[f64; 3]; 3],
    out: &mut ElementResponse,
) -> f64 {
    let u = flatten(u);
    let (g, area) = gradients(x0);
    let mut f = [[0.0; 3]; 3];
    let sums = integrate(
        opts.kinematics,
        law,
        &[g],
        &[area * opts.thickness],
        &u,
        false,
        &mut f,
    );
    finish(&f, &sums, out);
    plane_outputs(plane, mat, out);
    out.hourglass_energy = 0.0;
    out.hourglass_power = 0.0;
    out.min_jacobian = jacobian(&current(x0, &u));
    sums.volume
}

/// Equal thirds of `ρ A t`.
pub fn lumped_masses(rho: f64, thickness: f64, x0: &[[f64; 3]; 3]) -> [f64; 3] {
    [rho * 0.5 * jacobian(x0).abs() * thickness / 3.0; 3]
}
