//! The flexible-beam element kernel: the internal force of one 2-node, shear-deformable
//! (Reissner/Timoshenko) 3-D beam element by the co-rotational, incremental method of
//! Downer, Park & Chiou (notes B §1–§6; the per-element algorithm is notes B §6.4).
//!
//! **What it is.** Plain functions over caller-owned plain data, no allocation:
//! [`internal_force`] advances one element by one force evaluation (convected frame,
//! objective strain increments, additive resultant update, nodal wrenches);
//! [`strain_rate`] is the strain operator `B` (5.2) applied to the nodal velocities;
//! [`total_curvature`] is the Euler-parameter curvature (5.7–5.9); [`lumped_mass`] is a
//! node's share of the element's mass and rotary inertia (3.25). The interpreter and
//! generated code call them per element; they own the [`ElementState`]s.
//!
//! **Conventions** (the runtime's, [`crate::contract::system`]):
//! - A node is a body: position `x` (world), unit quaternion `q` body → world with
//!   `C = rotation(q)` (the paper's `R = Cᵀ`, notes B §5.2), velocity `v` (world), angular
//!   velocity `ω` (**body** components). Its body frame is the cross-section frame `b`:
//!   axis 1 along the beam, axes 2 and 3 the section's principal axes.
//! - The convected (chord) frame `a` is held as the paper's `T` (rows `a₁, a₂, a₃`, world
//!   components), so `T` maps world → convected components and `Tᵀ = [a₁ a₂ a₃]`. The
//!   paper's `S_I = R_I Tᵀ = C_Iᵀ Tᵀ` (5.5) maps convected → body components of node `I`.
//! - Resultants `N = (N₁, N₂, N₃)` (axial, shear 2, shear 3) and `M = (M₁, M₂, M₃)`
//!   (torsion, bending 2, bending 3) are in **convected** components (3.15); strains
//!   `γ = (axial, shear 2, shear 3)` and `κ = (twist, curvature 2, curvature 3)` likewise.
//! - Output wrenches are **the forces acting on the nodes** (`−S` of the paper's
//!   `M z̈ + S = f`, 3.29), in [`Wrench`]'s convention: force in world components, moment in
//!   the node's body components; they add to applied forces like any other force kernel.
//!
//! **What it must never know.** No integrator (it never advances positions or velocities,
//! and needs no step size: increments are measured against the configuration stored at
//! the previous call), no solver, no scene text, no assembly (node numbering, attachments
//! and the scene's `up` vector are the caller's).
//!
//! **Printing errors of the paper it corrects** (notes B §9, §3.2, §6):
//! - convected frame `a₂ = b₃ × a₁` (normalised), not `a₁ × b₃`, so `S = I` on the
//!   undeformed straight element (§9 item 7);
//! - (5.20) with the transpose restored, `Δφ̃ᵀ = (Tⁿ⁺¹ − Tⁿ)(Tⁿ⁺½)ᵀ`; here in the
//!   equivalent form (5.21)–(5.23) with `Tⁿ⁺½` the geometric half rotation (§9 item 3);
//! - `Δτ_a` from the deformation-only relative rotation `ΔS_I = S_Iⁿᵀ S_Iⁿ⁺¹` with the
//!   Cayley extraction (5.25), and the incremental curvature `Δκ = (Δτ_a2 − Δτ_a1)/ℓ`
//!   (the operand of ∂/∂ξ lost in (5.24), §9 item 5);
//! - one-point (midpoint) integration of the shear terms, `Δγ₂ = ½ e₁ × (Δτ_a1 + Δτ_a2)`,
//!   against shear locking (§6.3, §8 item 6);
//! - the element force is the integral (`ℓ·Bᵀ{N; M}`), not the midpoint integrand that
//!   (5.2) prints (§9 item 6);
//! - the curvature row of `B` is "variant A" `[0, 0, −S₁ᵀ/ℓ, S₂ᵀ/ℓ]`: the printed
//!   `½ κ̃_S` terms are not objective in 3-D (notes B §3.2; they vanish in plane motion)
//!   and are not conjugate to the `Δκ` used in the stress update;
//! - ρ counted once in the rotary inertia (3.25, §9 item 8);
//! - `Δγ₁` divides by the chord length of the previous evaluation, `ℓⁿ` (notes B §6.3's
//!   recommendation: the printed `d/(ℓₑ + d)` claim is not reproducible, §9 item 4).
//!
//! The Cayley update with `D = 1 + h²|ω|²/16` (§9 item 2) belongs to the integrator
//! ([`crate::contract::math::cayley_update`]); this kernel does not integrate.
//!
//! **Observations on the notes** (beyond §9):
//! - With the §6.4 formulas, `Δγ₁ = ΔT½ [T½ (Δu₂ − Δu₁)/ℓⁿ − T½ (a₁ − a₁ⁿ)]` is
//!   *identically* `((ℓ − ℓⁿ)/ℓⁿ) e₁` (because `Δu₂ − Δu₁ = ℓ a₁ − ℓⁿ a₁ⁿ` and
//!   `ΔT½ T½ a₁ = T a₁ = e₁`): all transverse shear comes from `Δγ₂`, the section rotation
//!   relative to the chord. The algorithm is implemented as written; a test checks the
//!   identity.
//! - §6.4 divides `Δκ` by the *current* length `ℓ` but `Δγ₁` by `ℓⁿ`; the notes give no
//!   reason for the difference. Kept as written (the current `ℓ` is the one in `B`).

use nalgebra::{Matrix3, Quaternion, Vector3};

use crate::contract::math::{qconj, qmul, quat_from_rotation, rotation};
use crate::contract::scene::Section;
use crate::contract::system::{Pose, Twist, Wrench};

/// Why a beam element could not be built or evaluated.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum BeamError {
    /// A section property is zero, negative or not finite.
    #[error("beam section: {what} = {value} must be positive and finite")]
    NonPositive {
        /// The property's name (`EA`, `GA2`, ...).
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// The element's chord has (almost) zero length.
    #[error("beam element: chord length {length} is (almost) zero")]
    ZeroLength {
        /// The chord length.
        length: f64,
    },
    /// Node 1's section axis `b₃` is (almost) parallel to the chord, so the convected
    /// frame's `a₂ = b₃ × a₁` is undefined (a shear angle of 90°).
    #[error("beam element: section axis 3 of node 1 is parallel to the chord")]
    DegenerateFrame,
    /// A node's section rotated by (almost) 180° relative to the chord frame in one
    /// evaluation, where the increment (5.25) is singular.
    #[error("beam element: rotation increment of node {node} is (almost) 180°")]
    RotationIncrement {
        /// The node (1 or 2).
        node: usize,
    },
}

