//! Reference-shape check: the smallest Jacobian determinant of the isoparametric map from
//! the parent element, refused when ≤ 0.
//!
//! What is checked: bar2 `L/2`; tri3 `2A` and tet4 `6V` (constant); quad4 the four corners
//! (det J is bilinear, so its minimum over the element is at a corner); hex8 the 8 corners,
//! the 8 Gauss points and the centroid. 2-D elements use x, y only, so a clockwise element
//! has a negative determinant and is refused. `Degenerate::corner` is the node where the
//! minimum was found (for a hex8 Gauss point, the node nearest to it; 0 for constant
//! Jacobians).

use super::{bar2, hex8, quad4, tet4, tri3, Degenerate};
use crate::contract::scene::ElementKind;

/// `(min, corner)` over `d`, corner `i % modulo`.
fn smallest(d: &[f64], modulo: usize) -> (f64, usize) {
    let mut best = (f64::INFINITY, 0);
    for (i, &x) in d.iter().enumerate() {
        // NaN counts as the smallest (it is refused).
        if x.is_nan() || x < best.0 {
            best = (x, i % modulo);
        }
    }
    best
}

/// See the module doc.
pub(super) fn shape_check(kind: ElementKind, x0: &[[f64; 3]]) -> Result<f64, Degenerate> {
    let (min_jacobian, corner) = match kind {
        ElementKind::Bar2 => (0.5 * bar2::length(super::nodes(x0)), 0),
        ElementKind::Tri3PlaneStress | ElementKind::Tri3PlaneStrain => {
            (tri3::jacobian(super::nodes(x0)), 0)
        }
        ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain => {
            smallest(&quad4::corner_jacobians(super::nodes(x0)), 4)
        }
        ElementKind::Tet4 => (tet4::jacobian(super::nodes(x0)), 0),
        ElementKind::Hex8 => smallest(&hex8::jacobians(super::nodes(x0)), 8),
    };
    if min_jacobian > 0.0 {
        // NaN fails this test and is refused.
        Ok(min_jacobian)
    } else {
        Err(Degenerate {
            min_jacobian,
            corner,
        })
    }
}
