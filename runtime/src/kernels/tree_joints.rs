//! Per-tree-joint kinematics of natural partitioning: the null-space blocks, the
//! velocity-product term and the position projection, one function per joint kind.
//!
//! # The relation (notes C §1.4, generalized to every tree-eligible kind)
//!
//! For a tree joint with parent body `p` (the ground: identity pose, zero twist) and child
//! body `c`, the child's twist `u_c = (v_c, w_c)` (`v` world, `w` body components, as in
//! [`crate::contract::system`]) is
//!
//! ```text
//! u_c = X u_p + S q̇,          u̇_c' = X u̇_p' + S q̈ + κ,
//! ```
//!
//! `q̇` being the joint's independent rates (`dof` numbers), `X` the transport of the
//! parent's twist, `S` the joint's motion subspace and `κ = Ȧ q̇` (the child's acceleration
//! when every `q̈ = 0`) the velocity-product term. Stacked root → leaf these are the block
//! rows of the null space `A` of the tree Jacobian: `A_cc = S_c`, `A_ck = X_c A_pk`.
//!
//! **Dependent coordinates, analytically inverted.** The natural choice of the paper: the
//! child's translational velocity is dependent. Every point-coincidence block of the child is
//! `B^d = ∓I` (its inverse is `∓I`, no factorization), so the three point rows give
//! `v_c = v_p + ω_p × ℓ_p − ω_c × ℓ_c` directly. The angular rows are block-triangular
//! below them: they only involve the relative angular velocity, which the joint's free
//! rotation rates parametrize explicitly (`ω_c = ω_p + σ Σ e_k θ̇_k`, world components).
//! Translational joints (prismatic, cylindrical, planar) replace the point rows by
//! `ṗ_b − ṗ_a − ω_a × d = σ Σ t_k ṡ_k`, the slide rates along the free directions.
//!
//! | kind | `q̇` (in order) | rotation axes `e_k` | slide axes `t_k` | levers |
//! |---|---|---|---|---|
//! | spherical | `w_c`: the child's own angular velocity, body components (the paper's choice, `X` has no angular part) | — | — | own points |
//! | revolute | θ̇ about `za` | `za` | — | own points |
//! | universal | θ̇₁ about `za`, θ̇₂ about `zb` | `za`, `zb` | — | own points |
//! | fixed | — | — | — | own points |
//! | prismatic | ṡ along `za` | — | `za` | both to `pb` |
//! | cylindrical | θ̇ about `za`, ṡ along `za` | `za` | `za` | both to `pb` |
//! | planar | θ̇ about `za`, ṡ₁ along `xa`, ṡ₂ along `ya` | `za` | `xa`, `ya` | both to `pb` |
//!
//! Rates are those of side b relative to side a (`σ = +1` when the child is side b, `−1`
//! when it is side a), measured in side a's joint frame, so they read the same whichever
//! side the tree calls the parent. The levers `ℓ` go from each body's mass centre to the
//! joint point: for the point joints each body's own attachment point; for the
//! translational joints both go to `pb`, the material point of side b.
//!
//! **Exactness.** With these relations every row of the joint kernels ([`crate::kernels::joints`])
//! vanishes on `S` and on `X u_p` identically, at *any* configuration, violated or not:
//! the point rows because `ṗ_c = ṗ_p` by construction, the dot-1 rows `e_a·e_b` because
//! the relative rotation is about an axis perpendicular to `e_a × e_b`, the dot-2 rows
//! `e_a·d` because `ḋ − ω_a × d` is along directions perpendicular to `e_a`. Hence
//! `B A = 0` to round-off (tested over random trees and configurations), and since
//! `B(q) A(q) ≡ 0`, differentiating along the motion gives `B κ = γ` for the kernels'
//! `γ` (also tested).
//!
//! The velocity-product term (derived by differentiating the relation at constant rates,
//! `ė = ω × e` for an axis fixed to its side, `ℓ̇ = ω × ℓ + Σ t ṡ` for a lever that
//! reaches the other body's point):
//!
//! ```text
//! κ_ω = σ Σ_k (ω_side(k) × e_k) θ̇_k                                  (world)
//! κ_v = −κ_ω × ℓ_c + ω_p × (ω_p × ℓ_p) − ω_c × (ω_c × ℓ_c) + 2 ω_a × σ Σ t_k ṡ_k
//! ```
//!
//! (spherical: `κ_ω = 0`, `κ_v = ω_p × (ω_p × ℓ_p) − ω_c × (ω_c × ℓ_c)`, notes C §1.4).
//!
//! # Position projection
//!
//! [`project`] moves the child (parent fixed) back onto the joint's position constraints:
//! the smallest rotation that restores the angular conditions (`zb ∥ za`; `za ⟂ zb`; or
//! the frames equal for prismatic and fixed joints), then a translation that restores the
//! point or line or plane condition. Applied root → leaf after each coordinate update it
//! keeps the tree constraints at round-off.
//!
//! # Who calls them
//!
//! Natural partitioning (`integrators::natural`) asks the system for each tree joint's
//! kernel and geometry ([`System::tree_joint`](crate::contract::system::System::tree_joint),
//! implemented alike by the interpreter and generated code) and calls [`tree_joint`] and
//! [`project`], which dispatch on the [`JointKernel`] to the per-kind functions
//! [`spherical`], [`revolute`], …, [`planar`].

