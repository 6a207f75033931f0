//! The spanning tree of a [`Layout`] in the form the recursions walk it, and the schedule
//! that runs sibling branches in parallel.
//!
//! # Order
//!
//! The tree is [`crate::analysis::topology::Topology`]'s (BFS forest rooted at ground and at one
//! centre body per free component; see there), built here from the layout's joint kinds
//! and bodies so that the interpreter and generated code get the same tree `mbdc check
//! --topology` prints. Bodies are renumbered into *positions*: branches by branch depth,
//! and within a branch parent before child. So
//! - a branch occupies a contiguous range of positions, and position `s + 1` is the only
//!   child of position `s` inside a branch;
//! - the branches of one branch depth (a *level*) occupy a contiguous range, every parent
//!   branch lies in a shallower level (lower positions) and every child branch in a deeper
//!   one (higher positions).
//!
//! # Parallel schedule
//!
//! A leaf → root recursion processes levels deepest first, a root → leaf recursion
//! shallowest first; inside a level the branches are independent (notes C §1.5: "build
//! rows 2 and 4 simultaneously, ... rows 3 and 5 simultaneously, each in its own branch").
//! [`Schedule::levels`] hands each branch its own `&mut` slice of the per-position data
//! and a read-only view of the other levels (split with `split_at_mut`, no `unsafe`), and
//! runs the branches of a level with `rayon::join` when the level holds at least
//! [`Schedule::par_min`] bodies. Per-body work ([`Schedule::nodes`]) is split into chunks
//! the same way. Nothing here allocates after construction.

use crate::analysis::topology::Topology;
use crate::contract::scene::{
    Attachment, Body, BodyRef, Fn1, Joint, JointKind, Origin, Scene, Simulate,
};
use crate::contract::system::{JointKernel, Layout};

/// Marker for "no position" (ground parent, free root).
pub const NONE: usize = usize::MAX;

/// Static description of one position of the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Link {
    /// Body index.
    pub body: usize,
    /// Position of the parent, [`NONE`] for a child of the ground or a free root.
    pub parent: usize,
    /// Layout joint to the parent, [`NONE`] for a free root.
    pub joint: usize,
    /// Kind of that joint (`None` for a free root).
    pub kind: Option<JointKernel>,
    /// Whether the child (this body) is side b of the joint.
    pub child_is_b: bool,
    /// Independent rates (6 for a free root).
    pub dof: usize,
    /// Offset of this position's rates in the independent-coordinate vector.
    pub off: usize,
}

/// The tree in processing order.
#[derive(Clone, Debug)]
pub struct Tree {
    /// Per position.
    pub links: Vec<Link>,
    /// Position of each body.
    pub pos: Vec<usize>,
    /// Children of position `p` (positions): `child_idx[child_ptr[p]..child_ptr[p + 1]]`.
    pub child_ptr: Vec<usize>,
    /// See `child_ptr`.
    pub child_idx: Vec<usize>,
    /// Number of independent coordinates.
    pub ncoord: usize,
    /// Layout rows that are not rows of tree joints (cut joints, drivers, distance,
    /// nonholonomic and curve constraints, locks), ascending.
    pub cut_rows: Vec<usize>,
    /// Layout joints of the tree, ascending.
    pub tree_joints: Vec<usize>,
    /// The schedule.
    pub sched: Schedule,
    /// The topology it was built from.
    pub topology: Topology,
}

/// Branch and level ranges for the recursions.
#[derive(Clone, Debug)]
pub struct Schedule {
    /// Branch `k` covers positions `bstart[k]..bstart[k + 1]`.
    pub bstart: Vec<usize>,
    /// Level `l` covers branches `lstart[l]..lstart[l + 1]`.
    pub lstart: Vec<usize>,
    /// Smallest number of bodies a level (or a per-body pass) must have to be split over
    /// threads.
    pub par_min: usize,
}

/// Default [`Schedule::par_min`] (measured, see docs/methods.md: below it the cost of
/// waking a second thread exceeds the work).
pub const PAR_MIN: usize = 512;

