//! Solid finite elements: the internal force of one element of a mesh at one
//! configuration, for the explicit central-difference method (notes D §1.1, blueprint §6).
//!
//! Every kernel is a pure function of the element's reference coordinates `x0`, its nodal
//! displacements `u` and velocities `v` (world components, m and m/s; 2-D elements use x
//! and y and ignore z), and writes an [`ElementResponse`]: the internal nodal forces (to be
//! *subtracted* from the external forces), the element's mean stress and strain, and the
//! hourglass power. No stiffness matrix is formed (the method is matrix-free).
//!
//! Element types ([`ElementKind`]): `bar2` (truss), `tri3` and `quad4` (plane stress or
//! plane strain, with a thickness), `tet4`, `hex8` with one-point integration and
//! Flanagan–Belytschko hourglass control or fully integrated 2×2×2 (optionally B-bar).
//! Kinematics ([`Kinematics`]): small strain (linear elastic) or total-Lagrangian
//! St Venant–Kirchhoff (large rotations). Elastoplastic materials ([`respond_plastic`]):
//! J2 plasticity with linear isotropic hardening by return mapping at every integration
//! point ([`plasticity`]), with the state of the points passed in and updated; the elastic
//! entry point [`respond`] has no state and compiles to the elastic loops alone.
//!
//! Beside the forces: [`lumped_masses`] (the element's share of mass per node),
//! [`max_frequency`] (an upper bound of the element's highest undamped frequency with
//! lumped mass, for the central-difference limit `h ≤ 2/ω_max`), and [`shape_check`] (the
//! smallest Jacobian determinant, to refuse degenerate or inverted elements).
//!
//! Files, one concept each: `material` (Lamé constants, plane-stress reduction
//! `λ* = 2λμ/(λ+2μ)`, stress and energy density for both kinematics), `continuum`
//! (isoparametric gradients, the quadrature loop generic over the point law, B-bar),
//! [`plasticity`] (the return mappings and the elastoplastic point law), `hourglass` (Flanagan–Belytschko,
//! its coefficients documented there), the element types [`bar2`], [`tri3`], [`quad4`],
//! [`tet4`], [`hex8`] (public, with fixed-size-array entry points), `element_kernel` (one
//! zero-sized type per kind behind the [`ElementKernel`] trait, for loops monomorphized per
//! type; [`respond`] and [`respond_plastic`] dispatch to them), `frequency` ([`max_frequency`]), `stiffness` ([`element_stiffness`], the small-strain `K_e` of the implicit analyses), `shape` ([`shape_check`]) and `tests`.
//!
//! Conventions: forces are internal (`M a = f_ext − f`); stress and strain are volume means
//! in Voigt order `xx yy zz yz xz xy` with tensor shear strains; 2-D kinds take their plane
//! mode from the kind, not from [`ElementOptions::plane`], multiply by
//! [`ElementOptions::thickness`] and report σ_zz = 0 (plane stress) or λ tr ε (plane strain);
//! bars use the thickness as the cross-section area. `min_jacobian` and [`shape_check`]
//! report `det J` of the map from the parent element (bar2 `L/2`, tri3 `2A`, tet4 `6V`,
//! quad4/hex8 with ξ ∈ [−1, 1]: `A/4`, `V/8` on parallelograms).

use crate::contract::scene::ElementKind;
pub(crate) use element_kernel::with_kernel;
pub use element_kernel::{
    kernel_name, reduced, Bar2, ElementKernel, Hex8, Hex8Reduced, Quad4PlaneStrain,
    Quad4PlaneStrainReduced, Quad4PlaneStress, Quad4PlaneStressReduced, Tet4, Tri3PlaneStrain,
    Tri3PlaneStress,
};
pub use plasticity::{Plastic, PlasticPoints, PlasticResponse};
pub use stiffness::{element_stiffness, ElementMatrix, MAX_DOFS};

pub mod bar2;
mod continuum;
mod element_kernel;
mod frequency;
pub mod hex8;
mod hourglass;
mod material;
pub mod plasticity;
pub mod quad4;
mod shape;
mod stiffness;
#[cfg(test)]
mod tests;
pub mod tet4;
pub mod tri3;

/// Largest number of nodes of an element.
pub const MAX_NODES: usize = 8;

/// The strain measure and stress law.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Kinematics {
    /// Small strain, linear elastic: `ε = sym ∇u`, `σ = λ tr ε I + 2μ ε`.
    #[default]
    SmallStrain,
    /// Total Lagrangian St Venant–Kirchhoff: Green–Lagrange `E`, second Piola–Kirchhoff
    /// `S = λ tr E I + 2μ E`, nodal forces from `P = F S`. Exact under rigid rotations.
    TotalLagrangian,
}

/// In-plane behaviour of 2-D elements.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Plane {
    /// σ_zz = 0.
    #[default]
    Stress,
    /// ε_zz = 0.
    Strain,
}

