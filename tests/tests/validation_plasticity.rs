//! Validation of J2 plasticity in the finite-element meshes (issue 15, check 6) against
//! closed forms: the uniaxial stress path of every element type (elastic slope E, plastic
//! slope `E H/(E + H)` with linear isotropic hardening, elastic unloading, reverse yield at
//! the grown yield stress) with the plastic work and the energy balance, and the plastic
//! hinge of a bent beam (the plastic work per hinge rotation against the hinge moment
//! `M_p = σ_y b h²/4`). Every test states its reference and tolerance.
//!
//! The scenes are written in the language and run through the interpreter with the
//! explicit central-difference method at 0.9 of the critical step; quasi-static paths are
//! driven by prescribed displacements slow against the parts' lowest periods.

use mbdc_runtime::interp::Interp;
use mbdc_runtime::mesh_model;
use mbdc_runtime::system::System;
use mbdc_tests::*;

/// 0.9 × the central-difference limit of the scene's meshes.
fn step_of(scene: &mbdc_runtime::scene::Scene) -> f64 {
    let sys = Interp::new(scene).expect("interpretable");
    0.9 * mesh_model::critical_step(&sys.layout().meshes)
        .expect("elements")
        .step
}

const E: f64 = 200e9;
const SY: f64 = 250e6;
const H: f64 = 10e9;

/// The closed-form uniaxial response of linear isotropic hardening on one monotone leg:
/// from the state `(ε0, σ0, ε̄ᵖ0)`, loading in direction `d` (±1) to strain `eps` —
/// elastic (slope E) until `d σ` reaches `σ_y0 + H ε̄ᵖ0`, then slope `E_t = E H/(E + H)`
/// with `dε̄ᵖ = E/(E + H) |dε|`. Returns `(σ, ε̄ᵖ)`.
fn leg(e0: f64, s0: f64, a0: f64, d: f64, eps: f64) -> (f64, f64) {
    let s_el = s0 + E * (eps - e0);
    let sy = SY + H * a0;
    if d * s_el <= sy {
        (s_el, a0)
    } else {
        let e_y = e0 + (d * sy - s0) / E;
        let et = E * H / (E + H);
        (
            d * sy + et * (eps - e_y),
            a0 + d * (eps - e_y) * E / (E + H),
        )
    }
}

/// The strain path: `ε(t) = ε_m (4/(3√3)) (sin x − ½ sin 2x)`, `x = 2π t/T`: starts and ends
/// at rest, tension to `+ε_m` at `x = 2π/3`, compression to `−ε_m` at `4π/3`, back to 0
/// (where the element yields in tension again).
const PATH: &str = "4 / (3 * sqrt(3)) * (sin(2 * pi * t / T) - 0.5 * sin(4 * pi * t / T))";

/// The closed-form `(σ, ε̄ᵖ)` along a strain series that rises to its maximum, falls to its
/// minimum and rises again: each value on its monotone leg ([`leg`]), the legs turning at
/// the series' own extremes (the steps nearest the path's turning points).
fn closed_form(eps: &[f64]) -> Vec<(f64, f64)> {
    let i_max = (0..eps.len()).fold(0, |m, i| if eps[i] > eps[m] { i } else { m });
    let i_min = (0..eps.len()).fold(0, |m, i| if eps[i] < eps[m] { i } else { m });
    assert!(
        0 < i_max && i_max < i_min,
        "the path turns at its maximum, then its minimum"
    );
    let (e1, e2) = (eps[i_max], eps[i_min]);
    let (s1, a1) = leg(0.0, 0.0, 0.0, 1.0, e1);
    let (s2, a2) = leg(e1, s1, a1, -1.0, e2);
    eps.iter()
        .enumerate()
        .map(|(i, &e)| {
            if i <= i_max {
                leg(0.0, 0.0, 0.0, 1.0, e)
            } else if i <= i_min {
                leg(e1, s1, a1, -1.0, e)
            } else {
                leg(e2, s2, a2, 1.0, e)
            }
        })
        .collect()
}

