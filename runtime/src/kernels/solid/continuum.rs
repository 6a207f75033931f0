//! Shared continuum machinery of the 2-D and 3-D elements: isoparametric shape functions,
//! Jacobians and spatial gradients, and the quadrature loop that turns nodal displacements
//! into nodal forces `f_a = ∫ P ∇₀N_a dV` (P = σ for small strain, P = F S for total
//! Lagrangian), optionally with the mean-dilatation (B-bar) modification.
//!
//! 2-D elements run through the same 3-D code with zero z components (their gradients have
//! `∂N/∂z = 0` and their displacements `u_z = 0`), so the z row and column of the
//! displacement gradient vanish; the plane-stress law is passed in as `λ*` by the caller.
//!
//! **B-bar / mean dilatation.** With `bbar`, the volumetric part of the strain at each
//! quadrature point is replaced by its element mean: `Ē = E + ⅓(θ̄ − θ) I`, `θ = tr E`,
//! `θ̄ = (1/V) ∫ θ dV`. The forces are the exact gradient of `∫ W(Ē) dV`:
//! `f_a = ∫ [P ∇N_a + ⅓ tr S (ḡ_a − g_a)] dV` with `g_a = F ∇N_a` (the derivative of θ with
//! respect to `u_a`) and `ḡ_a` its element mean. For small strain `F = I` and this is Hughes'
//! B-bar; for total Lagrangian it is mean dilatation applied to the Green–Lagrange strain
//! (objective: a rigid rotation leaves `E = 0` at every point), a simpler relative of F-bar.
//!
//! Everything is on fixed-size arrays (no allocation); loops run over compile-time sizes.

use super::material::{energy_density, strain, stress, tensor};
use super::Kinematics;

/// A 3-vector.
pub(super) type V3 = [f64; 3];
/// A 3×3 matrix, row-major.
pub(super) type M3 = [[f64; 3]; 3];

/// Gauss abscissa of the 2-point rule, `1/√3`.
pub(super) const G2: f64 = 0.577_350_269_189_625_8;

