//! Tests of the solid kernels across element types. References are stated per test: exact
//! linear-elastic solutions (patch tests), invariance (rigid motions), closed forms (bar
//! frequency `2c/L`, mean-dilatation energy ratio), and self-consistency (force = energy
//! gradient, element eigenvalues computed independently from the energy).

#![allow(clippy::needless_range_loop)] // index loops mirror the index notation

use super::material::{stress, VOIGT};
use super::*;
use crate::contract::scene::ElementKind;
use nalgebra::DMatrix;
use proptest::prelude::*;

type X = [[f64; 3]; MAX_NODES];

fn steel() -> Elastic {
    Elastic::new(200e9, 0.3, 7800.0)
}

const ALL: [ElementKind; 7] = [
    ElementKind::Bar2,
    ElementKind::Tri3PlaneStress,
    ElementKind::Tri3PlaneStrain,
    ElementKind::Quad4PlaneStress,
    ElementKind::Quad4PlaneStrain,
    ElementKind::Tet4,
    ElementKind::Hex8,
];

/// Distorted (non-parallelogram) reference elements, positively oriented.
fn geometry(kind: ElementKind) -> X {
    let mut x = [[0.0; 3]; MAX_NODES];
    let pts: &[[f64; 3]] = match kind {
        ElementKind::Bar2 => &[[0.1, 0.2, 0.3], [1.3, 0.7, -0.4]],
        ElementKind::Tri3PlaneStress | ElementKind::Tri3PlaneStrain => {
            &[[0.1, -0.1, 0.0], [1.2, 0.1, 0.0], [0.3, 0.9, 0.0]]
        }
        ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain => &[
            [0.0, 0.0, 0.0],
            [2.0, 0.2, 0.0],
            [1.7, 1.5, 0.0],
            [0.2, 1.1, 0.0],
        ],
        ElementKind::Tet4 => &[
            [0.0, 0.0, 0.0],
            [1.0, 0.1, 0.05],
            [0.2, 1.1, 0.1],
            [0.1, 0.3, 0.9],
        ],
        ElementKind::Hex8 => &[
            [0.0, 0.0, 0.0],
            [1.1, 0.1, -0.05],
            [1.2, 0.9, 0.1],
            [-0.1, 1.0, 0.0],
            [0.05, -0.1, 1.0],
            [0.9, 0.05, 1.2],
            [1.1, 1.2, 0.9],
            [0.1, 0.8, 1.1],
        ],
    };
    x[..pts.len()].copy_from_slice(pts);
    x
}

fn unit_cube(half: f64) -> X {
    let mut x = [[0.0; 3]; MAX_NODES];
    for (a, s) in super::continuum::HEX8_NODES.iter().enumerate() {
        for i in 0..3 {
            x[a][i] = half * s[i];
        }
    }
    x
}

/// The integration variants that apply to `kind`.
fn variants(kind: ElementKind) -> Vec<Integration> {
    match kind {
        ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain | ElementKind::Hex8 => vec![
            Integration::Full { bbar: false },
            Integration::Full { bbar: true },
            Integration::Reduced(Hourglass::Stiffness { coefficient: 0.1 }),
            Integration::Reduced(Hourglass::Viscous { coefficient: 0.1 }),
        ],
        _ => vec![Integration::default()],
    }
}

fn opts(kin: Kinematics, integration: Integration) -> ElementOptions {
    ElementOptions {
        kinematics: kin,
        plane: Plane::Stress,
        integration,
        thickness: 0.01,
    }
}

fn eval(
    kind: ElementKind,
    o: &ElementOptions,
    m: &Elastic,
    x0: &X,
    u: &X,
    v: &X,
) -> ElementResponse {
    let n = kind.nodes();
    let mut out = ElementResponse::default();
    respond(kind, o, m, &x0[..n], &u[..n], &v[..n], &mut out);
    out
}

fn matvec(a: &[[f64; 3]; 3], x: &[f64; 3]) -> [f64; 3] {
    [
        a[0][0] * x[0] + a[0][1] * x[1] + a[0][2] * x[2],
        a[1][0] * x[0] + a[1][1] * x[1] + a[1][2] * x[2],
        a[2][0] * x[0] + a[2][1] * x[1] + a[2][2] * x[2],
    ]
}

fn field(kind: ElementKind, x0: &X, f: impl Fn(&[f64; 3]) -> [f64; 3]) -> X {
    let mut u = [[0.0; 3]; MAX_NODES];
    for a in 0..kind.nodes() {
        u[a] = f(&x0[a]);
        if kind.dim() == 2 {
            u[a][2] = 0.0;
        }
    }
    u
}

/// The exact stress of the homogeneous gradient `a` (`u = a X`): small strain `D sym a`,
/// total Lagrangian `D E(I + a)`, reduced to the element's plane mode or bar axis.
fn exact_stress(
    kind: ElementKind,
    kin: Kinematics,
    m: &Elastic,
    x0: &X,
    a: &[[f64; 3]; 3],
) -> [f64; 6] {
    let mut a = *a;
    if kind.dim() == 2 {
        for i in 0..3 {
            a[2][i] = 0.0;
            a[i][2] = 0.0;
        }
    }
    let e = super::material::strain(kin, &a);
    match kind {
        ElementKind::Bar2 => {
            let d = [
                x0[1][0] - x0[0][0],
                x0[1][1] - x0[0][1],
                x0[1][2] - x0[0][2],
            ];
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let n = [d[0] / l, d[1] / l, d[2] / l];
            let t = super::material::tensor(&e);
            let tn = matvec(&t, &n);
            [
                m.e * (n[0] * tn[0] + n[1] * tn[1] + n[2] * tn[2]),
                0.0,
                0.0,
                0.0,
                0.0,
                0.0,
            ]
        }
        ElementKind::Tri3PlaneStress | ElementKind::Quad4PlaneStress => {
            let p = m.plane_stress();
            let mut s = stress(p.lambda, p.mu, &e);
            s[2] = 0.0;
            s
        }
        _ => stress(m.lambda, m.mu, &e),
    }
}

const A: [[f64; 3]; 3] = [
    [1.0e-3, 2.0e-4, -3.0e-4],
    [-5.0e-4, 7.0e-4, 1.5e-4],
    [2.5e-4, -1.0e-4, -6.0e-4],
];

fn assert_close6(got: &[f64; 6], want: &[f64; 6], rel: f64, what: &str) {
    let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    for k in 0..6 {
        assert!(
            (got[k] - want[k]).abs() <= rel * scale,
            "{what}: component {k}: {} vs {} (scale {scale})",
            got[k],
            want[k]
        );
    }
}

// ---------------------------------------------------------------- 1. patch tests

