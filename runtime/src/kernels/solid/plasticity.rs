//! J2 (von Mises) plasticity with linear isotropic hardening: the return mappings of one
//! integration point, and the point law the quadrature loop calls for elastoplastic blocks.
//!
//! **Model** (small strain; Simo & Hughes 1998, *Computational Inelasticity*, §2.3, §3.3):
//! additive split `ε = εᵉ + εᵖ`, `σ = λ tr εᵉ I + 2μ εᵉ`, yield function
//! `f = |s| − √(2/3) σ_y(ε̄ᵖ)` with `s = dev σ` and `σ_y(ε̄ᵖ) = σ_y0 + H ε̄ᵖ`, associative
//! flow `ε̇ᵖ = γ̇ s/|s|` (deviatoric: `tr εᵖ = 0`), `ε̄̇ᵖ = √(2/3) |ε̇ᵖ|`.
//!
//! **Returns** (backward Euler, from the trial state `σ_tr = C(ε_{n+1} − εᵖ_n)`):
//! - [`radial_return`], 3-D and plane strain (Box 3.2): `Δγ = f_tr / (2μ + ⅔H)`,
//!   `σ = σ_tr − 2μ Δγ n`, `εᵖ += Δγ n`, `ε̄ᵖ += √(2/3) Δγ`, `n = s_tr/|s_tr|`. Closed form:
//!   exact consistency `|s| = √(2/3) σ_y(ε̄ᵖ)` after the return.
//! - [`plane_stress_return`], plane stress: the projected algorithm of Simo & Taylor (1986)
//!   (Simo & Hughes §3.4). With the in-plane stress `σ = (σ11, σ22, σ12)`,
//!   `P = ⅓[[2, −1, 0], [−1, 2, 0], [0, 0, 6]]` (`½ σᵀPσ = J₂`) and the plane-stress
//!   modulus `C`, the return `σ = (I + Δγ C P)⁻¹ σ_tr` is diagonal in the common
//!   eigenbasis of C and P: `σ11 + σ22` divides by `1 + Δγ E/(3(1−ν))`, and `σ22 − σ11`
//!   and `σ12` by `1 + 2μΔγ`. The one unknown Δγ solves the scalar consistency condition
//!   `½ φ²(Δγ) − ⅓ σ_y²(ε̄ᵖ_n + √(2/3) Δγ φ(Δγ)) = 0`, `φ² = σᵀPσ`, by a safeguarded
//!   Newton iteration (bisection when a step leaves the bracket; converged to 1e-13
//!   relative). Then `Δεᵖ = Δγ P σ` (in plane; tensor shear `Δγ σ12`) and
//!   `Δεᵖ_zz = −(Δεᵖ_xx + Δεᵖ_yy)`: σ_zz = 0 holds exactly, not iteratively.
//! - [`uniaxial_return`], bars: `σ_tr = E(ε − εᵖ)`, `Δγ = (|σ_tr| − σ_y)/(E + H)`,
//!   `σ = σ_tr − E Δγ sign σ_tr`; here `ε̄ᵖ = ∫|dεᵖ|` and the tangent after yield is
//!   `E H/(E + H)`.
//!
//! **Plastic work** of a step, per unit volume: `½ (σ_n + σ_{n+1}) : Δεᵖ`, the trapezoidal
//! rule like the work of the external forces, with the point's stress at the end of the
//! previous step kept in its state. With `σ = C εᵉ` this makes the discrete balance exact:
//! `½ (σ_n + σ_{n+1}) : Δε = ΔU + ½ (σ_n + σ_{n+1}) : Δεᵖ` with `U = ½ σ : εᵉ` (C symmetric),
//! so the internal work of a step is the change of elastic energy plus the plastic work.
//! (The backward-Euler `σ_{n+1} : Δεᵖ = σ_y(ε̄ᵖ_{n+1}) Δε̄ᵖ`, or `∫ σ_y dε̄ᵖ`, differ
//! from it in steps where the stress was inside the yield
//! surface or the flow turns: an error of the order of the step, visible in impacts.)
//!
//! **Total Lagrangian** (`strain green`): the same returns act on the Green–Lagrange strain
//! and the second Piola–Kirchhoff stress, with `E = Eᵉ + Eᵖ` additive. This is exact under
//! rigid rotations (E and S do not see them) but is a valid elastoplastic model only when
//! the elastic strains stay small; large plastic stretches would need a multiplicative
//! split `F = Fᵉ Fᵖ`.
//!
//! Strains and stresses in Voigt order `xx yy zz yz xz xy` with tensor shear strains, as in
//! `material`; `|s|² = s_xx² + s_yy² + s_zz² + 2(s_yz² + s_xz² + s_xy²)`.