/// A one-element (or one-cube) uniaxial-stress specimen of side 1 cm: `element` lines and
/// the boundary conditions for the kind — symmetry planes x = 0, y = 0 (and z = 0), the
/// face x = 1 cm pulled by `u = ε(t) · 1 cm`, lateral faces free; bars are prescribed at
/// both ends.
fn specimen(element: &str, em: f64, tp: f64) -> String {
    let (gen, thick, bcs) = if element.starts_with("bar2") {
        (
            "line(origin: (0, 0, 0) m, size: (1, 0, 0) cm, divisions: 1)",
            "thickness 1 cm^2",
            "set x0 = nodes(x == 0)\n    set x1 = nodes(x == 1 cm)\n    fix x0\n    displace x1, (U, 0, 0)",
        )
    } else if element.starts_with("hex8") || element.starts_with("tet4") {
        (
            "box(origin: (0, 0, 0) m, size: (1, 1, 1) cm, divisions: (1, 1, 1))",
            "",
            "set x0 = nodes(x == 0)\n    set y0 = nodes(y == 0)\n    set z0 = nodes(z == 0)\n    set x1 = nodes(x == 1 cm)\n    displace x0, (0, free, free)\n    displace y0, (free, 0, free)\n    displace z0, (free, free, 0)\n    displace x1, (U, free, free)",
        )
    } else {
        (
            "rect(origin: (0, 0) m, size: (1, 1) cm, divisions: (1, 1))",
            "thickness 1 cm",
            "set x0 = nodes(x == 0)\n    set y0 = nodes(y == 0)\n    set x1 = nodes(x == 1 cm)\n    displace x0, (0, free)\n    displace y0, (free, 0)\n    displace x1, (U, free)",
        )
    };
    format!(
        r#"
model uniaxial {{
  const T = {tp} s
  const U = {em} * 1 cm * {PATH}
  material steel {{
    E 200 GPa; nu 0.3; rho 7850 kg/m^3
    plastic {{ yield 250 MPa; hardening 10 GPa }}
  }}
  mesh specimen {{
    element {element}
    {thick}
    generate {gen}
    material steel
    {bcs}
  }}
  simulate {{ duration {tp} s; step 1 us }}
}}
"#
    )
}