/// Reference: a homogeneous displacement gradient is reproduced exactly by every element
/// (complete linear interpolation), so the stress is the material law of that gradient at
/// every point: `D sym A` (small strain) or `D E(I + A)` (total Lagrangian), to round-off.
#[test]
fn patch_single_distorted_element_gives_the_exact_constant_stress() {
    let m = steel();
    for kind in ALL {
        let x0 = geometry(kind);
        let u = field(kind, &x0, |x| matvec(&A, x));
        for integ in variants(kind) {
            for kin in [Kinematics::SmallStrain, Kinematics::TotalLagrangian] {
                // Large gradient for TL so the nonlinear terms matter.
                let scale = if kin == Kinematics::TotalLagrangian {
                    200.0
                } else {
                    1.0
                };
                let mut a = A;
                a.iter_mut().flatten().for_each(|x| *x *= scale);
                let u = field(kind, &x0, |x| matvec(&a, x));
                let r = eval(kind, &opts(kin, integ), &m, &x0, &u, &u);
                let want = exact_stress(kind, kin, &m, &x0, &a);
                assert_close6(
                    &r.stress,
                    &want,
                    1e-10,
                    &format!("{kind:?} {integ:?} {kin:?}"),
                );
            }
        }
        let _ = u;
    }
}

/// Reference: static equilibrium of the element's internal forces for any displacement:
/// `Σ f = 0` and `Σ X × f = 0` (small strain, σ symmetric); total Lagrangian: moments about
/// the *current* positions (P Fᵀ = F S Fᵀ symmetric). Full integration.
#[test]
fn full_integration_single_element_forces_balance() {
    let m = steel();
    for kind in ALL {
        let x0 = geometry(kind);
        // A non-linear field.
        let u = field(kind, &x0, |x| {
            [
                1e-3 * x[1] * x[0] + 2e-3 * x[2],
                -1e-3 * x[0] * x[0] + 5e-4 * x[2] * x[1],
                3e-4 * x[0] * x[1],
            ]
        });
        for kin in [Kinematics::SmallStrain, Kinematics::TotalLagrangian] {
            let mut integs = vec![
                Integration::Full { bbar: false },
                Integration::Full { bbar: true },
            ];
            if kin == Kinematics::SmallStrain {
                // Hourglass forces balance about the reference positions.
                integs.push(Integration::Reduced(Hourglass::Stiffness {
                    coefficient: 0.1,
                }));
            }
            for integ in integs {
                let r = eval(kind, &opts(kin, integ), &m, &x0, &u, &u);
                let fmax = r.f.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
                assert!(fmax > 0.0);
                let mut sf = [0.0; 3];
                let mut sm = [0.0; 3];
                for a in 0..kind.nodes() {
                    let p = if kin == Kinematics::TotalLagrangian {
                        [x0[a][0] + u[a][0], x0[a][1] + u[a][1], x0[a][2] + u[a][2]]
                    } else {
                        x0[a]
                    };
                    let f = r.f[a];
                    for i in 0..3 {
                        sf[i] += f[i];
                    }
                    sm[0] += p[1] * f[2] - p[2] * f[1];
                    sm[1] += p[2] * f[0] - p[0] * f[2];
                    sm[2] += p[0] * f[1] - p[1] * f[0];
                }
                for i in 0..3 {
                    assert!(
                        sf[i].abs() < 1e-12 * fmax,
                        "{kind:?} {kin:?} {integ:?} Σf {sf:?}"
                    );
                    assert!(
                        sm[i].abs() < 1e-12 * fmax,
                        "{kind:?} {kin:?} {integ:?} ΣX×f {sm:?}"
                    );
                }
            }
        }
    }
}

/// A 2×2 quad patch and a 2×2×2 hex patch with every node perturbed (the interior node
/// included), plus the quad patch split into triangles. Reference (the classic patch test):
/// under `u = A X` the assembled internal force at the interior node vanishes and every
/// element carries the exact stress.
#[test]
fn patch_assembled_interior_node_is_in_equilibrium() {
    let m = steel();
    let jitter = |i: usize, k: usize| (((i * 7 + k * 13) % 11) as f64 / 11.0 - 0.5) * 0.3;
    // 2-D: 3×3 grid.
    let mut p2 = [[0.0; 3]; 9];
    for j in 0..3 {
        for i in 0..3 {
            let id = j * 3 + i;
            p2[id] = [i as f64 + jitter(id, 0), j as f64 + jitter(id, 1), 0.0];
        }
    }
    let quads: Vec<[usize; 4]> = (0..2)
        .flat_map(|j| (0..2).map(move |i| [j * 3 + i, j * 3 + i + 1, j * 3 + i + 4, j * 3 + i + 3]))
        .collect();
    let tris: Vec<[usize; 3]> = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    // 3-D: 3×3×3 grid.
    let mut p3 = [[0.0; 3]; 27];
    for k in 0..3 {
        for j in 0..3 {
            for i in 0..3 {
                let id = k * 9 + j * 3 + i;
                p3[id] = [
                    i as f64 + jitter(id, 0),
                    j as f64 + jitter(id, 1),
                    k as f64 + jitter(id, 2),
                ];
            }
        }
    }
    let mut hexes = Vec::new();
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..2 {
                let b = k * 9 + j * 3 + i;
                hexes.push([b, b + 1, b + 4, b + 3, b + 9, b + 10, b + 13, b + 12]);
            }
        }
    }
    let check = |kind: ElementKind, pts: &[[f64; 3]], elems: &[Vec<usize>], interior: usize| {
        for integ in variants(kind) {
            let o = opts(Kinematics::SmallStrain, integ);
            let mut fi = [0.0; 3];
            let mut fmax = 0.0f64;
            for e in elems {
                let mut x0 = [[0.0; 3]; MAX_NODES];
                for (a, &n) in e.iter().enumerate() {
                    x0[a] = pts[n];
                }
                assert!(shape_check(kind, &x0[..e.len()]).is_ok());
                let u = field(kind, &x0, |x| matvec(&A, x));
                let r = eval(kind, &o, &m, &x0, &u, &u);
                assert_close6(
                    &r.stress,
                    &exact_stress(kind, o.kinematics, &m, &x0, &A),
                    1e-10,
                    "patch",
                );
                for (a, &n) in e.iter().enumerate() {
                    fmax = r.f[a].iter().fold(fmax, |s, x| s.max(x.abs()));
                    if n == interior {
                        for i in 0..3 {
                            fi[i] += r.f[a][i];
                        }
                    }
                }
            }
            assert!(
                fi.iter().all(|x| x.abs() < 1e-12 * fmax),
                "{kind:?} {integ:?}: {fi:?} vs {fmax}"
            );
        }
    };
    let q: Vec<Vec<usize>> = quads.iter().map(|e| e.to_vec()).collect();
    let t: Vec<Vec<usize>> = tris.iter().map(|e| e.to_vec()).collect();
    let h: Vec<Vec<usize>> = hexes.iter().map(|e| e.to_vec()).collect();
    check(ElementKind::Quad4PlaneStress, &p2, &q, 4);
    check(ElementKind::Quad4PlaneStrain, &p2, &q, 4);
    check(ElementKind::Tri3PlaneStress, &p2, &t, 4);
    check(ElementKind::Hex8, &p3, &h, 13);
}

