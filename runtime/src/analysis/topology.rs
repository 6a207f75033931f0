//! Topology of a scene's joint graph: spanning forest, cut joints, loops, levels,
//! branches, degrees of freedom, and redundant constraint rows.
//!
//! # The graph (notes C §1.4–1.6)
//!
//! Nodes are the ground and the bodies; edges are joints. Only the *tree-eligible* kinds
//! (spherical, revolute, prismatic, cylindrical, universal, fixed, planar) can be tree
//! edges: they are the joints whose relative velocity has a natural parametrization
//! (notes C §1.4). Distance, curve, rolling, point-velocity joints and drivers are *extra*
//! constraints: drivers act on another joint's coordinate, nonholonomic and path
//! constraints add rows to a body that keeps its tree parametrization.
//!
//! # The spanning forest
//!
//! [`Topology::new`] grows a forest by breadth-first search, level by level:
//! 1. from the ground, over eligible joints;
//! 2. then, for every set of bodies not connected to ground, from a root body that gets
//!    6 degrees of freedom ([`Parent::Free`]). The root is the centre of the component's
//!    longest shortest path (double BFS sweep), which halves the depth of a floating
//!    chain compared with rooting it at an end.
//!
//! BFS gives every body its smallest possible depth, so kinematic loops closed by the
//! cut joints are as short as the graph allows and the recursions of natural partitioning
//! are as shallow as possible. When a body can hang off several parents of the same
//! level, it takes the one with the fewest children so far (ties: the lower scene joint
//! index), which balances branches for parallel scheduling.
//!
//! Eligible joints not used by the forest are *cut joints*: each closes one loop.
//! [`Topology::loops`] is the cycle rank of the graph of eligible and distance joints:
//! the cut joints plus the distance joints whose two ends are already connected (a
//! distance joint between otherwise unconnected parts links them without a loop).
//! Drivers, nonholonomic and curve constraints never count.
//!
//! # Branches
//!
//! A [`Branch`] is a maximal chain of bodies that starts at a child of the ground, at a
//! free root, or at a child of a body with ≥ 2 children, and continues while each body
//! has exactly one child. The subtree hanging off a branching body is the branch that
//! starts at the child plus its descendant branches; sibling subtrees are independent,
//! so the recursions of notes C §1.5 can run one task per branch once the parent branch
//! is done ([`Topology::branch_levels`]) or level-synchronously ([`Topology::levels`]).
//!
//! # Redundancy
//!
//! [`dependent_rows`] finds the constraint rows that are linear combinations of others
//! (numerical rank of the `m × 6n` Jacobian), [`redundancy`] also groups them by the
//! joints involved; see there for the algorithms.

use std::collections::VecDeque;
use std::fmt::Write as _;

use crate::contract::scene::{JointKind, Scene};
use crate::contract::system::{JointKernel, Layout, RowJac};
use crate::linalg::{Definiteness, SparseCholesky};

/// The parent of a body in the spanning forest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parent {
    /// Attached to the ground by a tree joint.
    Ground,
    /// Attached to another body by a tree joint.
    Body(usize),
    /// A root of a component not connected to ground: 6 degrees of freedom.
    Free,
}

/// A joint of the spanning forest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TreeJoint {
    /// Index into `Scene::joints`.
    pub joint: usize,
    /// Parent body, `None` for ground.
    pub parent: Option<usize>,
    /// Child body.
    pub child: usize,
    /// Whether the joint's side `a` is attached to the parent (else side `b` is, and the
    /// kinematics must be oriented from `b` to `a`).
    pub a_is_parent: bool,
    /// Independent relative velocities ([`JointKernel::tree_dof`]).
    pub dof: usize,
}

/// A maximal unbranched chain of the forest (see the module doc).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Branch {
    /// Bodies, parent before child.
    pub bodies: Vec<usize>,
    /// What the first body hangs off: ground, a branching body, or nothing (free root).
    pub base: Parent,
    /// The branch containing the base body, if any.
    pub parent: Option<usize>,
    /// Branches hanging off this branch's last body.
    pub children: Vec<usize>,
    /// Number of ancestor branches.
    pub depth: usize,
}

/// Degrees-of-freedom counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dof {
    /// Bodies.
    pub bodies: usize,
    /// Holonomic constraint rows of all joints (drivers included).
    pub holonomic_rows: usize,
    /// Nonholonomic (velocity-level) rows.
    pub nonholonomic_rows: usize,
    /// Grübler count `6·bodies − holonomic_rows` (too small when rows are redundant).
    pub grubler: i64,
    /// Velocities of the open forest: tree joints' freedoms plus 6 per free root.
    pub tree: usize,
}

/// The topology of a scene.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Topology {
    /// Per body: its parent.
    pub parent: Vec<Parent>,
    /// Per body: the index into [`Topology::tree_joints`] of the joint to its parent
    /// (`None` for free roots).
    pub parent_joint: Vec<Option<usize>>,
    /// Per body: depth (0 for children of ground and for free roots).
    pub level: Vec<usize>,
    /// Per body: children, in the order they were attached.
    pub children: Vec<Vec<usize>>,
    /// Bodies attached to ground by a tree joint.
    pub ground_children: Vec<usize>,
    /// Free roots (one per component not connected to ground).
    pub free_roots: Vec<usize>,
    /// Every body once, parents before children (ground component first, BFS order).
    pub order: Vec<usize>,
    /// Bodies by level: each level depends only on the previous one.
    pub levels: Vec<Vec<usize>>,
    /// Tree joints, in `order` of their child.
    pub tree_joints: Vec<TreeJoint>,
    /// Eligible joints not in the forest (scene indices, ascending).
    pub cut_joints: Vec<usize>,
    /// Joints of the never-tree kinds (scene indices, ascending).
    pub extra_joints: Vec<usize>,
    /// Branches, parents before children.
    pub branches: Vec<Branch>,
    /// Branch indices by branch depth.
    pub branch_levels: Vec<Vec<usize>>,
    /// Per body: the branch containing it.
    pub branch_of: Vec<usize>,
    /// Independent kinematic loops (see the module doc).
    pub loops: usize,
    /// Degrees of freedom.
    pub dof: Dof,
}

/// Number of independent kinematic loops closed by the scene's joints: cut joints plus
/// distance joints whose ends are already connected. Drivers, nonholonomic and curve
/// constraints are not loops.
pub fn loop_count(scene: &Scene) -> usize {
    Topology::new(scene).loops
}

/// Union–find with path halving.
struct Dsu(Vec<usize>);

impl Dsu {
    fn find(&mut self, mut x: usize) -> usize {
        while self.0[x] != x {
            self.0[x] = self.0[self.0[x]];
            x = self.0[x];
        }
        x
    }
    /// Merge; false if already in the same set.
    fn union(&mut self, a: usize, b: usize) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        self.0[ra] = rb;
        true
    }
}

