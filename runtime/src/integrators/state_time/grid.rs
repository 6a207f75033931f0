//! The time grid of one window, shared by the planar and the spatial window: the
//! numbering of unknowns and equations (time-major, so that the Jacobian is banded) and the
//! Gauss tables of the element integrals.
//!
//! A window of `E` elements has `2E + 1` quadratic nodes (node `j` at `t₀ + j·h/2`) and
//! `E + 1` force nodes (node `n` at `t₀ + n·h`, which is quadratic node `2n`). The bodies'
//! unknowns live at nodes `1 … 2E` (node 0 is the known start), their equations at the test
//! nodes `0 … 2E − 1` (the last node's test function is dropped, reading "D" of notes F
//! §1.10); the joints' force unknowns and constraint equations at every force node. Both
//! are numbered node by node: a force node's block before the quadratic node's.

use super::shape::{dpsi, phi, psi, GAUSS6};

/// Gauss points per element.
pub const NG: usize = GAUSS6.len();

/// The numbering and quadrature of one window.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Elements.
    pub elements: usize,
    /// Element length, s.
    pub h: f64,
    /// Start time, s.
    pub t0: f64,
    /// Offset of quadratic node `j`'s body unknowns (unused for `j = 0`).
    pub kin_off: Vec<usize>,
    /// Offset of force node `n`'s unknowns.
    pub frc_off: Vec<usize>,
    /// Row of test node `j`'s body equations (`j < 2E`).
    pub kin_row: Vec<usize>,
    /// Row of force node `n`'s constraint equations.
    pub frc_row: Vec<usize>,
    /// Number of unknowns (= equations).
    pub unknowns: usize,
    /// `ψ` at the Gauss points.
    pub tp: [[f64; 3]; NG],
    /// `ψ̇` at the Gauss points (per second).
    pub td: [[f64; 3]; NG],
    /// `φ` at the Gauss points.
    pub tf: [[f64; 2]; NG],
    /// Gauss weights times `h`.
    pub tw: [f64; NG],
}

impl Grid {
    /// The grid of `elements` elements of length `h` from `t0`, with `per_node` body
    /// unknowns per quadratic node and `per_force_node` joint unknowns per force node.
    pub fn new(elements: usize, h: f64, t0: f64, per_node: usize, per_force_node: usize) -> Grid {
        let e = elements;
        let (mut kin_off, mut frc_off) = (vec![0; 2 * e + 1], vec![0; e + 1]);
        let (mut kin_row, mut frc_row) = (vec![0; 2 * e], vec![0; e + 1]);
        let (mut off, mut row) = (0, 0);
        for j in 0..=2 * e {
            if j % 2 == 0 {
                frc_off[j / 2] = off;
                off += per_force_node;
                frc_row[j / 2] = row;
                row += per_force_node;
            }
            if j >= 1 {
                kin_off[j] = off;
                off += per_node;
            }
            if j < 2 * e {
                kin_row[j] = row;
                row += per_node;
            }
        }
        debug_assert_eq!(off, row);
        let mut tp = [[0.0; 3]; NG];
        let mut td = [[0.0; 3]; NG];
        let mut tf = [[0.0; 2]; NG];
        let mut tw = [0.0; NG];
        for (g, &(t, w)) in GAUSS6.iter().enumerate() {
            tp[g] = psi(t);
            td[g] = dpsi(t).map(|d| d / h);
            tf[g] = phi(t);
            tw[g] = w * h;
        }
        Grid {
            elements,
            h,
            t0,
            kin_off,
            frc_off,
            kin_row,
            frc_row,
            unknowns: off,
            tp,
            td,
            tf,
            tw,
        }
    }

    /// The loads of `bodies` bodies at every Gauss point of the window, from
    /// `load(t, out)`, at `[(e·NG + g)·bodies + b]`.
    pub fn sample<T: Clone + Default>(
        &self,
        bodies: usize,
        mut load: impl FnMut(f64, &mut [T]),
    ) -> Vec<T> {
        let mut out = vec![T::default(); self.elements * NG * bodies];
        for el in 0..self.elements {
            for (g, &(t, _)) in GAUSS6.iter().enumerate() {
                let at = (el * NG + g) * bodies;
                load(
                    self.t0 + (el as f64 + t) * self.h,
                    &mut out[at..at + bodies],
                );
            }
        }
        out
    }
}