/// Check 6a: the uniaxial stress path of every element type. One element (tri3: two; tet4:
/// the six of a cube) of side 1 cm, E = 200 GPa, ν = 0.3, σ_y0 = 250 MPa, H = 10 GPa,
/// driven by the axial strain path `PATH` to ±3 ε_y (ε_y = 1.25e-3) and back over
/// T = 40 ms (≈ 10⁴ periods of the element's lateral mode: quasi-static; 22 000 to 53 000
/// steps per case, every step recorded).
///
/// Reference: the closed-form 1-D response along the path's monotone legs ([`leg`]):
/// σ = Eε to yield, slope `EH/(E+H)` after, elastic unloading, reverse yield at
/// `−(σ_y0 + H ε̄ᵖ)`, and yield again on the way back to 0. Tolerances:
/// - at every step the element's mean σ_xx against the closed form at its mean ε_xx, and
///   the lateral stresses against 0: 5e-4 σ_y0 (measured ≤ 2.6e-4: the lateral inertia of
///   the free faces, excited where the tangent Poisson ratio jumps at yield; it falls as
///   1/T). bar2, prescribed at both nodes, has no free dof: 1e-9 (measured 1e-15);
/// - ε̄ᵖ at the end, and the plastic work against `V (σ_y0 ε̄ᵖ + ½ H ε̄ᵖ²)` (σ : ε̇ᵖ = σ_y ε̄̇ᵖ
///   on the yield surface): 1e-4 relative (measured ≤ 1e-5);
/// - the energy balance `K + U + U_hg + D_p − W`: 1e-9 of the plastic work (measured
///   ≤ 5e-11: the trapezoidal plastic work closes the discrete balance), and the run's
///   energy watch below 1e-3.
///
/// The plane-stress kinds run the Simo–Taylor return, bar2 the 1-D one, the others the 3-D
/// radial return; `strain green` runs the same return on the Green–Lagrange strain and the
/// 2nd Piola–Kirchhoff stress, for which the same closed form holds in (E_xx, S_xx).
#[test]
fn uniaxial_stress_path_follows_the_closed_form() {
    let ey = SY / E;
    let em = 3.0 * ey;
    let tp = 40e-3;
    let cases = [
        ("bar2", 1e-9),
        ("bar2\n    strain green", 1e-9),
        ("hex8", 5e-4),
        ("hex8\n    integration bbar", 5e-4),
        (
            "hex8\n    integration reduced\n    hourglass stiffness(0.05)",
            5e-4,
        ),
        ("hex8\n    strain green", 5e-4),
        ("tet4", 5e-4),
        ("quad4, plane_stress", 5e-4),
        ("quad4, plane_stress\n    integration reduced", 5e-4),
        ("tri3, plane_stress", 5e-4),
    ];
    for (element, tol) in cases {
        let scene = load_text(&specimen(element, em, tp));
        let h = step_of(&scene);
        let tr = simulate(&scene, method("staggered"), h, tp, 1);
        let what = element.replace("\n   ", "");
        assert!(tr.report.finished, "{what}: {:?}", tr.report.failure);
        // Element means (the fields are uniform: every element and point agrees).
        let mean = |r: &Rec, f: &dyn Fn(usize) -> f64| {
            (0..r.mesh.stress.len()).map(f).sum::<f64>() / r.mesh.stress.len() as f64
        };
        let frames = &tr.frames[1..];
        let eps: Vec<f64> = frames
            .iter()
            .map(|r| mean(r, &|e| r.mesh.strain[e][0]))
            .collect();
        let want = closed_form(&eps);
        let (mut worst, mut worst_lat) = (0.0f64, 0.0f64);
        for (r, (s, _)) in frames.iter().zip(&want) {
            let sxx = mean(r, &|e| r.mesh.stress[e][0]);
            worst = worst.max((sxx - s).abs() / SY);
            let lat = mean(r, &|e| {
                r.mesh.stress[e][1].abs().max(r.mesh.stress[e][2].abs())
            });
            worst_lat = worst_lat.max(lat / SY);
        }
        let last = tr.last();
        let a_end = want.last().expect("frames").1;
        let a = mean(last, &|e| last.mesh.equivalent_plastic_strain[e]);
        // Every specimen's volume is 1 cm³ (bars: 1 cm² × 1 cm; 2-D: 1 cm thick).
        let wp = 1e-6 * (SY * a_end + 0.5 * H * a_end * a_end);
        let en = &last.mesh.energy;
        let balance = en.kinetic + en.strain + en.hourglass + en.plastic - en.external_work;
        eprintln!(
            "{what}: |σ_xx − closed form| ≤ {worst:.2e} σ_y, lateral ≤ {worst_lat:.2e} σ_y, ε̄ᵖ {a:.6e} vs {a_end:.6e}, plastic work {:.6e} vs {wp:.6e} J, balance {balance:.2e} J",
            en.plastic
        );
        assert!(
            worst <= tol,
            "{what}: σ_xx off the closed form by {worst:e} σ_y"
        );
        assert!(worst_lat <= tol, "{what}: lateral stress {worst_lat:e} σ_y");
        assert!((a / a_end - 1.0).abs() <= 1e-4, "{what}: ε̄ᵖ {a} vs {a_end}");
        assert!(
            (en.plastic / wp - 1.0).abs() <= 1e-4,
            "{what}: plastic work {} vs {wp}",
            en.plastic
        );
        assert!(
            balance.abs() <= 1e-9 * wp,
            "{what}: energy balance {balance:e} J"
        );
        assert!(
            tr.report.max_energy_drift < 1e-3,
            "{what}: drift {}",
            tr.report.max_energy_drift
        );
    }
}

/// A beam of depth `h = nz` cm (z), half-width 1 cm (y, one element: y = 0 is a symmetry
/// plane) and length `nx` cm (x), steel (E = 200 GPa, ν = 0.3), perfectly plastic with
/// σ_y = 250 MPa, in 1 cm cubes. The section x = 0 is a symmetry plane (u_x = 0, the root:
/// it keeps the section plane and lets it contract freely), u_z = 0 on its mid-depth line;
/// the end section x = L is turned by `θ(t) = θ_max (1 − cos(π t/T))/2` about its
/// mid-depth line (`u_x = −θ (z − h/2)` on each row of nodes, u_y and u_z free).
fn bent_beam(element: &str, nx: usize, nz: usize, theta_max: f64, tp: f64) -> String {
    let mut rows = String::new();
    for k in 0..=nz {
        let arm = k as f64 - nz as f64 / 2.0;
        rows.push_str(&format!(
            "    set end{k} = nodes(x == {nx} cm and z == {k} cm)\n    displace end{k}, ({arm} cm * -theta, free, free)\n"
        ));
    }
    format!(
        r#"
model bent_beam {{
  const T = {tp} s
  const theta = {theta_max} * (1 - cos(pi * t / T)) / 2
  material steel {{
    E 200 GPa; nu 0.3; rho 7850 kg/m^3
    plastic {{ yield 250 MPa }}
  }}
  mesh beam {{
    element {element}
    generate box(origin: (0, 0, 0) m, size: ({nx}, 1, {nz}) cm, divisions: ({nx}, 1, {nz}))
    material steel
    set root = nodes(x == 0)
    set sym = nodes(y == 0)
    set axis = nodes(x == 0 and z == {half} cm)
    displace root, (0, free, free)
    displace sym, (free, 0, free)
    displace axis, (free, free, 0)
{rows}  }}
  simulate {{ duration {tp} s; step 1 us }}
}}
"#,
        half = nz as f64 / 2.0
    )
}