// The blocks index several parallel arrays (rates, axes) with one counter.
#![allow(clippy::needless_range_loop)]

use nalgebra::{Matrix2, Matrix3, Quaternion, Vector3};

use crate::contract::math::{qconj, qmul, quat, skew, vec3};
use crate::contract::system::{JointGeom, JointKernel};
use crate::contract::system::{Pose, Twist, Wrench};

/// Whether the joint's position condition is a point coincidence (else a line or a plane
/// through `pa` on which `pb` slides).
fn is_point(kind: JointKernel) -> bool {
    matches!(
        kind,
        JointKernel::Spherical
            | JointKernel::Revolute
            | JointKernel::Universal
            | JointKernel::Fixed
    )
}

/// The null-space blocks of one tree joint at one configuration (see the module doc):
/// `u_c = X u_p + S q̇` with `X = [[I, xv], [0, xw]]`, plus what the rates and the
/// velocity-product term need. Filled by [`tree_joint`] or one of the per-kind functions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeJointKin {
    /// Independent rates (columns of `S`).
    pub dof: usize,
    /// `+1` when the child is side b, `−1` when it is side a.
    pub sigma: f64,
    /// Spherical joint: the rates are the child's own angular velocity and `xw = 0`.
    pub absolute: bool,
    /// `v_c` gets `v_p + xv w_p`.
    pub xv: Matrix3<f64>,
    /// `w_c` gets `xw w_p`.
    pub xw: Matrix3<f64>,
    /// Columns of `S`: `[v (world), w (child body)]`; the first `dof` are used. A tree
    /// joint has at most 3 rates; `dof == 6` (a free root) means `S = I₆`
    /// ([`TreeJointKin::cols`]).
    pub s: [[f64; 6]; 3],
    /// Lever from the parent's mass centre to the joint point (world).
    pub lever_p: Vector3<f64>,
    /// Lever from the child's mass centre to the joint point (world).
    pub lever_c: Vector3<f64>,
    /// Rotation axes (world), the first `nrot` used.
    pub rot: [Vector3<f64>; 2],
    /// Whether each rotation axis is fixed to side a (else to side b).
    pub rot_on_a: [bool; 2],
    /// Number of rotation axes.
    pub nrot: usize,
    /// Slide axes (world, fixed to side a), the first `ntrans` used.
    pub trans: [Vector3<f64>; 2],
    /// Number of slide axes.
    pub ntrans: usize,
}

/// The columns of `S = I₆` (a free root).
const IDENT6: [[f64; 6]; 6] = {
    let mut m = [[0.0; 6]; 6];
    let mut i = 0;
    while i < 6 {
        m[i][i] = 1.0;
        i += 1;
    }
    m
};

impl Default for TreeJointKin {
    fn default() -> Self {
        TreeJointKin {
            dof: 0,
            sigma: 1.0,
            absolute: false,
            xv: Matrix3::zeros(),
            xw: Matrix3::identity(),
            s: [[0.0; 6]; 3],
            lever_p: Vector3::zeros(),
            lever_c: Vector3::zeros(),
            rot: [Vector3::zeros(); 2],
            rot_on_a: [true; 2],
            nrot: 0,
            trans: [Vector3::zeros(); 2],
            ntrans: 0,
        }
    }
}