/// Section properties of a beam, as the element kernel uses them: stiffnesses for the
/// constitutive law (5.4) and inertia per length for the lumped mass (3.25).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamSection {
    /// Axial stiffness EA (N).
    pub ea: f64,
    /// Effective shear stiffness along section axis 2, `k₂GA` (N; correction included).
    pub ga2: f64,
    /// Effective shear stiffness along section axis 3, `k₃GA` (N).
    pub ga3: f64,
    /// Torsional stiffness GJ (N·m²).
    pub gj: f64,
    /// Bending stiffness about section axis 2, EI₂ (N·m²).
    pub ei2: f64,
    /// Bending stiffness about section axis 3, EI₃ (N·m²).
    pub ei3: f64,
    /// Mass per length ρA (kg/m).
    pub rho_a: f64,
    /// Rotary inertia per length `ρJ = ρ·diag(I₁ (polar), I₂, I₃)` (kg·m), body axes
    /// (notes B §2.1, (3.4)); ρ is in it once.
    pub rho_j: Vector3<f64>,
}

impl BeamSection {
    /// The kernel's section from the scene's [`Section`]. The scene gives one rotary
    /// inertia, the polar `ρI₁`; the two bending ones are derived for a homogeneous section
    /// as `ρI_k = ρA · EI_k / EA` (`ρI_k = ρ A (I_k/A)` and `EI_k/EA = I_k/A`).
    ///
    /// Errors with [`BeamError::NonPositive`] naming the first property that is not
    /// positive and finite.
    pub fn from_scene(s: &Section) -> Result<BeamSection, BeamError> {
        for (what, value) in [
            ("EA", s.ea),
            ("GA2", s.ga2),
            ("GA3", s.ga3),
            ("GJ", s.gj),
            ("EI2", s.ei2),
            ("EI3", s.ei3),
            ("rhoA", s.rho_a),
            ("rhoI", s.rho_i),
        ] {
            if value.is_nan() || value <= 0.0 || value.is_infinite() {
                return Err(BeamError::NonPositive { what, value });
            }
        }
        Ok(BeamSection {
            ea: s.ea,
            ga2: s.ga2,
            ga3: s.ga3,
            gj: s.gj,
            ei2: s.ei2,
            ei3: s.ei3,
            rho_a: s.rho_a,
            rho_j: Vector3::new(s.rho_i, s.rho_a * s.ei2 / s.ea, s.rho_a * s.ei3 / s.ea),
        })
    }

    /// The diagonal of the force–strain law (5.4), `ΔN = diag(EA, GA₂, GA₃) Δγ`.
    pub fn c_gamma(&self) -> Vector3<f64> {
        Vector3::new(self.ea, self.ga2, self.ga3)
    }

    /// The diagonal of the moment–curvature law (5.4), `ΔM = diag(GJ, EI₂, EI₃) Δκ`.
    pub fn c_kappa(&self) -> Vector3<f64> {
        Vector3::new(self.gj, self.ei2, self.ei3)
    }
}

/// One beam node as the element sees it: its pose (position world, orientation body →
/// world) and its twist (velocity world, angular velocity body). Only [`strain_rate`]
/// reads the twist.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamNode {
    /// Position and orientation (`pose.c` must equal `rotation(pose.q)`, as
    /// [`Pose::new`] keeps it).
    pub pose: Pose,
    /// Velocity (world) and angular velocity (body components).
    pub twist: Twist,
}

/// The state an element carries from one force evaluation to the next: its resultants,
/// its accumulated strains and the configuration of the previous evaluation (the
/// increments of notes B §6.3 are measured against it). All public so that a caller can
/// prestress an element or save and restore it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElementState {
    /// Force resultants `N = (axial, shear 2, shear 3)`, convected components (3.15).
    pub n: Vector3<f64>,
    /// Moment resultants `M = (torsion, bending 2, bending 3)`, convected components.
    pub m: Vector3<f64>,
    /// Accumulated force strains `γ = Σ Δγ` (axial, shear 2, shear 3).
    pub gamma: Vector3<f64>,
    /// Accumulated curvatures `κ = Σ Δκ` (twist, curvature 2, curvature 3), 1/m.
    pub kappa: Vector3<f64>,
    /// Reference (stress-free) chord length `ℓ₀` (m), for the lumped mass.
    pub l0: f64,
    /// Chord length at the previous evaluation, `ℓⁿ`.
    pub l_prev: f64,
    /// Convected frame at the previous evaluation, `Tⁿ` (rows `a₁, a₂, a₃`).
    pub t_prev: Matrix3<f64>,
    /// Section-vs-convected rotations at the previous evaluation, `S_Iⁿ` (5.5).
    pub s_prev: [Matrix3<f64>; 2],
    /// Node positions at the previous evaluation (world).
    pub x_prev: [Vector3<f64>; 2],
}

impl ElementState {
    /// A stress-free element in the configuration of `nodes` (the reference: `ℓ₀` is its
    /// chord length). The sections need not be perpendicular to the chord; whatever `S_I`
    /// they have is the unstrained one.
    pub fn new(nodes: &[BeamNode; 2]) -> Result<ElementState, BeamError> {
        let x = [nodes[0].pose.r, nodes[1].pose.r];
        let (t, l) = convected_frame(&x[0], &x[1], &nodes[0].pose.c)?;
        Ok(ElementState {
            n: Vector3::zeros(),
            m: Vector3::zeros(),
            gamma: Vector3::zeros(),
            kappa: Vector3::zeros(),
            l0: l,
            l_prev: l,
            t_prev: t,
            s_prev: [
                section_rotation(&nodes[0].pose.c, &t),
                section_rotation(&nodes[1].pose.c, &t),
            ],
            x_prev: x,
        })
    }
}

/// What one evaluation of [`internal_force`] produces.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ElementForce {
    /// The internal forces acting on node 1 and node 2 (force world, moment body).
    pub wrench: [Wrench; 2],
    /// This evaluation's force-strain increment `Δγ = Δγ₁ + Δγ₂` (5.12).
    pub d_gamma: Vector3<f64>,
    /// This evaluation's curvature increment `Δκ` (5.13).
    pub d_kappa: Vector3<f64>,
    /// The Euler-parameter total curvature (5.9) of the current configuration, in the
    /// mean section frame `q_a` (for output and checks; the stress update uses `Δκ`).
    pub kappa_total: Vector3<f64>,
    /// Current chord length `ℓ`.
    pub length: f64,
    /// Current convected frame `T` (rows `a₁, a₂, a₃`).
    pub frame: Matrix3<f64>,
}

/// The convected (chord) frame of notes B §6.1 step 2 and the chord length:
/// `a₁ = (x₂ − x₁)/ℓ`, `a₂ = (b₃ × a₁)/|b₃ × a₁|` with `b₃ = C₁ e₃` node 1's section axis 3
/// (the corrected order, §9 item 7), `a₃ = a₁ × a₂`. Returns `T` (rows `a₁, a₂, a₃`) and
/// `ℓ`.
pub fn convected_frame(
    x1: &Vector3<f64>,
    x2: &Vector3<f64>,
    c1: &Matrix3<f64>,
) -> Result<(Matrix3<f64>, f64), BeamError> {
    let d = x2 - x1;
    let l = d.norm();
    let scale = x1.norm().max(x2.norm());
    if !l.is_finite() || l == 0.0 || l <= 1e-12 * scale {
        return Err(BeamError::ZeroLength { length: l });
    }
    let a1 = d / l;
    let b3 = c1.column(2).into_owned();
    let a2 = b3.cross(&a1);
    let s = a2.norm();
    if s.is_nan() || s <= 1e-8 {
        return Err(BeamError::DegenerateFrame);
    }
    let a2 = a2 / s;
    let a3 = a1.cross(&a2);
    Ok((
        Matrix3::from_rows(&[a1.transpose(), a2.transpose(), a3.transpose()]),
        l,
    ))
}

