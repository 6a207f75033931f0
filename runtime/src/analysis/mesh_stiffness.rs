//! The assembled linear stiffness of a system's meshes, for the implicit analyses
//! (`simulate { mesh_method newmark | static }`, docs/methods.md "Meshes: implicit
//! analyses").
//!
//! - Degrees of freedom: three per node, global dof `3 n + i` (node `n`, component `i`); a
//!   2-D element's stiffness covers its nodes' x and y (their z is fixed). The fixed and
//!   prescribed components ([`MeshLayout::constrained`]) are eliminated
//!   ([`SymmetricAssembly`]): prescribed values move to the right-hand side through the
//!   constrained rows, which also give the reactions.
//! - Element stiffness: [`solid::element_stiffness`], the small-strain `K_e` at the
//!   reference configuration (with B-bar and the hourglass stiffness of one-point
//!   elements). Foundation springs add `k n nᵀ` at their node.
//! - Refused ([`linear_refusal`]): what a linear stiffness cannot represent — plastic
//!   materials (the stiffness changes with the plastic flow), `strain green` (large
//!   rotations: the stiffness changes with the configuration), viscous hourglass control
//!   (a damping, not a stiffness: the hourglass modes would have none) and ties to bodies
//!   (the coupling with the rigid integrators is explicit).
//!
//! The assembly is built once before a run; the same pattern serves every factorization.

use super::mesh_model::{elastic, element_place, element_x0, options, MeshError};
use crate::contract::mesh_layout::{ElementBlock, MeshLayout};
use crate::contract::scene::{HourglassControl, MeshIntegration, MeshKinematics, MeshMethod};
use crate::kernels::solid;
use crate::linalg::{ElementDofs, SymmetricAssembly};

/// The assembled stiffness: pattern and scatter, and the values of the free–free block
/// and of the constrained rows.
#[derive(Clone, Debug)]
pub struct MeshStiffness {
    /// Pattern, scatter and the constrained dofs.
    pub assembly: SymmetricAssembly,
    /// `K_ff` values (upper triangle, aligned with the pattern).
    pub free: Vec<f64>,
    /// The constrained rows' values `[K_cf K_cc]`.
    pub constrained: Vec<f64>,
}

/// Why the meshes of `l` cannot be analysed with the linear stiffness of `method` (`None`:
/// they can). The reason names the mesh and says what to change.
pub fn linear_refusal(l: &MeshLayout, method: MeshMethod) -> Option<MeshError> {
    let name = method.name();
    for b in &l.blocks {
        let err = |reason: String| {
            Some(MeshError {
                mesh: b.name.clone(),
                reason,
            })
        };
        if b.material.plastic.is_some() {
            return err(format!(
                "`mesh_method {name}` solves with the linear elastic stiffness, and this mesh's material is plastic (its stiffness changes as it yields); use `mesh_method central_difference`, or an elastic material"
            ));
        }
        if b.formulation.kinematics == MeshKinematics::Green {
            return err(format!(
                "`mesh_method {name}` solves with the small-strain stiffness, and this mesh has `strain green` (large rotations: its stiffness changes with the configuration); use `strain small`, or `mesh_method central_difference`"
            ));
        }
        if let MeshIntegration::Reduced {
            hourglass: HourglassControl::Viscous { .. },
        } = b.formulation.integration
        {
            return err(format!(
                "`mesh_method {name}` needs a stiffness against the hourglass modes of one-point elements, and viscous hourglass control has none; use `hourglass stiffness(0.05)` or `integration full`"
            ));
        }
    }
    if let Some(t) = l.ties.first() {
        return Some(MeshError {
            mesh: t.mesh.clone(),
            reason: format!(
                "set '{}' is tied to a body, and `mesh_method {name}` does not couple meshes to bodies; use `mesh_method central_difference`",
                t.set
            ),
        });
    }
    None
}

/// Assemble the linear stiffness of the meshes of `l`.
///
/// # Errors
/// A non-finite element stiffness (the element named), a layout too large for the pattern.
pub fn assemble(l: &MeshLayout) -> Result<MeshStiffness, MeshError> {
    let n = l.nodes();
    let first = || {
        l.blocks
            .first()
            .map_or_else(String::new, |b| b.name.clone())
    };
    let constrained: Vec<bool> = l.constrained.iter().flatten().copied().collect();
    let dof_lists: Vec<(Vec<u32>, usize)> = l
        .blocks
        .iter()
        .map(|b| {
            let d = b.kind.dim();
            let dofs = b
                .conn
                .iter()
                .flat_map(|&node| (0..d as u32).map(move |i| 3 * node + i))
                .collect();
            (dofs, b.kind.nodes() * d)
        })
        .chain(std::iter::once((
            l.foundation
                .iter()
                .flat_map(|s| (0..3).map(move |i| 3 * s.node + i))
                .collect(),
            3,
        )))
        .collect();
    let blocks: Vec<ElementDofs<'_>> = dof_lists
        .iter()
        .map(|(dofs, per_element)| ElementDofs {
            dofs,
            per_element: *per_element,
        })
        .collect();
    let assembly = SymmetricAssembly::new(3 * n, &constrained, &blocks).map_err(|e| MeshError {
        mesh: first(),
        reason: format!("the stiffness pattern: {e}"),
    })?;
    let mut free = vec![0.0; assembly.nnz_free()];
    let mut cons = vec![0.0; assembly.nnz_constrained()];
    for (bi, b) in l.blocks.iter().enumerate() {
        for e in 0..b.elements() {
            let k = element_stiffness(l, b, e)?;
            assembly.add_element(bi, e, |r, c| k[r][c], &mut free, &mut cons);
        }
    }
    let fb = l.blocks.len();
    for (i, s) in l.foundation.iter().enumerate() {
        assembly.add_element(fb, i, |r, c| s.k * s.n[r] * s.n[c], &mut free, &mut cons);
    }
    Ok(MeshStiffness {
        assembly,
        free,
        constrained: cons,
    })
}

/// The small-strain stiffness of element `e` of block `b` at its reference shape.
///
/// # Errors
/// A non-finite entry, naming the element and its place.
pub fn element_stiffness(
    l: &MeshLayout,
    b: &ElementBlock,
    e: usize,
) -> Result<solid::ElementMatrix, MeshError> {
    let x0 = element_x0(l, b, e);
    let k = solid::element_stiffness(b.kind, &options(b), &elastic(&b.material), &x0);
    let d = b.kind.nodes() * b.kind.dim();
    if k[..d]
        .iter()
        .any(|row| row[..d].iter().any(|v| !v.is_finite()))
    {
        return Err(MeshError {
            mesh: b.name.clone(),
            reason: format!(
                "{}: the element stiffness is not finite",
                element_place(l, b, e)
            ),
        });
    }
    Ok(k)
}