impl TreeJointKin {
    /// The columns of `S` (all of them: `dof` columns, `I₆` for a free root).
    #[inline]
    pub fn cols(&self) -> &[[f64; 6]] {
        if self.dof == 6 {
            &IDENT6
        } else {
            &self.s[..self.dof]
        }
    }

    /// `X u_p`: the child's twist when every rate is zero.
    #[inline]
    pub fn transport(&self, up: &Twist) -> Twist {
        Twist {
            v: up.v + self.xv * up.w,
            w: self.xw * up.w,
        }
    }

    /// `Xᵀ f`: a generalized force on the child seen by the parent (force world, torque
    /// body, dual to [`Twist`]).
    #[inline]
    pub fn transport_t(&self, f: &Wrench) -> Wrench {
        Wrench {
            f: f.f,
            t: self.xv.tr_mul(&f.f) + self.xw.tr_mul(&f.t),
        }
    }

    /// `S x` for the first `dof` entries of `x`.
    #[inline]
    pub fn s_mul(&self, x: &[f64]) -> Twist {
        let mut o = [0.0; 6];
        for (k, col) in self.cols().iter().enumerate() {
            for i in 0..6 {
                o[i] += col[i] * x[k];
            }
        }
        Twist {
            v: Vector3::new(o[0], o[1], o[2]),
            w: Vector3::new(o[3], o[4], o[5]),
        }
    }

    /// `Sᵀ f` into the first `dof` entries of `out`.
    #[inline]
    pub fn s_t(&self, f: &Wrench, out: &mut [f64]) {
        let g = [f.f.x, f.f.y, f.f.z, f.t.x, f.t.y, f.t.z];
        for (k, col) in self.cols().iter().enumerate() {
            out[k] = (0..6).map(|i| col[i] * g[i]).sum();
        }
    }

    /// `X u_p + S q̇`.
    #[inline]
    pub fn forward(&self, up: &Twist, qd: &[f64]) -> Twist {
        let t = self.transport(up);
        let s = self.s_mul(qd);
        Twist {
            v: t.v + s.v,
            w: t.w + s.w,
        }
    }

    /// The joint rates of the twists `up`, `uc` (exact when `uc = X up + S q̇`; otherwise
    /// the rates of the relative motion projected on the joint's free directions), with
    /// `cp`, `cc` the parent's and the child's rotations (body → world) at which the
    /// blocks were built. Entries beyond `dof` are zero.
    pub fn rates(&self, cp: &Matrix3<f64>, cc: &Matrix3<f64>, up: &Twist, uc: &Twist) -> [f64; 6] {
        let mut out = [0.0; 6];
        if self.absolute {
            out[..3].copy_from_slice(uc.w.as_slice());
            return out;
        }
        let (wp, wc) = (cp * up.w, cc * uc.w);
        let wrel = (wc - wp) * self.sigma;
        match self.nrot {
            0 => {}
            1 => out[0] = self.rot[0].dot(&wrel),
            _ => {
                // dual basis of the two axes (they are perpendicular when the joint holds)
                let (e1, e2) = (&self.rot[0], &self.rot[1]);
                let g = Matrix2::new(e1.dot(e1), e1.dot(e2), e1.dot(e2), e2.dot(e2));
                let r = nalgebra::Vector2::new(e1.dot(&wrel), e2.dot(&wrel));
                let x = g.try_inverse().map_or(r, |gi| gi * r);
                out[0] = x[0];
                out[1] = x[1];
            }
        }
        if self.ntrans > 0 {
            let vrel =
                (uc.v + wc.cross(&self.lever_c) - up.v - wp.cross(&self.lever_p)) * self.sigma;
            for k in 0..self.ntrans {
                out[self.nrot + k] = self.trans[k].dot(&vrel);
            }
        }
        out
    }

