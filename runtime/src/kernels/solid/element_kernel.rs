//! One zero-sized type per element kernel variant, behind one trait ([`ElementKernel`]), so
//! that a loop over the elements of a type-homogeneous block can be written once, generic
//! over the kernel, and monomorphized per type: the kind is chosen once per block, not
//! matched per element, and the compiler sees one type's straight-line kernel in the loop.
//!
//! The variants are the element kinds of [`ElementKind`] (the plane mode of tri3 and quad4
//! is part of the type). Each implementation calls the per-type kernel ([`super::bar2`],
//! [`super::tri3`], …) exactly as [`super::respond`] and [`super::respond_plastic`] do —
//! those two dispatch to these types — so every path computes the same numbers to the bit.

use super::plasticity::{PlasticLaw, PlasticPoints, PlasticResponse};
use super::{
    bar2, hex8, nodes, quad4, tet4, tri3, Elastic, ElementOptions, ElementResponse, Plane, Plastic,
};
use crate::contract::scene::ElementKind;

/// One element type's evaluation, for the monomorphized block loops.
///
/// `x0`, `u`, `v` hold at least [`ElementKernel::NODES`] rows (reference coordinates,
/// displacements, velocities; world components, 2-D kinds read x and y); the first
/// `NODES` rows of `out.f` are written. The types are zero-sized: the choice of one is the
/// only thing they carry.
pub trait ElementKernel: Copy + Send + Sync + 'static {
    /// The element kind this kernel evaluates.
    const KIND: ElementKind;
    /// Nodes per element (`KIND.nodes()`).
    const NODES: usize;

    /// Internal forces, stress, strain and energies of one elastic element (see
    /// [`super::respond`]).
    fn respond(
        opts: &ElementOptions,
        mat: &Elastic,
        x0: &[[f64; 3]],
        u: &[[f64; 3]],
        v: &[[f64; 3]],
        out: &mut ElementResponse,
    );

    /// The same for an elastoplastic material, with the integration points' state updated
    /// in place (see [`super::respond_plastic`]).
    #[allow(clippy::too_many_arguments)] // respond's arguments, the constants and the state
    fn respond_plastic(
        opts: &ElementOptions,
        mat: &Elastic,
        plastic: &Plastic,
        x0: &[[f64; 3]],
        u: &[[f64; 3]],
        v: &[[f64; 3]],
        points: PlasticPoints<'_>,
        out: &mut ElementResponse,
    ) -> PlasticResponse;
}

/// `bar2`: the truss.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Bar2;

/// `tri3`, plane stress.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tri3PlaneStress;

/// `tri3`, plane strain.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tri3PlaneStrain;

/// `quad4`, plane stress.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Quad4PlaneStress;

/// `quad4`, plane strain.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Quad4PlaneStrain;

/// `tet4`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tet4;

/// `hex8` (one-point with hourglass control, full or B-bar: the quadrature is the
/// options' data).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Hex8;

