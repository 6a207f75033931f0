//! Race-free assembly of the meshes' element forces into nodal forces (notes D §6.3): the
//! three strategies of [`Assembly`] run over the plans of
//! [`crate::contract::mesh_plan`], with no allocation in a step and no `unsafe`.
//!
//! The integrator drives one step's assembly as [`Assembler::begin`], then
//! [`Assembler::elements`] once per element block (the assembler decides which elements
//! run in which order on which thread, and calls the integrator's element evaluation for
//! each), then [`Assembler::finish`], which leaves the accelerations and the reactions.
//!
//! | strategy | element pass | node pass |
//! |---|---|---|
//! | gather | parallel over runs of elements, each writing its own slots | parallel over nodes, each summing its slots in the canonical order |
//! | colouring | colour after colour, parallel over runs of the colour's groups, subtracting from the nodal sums | the nodal sums to accelerations |
//! | partitions | parallel over the partitions, each in the canonical order: interior nodes directly, interface nodes into interface slots | interface nodes sum their slots in the canonical order; then as colouring |
//!
//! Every strategy computes a node's force as `(f_ext + f_found) − f_e₁ − f_e₂ − …` in the
//! same canonical order, so the results are bitwise the same across strategies and thread
//! counts. Colouring and partitions write the shared nodal sums through relaxed atomic loads
//! and stores ([`Sum3`]): the plans guarantee one writer per node at a time (node-disjoint
//! colour groups; a node interior to one partition), so these are plain moves, and a plan
//! that broke the guarantee could give wrong sums but never undefined behaviour. Rayon's
//! `join` orders the colours.

use std::marker::PhantomData;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

use rayon::prelude::*;

use crate::contract::mesh_layout::MeshLayout;
use crate::contract::mesh_plan::{Assembly, INTERFACE};
use crate::contract::ranks::Ranks;
use crate::kernels::solid::MAX_NODES;

/// Elements (of a block) or nodes below which a pass runs on the calling thread.
pub const PARALLEL_ELEMENTS: usize = 2048;
/// Elements per parallel task of the gather's element pass.
const ELEMENT_GRAIN: usize = 256;
/// Elements scanned per parallel task of one colour (about `1/colours` of them evaluate).
const COLOUR_GRAIN: usize = 1024;
/// Nodes per parallel task of the node passes.
const NODE_GRAIN: usize = 512;

/// What one element's entry of a per-element array is: [`One`] value or a [`Run`] of them.
pub trait RowType {
    /// One element's entry, borrowed for `'r`.
    type Row<'r>;
}

/// One value per element (its stress, its scalars, …).
pub struct One<T>(PhantomData<T>);

impl<T: Send + 'static> RowType for One<T> {
    type Row<'r> = &'r mut T;
}

/// A run of values per element (the state of each of its integration points).
pub struct Run<T>(PhantomData<T>);

impl<T: Send + 'static> RowType for Run<T> {
    type Row<'r> = &'r mut [T];
}

/// One per-element array of a block: a mutable slice (one value per element) or [`Runs`]
/// (`per` values per element), which the assembler splits between threads.
pub trait Column: Send + Sized {
    /// What an element's entry is.
    type Type: RowType;
    /// The same array reborrowed for `'b`.
    type View<'b>: Column<Type = Self::Type>
    where
        Self: 'b;
    /// Number of elements.
    fn len(&self) -> usize;
    /// Whether there is no element.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Split at element `mid`.
    fn split_at(self, mid: usize) -> (Self, Self);
    /// Element `i`'s entry.
    fn row(&mut self, i: usize) -> <Self::Type as RowType>::Row<'_>;
    /// Reborrow.
    fn view(&mut self) -> Self::View<'_>;
}

impl<T: Send + 'static> Column for &mut [T] {
    type Type = One<T>;
    type View<'b>
        = &'b mut [T]
    where
        Self: 'b;
    fn len(&self) -> usize {
        <[T]>::len(self)
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        self.split_at_mut(mid)
    }
    fn row(&mut self, i: usize) -> &mut T {
        &mut self[i]
    }
    fn view(&mut self) -> Self::View<'_> {
        self
    }
}

/// An array of `per` consecutive values per element (integration points' state).
pub struct Runs<'s, T> {
    data: &'s mut [T],
    per: usize,
}

