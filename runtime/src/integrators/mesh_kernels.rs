//! The element evaluation of the meshes' blocks, chosen once before a run: one loop per
//! block, generic over the block's [`ElementKernel`] and monomorphized per kernel
//! ([`elastic_block`], [`plastic_block`]), so that a loop holds one element type's kernel,
//! which the compiler can inline (and vectorize), and no `match` on the kind runs per
//! element.
//!
//! [`BlockKernels`] is the table of those loops, one [`BlockKernel`] per block of a
//! [`MeshLayout`], in block order. The interpreter's table is built at run time by a
//! `match` over every kind ([`BlockKernels::interpreted`]); generated code writes its own,
//! naming only the kernels its blocks use (`BlockKernel::elastic::<Hex8>()`), and hands it
//! to the integrators through [`System::mesh_kernels`](crate::contract::system::System).
//! That hook is typed `Any` because the table lives here and not in the contract floor
//! below: a [`BlockFn`] takes [`BlockArgs`], which holds this floor's `Assembler` and
//! `BlockEval` (the solid kernels' `ElementOptions`, `Elastic`, `Plastic`) and the kernels'
//! `PlasticResponse` outputs, and the contract may name nothing outside itself; the
//! constructors [`BlockKernel::elastic`] and [`BlockKernel::plastic`] name the loops below.
//!
//! The loops run their elements through the [`Assembler`] (which decides order and
//! threads) and evaluate each with the same per-type kernels as
//! [`crate::kernels::solid::respond`] and [`crate::kernels::solid::respond_plastic`]: the
//! results are bitwise the same whichever table runs, for every assembly strategy and
//! thread count.

use std::borrow::Cow;

use super::mesh_assembly::{Assembler, Runs};
use crate::analysis::mesh_model::options;
use crate::contract::mesh_layout::{ElementBlock, MeshLayout};
use crate::contract::scene::ElementKind;
use crate::kernels::solid::{
    reduced, with_kernel, Elastic, ElementKernel, ElementOptions, ElementResponse, Plastic,
    PlasticPoints, PlasticResponse, MAX_NODES,
};

/// One block's evaluation constants.
pub(super) struct BlockEval {
    pub(super) opts: ElementOptions,
    pub(super) mat: Elastic,
    /// The plastic constants (`None`: an elastic block).
    pub(super) plastic: Option<Plastic>,
    /// Integration points per element.
    pub(super) points: usize,
}

/// What one element leaves for the reductions.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct ElementScalars {
    pub(super) strain_energy: f64,
    pub(super) hourglass_energy: f64,
    pub(super) hourglass_power: f64,
    pub(super) min_jacobian: f64,
}

impl ElementScalars {
    #[inline]
    fn of(r: &ElementResponse) -> ElementScalars {
        ElementScalars {
            strain_energy: r.strain_energy,
            hourglass_energy: r.hourglass_energy,
            hourglass_power: r.hourglass_power,
            min_jacobian: r.min_jacobian,
        }
    }
}

/// The per-element outputs of one block: stress, strain, scalars.
pub(super) type BlockOut<'a> = (
    &'a mut [[f64; 6]],
    &'a mut [[f64; 6]],
    &'a mut [ElementScalars],
);

/// The plastic state of one block's integration points (plastic strain, equivalent plastic
/// strain, stress; point after point) and its elements' plastic means and work.
pub(super) type PlasticOut<'a> = (
    &'a mut [[f64; 6]],
    &'a mut [f64],
    &'a mut [[f64; 6]],
    &'a mut [PlasticResponse],
);

/// What a block loop is handed by the mesh integrator: the assembler, the block, its
/// constants, the nodal displacements and velocities, and the block's outputs (and, for a
/// plastic block, its points' state). Opaque: only the integrator builds one.
pub struct BlockArgs<'a> {
    pub(super) assembly: &'a mut Assembler,
    pub(super) layout: &'a MeshLayout,
    pub(super) block: usize,
    pub(super) eval: &'a BlockEval,
    pub(super) u: &'a [[f64; 3]],
    pub(super) v: &'a [[f64; 3]],
    pub(super) out: BlockOut<'a>,
    /// `Some` for a plastic block.
    pub(super) plastic: Option<PlasticOut<'a>>,
}