/// Flanagan–Belytschko hourglass control of one-point hex8 (and quad4) elements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Hourglass {
    /// Viscous: forces proportional to the hourglass velocity modes (dissipative).
    Viscous {
        /// Dimensionless coefficient (typically 0.05–0.15).
        coefficient: f64,
    },
    /// Stiffness: forces proportional to the hourglass displacement modes (stores energy).
    Stiffness {
        /// Dimensionless coefficient (typically 0.05–0.15).
        coefficient: f64,
    },
}

/// Quadrature of hex8 (and quad4) elements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integration {
    /// One point with hourglass control.
    Reduced(Hourglass),
    /// Full (2×2×2, 2×2), optionally with the B-bar (mean dilatation) against locking.
    Full {
        /// Mean volumetric strain over the element.
        bbar: bool,
    },
}

impl Default for Integration {
    fn default() -> Self {
        Integration::Full { bbar: false }
    }
}

/// Isotropic elastic constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Elastic {
    /// First Lamé constant, Pa.
    pub lambda: f64,
    /// Shear modulus, Pa.
    pub mu: f64,
    /// Young's modulus, Pa (bars use it).
    pub e: f64,
    /// Density, kg/m³.
    pub rho: f64,
}

/// How one element type is evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ElementOptions {
    /// Strain measure.
    pub kinematics: Kinematics,
    /// 2-D elements: plane stress or strain. Not read by the kernels: the plane mode of the
    /// [`ElementKind`] (`Tri3PlaneStress`, …) is authoritative; kept for callers' records.
    pub plane: Plane,
    /// hex8 and quad4 quadrature.
    pub integration: Integration,
    /// 2-D elements: thickness (m); bars: cross-section area (m²); unused by solids.
    pub thickness: f64,
}

/// What one element evaluation produces.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ElementResponse {
    /// Internal nodal forces (N), first `kind.nodes()` rows used.
    pub f: [[f64; 3]; MAX_NODES],
    /// Volume-mean stress, Voigt order xx yy zz yz xz xy (Pa): Cauchy for small strain,
    /// second Piola–Kirchhoff for total Lagrangian. Bars: xx is the axial stress.
    pub stress: [f64; 6],
    /// Volume-mean strain, same order, tensor (not engineering) shear components.
    pub strain: [f64; 6],
    /// Elastic strain energy of the element (J), hourglass stiffness energy excluded.
    pub strain_energy: f64,
    /// Hourglass forces' stored energy (stiffness form, J).
    pub hourglass_energy: f64,
    /// The power the hourglass control dissipates (W): `Σ f_hg · v` for the viscous form,
    /// 0 for the stiffness form (conservative: its work goes into `hourglass_energy`).
    pub hourglass_power: f64,
    /// Smallest Jacobian determinant of the deformed element over its integration points
    /// (≤ 0: the element has inverted).
    pub min_jacobian: f64,
}

/// A degenerate element (zero or negative Jacobian in its reference configuration).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Degenerate {
    /// Smallest Jacobian determinant found.
    pub min_jacobian: f64,
    /// Local index of the node (corner) where it was found.
    pub corner: usize,
}

/// The first `N` rows of a node slice as an array (panics when the slice is shorter).
#[inline]
fn nodes<const N: usize>(x: &[[f64; 3]]) -> &[[f64; 3]; N] {
    x[..N]
        .try_into()
        .expect("solid element: fewer node rows than kind.nodes()")
}

/// Internal forces, stress, strain and energies of one element.
///
/// `x0`, `u`, `v` hold at least `kind.nodes()` rows. Dispatches to the [`ElementKernel`] of
/// the kind and quadrature ([`Bar2`], [`Tri3PlaneStress`], …, [`Hex8`], [`Hex8Reduced`]),
/// which calls the per-type kernel
/// ([`bar2::respond`], [`tri3::respond`], [`quad4::respond`], [`tet4::respond`],
/// [`hex8::respond`]); loops over many elements of one kind call the [`ElementKernel`]
/// directly instead (monomorphized, no `match` per element). No allocation. For 2-D kinds
/// the plane mode comes from the kind and `opts.plane` is ignored.
pub fn respond(
    kind: ElementKind,
    opts: &ElementOptions,
    mat: &Elastic,
    x0: &[[f64; 3]],
    u: &[[f64; 3]],
    v: &[[f64; 3]],
    out: &mut ElementResponse,
) {
    with_kernel!(kind, reduced(kind, &opts.integration), K => {
        K::respond(opts, mat, x0, u, v, out)
    })
}