impl<'s, T> Runs<'s, T> {
    /// `data` cut into runs of `per` (≥ 1) values, one run per element.
    pub fn new(data: &'s mut [T], per: usize) -> Self {
        debug_assert!(per > 0 && data.len().is_multiple_of(per));
        Runs { data, per }
    }
}

impl<T: Send + 'static> Column for Runs<'_, T> {
    type Type = Run<T>;
    type View<'b>
        = Runs<'b, T>
    where
        Self: 'b;
    fn len(&self) -> usize {
        self.data.len() / self.per
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (a, b) = self.data.split_at_mut(mid * self.per);
        (
            Runs {
                data: a,
                per: self.per,
            },
            Runs {
                data: b,
                per: self.per,
            },
        )
    }
    fn row(&mut self, i: usize) -> &mut [T] {
        &mut self.data[i * self.per..(i + 1) * self.per]
    }
    fn view(&mut self) -> Self::View<'_> {
        Runs {
            data: &mut *self.data,
            per: self.per,
        }
    }
}

/// The entry types of a tuple of per-element arrays.
pub trait RowTypes {
    /// One element's entries: `(&mut A, &mut [B], …)`.
    type Row<'r>;
}

/// Per-element arrays of one block (stress, strain, scalars, state, …), as a tuple of
/// equally long [`Column`]s: the assembler splits them between threads and hands the
/// element evaluation one element's row at a time.
pub trait Columns: Send + Sized {
    /// The arrays' entry types.
    type Types: RowTypes;
    /// The same arrays reborrowed for `'b`.
    type View<'b>: Columns<Types = Self::Types>
    where
        Self: 'b;
    /// Number of elements.
    fn len(&self) -> usize;
    /// Whether there is no element.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Split at element `mid`.
    fn split_at(self, mid: usize) -> (Self, Self);
    /// Element `i`'s row.
    fn row(&mut self, i: usize) -> <Self::Types as RowTypes>::Row<'_>;
    /// Reborrow (to run several passes over the same arrays).
    fn view(&mut self) -> Self::View<'_>;
}

macro_rules! columns {
    ($($t:ident $i:tt),+) => {
        impl<$($t: RowType),+> RowTypes for ($($t,)+) {
            type Row<'r> = ($($t::Row<'r>,)+);
        }
        impl<$($t: Column),+> Columns for ($($t,)+) {
            type Types = ($($t::Type,)+);
            type View<'b> = ($($t::View<'b>,)+) where Self: 'b;
            fn len(&self) -> usize {
                self.0.len()
            }
            fn split_at(self, mid: usize) -> (Self, Self) {
                #[allow(non_snake_case)]
                let ($($t,)+) = ($(self.$i.split_at(mid),)+);
                (($($t.0,)+), ($($t.1,)+))
            }
            fn row(&mut self, i: usize) -> <Self::Types as RowTypes>::Row<'_> {
                ($(self.$i.row(i),)+)
            }
            fn view(&mut self) -> Self::View<'_> {
                ($(self.$i.view(),)+)
            }
        }
    };
}
columns!(A 0);
columns!(A 0, B 1);
columns!(A 0, B 1, C 2);
columns!(A 0, B 1, C 2, D 3);
columns!(A 0, B 1, C 2, D 3, E 4);
columns!(A 0, B 1, C 2, D 3, E 4, F 5);
columns!(A 0, B 1, C 2, D 3, E 4, F 5, G 6);

/// The gather's element slots beside the caller's arrays: one more column, whose row is
/// the element's `nodes per element` slots.
struct WithSlots<'a, C> {
    cols: C,
    slots: &'a mut [[f64; 3]],
    npe: usize,
}

impl<C: Columns> WithSlots<'_, C> {
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (c0, c1) = self.cols.split_at(mid);
        let (s0, s1) = self.slots.split_at_mut(mid * self.npe);
        let npe = self.npe;
        (
            WithSlots {
                cols: c0,
                slots: s0,
                npe,
            },
            WithSlots {
                cols: c1,
                slots: s1,
                npe,
            },
        )
    }
}

/// A nodal force sum that threads share: three `f64` as bits, read and written with
/// relaxed atomic loads and stores (plain moves: the plans leave one writer at a time).
#[derive(Debug, Default)]
pub struct Sum3([AtomicU64; 3]);