/// The 3-D return mapping at every point of a tet4 or hex8, whose `respond_with` is `f`.
fn plastic_3d(
    mat: &Elastic,
    plastic: &Plastic,
    points: PlasticPoints<'_>,
    f: impl FnOnce(&mut PlasticLaw<'_>) -> f64,
) -> PlasticResponse {
    let mut l = PlasticLaw::new(mat.lambda, mat.mu, false, *plastic, points);
    let volume = f(&mut l);
    l.response(volume)
}

/// The plane-stress or plane-strain return mapping at every point of a tri3 or quad4, whose
/// `respond_with` is `f`.
fn plastic_plane(
    mat: &Elastic,
    plastic: &Plastic,
    plane: Plane,
    points: PlasticPoints<'_>,
    out: &mut ElementResponse,
    f: impl FnOnce(&mut PlasticLaw<'_>, &mut ElementResponse) -> f64,
) -> PlasticResponse {
    let stress = plane == Plane::Stress;
    let lambda = if stress {
        mat.plane_stress().lambda
    } else {
        mat.lambda
    };
    let mut l = PlasticLaw::new(lambda, mat.mu, stress, *plastic, points);
    let volume = f(&mut l, out);
    let r = l.response(volume);
    if stress {
        // ε_zz = εᵉ_zz + εᵖ_zz, εᵉ_zz = −λ/(λ+2μ)(εᵉ_xx + εᵉ_yy): the elastic
        // formula on the total strain (plane_outputs) misses −(1 − λ/(λ+2μ))(εᵖ_xx + εᵖ_yy).
        let c = mat.lambda / (mat.lambda + 2.0 * mat.mu);
        out.strain[2] -= (1.0 - c) * (r.strain[0] + r.strain[1]);
    }
    r
}

impl ElementKernel for Bar2 {
    const KIND: ElementKind = ElementKind::Bar2;
    const NODES: usize = 2;
    #[inline]
    fn respond(
        opts: &ElementOptions,
        mat: &Elastic,
        x0: &[[f64; 3]],
        u: &[[f64; 3]],
        v: &[[f64; 3]],
        out: &mut ElementResponse,
    ) {
        bar2::respond(opts, mat, nodes(x0), nodes(u), nodes(v), out)
    }
    #[inline]
    fn respond_plastic(
        opts: &ElementOptions,
        mat: &Elastic,
        plastic: &Plastic,
        x0: &[[f64; 3]],
        u: &[[f64; 3]],
        _v: &[[f64; 3]],
        points: PlasticPoints<'_>,
        out: &mut ElementResponse,
    ) -> PlasticResponse {
        bar2::respond_plastic(opts, mat, plastic, nodes(x0), nodes(u), points, out)
    }
}

/// The [`ElementKernel`] of a 2-D kind: `$module` (tri3 or quad4) in plane mode `$plane`.
macro_rules! plane_kernel {
    ($ty:ident, $kind:ident, $module:ident, $plane:expr, $nodes:literal) => {
        impl ElementKernel for $ty {
            const KIND: ElementKind = ElementKind::$kind;
            const NODES: usize = $nodes;
            #[inline]
            fn respond(
                opts: &ElementOptions,
                mat: &Elastic,
                x0: &[[f64; 3]],
                u: &[[f64; 3]],
                v: &[[f64; 3]],
                out: &mut ElementResponse,
            ) {
                $module::respond(opts, mat, $plane, nodes(x0), nodes(u), nodes(v), out)
            }
            #[inline]
            fn respond_plastic(
                opts: &ElementOptions,
                mat: &Elastic,
                plastic: &Plastic,
                x0: &[[f64; 3]],
                u: &[[f64; 3]],
                v: &[[f64; 3]],
                points: PlasticPoints<'_>,
                out: &mut ElementResponse,
            ) -> PlasticResponse {
                plastic_plane(mat, plastic, $plane, points, out, |l, out| {
                    $module::respond_with(opts, mat, $plane, l, nodes(x0), nodes(u), nodes(v), out)
                })
            }
        }
    };
}

plane_kernel!(Tri3PlaneStress, Tri3PlaneStress, tri3, Plane::Stress, 3);
plane_kernel!(Tri3PlaneStrain, Tri3PlaneStrain, tri3, Plane::Strain, 3);
plane_kernel!(Quad4PlaneStress, Quad4PlaneStress, quad4, Plane::Stress, 4);
plane_kernel!(Quad4PlaneStrain, Quad4PlaneStrain, quad4, Plane::Strain, 4);

impl ElementKernel for Tet4 {
    const KIND: ElementKind = ElementKind::Tet4;
    const NODES: usize = 4;
    #[inline]
    fn respond(
        opts: &ElementOptions,
        mat: &Elastic,
        x0: &[[f64; 3]],
        u: &[[f64; 3]],
        v: &[[f64; 3]],
        out: &mut ElementResponse,
    ) {
        tet4::respond(opts, mat, nodes(x0), nodes(u), nodes(v), out)
    }
    #[inline]
    fn respond_plastic(
        opts: &ElementOptions,
        mat: &Elastic,
        plastic: &Plastic,
        x0: &[[f64; 3]],
        u: &[[f64; 3]],
        v: &[[f64; 3]],
        points: PlasticPoints<'_>,
        out: &mut ElementResponse,
    ) -> PlasticResponse {
        plastic_3d(mat, plastic, points, |l| {
            tet4::respond_with(opts, l, nodes(x0), nodes(u), nodes(v), out)
        })
    }
}

impl ElementKernel for Hex8 {
    const KIND: ElementKind = ElementKind::Hex8;
    const NODES: usize = 8;
    #[inline]
    fn respond(
        opts: &ElementOptions,
        mat: &Elastic,
        x0: &[[f64; 3]],
        u: &[[f64; 3]],
        v: &[[f64; 3]],
        out: &mut ElementResponse,
    ) {
        hex8::respond(opts, mat, nodes(x0), nodes(u), nodes(v), out)
    }
    #[inline]
    fn respond_plastic(
        opts: &ElementOptions,
        mat: &Elastic,
        plastic: &Plastic,
        x0: &[[f64; 3]],
        u: &[[f64; 3]],
        v: &[[f64; 3]],
        points: PlasticPoints<'_>,
        out: &mut ElementResponse,
    ) -> PlasticResponse {
        plastic_3d(mat, plastic, points, |l| {
            hex8::respond_with(opts, mat, l, nodes(x0), nodes(u), nodes(v), out)
        })
    }
}

/// `$body` with the type parameter `$k` set to the [`ElementKernel`] of `kind`: the one
/// `match` over the kinds, for the callers that choose per call.
macro_rules! with_kernel {
    ($kind:expr, $k:ident => $body:expr) => {
        match $kind {
            ElementKind::Bar2 => {
                type $k = $crate::kernels::solid::Bar2;
                $body
            }
            ElementKind::Tri3PlaneStress => {
                type $k = $crate::kernels::solid::Tri3PlaneStress;
                $body
            }
            ElementKind::Tri3PlaneStrain => {
                type $k = $crate::kernels::solid::Tri3PlaneStrain;
                $body
            }
            ElementKind::Quad4PlaneStress => {
                type $k = $crate::kernels::solid::Quad4PlaneStress;
                $body
            }
            ElementKind::Quad4PlaneStrain => {
                type $k = $crate::kernels::solid::Quad4PlaneStrain;
                $body
            }
            ElementKind::Tet4 => {
                type $k = $crate::kernels::solid::Tet4;
                $body
            }
            ElementKind::Hex8 => {
                type $k = $crate::kernels::solid::Hex8;
                $body
            }
        }
    };
}
pub(crate) use with_kernel;