/// Number of integration points of an element of `kind` evaluated with `opts`: the length
/// of the [`PlasticPoints`] slices [`respond_plastic`] takes. bar2, tri3, tet4 and reduced
/// quad4/hex8: 1; full or B-bar quad4: 4; full or B-bar hex8: 8.
pub fn integration_points(kind: ElementKind, opts: &ElementOptions) -> usize {
    let full = matches!(opts.integration, Integration::Full { .. });
    match kind {
        ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain if full => 4,
        ElementKind::Hex8 if full => 8,
        _ => 1,
    }
}

/// [`respond`] for an elastoplastic material: J2 plasticity with linear isotropic
/// hardening ([`plasticity`]) at every integration point. `points` holds the plastic state
/// of the element's [`integration_points`] (plastic strain, equivalent plastic strain) at
/// the start of the step and is updated by the return mapping; the returned
/// [`PlasticResponse`] has their volume means and the plastic work of this evaluation.
///
/// Per kind: bar2 the 1-D return; plane-stress tri3/quad4 the plane-stress return of
/// Simo & Taylor (σ_zz = 0 exactly); plane-strain tri3/quad4, tet4 and hex8 (one-point,
/// full and B-bar, where the return sees the B-bar strain) the 3-D radial return. The
/// hourglass forces of one-point elements stay elastic. With total Lagrangian kinematics
/// the returns act on the Green–Lagrange strain and the second Piola–Kirchhoff stress
/// (additive split; valid for small elastic strains). `out.strain_energy` is the elastic
/// energy `½ σ : εᵉ`; for plane stress `out.strain[2]` includes the plastic `εᵖ_zz`.
/// No allocation.
///
/// # Panics
/// When `points` holds fewer than [`integration_points`] entries.
#[allow(clippy::too_many_arguments)] // respond's arguments, the constants and the state
pub fn respond_plastic(
    kind: ElementKind,
    opts: &ElementOptions,
    mat: &Elastic,
    plastic: &Plastic,
    x0: &[[f64; 3]],
    u: &[[f64; 3]],
    v: &[[f64; 3]],
    points: PlasticPoints<'_>,
    out: &mut ElementResponse,
) -> PlasticResponse {
    with_kernel!(kind, reduced(kind, &opts.integration), K => {
        K::respond_plastic(opts, mat, plastic, x0, u, v, points, out)
    })
}

/// Each node's share of the element's mass (kg), first `kind.nodes()` used.
///
/// Row-sum lumping `m_a = ∫ ρ N_a dV`: equal shares for bar2 (`ρ A L/2`), tri3
/// (`ρ t A/3`) and tet4 (`ρ V/4`); quad4 and hex8 integrate `N_a` exactly (equal shares on
/// parallelograms / parallelepipeds). `opts.thickness` is the bar area or the 2-D thickness.
pub fn lumped_masses(
    kind: ElementKind,
    opts: &ElementOptions,
    rho: f64,
    x0: &[[f64; 3]],
) -> [f64; MAX_NODES] {
    let mut m = [0.0; MAX_NODES];
    let t = opts.thickness;
    match kind {
        ElementKind::Bar2 => m[..2].copy_from_slice(&bar2::lumped_masses(rho, t, nodes(x0))),
        ElementKind::Tri3PlaneStress | ElementKind::Tri3PlaneStrain => {
            m[..3].copy_from_slice(&tri3::lumped_masses(rho, t, nodes(x0)))
        }
        ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain => {
            m[..4].copy_from_slice(&quad4::lumped_masses(rho, t, nodes(x0)))
        }
        ElementKind::Tet4 => m[..4].copy_from_slice(&tet4::lumped_masses(rho, nodes(x0))),
        ElementKind::Hex8 => m[..8].copy_from_slice(&hex8::lumped_masses(rho, nodes(x0))),
    }
    m
}

/// An upper bound of the element's highest undamped angular frequency with lumped mass
/// (rad/s), including the hourglass stiffness of reduced elements.
///
/// bar2: exactly `2c/L`. Others: `√λ_max(M^{-1/2} K M^{-1/2})` of the small-strain element
/// stiffness at the reference configuration (raised by 1e-10 relative against round-off).
/// The mesh's stable central-difference step is `h ≤ 2 / max_e ω_e` (Irons' bound: the
/// assembled highest frequency never exceeds the largest element one). Runs once per
/// element before a run; no heap allocation.
pub fn max_frequency(
    kind: ElementKind,
    opts: &ElementOptions,
    mat: &Elastic,
    x0: &[[f64; 3]],
) -> f64 {
    frequency::max_frequency(kind, opts, mat, x0)
}

/// The element's reference shape: `Ok(min det J)`, or `Err` when a Jacobian determinant is
/// zero or negative (bars: zero length; 2-D elements: also clockwise node order; hex8:
/// corners, Gauss points and centroid checked).
pub fn shape_check(kind: ElementKind, x0: &[[f64; 3]]) -> Result<f64, Degenerate> {
    shape::shape_check(kind, x0)
}