impl Topology {
    /// Analyse a scene (see the module doc for the algorithm). `O(bodies + joints)`.
    pub fn new(scene: &Scene) -> Topology {
        let n = scene.bodies.len();
        let ground = n;
        let node = |r: crate::contract::scene::BodyRef| r.index().unwrap_or(ground);
        // Adjacency over eligible joints (no self-loops): (neighbour, joint).
        let mut adj: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n + 1];
        let mut extra_joints = Vec::new();
        for (j, joint) in scene.joints.iter().enumerate() {
            if !JointKernel::of(&joint.kind).is_tree() {
                extra_joints.push(j);
                continue;
            }
            let (a, b) = (node(joint.a.body), node(joint.b.body));
            if a != b {
                adj[a].push((b, j));
                adj[b].push((a, j));
            }
        }

        let mut f = Forest {
            scene,
            adj: &adj,
            ground,
            parent: vec![Parent::Free; n],
            parent_joint: vec![None; n],
            level: vec![0; n],
            children: vec![Vec::new(); n],
            ground_children: Vec::new(),
            order: Vec::with_capacity(n),
            tree_joints: Vec::with_capacity(n),
            in_tree: vec![false; scene.joints.len()],
            visited: vec![false; n + 1],
            disc: vec![usize::MAX; n + 1],
        };
        f.grow(ground, 0);
        let mut free_roots = Vec::new();
        let mut bfs = Bfs::new(adj.len());
        for start in 0..n {
            if f.visited[start] {
                continue;
            }
            let root = component_centre(&mut bfs, start, &adj, &f.visited);
            free_roots.push(root);
            f.parent[root] = Parent::Free;
            f.level[root] = 0;
            f.order.push(root);
            f.grow(root, 1);
        }
        let Forest {
            parent,
            parent_joint,
            level,
            children,
            ground_children,
            order,
            tree_joints,
            in_tree,
            ..
        } = f;

        let cut_joints: Vec<usize> = (0..scene.joints.len())
            .filter(|&j| JointKernel::of(&scene.joints[j].kind).is_tree() && !in_tree[j])
            .collect();

        let max_level = level.iter().copied().max().map_or(0, |l| l + 1);
        let mut levels = vec![Vec::new(); if n == 0 { 0 } else { max_level }];
        for &b in &order {
            levels[level[b]].push(b);
        }

        // Loops: cycle rank over eligible + distance joints.
        let mut dsu = Dsu((0..=n).collect());
        let mut loops = 0;
        for tj in &tree_joints {
            dsu.union(tj.parent.unwrap_or(ground), tj.child);
        }
        loops += cut_joints.len();
        for &j in &extra_joints {
            let joint = &scene.joints[j];
            if matches!(joint.kind, JointKind::Distance { .. })
                && !dsu.union(node(joint.a.body), node(joint.b.body))
            {
                loops += 1;
            }
        }

        let (branches, branch_of) = build_branches(n, &parent, &children, &order);
        let depth_max = branches.iter().map(|b| b.depth + 1).max().unwrap_or(0);
        let mut branch_levels = vec![Vec::new(); depth_max];
        for (i, b) in branches.iter().enumerate() {
            branch_levels[b.depth].push(i);
        }

        let holonomic_rows: usize = scene
            .joints
            .iter()
            .map(|j| j.kind.rows() - j.kind.nonholonomic_rows())
            .sum();
        let nonholonomic_rows: usize = scene
            .joints
            .iter()
            .map(|j| j.kind.nonholonomic_rows())
            .sum();
        let dof = Dof {
            bodies: n,
            holonomic_rows,
            nonholonomic_rows,
            grubler: 6 * n as i64 - holonomic_rows as i64,
            tree: tree_joints.iter().map(|t| t.dof).sum::<usize>() + 6 * free_roots.len(),
        };

        Topology {
            parent,
            parent_joint,
            level,
            children,
            ground_children,
            free_roots,
            order,
            levels,
            tree_joints,
            cut_joints,
            extra_joints,
            branches,
            branch_levels,
            branch_of,
            loops,
            dof,
        }
    }

    /// The tree joint connecting body `b` to its parent.
    pub fn tree_joint(&self, b: usize) -> Option<&TreeJoint> {
        self.parent_joint[b].map(|k| &self.tree_joints[k])
    }

    /// Number of components: one for the ground's (if any body hangs off ground) plus one
    /// per free root.
    pub fn components(&self) -> usize {
        usize::from(!self.ground_children.is_empty()) + self.free_roots.len()
    }

    /// A human-readable report for `mbdc check --topology`: the forest (indented, with
    /// each tree joint and its free coordinates), cut joints, other constraints, loops,
    /// branches and degrees of freedom.
    pub fn render(&self, scene: &Scene) -> String {
        let mut s = String::new();
        let bname = |b: usize| scene.bodies.get(b).map_or("?", |x| x.name.as_str());
        let side = |r: crate::contract::scene::BodyRef| r.index().map_or("ground", bname);
        let _ = writeln!(
            s,
            "topology of {}: {} bodies, {} joints ({} tree, {} cut, {} other)",
            scene.name,
            scene.bodies.len(),
            scene.joints.len(),
            self.tree_joints.len(),
            self.cut_joints.len(),
            self.extra_joints.len()
        );
        let tree_line = |s: &mut String, prefix: &str, b: usize| {
            let tj = self.tree_joint(b).expect("tree body");
            let j = &scene.joints[tj.joint];
            let _ = writeln!(
                s,
                "{prefix}{}  via {} ({}, {} dof: {})",
                bname(b),
                j.name,
                j.kind.keyword(),
                tj.dof,
                JointKernel::of(&j.kind).coordinates()
            );
        };
        fn walk(
            t: &Topology,
            s: &mut String,
            kids: &[usize],
            indent: &str,
            line: &dyn Fn(&mut String, &str, usize),
        ) {
            for (i, &c) in kids.iter().enumerate() {
                let last = i + 1 == kids.len();
                line(
                    s,
                    &format!("{indent}{}", if last { "└─ " } else { "├─ " }),
                    c,
                );
                let deeper = format!("{indent}{}", if last { "   " } else { "│  " });
                walk(t, s, &t.children[c], &deeper, line);
            }
        }
        if !self.ground_children.is_empty() {
            s.push_str("tree:\n  ground\n");
            walk(self, &mut s, &self.ground_children, "  ", &tree_line);
        }
        for &r in &self.free_roots {
            let _ = writeln!(
                s,
                "free body (root, 6 dof: translations x, y, z and 3 rotations):\n  {}",
                bname(r)
            );
            walk(self, &mut s, &self.children[r], "  ", &tree_line);
        }
        if !self.cut_joints.is_empty() {
            s.push_str("cut joints (each closes a loop):\n");
            for &j in &self.cut_joints {
                let jt = &scene.joints[j];
                let _ = writeln!(
                    s,
                    "  {} ({}, {} rows) between {} and {}",
                    jt.name,
                    jt.kind.keyword(),
                    jt.kind.rows(),
                    side(jt.a.body),
                    side(jt.b.body)
                );
            }
        }
        if !self.extra_joints.is_empty() {
            s.push_str("other constraints:\n");
            for &j in &self.extra_joints {
                let jt = &scene.joints[j];
                let nh = jt.kind.nonholonomic_rows();
                let rows = if nh > 0 {
                    format!("{} holonomic + {nh} nonholonomic rows", jt.kind.rows() - nh)
                } else {
                    format!(
                        "{} row{}",
                        jt.kind.rows(),
                        if jt.kind.rows() == 1 { "" } else { "s" }
                    )
                };
                let what = match &jt.kind {
                    JointKind::DriveAngle { joint, .. }
                    | JointKind::DriveDisplacement { joint, .. } => {
                        format!(
                            " driving {}",
                            scene.joints.get(*joint).map_or("?", |x| x.name.as_str())
                        )
                    }
                    _ => format!(" between {} and {}", side(jt.a.body), side(jt.b.body)),
                };
                let _ = writeln!(s, "  {} ({}, {rows}){what}", jt.name, jt.kind.keyword());
            }
        }
        let d = &self.dof;
        let _ = writeln!(s, "loops: {}", self.loops);
        let _ = writeln!(
            s,
            "branches: {} in {} level{}; body levels: {}",
            self.branches.len(),
            self.branch_levels.len(),
            if self.branch_levels.len() == 1 {
                ""
            } else {
                "s"
            },
            self.levels.len()
        );
        let _ = writeln!(
            s,
            "degrees of freedom: 6·{} − {} holonomic rows = {} (Grübler){}; open tree: {}",
            d.bodies,
            d.holonomic_rows,
            d.grubler,
            if d.nonholonomic_rows > 0 {
                format!(
                    ", minus {} nonholonomic velocity constraints",
                    d.nonholonomic_rows
                )
            } else {
                String::new()
            },
            d.tree
        );
        s
    }
}