/// The plastic work per unit length of an elastic–perfectly plastic rectangular section
/// (b × h) bent monotonically to curvature κ ≥ κ_y (beam theory): `∫₀^κ M dκ − U'(κ)` with
/// `M = M_p (1 − κ_y²/(3κ²))` beyond `κ_y = 2σ_y/(E h)` and the elastic energy
/// `U' = b σ_y²/E (h/2 − 2c/3)` of the section with the elastic core `|z| < c = h κ_y/(2κ)`.
/// Its derivative is `M_p (1 − κ_y²/κ²)`, which tends to `M_p = σ_y b h²/4`.
fn section_plastic_work(b: f64, h: f64, kappa: f64) -> f64 {
    let ky = 2.0 * SY / (E * h);
    let mp = SY * b * h * h / 4.0;
    let ei = E * b * h * h * h / 12.0;
    let c = h * ky / (2.0 * kappa);
    let moment_work =
        ei * ky * ky / 2.0 + mp * ((kappa - ky) + ky * ky / 3.0 * (1.0 / kappa - 1.0 / ky));
    moment_work - b * SY * SY / E * (h / 2.0 - 2.0 * c / 3.0)
}

/// Check 6b: a plastic hinge in a bent beam dissipates the work of the hinge moment.
///
/// A steel beam of depth h = 8 cm, (half-)width b = 1 cm and length L = 8 cm in 1 cm
/// cubes (8 through the depth), perfectly plastic (σ_y = 250 MPa), its root section a
/// symmetry plane and its end section turned slowly (T = 4 ms, ≈ 100 periods of the
/// beam's lowest mode) to θ = 12.5 κ_y L ([`bent_beam`]): a constant moment with no shear,
/// so the whole length is the hinge and its rotation is θ. Once the section is fully
/// plastic the extra plastic work per extra rotation is the hinge moment:
/// `dD_p/dθ = M_p (1 − κ_y²/κ²) → M_p = σ_y b h²/4` (beam theory, derivative of
/// [`section_plastic_work`]).
///
/// Tolerances: the secant `ΔD_p/Δθ` over κ = 9–12 κ_y against
/// `M_p (1 − κ_y²/(κ₁κ₂))` = 0.9907 M_p and against M_p, 2 %; `D_p` at the end against
/// `L ×` [`section_plastic_work`], 2 %. The 2 % is the through-thickness discretization
/// (8 elements): measured +0.2 % (full 2×2×2: shear locking's parasitic shear adds a
/// little flow near the neutral axis), −0.1 % (B-bar), +1.1 % (one point: 8 layers of
/// constant stress carry exactly M_p once every layer has yielded, from κ = 8 κ_y, where
/// the continuous section still has its elastic core), and D_p within 0.7 %. The energy
/// balance `K + U + U_hg + D_p − W` within 1e-8 of W (measured 4e-10; the hourglass control
/// stays elastic and stores `U_hg`) and the run's energy watch below 1e-3.
#[test]
fn plastic_hinge_dissipates_the_hinge_moment_work() {
    let (nx, nz) = (8usize, 8usize);
    let (hd, b) = (nz as f64 * 0.01, 0.01);
    let len = nx as f64 * 0.01;
    let kappa_y = 2.0 * SY / (E * hd);
    let mp = SY * b * hd * hd / 4.0;
    let k_end = 12.5 * kappa_y;
    let theta_max = k_end * len;
    let tp = 4e-3;
    for element in [
        "hex8",
        "hex8\n    integration bbar",
        "hex8\n    integration reduced\n    hourglass stiffness(0.05)",
    ] {
        let scene = load_text(&bent_beam(element, nx, nz, theta_max, tp));
        let h = step_of(&scene);
        let tr = simulate(&scene, method("staggered"), h, tp, 10);
        let what = element.replace("\n   ", "");
        assert!(tr.report.finished, "{what}: {:?}", tr.report.failure);
        let theta = |t: f64| theta_max * (1.0 - (std::f64::consts::PI * t / tp).cos()) / 2.0;
        // D_p where the curvature θ/L reaches k (linear interpolation between frames).
        let plastic_at = |k: f64| {
            for w in tr.frames.windows(2) {
                let (k0, k1) = (theta(w[0].t) / len, theta(w[1].t) / len);
                if k0 <= k && k1 >= k {
                    let s = (k - k0) / (k1 - k0);
                    return w[0].mesh.energy.plastic * (1.0 - s) + w[1].mesh.energy.plastic * s;
                }
            }
            panic!("{what}: the curvature never reaches {k}");
        };
        let (k1, k2) = (9.0, 12.0);
        let slope =
            (plastic_at(k2 * kappa_y) - plastic_at(k1 * kappa_y)) / ((k2 - k1) * kappa_y * len);
        let beam = mp * (1.0 - 1.0 / (k1 * k2));
        let last = tr.last();
        let en = &last.mesh.energy;
        let d_end = len * section_plastic_work(b, hd, theta(last.t) / len);
        let balance = en.kinetic + en.balance_potential();
        eprintln!(
            "{what}: ΔD_p/Δθ over κ = 9–12 κ_y {slope:.5e} N·m = {:.4} M_p (beam theory {:.4} M_p, {:+.2} %); D_p {:.4e} J vs {d_end:.4e} J ({:+.2} %); balance {balance:.1e} J of W {:.3e} J; {} steps",
            slope / mp,
            beam / mp,
            100.0 * (slope / beam - 1.0),
            en.plastic,
            100.0 * (en.plastic / d_end - 1.0),
            en.external_work,
            tr.report.steps
        );
        assert!(
            (slope / beam - 1.0).abs() < 0.02,
            "{what}: ΔD_p/Δθ {slope} vs {beam}"
        );
        assert!(
            (slope / mp - 1.0).abs() < 0.02,
            "{what}: ΔD_p/Δθ {slope} vs M_p {mp}"
        );
        assert!(
            (en.plastic / d_end - 1.0).abs() < 0.02,
            "{what}: D_p {} vs {d_end}",
            en.plastic
        );
        assert!(
            balance.abs() < 1e-8 * en.external_work,
            "{what}: balance {balance:e} J"
        );
        assert!(
            tr.report.max_energy_drift < 1e-3,
            "{what}: drift {}",
            tr.report.max_energy_drift
        );
    }
}