/// A scene with the layout's bodies and joint kinds only, for [`Topology::new`].
fn skeleton(layout: &Layout) -> Scene {
    let body = |i: usize| Body {
        name: layout.body_names.get(i).cloned().unwrap_or_default(),
        mass: layout.mass[i].m,
        inertia: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        position: [0.0; 3],
        orientation: [1.0, 0.0, 0.0, 0.0],
        velocity: [0.0; 3],
        angular_velocity: [0.0; 3],
        origin: Origin::default(),
    };
    let att = |b: Option<usize>| Attachment {
        body: b.map_or(BodyRef::Ground, BodyRef::Body),
        point: [0.0; 3],
        frame: [1.0, 0.0, 0.0, 0.0],
    };
    let joints = layout
        .joints
        .iter()
        .map(|j| Joint {
            name: j.name.clone(),
            kind: match JointKernel::from_keyword(j.kind) {
                Some(JointKernel::Spherical) => JointKind::Spherical,
                Some(JointKernel::Revolute) => JointKind::Revolute,
                Some(JointKernel::Prismatic) => JointKind::Prismatic,
                Some(JointKernel::Cylindrical) => JointKind::Cylindrical,
                Some(JointKernel::Universal) => JointKind::Universal,
                Some(JointKernel::Fixed) => JointKind::Fixed,
                Some(JointKernel::Planar) => JointKind::Planar,
                // never a tree edge and never a loop: only its rows matter here
                _ => JointKind::Curve {
                    curve: Fn1::Const(0.0),
                },
            },
            a: att(j.a),
            b: att(j.b),
            origin: Origin::default(),
        })
        .collect();
    Scene {
        name: String::new(),
        gravity: None,
        bodies: (0..layout.bodies()).map(body).collect(),
        joints,
        forces: Vec::new(),
        beams: Vec::new(),
        meshes: Vec::new(),
        contacts: Vec::new(),
        simulate: Simulate::default(),
        reference: None,
        params: Vec::new(),
    }
}

impl Tree {
    /// The tree of `layout` (see the module doc). Joints whose rows start inactive (locks)
    /// are never tree joints.
    pub fn new(layout: &Layout) -> Tree {
        let mut sk = skeleton(layout);
        for (j, jl) in layout.joints.iter().enumerate() {
            if jl.starts_inactive {
                sk.joints[j].kind = JointKind::Curve {
                    curve: Fn1::Const(0.0),
                };
            }
        }
        let topo = Topology::new(&sk);
        let n = layout.bodies();
        let mut bstart = Vec::with_capacity(topo.branches.len() + 1);
        let mut lstart = Vec::with_capacity(topo.branch_levels.len() + 1);
        let mut order = Vec::with_capacity(n);
        for lvl in &topo.branch_levels {
            lstart.push(bstart.len());
            for &b in lvl {
                bstart.push(order.len());
                order.extend_from_slice(&topo.branches[b].bodies);
            }
        }
        lstart.push(bstart.len());
        bstart.push(order.len());
        assert_eq!(order.len(), n, "every body is in exactly one branch");
        let mut pos = vec![NONE; n];
        for (p, &b) in order.iter().enumerate() {
            pos[b] = p;
        }
        let mut links = Vec::with_capacity(n);
        let mut off = 0;
        for &b in &order {
            let link = match topo.tree_joint(b) {
                Some(tj) => {
                    let kind = JointKernel::from_keyword(layout.joints[tj.joint].kind)
                        .filter(|k| k.is_tree())
                        .expect("tree joints are tree-eligible");
                    Link {
                        body: b,
                        parent: tj.parent.map_or(NONE, |p| pos[p]),
                        joint: tj.joint,
                        kind: Some(kind),
                        child_is_b: tj.a_is_parent,
                        dof: kind.tree_dof().unwrap_or(0),
                        off,
                    }
                }
                None => Link {
                    body: b,
                    parent: NONE,
                    joint: NONE,
                    kind: None,
                    child_is_b: true,
                    dof: 6,
                    off,
                },
            };
            off += link.dof;
            links.push(link);
        }
        let mut child_ptr = vec![0; n + 1];
        for l in &links {
            if l.parent != NONE {
                child_ptr[l.parent + 1] += 1;
            }
        }
        for p in 0..n {
            child_ptr[p + 1] += child_ptr[p];
        }
        let mut fill = child_ptr.clone();
        let mut child_idx = vec![0; child_ptr[n]];
        for (p, l) in links.iter().enumerate() {
            if l.parent != NONE {
                child_idx[fill[l.parent]] = p;
                fill[l.parent] += 1;
            }
        }
        let mut is_tree = vec![false; layout.joints.len()];
        let mut tree_joints = Vec::new();
        for l in &links {
            if l.joint != NONE {
                is_tree[l.joint] = true;
                tree_joints.push(l.joint);
            }
        }
        tree_joints.sort_unstable();
        let cut_rows = (0..layout.rows)
            .filter(|&r| !is_tree[layout.row_joint[r]])
            .collect();
        Tree {
            links,
            pos,
            child_ptr,
            child_idx,
            ncoord: off,
            cut_rows,
            tree_joints,
            sched: Schedule {
                bstart,
                lstart,
                par_min: PAR_MIN,
            },
            topology: topo,
        }
    }