/// `S = R Tᵀ = Cᵀ Tᵀ` (5.5): convected → body components of a node with rotation `C`
/// (body → world).
fn section_rotation(c: &Matrix3<f64>, t: &Matrix3<f64>) -> Matrix3<f64> {
    (t * c).transpose()
}

/// The rotation vector of a deformation-only increment `ΔS` by the Cayley extraction
/// (5.25): `Δτ̃ᵀ = 2(ΔS − ΔSᵀ)/(1 + tr ΔS)`, read from the layout
/// `ṽᵀ = [[0, v₃, −v₂], [−v₃, 0, v₁], [v₂, −v₁, 0]]`. Its length is `2 tan(θ/2)` for a
/// rotation by θ; `None` near θ = π, where it is singular.
pub fn cayley_rotation_vector(ds: &Matrix3<f64>) -> Option<Vector3<f64>> {
    let den = 1.0 + ds.trace();
    if den.is_nan() || den <= 1e-12 {
        return None;
    }
    let f = 2.0 / den;
    Some(Vector3::new(
        f * (ds[(1, 2)] - ds[(2, 1)]),
        f * (ds[(2, 0)] - ds[(0, 2)]),
        f * (ds[(0, 1)] - ds[(1, 0)]),
    ))
}

/// The total curvature of notes B (5.7)–(5.9): with `q₂` sign-aligned to `q₁`
/// (`q₁·q₂ ≥ 0`; `q` and `−q` are one rotation, which the notes leave unsaid),
/// `q_a = (q₁ + q₂)/|q₁ + q₂|` and `∂q/∂ξ = (q₂ − q₁)/ℓ`,
/// `{0; κ} = E(q_a) ∂q/∂ξ = 2 q_a* ⊗ ∂q/∂ξ`, i.e. `κ` in the body components of the mean
/// section frame `q_a`. Invariant to rigid rotations. Pure bending (notes B (5.10), Fig. 3),
/// the nodes rotated by `∓τ` about `n` relative to the mean frame (so by **2τ** relative
/// to each other), gives `κ = (4/ℓ) sin(τ/2) n`, against `(2/ℓ) τ n` for the exact arc.
/// Because of the sign alignment this holds for a relative angle `2τ < π`: past it, the
/// element reads the shorter rotation the other way (the notes' "for any φ, n_a" is
/// silent on τ; a 2-node element cannot tell 2τ from 2τ − 2π).
pub fn total_curvature(q1: &Quaternion<f64>, q2: &Quaternion<f64>, l: f64) -> Vector3<f64> {
    let q2 = if q1.coords.dot(&q2.coords) < 0.0 {
        -q2
    } else {
        *q2
    };
    let qa = q1 + q2;
    let qa = qa / qa.norm();
    let k = qmul(&qconj(&qa), &(q2 - q1)) * (2.0 / l);
    Vector3::new(k.i, k.j, k.k)
}

/// One force evaluation of the element (notes B §6.4), from the stored previous
/// configuration in `state` to the configuration of `nodes`:
///
/// 1. frame: `T` and `ℓ` by [`convected_frame`]; `S_I = C_Iᵀ Tᵀ` (5.5);
/// 2. chord increment (5.17)–(5.23): `ΔT = T Tⁿᵀ`, `ΔT½ = √ΔT` (half the rotation angle,
///    same axis), `T½ = ΔT½ Tⁿ`, `{0, −Δφ₃, Δφ₂} = −T½ (a₁ − a₁ⁿ)` (5.21),
///    `Δγ₁ = ΔT½ [T½ (Δu₂ − Δu₁)/ℓⁿ + {0, −Δφ₃, Δφ₂}]` (5.22–5.23);
/// 3. section increments (5.24)–(5.25): `ΔS_I = S_Iⁿᵀ S_I`, `Δτ_I` by
///    [`cayley_rotation_vector`]; `Δγ₂ = ½ e₁ × (Δτ₁ + Δτ₂)` (one-point rule),
///    `Δκ = (Δτ₂ − Δτ₁)/ℓ`;
/// 4. resultants (5.3)–(5.4): `N += diag(EA, GA₂, GA₃)(Δγ₁ + Δγ₂)`,
///    `M += diag(GJ, EI₂, EI₃) Δκ`;
/// 5. nodal forces, the integral `ℓ [Bᴱ]ᵀ {N; M}` of (5.1)–(5.2) with the objective
///    curvature row: the paper's `S₁ᵉ = −TᵀN`, `S₂ᵉ = TᵀN`,
///    `S_Iᵇ = (ℓ/2) S_I ĩ₁ᵀ N ∓ S_I M` (− node 1, + node 2; `ĩ₁ v = e₁ × v`); the output
///    wrenches are their negatives (the forces on the nodes).
///
/// The element is in exact equilibrium (the wrenches' resultant force and moment about any
/// point vanish, since `C_I S_I = Tᵀ`), and a rigid motion changes no strain. On error
/// `state` is left unchanged.
pub fn internal_force(
    section: &BeamSection,
    state: &mut ElementState,
    nodes: &[BeamNode; 2],
    out: &mut ElementForce,
) -> Result<(), BeamError> {
    let a = advance(section, state, nodes)?;
    out.wrench = nodal_wrenches(&a.t, a.l, &a.s, &state.n, &state.m);
    out.d_gamma = a.d_gamma;
    out.d_kappa = a.d_kappa;
    out.kappa_total = total_curvature(&nodes[0].pose.q, &nodes[1].pose.q, a.l);
    out.length = a.l;
    out.frame = a.t;
    Ok(())
}

/// What the state update of one evaluation leaves for the nodal forces.
struct Advanced {
    /// Convected frame `T`.
    t: Matrix3<f64>,
    /// Chord length `ℓ`.
    l: f64,
    /// Section rotations `S_I`.
    s: [Matrix3<f64>; 2],
    /// Strain increments `Δγ`, `Δκ`.
    d_gamma: Vector3<f64>,
    d_kappa: Vector3<f64>,
}