impl Sum3 {
    fn get(&self) -> [f64; 3] {
        [0, 1, 2].map(|k| f64::from_bits(self.0[k].load(Relaxed)))
    }
    fn set(&self, f: [f64; 3]) {
        for (c, x) in self.0.iter().zip(f) {
            c.store(x.to_bits(), Relaxed);
        }
    }
    /// `self −= f`, component by component.
    fn sub(&self, f: &[f64; 3]) {
        for (c, x) in self.0.iter().zip(f) {
            c.store((f64::from_bits(c.load(Relaxed)) - x).to_bits(), Relaxed);
        }
    }
}

/// The assembly's buffers, sized once for the layout's strategy.
#[derive(Debug)]
pub struct Assembler {
    strategy: Assembly,
    /// Gather: one force per element node (`Σ nodes per element`).
    slots: Vec<[f64; 3]>,
    /// Colouring, partitions: every node's net force, `f_ext + f_found − Σ f_e`.
    net: Vec<Sum3>,
    /// Partitions: the forces at interface nodes, one per incidence.
    interface: Vec<Sum3>,
    /// A rank's part: the own slots' forces sent to the other ranks, flat.
    send: Vec<f64>,
    /// A rank's part: the ghost slots' forces received, flat.
    recv: Vec<f64>,
}

impl Assembler {
    /// Buffers for `l` and its strategy.
    pub fn new(l: &MeshLayout) -> Assembler {
        let strategy = l.assembly.strategy();
        let shared = |n: usize| (0..n).map(|_| Sum3::default()).collect();
        Assembler {
            strategy,
            slots: match strategy {
                Assembly::Gather => {
                    vec![[0.0; 3]; l.total_slots() + l.halo.as_ref().map_or(0, |h| h.ghost_slots)]
                }
                _ => Vec::new(),
            },
            net: match strategy {
                Assembly::Gather => Vec::new(),
                _ => shared(l.nodes()),
            },
            interface: match strategy {
                Assembly::Partitions => shared(l.assembly.interface_slots()),
                _ => Vec::new(),
            },
            send: l
                .halo
                .as_ref()
                .map_or_else(Vec::new, |h| vec![0.0; h.exchange.send_len()]),
            recv: l
                .halo
                .as_ref()
                .map_or_else(Vec::new, |h| vec![0.0; h.exchange.recv_len()]),
        }
    }

    /// A rank's part of a distributed run ([`MeshLayout::halo`]): send the own elements'
    /// forces at the interface nodes to the ranks that share those nodes, and fill the
    /// ghost slots with theirs. Between the element passes and [`Assembler::finish`]; every
    /// rank calls it every step. Nothing to do for a mesh in one process.
    pub fn exchange(&mut self, l: &MeshLayout, ranks: &dyn Ranks) {
        let Some(h) = &l.halo else {
            return;
        };
        debug_assert_eq!(
            self.strategy,
            Assembly::Gather,
            "a rank's part runs the gather"
        );
        for (out, &s) in self.send.chunks_exact_mut(3).zip(&h.send_slots) {
            out.copy_from_slice(&self.slots[s as usize]);
        }
        ranks.exchange(&h.exchange, &self.send, &mut self.recv);
        let ghosts = l.total_slots();
        for (slot, f) in self.slots[ghosts..]
            .iter_mut()
            .zip(self.recv.chunks_exact(3))
        {
            slot.copy_from_slice(f);
        }
    }

    /// The strategy these buffers run.
    pub fn strategy(&self) -> Assembly {
        self.strategy
    }

    /// Start a step's assembly: colouring and partitions set every nodal sum to
    /// `f_ext + f_found` (the gather starts from them in [`Assembler::finish`]).
    pub fn begin(&mut self, f_ext: &[[f64; 3]], f_found: &[[f64; 3]]) {
        if self.strategy == Assembly::Gather {
            return;
        }
        let start = |(s, (e, f)): (&Sum3, (&[f64; 3], &[f64; 3]))| {
            s.set([e[0] + f[0], e[1] + f[1], e[2] + f[2]]);
        };
        if self.net.len() >= PARALLEL_ELEMENTS {
            self.net
                .par_iter()
                .zip(f_ext.par_iter().zip(f_found))
                .with_min_len(NODE_GRAIN)
                .for_each(start);
        } else {
            self.net
                .iter()
                .zip(f_ext.iter().zip(f_found))
                .for_each(start);
        }
    }