    /// The velocity-product term `κ = Ȧq̇` (child acceleration with zero `q̈`, relative to
    /// the transported parent acceleration) at the twists `up`, `uc` with rates `qd`
    /// (from [`TreeJointKin::rates`]); `cp`, `cc` as there.
    pub fn kappa(
        &self,
        cp: &Matrix3<f64>,
        cc: &Matrix3<f64>,
        up: &Twist,
        uc: &Twist,
        qd: &[f64; 6],
    ) -> Twist {
        let (wp, wc) = (cp * up.w, cc * uc.w);
        let centripetal = wp.cross(&wp.cross(&self.lever_p)) - wc.cross(&wc.cross(&self.lever_c));
        if self.absolute {
            return Twist {
                v: centripetal,
                w: Vector3::zeros(),
            };
        }
        let (wa, wb) = if self.sigma > 0.0 { (wp, wc) } else { (wc, wp) };
        let mut kw = Vector3::zeros();
        for k in 0..self.nrot {
            let w_side = if self.rot_on_a[k] { &wa } else { &wb };
            kw += w_side.cross(&self.rot[k]) * qd[k];
        }
        kw *= self.sigma;
        let mut slide = Vector3::zeros();
        for k in 0..self.ntrans {
            slide += self.trans[k] * qd[self.nrot + k];
        }
        let kv = -kw.cross(&self.lever_c) + centripetal + 2.0 * self.sigma * wa.cross(&slide);
        Twist {
            v: kv,
            w: cc.tr_mul(&kw),
        }
    }

    /// Fill `xv`, `xw` and `s` from the levers and axes (`cp`, `cc`: the parent's and the
    /// child's rotations).
    #[inline]
    fn build(&mut self, cp: &Matrix3<f64>, cc: &Matrix3<f64>) {
        if self.absolute {
            self.xv = -skew(&self.lever_p) * cp;
            self.xw = Matrix3::zeros();
            let sv = skew(&self.lever_c) * cc;
            for k in 0..3 {
                let mut col = [0.0; 6];
                for i in 0..3 {
                    col[i] = sv[(i, k)];
                }
                col[3 + k] = 1.0;
                self.s[k] = col;
            }
            self.dof = 3;
            return;
        }
        self.xv = -skew(&(self.lever_p - self.lever_c)) * cp;
        self.xw = cc.tr_mul(cp);
        let sg = self.sigma;
        for k in 0..self.nrot {
            let e = self.rot[k];
            let v = self.lever_c.cross(&e) * sg;
            let w = cc.tr_mul(&e) * sg;
            self.s[k] = [v.x, v.y, v.z, w.x, w.y, w.z];
        }
        for k in 0..self.ntrans {
            let t = self.trans[k] * sg;
            self.s[self.nrot + k] = [t.x, t.y, t.z, 0.0, 0.0, 0.0];
        }
        self.dof = self.nrot + self.ntrans;
    }
}

/// The sides `(a, b)` of a joint from its parent and child.
#[inline]
fn sides<'a>(child_is_b: bool, parent: &'a Pose, child: &'a Pose) -> (&'a Pose, &'a Pose) {
    if child_is_b {
        (parent, child)
    } else {
        (child, parent)
    }
}

/// Common set-up: rotations, sign, levers.
#[inline]
fn frame(
    g: &JointGeom,
    point: bool,
    child_is_b: bool,
    parent: &Pose,
    child: &Pose,
    out: &mut TreeJointKin,
) {
    let (a, b) = sides(child_is_b, parent, child);
    let sa = a.c * vec3(&g.pa);
    let sb = b.c * vec3(&g.pb);
    let (la, lb) = if point {
        (sa, sb)
    } else {
        (b.r + sb - a.r, sb)
    };
    out.sigma = if child_is_b { 1.0 } else { -1.0 };
    out.absolute = false;
    (out.lever_p, out.lever_c) = if child_is_b { (la, lb) } else { (lb, la) };
    out.nrot = 0;
    out.ntrans = 0;
}

/// Axis `k` of side a's joint frame in world components.
#[inline]
fn axis_a(g: &JointGeom, child_is_b: bool, parent: &Pose, child: &Pose, k: usize) -> Vector3<f64> {
    sides(child_is_b, parent, child).0.c * vec3(&g.fa[k])
}

/// Axis `k` of side b's joint frame in world components.
#[inline]
fn axis_b(g: &JointGeom, child_is_b: bool, parent: &Pose, child: &Pose, k: usize) -> Vector3<f64> {
    sides(child_is_b, parent, child).1.c * vec3(&g.fb[k])
}

/// Spherical joint blocks: `q̇ = w_c` (the paper's choice).
pub fn spherical(
    g: &JointGeom,
    child_is_b: bool,
    parent: &Pose,
    child: &Pose,
    out: &mut TreeJointKin,
) {
    frame(g, true, child_is_b, parent, child, out);
    out.absolute = true;
    out.build(&parent.c, &child.c);
}