/// Steps 1–4 of [`internal_force`]: the frame, the increments and the resultant update.
/// On error `state` is left unchanged.
#[inline(always)]
fn advance(
    section: &BeamSection,
    state: &mut ElementState,
    nodes: &[BeamNode; 2],
) -> Result<Advanced, BeamError> {
    let x = [nodes[0].pose.r, nodes[1].pose.r];
    let c = [nodes[0].pose.c, nodes[1].pose.c];
    let (t, l) = convected_frame(&x[0], &x[1], &c[0])?;
    let s = [section_rotation(&c[0], &t), section_rotation(&c[1], &t)];

    // (ii) first, since it can fail: Δτ_I of the deformation-only increments (5.25).
    let mut dtau = [Vector3::zeros(); 2];
    for i in 0..2 {
        let ds = state.s_prev[i].transpose() * s[i];
        dtau[i] =
            cayley_rotation_vector(&ds).ok_or(BeamError::RotationIncrement { node: i + 1 })?;
    }

    // (i) chord stretch/shear increment (5.17)–(5.23) with the geometric half rotation.
    let dt = t * state.t_prev.transpose();
    let p = quat_from_rotation(&dt); // w ≥ 0, so (1 + p)/|1 + p| is the half rotation
    let ph = Quaternion::new(1.0 + p.w, p.i, p.j, p.k);
    let dt_half = rotation(&(ph / ph.norm()));
    let t_half = dt_half * state.t_prev;
    let a1 = t.row(0).transpose();
    let a1_prev = state.t_prev.row(0).transpose();
    let dphi_term = -(t_half * (a1 - a1_prev));
    let du = (x[1] - state.x_prev[1]) - (x[0] - state.x_prev[0]);
    let dg1 = dt_half * (t_half * du / state.l_prev + dphi_term);

    let e1 = Vector3::x();
    let dg2 = 0.5 * e1.cross(&(dtau[0] + dtau[1]));
    let d_gamma = dg1 + dg2;
    let d_kappa = (dtau[1] - dtau[0]) / l;

    state.n += section.c_gamma().component_mul(&d_gamma);
    state.m += section.c_kappa().component_mul(&d_kappa);
    state.gamma += d_gamma;
    state.kappa += d_kappa;
    state.l_prev = l;
    state.t_prev = t;
    state.s_prev = s;
    state.x_prev = x;
    Ok(Advanced {
        t,
        l,
        s,
        d_gamma,
        d_kappa,
    })
}

/// What the integrators evaluate per element and force evaluation, monomorphized on
/// whether the beam is damped: [`internal_force`]'s state update and nodal forces into `w`,
/// without the total curvature (an output quantity, not a force), and with `DAMPED` the
/// stiffness-proportional damping forces `β ℓ Bᵀ{diag(EA, GA₂, GA₃) γ̇; diag(GJ, EI₂, EI₃) κ̇}`
/// ([`strain_rate`] of the nodes' twists) in the same frame, added. The frame, chord and
/// section rotations are computed once for both, so the result is bitwise that of
/// [`internal_force`] followed by a damping evaluation that recomputes them.
///
/// Returns the element's relative section turn in this evaluation, `|Δκ| ℓ` (the Cayley
/// length of the turn), which the caller compares with its large-rotation threshold. On
/// error `state` is left unchanged.
#[inline]
pub fn element_forces<const DAMPED: bool>(
    section: &BeamSection,
    beta: f64,
    state: &mut ElementState,
    nodes: &[BeamNode; 2],
    w: &mut [Wrench; 2],
) -> Result<f64, BeamError> {
    let a = advance(section, state, nodes)?;
    if DAMPED {
        let (gd, kd) = strain_rate_in(&a.t, a.l, nodes);
        let n = section.c_gamma().component_mul(&gd) * beta;
        let m = section.c_kappa().component_mul(&kd) * beta;
        // the elastic and the damping wrenches, summed (not the summed resultants' wrenches:
        // the operations of the two evaluations, in their order)
        let e = nodal_wrenches(&a.t, a.l, &a.s, &state.n, &state.m);
        let d = nodal_wrenches(&a.t, a.l, &a.s, &n, &m);
        for i in 0..2 {
            w[i].f = e[i].f + d[i].f;
            w[i].t = e[i].t + d[i].t;
        }
    } else {
        *w = nodal_wrenches(&a.t, a.l, &a.s, &state.n, &state.m);
    }
    Ok(a.d_kappa.norm() * a.l)
}

/// The forces on an element's nodes from section resultants `N`, `M` (convected
/// components) in the configuration with convected frame `t`, chord length `l` and
/// section rotations `s` (`S_I = C_Iᵀ Tᵀ`, (5.5)): `−ℓ Bᵀ{N; M}`, i.e. the paper's
/// `S₁ᵉ = −TᵀN`, `S₂ᵉ = TᵀN`, `S_Iᵇ = (ℓ/2) S_I ĩ₁ᵀ N ∓ S_I M`, negated (force world,
/// moment body). Used by [`internal_force`] and for damping resultants.
pub fn nodal_wrenches(
    t: &Matrix3<f64>,
    l: f64,
    s: &[Matrix3<f64>; 2],
    n: &Vector3<f64>,
    m: &Vector3<f64>,
) -> [Wrench; 2] {
    let f = t.transpose() * n; // TᵀN, world
    let shear = 0.5 * l * -Vector3::x().cross(n); // (ℓ/2) ĩ₁ᵀ N
    [
        Wrench {
            f,
            t: -(s[0] * (shear - m)),
        },
        Wrench {
            f: -f,
            t: -(s[1] * (shear + m)),
        },
    ]
}

/// `S_I = C_Iᵀ Tᵀ` (5.5) of both nodes: convected → body components.
pub fn section_rotations(nodes: &[BeamNode; 2], t: &Matrix3<f64>) -> [Matrix3<f64>; 2] {
    [
        section_rotation(&nodes[0].pose.c, t),
        section_rotation(&nodes[1].pose.c, t),
    ]
}

/// The elastic strain energy stored in an element, `ℓ₀/2 (γ·N + κ·M)` (J): exact for the
/// linear section law, whose resultants are `N = diag(EA, GA₂, GA₃) γ` and
/// `M = diag(GJ, EI₂, EI₃) κ` of the accumulated strains.
pub fn strain_energy(state: &ElementState) -> f64 {
    0.5 * state.l0 * (state.gamma.dot(&state.n) + state.kappa.dot(&state.m))
}

/// The strain rates `{γ̇; κ̇} = Bᴱ ż` of the current configuration: the one-point strain
/// operator (5.2) with the objective curvature row ("variant A", notes B §3.2) applied to
/// the nodal velocities `ż = {v₁, v₂, ω₁, ω₂}`:
/// `γ̇ = T (v₂ − v₁)/ℓ + ½ e₁ × (S₁ᵀω₁ + S₂ᵀω₂)`, `κ̇ = (S₂ᵀω₂ − S₁ᵀω₁)/ℓ` (convected
/// components). Zero for every rigid velocity field; the conjugate of [`internal_force`]'s
/// wrenches: `Σ_I (f_I·v_I + t_I·ω_I) = −ℓ (N·γ̇ + M·κ̇)`. Returns `(γ̇, κ̇)`.
pub fn strain_rate(nodes: &[BeamNode; 2]) -> Result<(Vector3<f64>, Vector3<f64>), BeamError> {
    let (t, l) = convected_frame(&nodes[0].pose.r, &nodes[1].pose.r, &nodes[0].pose.c)?;
    Ok(strain_rate_in(&t, l, nodes))
}