use super::continuum::PointLaw;
use super::material::{energy_density, stress};

/// `√(2/3)`.
pub const SQRT_2_3: f64 = 0.816_496_580_927_726;

/// The J2 plasticity constants of a material, for the kernels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plastic {
    /// Initial uniaxial yield stress `σ_y0`, Pa.
    pub yield_stress: f64,
    /// Linear isotropic hardening modulus `H`, Pa (`σ_y = σ_y0 + H ε̄ᵖ`).
    pub hardening: f64,
}

impl Plastic {
    /// The uniaxial yield stress at equivalent plastic strain `alpha`: `σ_y0 + H ε̄ᵖ`.
    #[inline]
    pub fn yield_at(&self, alpha: f64) -> f64 {
        self.yield_stress + self.hardening * alpha
    }
}

/// The norm of the deviator of a Voigt stress, `|s|` (tensor norm).
#[inline]
pub fn deviator_norm(s: &[f64; 6]) -> f64 {
    let m = (s[0] + s[1] + s[2]) / 3.0;
    let (a, b, c) = (s[0] - m, s[1] - m, s[2] - m);
    (a * a + b * b + c * c + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5])).sqrt()
}

/// The 3-D radial return (plane strain too: its z strain is 0 and its plastic z strain is
/// not). `e` is the total strain at the point; `ep` (plastic strain) and `alpha` (ε̄ᵖ) hold
/// the state at the start of the step and are updated. Returns the stress.
#[inline]
pub fn radial_return(
    lambda: f64,
    mu: f64,
    p: &Plastic,
    e: &[f64; 6],
    ep: &mut [f64; 6],
    alpha: &mut f64,
) -> [f64; 6] {
    let mut ee = [0.0; 6];
    for k in 0..6 {
        ee[k] = e[k] - ep[k];
    }
    let mut s = stress(lambda, mu, &ee);
    let m = (s[0] + s[1] + s[2]) / 3.0;
    let dev = [s[0] - m, s[1] - m, s[2] - m, s[3], s[4], s[5]];
    let norm = (dev[0] * dev[0]
        + dev[1] * dev[1]
        + dev[2] * dev[2]
        + 2.0 * (dev[3] * dev[3] + dev[4] * dev[4] + dev[5] * dev[5]))
        .sqrt();
    let f = norm - SQRT_2_3 * p.yield_at(*alpha);
    if f > 0.0 {
        let dg = f / (2.0 * mu + 2.0 / 3.0 * p.hardening);
        let inv = 1.0 / norm;
        for k in 0..6 {
            let n = dev[k] * inv;
            s[k] -= 2.0 * mu * dg * n;
            ep[k] += dg * n;
        }
        *alpha += SQRT_2_3 * dg;
    }
    s
}

