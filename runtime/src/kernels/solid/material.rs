//! Isotropic elasticity: Lamé constants, the plane-stress reduction, stress from strain for
//! both kinematics, and the strain-energy density.
//!
//! Strains and stresses are in Voigt order `xx yy zz yz xz xy` with **tensor** shear strains
//! (`ε_xy = ½ γ_xy`), so `σ = λ tr ε I + 2μ ε` holds component by component and the energy
//! density is `W = ½ σ : ε = ½ (Σ_diag σ_ii ε_ii + 2 Σ_shear σ_ij ε_ij)`.
//!
//! The same law serves both kinematics: small strain (`ε = sym ∇u`, Cauchy stress) and total
//! Lagrangian St Venant–Kirchhoff (Green–Lagrange `E = ½(FᵀF − I)`, second Piola–Kirchhoff
//! `S = λ tr E I + 2μ E`, `W = λ/2 (tr E)² + μ E:E`).
//!
//! Plane stress is obtained by replacing λ with `λ* = 2λμ/(λ+2μ)` in the in-plane law (then
//! σ_zz = 0 and `ε_zz = −λ/(λ+2μ) (ε_xx + ε_yy)`); plane strain keeps λ with ε_zz = 0, so
//! `σ_zz = λ tr ε`.

use super::{Elastic, Kinematics};

impl Elastic {
    /// From Young's modulus `e` (Pa), Poisson's ratio `nu` (−1 < ν < ½) and density `rho`.
    pub fn new(e: f64, nu: f64, rho: f64) -> Self {
        Elastic {
            lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
            mu: e / (2.0 * (1.0 + nu)),
            e,
            rho,
        }
    }

    /// The in-plane law of plane stress: λ replaced by `λ* = 2λμ/(λ+2μ)` (μ, E and ρ kept).
    pub fn plane_stress(&self) -> Self {
        Elastic {
            lambda: 2.0 * self.lambda * self.mu / (self.lambda + 2.0 * self.mu),
            ..*self
        }
    }

    /// Dilatational (P-wave) speed `√((λ+2μ)/ρ)`, m/s. For plane stress call it on
    /// [`Elastic::plane_stress`].
    pub fn dilatational_speed(&self) -> f64 {
        ((self.lambda + 2.0 * self.mu) / self.rho).sqrt()
    }
}

/// Voigt index pairs, order `xx yy zz yz xz xy`.
pub(super) const VOIGT: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];

/// Strain (Voigt, tensor shears) from the displacement gradient `h = ∂u/∂X`: `sym h` for
/// small strain, `½(h + hᵀ + hᵀh)` (Green–Lagrange) for total Lagrangian.
#[inline]
pub(super) fn strain(kin: Kinematics, h: &[[f64; 3]; 3]) -> [f64; 6] {
    let mut e = [0.0; 6];
    for (k, &(i, j)) in VOIGT.iter().enumerate() {
        let mut s = 0.5 * (h[i][j] + h[j][i]);
        if kin == Kinematics::TotalLagrangian {
            s += 0.5 * (h[0][i] * h[0][j] + h[1][i] * h[1][j] + h[2][i] * h[2][j]);
        }
        e[k] = s;
    }
    e
}

/// `σ = λ tr ε I + 2μ ε` (Voigt, tensor shear strains).
#[inline]
pub(super) fn stress(lambda: f64, mu: f64, e: &[f64; 6]) -> [f64; 6] {
    let l = lambda * (e[0] + e[1] + e[2]);
    [
        l + 2.0 * mu * e[0],
        l + 2.0 * mu * e[1],
        l + 2.0 * mu * e[2],
        2.0 * mu * e[3],
        2.0 * mu * e[4],
        2.0 * mu * e[5],
    ]
}

/// Energy density `½ σ : ε` (Voigt, tensor shear strains).
#[inline]
pub(super) fn energy_density(s: &[f64; 6], e: &[f64; 6]) -> f64 {
    0.5 * (s[0] * e[0] + s[1] * e[1] + s[2] * e[2]) + (s[3] * e[3] + s[4] * e[4] + s[5] * e[5])
}

/// A 3×3 symmetric tensor from Voigt components.
#[inline]
pub(super) fn tensor(s: &[f64; 6]) -> [[f64; 3]; 3] {
    [[s[0], s[5], s[4]], [s[5], s[1], s[3]], [s[4], s[3], s[2]]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lame_constants_and_plane_stress() {
        // E = 200 GPa, ν = 0.3: λ = Eν/((1+ν)(1−2ν)), μ = E/(2(1+ν)).
        let m = Elastic::new(200e9, 0.3, 7800.0);
        assert!((m.lambda - 200e9 * 0.3 / (1.3 * 0.4)).abs() < 1e-3);
        assert!((m.mu - 200e9 / 2.6).abs() < 1e-3);
        // Plane stress: σ_xx = E/(1−ν²)(ε_xx + ν ε_yy) = (λ* + 2μ) ε_xx + λ* ε_yy.
        let p = m.plane_stress();
        let c = 200e9 / (1.0 - 0.09);
        assert!(((p.lambda + 2.0 * p.mu) - c).abs() < 1e-6 * c);
        assert!((p.lambda - 0.3 * c).abs() < 1e-6 * c);
    }

    #[test]
    fn green_lagrange_of_a_rotation_is_zero() {
        let (s, c) = (0.6f64.sin(), 0.6f64.cos());
        // F = R about z, h = F − I.
        let h = [[c - 1.0, -s, 0.0], [s, c - 1.0, 0.0], [0.0, 0.0, 0.0]];
        let e = strain(Kinematics::TotalLagrangian, &h);
        assert!(e.iter().all(|x| x.abs() < 1e-15), "{e:?}");
    }
}