/// State of the forest construction.
struct Forest<'a> {
    scene: &'a Scene,
    adj: &'a [Vec<(usize, usize)>],
    ground: usize,
    parent: Vec<Parent>,
    parent_joint: Vec<Option<usize>>,
    level: Vec<usize>,
    children: Vec<Vec<usize>>,
    ground_children: Vec<usize>,
    order: Vec<usize>,
    tree_joints: Vec<TreeJoint>,
    in_tree: Vec<bool>,
    visited: Vec<bool>,
    /// Discovery rank of a node within the level being built.
    disc: Vec<usize>,
}

impl Forest<'_> {
    fn nchildren(&self, u: usize) -> usize {
        if u == self.ground {
            self.ground_children.len()
        } else {
            self.children[u].len()
        }
    }

    /// Level-synchronous BFS from `root` (already placed); its children get level
    /// `first_level`. Each newly reached body takes, among the joints to the current
    /// frontier, the parent with the fewest children so far, then the lowest joint index.
    fn grow(&mut self, root: usize, first_level: usize) {
        self.visited[root] = true;
        let mut frontier = vec![root];
        let mut depth = first_level;
        let mut cand: Vec<(usize, usize, usize)> = Vec::new();
        while !frontier.is_empty() {
            cand.clear();
            let mut rank = 0;
            for &u in &frontier {
                for &(v, j) in &self.adj[u] {
                    if !self.visited[v] {
                        if self.disc[v] == usize::MAX {
                            self.disc[v] = rank;
                            rank += 1;
                        }
                        cand.push((v, u, j));
                    }
                }
            }
            // Group by discovery rank; the stable sort keeps the scan order inside a group.
            cand.sort_by_key(|c| self.disc[c.0]);
            let mut next = Vec::with_capacity(rank);
            let mut i = 0;
            while i < cand.len() {
                let v = cand[i].0;
                let mut k = i;
                while k < cand.len() && cand[k].0 == v {
                    k += 1;
                }
                let (_, u, j) = *cand[i..k]
                    .iter()
                    .min_by_key(|c| (self.nchildren(c.1), c.2))
                    .expect("non-empty group");
                self.attach(v, u, j, depth);
                next.push(v);
                i = k;
            }
            for &v in &next {
                self.disc[v] = usize::MAX;
            }
            frontier = next;
            depth += 1;
        }
    }

    fn attach(&mut self, v: usize, u: usize, j: usize, depth: usize) {
        self.visited[v] = true;
        self.in_tree[j] = true;
        let joint = &self.scene.joints[j];
        let a_is_parent = joint.a.body.index().unwrap_or(self.ground) == u;
        self.tree_joints.push(TreeJoint {
            joint: j,
            parent: if u == self.ground { None } else { Some(u) },
            child: v,
            a_is_parent,
            dof: JointKernel::of(&joint.kind)
                .tree_dof()
                .expect("tree joints are eligible"),
        });
        self.parent_joint[v] = Some(self.tree_joints.len() - 1);
        if u == self.ground {
            self.parent[v] = Parent::Ground;
            self.ground_children.push(v);
        } else {
            self.parent[v] = Parent::Body(u);
            self.children[u].push(v);
        }
        self.level[v] = depth;
        self.order.push(v);
    }
}

/// Breadth-first search buffers, sized once for all bodies and reset only where a search
/// went: a scene of many small components (200 000 free bodies) costs linear time, not
/// (bodies × components).
struct Bfs {
    dist: Vec<usize>,
    prev: Vec<usize>,
    touched: Vec<usize>,
    queue: VecDeque<usize>,
}

impl Bfs {
    fn new(n: usize) -> Bfs {
        Bfs {
            dist: vec![usize::MAX; n],
            prev: vec![usize::MAX; n],
            touched: Vec::new(),
            queue: VecDeque::new(),
        }
    }

    /// Forget the last search (only the entries it set).
    fn reset(&mut self) {
        for &u in &self.touched {
            self.dist[u] = usize::MAX;
            self.prev[u] = usize::MAX;
        }
        self.touched.clear();
    }

    /// BFS distances from `start` over eligible joints among unvisited bodies; returns the
    /// farthest body (distances and predecessors stay in the buffers until the next search).
    fn far(&mut self, start: usize, adj: &[Vec<(usize, usize)>], visited: &[bool]) -> usize {
        self.reset();
        self.dist[start] = 0;
        self.touched.push(start);
        self.queue.push_back(start);
        let mut far = start;
        while let Some(u) = self.queue.pop_front() {
            if self.dist[u] > self.dist[far] {
                far = u;
            }
            for &(v, _) in &adj[u] {
                if !visited[v] && self.dist[v] == usize::MAX {
                    self.dist[v] = self.dist[u] + 1;
                    self.prev[v] = u;
                    self.touched.push(v);
                    self.queue.push_back(v);
                }
            }
        }
        far
    }
}