/// Check 8 with plasticity: an elastoplastic block large enough for the parallel element
/// loop (3456 hex8, 8 points each) gives bitwise the same displacements, stresses,
/// plastic strains and plastic work with 1, 2 and 4 threads (each element updates only
/// its own points; the plastic work is summed in element order).
#[test]
fn plastic_results_are_bitwise_identical_for_any_thread_count() {
    let scene = load_text(
        r#"
model threads {
  material steel {
    E 200 GPa; nu 0.3; rho 8000 kg/m^3
    plastic { yield 1 MPa; hardening 2 GPa }
  }
  mesh block {
    element hex8
    generate box(origin: (0, 0, 0) m, size: (0.4, 0.2, 0.2) m, divisions: (24, 12, 12))
    material steel
    set bottom = nodes(z == 0)
    set top = nodes(z == 0.2 m)
    fix bottom
    traction top, (1 MPa * step(t), 0, -2 MPa * step(t))
  }
  simulate { duration 1 ms; step 1 us }
}
"#,
    );
    let h = step_of(&scene);
    let [(_, one), others @ ..] =
        simulate_on_1_2_4_threads(&scene, method("staggered"), h, 20.0 * h, 20);
    assert!(one.report.finished, "{:?}", one.report.failure);
    let m1 = &one.last().mesh;
    assert!(m1.energy.plastic > 0.0, "the block yields");
    for (n, other) in &others {
        let m = &other.last().mesh;
        assert_eq!(m1.u, m.u, "{n} threads");
        assert_eq!(m1.stress, m.stress, "{n} threads");
        assert_eq!(m1.plastic, m.plastic, "{n} threads");
        assert_eq!(
            m1.equivalent_plastic_strain, m.equivalent_plastic_strain,
            "{n} threads"
        );
        assert_eq!(
            m1.energy.plastic.to_bits(),
            m.energy.plastic.to_bits(),
            "{n} threads"
        );
    }
}