/// The plane-stress return of Simo & Taylor (module doc). `lambda_star` is the plane-stress
/// `λ* = 2λμ/(λ+2μ)`; `e` the total strain (its xx, yy and xy components are read); `ep`
/// and `alpha` the state, updated (`ep[2] = −(ep[0] + ep[1])`, `ep[3] = ep[4] = 0`).
/// Returns the stress, with σ_zz = σ_yz = σ_xz = 0.
pub fn plane_stress_return(
    lambda_star: f64,
    mu: f64,
    p: &Plastic,
    e: &[f64; 6],
    ep: &mut [f64; 6],
    alpha: &mut f64,
) -> [f64; 6] {
    let (e0, e1, e5) = (e[0] - ep[0], e[1] - ep[1], e[5] - ep[5]);
    let l = lambda_star * (e0 + e1);
    let (s0, s1, s5) = (l + 2.0 * mu * e0, l + 2.0 * mu * e1, 2.0 * mu * e5);
    // φ² = σᵀPσ = A/(1 + k₁Δγ)² + B/(1 + 2μΔγ)²: A = (σ11 + σ22)²/6,
    // B = (σ22 − σ11)²/2 + 2σ12², k₁ = E/(3(1 − ν)) = (2λ* + 2μ)/3.
    let a = (s0 + s1) * (s0 + s1) / 6.0;
    let b = 0.5 * (s1 - s0) * (s1 - s0) + 2.0 * s5 * s5;
    let k1 = (2.0 * lambda_star + 2.0 * mu) / 3.0;
    let k2 = 2.0 * mu;
    let h = p.hardening;
    let a0 = *alpha;
    // f(Δγ) = ½φ² − ⅓R², R = σ_y(ᾱ_n + √⅔ Δγ φ); and f'.
    let eval = |dg: f64| -> (f64, f64, f64) {
        let (d1, d2) = (1.0 + k1 * dg, 1.0 + k2 * dg);
        let phi2 = a / (d1 * d1) + b / (d2 * d2);
        let dphi2 = -2.0 * a * k1 / (d1 * d1 * d1) - 2.0 * b * k2 / (d2 * d2 * d2);
        let phi = phi2.sqrt();
        let r = p.yield_at(a0 + SQRT_2_3 * dg * phi);
        let dphi = if phi > 0.0 { 0.5 * dphi2 / phi } else { 0.0 };
        let dr = h * SQRT_2_3 * (phi + dg * dphi);
        (
            0.5 * phi2 - r * r / 3.0,
            0.5 * dphi2 - 2.0 / 3.0 * r * dr,
            phi,
        )
    };
    let (f0, _, _) = eval(0.0);
    if f0 <= 0.0 {
        return [s0, s1, 0.0, 0.0, 0.0, s5];
    }
    // Bracket: f(0) > 0, and f(hi) < 0 at hi with φ(hi) below √⅔ σ_y0 ≤ √⅔ R.
    let kmin = k1.min(k2);
    let mut lo = 0.0;
    let mut hi = ((1.5 * (a + b)).sqrt() / p.yield_stress) / kmin + 1.0 / kmin;
    let tol = 1e-13 * p.yield_at(a0) * p.yield_at(a0);
    let mut dg = 0.0;
    for _ in 0..100 {
        let (f, df, _) = eval(dg);
        if f.abs() <= tol {
            break;
        }
        if f > 0.0 {
            lo = dg;
        } else {
            hi = dg;
        }
        let next = dg - f / df;
        dg = if df < 0.0 && next > lo && next < hi {
            next
        } else {
            0.5 * (lo + hi)
        };
        if hi - lo <= 1e-15 * hi {
            break;
        }
    }
    let (_, _, phi) = eval(dg);
    let sum = (s0 + s1) / (1.0 + k1 * dg);
    let dif = (s1 - s0) / (1.0 + k2 * dg);
    let (t0, t1, t5) = (0.5 * (sum - dif), 0.5 * (sum + dif), s5 / (1.0 + k2 * dg));
    // Δεᵖ = Δγ P σ: (2σ11 − σ22)/3, (2σ22 − σ11)/3; tensor shear Δγ σ12.
    let d0 = dg * (2.0 * t0 - t1) / 3.0;
    let d1 = dg * (2.0 * t1 - t0) / 3.0;
    ep[0] += d0;
    ep[1] += d1;
    ep[2] -= d0 + d1;
    ep[5] += dg * t5;
    *alpha += SQRT_2_3 * dg * phi;
    [t0, t1, 0.0, 0.0, 0.0, t5]
}

/// The 1-D return of a bar: total axial strain `eps`, state `ep` (axial plastic strain) and
/// `alpha` (accumulated `∫|dεᵖ|`), updated. Returns the axial stress.
#[inline]
pub fn uniaxial_return(e_mod: f64, p: &Plastic, eps: f64, ep: &mut f64, alpha: &mut f64) -> f64 {
    let s = e_mod * (eps - *ep);
    let f = s.abs() - p.yield_at(*alpha);
    if f > 0.0 {
        let dg = f / (e_mod + p.hardening);
        let sign = s.signum();
        *ep += dg * sign;
        *alpha += dg;
        s - e_mod * dg * sign
    } else {
        s
    }
}

/// The state of one element's integration points, borrowed from its block's arrays (one
/// array per quantity, point after point).
#[derive(Debug)]
pub struct PlasticPoints<'a> {
    /// Plastic strain per point (Voigt, tensor shears; bars: the axial one in xx).
    pub strain: &'a mut [[f64; 6]],
    /// Equivalent plastic strain `ε̄ᵖ` per point.
    pub equivalent: &'a mut [f64],
    /// Stress per point at the end of the last evaluation (Voigt; bars: the axial one in
    /// xx), for the trapezoidal plastic work `½ (σ_n + σ_{n+1}) : Δεᵖ`.
    pub stress: &'a mut [[f64; 6]],
}

