//! Two-node bar (truss), cross-section area `A = opts.thickness`, Young's modulus `E`.
//!
//! - Small strain: axis `n = (X₁ − X₀)/L` (reference), `ε = n·(u₁ − u₀)/L`, `σ = E ε`,
//!   `f₁ = −f₀ = σ A n`, energy `½ E ε² A L`.
//! - Total Lagrangian: current axis `d = x₁ − x₀`, Green–Lagrange `E_GL = (|d|² − L²)/(2L²)`,
//!   `S = E · E_GL`, `f₁ = −f₀ = S A d / L` (along the current axis; `P = F S`), energy
//!   `½ E E_GL² A L`. Exact under rigid rotations.
//!
//! - Elastoplastic ([`respond_plastic`]): the 1-D return of J2 plasticity on the axial
//!   strain (ε or E_GL), `σ = E(ε − εᵖ)`, energy `½ σ (ε − εᵖ) A L`.
//!
//! Stress and strain: only xx, the axial component (σ or S; ε or E_GL). `min_jacobian` is
//! `dx/dξ = |d|/2` (ξ ∈ [−1, 1]): 0 when the bar has collapsed to a point.
//! With lumped masses `ρ A L / 2` the highest frequency is exactly `2c/L`, `c = √(E/ρ)`.

use super::plasticity::{uniaxial_return, Plastic, PlasticPoints, PlasticResponse};
use super::{Elastic, ElementOptions, ElementResponse, Kinematics};

#[inline]
fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline]
fn norm(a: &[f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// Reference length `L`.
#[inline]
pub fn length(x0: &[[f64; 3]; 2]) -> f64 {
    norm(&sub(&x0[1], &x0[0]))
}

/// Axial force, stress and strain of one bar.
pub fn respond(
    opts: &ElementOptions,
    mat: &Elastic,
    x0: &[[f64; 3]; 2],
    u: &[[f64; 3]; 2],
    _v: &[[f64; 3]; 2],
    out: &mut ElementResponse,
) {
    respond_with(opts, x0, u, out, |strain| (mat.e * strain, strain));
}

/// Axial force, stress and strain of one elastoplastic bar: the 1-D return
/// ([`uniaxial_return`]) on the axial strain (small strain) or on the Green–Lagrange
/// strain with the second Piola–Kirchhoff stress (total Lagrangian). `points` holds the
/// bar's one point: its axial plastic strain (in xx), `∫|dεᵖ|` and its last stress,
/// updated; the work is `½ (σ_n + σ_{n+1}) Δεᵖ A L`.
pub fn respond_plastic(
    opts: &ElementOptions,
    mat: &Elastic,
    plastic: &Plastic,
    x0: &[[f64; 3]; 2],
    u: &[[f64; 3]; 2],
    points: PlasticPoints<'_>,
    out: &mut ElementResponse,
) -> PlasticResponse {
    let ep = &mut points.strain[0];
    let alpha = &mut points.equivalent[0];
    let s0 = &mut points.stress[0];
    let (ep0, sigma0) = (ep[0], s0[0]);
    let volume = respond_with(opts, x0, u, out, |strain| {
        let s = uniaxial_return(mat.e, plastic, strain, &mut ep[0], alpha);
        (s, strain - ep[0])
    });
    let sigma = out.stress[0];
    s0[0] = sigma;
    PlasticResponse {
        strain: [ep[0], 0.0, 0.0, 0.0, 0.0, 0.0],
        equivalent: *alpha,
        work: volume * 0.5 * (sigma0 + sigma) * (ep[0] - ep0),
    }
}

/// The bar with the axial stress from `law(strain) = (stress, elastic strain)`; returns
/// the volume `A L`.
#[inline]
fn respond_with(
    opts: &ElementOptions,
    x0: &[[f64; 3]; 2],
    u: &[[f64; 3]; 2],
    out: &mut ElementResponse,
    law: impl FnOnce(f64) -> (f64, f64),
) -> f64 {
    let area = opts.thickness;
    let l0v = sub(&x0[1], &x0[0]);
    let l0 = norm(&l0v);
    let du = sub(&u[1], &u[0]);
    let d = [l0v[0] + du[0], l0v[1] + du[1], l0v[2] + du[2]];
    let (strain, dir) = match opts.kinematics {
        Kinematics::SmallStrain => {
            let n = [l0v[0] / l0, l0v[1] / l0, l0v[2] / l0];
            ((n[0] * du[0] + n[1] * du[1] + n[2] * du[2]) / l0, n)
        }
        Kinematics::TotalLagrangian => {
            // |d|² − L² = 2 L·Δu + Δu·Δu, without cancellation (exactly 0 under translation).
            let dl = 2.0 * (l0v[0] * du[0] + l0v[1] * du[1] + l0v[2] * du[2])
                + du[0] * du[0]
                + du[1] * du[1]
                + du[2] * du[2];
            (dl / (2.0 * l0 * l0), [d[0] / l0, d[1] / l0, d[2] / l0])
        }
    };
    let (s, elastic) = law(strain);
    out.f = [[0.0; 3]; super::MAX_NODES];
    for (i, di) in dir.iter().enumerate() {
        out.f[1][i] = s * area * di;
        out.f[0][i] = -out.f[1][i];
    }
    out.stress = [s, 0.0, 0.0, 0.0, 0.0, 0.0];
    out.strain = [strain, 0.0, 0.0, 0.0, 0.0, 0.0];
    out.strain_energy = 0.5 * s * elastic * area * l0;
    out.hourglass_energy = 0.0;
    out.hourglass_power = 0.0;
    out.min_jacobian = 0.5 * norm(&d);
    area * l0
}

/// Equal halves of `ρ A L`.
pub fn lumped_masses(rho: f64, area: f64, x0: &[[f64; 3]; 2]) -> [f64; 2] {
    [0.5 * rho * area * length(x0); 2]
}

/// `2c/L`, `c = √(E/ρ)`: the exact highest frequency with lumped mass.
pub fn max_frequency(mat: &Elastic, x0: &[[f64; 3]; 2]) -> f64 {
    2.0 * (mat.e / mat.rho).sqrt() / length(x0)
}