/// A block loop: [`elastic_block`] or [`plastic_block`] for one kernel.
pub type BlockFn = fn(BlockArgs<'_>);

/// One block's loop and what it is for (checked against the block before a run).
#[derive(Clone, Copy, Debug)]
pub struct BlockKernel {
    /// The element kind the loop evaluates.
    pub kind: ElementKind,
    /// Whether it is the one-point variant of the kind's kernel (hex8, quad4).
    pub reduced: bool,
    /// Whether it is the elastoplastic loop.
    pub plastic: bool,
    /// The loop.
    pub run: BlockFn,
}

impl BlockKernel {
    /// The elastic loop of kernel `K`: [`elastic_block::<K>`](elastic_block).
    pub const fn elastic<K: ElementKernel>() -> BlockKernel {
        BlockKernel {
            kind: K::KIND,
            reduced: K::REDUCED,
            plastic: false,
            run: elastic_block::<K>,
        }
    }

    /// The elastoplastic loop of kernel `K`: [`plastic_block::<K>`](plastic_block).
    pub const fn plastic<K: ElementKernel>() -> BlockKernel {
        BlockKernel {
            kind: K::KIND,
            reduced: K::REDUCED,
            plastic: true,
            run: plastic_block::<K>,
        }
    }

    /// The loop of a block of `kind` (its one-point variant when `reduced`), elastoplastic
    /// or not, chosen at run time.
    pub fn of(kind: ElementKind, reduced: bool, plastic: bool) -> BlockKernel {
        with_kernel!(kind, reduced, K => if plastic {
            BlockKernel::plastic::<K>()
        } else {
            BlockKernel::elastic::<K>()
        })
    }
}

/// The element loops of a mesh layout's blocks, in block order.
#[derive(Clone, Debug)]
pub struct BlockKernels(Cow<'static, [BlockKernel]>);

impl BlockKernels {
    /// A table written in code (generated code's `static`).
    pub const fn new(blocks: &'static [BlockKernel]) -> BlockKernels {
        BlockKernels(Cow::Borrowed(blocks))
    }

    /// The interpreter's table: each block's loop chosen from its kind, quadrature and
    /// material.
    pub fn interpreted(layout: &MeshLayout) -> BlockKernels {
        BlockKernels(Cow::Owned(
            layout
                .blocks
                .iter()
                .map(|b| BlockKernel::of(b.kind, block_reduced(b), b.material.plastic.is_some()))
                .collect(),
        ))
    }

    /// The loops, block after block.
    pub fn blocks(&self) -> &[BlockKernel] {
        &self.0
    }

    /// Why the table does not fit `layout` (another number of blocks, or a block's kind or
    /// material), `None` when it does.
    pub fn mismatch(&self, layout: &MeshLayout) -> Option<String> {
        if self.0.len() != layout.blocks.len() {
            return Some(format!(
                "the element kernels are for {} mesh blocks, the scene has {}",
                self.0.len(),
                layout.blocks.len()
            ));
        }
        self.0.iter().zip(&layout.blocks).find_map(|(k, b)| {
            let (reduced, plastic) = (block_reduced(b), b.material.plastic.is_some());
            let what = |reduced: bool, plastic: bool| {
                format!(
                    "{}{}",
                    if reduced { " one-point" } else { "" },
                    if plastic { " plastic" } else { "" }
                )
            };
            (k.kind != b.kind || k.reduced != reduced || k.plastic != plastic).then(|| {
                format!(
                    "mesh '{}': the element kernel is for{} {:?} elements, the mesh has{} {:?}",
                    b.name,
                    what(k.reduced, k.plastic),
                    k.kind,
                    what(reduced, plastic),
                    b.kind,
                )
            })
        })
    }
}

/// Whether a block runs the one-point variant of its kind's kernel
/// ([`crate::kernels::solid::reduced`]).
pub fn block_reduced(b: &ElementBlock) -> bool {
    reduced(b.kind, &options(b).integration)
}

/// One vector per node of an element (first `K::NODES` rows used).
type NodeRows = [[f64; 3]; MAX_NODES];

/// The reference coordinates, displacements and velocities of element `e`'s nodes.
#[inline(always)]
fn gather<K: ElementKernel>(
    l: &MeshLayout,
    b: &ElementBlock,
    e: usize,
    u: &[[f64; 3]],
    v: &[[f64; 3]],
) -> (NodeRows, NodeRows, NodeRows) {
    let mut x0 = [[0.0; 3]; MAX_NODES];
    let mut ue = [[0.0; 3]; MAX_NODES];
    let mut ve = [[0.0; 3]; MAX_NODES];
    let conn = &b.conn[e * K::NODES..(e + 1) * K::NODES];
    for (a, &g) in conn.iter().enumerate() {
        x0[a] = l.x0[g as usize];
        ue[a] = u[g as usize];
        ve[a] = v[g as usize];
    }
    (x0, ue, ve)
}

/// The element loop of an elastic block of kernel `K`: every element gathers its nodes,
/// evaluates `K::respond` and leaves its forces to the assembler and its stress, strain and
/// scalars in the block's outputs.
pub fn elastic_block<K: ElementKernel>(args: BlockArgs<'_>) {
    let BlockArgs {
        assembly,
        layout: l,
        block: bi,
        eval: ev,
        u,
        v,
        out,
        ..
    } = args;
    let b = &l.blocks[bi];
    debug_assert_eq!(b.kind, K::KIND);
    assembly.elements(l, bi, out, |e, fs, (st, sn, sc)| {
        let (x0, ue, ve) = gather::<K>(l, b, e, u, v);
        let mut r = ElementResponse::default();
        K::respond(&ev.opts, &ev.mat, &x0, &ue, &ve, &mut r);
        fs.copy_from_slice(&r.f[..K::NODES]);
        *st = r.stress;
        *sn = r.strain;
        *sc = ElementScalars::of(&r);
    });
}

/// The element loop of an elastoplastic block of kernel `K`: every element evaluates
/// `K::respond_plastic` with its points' run of the block's plastic state (updated in
/// place) and leaves its plastic means and work beside its other outputs; the assembler
/// runs the elements and sums their forces as for an elastic block. Each element writes
/// only its own outputs and state, so results do not depend on the strategy or the number
/// of threads.
///
/// # Panics
/// When handed an elastic block (the table and the layout disagree; checked before a run).
pub fn plastic_block<K: ElementKernel>(args: BlockArgs<'_>) {
    let BlockArgs {
        assembly,
        layout: l,
        block: bi,
        eval: ev,
        u,
        v,
        out: (stress, strain, scalars),
        plastic,
    } = args;
    let b = &l.blocks[bi];
    debug_assert_eq!(b.kind, K::KIND);
    let (Some(law), Some((ep_all, eq_all, s_all, pout))) = (&ev.plastic, plastic) else {
        panic!(
            "mesh '{}': the plastic element loop on an elastic block",
            b.name
        );
    };
    let np = ev.points;
    let cols = (
        stress,
        strain,
        scalars,
        pout,
        Runs::new(ep_all, np),
        Runs::new(eq_all, np),
        Runs::new(s_all, np),
    );
    assembly.elements(l, bi, cols, |e, fs, (st, sn, sc, po, pst, peq, pss)| {
        let (x0, ue, ve) = gather::<K>(l, b, e, u, v);
        let mut r = ElementResponse::default();
        let points = PlasticPoints {
            strain: pst,
            equivalent: peq,
            stress: pss,
        };
        *po = K::respond_plastic(&ev.opts, &ev.mat, law, &x0, &ue, &ve, points, &mut r);
        fs.copy_from_slice(&r.f[..K::NODES]);
        *st = r.stress;
        *sn = r.strain;
        *sc = ElementScalars::of(&r);
    });
}
