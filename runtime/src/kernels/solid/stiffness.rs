//! The small-strain element stiffness `K_e` at the reference configuration, formed column
//! by column from [`respond`] with unit displacements.
//!
//! The small-strain response is linear in the displacements (and the viscous hourglass
//! form, at zero velocity, adds nothing), so column `j` of `K_e` is exactly the internal
//! force of the unit displacement of dof `j`: no finite differences. It includes the B-bar
//! option and the hourglass *stiffness* of one-point elements. Used by the element bound of
//! the explicit step ([`super::max_frequency`]) and by the assembled global stiffness of the
//! implicit analyses (`analysis/mesh_stiffness.rs`).

use super::{respond, Elastic, ElementOptions, ElementResponse, Kinematics, MAX_NODES};
use crate::contract::scene::ElementKind;

/// Largest number of degrees of freedom of an element (hex8: 8 nodes × 3).
pub const MAX_DOFS: usize = 24;

/// A dense element stiffness: entry `[r][c]`, dof `a·d + i` for node `a`, component `i`
/// (`d` = [`ElementKind::dim`]), only the leading `kind.nodes() · d` block used.
pub type ElementMatrix = [[f64; MAX_DOFS]; MAX_DOFS];

/// The small-strain stiffness of one element at its reference coordinates `x0` (at least
/// `kind.nodes()` rows), whatever the kinematics in `opts` (the tangent at the reference
/// configuration is the small-strain one for both measures). Symmetrized against
/// round-off. No heap allocation.
#[allow(clippy::needless_range_loop)] // index loops mirror the index notation
pub fn element_stiffness(
    kind: ElementKind,
    opts: &ElementOptions,
    mat: &Elastic,
    x0: &[[f64; 3]],
) -> ElementMatrix {
    let (n, d) = (kind.nodes(), kind.dim());
    let lin = ElementOptions {
        kinematics: Kinematics::SmallStrain,
        ..*opts
    };
    let zero = [[0.0; 3]; MAX_NODES];
    let mut u = zero;
    let mut out = ElementResponse::default();
    let mut k = [[0.0; MAX_DOFS]; MAX_DOFS];
    for a in 0..n {
        for i in 0..d {
            u[a][i] = 1.0;
            respond(kind, &lin, mat, x0, &u[..n], &zero[..n], &mut out);
            u[a][i] = 0.0;
            let col = a * d + i;
            for b in 0..n {
                for j in 0..d {
                    k[b * d + j][col] = out.f[b][j];
                }
            }
        }
    }
    let dofs = n * d;
    for r in 0..dofs {
        for c in r + 1..dofs {
            let s = 0.5 * (k[r][c] + k[c][r]);
            k[r][c] = s;
            k[c][r] = s;
        }
    }
    k
}