/// `½ (a + b) : d` for Voigt stresses `a`, `b` and a tensor-shear Voigt strain `d`.
#[inline]
pub(super) fn trapezoid_work(a: &[f64; 6], b: &[f64; 6], d: &[f64; 6]) -> f64 {
    0.5 * ((a[0] + b[0]) * d[0] + (a[1] + b[1]) * d[1] + (a[2] + b[2]) * d[2])
        + ((a[3] + b[3]) * d[3] + (a[4] + b[4]) * d[4] + (a[5] + b[5]) * d[5])
}

/// What an elastoplastic element evaluation adds to [`super::ElementResponse`].
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct PlasticResponse {
    /// Volume-mean plastic strain (Voigt, tensor shears; bars: the axial one in xx).
    pub strain: [f64; 6],
    /// Volume-mean equivalent plastic strain.
    pub equivalent: f64,
    /// Plastic work of this evaluation's returns (J): `Σ_q w_q ½ (σ_n + σ_{n+1}) : Δεᵖ`.
    pub work: f64,
}

/// The elastoplastic law of a continuum element: [`radial_return`] (3-D, plane strain) or
/// [`plane_stress_return`], with the volume-weighted sums of the state and the work.
pub(super) struct PlasticLaw<'a> {
    /// λ (λ* with `plane_stress`).
    pub lambda: f64,
    /// μ.
    pub mu: f64,
    /// Use the plane-stress return.
    pub plane_stress: bool,
    /// The constants.
    pub plastic: Plastic,
    /// The points' state.
    pub points: PlasticPoints<'a>,
    /// `Σ w εᵖ`.
    pub sum_strain: [f64; 6],
    /// `Σ w ε̄ᵖ`.
    pub sum_equivalent: f64,
    /// `Σ w ½ (σ_n + σ_{n+1}) : Δεᵖ`.
    pub work: f64,
}

impl<'a> PlasticLaw<'a> {
    /// A law over `points` (λ* with `plane_stress`).
    pub fn new(
        lambda: f64,
        mu: f64,
        plane_stress: bool,
        plastic: Plastic,
        points: PlasticPoints<'a>,
    ) -> Self {
        PlasticLaw {
            lambda,
            mu,
            plane_stress,
            plastic,
            points,
            sum_strain: [0.0; 6],
            sum_equivalent: 0.0,
            work: 0.0,
        }
    }

    /// The element's plastic response, the sums divided by the element's volume.
    pub fn response(&self, volume: f64) -> PlasticResponse {
        let inv = 1.0 / volume;
        let mut strain = self.sum_strain;
        for s in strain.iter_mut() {
            *s *= inv;
        }
        PlasticResponse {
            strain,
            equivalent: self.sum_equivalent * inv,
            work: self.work,
        }
    }
}

impl PointLaw for PlasticLaw<'_> {
    #[inline]
    fn point(&mut self, q: usize, w: f64, e: &[f64; 6]) -> ([f64; 6], f64) {
        let ep = &mut self.points.strain[q];
        let alpha = &mut self.points.equivalent[q];
        let ep0 = *ep;
        let s = if self.plane_stress {
            plane_stress_return(self.lambda, self.mu, &self.plastic, e, ep, alpha)
        } else {
            radial_return(self.lambda, self.mu, &self.plastic, e, ep, alpha)
        };
        let mut ee = [0.0; 6];
        let mut dep = [0.0; 6];
        for k in 0..6 {
            ee[k] = e[k] - ep[k];
            dep[k] = ep[k] - ep0[k];
            self.sum_strain[k] += w * ep[k];
        }
        self.sum_equivalent += w * *alpha;
        let s0 = &mut self.points.stress[q];
        self.work += w * trapezoid_work(s0, &s, &dep);
        *s0 = s;
        (s, energy_density(&s, &ee))
    }
}

#[cfg(test)]
mod tests {
    //! The return mappings against their defining equations (consistency on the yield
    //! surface, elastic law on the elastic strain, plastic incompressibility, the
    //! equivalent-plastic-strain rate) and against independent solutions (the plane-stress
    //! return against the 3-D return with the thickness strain solved for σ_zz = 0; the bar
    //! against the closed-form 1-D path).

    use super::*;
    use crate::kernels::solid::Elastic;
    use proptest::prelude::*;

    fn steel() -> Elastic {
        Elastic::new(200e9, 0.3, 7800.0)
    }