/// The middle of a longest shortest path of the component of `start` (double sweep).
fn component_centre(
    bfs: &mut Bfs,
    start: usize,
    adj: &[Vec<(usize, usize)>],
    visited: &[bool],
) -> usize {
    let u = bfs.far(start, adj, visited);
    let v = bfs.far(u, adj, visited);
    let mut c = v;
    for _ in 0..bfs.dist[v] / 2 {
        c = bfs.prev[c];
    }
    c
}

fn build_branches(
    n: usize,
    parent: &[Parent],
    children: &[Vec<usize>],
    order: &[usize],
) -> (Vec<Branch>, Vec<usize>) {
    let mut branches: Vec<Branch> = Vec::new();
    let mut branch_of = vec![usize::MAX; n];
    // Starts: in `order`, bodies that are free roots, ground children, or children of a
    // body with ≥ 2 children.
    for &b in order {
        let starts = match parent[b] {
            Parent::Free | Parent::Ground => true,
            Parent::Body(p) => children[p].len() >= 2,
        };
        if !starts {
            continue;
        }
        let (base, parent_branch, depth) = match parent[b] {
            Parent::Free => (Parent::Free, None, 0),
            Parent::Ground => (Parent::Ground, None, 0),
            Parent::Body(p) => {
                let pb = branch_of[p];
                (Parent::Body(p), Some(pb), branches[pb].depth + 1)
            }
        };
        let idx = branches.len();
        let mut bodies = vec![b];
        branch_of[b] = idx;
        let mut cur = b;
        while children[cur].len() == 1 {
            cur = children[cur][0];
            branch_of[cur] = idx;
            bodies.push(cur);
        }
        if let Some(pb) = parent_branch {
            branches[pb].children.push(idx);
        }
        branches.push(Branch {
            bodies,
            base,
            parent: parent_branch,
            children: Vec::new(),
            depth,
        });
    }
    (branches, branch_of)
}

/// Default tolerance of [`dependent_rows`]: a row is dependent when its distance to the
/// span of the previous rows is at most `1e-9` of its length (angle ≲ 1e-9 rad).
pub const DEFAULT_RANK_TOL: f64 = 1e-9;

/// Largest `m² · 6n` (the flop count of Gram–Schmidt, ~0.1 s) for which the redundancy
/// check factors `B` densely.
const DENSE_RANK_MAX_FLOPS: usize = 200_000_000;

/// A set of joints whose rows are jointly redundant.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RedundantGroup {
    /// Joint indices (into `Layout::joints`), ascending.
    pub joints: Vec<usize>,
    /// Total rows of those joints.
    pub rows: usize,
    /// Dependent rows among them (global row indices, ascending).
    pub dependent: Vec<usize>,
}

/// Redundant constraint rows, grouped by the joints involved.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Redundancy {
    /// All dependent rows, ascending.
    pub dependent: Vec<usize>,
    /// Groups of joints that share dependencies.
    pub groups: Vec<RedundantGroup>,
}

impl Redundancy {
    /// One sentence per group, e.g. `joints a, b, c are redundant: 3 of their 20 rows are
    /// dependent`.
    pub fn messages(&self, layout: &Layout) -> Vec<String> {
        self.groups
            .iter()
            .map(|g| {
                let names: Vec<&str> = g
                    .joints
                    .iter()
                    .map(|&j| layout.joints[j].name.as_str())
                    .collect();
                let who = if names.len() == 1 {
                    format!("joint {} is", names[0])
                } else {
                    format!("joints {} are", names.join(", "))
                };
                format!(
                    "{who} redundant: {} of {} {} rows {} dependent",
                    g.dependent.len(),
                    if names.len() == 1 { "its" } else { "their" },
                    g.rows,
                    if g.dependent.len() == 1 { "is" } else { "are" }
                )
            })
            .collect()
    }
}

/// Constraint rows that are linear combinations of other rows (sorted). Rows of joints
/// that start inactive (locks) are ignored. See [`redundancy`].
pub fn dependent_rows(jac: &[RowJac], layout: &Layout, tol: f64) -> Vec<usize> {
    redundancy(jac, layout, tol).dependent
}

/// Find dependent constraint rows and group them by joint.
///
/// Rows are normalized to unit length, then:
/// - when `m² · 6n ≤ 2·10⁸` (about 0.1 s): modified Gram–Schmidt with reorthogonalization over the rows in
///   order, on the dense `B`; row `i` is dependent when its residual after projection onto
///   the accepted rows is `≤ tol` (so later rows are reported dependent on earlier ones,
///   e.g. a cut joint's rows rather than the tree's). The accepted rows a dependent row
///   combines are found by back substitution with the triangular factor.
/// - otherwise: the sparse Gram matrix `B Bᵀ` (entries are cosines of the angles between
///   rows) is factored by [`SparseCholesky`] in semidefinite mode with pivot tolerance
///   `max(tol², 1e-12)` (the Gram matrix squares the angles, so it cannot resolve angles
///   below ~1e-6), and a dependent row's combination is the basic solution of
///   `G x = G e_d`.
///
/// A group is the set of joints of a dependent row and of the rows it combines (with a
/// coefficient above `1e-6` of the largest), merged when groups share a joint.
pub fn redundancy(jac: &[RowJac], layout: &Layout, tol: f64) -> Redundancy {
    redundancy_with(jac, layout, tol, DENSE_RANK_MAX_FLOPS)
}