    /// Evaluate every element of block `bi` with `eval(e, f, row)` (`e` in block numbering;
    /// `f`, of `nodes per element` entries, to be filled with the element's internal nodal
    /// forces; `row` the element's row of `cols`) and assemble the forces by the strategy.
    /// Each element is evaluated exactly once.
    pub fn elements<C, F>(&mut self, l: &MeshLayout, bi: usize, mut cols: C, eval: F)
    where
        C: Columns,
        F: Fn(usize, &mut [[f64; 3]], <C::Types as RowTypes>::Row<'_>) + Sync,
    {
        let b = &l.blocks[bi];
        let plan = &l.assembly.blocks[bi];
        let npe = b.kind.nodes();
        let ne = b.elements();
        debug_assert_eq!(cols.len(), ne);
        let parallel = ne >= PARALLEL_ELEMENTS;
        match self.strategy {
            Assembly::Gather => {
                let all = WithSlots {
                    cols,
                    slots: &mut self.slots[b.first_slot..b.first_slot + ne * npe],
                    npe,
                };
                let leaf = |offset: usize, mut w: WithSlots<'_, C>| {
                    for (i, fs) in w.slots.chunks_exact_mut(npe).enumerate() {
                        eval(offset + i, fs, w.cols.row(i));
                    }
                };
                if parallel {
                    split_runs(all, 0, ne, ELEMENT_GRAIN, 1, &WithSlots::split_at, &leaf);
                } else {
                    leaf(0, all);
                }
            }
            Assembly::Colouring => {
                let net = &self.net[..];
                let group = plan.group;
                for c in 0..plan.colours as u32 {
                    let leaf = |offset: usize, mut v: C::View<'_>| {
                        let end = offset + v.len();
                        let mut f = [[0.0; 3]; MAX_NODES];
                        for g in offset / group..end.div_ceil(group) {
                            if plan.group_colour[g] != c {
                                continue;
                            }
                            for e in g * group..((g + 1) * group).min(end) {
                                eval(e, &mut f[..npe], v.row(e - offset));
                                for (fa, &n) in f.iter().zip(b.element_nodes(e)) {
                                    net[n as usize].sub(fa);
                                }
                            }
                        }
                    };
                    let v = cols.view();
                    if parallel {
                        let grain = COLOUR_GRAIN.max(group);
                        split_runs(v, 0, ne, grain, group, &Columns::split_at, &leaf);
                    } else {
                        leaf(0, v);
                    }
                }
            }
            Assembly::Partitions => {
                let (net, interface) = (&self.net[..], &self.interface[..]);
                let leaf = |p: usize, offset: usize, mut v: C| {
                    let mut f = [[0.0; 3]; MAX_NODES];
                    let run = plan.parts[p] as usize..plan.parts[p + 1] as usize;
                    for &e in &plan.order[run] {
                        let e = e as usize;
                        eval(e, &mut f[..npe], v.row(e - offset));
                        for (fa, &t) in f.iter().zip(&plan.targets[e * npe..(e + 1) * npe]) {
                            if t & INTERFACE == 0 {
                                net[t as usize].sub(fa);
                            } else {
                                interface[(t & !INTERFACE) as usize].set(*fa);
                            }
                        }
                    }
                };
                split_parts(cols, &plan.parts, 0, &leaf);
            }
        }
    }

    /// Finish the step's assembly: every node's net force `f_ext + f_found − Σ f_e` (in the
    /// canonical order), then the accelerations `a = f / m` of the free components and the
    /// reactions `m a − f` of the constrained ones (whose `a` is prescribed).
    pub fn finish(
        &mut self,
        l: &MeshLayout,
        f_ext: &[[f64; 3]],
        f_found: &[[f64; 3]],
        a: &mut [[f64; 3]],
        reaction: &mut [[f64; 3]],
    ) {
        let parallel = l.nodes() >= PARALLEL_ELEMENTS;
        match self.strategy {
            Assembly::Gather => {
                let slots = &self.slots;
                let node = |n: usize, a: &mut [f64; 3], r: &mut [f64; 3]| {
                    let mut f = [
                        f_ext[n][0] + f_found[n][0],
                        f_ext[n][1] + f_found[n][1],
                        f_ext[n][2] + f_found[n][2],
                    ];
                    for &s in &l.slots[l.first[n] as usize..l.first[n + 1] as usize] {
                        let fe = slots[s as usize];
                        for k in 0..3 {
                            f[k] -= fe[k];
                        }
                    }
                    accelerate(l, n, f, a, r);
                };
                nodes(a, reaction, parallel, node);
            }
            Assembly::Colouring | Assembly::Partitions => {
                let (net, interface) = (&self.net, &self.interface);
                if self.strategy == Assembly::Partitions {
                    let p = &l.assembly;
                    let sum = |(i, &n): (usize, &u32)| {
                        let s = &net[n as usize];
                        let mut f = s.get();
                        let run = p.interface_first[i] as usize..p.interface_first[i + 1] as usize;
                        for fe in &interface[run] {
                            let fe = fe.get();
                            for k in 0..3 {
                                f[k] -= fe[k];
                            }
                        }
                        s.set(f);
                    };
                    if p.interface_nodes.len() >= PARALLEL_ELEMENTS {
                        p.interface_nodes
                            .par_iter()
                            .enumerate()
                            .with_min_len(NODE_GRAIN)
                            .for_each(sum);
                    } else {
                        p.interface_nodes.iter().enumerate().for_each(sum);
                    }
                }
                let node = |n: usize, a: &mut [f64; 3], r: &mut [f64; 3]| {
                    accelerate(l, n, net[n].get(), a, r);
                };
                nodes(a, reaction, parallel, node);
            }
        }
    }
}