/// Plane outputs: plane stress reports σ_zz = 0 and `ε_zz = −λ/(λ+2μ)(ε_xx+ε_yy)`; plane
/// strain ε_zz = 0 and σ_zz = λ tr ε = ν(σ_xx + σ_yy).
#[test]
fn plane_zz_components() {
    let m = steel();
    let nu = 0.3;
    for kind in [ElementKind::Quad4PlaneStress, ElementKind::Quad4PlaneStrain] {
        let x0 = geometry(kind);
        let u = field(kind, &x0, |x| matvec(&A, x));
        let r = eval(
            kind,
            &opts(Kinematics::SmallStrain, Integration::default()),
            &m,
            &x0,
            &u,
            &u,
        );
        if kind == ElementKind::Quad4PlaneStress {
            assert_eq!(r.stress[2], 0.0);
            let want = -nu / (1.0 - nu) * (A[0][0] + A[1][1]);
            assert!((r.strain[2] - want).abs() < 1e-12 * want.abs());
        } else {
            assert_eq!(r.strain[2], 0.0);
            let want = nu * (r.stress[0] + r.stress[1]);
            assert!((r.stress[2] - want).abs() < 1e-10 * want.abs());
        }
        // Voigt strain is the tensor (not engineering) shear: ε_xy = ½(A_xy + A_yx).
        assert!((r.strain[5] - 0.5 * (A[0][1] + A[1][0])).abs() < 1e-15);
    }
}

// ---------------------------------------------------------------- 2. rigid motions

fn rotation(axis: [f64; 3], angle: f64) -> [[f64; 3]; 3] {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let k = [axis[0] / n, axis[1] / n, axis[2] / n];
    let (s, c) = angle.sin_cos();
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = (1.0 - c) * k[i] * k[j] + if i == j { c } else { 0.0 };
        }
    }
    r[0][1] -= s * k[2];
    r[0][2] += s * k[1];
    r[1][0] += s * k[2];
    r[1][2] -= s * k[0];
    r[2][0] -= s * k[1];
    r[2][1] += s * k[0];
    r
}

/// `max |f| / (E · size²)` and `max |σ| / E` of a rigid motion `x ↦ R x + c`.
fn rigid_residual(
    kind: ElementKind,
    integ: Integration,
    kin: Kinematics,
    r: &[[f64; 3]; 3],
    c: [f64; 3],
) -> (f64, f64) {
    let m = steel();
    let x0 = geometry(kind);
    let mut rr = *r;
    if kind.dim() == 2 {
        rr[2] = [0.0, 0.0, 1.0];
        rr[0][2] = 0.0;
        rr[1][2] = 0.0;
    }
    let u = field(kind, &x0, |x| {
        let y = matvec(&rr, x);
        [y[0] - x[0] + c[0], y[1] - x[1] + c[1], y[2] - x[2] + c[2]]
    });
    let v = [[0.0; 3]; MAX_NODES];
    let o = opts(kin, integ);
    let out = eval(kind, &o, &m, &x0, &u, &v);
    let f = out.f.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
    let s = out.stress.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    (f / m.e, s / m.e)
}

