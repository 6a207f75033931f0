//! One zero-sized type per element kernel variant, behind one trait ([`ElementKernel`]), so
//! that a loop over the elements of a type-homogeneous block can be written once, generic
//! over the kernel, and monomorphized per type: the kind is chosen once per block, not
//! matched per element, and the compiler sees one type's straight-line kernel in the loop.
//!
//! The variants are the element kinds of [`ElementKind`] (the plane mode of tri3 and quad4
//! is part of the type) and, for hex8 and quad4, the quadrature: full (2×2×2, 2×2,
//! optionally B-bar) or one point with hourglass control (`…Reduced`), whose code paths
//! share nothing but the element. The type chooses the quadrature; the options give only its
//! constants (the B-bar flag, the hourglass control). Each implementation calls the
//! per-type kernel ([`super::bar2`], [`super::tri3`], …) exactly as [`super::respond`] and
//! [`super::respond_plastic`] do — those two dispatch to these types — so every path
//! computes the same numbers to the bit.

use super::continuum::{plane_law, ElasticLaw, PointLaw};
use super::plasticity::{PlasticLaw, PlasticPoints, PlasticResponse};
use super::{
    bar2, hex8, nodes, quad4, tet4, tri3, Elastic, ElementOptions, ElementResponse, Hourglass,
    Integration, Plane, Plastic,
};
use crate::contract::scene::ElementKind;

/// `$body` with the type parameter `$k` set to the [`ElementKernel`] of `kind` (its
/// one-point variant when `reduced`, see [`reduced`]): the one `match` over the kernels, for
/// the callers that choose per call.
macro_rules! with_kernel {
    ($kind:expr, $reduced:expr, $k:ident => $body:expr) => {{
        use $crate::contract::scene::ElementKind as Kind;
        use $crate::kernels::solid as s;
        match ($kind, $reduced) {
            (Kind::Bar2, _) => {
                type $k = s::Bar2;
                $body
            }
            (Kind::Tri3PlaneStress, _) => {
                type $k = s::Tri3PlaneStress;
                $body
            }
            (Kind::Tri3PlaneStrain, _) => {
                type $k = s::Tri3PlaneStrain;
                $body
            }
            (Kind::Quad4PlaneStress, false) => {
                type $k = s::Quad4PlaneStress;
                $body
            }
            (Kind::Quad4PlaneStress, true) => {
                type $k = s::Quad4PlaneStressReduced;
                $body
            }
            (Kind::Quad4PlaneStrain, false) => {
                type $k = s::Quad4PlaneStrain;
                $body
            }
            (Kind::Quad4PlaneStrain, true) => {
                type $k = s::Quad4PlaneStrainReduced;
                $body
            }
            (Kind::Tet4, _) => {
                type $k = s::Tet4;
                $body
            }
            (Kind::Hex8, false) => {
                type $k = s::Hex8;
                $body
            }
            (Kind::Hex8, true) => {
                type $k = s::Hex8Reduced;
                $body
            }
        }
    }};
}
pub(crate) use with_kernel;

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
    /// Whether this is the one-point (hourglass-controlled) variant of hex8 or quad4
    /// ([`reduced`]).
    const REDUCED: bool;
    /// The type's name, as `mbdc_runtime::solid` exports it.
    const NAME: &'static str;

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

/// `quad4`, plane stress, full 2×2 quadrature.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Quad4PlaneStress;

/// `quad4`, plane strain, full 2×2 quadrature (B-bar if the options say so).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Quad4PlaneStrain;

/// `quad4`, plane stress, one point with hourglass control.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Quad4PlaneStressReduced;

/// `quad4`, plane strain, one point with hourglass control.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Quad4PlaneStrainReduced;

/// `tet4`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tet4;

/// `hex8`, full 2×2×2 quadrature (B-bar if the options say so).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Hex8;

/// `hex8`, one point with Flanagan–Belytschko hourglass control.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Hex8Reduced;