fn redundancy_with(jac: &[RowJac], layout: &Layout, tol: f64, dense_max: usize) -> Redundancy {
    let m = layout.rows;
    assert_eq!(jac.len(), m, "one Jacobian row per constraint row");
    let cols = 6 * layout.bodies();
    let rows: Vec<usize> = (0..m)
        .filter(|&r| !layout.joints[layout.row_joint[r]].starts_inactive)
        .collect();
    // Sparse rows: (column, value) pairs, normalized; `None` for all-zero rows.
    let sparse_row = |r: usize| -> Option<Vec<(usize, f64)>> {
        let (a, b) = layout.row_bodies(r);
        let mut v: Vec<(usize, f64)> = Vec::with_capacity(12);
        for (body, blk) in [(a, &jac[r].a), (b, &jac[r].b)] {
            if let Some(i) = body {
                for (k, &x) in blk.iter().enumerate() {
                    if let Some(e) = v.iter_mut().find(|e| e.0 == 6 * i + k) {
                        e.1 += x;
                    } else {
                        v.push((6 * i + k, x));
                    }
                }
            }
        }
        let norm = v.iter().map(|e| e.1 * e.1).sum::<f64>().sqrt();
        if norm == 0.0 || !norm.is_finite() {
            return None;
        }
        v.iter_mut().for_each(|e| e.1 /= norm);
        Some(v)
    };
    // (dependent row, rows it combines)
    let mut deps: Vec<(usize, Vec<usize>)> = Vec::new();
    if rows.len().saturating_mul(rows.len()).saturating_mul(cols) <= dense_max {
        let mut q: Vec<Vec<f64>> = Vec::new(); // orthonormal basis
        let mut rmat: Vec<Vec<f64>> = Vec::new(); // column j: coefficients of accepted row j
        let mut accepted: Vec<usize> = Vec::new();
        let mut w = vec![0.0; cols];
        for &r in &rows {
            let Some(sr) = sparse_row(r) else {
                deps.push((r, Vec::new()));
                continue;
            };
            w.fill(0.0);
            for &(c, x) in &sr {
                w[c] = x;
            }
            let mut coef = vec![0.0; q.len()];
            for _pass in 0..2 {
                for (k, qk) in q.iter().enumerate() {
                    let d: f64 = qk.iter().zip(&w).map(|(a, b)| a * b).sum();
                    coef[k] += d;
                    for (wi, qi) in w.iter_mut().zip(qk) {
                        *wi -= d * qi;
                    }
                }
            }
            let res = w.iter().map(|x| x * x).sum::<f64>().sqrt();
            if res <= tol {
                // Solve R x = coef (R upper triangular, column j = rmat[j]).
                let k = q.len();
                let mut x = coef;
                for j in (0..k).rev() {
                    x[j] /= rmat[j][j];
                    let xj = x[j];
                    for (i, xi) in x.iter_mut().enumerate().take(j) {
                        *xi -= rmat[j][i] * xj;
                    }
                }
                let xmax = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                let combo = x
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| v.abs() > 1e-6 * xmax)
                    .map(|(j, _)| accepted[j])
                    .collect();
                deps.push((r, combo));
            } else {
                let mut col = coef;
                col.push(res);
                rmat.push(col);
                q.push(w.iter().map(|x| x / res).collect());
                accepted.push(r);
            }
        }
    } else {
        // Gram matrix on the considered rows, pattern from shared bodies.
        let sub: Vec<(Option<usize>, Option<usize>)> =
            rows.iter().map(|&r| layout.row_bodies(r)).collect();
        let pattern = crate::linalg::KPattern::from_row_bodies(&sub, layout.bodies());
        let srows: Vec<Option<Vec<(usize, f64)>>> = rows.iter().map(|&r| sparse_row(r)).collect();
        let dot = |x: &Option<Vec<(usize, f64)>>, y: &Option<Vec<(usize, f64)>>| -> f64 {
            match (x, y) {
                (Some(x), Some(y)) => x
                    .iter()
                    .map(|(c, v)| y.iter().find(|e| e.0 == *c).map_or(0.0, |e| e.1 * v))
                    .sum(),
                _ => 0.0,
            }
        };
        let mut chol = SparseCholesky::new(
            rows.len(),
            pattern.col_ptr(),
            pattern.row_idx(),
            Definiteness::SemiDefinite {
                tol: (tol * tol).max(1e-12),
            },
        )
        .expect("valid pattern");
        let (cp, ri) = (pattern.col_ptr().to_vec(), pattern.row_idx().to_vec());
        {
            let vals = chol.values_mut();
            for s in 0..rows.len() {
                for e in cp[s]..cp[s + 1] {
                    vals[e] = dot(&srows[ri[e]], &srows[s]);
                }
            }
        }
        if chol.factor().is_ok() {
            let dep: Vec<usize> = chol.dependent_rows().to_vec();
            // Rows touching each body, to build columns of G without a full scan.
            let mut body_rows: Vec<Vec<usize>> = vec![Vec::new(); layout.bodies()];
            for (i, &(a, b)) in sub.iter().enumerate() {
                for body in [a, b].into_iter().flatten() {
                    if body_rows[body].last() != Some(&i) {
                        body_rows[body].push(i);
                    }
                }
            }
            let mut g = vec![0.0; rows.len()];
            for d in dep {
                g.fill(0.0);
                let (a, b) = sub[d];
                for body in [a, b].into_iter().flatten() {
                    for &i in &body_rows[body] {
                        g[i] = dot(&srows[i], &srows[d]);
                    }
                }
                chol.solve_in_place(&mut g);
                let xmax = g.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                let combo = g
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| xmax > 0.0 && v.abs() > 1e-6 * xmax)
                    .map(|(i, _)| rows[i])
                    .collect();
                deps.push((rows[d], combo));
            }
        }
    }
    group(layout, deps)
}