/// [`strain_rate`] in a frame `t` and chord length `l` already computed.
#[inline(always)]
fn strain_rate_in(t: &Matrix3<f64>, l: f64, nodes: &[BeamNode; 2]) -> (Vector3<f64>, Vector3<f64>) {
    // S_Iᵀ ω_I = T C_I ω_I: the angular velocity in convected components.
    let w1 = t * (nodes[0].pose.c * nodes[0].twist.w);
    let w2 = t * (nodes[1].pose.c * nodes[1].twist.w);
    let g = t * (nodes[1].twist.v - nodes[0].twist.v) / l + 0.5 * Vector3::x().cross(&(w1 + w2));
    (g, (w2 - w1) / l)
}

/// A node's lumped share of one element's inertia (notes B §3.1): half the element each.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LumpedMass {
    /// Mass `ρA ℓ/2` (kg).
    pub m: f64,
    /// Rotary inertia `ρJ ℓ/2` (kg·m²), the diagonal in body (section) axes; ρ is counted
    /// once (the paper's (3.25) prints `ρ J_I` with `J` already containing ρ, §9 item 8).
    pub j: Vector3<f64>,
}

/// The lumped mass and rotary inertia that one element of length `l` gives each of its two
/// nodes (3.25 lumped): `m = ρA l/2`, `J = ρJ l/2`. Pass the reference length
/// ([`ElementState::l0`]), so the mass is constant. A node's total is the sum over the
/// elements it belongs to.
pub fn lumped_mass(section: &BeamSection, l: f64) -> LumpedMass {
    LumpedMass {
        m: 0.5 * l * section.rho_a,
        j: 0.5 * l * section.rho_j,
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Matrix3, Quaternion, Vector3};
    use proptest::prelude::*;

    use super::*;
    use crate::contract::math::{axis_angle, qmul, quat_from_rotation, rotate};

    fn section() -> BeamSection {
        BeamSection::from_scene(&Section {
            ea: 2.8e7,
            ga2: 1.0e7,
            ga3: 0.9e7,
            ei2: 1.4e4,
            ei3: 2.1e4,
            gj: 1.1e4,
            rho_a: 1.2,
            rho_i: 6.0e-4,
        })
        .unwrap()
    }

    fn node(x: Vector3<f64>, q: Quaternion<f64>) -> BeamNode {
        BeamNode {
            pose: Pose::new(x, q),
            twist: Twist::default(),
        }
    }

    fn v3(a: [f64; 3]) -> Vector3<f64> {
        Vector3::new(a[0], a[1], a[2])
    }

    /// A unit quaternion from a rotation vector.
    fn qrot(r: Vector3<f64>) -> Quaternion<f64> {
        axis_angle(&r, r.norm())
    }

    /// A random element: node 1 at `x1`, chord `l·dir`, node sections = the chord-aligned
    /// frame `q0` (its axis 1 along `dir`) turned by the rotation vectors `r1`, `r2`
    /// (body), so that the reference is already "deformed-looking" (S ≠ I, 3-D curvature).
    fn element(x1: [f64; 3], dir: [f64; 3], l: f64, r1: [f64; 3], r2: [f64; 3]) -> [BeamNode; 2] {
        let d = v3(dir).normalize();
        let q0 = quat_from_rotation(&rotation_aligning_x(&d));
        let x1 = v3(x1);
        [
            node(x1, qmul(&q0, &qrot(v3(r1)))),
            node(x1 + l * d, qmul(&q0, &qrot(v3(r2)))),
        ]
    }

    /// A rotation matrix whose first column is the unit vector `d`.
    fn rotation_aligning_x(d: &Vector3<f64>) -> Matrix3<f64> {
        let h = if d.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let e2 = h.cross(d).normalize();
        let e3 = d.cross(&e2);
        Matrix3::from_columns(&[*d, e2, e3])
    }

    /// The element moved rigidly: `x → Q x + b`, `C → Q C`, with the rigid velocity field
    /// `v = v₀ + Ω × x'`, `ω = C'ᵀ Ω` (the same world `Ω` for both nodes).
    fn rigid(
        nodes: &[BeamNode; 2],
        q: &Quaternion<f64>,
        b: Vector3<f64>,
        v0: Vector3<f64>,
        om: Vector3<f64>,
    ) -> [BeamNode; 2] {
        nodes.map(|n| {
            let pose = Pose::new(rotate(q, &n.pose.r) + b, qmul(q, &n.pose.q));
            let twist = Twist {
                v: v0 + om.cross(&pose.r),
                w: pose.c.transpose() * om,
            };
            BeamNode { pose, twist }
        })
    }

    fn a3() -> impl Strategy<Value = [f64; 3]> {
        prop::array::uniform3(-1.0f64..1.0)
    }

    fn dir() -> impl Strategy<Value = [f64; 3]> {
        a3().prop_filter("non-zero direction", |d| v3(*d).norm() > 0.1)
    }

    /// Worst relative residual of one rigid-motion case (strain increments, strain rates,
    /// forces of a stress-free element relative to EA, and the covariance of the wrenches
    /// of a prestressed element).
    #[allow(clippy::too_many_arguments)]
    fn rigid_case(
        x1: [f64; 3],
        d: [f64; 3],
        l: f64,
        r1: [f64; 3],
        r2: [f64; 3],
        axis: [f64; 3],
        angle: f64,
        b: [f64; 3],
        v0: [f64; 3],
        om: [f64; 3],
    ) -> (f64, f64, f64) {
        let sec = section();
        let x1 = v3(x1) * 10.0;
        let a = element(x1.into(), d, l, r1, r2);
        let q = axis_angle(&v3(axis), angle);
        let moved = rigid(&a, &q, v3(b) * 100.0, v3(v0), v3(om));
        // Geometry scale of the round-off: coordinates over length.
        let geo = 1.0 + (x1.norm() + v3(b).norm() * 100.0) / l;

        // Stress-free: zero increments, zero force.
        let mut st = ElementState::new(&a).unwrap();
        let mut out = ElementForce::default();
        internal_force(&sec, &mut st, &moved, &mut out).unwrap();
        let strain = out.d_gamma.amax().max(out.d_kappa.amax() * l) / geo;
        let force = out
            .wrench
            .iter()
            .map(|w| w.f.amax().max(w.t.amax() / l))
            .fold(0.0, f64::max)
            / (sec.ea * geo);
        // Rigid velocities: zero strain rate (B ż = 0 for a finite rigid field).
        let (gd, kd) = strain_rate(&moved).unwrap();
        let vs = v3(v0).norm() / l + v3(om).norm() * geo;
        let rate = gd.amax().max(kd.amax() * l) / vs.max(1e-300);

        // Prestressed: resultants unchanged, forces rotate with Q, body moments unchanged.
        let mut st = ElementState::new(&a).unwrap();
        st.n = Vector3::new(3.0e4, -2.0e3, 1.5e3);
        st.m = Vector3::new(40.0, -25.0, 60.0);
        let mut st2 = st;
        let mut before = ElementForce::default();
        // A zero-increment call gives the wrenches in the reference configuration.
        internal_force(&sec, &mut st, &a, &mut before).unwrap();
        internal_force(&sec, &mut st2, &moved, &mut out).unwrap();
        let scale = st.n.norm() + st.m.norm() / l;
        let mut cov: f64 = 0.0;
        for i in 0..2 {
            let df = out.wrench[i].f - rotate(&q, &before.wrench[i].f);
            let dt = out.wrench[i].t - before.wrench[i].t;
            cov = cov.max(df.amax().max(dt.amax() / l) / (scale * geo));
        }
        (strain.max(rate), force, cov)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// Test 1: any rigid motion (any translation, any finite rotation, rigid velocities)
        /// of a (3-D curved, sheared) element produces zero strain increments, zero strain
        /// rates and, from a stress-free state, zero force; a prestressed element's
        /// wrenches are carried along (f rotates with Q, body moments stay). Tolerance:
        /// 1e-13 relative (strains and rates; forces relative to EA), 1e-12 for the
        /// prestressed wrenches (relative to |N| + |M|/ℓ), times the geometry factor 1 + |x|/ℓ of the cancellation in `x₂ − x₁`.
        #[test]
        fn rigid_motion_is_strain_and_force_free(
            x1 in a3(), d in dir(), l in 0.05f64..20.0,
            r1 in a3(), r2 in a3(),
            axis in dir(), angle in 0.0f64..std::f64::consts::PI,
            b in a3(), v0 in a3(), om in a3(),
        ) {
            let s = 0.6; // section rotations up to ~0.6·√3 rad relative to the chord
            let r1 = r1.map(|c| c * s);
            let r2 = r2.map(|c| c * s);
            let (strain, force, cov) = rigid_case(x1, d, l, r1, r2, axis, angle, b, v0, om);
            prop_assert!(strain < 1e-13, "strain residual {strain:e}");
            prop_assert!(force < 1e-13, "force residual {force:e} (relative to EA)");
            prop_assert!(cov < 1e-12, "prestress covariance residual {cov:e}");
        }

        /// Test 3: B·δz = 0 — the strain operator applied to an infinitesimal rigid
        /// displacement `δu_I = δu₀ + δθ × x_I`, `δα_I = C_Iᵀ δθ` of a random deformed
        /// element is zero (checked with the operator itself, [`strain_rate`], on a random
        /// configuration whose nodes are displaced and rotated independently), and the
        /// wrenches are its exact transpose: `Σ f·v + t·ω = −ℓ (N·γ̇ + M·κ̇)` for any
        /// velocities. Tolerance 1e-12 relative.
        #[test]
        fn strain_operator_kills_rigid_virtual_motion(
            x1 in a3(), d in dir(), l in 0.05f64..20.0,
            r1 in a3(), r2 in a3(), dx in a3(),
            du in a3(), dth in a3(), v1 in a3(), v2 in a3(), w1 in a3(), w2 in a3(),
            n in a3(), m in a3(),
        ) {
            let mut e = element(x1, d, l, r1.map(|c| 0.6 * c), r2.map(|c| 0.6 * c));
            e[1].pose.r += v3(dx) * (0.2 * l);
            let dth = v3(dth);
            let mut z = e;
            for k in &mut z {
                k.twist.v = v3(du) + dth.cross(&k.pose.r);
                k.twist.w = k.pose.c.transpose() * dth;
            }
            let (gd, kd) = strain_rate(&z).unwrap();
            let lc = (e[1].pose.r - e[0].pose.r).norm();
            let scale = v3(du).norm() / lc + dth.norm() * (1.0 + v3(x1).norm() / lc);
            prop_assert!(gd.amax().max(kd.amax() * lc) < 1e-12 * scale, "B δz = {gd} {kd}");

            // Conjugacy of the wrenches and B.
            let sec = section();
            let mut st = ElementState::new(&e).unwrap();
            st.n = v3(n) * 1e4;
            st.m = v3(m) * 1e2;
            let mut out = ElementForce::default();
            internal_force(&sec, &mut st, &e, &mut out).unwrap();
            let mut y = e;
            y[0].twist = Twist { v: v3(v1), w: v3(w1) };
            y[1].twist = Twist { v: v3(v2), w: v3(w2) };
            let (gd, kd) = strain_rate(&y).unwrap();
            let power: f64 = (0..2)
                .map(|i| out.wrench[i].f.dot(&y[i].twist.v) + out.wrench[i].t.dot(&y[i].twist.w))
                .sum();
            let expect = -lc * (st.n.dot(&gd) + st.m.dot(&kd));
            let pscale = (st.n.norm() * lc + st.m.norm()) * (1.0 + 4.0 / lc);
            prop_assert!((power - expect).abs() < 1e-12 * pscale, "{power} vs {expect}");
        }

        /// Test 5: for random deformed states (random reference, nodes then displaced and
        /// rotated independently, random prestress), the nodal forces sum to zero and the
        /// moments about any point sum to zero. Tolerance 1e-12 relative to
        /// `|N| (ℓ + |x − p|) + |M|`.
        #[test]
        fn element_is_in_equilibrium(
            x1 in a3(), d in dir(), l in 0.05f64..20.0,
            r1 in a3(), r2 in a3(),
            dx1 in a3(), dx2 in a3(), dr1 in a3(), dr2 in a3(), p in a3(),
            n in a3(), m in a3(),
        ) {
            let sec = section();
            let e = element(x1, d, l, r1.map(|c| 0.3 * c), r2.map(|c| 0.3 * c));
            let mut st = ElementState::new(&e).unwrap();
            st.n = v3(n) * 1e4;
            st.m = v3(m) * 1e2;
            let mut def = e;
            for (k, (dx, dr)) in def.iter_mut().zip([(dx1, dr1), (dx2, dr2)]) {
                let q = qmul(&k.pose.q, &qrot(v3(dr) * 0.3));
                *k = node(k.pose.r + v3(dx) * (0.05 * l), q);
            }
            let mut out = ElementForce::default();
            internal_force(&sec, &mut st, &def, &mut out).unwrap();
            let p = v3(p) * 10.0;
            let fsum = out.wrench[0].f + out.wrench[1].f;
            let msum: Vector3<f64> = (0..2)
                .map(|i| (def[i].pose.r - p).cross(&out.wrench[i].f) + def[i].pose.c * out.wrench[i].t)
                .sum();
            let reach = (def[0].pose.r - p).norm().max((def[1].pose.r - p).norm());
            let scale = st.n.norm() * (out.length + reach) + st.m.norm();
            prop_assert!(fsum.amax() < 1e-12 * st.n.norm(), "Σf = {fsum}");
            prop_assert!(msum.amax() < 1e-12 * scale, "Σm = {msum}");
        }
    }

    /// Test 1's worst residuals over 2000 deterministic cases (printed with
    /// `--nocapture`), asserted against the same tolerance as the property test.
    #[test]
    fn rigid_motion_worst_residual() {
        let mut s = 0x2545_f491_4f6c_dd1d_u64;
        let mut r = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut worst = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..2000 {
            let mut a = || [r(), r(), r()];
            let (x1, mut d, r1, r2, axis, b, v0, om) = (a(), a(), a(), a(), a(), a(), a(), a());
            if v3(d).norm() < 0.1 {
                d = [1.0, 0.0, 0.0];
            }
            let l = 0.05 + 10.0 * (r() + 1.0);
            let angle = std::f64::consts::PI * 0.5 * (r() + 1.0);
            let (st, f, c) = rigid_case(
                x1,
                d,
                l,
                r1.map(|c| 0.6 * c),
                r2.map(|c| 0.6 * c),
                axis,
                angle,
                b,
                v0,
                om,
            );
            worst = (worst.0.max(st), worst.1.max(f), worst.2.max(c));
        }
        eprintln!(
            "rigid motion, worst relative residuals: strain/rate {:.2e}, force/EA {:.2e}, prestress covariance {:.2e}",
            worst.0, worst.1, worst.2
        );
        assert!(worst.0 < 1e-13 && worst.1 < 1e-13 && worst.2 < 1e-12);
    }

    /// Test 2: pure bending (notes B (5.10), Fig. 3). The convected orientation is any
    /// rotation `q_a`; the nodes are rotated by `∓τ` about `n ⊥ e₁` (mean-frame
    /// components) relative to it — relative angle 2τ — with the nodes on the arc (the
    /// chord along the mean axis 1). The total curvature (5.9) is
    /// `κ = (4/ℓ) sin(τ/2) n` within 1e-12 relative, for any `q_a`, `n`, 0.01 ≤ τ < π/2
    /// (relative angle below π, see [`total_curvature`]; (5.9) differences nearly equal quaternions, so its relative round-off grows like
    /// 1e-16/τ below that); the
    /// incremental curvature from a straight start, (5.25), is `(4/ℓ) tan(τ/2) n` (each
    /// node's increment has length `2 tan(τ/2)`), checked for `n = e₂, e₃` (where the
    /// node-1-based frame `a₂ = b₃ × a₁` does not twist) and τ < π/2 (beyond, a section
    /// would be turned past 90° from the chord and `a₂` flips).
    #[test]
    fn pure_bending_curvature() {
        let sec = section();
        let mut worst: f64 = 0.0;
        for (k, tau) in [0.01f64, 0.3, 1.0, 1.5].into_iter().enumerate() {
            for (j, phi) in [0.0f64, 0.7, 1.9, 3.0].into_iter().enumerate() {
                let n = Vector3::new(0.0, phi.cos(), phi.sin());
                let qa = axis_angle(
                    &Vector3::new(0.3 + k as f64, -1.0, 0.5 * j as f64),
                    0.4 + phi,
                );
                let l = 0.7 + phi;
                let x1 = Vector3::new(1.0, -2.0, 0.5);
                let x2 = x1 + l * rotate(&qa, &Vector3::x());
                let q1 = qmul(&qa, &axis_angle(&n, -tau));
                let q2 = qmul(&qa, &axis_angle(&n, tau));
                let kap = total_curvature(&q1, &q2, l);
                let expect = (4.0 / l) * (0.5 * tau).sin() * n;
                worst = worst.max((kap - expect).norm() / expect.norm());
                // q₂ → −q₂ is the same rotation: same curvature.
                let kap2 = total_curvature(&q1, &-q2, l);
                assert!((kap2 - kap).norm() <= 1e-15 * kap.norm());

                // Incremental, for n along a section axis; nodes fixed (no stretch).
                if (phi == 0.0 || phi == 1.9) && tau < 1.5 {
                    let n = if phi == 0.0 {
                        Vector3::y()
                    } else {
                        Vector3::z()
                    };
                    let mut st = ElementState::new(&[node(x1, qa), node(x2, qa)]).unwrap();
                    let bent = [
                        node(x1, qmul(&qa, &axis_angle(&n, -tau))),
                        node(x2, qmul(&qa, &axis_angle(&n, tau))),
                    ];
                    let mut out = ElementForce::default();
                    internal_force(&sec, &mut st, &bent, &mut out).unwrap();
                    let expect = (4.0 / l) * (0.5 * tau).tan() * n;
                    let rel = (out.d_kappa - expect).norm() / expect.norm();
                    assert!(rel < 1e-12, "tau {tau}: Δκ {} vs {expect}", out.d_kappa);
                    assert!(
                        (out.kappa_total - (4.0 / l) * (0.5 * tau).sin() * n).norm()
                            < 1e-12 * expect.norm()
                    );
                }
            }
        }
        eprintln!("pure bending: worst relative curvature error {worst:.2e}");
        assert!(worst < 1e-12, "worst {worst:e}");
    }

    /// Test 4a: a uniform stretch ε of a straight element gives `Δγ = (ε, 0, 0)`,
    /// `N₁ = EA ε` and end forces `±EA ε a₁` (node 1 pulled towards node 2), no moments;
    /// 1e-12 relative. Also checks the notes' identity `Δγ₁ = ((ℓ − ℓⁿ)/ℓⁿ) e₁` under a
    /// large rotation + stretch (notes B §6.3's test, with the `ℓⁿ` division).
    #[test]
    fn uniform_stretch_gives_axial_force() {
        let sec = section();
        let qa = axis_angle(&Vector3::new(1.0, 2.0, -0.5), 0.8);
        let a1 = rotate(&qa, &Vector3::x());
        let (x1, l0) = (Vector3::new(0.5, 0.1, -0.3), 1.7);
        for eps in [1e-6, 1e-3, 0.05, -0.02] {
            let mut st = ElementState::new(&[node(x1, qa), node(x1 + l0 * a1, qa)]).unwrap();
            let mut out = ElementForce::default();
            let str_ = [node(x1, qa), node(x1 + l0 * (1.0 + eps) * a1, qa)];
            internal_force(&sec, &mut st, &str_, &mut out).unwrap();
            let tol = 1e-12 * eps.abs() + 1e-15; // + a few ulp of the chord length
            assert!(
                (out.d_gamma - Vector3::new(eps, 0.0, 0.0)).amax() < tol,
                "{}",
                out.d_gamma
            );
            assert!(out.d_kappa.amax() < tol);
            assert!((st.n.x - sec.ea * eps).abs() < tol * sec.ea);
            assert!((out.wrench[0].f - sec.ea * eps * a1).amax() < tol * sec.ea);
            assert!((out.wrench[1].f + sec.ea * eps * a1).amax() < tol * sec.ea);
            assert!(out.wrench[0].t.amax() < tol * sec.ea * l0);
            assert!(out.wrench[1].t.amax() < tol * sec.ea * l0);
        }
        // Large rigid rotation + stretch in one evaluation: purely axial d/ℓⁿ.
        let (d, big) = (0.04, axis_angle(&Vector3::new(-0.2, 1.0, 0.4), 2.5));
        let mut st = ElementState::new(&[node(x1, qa), node(x1 + l0 * a1, qa)]).unwrap();
        let q = qmul(&big, &qa);
        let moved = [node(x1, q), node(x1 + (l0 + d) * rotate(&big, &a1), q)];
        let mut out = ElementForce::default();
        internal_force(&sec, &mut st, &moved, &mut out).unwrap();
        assert!(
            (out.d_gamma - Vector3::new(d / l0, 0.0, 0.0)).amax() < 1e-14,
            "{}",
            out.d_gamma
        );
    }

    /// Test 4b: a small transverse displacement δ of node 2 (sections kept in place) is a
    /// pure shear: the chord turns by ψ = atan(δ/ℓ₀) about a₃, each section turns by −ψ
    /// relative to it, so `N₂ = GA₂ · 2 tan(ψ/2)` (≈ GA₂ δ/ℓ₀) within 1e-12 relative, with
    /// no curvature; the wrenches are the shear force `∓N₂ a₂` and the couple `ℓ N₂`
    /// that balances it.
    #[test]
    fn transverse_displacement_gives_shear_force() {
        let sec = section();
        let (x1, l0) = (Vector3::zeros(), 2.0);
        let q = Quaternion::identity();
        for delta in [1e-3, 1e-2, 5e-2] {
            let mut st =
                ElementState::new(&[node(x1, q), node(Vector3::new(l0, 0.0, 0.0), q)]).unwrap();
            let mut out = ElementForce::default();
            let sheared = [node(x1, q), node(Vector3::new(l0, delta, 0.0), q)];
            internal_force(&sec, &mut st, &sheared, &mut out).unwrap();
            let psi = (delta / l0).atan();
            let n2 = sec.ga2 * 2.0 * (0.5 * psi).tan();
            assert!((st.n.y - n2).abs() < 1e-12 * n2, "N₂ {} vs {n2}", st.n.y);
            assert!(
                (st.n.y - sec.ga2 * delta / l0).abs() < 1e-12 * n2 + sec.ga2 * (delta / l0).powi(3)
            );
            assert!(st.n.z.abs() < 1e-12 * n2 && st.m.amax() < 1e-12 * n2 * l0);
            // Shear force on node 1 along +a₂ (towards node 2's displaced side).
            let a2 = out.frame.row(1).transpose();
            assert!((out.wrench[0].f.dot(&a2) - n2).abs() < 1e-12 * n2);
            // The couple: moments about node 1 balance the shear force over the chord.
            let m_about_1 = out.length * n2 * out.frame[(2, 2)];
            let tz = out.wrench[0].t.z + out.wrench[1].t.z;
            assert!(
                (tz - m_about_1).abs() < 1e-12 * m_about_1,
                "{tz} vs {m_about_1}"
            );
        }
    }

    /// Test 4c, no shear locking: pure bending of a straight element (nodes fixed, the
    /// sections turned by ∓τ about a₃ or a₂) produces no shear force at all — the
    /// one-point rule evaluates `e₁ × β` at the midpoint, where `β = 0`. (A two-point rule
    /// would see `β = ±τ/√3` at the Gauss points and a spurious shear force `≈ GA τ/√3`,
    /// stiffening bending by `GA ℓ²/(3 EI)`.) Tolerance: |N₂|, |N₃|, |N₁| < 1e-12 GA τ;
    /// the moment is `EI · 4 tan(τ/2)/ℓ` and the end forces vanish.
    #[test]
    fn pure_bending_has_no_spurious_shear() {
        let sec = section();
        let l = 0.9;
        for (n, ei) in [(Vector3::z(), sec.ei3), (Vector3::y(), sec.ei2)] {
            for tau in [1e-3, 1e-2, 0.2] {
                let q = axis_angle(&Vector3::new(0.3, -0.2, 0.9), 1.1);
                let a1 = rotate(&q, &Vector3::x());
                let x1 = Vector3::new(3.0, 1.0, 2.0);
                let mut st = ElementState::new(&[node(x1, q), node(x1 + l * a1, q)]).unwrap();
                let bent = [
                    node(x1, qmul(&q, &axis_angle(&n, -tau))),
                    node(x1 + l * a1, qmul(&q, &axis_angle(&n, tau))),
                ];
                let mut out = ElementForce::default();
                internal_force(&sec, &mut st, &bent, &mut out).unwrap();
                let tol = 1e-12 * sec.ga2 * tau;
                assert!(st.n.amax() < tol, "spurious N = {}", st.n);
                let m = ei * 4.0 * (0.5 * tau).tan() / l;
                assert!((st.m - m * n).amax() < 1e-12 * m, "M = {}", st.m);
                assert!(out.wrench[0].f.amax() < tol && out.wrench[1].f.amax() < tol);
            }
        }
    }

    /// The lumped mass is half the element each, ρ once: two nodes together carry
    /// `ρA ℓ` and `ρJ ℓ`; the bending rotary inertias come from `ρA EI_k/EA`.
    #[test]
    fn lumped_mass_is_half_the_element() {
        let sec = section();
        let lm = lumped_mass(&sec, 2.0);
        assert_eq!(lm.m, 1.2);
        assert_eq!(lm.j.x, 6.0e-4);
        assert!((lm.j.y - 1.2 * 1.4e4 / 2.8e7).abs() < 1e-18);
        assert!((lm.j.z - 1.2 * 2.1e4 / 2.8e7).abs() < 1e-18);
    }

    /// `from_scene` names the first bad property; degenerate geometry is an error that
    /// leaves the state unchanged.
    #[test]
    fn errors_are_clear() {
        let mut s = Section {
            ea: 1.0,
            ga2: 1.0,
            ga3: 1.0,
            ei2: 1.0,
            ei3: 1.0,
            gj: 0.0,
            rho_a: 1.0,
            rho_i: 1.0,
        };
        assert_eq!(
            BeamSection::from_scene(&s),
            Err(BeamError::NonPositive {
                what: "GJ",
                value: 0.0
            })
        );
        s.gj = 1.0;
        s.rho_a = f64::NAN;
        assert!(matches!(
            BeamSection::from_scene(&s),
            Err(BeamError::NonPositive { what: "rhoA", .. })
        ));
        let q = Quaternion::identity();
        let e = [node(Vector3::zeros(), q), node(Vector3::x(), q)];
        assert_eq!(
            ElementState::new(&[e[0], node(Vector3::zeros(), q)]),
            Err(BeamError::ZeroLength { length: 0.0 })
        );
        // Chord along node 1's b₃: no convected frame.
        assert_eq!(
            ElementState::new(&[e[0], node(Vector3::z(), q)]),
            Err(BeamError::DegenerateFrame)
        );
        let sec = section();
        let mut st = ElementState::new(&e).unwrap();
        let keep = st;
        let flipped = [
            e[0],
            node(
                Vector3::x(),
                axis_angle(&Vector3::x(), std::f64::consts::PI),
            ),
        ];
        let mut out = ElementForce::default();
        assert_eq!(
            internal_force(&sec, &mut st, &flipped, &mut out),
            Err(BeamError::RotationIncrement { node: 2 })
        );
        assert_eq!(st, keep);
    }
}