/// Whether an element of `kind` evaluated with `integration` runs the one-point variant of
/// its kernel: reduced hex8 and quad4; the other kinds have one variant (false).
pub fn reduced(kind: ElementKind, integration: &Integration) -> bool {
    matches!(
        kind,
        ElementKind::Hex8 | ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain
    ) && matches!(integration, Integration::Reduced(_))
}

/// The name of the [`ElementKernel`] type of `kind` (one-point variant when `reduced`), as
/// `mbdc_runtime::solid` exports it.
pub fn kernel_name(kind: ElementKind, reduced: bool) -> &'static str {
    with_kernel!(kind, reduced, K => K::NAME)
}

/// The B-bar flag of full quadrature (false when the options ask for one point).
#[inline]
fn bbar(opts: &ElementOptions) -> bool {
    matches!(opts.integration, Integration::Full { bbar: true })
}

/// The hourglass control of one-point quadrature (none, a zero coefficient, when the
/// options ask for full quadrature).
#[inline]
fn hourglass(opts: &ElementOptions) -> Hourglass {
    match opts.integration {
        Integration::Reduced(hg) => hg,
        Integration::Full { .. } => Hourglass::Viscous { coefficient: 0.0 },
    }
}

/// quad4 with full quadrature, in `respond_with`'s form.
#[allow(clippy::too_many_arguments)] // respond's arguments and the law
#[inline]
fn quad4_full<L: PointLaw>(
    opts: &ElementOptions,
    mat: &Elastic,
    plane: Plane,
    law: &mut L,
    x0: &[[f64; 3]; 4],
    u: &[[f64; 3]; 4],
    _v: &[[f64; 3]; 4],
    out: &mut ElementResponse,
) -> f64 {
    quad4::full_with(opts, mat, plane, law, bbar(opts), x0, u, out)
}

/// quad4 with one point, in `respond_with`'s form.
#[allow(clippy::too_many_arguments)] // respond's arguments and the law
#[inline]
fn quad4_reduced<L: PointLaw>(
    opts: &ElementOptions,
    mat: &Elastic,
    plane: Plane,
    law: &mut L,
    x0: &[[f64; 3]; 4],
    u: &[[f64; 3]; 4],
    v: &[[f64; 3]; 4],
    out: &mut ElementResponse,
) -> f64 {
    quad4::reduced_with(opts, mat, plane, law, hourglass(opts), x0, u, v, out)
}

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

/// The [`ElementKernel`] impl of `$ty`: its constants, and the bodies of `respond` and
/// `respond_plastic` with the parameter names they use (a name starting with `_` for a
/// parameter the body does not read), so that each impl states only what differs.
macro_rules! kernel {
    (
        $ty:ident: $kind:ident, $nodes:literal nodes, reduced $reduced:literal;
        respond($opts:ident, $mat:ident, $x0:ident, $u:ident, $v:ident, $out:ident) $respond:block
        respond_plastic(
            $p_opts:ident, $p_mat:ident, $plastic:ident, $p_x0:ident, $p_u:ident, $p_v:ident,
            $points:ident, $p_out:ident
        ) $respond_plastic:block
    ) => {
        impl ElementKernel for $ty {
            const NAME: &'static str = stringify!($ty);
            const KIND: ElementKind = ElementKind::$kind;
            const NODES: usize = $nodes;
            const REDUCED: bool = $reduced;
            #[inline]
            fn respond(
                $opts: &ElementOptions,
                $mat: &Elastic,
                $x0: &[[f64; 3]],
                $u: &[[f64; 3]],
                $v: &[[f64; 3]],
                $out: &mut ElementResponse,
            ) $respond
            #[inline]
            fn respond_plastic(
                $p_opts: &ElementOptions,
                $p_mat: &Elastic,
                $plastic: &Plastic,
                $p_x0: &[[f64; 3]],
                $p_u: &[[f64; 3]],
                $p_v: &[[f64; 3]],
                $points: PlasticPoints<'_>,
                $p_out: &mut ElementResponse,
            ) -> PlasticResponse $respond_plastic
        }
    };
}