/// `node(n, a[n], reaction[n])` for every node, in parallel when `parallel`.
fn nodes(
    a: &mut [[f64; 3]],
    reaction: &mut [[f64; 3]],
    parallel: bool,
    node: impl Fn(usize, &mut [f64; 3], &mut [f64; 3]) + Sync,
) {
    if parallel {
        a.par_iter_mut()
            .zip(reaction.par_iter_mut())
            .enumerate()
            .with_min_len(NODE_GRAIN)
            .for_each(|(n, (a, r))| node(n, a, r));
    } else {
        for (n, (a, r)) in a.iter_mut().zip(reaction.iter_mut()).enumerate() {
            node(n, a, r);
        }
    }
}

/// Node `n`'s acceleration from its net force `f`, or, on a constrained component, the
/// reaction `m a − f` that the constraint supplies (`a` is the prescribed acceleration).
fn accelerate(l: &MeshLayout, n: usize, f: [f64; 3], a: &mut [f64; 3], r: &mut [f64; 3]) {
    let inv_m = 1.0 / l.mass[n];
    let c = l.constrained[n];
    for k in 0..3 {
        if c[k] {
            r[k] = l.mass[n] * a[k] - f[k];
        } else {
            a[k] = f[k] * inv_m;
            r[k] = 0.0;
        }
    }
}

/// `leaf(offset, piece)` over pieces of `whole` (elements `offset..offset + len`) of at
/// most about `grain` elements, split at multiples of `align` (so that no colour group is
/// cut), in parallel by `rayon::join`.
fn split_runs<S: Send>(
    whole: S,
    offset: usize,
    len: usize,
    grain: usize,
    align: usize,
    split: &(impl Fn(S, usize) -> (S, S) + Sync),
    leaf: &(impl Fn(usize, S) + Sync),
) {
    let mid = len / 2 / align * align;
    if len <= grain || mid == 0 {
        return leaf(offset, whole);
    }
    let (x, y) = split(whole, mid);
    rayon::join(
        || split_runs(x, offset, mid, grain, align, split, leaf),
        || split_runs(y, offset + mid, len - mid, grain, align, split, leaf),
    );
}

/// `leaf(p, offset, piece)` for every partition `p0 + k` of `bounds` (partition `k` is
/// elements `bounds[k]..bounds[k + 1]`; `whole` starts at `bounds[0]`), in parallel.
fn split_parts<C: Columns>(
    whole: C,
    bounds: &[u32],
    p0: usize,
    leaf: &(impl Fn(usize, usize, C) + Sync),
) {
    let parts = bounds.len() - 1;
    if parts <= 1 {
        if parts == 1 {
            leaf(p0, bounds[0] as usize, whole);
        }
        return;
    }
    let m = parts / 2;
    let (x, y) = whole.split_at((bounds[m] - bounds[0]) as usize);
    rayon::join(
        || split_parts(x, &bounds[..=m], p0, leaf),
        || split_parts(y, &bounds[m..], p0 + m, leaf),
    );
}