/// Revolute joint blocks: `q̇ = θ̇` about `za`.
pub fn revolute(
    g: &JointGeom,
    child_is_b: bool,
    parent: &Pose,
    child: &Pose,
    out: &mut TreeJointKin,
) {
    frame(g, true, child_is_b, parent, child, out);
    out.rot[0] = axis_a(g, child_is_b, parent, child, 2);
    out.rot_on_a[0] = true;
    out.nrot = 1;
    out.build(&parent.c, &child.c);
}

/// Universal joint blocks: `q̇ = (θ̇₁ about za, θ̇₂ about zb)`.
pub fn universal(
    g: &JointGeom,
    child_is_b: bool,
    parent: &Pose,
    child: &Pose,
    out: &mut TreeJointKin,
) {
    frame(g, true, child_is_b, parent, child, out);
    out.rot[0] = axis_a(g, child_is_b, parent, child, 2);
    out.rot[1] = axis_b(g, child_is_b, parent, child, 2);
    out.rot_on_a = [true, false];
    out.nrot = 2;
    out.build(&parent.c, &child.c);
}

/// Fixed joint blocks: no rates.
pub fn fixed(g: &JointGeom, child_is_b: bool, parent: &Pose, child: &Pose, out: &mut TreeJointKin) {
    frame(g, true, child_is_b, parent, child, out);
    out.build(&parent.c, &child.c);
}

/// Prismatic joint blocks: `q̇ = ṡ` along `za`.
pub fn prismatic(
    g: &JointGeom,
    child_is_b: bool,
    parent: &Pose,
    child: &Pose,
    out: &mut TreeJointKin,
) {
    frame(g, false, child_is_b, parent, child, out);
    out.trans[0] = axis_a(g, child_is_b, parent, child, 2);
    out.ntrans = 1;
    out.build(&parent.c, &child.c);
}

/// Cylindrical joint blocks: `q̇ = (θ̇ about za, ṡ along za)`.
pub fn cylindrical(
    g: &JointGeom,
    child_is_b: bool,
    parent: &Pose,
    child: &Pose,
    out: &mut TreeJointKin,
) {
    frame(g, false, child_is_b, parent, child, out);
    let za = axis_a(g, child_is_b, parent, child, 2);
    out.rot[0] = za;
    out.rot_on_a[0] = true;
    out.nrot = 1;
    out.trans[0] = za;
    out.ntrans = 1;
    out.build(&parent.c, &child.c);
}

/// Planar joint blocks: `q̇ = (θ̇ about za, ṡ₁ along xa, ṡ₂ along ya)`.
pub fn planar(
    g: &JointGeom,
    child_is_b: bool,
    parent: &Pose,
    child: &Pose,
    out: &mut TreeJointKin,
) {
    frame(g, false, child_is_b, parent, child, out);
    out.rot[0] = axis_a(g, child_is_b, parent, child, 2);
    out.rot_on_a[0] = true;
    out.nrot = 1;
    out.trans[0] = axis_a(g, child_is_b, parent, child, 0);
    out.trans[1] = axis_a(g, child_is_b, parent, child, 1);
    out.ntrans = 2;
    out.build(&parent.c, &child.c);
}

/// The blocks of a tree joint of kind `kind` (dispatches to the per-kind functions).
pub fn tree_joint(
    kind: JointKernel,
    g: &JointGeom,
    child_is_b: bool,
    parent: &Pose,
    child: &Pose,
    out: &mut TreeJointKin,
) {
    match kind {
        JointKernel::Spherical => spherical(g, child_is_b, parent, child, out),
        JointKernel::Revolute => revolute(g, child_is_b, parent, child, out),
        JointKernel::Prismatic => prismatic(g, child_is_b, parent, child, out),
        JointKernel::Cylindrical => cylindrical(g, child_is_b, parent, child, out),
        JointKernel::Universal => universal(g, child_is_b, parent, child, out),
        JointKernel::Fixed => fixed(g, child_is_b, parent, child, out),
        JointKernel::Planar => planar(g, child_is_b, parent, child, out),
        other => unreachable!(
            "{} is not a tree joint kind: natural partitioning builds its tree from \
             JointKernel::is_tree joints only",
            other.keyword()
        ),
    }
}