    const YIELD: f64 = 250e6;

    fn tensor_norm(e: &[f64; 6]) -> f64 {
        (e[0] * e[0] + e[1] * e[1] + e[2] * e[2] + 2.0 * (e[3] * e[3] + e[4] * e[4] + e[5] * e[5]))
            .sqrt()
    }

    /// Checks one return from state (ep0, a0) to (ep, a) at strain `e` with stress `s`.
    fn check_return(
        lambda: f64,
        mu: f64,
        p: &Plastic,
        e: &[f64; 6],
        s: &[f64; 6],
        (ep0, a0): (&[f64; 6], f64),
        (ep, a): (&[f64; 6], f64),
    ) {
        let sy = p.yield_at(a);
        // The stress is the elastic law of the elastic strain.
        let mut ee = [0.0; 6];
        for k in 0..6 {
            ee[k] = e[k] - ep[k];
        }
        let want = stress(lambda, mu, &ee);
        for k in 0..6 {
            assert!(
                (s[k] - want[k]).abs() <= 1e-9 * sy,
                "σ = C(ε − εᵖ), component {k}: {} vs {}",
                s[k],
                want[k]
            );
        }
        let n = deviator_norm(s);
        // Never outside the yield surface.
        assert!(n <= SQRT_2_3 * sy * (1.0 + 1e-12), "|s| {n} > √⅔ σ_y {sy}");
        let mut dep = [0.0; 6];
        for k in 0..6 {
            dep[k] = ep[k] - ep0[k];
        }
        // Plastic incompressibility.
        assert!(
            (ep[0] + ep[1] + ep[2]).abs() <= 1e-13 * tensor_norm(ep).max(1e-6),
            "tr εᵖ = {:e}, |εᵖ| = {:e}",
            ep[0] + ep[1] + ep[2],
            tensor_norm(ep)
        );
        // ε̄ᵖ grows by √⅔ |Δεᵖ|.
        assert!(
            ((a - a0) - SQRT_2_3 * tensor_norm(&dep)).abs() <= 1e-12 * a.max(1e-9),
            "Δε̄ᵖ {} vs √⅔|Δεᵖ| {}",
            a - a0,
            SQRT_2_3 * tensor_norm(&dep)
        );
        if a > a0 {
            // Plastic step: on the yield surface, and the flow is along the deviator.
            assert!(
                (n / (SQRT_2_3 * sy) - 1.0).abs() <= 1e-12,
                "consistency: |s| = {n}, √⅔ σ_y = {}",
                SQRT_2_3 * sy
            );
            let m = (s[0] + s[1] + s[2]) / 3.0;
            let dev = [s[0] - m, s[1] - m, s[2] - m, s[3], s[4], s[5]];
            let r = tensor_norm(&dep) / n;
            for k in 0..6 {
                assert!(
                    (dep[k] - r * dev[k]).abs() <= 1e-9 * tensor_norm(&dep),
                    "Δεᵖ ∥ s, component {k}"
                );
            }
        }
    }

    fn strain_path() -> impl Strategy<Value = Vec<[f64; 6]>> {
        prop::collection::vec(prop::array::uniform6(-4e-3..4e-3f64), 1..6)
    }