fn group(layout: &Layout, deps: Vec<(usize, Vec<usize>)>) -> Redundancy {
    let nj = layout.joints.len();
    let mut dsu = Dsu((0..nj).collect());
    let mut involved = vec![false; nj];
    for (d, combo) in &deps {
        let jd = layout.row_joint[*d];
        involved[jd] = true;
        for &r in combo {
            let jr = layout.row_joint[r];
            involved[jr] = true;
            dsu.union(jd, jr);
        }
    }
    let mut groups: Vec<RedundantGroup> = Vec::new();
    let mut group_of_root: Vec<Option<usize>> = vec![None; nj];
    for (j, _) in involved.iter().enumerate().filter(|(_, &inv)| inv) {
        let root = dsu.find(j);
        let g = *group_of_root[root].get_or_insert_with(|| {
            groups.push(RedundantGroup {
                joints: Vec::new(),
                rows: 0,
                dependent: Vec::new(),
            });
            groups.len() - 1
        });
        groups[g].joints.push(j);
        groups[g].rows += layout.joints[j].rows;
    }
    let mut dependent: Vec<usize> = deps.iter().map(|d| d.0).collect();
    dependent.sort_unstable();
    for &d in &dependent {
        let root = dsu.find(layout.row_joint[d]);
        let g = group_of_root[root].expect("dependent joint is involved");
        groups[g].dependent.push(d);
    }
    Redundancy { dependent, groups }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::scene::{Attachment, Body, BodyRef, Fn1, Joint, Origin, Simulate};

    fn body(name: &str) -> Body {
        Body {
            name: name.into(),
            mass: 1.0,
            inertia: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            position: [0.0; 3],
            orientation: [1.0, 0.0, 0.0, 0.0],
            velocity: [0.0; 3],
            angular_velocity: [0.0; 3],
            origin: Origin::default(),
        }
    }

    fn at(b: Option<usize>) -> Attachment {
        Attachment {
            body: b.map_or(BodyRef::Ground, BodyRef::Body),
            point: [0.0; 3],
            frame: [1.0, 0.0, 0.0, 0.0],
        }
    }

    fn scene(bodies: usize, joints: &[(Option<usize>, Option<usize>, JointKind)]) -> Scene {
        Scene {
            name: "t".into(),
            gravity: None,
            bodies: (0..bodies).map(|i| body(&format!("b{i}"))).collect(),
            joints: joints
                .iter()
                .enumerate()
                .map(|(k, (a, b, kind))| Joint {
                    name: format!("j{k}"),
                    kind: kind.clone(),
                    a: at(*a),
                    b: at(*b),
                    origin: Origin::default(),
                })
                .collect(),
            forces: vec![],
            beams: vec![],
            meshes: vec![],
            contacts: vec![],
            simulate: Simulate::default(),
            reference: None,
            params: vec![],
        }
    }

    use JointKind::*;

    /// Checks every structural invariant of a topology.
    fn check_invariants(sc: &Scene, t: &Topology) {
        let n = sc.bodies.len();
        // Every body exactly once in `order`, parents first.
        let mut pos = vec![usize::MAX; n];
        for (i, &b) in t.order.iter().enumerate() {
            assert_eq!(pos[b], usize::MAX, "body {b} twice");
            pos[b] = i;
        }
        assert!(pos.iter().all(|&p| p != usize::MAX), "every body reached");
        for b in 0..n {
            match t.parent[b] {
                Parent::Body(p) => {
                    assert!(pos[p] < pos[b]);
                    assert_eq!(t.level[b], t.level[p] + 1);
                    assert!(t.children[p].contains(&b));
                }
                Parent::Ground => assert_eq!(t.level[b], 0),
                Parent::Free => {
                    assert_eq!(t.level[b], 0);
                    assert!(t.free_roots.contains(&b));
                }
            }
        }
        // One tree joint per non-root body: tree joints + free roots = bodies.
        assert_eq!(t.tree_joints.len() + t.free_roots.len(), n);
        for tj in &t.tree_joints {
            let j = &sc.joints[tj.joint];
            let (pa, pb) = (j.a.body.index(), j.b.body.index());
            if tj.a_is_parent {
                assert_eq!((pa, pb), (tj.parent, Some(tj.child)));
            } else {
                assert_eq!((pb, pa), (tj.parent, Some(tj.child)));
            }
        }
        // Tree + cut = eligible; extra = the rest.
        let eligible = sc
            .joints
            .iter()
            .filter(|j| JointKernel::of(&j.kind).is_tree())
            .count();
        assert_eq!(t.tree_joints.len() + t.cut_joints.len(), eligible);
        assert_eq!(eligible + t.extra_joints.len(), sc.joints.len());
        // Levels partition the bodies.
        assert_eq!(t.levels.iter().map(Vec::len).sum::<usize>(), n);
        // Branches partition the bodies; each branch is a parent–child chain.
        let mut seen = vec![0; n];
        for (i, br) in t.branches.iter().enumerate() {
            for w in br.bodies.windows(2) {
                assert_eq!(t.parent[w[1]], Parent::Body(w[0]));
            }
            for &b in &br.bodies {
                seen[b] += 1;
                assert_eq!(t.branch_of[b], i);
            }
            if let Some(p) = br.parent {
                assert!(p < i && t.branches[p].children.contains(&i));
                assert_eq!(br.depth, t.branches[p].depth + 1);
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
    }

    #[test]
    fn chain() {
        let sc = scene(
            4,
            &[
                (None, Some(0), Revolute),
                (Some(0), Some(1), Revolute),
                (Some(1), Some(2), Spherical),
                (Some(3), Some(2), Universal),
            ],
        );
        let t = Topology::new(&sc);
        check_invariants(&sc, &t);
        assert_eq!(t.order, vec![0, 1, 2, 3]);
        assert_eq!(t.level, vec![0, 1, 2, 3]);
        assert_eq!(t.loops, 0);
        assert!(t.cut_joints.is_empty());
        // The last joint is written (3, 2) but body 2 is the parent.
        assert!(!t.tree_joint(3).unwrap().a_is_parent);
        assert!(t.tree_joint(1).unwrap().a_is_parent);
        assert_eq!(t.branches.len(), 1);
        assert_eq!(t.branches[0].bodies, vec![0, 1, 2, 3]);
        assert_eq!(t.dof.tree, 1 + 1 + 3 + 2);
        assert_eq!(t.dof.holonomic_rows, 5 + 5 + 3 + 4);
        assert_eq!(t.dof.grubler, 24 - 17);
        assert_eq!(loop_count(&sc), 0);
    }

    /// Notes C Fig. 2: body 1 is the root; 2 and 4 hang off 1; 3 off 2; 5 off 4
    /// (0-based here: 0; 1, 3; 2; 4).
    #[test]
    fn tree_with_branches_fig2() {
        let sc = scene(
            5,
            &[
                (None, Some(0), Spherical),
                (Some(0), Some(1), Spherical),
                (Some(1), Some(2), Spherical),
                (Some(0), Some(3), Spherical),
                (Some(3), Some(4), Spherical),
            ],
        );
        let t = Topology::new(&sc);
        check_invariants(&sc, &t);
        assert_eq!(t.levels, vec![vec![0], vec![1, 3], vec![2, 4]]);
        assert_eq!(t.children[0], vec![1, 3]);
        let chains: Vec<_> = t.branches.iter().map(|b| b.bodies.clone()).collect();
        assert_eq!(chains, vec![vec![0], vec![1, 2], vec![3, 4]]);
        assert_eq!(t.branch_levels, vec![vec![0], vec![1, 2]]);
        assert_eq!(t.branches[1].base, Parent::Body(0));
        assert_eq!(t.branches[0].base, Parent::Ground);
        assert_eq!(t.dof.tree, 15);
        assert_eq!(t.dof.grubler, 30 - 15);
    }

    /// Four-bar linkage: ground–crank–coupler–rocker–ground, all revolute: one cut joint,
    /// chosen so that the loop splits into two branches of equal depth.
    #[test]
    fn four_bar() {
        let sc = scene(
            3,
            &[
                (None, Some(0), Revolute),
                (Some(0), Some(1), Revolute),
                (Some(1), Some(2), Revolute),
                (Some(2), None, Revolute),
            ],
        );
        let t = Topology::new(&sc);
        check_invariants(&sc, &t);
        assert_eq!(t.ground_children, vec![0, 2]);
        assert_eq!(t.parent[1], Parent::Body(0));
        assert_eq!(t.cut_joints, vec![2]);
        assert_eq!(t.loops, 1);
        assert_eq!(t.dof.grubler, 18 - 20);
        assert_eq!(loop_count(&sc), 1);
        // The ground joint of the rocker is written (2, ground): b is the parent.
        assert!(!t.tree_joint(2).unwrap().a_is_parent);
    }

    /// A ladder of k rungs: two rails from ground, rung joints between them: k loops.
    #[test]
    fn ladder() {
        let k = 5;
        let mut joints = vec![];
        for side in 0..2 {
            for i in 0..=k {
                let b = side * (k + 1) + i;
                joints.push((if i == 0 { None } else { Some(b - 1) }, Some(b), Spherical));
            }
        }
        for i in 1..=k {
            joints.push((Some(i), Some(k + 1 + i), Revolute));
        }
        let sc = scene(2 * (k + 1), &joints);
        let t = Topology::new(&sc);
        check_invariants(&sc, &t);
        assert_eq!(t.loops, k);
        assert_eq!(t.cut_joints.len(), k);
        // BFS depth: each rail body at its rail depth.
        assert_eq!(t.levels.len(), k + 1);
    }

    /// A free body and two disconnected components: one hanging off ground, one floating
    /// chain of 5 rooted at its middle body.
    #[test]
    fn free_bodies_and_components() {
        let sc = scene(
            8,
            &[
                (None, Some(0), Revolute),
                (Some(0), Some(1), Revolute),
                // floating chain 2-3-4-5-6
                (Some(2), Some(3), Spherical),
                (Some(3), Some(4), Spherical),
                (Some(4), Some(5), Spherical),
                (Some(5), Some(6), Spherical),
                // body 7: free, only a distance joint to ground
                (Some(7), None, Distance { length: 1.0 }),
            ],
        );
        let t = Topology::new(&sc);
        check_invariants(&sc, &t);
        assert_eq!(t.free_roots, vec![4, 7]);
        assert_eq!(t.parent[7], Parent::Free);
        assert_eq!(t.level[2], 2);
        assert_eq!(t.level[6], 2);
        assert_eq!(t.components(), 3);
        // The distance joint links body 7 to ground without closing a loop.
        assert_eq!(t.loops, 0);
        assert_eq!(t.dof.tree, 2 + 4 * 3 + 6 + 6);
        // Branches: ground chain; the root 4 alone (2 children), then 3-2 and 5-6; 7.
        let chains: Vec<_> = t.branches.iter().map(|b| b.bodies.clone()).collect();
        assert_eq!(
            chains,
            vec![vec![0, 1], vec![4], vec![3, 2], vec![5, 6], vec![7]]
        );
        assert_eq!(t.branches[1].base, Parent::Free);
    }

    /// Drivers, rolling, point-velocity and curve constraints are extra rows, never tree
    /// joints or loops; a distance joint between connected bodies is a loop.
    #[test]
    fn drivers_and_rolling() {
        let sc = scene(
            3,
            &[
                (None, Some(0), Revolute),
                (
                    None,
                    Some(0),
                    DriveAngle {
                        joint: 0,
                        angle: Fn1::Var,
                    },
                ),
                (Some(0), Some(1), Prismatic),
                (
                    None,
                    Some(1),
                    DriveDisplacement {
                        joint: 2,
                        displacement: Fn1::Const(0.1),
                    },
                ),
                (Some(2), None, Rolling { radius: 0.1 }),
                (Some(1), None, Curve { curve: Fn1::Var }),
                (
                    Some(1),
                    None,
                    PointVelocity {
                        velocity: [Fn1::Const(0.0), Fn1::Const(0.0), Fn1::Const(0.0)],
                    },
                ),
                (Some(0), Some(1), Distance { length: 0.5 }),
            ],
        );
        let t = Topology::new(&sc);
        check_invariants(&sc, &t);
        assert_eq!(t.extra_joints, vec![1, 3, 4, 5, 6, 7]);
        assert_eq!(t.free_roots, vec![2]);
        assert_eq!(t.loops, 1);
        assert_eq!(t.dof.nonholonomic_rows, 2 + 3);
        assert_eq!(t.dof.holonomic_rows, 5 + 1 + 5 + 1 + 1 + 1 + 1);
        assert_eq!(t.dof.grubler, 18 - 15);
        assert_eq!(t.dof.tree, 1 + 1 + 6);
        let text = t.render(&sc);
        for needle in [
            "ground",
            "b0  via j0 (revolute, 1 dof: rotation about z)",
            "b1  via j2 (prismatic, 1 dof",
            "j1 (drive_angle, 1 row) driving j0",
            "j4 (rolling, 1 holonomic + 2 nonholonomic rows) between b2 and ground",
            "free body",
            "loops: 1",
            "6·3 − 15 holonomic rows = 3 (Grübler), minus 5 nonholonomic",
        ] {
            assert!(text.contains(needle), "missing {needle:?} in\n{text}");
        }
    }

    /// When a body can hang off two parents of the same level, it takes the one with
    /// fewer children: C and D, both joined to A and B, go one to each.
    #[test]
    fn balanced_parents() {
        let sc = scene(
            4,
            &[
                (None, Some(0), Revolute),
                (None, Some(1), Revolute),
                (Some(0), Some(2), Revolute),
                (Some(1), Some(2), Revolute),
                (Some(0), Some(3), Revolute),
                (Some(1), Some(3), Revolute),
            ],
        );
        let t = Topology::new(&sc);
        check_invariants(&sc, &t);
        assert_eq!(t.parent[2], Parent::Body(0));
        assert_eq!(t.parent[3], Parent::Body(1));
        assert_eq!(t.loops, 2);
    }

    #[test]
    fn rendering_of_a_tree() {
        let sc = scene(
            3,
            &[
                (None, Some(0), Revolute),
                (Some(0), Some(1), Spherical),
                (Some(0), Some(2), Fixed),
                (Some(1), Some(2), Revolute),
            ],
        );
        let t = Topology::new(&sc);
        let text = t.render(&sc);
        let expect = "\
topology of t: 3 bodies, 4 joints (3 tree, 1 cut, 0 other)
tree:
  ground
  └─ b0  via j0 (revolute, 1 dof: rotation about z)
     ├─ b1  via j1 (spherical, 3 dof: 3 rotations)
     └─ b2  via j2 (fixed, 0 dof: none)
cut joints (each closes a loop):
  j3 (revolute, 5 rows) between b1 and b2
loops: 1
branches: 3 in 2 levels; body levels: 2
degrees of freedom: 6·3 − 19 holonomic rows = -1 (Grübler); open tree: 4
";
        assert_eq!(text, expect);
    }

    /// Large scenes: a 20 000-body random tree with extra loop joints and a 20 000-body
    /// star keep every invariant (and finish in well under a second: the construction
    /// is linear, a quadratic one would take minutes here).
    #[test]
    fn large_scenes() {
        let mut rng = crate::linalg::testutil::Rng::new(9);
        let n = 20_000;
        let mut joints: Vec<_> = (0..n)
            .map(|i| {
                (
                    if i == 0 { None } else { Some(rng.below(i)) },
                    Some(i),
                    Revolute,
                )
            })
            .collect();
        for _ in 0..100 {
            joints.push((Some(rng.below(n)), Some(rng.below(n)), Spherical));
        }
        let sc = scene(n, &joints);
        let t = Topology::new(&sc);
        check_invariants(&sc, &t);
        assert_eq!(t.loops, 100);
        let star: Vec<_> = (0..n).map(|i| (None, Some(i), Spherical)).collect();
        let sc = scene(n, &star);
        let t = Topology::new(&sc);
        check_invariants(&sc, &t);
        assert_eq!(t.levels.len(), 1);
        assert_eq!(t.branches.len(), n);
    }

    #[test]
    fn empty_scene() {
        let t = Topology::new(&scene(0, &[]));
        assert!(t.order.is_empty() && t.levels.is_empty() && t.branches.is_empty());
        assert_eq!(t.loops, 0);
    }

    mod prop {
        use super::*;
        use proptest::prelude::*;

        fn kind(k: u8) -> JointKind {
            match k % 10 {
                0 => Spherical,
                1 => Revolute,
                2 => Prismatic,
                3 => Cylindrical,
                4 => Universal,
                5 => Fixed,
                6 => Planar,
                7 => Distance { length: 1.0 },
                8 => Rolling { radius: 1.0 },
                _ => DriveAngle {
                    joint: 0,
                    angle: Fn1::Const(0.0),
                },
            }
        }

        proptest! {
            /// Random multigraphs (ground included, self-loops and parallel joints
            /// allowed): every body is reached once, tree + cut = eligible, the forest
            /// has one edge per non-root body, and the loop count equals the cycle rank
            /// `E − V + C` of the eligible + distance graph (self-loops count).
            #[test]
            fn random_graphs(n in 1usize..14, edges in proptest::collection::vec((0usize..15, 0usize..15, 0u8..10), 0..30)) {
                let joints: Vec<_> = edges.iter().map(|&(a, b, k)| {
                    let side = |x: usize| if x % 15 >= n { None } else { Some(x % 15) };
                    (side(a), side(b), kind(k))
                }).collect();
                let sc = scene(n, &joints);
                let t = Topology::new(&sc);
                check_invariants(&sc, &t);
                // Cycle rank of the graph with eligible + distance edges over nodes
                // touched (ground + bodies).
                let mut dsu = Dsu((0..=n).collect());
                let mut e = 0usize;
                let mut comps = n + 1;
                for j in &sc.joints {
                    if JointKernel::of(&j.kind).is_tree() || matches!(j.kind, Distance { .. }) {
                        e += 1;
                        let a = j.a.body.index().unwrap_or(n);
                        let b = j.b.body.index().unwrap_or(n);
                        if dsu.union(a, b) { comps -= 1; }
                    }
                }
                prop_assert_eq!(t.loops, e + comps - (n + 1));
                // Shallowest tree: every level is the BFS distance over eligible joints.
                prop_assert!(t.levels.len() <= n);
            }
        }
    }

    mod redundancy {
        use super::*;
        use crate::linalg::testutil::{layout_from_joints, random_jac, Rng};

        /// A chain (3 rows per joint) plus joints repeating rows of others: the known
        /// dependent rows are found by both the dense and the sparse algorithm, and
        /// grouped with the joints they repeat.
        #[test]
        fn finds_and_groups_redundant_rows() {
            let mut rng = Rng::new(5);
            let mut joints: Vec<_> = (0..12)
                .map(|i| (if i == 0 { None } else { Some(i - 1) }, Some(i), 3))
                .collect();
            joints.push((Some(3), Some(4), 3)); // joint 12 repeats joint 4 (rows 12..15)
            joints.push((Some(8), Some(9), 2)); // joint 13: row 0 = joint 9 row 0, row 1 = 2·(joint 9 row 1) − joint 9 row 2
            let layout = layout_from_joints(&mut rng, 12, &joints);
            let mut jac = random_jac(&mut rng, layout.rows);
            let (r12, r13, r9) = (36, 39, 27);
            for k in 0..3 {
                jac[r12 + k] = jac[12 + k];
            }
            jac[r13] = jac[r9];
            for s in 0..6 {
                jac[r13 + 1].a[s] = 2.0 * jac[r9 + 1].a[s] - jac[r9 + 2].a[s];
                jac[r13 + 1].b[s] = 2.0 * jac[r9 + 1].b[s] - jac[r9 + 2].b[s];
            }
            for dense_max in [usize::MAX, 0] {
                let red = redundancy_with(&jac, &layout, DEFAULT_RANK_TOL, dense_max);
                if dense_max == usize::MAX {
                    // In-order elimination reports the later rows.
                    assert_eq!(red.dependent, vec![36, 37, 38, 39, 40]);
                } else {
                    assert_eq!(red.dependent.len(), 5);
                }
                assert_eq!(red.groups.len(), 2, "{dense_max}: {red:?}");
                let g0 = red.groups.iter().find(|g| g.joints.contains(&4)).unwrap();
                assert_eq!(g0.joints, vec![4, 12]);
                assert_eq!((g0.rows, g0.dependent.len()), (6, 3));
                let g1 = red.groups.iter().find(|g| g.joints.contains(&9)).unwrap();
                assert_eq!(g1.joints, vec![9, 13]);
                assert_eq!((g1.rows, g1.dependent.len()), (5, 2));
                let msgs = red.messages(&layout);
                assert!(
                    msgs.contains(
                        &"joints j4, j12 are redundant: 3 of their 6 rows are dependent"
                            .to_string()
                    ),
                    "{msgs:?}"
                );
            }
            assert_eq!(
                dependent_rows(&jac, &layout, DEFAULT_RANK_TOL),
                vec![36, 37, 38, 39, 40]
            );
        }

        /// Independent rows are not reported, with either algorithm; a nearly dependent
        /// row (angle 1e-3) is independent at the default tolerance.
        #[test]
        fn independent_rows_are_not_reported() {
            let mut rng = Rng::new(6);
            let joints: Vec<_> = (0..20)
                .map(|i| (if i == 0 { None } else { Some(i - 1) }, Some(i), 5))
                .collect();
            let layout = layout_from_joints(&mut rng, 20, &joints);
            let mut jac = random_jac(&mut rng, layout.rows);
            for s in 0..6 {
                jac[7].b[s] = jac[6].b[s] + 1e-3 * rng.normal();
                jac[7].a[s] = jac[6].a[s];
            }
            for dense_max in [usize::MAX, 0] {
                let red = redundancy_with(&jac, &layout, DEFAULT_RANK_TOL, dense_max);
                assert!(
                    red.dependent.is_empty() && red.groups.is_empty(),
                    "{dense_max}: {red:?}"
                );
            }
        }

        /// A zero row is dependent on its own; rows of locks are ignored.
        #[test]
        fn zero_rows_and_locks() {
            let mut rng = Rng::new(7);
            let mut layout = layout_from_joints(
                &mut rng,
                2,
                &[
                    (None, Some(0), 3),
                    (Some(0), Some(1), 3),
                    (Some(0), Some(1), 1),
                ],
            );
            let mut jac = random_jac(&mut rng, layout.rows);
            jac[4] = RowJac::default();
            jac[6] = jac[3];
            layout.joints[2].starts_inactive = true;
            let red = redundancy(&jac, &layout, DEFAULT_RANK_TOL);
            assert_eq!(red.dependent, vec![4]);
            assert_eq!(
                red.messages(&layout),
                vec!["joint j1 is redundant: 1 of its 3 rows is dependent".to_string()]
            );
        }
    }
}
