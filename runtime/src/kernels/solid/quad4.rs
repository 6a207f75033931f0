//! Four-node quadrilateral, plane stress or plane strain, thickness `t`; bilinear
//! isoparametric, nodes counter-clockwise.
//!
//! - `Integration::Full { bbar }`: 2×2 Gauss. B-bar (mean dilatation, see `continuum`) is
//!   applied in plane strain only: plane stress does not lock (σ_zz = 0 leaves the
//!   thickness free), so `bbar` is ignored there.
//! - `Integration::Reduced(hg)`: one point with the element-mean gradients (the uniform
//!   strain quadrilateral of Flanagan & Belytschko, mean computed exactly by 2×2 Gauss) and
//!   hourglass control on the mode ξη (see `hourglass`).
//!
//! `min_jacobian`: the deformed `det J` at the Gauss points (full) or at the centroid
//! (reduced); `det J = A/4` on a parallelogram. z components of the inputs are ignored.

use super::continuum::{
    current, det3, finish, flatten, gradients, integrate, jacobian, plane_law, plane_outputs,
    quad4_dn, quad4_gauss, quad4_n, PointLaw, QUAD4_NODES, V3,
};
use super::hourglass::{apply, bb, gammas, QUAD4_H};
use super::{Elastic, ElementOptions, ElementResponse, Hourglass, Integration, Plane};

/// Element-mean gradients `(1/A) ∫ ∇N_a dA` and the area `A` (exact by 2×2 Gauss).
pub(super) fn mean_gradients(x0: &[V3; 4]) -> ([V3; 4], f64) {
    let mut b = [[0.0; 3]; 4];
    let mut area = 0.0;
    for q in 0..4 {
        let (xi, eta) = quad4_gauss(q);
        let (g, det) = gradients(x0, &quad4_dn(xi, eta), true);
        area += det;
        for (ba, ga) in b.iter_mut().zip(g.iter()) {
            for i in 0..3 {
                ba[i] += det * ga[i];
            }
        }
    }
    for ba in b.iter_mut() {
        for x in ba.iter_mut() {
            *x /= area;
        }
    }
    (b, area)
}

/// `det J` at the four corners (x, y only): all positive for a convex counter-clockwise
/// quadrilateral.
pub fn corner_jacobians(x: &[[f64; 3]; 4]) -> [f64; 4] {
    let mut d = [0.0; 4];
    for (da, s) in d.iter_mut().zip(QUAD4_NODES.iter()) {
        *da = det3(&jacobian(x, &quad4_dn(s[0], s[1]), true));
    }
    d
}

/// Internal forces, stress and hourglass terms of one quadrilateral; `plane` is
/// authoritative (`opts.plane` is not read).
pub fn respond(
    opts: &ElementOptions,
    mat: &Elastic,
    plane: Plane,
    x0: &[[f64; 3]; 4],
    u: &[[f64; 3]; 4],
    v: &[[f64; 3]; 4],
    out: &mut ElementResponse,
) {
    respond_with(opts, mat, plane, &mut plane_law(plane, mat), x0, u, v, out);
}

/// [`respond`] with the stress at the integration points (4, or 1 when reduced) from
/// `law`; the hourglass control stays elastic (its stiffness from `mat`). Returns the
/// volume (area × thickness).
#[allow(clippy::too_many_arguments)] // respond's arguments and the law
pub(super) fn respond_with<L: PointLaw>(
    opts: &ElementOptions,
    mat: &Elastic,
    plane: Plane,
    law: &mut L,
    x0: &[[f64; 3]; 4],
    u: &[[f64; 3]; 4],
    v: &[[f64; 3]; 4],
    out: &mut ElementResponse,
) -> f64 {
    match opts.integration {
        Integration::Full { bbar } => full_with(opts, mat, plane, law, bbar, x0, u, out),
        Integration::Reduced(hg) => reduced_with(opts, mat, plane, law, hg, x0, u, v, out),
    }
}