/// Reference: a rigid translation strains nothing (both kinematics); a finite rotation
/// strains nothing with total Lagrangian (Green–Lagrange E = 0). This includes the reduced
/// hex8/quad4 with hourglass *stiffness* on distorted elements: the hourglass projection γ
/// is built on the reference configuration, and a rigid motion is linear in X, so it has no
/// hourglass component at all (see `hourglass`). Small strain does see a 60° rotation as
/// strain (R − I is not skew), which is checked to be large, as a control.
#[test]
fn rigid_motions_give_zero_force() {
    let id = rotation([0.0, 0.0, 1.0], 0.0);
    let rot = rotation([0.3, -0.5, 0.8], 60f64.to_radians());
    let rot_z = rotation([0.0, 0.0, 1.0], 60f64.to_radians());
    for kind in ALL {
        for integ in variants(kind) {
            for kin in [Kinematics::SmallStrain, Kinematics::TotalLagrangian] {
                let (f, s) = rigid_residual(kind, integ, kin, &id, [0.3, -1.2, 2.0]);
                assert!(
                    f < 1e-14 && s < 1e-14,
                    "{kind:?} {integ:?} {kin:?}: translation {f} {s}"
                );
            }
            let r = if kind.dim() == 2 { &rot_z } else { &rot };
            let (f, s) = rigid_residual(
                kind,
                integ,
                Kinematics::TotalLagrangian,
                r,
                [0.3, -1.2, 2.0],
            );
            assert!(
                f < 1e-14 && s < 1e-14,
                "{kind:?} {integ:?}: rotation {f} {s}"
            );
            let (f, _) = rigid_residual(kind, integ, Kinematics::SmallStrain, r, [0.0; 3]);
            assert!(
                f > 1e-3,
                "{kind:?} {integ:?}: small strain sees the rotation"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
    /// Random rigid motions (any axis, angle up to ±π, translation) give zero internal force
    /// and stress with total Lagrangian, for every element and integration variant.
    #[test]
    fn random_rigid_motions_are_force_free(
        ax in -1.0f64..1.0, ay in -1.0f64..1.0, az in 0.1f64..1.0,
        angle in -std::f64::consts::PI..std::f64::consts::PI,
        c in proptest::array::uniform3(-10.0f64..10.0),
    ) {
        for kind in ALL {
            let axis = if kind.dim() == 2 { [0.0, 0.0, 1.0] } else { [ax, ay, az] };
            let r = rotation(axis, angle);
            for integ in variants(kind) {
                let (f, s) = rigid_residual(kind, integ, Kinematics::TotalLagrangian, &r, c);
                prop_assert!(f < 1e-13 && s < 1e-13, "{:?} {:?}: {} {}", kind, integ, f, s);
            }
        }
    }
}

// ---------------------------------------------------------------- 3. hourglass

/// Reference: on a cube the hourglass modes `h_α` are exactly the zero-energy modes of the
/// one-point element (b·h_α = 0), so without control (κ = 0) the force is zero; with the
/// stiffness form the force is `C_s (γ·γ) h` ≠ 0 and the stored energy is ½ uᵀ f; with the
/// viscous form the power `Σ f·v = C_v Σ|q̇|²` is positive.
#[test]
fn hourglass_modes_of_one_point_hex8() {
    let m = steel();
    let x0 = unit_cube(0.5);
    let zero = [[0.0; 3]; MAX_NODES];
    for (alpha, h) in super::hourglass::HEX8_H.iter().enumerate() {
        for comp in 0..3 {
            let mut u = zero;
            for a in 0..8 {
                u[a][comp] = 1e-4 * h[a];
            }
            let none = opts(
                Kinematics::SmallStrain,
                Integration::Reduced(Hourglass::Stiffness { coefficient: 0.0 }),
            );
            let r0 = eval(ElementKind::Hex8, &none, &m, &x0, &u, &zero);
            assert!(
                r0.f.iter().flatten().all(|x| x.abs() < 1e-6),
                "mode {alpha}: {:?}",
                r0.f
            );
            assert!(r0.strain_energy.abs() < 1e-20);
            let stiff = opts(
                Kinematics::SmallStrain,
                Integration::Reduced(Hourglass::Stiffness { coefficient: 0.1 }),
            );
            let r1 = eval(ElementKind::Hex8, &stiff, &m, &x0, &u, &zero);
            let work: f64 = (0..8)
                .map(|a| (0..3).map(|i| r1.f[a][i] * u[a][i]).sum::<f64>())
                .sum();
            assert!(work > 0.0);
            assert!((r1.hourglass_energy - 0.5 * work).abs() < 1e-12 * work);
            // Conservative: no dissipated power, whatever the velocity.
            assert_eq!(
                eval(ElementKind::Hex8, &stiff, &m, &x0, &u, &u).hourglass_power,
                0.0
            );
            // C_s = κ (λ+2μ) V (b·b)/3 with b·b = 24/16 on the unit cube; γ = h, q = 8·1e-4.
            let cs = 0.1 * (m.lambda + 2.0 * m.mu) * 1.5 / 3.0;
            assert!((r1.f[0][comp] - cs * 8.0 * 1e-4 * h[0]).abs() < 1e-9 * cs * 8e-4);
            let visc = opts(
                Kinematics::SmallStrain,
                Integration::Reduced(Hourglass::Viscous { coefficient: 0.1 }),
            );
            let r2 = eval(ElementKind::Hex8, &visc, &m, &x0, &zero, &u);
            assert!(r2.hourglass_power > 0.0 && r2.hourglass_energy == 0.0);
            let p: f64 = (0..8)
                .map(|a| (0..3).map(|i| r2.f[a][i] * u[a][i]).sum::<f64>())
                .sum();
            assert!((p - r2.hourglass_power).abs() < 1e-12 * p);
        }
    }
}

/// The same for the one-point quad4 on a square (mode ξη = (1, −1, 1, −1) in x and in y):
/// zero force without control, `C_s (γ·γ) h` with it (`C_s = κ (λ*+2μ) t A (b·b)/2`,
/// b·b = 4 · 2 · ¼ = 2 on the unit square, γ = h, q = 4 · 1e-4).
#[test]
fn hourglass_mode_of_one_point_quad4() {
    let m = steel();
    let x0 = unit_cube(0.5);
    let zero = [[0.0; 3]; MAX_NODES];
    let h = super::hourglass::QUAD4_H[0];
    for comp in 0..2 {
        let mut u = zero;
        for a in 0..4 {
            u[a][comp] = 1e-4 * h[a];
        }
        let kind = ElementKind::Quad4PlaneStress;
        let none = opts(
            Kinematics::SmallStrain,
            Integration::Reduced(Hourglass::Stiffness { coefficient: 0.0 }),
        );
        let r0 = eval(kind, &none, &m, &x0, &u, &zero);
        assert!(r0.f.iter().flatten().all(|x| x.abs() < 1e-6), "{:?}", r0.f);
        let stiff = opts(
            Kinematics::SmallStrain,
            Integration::Reduced(Hourglass::Stiffness { coefficient: 0.1 }),
        );
        let r1 = eval(kind, &stiff, &m, &x0, &u, &zero);
        let p = m.plane_stress();
        let cs = 0.1 * (p.lambda + 2.0 * p.mu) * 0.01 * 1.0 * 2.0 / 2.0;
        for a in 0..4 {
            assert!((r1.f[a][comp] - cs * 4e-4 * h[a]).abs() < 1e-9 * cs * 4e-4);
        }
        assert!(r1.hourglass_energy > 0.0);
    }
}

/// Viscous hourglass power is never negative, for any velocity of a distorted element
/// (hex8 and quad4): `Σ f·v = C_v Σ_α |q̇_α|²`.
#[test]
fn viscous_hourglass_power_is_non_negative() {
    let m = steel();
    for kind in [ElementKind::Hex8, ElementKind::Quad4PlaneStrain] {
        let x0 = geometry(kind);
        let o = opts(
            Kinematics::TotalLagrangian,
            Integration::Reduced(Hourglass::Viscous { coefficient: 0.1 }),
        );
        for s in 0..50u64 {
            let mut v = [[0.0; 3]; MAX_NODES];
            for a in 0..kind.nodes() {
                for i in 0..kind.dim() {
                    v[a][i] = (((s * 31 + a as u64 * 17 + i as u64 * 7) % 23) as f64 - 11.0) * 0.1;
                }
            }
            let u = [[0.0; 3]; MAX_NODES];
            let r = eval(kind, &o, &m, &x0, &u, &v);
            assert!(r.hourglass_power >= 0.0, "{kind:?} {}", r.hourglass_power);
        }
    }
}

// ---------------------------------------------------------------- 4. frequency

/// Reference: the lumped-mass two-node bar has `ω_max = 2c/L` exactly.
#[test]
fn bar2_max_frequency_is_2c_over_l() {
    let m = steel();
    let x0 = geometry(ElementKind::Bar2);
    let l = super::bar2::length(&[x0[0], x0[1]]);
    let w = max_frequency(
        ElementKind::Bar2,
        &opts(Kinematics::SmallStrain, Integration::default()),
        &m,
        &x0[..2],
    );
    assert_eq!(w, 2.0 * (m.e / m.rho).sqrt() / l);
}

/// The element stiffness from the *energy* path, `K_ij = U(e_i + e_j) − U(e_i) − U(e_j)`
/// (exact for the quadratic small-strain energy; includes the hourglass stiffness energy),
/// independent of the force path `max_frequency` uses.
fn stiffness_from_energy(
    kind: ElementKind,
    o: &ElementOptions,
    m: &Elastic,
    x0: &X,
) -> DMatrix<f64> {
    let (n, d) = (kind.nodes(), kind.dim());
    let zero = [[0.0; 3]; MAX_NODES];
    // Small strain: the energy is exactly quadratic (total Lagrangian linearises to it).
    let o = &ElementOptions {
        kinematics: Kinematics::SmallStrain,
        ..*o
    };
    let energy = |u: &X| {
        let r = eval(kind, o, m, x0, u, &zero);
        r.strain_energy + r.hourglass_energy
    };
    let unit = |k: usize| {
        let mut u = zero;
        u[k / d][k % d] = 1.0;
        u
    };
    let dofs = n * d;
    let mut k = DMatrix::zeros(dofs, dofs);
    for i in 0..dofs {
        for j in 0..dofs {
            let mut u = unit(i);
            u[j / d][j % d] += 1.0;
            k[(i, j)] = if i == j {
                2.0 * energy(&unit(i))
            } else {
                energy(&u) - energy(&unit(i)) - energy(&unit(j))
            };
        }
    }
    k
}

fn exact_element_omega(kind: ElementKind, o: &ElementOptions, m: &Elastic, x0: &X) -> f64 {
    let (n, d) = (kind.nodes(), kind.dim());
    let k = stiffness_from_energy(kind, o, m, x0);
    let mass = lumped_masses(kind, o, m.rho, &x0[..n]);
    let s = DMatrix::from_fn(n * d, n * d, |r, c| {
        k[(r, c)] / (mass[r / d] * mass[c / d]).sqrt()
    });
    let s = (&s + s.transpose()) * 0.5;
    s.symmetric_eigen().eigenvalues.max().sqrt()
}

/// Reference: the generalised eigenvalue problem `K φ = ω² M φ` solved by nalgebra on the
/// energy-path stiffness. `max_frequency` must not be below it, and agrees to 1e-8.
#[test]
fn max_frequency_bounds_the_element_eigenvalue() {
    let m = steel();
    for kind in ALL.into_iter().skip(1) {
        for x0 in [
            geometry(kind),
            if kind == ElementKind::Hex8 {
                unit_cube(0.05)
            } else {
                geometry(kind)
            },
        ] {
            for integ in variants(kind) {
                let o = opts(Kinematics::TotalLagrangian, integ);
                let w = max_frequency(kind, &o, &m, &x0[..kind.nodes()]);
                let exact = exact_element_omega(kind, &o, &m, &x0);
                assert!(w >= exact, "{kind:?} {integ:?}: {w} < {exact}");
                assert!(
                    w <= exact * (1.0 + 1e-8),
                    "{kind:?} {integ:?}: {w} vs {exact}"
                );
            }
        }
    }
}

/// Cube of side 0.1 m, full integration: compared with the directly computed eigenvalue.
/// Against the bar value `2 c_d / L` of the dilatational speed the ratio is 1.3628 for
/// ν = 0.3 (printed; the highest mode couples the three directions).
#[test]
fn hex8_cube_frequency() {
    let m = steel();
    let x0 = unit_cube(0.05);
    let o = opts(Kinematics::SmallStrain, Integration::Full { bbar: false });
    let w = max_frequency(ElementKind::Hex8, &o, &m, &x0[..8]);
    let exact = exact_element_omega(ElementKind::Hex8, &o, &m, &x0);
    assert!(w >= exact && w <= exact * (1.0 + 1e-8));
    let bar = 2.0 * m.dilatational_speed() / 0.1;
    let ratio = w / bar;
    eprintln!("hex8 cube: ω_max / (2 c_d / L) = {ratio}");
    assert!(ratio > 1.0 && ratio < 2.0, "ω_max / (2c_d/L) = {ratio}");
}

/// Irons' bound: the assembled (two hex8 sharing a face, lumped mass) highest frequency does
/// not exceed the largest element value.
#[test]
fn irons_bound_on_a_two_element_mesh() {
    let m = steel();
    let a = geometry(ElementKind::Hex8);
    // Second element on top of the first: its bottom face is the first's top.
    let mut b = a;
    for k in 0..4 {
        b[k] = a[k + 4];
        b[k + 4] = [a[k + 4][0] + 0.1, a[k + 4][1] - 0.05, a[k + 4][2] + 1.0];
    }
    let o = opts(Kinematics::SmallStrain, Integration::Full { bbar: false });
    let conn = [[0usize, 1, 2, 3, 4, 5, 6, 7], [4, 5, 6, 7, 8, 9, 10, 11]];
    let mut kg = DMatrix::<f64>::zeros(36, 36);
    let mut mg = [0.0; 12];
    let mut wmax = 0.0f64;
    for (e, x0) in [a, b].iter().enumerate() {
        let ke = stiffness_from_energy(ElementKind::Hex8, &o, &m, x0);
        let me = lumped_masses(ElementKind::Hex8, &o, m.rho, &x0[..8]);
        for p in 0..8 {
            mg[conn[e][p]] += me[p];
            for q in 0..8 {
                for i in 0..3 {
                    for j in 0..3 {
                        kg[(conn[e][p] * 3 + i, conn[e][q] * 3 + j)] += ke[(p * 3 + i, q * 3 + j)];
                    }
                }
            }
        }
        wmax = wmax.max(max_frequency(ElementKind::Hex8, &o, &m, &x0[..8]));
    }
    let s = DMatrix::from_fn(36, 36, |r, c| kg[(r, c)] / (mg[r / 3] * mg[c / 3]).sqrt());
    let s = (&s + s.transpose()) * 0.5;
    let w = s.symmetric_eigen().eigenvalues.max().sqrt();
    assert!(w <= wmax, "{w} > {wmax}");
    assert!(w > 0.5 * wmax);
}

// ---------------------------------------------------------------- 5. energy

/// Reference: for the small-strain (linear) elements `f = K u` and `U = ½ uᵀ K u`, so
/// `strain_energy (+ hourglass_energy) = ½ uᵀ f`.
#[test]
fn small_strain_energy_is_half_u_dot_f() {
    let m = steel();
    for kind in ALL {
        let x0 = geometry(kind);
        let u = field(kind, &x0, |x| {
            [
                1e-3 * x[1] * x[0] + 2e-4,
                -1e-3 * x[0] * x[0] + 5e-4 * x[2],
                3e-4 * x[0] * x[1],
            ]
        });
        for integ in variants(kind) {
            let r = eval(
                kind,
                &opts(Kinematics::SmallStrain, integ),
                &m,
                &x0,
                &u,
                &[[0.0; 3]; MAX_NODES],
            );
            let uf: f64 = (0..kind.nodes())
                .map(|a| (0..3).map(|i| u[a][i] * r.f[a][i]).sum::<f64>())
                .sum();
            let e = r.strain_energy + r.hourglass_energy;
            assert!(e > 0.0);
            assert!(
                (e - 0.5 * uf).abs() < 1e-12 * e,
                "{kind:?} {integ:?}: {e} vs {}",
                0.5 * uf
            );
        }
    }
}

/// Reference: the total-Lagrangian forces are the gradient of the stored energy (SVK plus
/// hourglass stiffness), checked by central differences with step 1e-7 relative (error
/// O(h²) ≈ 1e-12, round-off ≈ 1e-9 relative).
#[test]
fn total_lagrangian_force_is_the_energy_gradient() {
    let m = steel();
    for kind in ALL {
        let x0 = geometry(kind);
        // Large deformation: 20 % strains plus a rotation.
        let r = rotation([0.2, 0.4, 1.0], 0.7);
        let u = field(kind, &x0, |x| {
            let y = matvec(
                &r,
                &[
                    x[0] * 1.2 + 0.1 * x[1] * x[1],
                    x[1] * 0.9 + 0.05 * x[0] * x[2],
                    x[2] * 1.1,
                ],
            );
            [y[0] - x[0], y[1] - x[1], y[2] - x[2]]
        });
        let zero = [[0.0; 3]; MAX_NODES];
        for integ in variants(kind) {
            let o = opts(Kinematics::TotalLagrangian, integ);
            let base = eval(kind, &o, &m, &x0, &u, &zero);
            let fmax = base.f.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
            let h = 1e-7;
            for a in 0..kind.nodes() {
                for i in 0..kind.dim() {
                    let mut up = u;
                    up[a][i] += h;
                    let mut um = u;
                    um[a][i] -= h;
                    let ep = eval(kind, &o, &m, &x0, &up, &zero);
                    let em = eval(kind, &o, &m, &x0, &um, &zero);
                    let g = ((ep.strain_energy + ep.hourglass_energy)
                        - (em.strain_energy + em.hourglass_energy))
                        / (2.0 * h);
                    assert!(
                        (g - base.f[a][i]).abs() < 1e-6 * fmax,
                        "{kind:?} {integ:?} node {a} dir {i}: {g} vs {}",
                        base.f[a][i]
                    );
                }
            }
        }
    }
}

// ---------------------------------------------------------------- 6. B-bar

/// Reference (closed form): on the cube [−½, ½]³, the nodal field `u_x = κ x y` (a bending
/// mode with zero mean dilatation) has exact (2×2×2) energy `κ²/12 (λ/2 + 3μ/2)`, while
/// with B-bar the volumetric part is the mean, 0, leaving `μ κ²/12 · 7/6`. The ratio is
/// `3(λ + 3μ)/(7μ)`: with ν = 0.4999 (λ/μ = 4999) that is 2143.7 — the locking B-bar
/// removes. The same holds for the plane-strain quad4 on the unit square (per thickness).
#[test]
fn bbar_unlocks_nearly_incompressible_bending() {
    let m = Elastic::new(1e9, 0.4999, 1000.0);
    let kappa = 1e-3;
    let ratio_exact = 3.0 * (m.lambda + 3.0 * m.mu) / (7.0 * m.mu);
    for kind in [ElementKind::Hex8, ElementKind::Quad4PlaneStrain] {
        let x0 = unit_cube(0.5);
        let t = 0.01;
        let u = field(kind, &x0, |x| [kappa * x[0] * x[1], 0.0, 0.0]);
        let zero = [[0.0; 3]; MAX_NODES];
        let thick = if kind == ElementKind::Hex8 { 1.0 } else { t };
        let full = eval(
            kind,
            &opts(Kinematics::SmallStrain, Integration::Full { bbar: false }),
            &m,
            &x0,
            &u,
            &zero,
        );
        let bbar = eval(
            kind,
            &opts(Kinematics::SmallStrain, Integration::Full { bbar: true }),
            &m,
            &x0,
            &u,
            &zero,
        );
        let want_full = thick * kappa * kappa / 12.0 * (m.lambda / 2.0 + 1.5 * m.mu);
        let want_bbar = thick * m.mu * kappa * kappa / 12.0 * 7.0 / 6.0;
        assert!(
            (full.strain_energy - want_full).abs() < 1e-10 * want_full,
            "{kind:?}"
        );
        assert!(
            (bbar.strain_energy - want_bbar).abs() < 1e-10 * want_bbar,
            "{kind:?}"
        );
        let ratio = full.strain_energy / bbar.strain_energy;
        assert!((ratio - ratio_exact).abs() < 1e-8 * ratio_exact);
        assert!(ratio > 2000.0, "{kind:?}: {ratio}");
    }
}

// ---------------------------------------------------------------- 7. shapes, masses, Jacobians

#[test]
fn shape_check_accepts_good_and_rejects_bad_elements() {
    // Good: values of det J of the parent map.
    assert_eq!(
        shape_check(ElementKind::Bar2, &[[0.0; 3], [2.0, 0.0, 0.0]]),
        Ok(1.0)
    );
    let c = shape_check(ElementKind::Hex8, &unit_cube(0.5)[..8]).unwrap();
    assert!((c - 0.125).abs() < 1e-15);
    let tri = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    assert_eq!(shape_check(ElementKind::Tri3PlaneStress, &tri), Ok(1.0));
    for kind in ALL {
        assert!(
            shape_check(kind, &geometry(kind)[..kind.nodes()]).is_ok(),
            "{kind:?}"
        );
    }
    // Bar of zero length.
    assert!(shape_check(ElementKind::Bar2, &[[1.0; 3], [1.0; 3]]).is_err());
    // Clockwise quad and triangle.
    let q = [[0.0; 3], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]];
    let e = shape_check(ElementKind::Quad4PlaneStress, &q).unwrap_err();
    assert!(e.min_jacobian < 0.0);
    assert!(shape_check(ElementKind::Tri3PlaneStrain, &[tri[0], tri[2], tri[1]]).is_err());
    // Re-entrant quad: node 2 pushed inside; the negative corner is node 2.
    let q = [[0.0; 3], [2.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 2.0, 0.0]];
    let e = shape_check(ElementKind::Quad4PlaneStress, &q).unwrap_err();
    assert_eq!(e.corner, 2);
    // Flat tet.
    let t = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
    assert!(shape_check(ElementKind::Tet4, &t).is_err());
    // Inverted tet (two nodes swapped).
    let t = geometry(ElementKind::Tet4);
    assert!(shape_check(ElementKind::Tet4, &[t[0], t[2], t[1], t[3]]).is_err());
    // Inverted hex: top and bottom faces swapped.
    let c = unit_cube(0.5);
    let inv = [c[4], c[5], c[6], c[7], c[0], c[1], c[2], c[3]];
    let e = shape_check(ElementKind::Hex8, &inv).unwrap_err();
    assert!(e.min_jacobian < 0.0);
    // One corner of a hex pushed through the opposite face: locally inverted at that corner.
    let mut h = unit_cube(0.5);
    h[6] = [-0.4, -0.4, -0.4];
    let e = shape_check(ElementKind::Hex8, &h[..8]).unwrap_err();
    assert_eq!(e.corner, 6);
}

/// Reference: row-sum lumping conserves the mass `ρ V` and gives equal shares on
/// parallelograms; the distorted quad4/hex8 masses are `ρ ∫ N_a dV`, which sum to ρV.
#[test]
fn lumped_masses_sum_to_the_element_mass() {
    let m = steel();
    let o = opts(Kinematics::SmallStrain, Integration::default());
    // Parallelogram: equal quarters of ρ t A (A = 2 · 1).
    let par = [[0.0; 3], [2.0, 0.0, 0.0], [2.5, 1.0, 0.0], [0.5, 1.0, 0.0]];
    let mp = lumped_masses(ElementKind::Quad4PlaneStress, &o, m.rho, &par);
    for a in 0..4 {
        assert!((mp[a] - m.rho * 0.01 * 2.0 / 4.0).abs() < 1e-12 * mp[a]);
    }
    let mc = lumped_masses(ElementKind::Hex8, &o, m.rho, &unit_cube(0.5)[..8]);
    assert!(mc[..8]
        .iter()
        .all(|x| (x - m.rho / 8.0).abs() < 1e-12 * m.rho));
    // Distorted: total ρ V with V from the one-point mean-gradient computation.
    let x = geometry(ElementKind::Hex8);
    let mh = lumped_masses(ElementKind::Hex8, &o, m.rho, &x[..8]);
    let xa: [[f64; 3]; 8] = x[..8].try_into().unwrap();
    let (_, vol) = super::hex8::mean_gradients(&xa);
    assert!((mh.iter().sum::<f64>() - m.rho * vol).abs() < 1e-12 * m.rho * vol);
    let xt = geometry(ElementKind::Tet4);
    let mt = lumped_masses(ElementKind::Tet4, &o, m.rho, &xt[..4]);
    let v6 = shape_check(ElementKind::Tet4, &xt[..4]).unwrap();
    assert!((mt.iter().sum::<f64>() - m.rho * v6 / 6.0).abs() < 1e-12 * m.rho);
    let mb = lumped_masses(ElementKind::Bar2, &o, m.rho, &[[0.0; 3], [3.0, 4.0, 0.0]]);
    assert_eq!(mb[..2], [0.5 * m.rho * 0.01 * 5.0; 2]);
}

/// `min_jacobian` goes negative when the deformed element inverts.
#[test]
fn min_jacobian_detects_inversion() {
    let m = steel();
    let o = opts(
        Kinematics::TotalLagrangian,
        Integration::Full { bbar: false },
    );
    for kind in ALL {
        let x0 = geometry(kind);
        let zero = [[0.0; 3]; MAX_NODES];
        let r = eval(kind, &o, &m, &x0, &zero, &zero);
        let s = shape_check(kind, &x0[..kind.nodes()]).unwrap();
        assert!(r.min_jacobian > 0.0);
        if kind == ElementKind::Bar2
            || kind == ElementKind::Tri3PlaneStress
            || kind == ElementKind::Tet4
        {
            assert!((r.min_jacobian - s).abs() < 1e-14 * s.abs(), "{kind:?}");
        }
        if kind == ElementKind::Bar2 {
            continue;
        }
        // Mirror x: every Jacobian changes sign.
        let u = field(kind, &x0, |x| [-2.0 * x[0], 0.0, 0.0]);
        let r = eval(kind, &o, &m, &x0, &u, &zero);
        assert!(r.min_jacobian < 0.0, "{kind:?}");
    }
}

#[test]
fn voigt_order_is_xx_yy_zz_yz_xz_xy() {
    assert_eq!(VOIGT, [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]);
}

// ---------------------------------------------------------------- plasticity

/// The plastic state of `n` integration points, fresh.
struct Points {
    strain: Vec<[f64; 6]>,
    equivalent: Vec<f64>,
    stress: Vec<[f64; 6]>,
}

impl Points {
    fn new(n: usize) -> Points {
        Points {
            strain: vec![[0.0; 6]; n],
            equivalent: vec![0.0; n],
            stress: vec![[0.0; 6]; n],
        }
    }
    fn view(&mut self) -> PlasticPoints<'_> {
        PlasticPoints {
            strain: &mut self.strain,
            equivalent: &mut self.equivalent,
            stress: &mut self.stress,
        }
    }
}

fn eval_plastic(
    kind: ElementKind,
    o: &ElementOptions,
    m: &Elastic,
    p: &Plastic,
    x0: &X,
    u: &X,
    pts: &mut Points,
) -> (ElementResponse, PlasticResponse) {
    let n = kind.nodes();
    let mut out = ElementResponse::default();
    let pr = respond_plastic(
        kind,
        o,
        m,
        p,
        &x0[..n],
        &u[..n],
        &u[..n],
        pts.view(),
        &mut out,
    );
    (out, pr)
}

/// Reference: with a yield stress no state reaches, the elastoplastic kernels compute what
/// the elastic ones compute — bitwise (the elastic strain is the strain minus an exact
/// zero, and the plane-stress return forms the same products) — for every kind, variant
/// and kinematics, and leave the state at zero.
#[test]
fn plastic_kernels_below_yield_are_the_elastic_kernels() {
    let m = steel();
    let p = Plastic {
        yield_stress: 1e15,
        hardening: 0.0,
    };
    for kind in ALL {
        let x0 = geometry(kind);
        let u = field(kind, &x0, |x| matvec(&A, x));
        for integ in variants(kind) {
            for kin in [Kinematics::SmallStrain, Kinematics::TotalLagrangian] {
                let o = opts(kin, integ);
                let mut pts = Points::new(integration_points(kind, &o));
                let r = eval(kind, &o, &m, &x0, &u, &u);
                let (rp, pr) = eval_plastic(kind, &o, &m, &p, &x0, &u, &mut pts);
                let what = format!("{kind:?} {integ:?} {kin:?}");
                assert_eq!(r, rp, "{what}");
                assert_eq!(pr, PlasticResponse::default(), "{what}");
                assert!(pts.equivalent.iter().all(|&a| a == 0.0), "{what}");
            }
        }
    }
}

/// Reference: a homogeneous displacement gradient (strains ≈ 3–4× the yield strain) is
/// reproduced exactly by every element, so every integration point sees the same strain
/// and the element's stress and state are those of one return at that strain:
/// [`plasticity::radial_return`] (3-D kinds, plane strain), the plane-stress return
/// (plane-stress kinds) or the 1-D return of the axial strain (bar2); tolerance 1e-10
/// relative. The volume means of the state equal the point state, the plastic work of this
/// first step is the trapezoidal `V ½ (0 + σ) : εᵖ`, the points keep σ, and the strain
/// energy is `V ½ σ : εᵉ`. Every kind and variant, both kinematics (total Lagrangian on
/// the Green–Lagrange strain).
#[test]
fn plastic_kernels_under_a_homogeneous_strain_return_like_one_point() {
    use super::plasticity::{plane_stress_return, radial_return, uniaxial_return};
    let m = steel();
    let p = Plastic {
        yield_stress: 250e6,
        hardening: 5e9,
    };
    for kind in ALL {
        let x0 = geometry(kind);
        let mut a = A;
        a.iter_mut().flatten().for_each(|x| *x *= 4.0);
        if kind.dim() == 2 {
            for i in 0..3 {
                a[2][i] = 0.0;
                a[i][2] = 0.0;
            }
        }
        let u = field(kind, &x0, |x| matvec(&a, x));
        for integ in variants(kind) {
            for kin in [Kinematics::SmallStrain, Kinematics::TotalLagrangian] {
                let o = opts(kin, integ);
                let what = format!("{kind:?} {integ:?} {kin:?}");
                let e = super::material::strain(kin, &a);
                let (mut ep, mut alpha) = ([0.0; 6], 0.0);
                let want = match kind {
                    ElementKind::Bar2 => {
                        let d = [
                            x0[1][0] - x0[0][0],
                            x0[1][1] - x0[0][1],
                            x0[1][2] - x0[0][2],
                        ];
                        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                        let n = [d[0] / l, d[1] / l, d[2] / l];
                        let tn = matvec(&super::material::tensor(&e), &n);
                        let axial = n[0] * tn[0] + n[1] * tn[1] + n[2] * tn[2];
                        let s = uniaxial_return(m.e, &p, axial, &mut ep[0], &mut alpha);
                        [s, 0.0, 0.0, 0.0, 0.0, 0.0]
                    }
                    ElementKind::Tri3PlaneStress | ElementKind::Quad4PlaneStress => {
                        let ls = m.plane_stress().lambda;
                        plane_stress_return(ls, m.mu, &p, &e, &mut ep, &mut alpha)
                    }
                    _ => radial_return(m.lambda, m.mu, &p, &e, &mut ep, &mut alpha),
                };
                // Well past yield (ε_y = 1.25e-3).
                assert!(alpha > 5e-4, "{what}: not plastic enough ({alpha})");
                let mut pts = Points::new(integration_points(kind, &o));
                let (r, pr) = eval_plastic(kind, &o, &m, &p, &x0, &u, &mut pts);
                assert_close6(&r.stress, &want, 1e-10, &what);
                assert_close6(&pr.strain, &ep, 1e-10, &what);
                assert!((pr.equivalent / alpha - 1.0).abs() < 1e-10, "{what}");
                for (q, a_q) in pts.equivalent.iter().enumerate() {
                    assert!((a_q / alpha - 1.0).abs() < 1e-10, "{what}: point {q}");
                }
                // The element's volume: ρV from the lumped masses with ρ = 1 (bars: A L).
                let vol: f64 = lumped_masses(kind, &o, 1.0, &x0[..kind.nodes()])
                    .iter()
                    .sum();
                let mut ee = [0.0; 6];
                for k in 0..6 {
                    ee[k] = if kind == ElementKind::Bar2 {
                        [e_axial(&x0, &e), 0.0, 0.0, 0.0, 0.0, 0.0][k] - ep[k]
                    } else {
                        e[k] - ep[k]
                    };
                }
                // ½ a : b with tensor shears.
                let dot = |a: &[f64; 6], b: &[f64; 6]| {
                    0.5 * (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
                        + (a[3] * b[3] + a[4] * b[4] + a[5] * b[5])
                };
                let w = dot(&want, &ee);
                let hg = r.hourglass_energy;
                assert!(
                    (r.strain_energy + hg - vol * w).abs() < 1e-9 * vol * w,
                    "{what}: energy {} vs V·½σ:εᵉ {}",
                    r.strain_energy,
                    vol * w
                );
                // One step from rest: the trapezoidal work V ½ (0 + σ) : εᵖ, and the points
                // keep the stress for the next step.
                let wp = vol * dot(&want, &ep);
                assert!(
                    (pr.work - wp).abs() < 1e-9 * wp,
                    "{what}: plastic work {} vs V ½σ:εᵖ {wp}",
                    pr.work
                );
                for s in &pts.stress {
                    assert_close6(s, &want, 1e-10, &what);
                }
            }
        }
    }
}

/// The axial Green/small strain of a bar under the homogeneous strain `e`.
fn e_axial(x0: &X, e: &[f64; 6]) -> f64 {
    let d = [
        x0[1][0] - x0[0][0],
        x0[1][1] - x0[0][1],
        x0[1][2] - x0[0][2],
    ];
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let n = [d[0] / l, d[1] / l, d[2] / l];
    let tn = matvec(&super::material::tensor(e), &n);
    n[0] * tn[0] + n[1] * tn[1] + n[2] * tn[2]
}

/// Reference: plastic flow is isochoric and σ_zz = 0 in plane stress, so the thickness
/// strain of a plane-stress element is `−λ/(λ+2μ)(εᵉ_xx + εᵉ_yy) + εᵖ_zz` with
/// `εᵖ_zz = −(εᵖ_xx + εᵖ_yy)`: checked against the element's state to 1e-12.
#[test]
fn plane_stress_thickness_strain_includes_the_plastic_part() {
    let m = steel();
    let p = Plastic {
        yield_stress: 250e6,
        hardening: 0.0,
    };
    for kind in [ElementKind::Tri3PlaneStress, ElementKind::Quad4PlaneStress] {
        let x0 = geometry(kind);
        let u = field(kind, &x0, |x| {
            [3e-3 * x[0], -1e-3 * x[1] + 2e-3 * x[0], 0.0]
        });
        let o = opts(Kinematics::SmallStrain, Integration::default());
        let mut pts = Points::new(integration_points(kind, &o));
        let (r, pr) = eval_plastic(kind, &o, &m, &p, &x0, &u, &mut pts);
        assert!(pr.equivalent > 1e-3);
        assert_eq!(r.stress[2], 0.0);
        let c = m.lambda / (m.lambda + 2.0 * m.mu);
        let want = -c * (r.strain[0] - pr.strain[0] + r.strain[1] - pr.strain[1]) + pr.strain[2];
        assert!((r.strain[2] - want).abs() < 1e-12 * want.abs(), "{kind:?}");
        assert!((pr.strain[2] + pr.strain[0] + pr.strain[1]).abs() < 1e-15);
    }
}