kernel! {
    Bar2: Bar2, 2 nodes, reduced false;
    respond(opts, mat, x0, u, v, out) {
        bar2::respond(opts, mat, nodes(x0), nodes(u), nodes(v), out)
    }
    respond_plastic(opts, mat, plastic, x0, u, _v, points, out) {
        bar2::respond_plastic(opts, mat, plastic, nodes(x0), nodes(u), points, out)
    }
}

/// The [`ElementKernel`] of a 2-D kind: `$with` (a `respond_with` of tri3 or quad4) in plane
/// mode `$plane`.
macro_rules! plane_kernel {
    ($ty:ident, $kind:ident, $with:path, $plane:expr, $nodes:literal, $reduced:literal) => {
        kernel! {
            $ty: $kind, $nodes nodes, reduced $reduced;
            respond(opts, mat, x0, u, v, out) {
                let mut law = plane_law($plane, mat);
                $with(
                    opts,
                    mat,
                    $plane,
                    &mut law,
                    nodes(x0),
                    nodes(u),
                    nodes(v),
                    out,
                );
            }
            respond_plastic(opts, mat, plastic, x0, u, v, points, out) {
                plastic_plane(mat, plastic, $plane, points, out, |l, out| {
                    $with(opts, mat, $plane, l, nodes(x0), nodes(u), nodes(v), out)
                })
            }
        }
    };
}

plane_kernel!(
    Tri3PlaneStress,
    Tri3PlaneStress,
    tri3::respond_with,
    Plane::Stress,
    3,
    false
);
plane_kernel!(
    Tri3PlaneStrain,
    Tri3PlaneStrain,
    tri3::respond_with,
    Plane::Strain,
    3,
    false
);
plane_kernel!(
    Quad4PlaneStress,
    Quad4PlaneStress,
    quad4_full,
    Plane::Stress,
    4,
    false
);
plane_kernel!(
    Quad4PlaneStrain,
    Quad4PlaneStrain,
    quad4_full,
    Plane::Strain,
    4,
    false
);
plane_kernel!(
    Quad4PlaneStressReduced,
    Quad4PlaneStress,
    quad4_reduced,
    Plane::Stress,
    4,
    true
);
plane_kernel!(
    Quad4PlaneStrainReduced,
    Quad4PlaneStrain,
    quad4_reduced,
    Plane::Strain,
    4,
    true
);

kernel! {
    Tet4: Tet4, 4 nodes, reduced false;
    respond(opts, mat, x0, u, v, out) {
        tet4::respond(opts, mat, nodes(x0), nodes(u), nodes(v), out)
    }
    respond_plastic(opts, mat, plastic, x0, u, v, points, out) {
        plastic_3d(mat, plastic, points, |l| {
            tet4::respond_with(opts, l, nodes(x0), nodes(u), nodes(v), out)
        })
    }
}

kernel! {
    Hex8: Hex8, 8 nodes, reduced false;
    respond(opts, mat, x0, u, _v, out) {
        let mut law = ElasticLaw {
            lambda: mat.lambda,
            mu: mat.mu,
        };
        hex8::full_with(opts, &mut law, bbar(opts), nodes(x0), nodes(u), out);
    }
    respond_plastic(opts, mat, plastic, x0, u, _v, points, out) {
        plastic_3d(mat, plastic, points, |l| {
            hex8::full_with(opts, l, bbar(opts), nodes(x0), nodes(u), out)
        })
    }
}