/// The unit quaternion of the smallest rotation taking the unit vector `u` to `w`
/// (`u·w > −1`).
#[inline]
fn min_rotation(u: &Vector3<f64>, w: &Vector3<f64>) -> Quaternion<f64> {
    let k = u.cross(w);
    let q = Quaternion::new(1.0 + u.dot(w), k.x, k.y, k.z);
    let n = q.norm();
    if n > 0.0 && n.is_finite() {
        q / n
    } else {
        Quaternion::identity()
    }
}

/// Rotate `pose` by the world rotation `r` (`q ← r ⊗ q`).
#[inline]
fn rotate_world(pose: &mut Pose, r: &Quaternion<f64>) {
    pose.set_q(qmul(r, &pose.q));
}

/// Move the child of a tree joint of kind `kind` (parent fixed) back onto the joint's
/// position constraints (see the module doc). The result satisfies the kernel rows to
/// round-off when the violation was small.
pub fn project(
    kind: JointKernel,
    g: &JointGeom,
    child_is_b: bool,
    parent: &Pose,
    child: &mut Pose,
) {
    // Orientation.
    match kind {
        JointKernel::Spherical => {}
        JointKernel::Revolute | JointKernel::Cylindrical | JointKernel::Planar => {
            let zp = parent.c * vec3(if child_is_b { &g.fa[2] } else { &g.fb[2] });
            let zc = child.c * vec3(if child_is_b { &g.fb[2] } else { &g.fa[2] });
            rotate_world(child, &min_rotation(&zc, &zp));
        }
        JointKernel::Universal => {
            let zp = parent.c * vec3(if child_is_b { &g.fa[2] } else { &g.fb[2] });
            let zc = child.c * vec3(if child_is_b { &g.fb[2] } else { &g.fa[2] });
            let t = zc - zp * zp.dot(&zc);
            let n = t.norm();
            if n > 0.0 {
                rotate_world(child, &min_rotation(&zc, &(t / n)));
            }
        }
        JointKernel::Prismatic | JointKernel::Fixed => {
            // world joint frames equal: q_b ⊗ qb = q_a ⊗ qa
            let (qa, qb) = (quat(g.qa), quat(g.qb));
            let target = if child_is_b {
                qmul(&qmul(&parent.q, &qa), &qconj(&qb))
            } else {
                qmul(&qmul(&parent.q, &qb), &qconj(&qa))
            };
            // keep the hemisphere of the current quaternion (continuous output)
            let target = if target.dot(&child.q) < 0.0 {
                -target
            } else {
                target
            };
            child.set_q(target);
        }
        other => unreachable!("{} is not a tree joint kind", other.keyword()),
    }
    // Position.
    let (a, b) = sides(child_is_b, parent, child);
    let pa = a.point(&vec3(&g.pa));
    let pb = b.point(&vec3(&g.pb));
    let delta = if is_point(kind) {
        // child point onto parent point
        if child_is_b {
            pa - pb
        } else {
            pb - pa
        }
    } else {
        let d = pb - pa;
        let mut off = Vector3::zeros();
        let along: &[usize] = if kind == JointKernel::Planar {
            &[2]
        } else {
            &[0, 1]
        };
        for &k in along {
            let e = a.c * vec3(&g.fa[k]);
            off += e * e.dot(&d);
        }
        // remove the off-line (off-plane) part of d = pb − pa by moving the child
        if child_is_b {
            -off
        } else {
            off
        }
    };
    child.r += delta;
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::contract::math::axis_angle;
    use crate::contract::system::{ConstraintEval, Need, RowJac};
    use crate::kernels::joints::{self, JointOut};
    use crate::linalg::testutil::Rng;

    pub(crate) const KINDS: [JointKernel; 7] = JointKernel::TREE;

    pub(crate) fn rvec(rng: &mut Rng, s: f64) -> Vector3<f64> {
        Vector3::new(rng.normal(), rng.normal(), rng.normal()) * s
    }

    pub(crate) fn rquat(rng: &mut Rng) -> Quaternion<f64> {
        axis_angle(&rvec(rng, 1.0), 3.0 * rng.uniform())
    }

    /// A random joint geometry (points, frames).
    pub(crate) fn random_geom(rng: &mut Rng) -> JointGeom {
        let fa = rquat(rng);
        let fb = rquat(rng);
        let a = crate::contract::scene::Attachment {
            body: crate::contract::scene::BodyRef::Body(0),
            point: rvec(rng, 0.5).into(),
            frame: crate::contract::math::quat_array(&fa),
        };
        let b = crate::contract::scene::Attachment {
            body: crate::contract::scene::BodyRef::Body(1),
            point: rvec(rng, 0.5).into(),
            frame: crate::contract::math::quat_array(&fb),
        };
        JointGeom::new(&a, &b, 0.0)
    }

    /// The kernel rows of a tree-eligible joint.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn kernel(
        kind: JointKernel,
        g: &JointGeom,
        pa: &Pose,
        pb: &Pose,
        ta: &Twist,
        tb: &Twist,
        ev: &mut ConstraintEval,
        first: usize,
    ) -> usize {
        let rows = 6 - kind.tree_dof().unwrap();
        let o = JointOut::new(ev, first, rows);
        let n = Need::ALL;
        match kind {
            JointKernel::Spherical => joints::spherical(g, pa, pb, ta, tb, n, o),
            JointKernel::Revolute => joints::revolute(g, pa, pb, ta, tb, n, o),
            JointKernel::Prismatic => joints::prismatic(g, pa, pb, ta, tb, n, o),
            JointKernel::Cylindrical => joints::cylindrical(g, pa, pb, ta, tb, n, o),
            JointKernel::Universal => joints::universal(g, pa, pb, ta, tb, n, o),
            JointKernel::Fixed => joints::fixed(g, pa, pb, ta, tb, n, o),
            JointKernel::Planar => joints::planar(g, pa, pb, ta, tb, n, o),
            other => unreachable!("{other:?} is not a tree kind"),
        }
        rows
    }

    fn dot6(r: &[f64; 6], t: &Twist) -> f64 {
        r[0] * t.v.x + r[1] * t.v.y + r[2] * t.v.z + r[3] * t.w.x + r[4] * t.w.y + r[5] * t.w.z
    }

    fn row_dot(j: &RowJac, child_is_b: bool, up: &Twist, uc: &Twist, ground: bool) -> f64 {
        let (ua, ub) = if child_is_b { (up, uc) } else { (uc, up) };
        let (ga, gb) = if child_is_b {
            (ground, false)
        } else {
            (false, ground)
        };
        (if ga { 0.0 } else { dot6(&j.a, ua) }) + (if gb { 0.0 } else { dot6(&j.b, ub) })
    }

    /// One joint at a random (violated) configuration: the kernel rows vanish on `S` and
    /// on `X u_p` (B A = 0), the rates are recovered, and `B κ = γ`.
    fn check_joint(rng: &mut Rng, kind: JointKernel, child_is_b: bool, ground: bool) {
        let g = random_geom(rng);
        let parent = if ground {
            Pose::default()
        } else {
            Pose::new(rvec(rng, 1.0), rquat(rng))
        };
        let child = Pose::new(rvec(rng, 1.0), rquat(rng));
        let mut k = TreeJointKin::default();
        tree_joint(kind, &g, child_is_b, &parent, &child, &mut k);
        assert_eq!(k.dof, kind.tree_dof().unwrap());
        let up = if ground {
            Twist::default()
        } else {
            Twist {
                v: rvec(rng, 1.0),
                w: rvec(rng, 2.0),
            }
        };
        let mut qd = [0.0; 6];
        for x in qd.iter_mut().take(k.dof) {
            *x = rng.normal();
        }
        let uc = k.forward(&up, &qd);
        let (pa, pb, ta, tb) = if child_is_b {
            (&parent, &child, &up, &uc)
        } else {
            (&child, &parent, &uc, &up)
        };
        let mut ev = ConstraintEval::new(6);
        let rows = kernel(kind, &g, pa, pb, ta, tb, &mut ev, 0);
        let scale = 1.0 + up.v.norm() + up.w.norm() + uc.v.norm() + uc.w.norm();
        // B (X u_p + S q̇) = 0 for random u_p and q̇, and column by column for S.
        for r in 0..rows {
            let res = row_dot(&ev.jac[r], child_is_b, &up, &uc, ground);
            assert!(res.abs() < 1e-13 * scale, "{kind:?} row {r}: B u = {res:e}");
            for c in 0..k.dof {
                let mut e = [0.0; 6];
                e[c] = 1.0;
                let col = k.s_mul(&e);
                let res = row_dot(&ev.jac[r], child_is_b, &Twist::default(), &col, true);
                assert!(res.abs() < 1e-13, "{kind:?} row {r} col {c}: B S = {res:e}");
            }
        }
        // The rates are recovered.
        let back = k.rates(&parent.c, &child.c, &up, &uc);
        for c in 0..k.dof {
            assert!(
                (back[c] - qd[c]).abs() < 1e-12 * scale,
                "{kind:?} rate {c}: {back:?} vs {qd:?}"
            );
        }
        // B κ = γ with a zero parent acceleration.
        let kap = k.kappa(&parent.c, &child.c, &up, &uc, &back);
        for r in 0..rows {
            let res = row_dot(&ev.jac[r], child_is_b, &Twist::default(), &kap, true);
            assert!(
                (res - ev.gamma[r]).abs() < 1e-12 * scale * scale,
                "{kind:?} row {r}: B κ = {res:e}, γ = {:e}",
                ev.gamma[r]
            );
        }
        // Transposes are adjoint: (X u)·f = u·(Xᵀ f), (S x)·f = x·(Sᵀ f).
        let f = Wrench {
            f: rvec(rng, 1.0),
            t: rvec(rng, 1.0),
        };
        let xu = k.transport(&up);
        let xtf = k.transport_t(&f);
        let l = xu.v.dot(&f.f) + xu.w.dot(&f.t);
        let r = up.v.dot(&xtf.f) + up.w.dot(&xtf.t);
        assert!((l - r).abs() < 1e-12 * scale * 10.0);
        let su = k.s_mul(&qd);
        let mut stf = [0.0; 6];
        k.s_t(&f, &mut stf);
        let l = su.v.dot(&f.f) + su.w.dot(&f.t);
        let r: f64 = (0..k.dof).map(|c| qd[c] * stf[c]).sum();
        assert!((l - r).abs() < 1e-12 * scale * 10.0);
    }

    #[test]
    fn blocks_annihilate_the_kernel_rows_at_random_configurations() {
        let mut rng = Rng::new(42);
        for trial in 0..200 {
            for kind in KINDS {
                check_joint(&mut rng, kind, trial % 2 == 0, trial % 5 == 0);
            }
        }
    }

    /// Projection from a perturbed configuration makes every kernel row vanish to
    /// round-off and moves the child by no more than the perturbation's order.
    #[test]
    fn projection_restores_the_joint() {
        let mut rng = Rng::new(7);
        for trial in 0..300 {
            for kind in KINDS {
                let child_is_b = trial % 2 == 0;
                let g = random_geom(&mut rng);
                let parent = if trial % 3 == 0 {
                    Pose::default()
                } else {
                    Pose::new(rvec(&mut rng, 1.0), rquat(&mut rng))
                };
                // an assembled child: project a random pose, then perturb by ~1e-4
                let mut child = Pose::new(rvec(&mut rng, 1.0), rquat(&mut rng));
                // assemble in two passes (large initial errors)
                for _ in 0..3 {
                    project(kind, &g, child_is_b, &parent, &mut child);
                }
                let exact = child;
                let mut pert = child;
                pert.r += rvec(&mut rng, 1e-4);
                pert.set_q(qmul(&axis_angle(&rvec(&mut rng, 1.0), 1e-4), &pert.q));
                project(kind, &g, child_is_b, &parent, &mut pert);
                let (pa, pb) = if child_is_b {
                    (&parent, &pert)
                } else {
                    (&pert, &parent)
                };
                let mut ev = ConstraintEval::new(6);
                let t = Twist::default();
                let rows = kernel(kind, &g, pa, pb, &t, &t, &mut ev, 0);
                for r in 0..rows {
                    assert!(
                        ev.phi[r].abs() < 1e-14,
                        "{kind:?} row {r}: Φ = {:e} after projection",
                        ev.phi[r]
                    );
                }
                assert!((pert.r - exact.r).norm() < 1e-3, "{kind:?}: moved far");
                assert!(
                    pert.q.dot(&exact.q).abs() > 1.0 - 1e-6,
                    "{kind:?}: turned far"
                );
            }
        }
    }
}
