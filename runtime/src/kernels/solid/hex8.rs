//! Eight-node hexahedron, trilinear isoparametric (bottom face 0-1-2-3 counter-clockwise
//! seen from +z, top 4-5-6-7 above them).
//!
//! - `Integration::Full { bbar }`: 2×2×2 Gauss, optionally B-bar / mean dilatation (see
//!   `continuum`) against volumetric locking.
//! - `Integration::Reduced(hg)`: the Flanagan–Belytschko uniform-strain hexahedron: one
//!   point with the element-mean gradients `b_a = (1/V) ∫ ∇N_a dV` (computed exactly by the
//!   2×2×2 rule — the integrand is quadratic in each natural coordinate; FB's closed-form
//!   `b = (1/V) ∂V/∂x` would be cheaper and gives the same numbers) and hourglass control
//!   on the four modes ηζ, ξζ, ξη, ξηζ (see `hourglass`). Its geometric data (b, V, γ) depend
//!   on the reference configuration only.
//!
//! `min_jacobian`: the deformed `det J` at the 8 Gauss points (full) or at the centroid
//! (reduced; a hourglassed element can invert at a corner before its centroid does);
//! `det J = V/8` on a parallelepiped.

use super::continuum::{
    current, det3, finish, gradients, hex8_dn, hex8_gauss, hex8_n, integrate, jacobian, ElasticLaw,
    PointLaw, HEX8_NODES, V3,
};
use super::hourglass::{apply, bb, gammas, HEX8_H};
use super::{Elastic, ElementOptions, ElementResponse, Hourglass, Integration};

/// Element-mean gradients `(1/V) ∫ ∇N_a dV` and the volume `V` (exact by 2×2×2 Gauss).
pub(super) fn mean_gradients(x0: &[V3; 8]) -> ([V3; 8], f64) {
    let mut b = [[0.0; 3]; 8];
    let mut vol = 0.0;
    for q in 0..8 {
        let (g, det) = gradients(x0, &hex8_dn(hex8_gauss(q)), false);
        vol += det;
        for (ba, ga) in b.iter_mut().zip(g.iter()) {
            for i in 0..3 {
                ba[i] += det * ga[i];
            }
        }
    }
    for ba in b.iter_mut() {
        for x in ba.iter_mut() {
            *x /= vol;
        }
    }
    (b, vol)
}

/// `det J` at the 8 corners, the 8 Gauss points and the centroid (index 16).
pub fn jacobians(x: &[[f64; 3]; 8]) -> [f64; 17] {
    let mut d = [0.0; 17];
    for a in 0..8 {
        d[a] = det3(&jacobian(x, &hex8_dn(HEX8_NODES[a]), false));
        d[8 + a] = det3(&jacobian(x, &hex8_dn(hex8_gauss(a)), false));
    }
    d[16] = det3(&jacobian(x, &hex8_dn([0.0; 3]), false));
    d
}

/// Internal forces, stress and hourglass terms of one hexahedron.
pub fn respond(
    opts: &ElementOptions,
    mat: &Elastic,
    x0: &[[f64; 3]; 8],
    u: &[[f64; 3]; 8],
    v: &[[f64; 3]; 8],
    out: &mut ElementResponse,
) {
    let mut law = ElasticLaw {
        lambda: mat.lambda,
        mu: mat.mu,
    };
    respond_with(opts, mat, &mut law, x0, u, v, out);
}

/// [`respond`] with the stress at the integration points (8, or 1 when reduced) from
/// `law`; the hourglass control stays elastic (its stiffness from `mat`). Returns the
/// volume.
pub(super) fn respond_with<L: PointLaw>(
    opts: &ElementOptions,
    mat: &Elastic,
    law: &mut L,
    x0: &[[f64; 3]; 8],
    u: &[[f64; 3]; 8],
    v: &[[f64; 3]; 8],
    out: &mut ElementResponse,
) -> f64 {
    match opts.integration {
        Integration::Full { bbar } => full_with(opts, law, bbar, x0, u, out),
        Integration::Reduced(hg) => reduced_with(opts, mat, law, hg, x0, u, v, out),
    }
}

/// [`respond_with`] with full 2×2×2 quadrature (B-bar when `bbar`), whatever
/// `opts.integration` says.
pub(super) fn full_with<L: PointLaw>(
    opts: &ElementOptions,
    law: &mut L,
    bbar: bool,
    x0: &[[f64; 3]; 8],
    u: &[[f64; 3]; 8],
    out: &mut ElementResponse,
) -> f64 {
    let xc = current(x0, u);
    let mut f = [[0.0; 3]; 8];
    let mut g = [[[0.0; 3]; 8]; 8];
    let mut w = [0.0; 8];
    let mut min_j = f64::INFINITY;
    for q in 0..8 {
        let dn = hex8_dn(hex8_gauss(q));
        let (gq, det) = gradients(x0, &dn, false);
        g[q] = gq;
        w[q] = det;
        min_j = min_j.min(det3(&jacobian(&xc, &dn, false)));
    }
    let sums = integrate(opts.kinematics, law, &g, &w, u, bbar, &mut f);
    finish(&f, &sums, out);
    out.hourglass_energy = 0.0;
    out.hourglass_power = 0.0;
    out.min_jacobian = min_j;
    sums.volume
}

/// [`respond_with`] with one point and hourglass control `hg`, whatever
/// `opts.integration` says.
#[allow(clippy::too_many_arguments)] // respond's arguments, the law and the control
pub(super) fn reduced_with<L: PointLaw>(
    opts: &ElementOptions,
    mat: &Elastic,
    law: &mut L,
    hg: Hourglass,
    x0: &[[f64; 3]; 8],
    u: &[[f64; 3]; 8],
    v: &[[f64; 3]; 8],
    out: &mut ElementResponse,
) -> f64 {
    let xc = current(x0, u);
    let mut f = [[0.0; 3]; 8];
    let (b, vol) = mean_gradients(x0);
    let sums = integrate(opts.kinematics, law, &[b], &[vol], u, false, &mut f);
    let gam = gammas(&HEX8_H, x0, &b);
    let m = mat.lambda + 2.0 * mat.mu;
    let c_s = m * vol * bb(&b) / 3.0;
    let c_v = (m * mat.rho).sqrt() * vol.powf(2.0 / 3.0) / 4.0;
    let (e, p) = apply(hg, &gam, c_s, c_v, u, v, &mut f);
    finish(&f, &sums, out);
    out.hourglass_energy = e;
    out.hourglass_power = p;
    out.min_jacobian = det3(&jacobian(&xc, &hex8_dn([0.0; 3]), false));
    sums.volume
}

/// Row-sum lumped masses `ρ ∫ N_a dV` (exact by 2×2×2 Gauss; equal eighths on a
/// parallelepiped).
pub fn lumped_masses(rho: f64, x0: &[[f64; 3]; 8]) -> [f64; 8] {
    let mut m = [0.0; 8];
    for q in 0..8 {
        let p = hex8_gauss(q);
        let det = det3(&jacobian(x0, &hex8_dn(p), false));
        for (ma, na) in m.iter_mut().zip(hex8_n(p).iter()) {
            *ma += rho * det * na;
        }
    }
    m
}