    proptest! {
        /// Along random strain paths (each strain a step from the previous state):
        /// consistency `|s| = √⅔ σ_y(ε̄ᵖ)` after every plastic return, the elastic law on
        /// the elastic strain, `tr εᵖ = 0`, `Δε̄ᵖ = √⅔|Δεᵖ|`, flow along the deviator.
        #[test]
        fn radial_return_is_consistent(path in strain_path(), h in 0.0..20e9f64) {
            let m = steel();
            let p = Plastic { yield_stress: YIELD, hardening: h };
            let (mut ep, mut a) = ([0.0; 6], 0.0);
            for e in &path {
                let (ep0, a0) = (ep, a);
                let s = radial_return(m.lambda, m.mu, &p, e, &mut ep, &mut a);
                check_return(m.lambda, m.mu, &p, e, &s, (&ep0, a0), (&ep, a));
            }
        }

        /// The plane-stress return against the 3-D radial return whose thickness strain is
        /// solved (bisection) so that σ_zz = 0: both solve the same backward-Euler
        /// equations, so the stresses and states agree to the solvers' tolerance (1e-9 σ_y);
        /// and the plane-stress state satisfies the checks of the 3-D one.
        #[test]
        fn plane_stress_return_equals_the_3d_return_with_free_thickness(
            path in prop::collection::vec(prop::array::uniform3(-4e-3..4e-3f64), 1..5),
            h in 0.0..20e9f64,
        ) {
            let m = steel();
            let ls = m.plane_stress().lambda;
            let p = Plastic { yield_stress: YIELD, hardening: h };
            let (mut ep, mut a) = ([0.0; 6], 0.0);
            for e3 in &path {
                let e = [e3[0], e3[1], 0.0, 0.0, 0.0, e3[2]];
                // 3-D reference: find ε_zz with σ_zz = 0 (σ_zz increases with ε_zz).
                let zz = |ezz: f64| {
                    let (mut q, mut b) = (ep, a);
                    let s = radial_return(m.lambda, m.mu, &p, &[e[0], e[1], ezz, 0.0, 0.0, e[5]], &mut q, &mut b);
                    (s, q, b)
                };
                let (mut lo, mut hi) = (-0.1, 0.1);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if zz(mid).0[2] > 0.0 { hi = mid } else { lo = mid }
                }
                let (s3, ep3, a3) = zz(0.5 * (lo + hi));
                let (ep0, a0) = (ep, a);
                let s = plane_stress_return(ls, m.mu, &p, &e, &mut ep, &mut a);
                for k in 0..6 {
                    prop_assert!((s[k] - s3[k]).abs() <= 1e-9 * YIELD, "σ {k}: {} vs {}", s[k], s3[k]);
                    prop_assert!((ep[k] - ep3[k]).abs() <= 1e-9 * YIELD / m.e, "εᵖ {k}: {} vs {}", ep[k], ep3[k]);
                }
                prop_assert!((a - a3).abs() <= 1e-9 * YIELD / m.e);
                // The 3-D checks with the thickness strain that makes σ_zz = 0.
                let c = m.lambda / (m.lambda + 2.0 * m.mu);
                let ezz = -c * (e[0] - ep[0] + e[1] - ep[1]) + ep[2];
                let mut e_full = e;
                e_full[2] = ezz;
                check_return(m.lambda, m.mu, &p, &e_full, &s, (&ep0, a0), (&ep, a));
            }
        }
    }

    /// Reference: the closed-form 1-D elastoplastic path with linear isotropic hardening
    /// (E = 200 GPa, σ_y0 = 250 MPa, H = 10 GPa): loading to 3 ε_y (`σ = σ_y0 + E_t(ε − ε_y)`,
    /// `E_t = EH/(E+H)`), elastic unloading (slope E), reverse yield at `−σ_y(ε̄ᵖ)`
    /// (isotropic: the surface grew symmetrically) and the plastic slope again. Every
    /// strain in 200 steps; tolerance 1e-12 σ_y0.
    #[test]
    fn uniaxial_return_follows_the_closed_form_path() {
        let (e_mod, h) = (200e9, 10e9);
        let p = Plastic {
            yield_stress: YIELD,
            hardening: h,
        };
        let ey = YIELD / e_mod;
        let et = e_mod * h / (e_mod + h);
        let (mut ep, mut a) = (0.0, 0.0);
        let e_max = 3.0 * ey;
        let s_max = YIELD + et * (e_max - ey);
        let a_max = (s_max - YIELD) / h;
        let mut path: Vec<f64> = (0..=100).map(|i| e_max * i as f64 / 100.0).collect();
        path.extend((1..=100).map(|i| e_max - 2.0 * e_max * i as f64 / 100.0));
        for (i, &eps) in path.iter().enumerate() {
            let s = uniaxial_return(e_mod, &p, eps, &mut ep, &mut a);
            let want = if i <= 100 {
                if eps <= ey {
                    e_mod * eps
                } else {
                    YIELD + et * (eps - ey)
                }
            } else {
                // unloading from (e_max, s_max): elastic until σ = −σ_y(ε̄ᵖ_max)
                let s_el = s_max - e_mod * (e_max - eps);
                let s_rev = -(YIELD + h * a_max);
                if s_el >= s_rev {
                    s_el
                } else {
                    // reverse plastic: from (ε_r, s_rev) with slope E_t
                    let eps_r = e_max - (s_max - s_rev) / e_mod;
                    s_rev + et * (eps - eps_r)
                }
            };
            assert!(
                (s - want).abs() <= 1e-12 * YIELD * 10.0,
                "ε = {eps:e}: σ = {s:e}, closed form {want:e}"
            );
        }
    }
}