    /// Number of positions (bodies).
    pub fn len(&self) -> usize {
        self.links.len()
    }

    /// Whether the tree has no bodies.
    pub fn is_empty(&self) -> bool {
        self.links.is_empty()
    }

    /// Children of position `p`.
    #[inline]
    pub fn children(&self, p: usize) -> &[usize] {
        &self.child_idx[self.child_ptr[p]..self.child_ptr[p + 1]]
    }
}

/// Read access to the positions outside the level being processed.
pub struct View<'a, T> {
    before: &'a [T],
    after: &'a [T],
    after_start: usize,
}

impl<T> View<'_, T> {
    /// The entry at absolute position `p`, which must lie outside the current level.
    #[inline]
    pub fn get(&self, p: usize) -> &T {
        if p < self.before.len() {
            &self.before[p]
        } else {
            &self.after[p - self.after_start]
        }
    }

    /// The parent of entry `i` of a branch `br` whose first entry's parent is at absolute
    /// position `parent` (`NONE`: a root): the previous entry of the branch, or for the first
    /// entry the one at `parent` outside the level; `None` for a root.
    #[inline]
    pub fn parent<'b>(&'b self, i: usize, parent: usize, br: &'b [T]) -> Option<&'b T> {
        if i > 0 {
            Some(&br[i - 1])
        } else {
            (parent != NONE).then(|| self.get(parent))
        }
    }
}

impl Schedule {
    /// Number of levels.
    pub fn levels_len(&self) -> usize {
        self.lstart.len() - 1
    }

    /// Run `f(start, branch, view)` for every branch, level by level (`leaf_first`: deepest
    /// level first). `branch` is the branch's slice of `data` (positions `start..`), `view`
    /// gives read access to every other level. Branches of a level run in parallel when the
    /// level holds at least `par_min` positions.
    pub fn levels<T, F>(&self, data: &mut [T], leaf_first: bool, f: &F)
    where
        T: Send + Sync,
        F: Fn(usize, &mut [T], &View<'_, T>) + Sync,
    {
        let nl = self.levels_len();
        for i in 0..nl {
            let l = if leaf_first { nl - 1 - i } else { i };
            let (b0, b1) = (self.lstart[l], self.lstart[l + 1]);
            let (lo, hi) = (self.bstart[b0], self.bstart[b1]);
            let (before, rest) = data.split_at_mut(lo);
            let (cur, after) = rest.split_at_mut(hi - lo);
            let view = View {
                before: &*before,
                after: &*after,
                after_start: hi,
            };
            let par = hi - lo >= self.par_min && b1 - b0 >= 2;
            self.branches(b0, b1, cur, lo, &view, par, f);
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn branches<T, F>(
        &self,
        b0: usize,
        b1: usize,
        cur: &mut [T],
        start: usize,
        view: &View<'_, T>,
        par: bool,
        f: &F,
    ) where
        T: Send + Sync,
        F: Fn(usize, &mut [T], &View<'_, T>) + Sync,
    {
        if b1 - b0 == 1 {
            f(start, cur, view);
            return;
        }
        if par && cur.len() >= self.par_min / 2 {
            // split at the branch boundary nearest the middle of the positions
            let target = start + cur.len() / 2;
            let mut mid = b0 + 1;
            while mid + 1 < b1 && self.bstart[mid] < target {
                mid += 1;
            }
            let cut = self.bstart[mid] - start;
            let (l, r) = cur.split_at_mut(cut);
            let rs = self.bstart[mid];
            rayon::join(
                || self.branches(b0, mid, l, start, view, par, f),
                || self.branches(mid, b1, r, rs, view, par, f),
            );
            return;
        }
        let mut rest = cur;
        let mut s = start;
        for b in b0..b1 {
            let len = self.bstart[b + 1] - self.bstart[b];
            let (mine, tail) = rest.split_at_mut(len);
            f(s, mine, view);
            s += len;
            rest = tail;
        }
    }

    /// Run `f(position, entry)` on every entry, in parallel chunks when there are at least
    /// `par_min` entries.
    pub fn nodes<T, F>(&self, data: &mut [T], f: &F)
    where
        T: Send,
        F: Fn(usize, &mut T) + Sync,
    {
        if data.len() >= self.par_min {
            use rayon::prelude::*;
            let chunk = (data.len() / (4 * rayon::current_num_threads()).max(1)).max(64);
            data.par_chunks_mut(chunk).enumerate().for_each(|(c, ch)| {
                for (i, x) in ch.iter_mut().enumerate() {
                    f(c * chunk + i, x);
                }
            });
        } else {
            for (i, x) in data.iter_mut().enumerate() {
                f(i, x);
            }
        }
    }
}
