//! Flanagan–Belytschko hourglass control of one-point quad4 and hex8 elements
//! (Flanagan & Belytschko 1981, "A uniform strain hexahedron and quadrilateral with
//! orthogonal hourglass control", IJNME 17).
//!
//! **Base vectors.** hex8: `h₁ = ηζ`, `h₂ = ξζ`, `h₃ = ξη`, `h₄ = ξηζ` sampled at the nodes
//! (entries ±1); quad4: `h = ξη = (1, −1, 1, −1)`.
//!
//! **Projection.** `γ_α = h_α − Σ_i (h_α · x_i) b_i` with `x_i` the nodal coordinates and
//! `b_i` the element-mean shape-function gradients (`b_ai = (1/V) ∫ ∂N_a/∂X_i dV`). Because
//! `Σ_a b_ai x_aj = δ_ij` and `Σ_a b_ai = 0`, γ is orthogonal to every field linear in x:
//! hourglass control never resists a uniform strain (the patch test passes) nor a rigid
//! motion.
//!
//! **Reference configuration.** γ, b and V are taken in the *reference* configuration for
//! both kinematics (stateless, total-displacement form; the integrator may precompute them).
//! A rigid motion `u = (R − I) X + c` is linear in X, so it produces no hourglass mode at all,
//! for every element shape (parallelogram or not); and a hourglass deformation `δ` seen after
//! a rotation `R`, `u = (R − I) X + R δ`, gives `q = R q(δ)` and forces `R f(δ)`: the
//! stiffness form is objective. (With the viscous form, a rigid spin `ω` of an element that
//! already carries a hourglass displacement `q_u` sees a spurious rate `ω × q_u`; small when
//! the hourglass is controlled.)
//!
//! **Forces.** With the generalised hourglass displacement `q_α = Σ_a γ_αa u_a` (a vector)
//! and velocity `q̇_α = Σ_a γ_αa v_a`:
//! - stiffness: `f_a = C_s Σ_α γ_αa q_α`, energy `½ C_s Σ_α |q_α|²`, with
//!   `C_s = κ (λ+2μ) V (b·b) / 3` in 3-D (FB 1981 with `B = V b`:
//!   `κ (λ+2μ) B_iI B_iI / (3V)`) and `C_s = κ (λ*+2μ) t A (b·b) / 2` for quad4;
//! - viscous: `f_a = C_v Σ_α γ_αa q̇_α`, with `C_v = κ ρ c V^{2/3} / 4` in 3-D (the FB /
//!   Hallquist scaling, so the usual κ ≈ 0.05–0.15 carry over) and `C_v = κ ρ c t √A / 2`
//!   for quad4, `c` the dilatational speed;
//! - dissipated power: `Σ_a f_a · v_a = C_v Σ|q̇_α|² ≥ 0` for the viscous form; 0 for the
//!   stiffness form, whose forces are conservative (their power is the rate of the stored
//!   energy, which the integrator already counts: adding it as dissipation too would count
//!   the hourglass energy twice in the balance).
//!
//! Moment balance: `Σ_a X_a × f_a = (Σ_a γ_αa X_a) × … = 0` (reference positions).

use super::continuum::V3;
use super::Hourglass;

/// hex8 base vectors ηζ, ξζ, ξη, ξηζ at the nodes.
pub(super) const HEX8_H: [[f64; 8]; 4] = [
    [1.0, 1.0, -1.0, -1.0, -1.0, -1.0, 1.0, 1.0],
    [1.0, -1.0, -1.0, 1.0, -1.0, 1.0, 1.0, -1.0],
    [1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0, 1.0, 1.0, -1.0, 1.0, -1.0],
];

/// quad4 base vector ξη at the nodes.
pub(super) const QUAD4_H: [[f64; 4]; 1] = [[1.0, -1.0, 1.0, -1.0]];

/// `γ_α = h_α − Σ_i (h_α · x_i) b_i`.
#[inline]
pub(super) fn gammas<const N: usize, const M: usize>(
    h: &[[f64; N]; M],
    x: &[V3; N],
    b: &[V3; N],
) -> [[f64; N]; M] {
    let mut gam = *h;
    for (ga, ha) in gam.iter_mut().zip(h.iter()) {
        let mut hx = [0.0; 3];
        for a in 0..N {
            for i in 0..3 {
                hx[i] += ha[a] * x[a][i];
            }
        }
        for a in 0..N {
            ga[a] -= hx[0] * b[a][0] + hx[1] * b[a][1] + hx[2] * b[a][2];
        }
    }
    gam
}

/// `Σ_a Σ_i b_ai²`.
#[inline]
pub(super) fn bb<const N: usize>(b: &[V3; N]) -> f64 {
    b.iter()
        .map(|ba| ba[0] * ba[0] + ba[1] * ba[1] + ba[2] * ba[2])
        .sum()
}

/// Adds the hourglass forces to `f`; returns (stored energy, dissipated power): stiffness
/// `(½ C_s Σ|q_α|², 0)`, viscous `(0, Σ f_hg · v)`.
/// `c_stiff` and `c_visc` are `C_s / κ` and `C_v / κ` (the coefficient comes from `hg`).
pub(super) fn apply<const N: usize, const M: usize>(
    hg: Hourglass,
    gam: &[[f64; N]; M],
    c_stiff: f64,
    c_visc: f64,
    u: &[V3; N],
    v: &[V3; N],
    f: &mut [V3; N],
) -> (f64, f64) {
    let (c, field, stiff) = match hg {
        Hourglass::Stiffness { coefficient } => (coefficient * c_stiff, u, true),
        Hourglass::Viscous { coefficient } => (coefficient * c_visc, v, false),
    };
    let mut energy = 0.0;
    let mut fh = [[0.0; 3]; N];
    for ga in gam.iter() {
        let mut q = [0.0; 3];
        for a in 0..N {
            for i in 0..3 {
                q[i] += ga[a] * field[a][i];
            }
        }
        energy += 0.5 * c * (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        for a in 0..N {
            for i in 0..3 {
                fh[a][i] += c * ga[a] * q[i];
            }
        }
    }
    let mut power = 0.0;
    for a in 0..N {
        for i in 0..3 {
            f[a][i] += fh[a][i];
            power += fh[a][i] * v[a][i];
        }
    }
    if stiff {
        (energy, 0.0)
    } else {
        (0.0, power)
    }
}