kernel! {
    Hex8Reduced: Hex8, 8 nodes, reduced true;
    respond(opts, mat, x0, u, v, out) {
        let mut law = ElasticLaw {
            lambda: mat.lambda,
            mu: mat.mu,
        };
        let hg = hourglass(opts);
        hex8::reduced_with(opts, mat, &mut law, hg, nodes(x0), nodes(u), nodes(v), out);
    }
    respond_plastic(opts, mat, plastic, x0, u, v, points, out) {
        let hg = hourglass(opts);
        plastic_3d(mat, plastic, points, |l| {
            hex8::reduced_with(opts, mat, l, hg, nodes(x0), nodes(u), nodes(v), out)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::{respond, Kinematics};
    use super::*;

    /// Every value of a response, bit for bit (`Debug` prints each `f64` exactly, −0 apart
    /// from +0).
    fn bits(r: &ElementResponse) -> String {
        format!("{r:?}")
    }

    /// Per kind and quadrature, the dispatch to the kernel types computes what the per-type
    /// kernels do (which choose the quadrature from the options at run time).
    #[test]
    fn the_kernel_types_are_the_per_type_kernels_to_the_bit() {
        let mat = Elastic {
            lambda: 1.1e9,
            mu: 0.8e9,
            e: 2.1e9,
            rho: 2700.0,
        };
        let x0: [[f64; 3]; 8] = [
            [0.0, 0.0, 0.0],
            [0.1, 0.0, 0.0],
            [0.11, 0.09, 0.0],
            [0.0, 0.1, 0.0],
            [0.0, 0.0, 0.1],
            [0.1, 0.01, 0.1],
            [0.1, 0.1, 0.1],
            [0.0, 0.1, 0.12],
        ];
        let wave = |a: usize, k: usize, s: f64| s * ((3 * a + k) as f64 * 0.7).sin();
        let u: [[f64; 3]; 8] = std::array::from_fn(|a| std::array::from_fn(|k| wave(a, k, 1e-3)));
        let v: [[f64; 3]; 8] =
            std::array::from_fn(|a| std::array::from_fn(|k| wave(a, k + 5, 0.3)));
        let integrations = [
            Integration::Full { bbar: false },
            Integration::Full { bbar: true },
            Integration::Reduced(Hourglass::Viscous { coefficient: 0.1 }),
            Integration::Reduced(Hourglass::Stiffness { coefficient: 0.05 }),
        ];
        for integration in integrations {
            for kinematics in [Kinematics::SmallStrain, Kinematics::TotalLagrangian] {
                let opts = ElementOptions {
                    kinematics,
                    integration,
                    thickness: 0.01,
                    ..ElementOptions::default()
                };
                let run = |kind, f: &dyn Fn(&mut ElementResponse)| {
                    let (mut a, mut b) = (ElementResponse::default(), ElementResponse::default());
                    respond(kind, &opts, &mat, &x0, &u, &v, &mut a);
                    f(&mut b);
                    assert_eq!(
                        bits(&a),
                        bits(&b),
                        "{kind:?} {integration:?} {kinematics:?}"
                    );
                };
                run(ElementKind::Hex8, &|r| {
                    hex8::respond(&opts, &mat, &x0, &u, &v, r)
                });
                let q = |x: &[[f64; 3]; 8]| -> [[f64; 3]; 4] { std::array::from_fn(|a| x[a]) };
                for (kind, plane) in [
                    (ElementKind::Quad4PlaneStress, Plane::Stress),
                    (ElementKind::Quad4PlaneStrain, Plane::Strain),
                ] {
                    run(kind, &|r| {
                        quad4::respond(&opts, &mat, plane, &q(&x0), &q(&u), &q(&v), r)
                    });
                }
            }
        }
        assert_eq!(kernel_name(ElementKind::Hex8, true), "Hex8Reduced");
        assert_eq!(kernel_name(ElementKind::Tet4, true), "Tet4");
        assert_eq!(
            kernel_name(ElementKind::Quad4PlaneStrain, false),
            "Quad4PlaneStrain"
        );
    }
}