/// [`respond_with`] with full 2×2 quadrature (B-bar when `bbar`, in plane strain only),
/// whatever `opts.integration` says.
#[allow(clippy::too_many_arguments)] // respond's arguments, the law and the flag
pub(super) fn full_with<L: PointLaw>(
    opts: &ElementOptions,
    mat: &Elastic,
    plane: Plane,
    law: &mut L,
    bbar: bool,
    x0: &[[f64; 3]; 4],
    u: &[[f64; 3]; 4],
    out: &mut ElementResponse,
) -> f64 {
    let (x0, u) = (flatten(x0), flatten(u));
    let t = opts.thickness;
    let xc = current(&x0, &u);
    let mut f = [[0.0; 3]; 4];
    let mut g = [[[0.0; 3]; 4]; 4];
    let mut w = [0.0; 4];
    let mut min_j = f64::INFINITY;
    for q in 0..4 {
        let (xi, eta) = quad4_gauss(q);
        let dn = quad4_dn(xi, eta);
        let (gq, det) = gradients(&x0, &dn, true);
        g[q] = gq;
        w[q] = det * t;
        min_j = min_j.min(det3(&jacobian(&xc, &dn, true)));
    }
    let bbar = bbar && plane == Plane::Strain;
    let sums = integrate(opts.kinematics, law, &g, &w, &u, bbar, &mut f);
    finish(&f, &sums, out);
    out.hourglass_energy = 0.0;
    out.hourglass_power = 0.0;
    out.min_jacobian = min_j;
    plane_outputs(plane, mat, out);
    sums.volume
}

/// [`respond_with`] with one point and hourglass control `hg`, whatever
/// `opts.integration` says.
#[allow(clippy::too_many_arguments)] // respond's arguments, the law and the control
pub(super) fn reduced_with<L: PointLaw>(
    opts: &ElementOptions,
    mat: &Elastic,
    plane: Plane,
    law: &mut L,
    hg: Hourglass,
    x0: &[[f64; 3]; 4],
    u: &[[f64; 3]; 4],
    v: &[[f64; 3]; 4],
    out: &mut ElementResponse,
) -> f64 {
    let (x0, u, v) = (flatten(x0), flatten(u), flatten(v));
    let elastic = plane_law(plane, mat);
    let t = opts.thickness;
    let xc = current(&x0, &u);
    let mut f = [[0.0; 3]; 4];
    let (b, area) = mean_gradients(&x0);
    let sums = integrate(opts.kinematics, law, &[b], &[area * t], &u, false, &mut f);
    let gam = gammas(&QUAD4_H, &x0, &b);
    let m = elastic.lambda + 2.0 * elastic.mu;
    let c_s = m * t * area * bb(&b) / 2.0;
    let c_v = (m * mat.rho).sqrt() * t * area.sqrt() / 2.0;
    let (e, p) = apply(hg, &gam, c_s, c_v, &u, &v, &mut f);
    finish(&f, &sums, out);
    out.hourglass_energy = e;
    out.hourglass_power = p;
    out.min_jacobian = det3(&jacobian(&xc, &quad4_dn(0.0, 0.0), true));
    plane_outputs(plane, mat, out);
    sums.volume
}

/// Row-sum lumped masses `ρ t ∫ N_a dA` (exact by 2×2 Gauss; equal quarters on a
/// parallelogram).
pub fn lumped_masses(rho: f64, thickness: f64, x0: &[[f64; 3]; 4]) -> [f64; 4] {
    let mut m = [0.0; 4];
    for q in 0..4 {
        let (xi, eta) = quad4_gauss(q);
        let det = det3(&jacobian(x0, &quad4_dn(xi, eta), true));
        for (ma, na) in m.iter_mut().zip(quad4_n(xi, eta).iter()) {
            *ma += rho * thickness * det * na;
        }
    }
    m
}