/// Natural coordinates of the quad4 nodes (counter-clockwise).
pub(super) const QUAD4_NODES: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Natural coordinates of the hex8 nodes (bottom 0-1-2-3 counter-clockwise seen from +z,
/// top 4-5-6-7 above them).
pub(super) const HEX8_NODES: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// quad4 shape functions at (ξ, η).
#[inline]
pub(super) fn quad4_n(xi: f64, eta: f64) -> [f64; 4] {
    let mut n = [0.0; 4];
    for (na, s) in n.iter_mut().zip(QUAD4_NODES.iter()) {
        *na = 0.25 * (1.0 + s[0] * xi) * (1.0 + s[1] * eta);
    }
    n
}

/// quad4 natural derivatives `∂N_a/∂(ξ, η, ·)` at (ξ, η), z component 0.
#[inline]
pub(super) fn quad4_dn(xi: f64, eta: f64) -> [V3; 4] {
    let mut d = [[0.0; 3]; 4];
    for (da, s) in d.iter_mut().zip(QUAD4_NODES.iter()) {
        da[0] = 0.25 * s[0] * (1.0 + s[1] * eta);
        da[1] = 0.25 * s[1] * (1.0 + s[0] * xi);
    }
    d
}

/// hex8 shape functions at (ξ, η, ζ).
#[inline]
pub(super) fn hex8_n(p: V3) -> [f64; 8] {
    let mut n = [0.0; 8];
    for (na, s) in n.iter_mut().zip(HEX8_NODES.iter()) {
        *na = 0.125 * (1.0 + s[0] * p[0]) * (1.0 + s[1] * p[1]) * (1.0 + s[2] * p[2]);
    }
    n
}

/// hex8 natural derivatives at (ξ, η, ζ).
#[inline]
pub(super) fn hex8_dn(p: V3) -> [V3; 8] {
    let mut d = [[0.0; 3]; 8];
    for (da, s) in d.iter_mut().zip(HEX8_NODES.iter()) {
        let (a, b, c) = (1.0 + s[0] * p[0], 1.0 + s[1] * p[1], 1.0 + s[2] * p[2]);
        da[0] = 0.125 * s[0] * b * c;
        da[1] = 0.125 * s[1] * a * c;
        da[2] = 0.125 * s[2] * a * b;
    }
    d
}

/// The 2×2 Gauss points of quad4 (weight 1 each), in node order.
#[inline]
pub(super) fn quad4_gauss(q: usize) -> (f64, f64) {
    (G2 * QUAD4_NODES[q][0], G2 * QUAD4_NODES[q][1])
}

/// The 2×2×2 Gauss points of hex8 (weight 1 each), in node order (point q is nearest node q).
#[inline]
pub(super) fn hex8_gauss(q: usize) -> V3 {
    let s = HEX8_NODES[q];
    [G2 * s[0], G2 * s[1], G2 * s[2]]
}

/// Jacobian `J_ij = Σ_a x_ai ∂N_a/∂ξ_j`. With `planar` the z row and column are those of the
/// identity (x_z ignored).
#[inline]
pub(super) fn jacobian<const N: usize>(x: &[V3; N], dn: &[V3; N], planar: bool) -> M3 {
    let mut j = [[0.0; 3]; 3];
    for a in 0..N {
        for (i, row) in j.iter_mut().enumerate() {
            for (k, jik) in row.iter_mut().enumerate() {
                *jik += x[a][i] * dn[a][k];
            }
        }
    }
    if planar {
        j[2] = [0.0, 0.0, 1.0];
        j[0][2] = 0.0;
        j[1][2] = 0.0;
    }
    j
}

/// Determinant of a 3×3 matrix.
#[inline]
pub(super) fn det3(m: &M3) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Inverse of a 3×3 matrix whose determinant is `det` (≠ 0).
#[inline]
pub(super) fn inv3(m: &M3, det: f64) -> M3 {
    let d = 1.0 / det;
    [
        [
            (m[1][1] * m[2][2] - m[1][2] * m[2][1]) * d,
            (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * d,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * d,
        ],
        [
            (m[1][2] * m[2][0] - m[1][0] * m[2][2]) * d,
            (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * d,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * d,
        ],
        [
            (m[1][0] * m[2][1] - m[1][1] * m[2][0]) * d,
            (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * d,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * d,
        ],
    ]
}

/// Spatial gradients `∇N_a = J⁻ᵀ ∂N_a/∂ξ` and `det J` at one point.
#[inline]
pub(super) fn gradients<const N: usize>(x: &[V3; N], dn: &[V3; N], planar: bool) -> ([V3; N], f64) {
    let j = jacobian(x, dn, planar);
    let det = det3(&j);
    let ji = inv3(&j, det);
    let mut g = [[0.0; 3]; N];
    for (ga, da) in g.iter_mut().zip(dn.iter()) {
        for (i, gi) in ga.iter_mut().enumerate() {
            *gi = ji[0][i] * da[0] + ji[1][i] * da[1] + ji[2][i] * da[2];
        }
    }
    (g, det)
}

/// `x0 + u`.
#[inline]
pub(super) fn current<const N: usize>(x0: &[V3; N], u: &[V3; N]) -> [V3; N] {
    let mut x = *x0;
    for (xa, ua) in x.iter_mut().zip(u.iter()) {
        for (xi, ui) in xa.iter_mut().zip(ua.iter()) {
            *xi += ui;
        }
    }
    x
}

/// The same points with z set to 0 (2-D elements).
#[inline]
pub(super) fn flatten<const N: usize>(x: &[V3; N]) -> [V3; N] {
    let mut y = *x;
    for ya in y.iter_mut() {
        ya[2] = 0.0;
    }
    y
}

/// Displacement gradient `H_ij = Σ_a u_ai ∂N_a/∂X_j`.
#[inline]
pub(super) fn displacement_gradient<const N: usize>(u: &[V3; N], g: &[V3; N]) -> M3 {
    let mut h = [[0.0; 3]; 3];
    for a in 0..N {
        for (i, row) in h.iter_mut().enumerate() {
            for (j, hij) in row.iter_mut().enumerate() {
                *hij += u[a][i] * g[a][j];
            }
        }
    }
    h
}

/// How a quadrature point turns its strain into stress: the elastic law (stateless) or an
/// elastoplastic one (`plasticity::PlasticLaw`, state per point). [`integrate`] is generic
/// over it, so elastic blocks compile to the elastic loop alone.
pub(super) trait PointLaw {
    /// The stress at point `q` of weight `w` (volume) from its total strain `e` (Voigt,
    /// tensor shears), and the elastic energy density `½ σ : εᵉ`.
    fn point(&mut self, q: usize, w: f64, e: &[f64; 6]) -> ([f64; 6], f64);
}

/// The elastic law: `σ = λ tr ε I + 2μ ε` (λ* for plane stress).
#[derive(Clone, Copy, Debug)]
pub(super) struct ElasticLaw {
    /// λ (λ* for plane stress).
    pub lambda: f64,
    /// μ.
    pub mu: f64,
}

impl PointLaw for ElasticLaw {
    #[inline]
    fn point(&mut self, _q: usize, _w: f64, e: &[f64; 6]) -> ([f64; 6], f64) {
        let s = stress(self.lambda, self.mu, e);
        (s, energy_density(&s, e))
    }
}

/// Weighted sums over the quadrature points.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Sums {
    /// `∫ σ dV` (Voigt).
    pub stress: [f64; 6],
    /// `∫ ε dV` (Voigt, tensor shears; the B-bar strain with `bbar`).
    pub strain: [f64; 6],
    /// `∫ W dV`.
    pub energy: f64,
    /// `∫ dV`.
    pub volume: f64,
}

/// Adds `∫ P ∇N_a dV` (with the B-bar term when `bbar`) to `f` over `Q` points with
/// reference gradients `g[q]` and weights `w[q]` (`det J ×` quadrature weight `×` thickness),
/// the stress of point `q` from `law` (called once per point, in order), and returns the
/// weighted sums of stress, strain, energy and volume.
pub(super) fn integrate<const N: usize, const Q: usize, L: PointLaw>(
    kin: Kinematics,
    law: &mut L,
    g: &[[V3; N]; Q],
    w: &[f64; Q],
    u: &[V3; N],
    bbar: bool,
    f: &mut [V3; N],
) -> Sums {
    let tl = kin == Kinematics::TotalLagrangian;
    let mut hq = [[[0.0; 3]; 3]; Q];
    let mut eq = [[0.0; 6]; Q];
    let mut volume = 0.0;
    for q in 0..Q {
        hq[q] = displacement_gradient(u, &g[q]);
        eq[q] = strain(kin, &hq[q]);
        volume += w[q];
    }
    // Mean dilatation: θ̄ and ḡ_a = (1/V) ∫ F ∇N_a dV.
    let mut gbar = [[0.0; 3]; N];
    let mut theta_bar = 0.0;
    if bbar {
        for q in 0..Q {
            theta_bar += w[q] * (eq[q][0] + eq[q][1] + eq[q][2]);
            let fq = deformation_gradient(&hq[q], tl);
            for (gb, ga) in gbar.iter_mut().zip(g[q].iter()) {
                for (i, gbi) in gb.iter_mut().enumerate() {
                    *gbi += w[q] * (fq[i][0] * ga[0] + fq[i][1] * ga[1] + fq[i][2] * ga[2]);
                }
            }
        }
        theta_bar /= volume;
        for gb in gbar.iter_mut() {
            for x in gb.iter_mut() {
                *x /= volume;
            }
        }
    }
    let mut sums = Sums {
        volume,
        ..Sums::default()
    };
    for q in 0..Q {
        let mut e = eq[q];
        if bbar {
            let d = (theta_bar - (e[0] + e[1] + e[2])) / 3.0;
            e[0] += d;
            e[1] += d;
            e[2] += d;
        }
        let (s, energy) = law.point(q, w[q], &e);
        let fq = deformation_gradient(&hq[q], tl);
        let st = tensor(&s);
        // P = F S.
        let mut p = [[0.0; 3]; 3];
        for (i, pi) in p.iter_mut().enumerate() {
            for (j, pij) in pi.iter_mut().enumerate() {
                *pij = fq[i][0] * st[0][j] + fq[i][1] * st[1][j] + fq[i][2] * st[2][j];
            }
        }
        let tr3 = (s[0] + s[1] + s[2]) / 3.0;
        let wq = w[q];
        for a in 0..N {
            let ga = g[q][a];
            for i in 0..3 {
                let mut fi = p[i][0] * ga[0] + p[i][1] * ga[1] + p[i][2] * ga[2];
                if bbar {
                    let fga = fq[i][0] * ga[0] + fq[i][1] * ga[1] + fq[i][2] * ga[2];
                    fi += tr3 * (gbar[a][i] - fga);
                }
                f[a][i] += wq * fi;
            }
        }
        for k in 0..6 {
            sums.stress[k] += wq * s[k];
            sums.strain[k] += wq * e[k];
        }
        sums.energy += wq * energy;
    }
    sums
}

/// `F = I + H` (total Lagrangian) or `I` (small strain: the forces use σ directly).
#[inline]
fn deformation_gradient(h: &M3, tl: bool) -> M3 {
    let mut f = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if tl {
        for i in 0..3 {
            for j in 0..3 {
                f[i][j] += h[i][j];
            }
        }
    }
    f
}

/// Writes forces, volume-mean stress and strain, and strain energy into `out` (other fields
/// untouched; rows of `out.f` past `N` zeroed).
pub(super) fn finish<const N: usize>(f: &[V3; N], sums: &Sums, out: &mut super::ElementResponse) {
    out.f = [[0.0; 3]; super::MAX_NODES];
    out.f[..N].copy_from_slice(f);
    let inv = 1.0 / sums.volume;
    for k in 0..6 {
        out.stress[k] = sums.stress[k] * inv;
        out.strain[k] = sums.strain[k] * inv;
    }
    out.strain_energy = sums.energy;
}

/// The zz components of a 2-D element's outputs: plane stress has σ_zz = 0 and
/// `ε_zz = −λ/(λ+2μ) (ε_xx + ε_yy)` (λ the 3-D constant); plane strain already has ε_zz = 0
/// and σ_zz = λ tr ε from the 3-D law.
pub(super) fn plane_outputs(
    plane: super::Plane,
    mat: &super::Elastic,
    out: &mut super::ElementResponse,
) {
    if plane == super::Plane::Stress {
        out.stress[2] = 0.0;
        out.strain[2] = -mat.lambda / (mat.lambda + 2.0 * mat.mu) * (out.strain[0] + out.strain[1]);
    }
}

/// The elastic law of a 2-D element: λ* for plane stress.
pub(super) fn plane_law(plane: super::Plane, mat: &super::Elastic) -> ElasticLaw {
    let m = if plane == super::Plane::Stress {
        mat.plane_stress()
    } else {
        *mat
    };
    ElasticLaw {
        lambda: m.lambda,
        mu: m.mu,
    }
}
