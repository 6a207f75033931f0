//! The token emitter behind [`super::generate`].

use mbdc_runtime::compiled::{JointCombo, Mode, Plan, Spec, TermCombo, TermKind, UJoint, UTerm};
use mbdc_runtime::scene::{ForceFrame, Scene};
use mbdc_runtime::system::JointKernel;
use std::collections::HashSet;

use proc_macro2::{Ident, Literal, TokenStream, TokenTree};
use quote::{format_ident, quote};

use super::token_scan::{idents, param};
use super::{lit_hex, lit_usize, shape, SceneJson};

/// Per-kind geometry tables: (term kind, field name, element type).
const KIND_TABLES: [(TermKind, &str, &str); 6] = [
    (TermKind::Point, "point_rho", "[f64; 3]"),
    (TermKind::Spring, "springs", "forces::SpringGeom"),
    (TermKind::RotSpring, "rot_springs", "forces::RotSpringGeom"),
    (
        TermKind::SpherePlane,
        "sphere_planes",
        "contact::SpherePlane",
    ),
    (
        TermKind::SphereSphere,
        "sphere_spheres",
        "contact::SphereSphere",
    ),
    (TermKind::BoxPlane, "box_planes", "contact::BoxPlane"),
];

/// Expressions of the two sides of a joint or term: poses and twists.
struct Sides {
    pa: TokenStream,
    pb: TokenStream,
    ta: TokenStream,
    tb: TokenStream,
}

impl Sides {
    /// Constant body indices (unrolled).
    fn fixed(a: Option<usize>, b: Option<usize>) -> Sides {
        let p = |s: Option<usize>| match s {
            Some(i) => {
                let i = lit_usize(i);
                quote!(&pose[#i])
            }
            None => quote!(&self.ground_pose),
        };
        let t = |s: Option<usize>| match s {
            Some(i) => {
                let i = lit_usize(i);
                quote!(&twist[#i])
            }
            None => quote!(&self.ground_twist),
        };
        Sides {
            pa: p(a),
            pb: p(b),
            ta: t(a),
            tb: t(b),
        }
    }

    /// Body indices read from a table row `r` (tables).
    fn table(r: &TokenStream) -> Sides {
        Sides {
            pa: quote!(self.pose_of(#r.a, pose)),
            pb: quote!(self.pose_of(#r.b, pose)),
            ta: quote!(self.twist_of(#r.a, twist)),
            tb: quote!(self.twist_of(#r.b, twist)),
        }
    }
}

/// What the code generator needs to know about the data it reads.
struct Ctx<'a> {
    spec: &'a Spec,
    /// Some shape uses tables.
    tables: bool,
}

impl Ctx<'_> {
    /// A call of shape `s` at `x` with constants from offset `c` and tables from `tb`.
    fn call(&self, s: usize, x: TokenStream, c: TokenStream, tb: TokenStream) -> TokenStream {
        let f = format_ident!("f{}", s);
        let tbl = if self.tables {
            quote!(&self.tb[#tb..])
        } else {
            quote!(&[])
        };
        quote!(#f(#x, &self.c[#c..], #tbl))
    }

    /// Calls of the functions of an item whose constants start at `c` and tables at `tb`
    /// (expressions), offsetting each function by the counts of those before it.
    fn calls(
        &self,
        fns: &[usize],
        x: TokenStream,
        c: &TokenStream,
        tb: &TokenStream,
        fixed: Option<(usize, usize)>,
    ) -> Vec<TokenStream> {
        let mut out = Vec::new();
        let (mut dc, mut dt) = (0usize, 0usize);
        for &s in fns {
            let (co, to) = match fixed {
                Some((c0, t0)) => {
                    let (a, b) = (lit_usize(c0 + dc), lit_usize(t0 + dt));
                    (quote!(#a), quote!(#b))
                }
                None => (offset(c, dc), offset(tb, dt)),
            };
            out.push(self.call(s, x.clone(), co, to));
            let (nc, nt) = self.spec.shapes[s].counts();
            dc += nc;
            dt += nt;
        }
        out
    }
}

/// The kernel call of one row group.
#[allow(clippy::too_many_arguments)]
fn joint_call(
    cx: &Ctx<'_>,
    combo: &JointCombo,
    s: &Sides,
    geom: TokenStream,
    lock_angle: TokenStream,
    first: TokenStream,
    rows: TokenStream,
    offsets: (TokenStream, TokenStream),
    fixed: Option<(usize, usize)>,
) -> TokenStream {
    let Sides { pa, pb, ta, tb } = s;
    let o = quote!(JointOut::new(out, #first, #rows));
    let f = format_ident!("{}", combo.kernel.function());
    let (c, t) = offsets;
    match combo.kernel {
        JointKernel::DriveAngle | JointKernel::DriveDisplacement => {
            let v = &cx.calls(&combo.fns, quote!(t), &c, &t, fixed)[0];
            quote!(joints::#f(#geom, #v, #pa, #pb, #ta, #tb, need, #o);)
        }
        JointKernel::PointVelocity => {
            let v = cx.calls(&combo.fns, quote!(t), &c, &t, fixed);
            quote!(joints::#f(#geom, [#(#v),*], #pa, #pb, #ta, #tb, need, #o);)
        }
        JointKernel::Curve => {
            let v = &cx.calls(&combo.fns, quote!(x), &c, &t, fixed)[0];
            quote!(joints::#f(#geom, |x| #v, #pa, #pb, #ta, #tb, need, #o);)
        }
        JointKernel::Lock => {
            quote!(joints::#f(#geom, Jet2::constant(#lock_angle), #pa, #pb, #ta, #tb, need, #o);)
        }
        _ => quote!(joints::#f(#geom, #pa, #pb, #ta, #tb, need, #o);),
    }
}

/// How to add a pair of wrenches to the sides.
fn add_pair(a: Option<usize>, b: Option<usize>, fixed: bool, r: &TokenStream) -> TokenStream {
    if !fixed {
        return quote!(Self::add_pair(out, #r.a, #r.b, w););
    }
    let mut v = Vec::new();
    if let Some(i) = a {
        let i = lit_usize(i);
        v.push(quote!(forces::add_wrench(&mut out[#i], &w.0);));
    }
    if let Some(i) = b {
        let i = lit_usize(i);
        v.push(quote!(forces::add_wrench(&mut out[#i], &w.1);));
    }
    quote!(#(#v)*)
}

/// The `applied` code of one force term (`r`: the table row in tables mode).
#[allow(clippy::too_many_arguments)]
fn term_applied(
    cx: &Ctx<'_>,
    combo: &TermCombo,
    s: &Sides,
    body: TokenStream,
    index: TokenStream,
    offsets: (TokenStream, TokenStream),
    fixed: Option<(usize, usize, Option<usize>, Option<usize>)>,
    r: &TokenStream,
) -> TokenStream {
    let Sides { pa, pb, ta, tb } = s;
    let (c, t) = offsets;
    let fx = fixed.map(|(c0, t0, _, _)| (c0, t0));
    let pair = |a, b| add_pair(a, b, fixed.is_some(), r);
    let (fa, fb) = fixed.map_or((None, None), |(_, _, a, b)| (a, b));
    match combo.kind {
        TermKind::Point | TermKind::Torque => {
            let v = cx.calls(&combo.fns, quote!(t), &c, &t, fx);
            let (v0, v1, v2) = (&v[0], &v[1], &v[2]);
            let val = quote!(Vector3::new(#v0.v, #v1.v, #v2.v));
            let w = match (combo.kind, combo.frame) {
                (TermKind::Point, Some(ForceFrame::Body)) => {
                    quote!(forces::point_force_body(&pose[#body], &self.point_rho[#index], &#val))
                }
                (TermKind::Point, _) => {
                    quote!(forces::point_force_world(&pose[#body], &self.point_rho[#index], &#val))
                }
                (_, Some(ForceFrame::Body)) => quote!(forces::torque_body(&#val)),
                _ => quote!(forces::torque_world(&pose[#body], &#val)),
            };
            quote! {
                let w = #w;
                forces::add_wrench(&mut out[#body], &w);
            }
        }
        TermKind::Spring => {
            let p = pair(fa, fb);
            quote! { let w = forces::spring(&self.springs[#index], #pa, #pb, #ta, #tb); #p }
        }
        TermKind::RotSpring => {
            let p = pair(fa, fb);
            quote! { let w = forces::rotational_spring(&self.rot_springs[#index], #pa, #pb, #ta, #tb); #p }
        }
        TermKind::SpherePlane => {
            let p = pair(fa, fb);
            quote! { let w = contact::sphere_plane(&self.sphere_planes[#index], #pa, #ta, #pb, #tb); #p }
        }
        TermKind::SphereSphere => {
            let p = pair(fa, fb);
            quote! { let w = contact::sphere_sphere(&self.sphere_spheres[#index], #pa, #ta, #pb, #tb); #p }
        }
        TermKind::BoxPlane => {
            let p = pair(fa, fb);
            quote! { let w = contact::box_plane(&self.box_planes[#index], #pa, #ta, #pb, #tb); #p }
        }
    }
}

/// The potential energy of one term, `None` for a term without one (a point force or a
/// torque).
fn term_energy(combo: &TermCombo, s: &Sides, index: TokenStream) -> Option<TokenStream> {
    let Sides { pa, pb, .. } = s;
    Some(match combo.kind {
        TermKind::Point | TermKind::Torque => return None,
        TermKind::Spring => quote!(forces::spring_energy(&self.springs[#index], #pa, #pb)),
        TermKind::RotSpring => {
            quote!(forces::rotational_spring_energy(&self.rot_springs[#index], #pa, #pb))
        }
        TermKind::SpherePlane => {
            quote!(contact::sphere_plane_energy(&self.sphere_planes[#index], #pa, #pb))
        }
        TermKind::SphereSphere => {
            quote!(contact::sphere_sphere_energy(&self.sphere_spheres[#index], #pa, #pb))
        }
        TermKind::BoxPlane => quote!(contact::box_plane_energy(&self.box_planes[#index], #pa, #pb)),
    })
}

/// `base + d`, or `base` for `d = 0` (no `x + 0` for `clippy::identity_op`).
fn offset(base: &TokenStream, d: usize) -> TokenStream {
    if d == 0 {
        base.clone()
    } else {
        let d = lit_usize(d);
        quote!(#base + #d)
    }
}

/// The dispatch of a table row on its combination: one `if` for a single arm (a `match`
/// with one arm and `_ => {}` is `clippy::single_match`), a `match` for several, nothing for
/// none.
fn dispatch(scrutinee: TokenStream, arms: Vec<(Literal, TokenStream)>) -> TokenStream {
    match arms.as_slice() {
        [] => quote!(),
        [(i, body)] => quote!(if #scrutinee == #i { #body }),
        _ => {
            let arms = arms.iter().map(|(i, body)| quote!(#i => { #body }));
            quote! {
                match #scrutinee {
                    #(#arms)*
                    _ => {}
                }
            }
        }
    }
}

/// The identifiers of `ts` that follow `prefix` (a sequence of identifiers and
/// punctuation, such as `self .`) or precede `suffix` (such as `::`), at any depth.
fn adjacent(ts: &TokenStream, prefix: &str, suffix: &str) -> HashSet<String> {
    fn flat(ts: &TokenStream, out: &mut Vec<Vec<String>>) {
        let mut level = Vec::new();
        for t in ts.clone() {
            match t {
                TokenTree::Group(g) => {
                    flat(&g.stream(), out);
                    level.push(String::from("{group}"));
                }
                TokenTree::Ident(i) => level.push(i.to_string()),
                TokenTree::Punct(p) => level.push(p.as_char().to_string()),
                TokenTree::Literal(l) => level.push(l.to_string()),
            }
        }
        out.push(level);
    }
    let (pre, suf): (Vec<String>, Vec<String>) = (
        prefix.split_whitespace().map(String::from).collect(),
        suffix.split_whitespace().map(String::from).collect(),
    );
    let mut levels = Vec::new();
    flat(ts, &mut levels);
    let mut out = HashSet::new();
    for level in &levels {
        for k in pre.len()..level.len() {
            let before = &level[k - pre.len()..k];
            let after = level.get(k + 1..k + 1 + suf.len());
            if before == pre.as_slice() && after.is_some_and(|a| a == suf.as_slice()) {
                out.insert(level[k].clone());
            }
        }
    }
    out
}

fn ty(s: &str) -> TokenStream {
    s.parse().unwrap_or_default()
}

/// The whole file.
///
/// The code is generated clean — it compiles without warnings under `#![deny(warnings)]`
/// and `#![deny(clippy::all)]` in the crate that includes it (`tests/generated_lints.rs`
/// checks) — so that the module carries no blanket `allow`: every helper, field, import and
/// parameter name is decided from what the bodies actually use (see [`idents`](super::token_scan::idents),
/// [`adjacent`]), not from a second copy of the conditions that produced the bodies.
pub fn file(
    plan: &Plan,
    scene: &Scene,
    module: &str,
    json: &SceneJson,
    scene_json: &str,
    effects: &[&str],
) -> TokenStream {
    let spec = &plan.spec;
    let unrolled = spec.unrolled.as_ref();
    let cx = Ctx {
        spec,
        tables: spec.shapes.iter().any(|s| s.uses_tables()),
    };
    let module_ident = format_ident!("{}", module);
    let name = &scene.name;
    let key = lit_hex(plan.key());
    let mode_tok = match spec.mode {
        Mode::Unrolled => quote!(Mode::Unrolled),
        Mode::Tables => quote!(Mode::Tables),
    };

    // ---- docs
    let eff = if effects.is_empty() {
        "none".to_string()
    } else {
        effects.join(", ")
    };
    let doc = [
        format!(
            " Generated by mbdc {} from the scene `{name}`. Do not edit: regenerate.",
            env!("CARGO_PKG_VERSION")
        ),
        String::new(),
        format!(
            " Effects: {eff}. Layout: {:?}. Structure key: {:016x}.",
            spec.mode,
            plan.key()
        ),
        String::new(),
        " [`Model`] implements `System`: run it with `mbdc_runtime::run` or any integrator."
            .to_string(),
    ];

    // ---- constants
    let json_tok = match json {
        SceneJson::Inline => {
            let l = Literal::string(scene_json);
            quote!(#l)
        }
        SceneJson::Include(p) => quote!(include_str!(#p)),
    };
    let mut consts = vec![quote! {
        /// The scene's name.
        pub const NAME: &str = #name;
        /// The structure key this code was generated for.
        pub const KEY: u64 = #key;
        /// The scene the code was generated from (JSON).
        pub const SCENE_JSON: &str = #json_tok;
    }];
    if let Some(u) = unrolled {
        let (nb, nr) = (lit_usize(u.bodies), lit_usize(u.rows));
        consts.push(quote! {
            /// Number of bodies.
            pub const BODIES: usize = #nb;
            /// Number of constraint rows.
            pub const ROWS: usize = #nr;
        });
    }

    // ---- fields and their initialisation from the plan: (name, declaration,
    // initialisation); only those the code reads are emitted (below).
    let mut fields: Vec<(&str, TokenStream, TokenStream)> = vec![
        (
            "layout",
            quote!(layout: Layout,),
            quote!(layout: plan.interp.layout().clone(),),
        ),
        (
            "pose0",
            quote!(pose0: Vec<Pose>,),
            quote!(pose0: plan.interp.initial().0.to_vec(),),
        ),
        (
            "twist0",
            quote!(twist0: Vec<Twist>,),
            quote!(twist0: plan.interp.initial().1.to_vec(),),
        ),
        (
            "ground_pose",
            quote!(ground_pose: Pose,),
            quote!(ground_pose: Pose::default(),),
        ),
        (
            "ground_twist",
            quote!(ground_twist: Twist,),
            quote!(ground_twist: Twist::default(),),
        ),
        (
            "velocity_forces",
            quote!(velocity_forces: bool,),
            quote!(velocity_forces: plan.interp.has_velocity_forces(),),
        ),
        (
            "state_forces",
            quote!(state_forces: bool,),
            quote!(state_forces: plan.interp.has_state_forces(),),
        ),
    ];
    let arr = |src: TokenStream| -> TokenStream { quote!(core::array::from_fn(|i| #src[i])) };
    if spec.gravity {
        fields.push((
            "g",
            quote!(g: Vector3<f64>,),
            quote!(g: Vector3::from(d.gravity),),
        ));
        fields.push(match unrolled {
            Some(u) => {
                let n = lit_usize(u.bodies);
                (
                    "m",
                    quote!(m: [f64; #n],),
                    quote!(m: core::array::from_fn(|i| plan.interp.layout().mass[i].m),),
                )
            }
            None => (
                "m",
                quote!(m: Vec<f64>,),
                quote!(m: plan.interp.layout().mass.iter().map(|m| m.m).collect(),),
            ),
        });
    }
    match unrolled {
        Some(u) => {
            if !u.joints.is_empty() {
                let n = lit_usize(u.joints.len());
                let a = arr(quote!(d.joints));
                fields.push(("j", quote!(j: [compiled::JointRow; #n],), quote!(j: #a,)));
            }
            if !spec.shapes.is_empty() {
                let n = lit_usize(u.consts);
                let a = arr(quote!(d.fns.c));
                fields.push(("c", quote!(c: [f64; #n],), quote!(c: #a,)));
            }
            for (kind, field, t) in KIND_TABLES.iter() {
                let n = u.per_kind[*kind as usize];
                if n > 0 {
                    let (f, t, nn) = (format_ident!("{}", field), ty(t), lit_usize(n));
                    let a = arr(quote!(d.#f));
                    fields.push((field, quote!(#f: [#t; #nn],), quote!(#f: #a,)));
                }
            }
        }
        None => {
            fields.push((
                "j",
                quote!(j: Vec<compiled::JointRow>,),
                quote!(j: d.joints,),
            ));
            fields.push((
                "terms",
                quote!(terms: Vec<compiled::TermRow>,),
                quote!(terms: d.terms,),
            ));
            if !spec.shapes.is_empty() {
                fields.push(("c", quote!(c: Vec<f64>,), quote!(c: d.fns.c,)));
            }
            for (kind, field, t) in KIND_TABLES.iter() {
                if spec.has_term(*kind) {
                    let (f, t) = (format_ident!("{}", field), ty(t));
                    fields.push((field, quote!(#f: Vec<#t>,), quote!(#f: d.#f,)));
                }
            }
        }
    }
    if cx.tables {
        fields.push(("tb", quote!(tb: Vec<Vec<[f64; 2]>>,), quote!(tb: d.fns.tb,)));
    }
    if spec.locks {
        fields.push((
            "locks",
            quote!(locks: Vec<mbdc_runtime::interp::Lock>,),
            quote!(locks: d.locks,),
        ));
    }

    // ---- shape functions
    let shape_items: Vec<TokenStream> = spec
        .shapes
        .iter()
        .enumerate()
        .map(|(i, s)| shape::item(i, s))
        .collect();

    // ---- applied, constraints, potential energy
    let gravity_applied = if spec.gravity {
        match unrolled {
            Some(u) => {
                let v: Vec<TokenStream> = (0..u.bodies)
                    .map(|i| {
                        let i = lit_usize(i);
                        quote!(out[#i] = forces::gravity(self.m[#i], &self.g);)
                    })
                    .collect();
                quote!(#(#v)*)
            }
            None => quote! {
                for (o, m) in out.iter_mut().zip(&self.m) {
                    *o = forces::gravity(*m, &self.g);
                }
            },
        }
    } else {
        quote!(out.iter_mut().for_each(|o| *o = Wrench::default());)
    };
    // The potential energy is summed from 0.0 in the interpreter's order. Its terms of
    // zero energy (point forces, torques) are left out rather than emitted as `e += 0.0`:
    // a sum started at +0.0 is never -0.0, so adding 0.0 never changes it and leaving it
    // out keeps the result bit-identical.
    let mut energies: Vec<TokenStream> = Vec::new();
    if spec.gravity {
        match unrolled {
            Some(u) => energies.extend((0..u.bodies).map(|i| {
                let i = lit_usize(i);
                quote!(e += forces::gravity_energy(self.m[#i], &self.g, &pose[#i]);)
            })),
            None => energies.push(quote! {
                for (p, m) in pose.iter().zip(&self.m) {
                    e += forces::gravity_energy(*m, &self.g, p);
                }
            }),
        }
    }

    let (constraints_body, applied_terms) = match unrolled {
        Some(u) => {
            let joints: Vec<TokenStream> = u
                .joints
                .iter()
                .enumerate()
                .map(|(k, j)| unrolled_joint(&cx, k, j))
                .collect();
            let terms: Vec<TokenStream> = u.terms.iter().map(|t| unrolled_term(&cx, t)).collect();
            energies.extend(u.terms.iter().filter_map(|t| {
                let s = Sides::fixed(t.a, t.b);
                let i = lit_usize(t.index);
                let e = term_energy(&spec.terms[t.combo], &s, quote!(#i))?;
                Some(quote!(e += #e;))
            }));
            (quote!(#(#joints)*), quote!(#(#terms)*))
        }
        None => {
            let e = quote!(e);
            let s = Sides::table(&e);
            let arms: Vec<(Literal, TokenStream)> = spec
                .joints
                .iter()
                .enumerate()
                .map(|(i, combo)| {
                    let call = joint_call(
                        &cx,
                        combo,
                        &s,
                        quote!(&e.geom),
                        quote!(e.lock_angle),
                        quote!(e.first),
                        quote!(e.rows),
                        (quote!(e.c), quote!(e.tb)),
                        None,
                    );
                    (lit_usize(i), call)
                })
                .collect();
            let constraints = if arms.is_empty() {
                quote!()
            } else {
                let d = dispatch(quote!(e.combo), arms);
                quote! {
                    for e in &self.j {
                        #d
                    }
                }
            };
            let r = quote!(r);
            let s = Sides::table(&r);
            let arms: Vec<(Literal, TokenStream)> = spec
                .terms
                .iter()
                .enumerate()
                .map(|(i, combo)| {
                    let code = term_applied(
                        &cx,
                        combo,
                        &s,
                        quote!(r.a.unwrap_or(0)),
                        quote!(r.index),
                        (quote!(r.c), quote!(r.tb)),
                        None,
                        &r,
                    );
                    (lit_usize(i), code)
                })
                .collect();
            let applied = if arms.is_empty() {
                quote!()
            } else {
                let d = dispatch(quote!(r.combo), arms);
                quote! {
                    for r in &self.terms {
                        #d
                    }
                }
            };
            let arms: Vec<TokenStream> = spec
                .terms
                .iter()
                .enumerate()
                .filter_map(|(i, combo)| {
                    let i = lit_usize(i);
                    let en = term_energy(combo, &s, quote!(r.index))?;
                    Some(quote!(#i => #en,))
                })
                .collect();
            if !arms.is_empty() {
                energies.push(quote! {
                    for r in &self.terms {
                        e += match r.combo {
                            #(#arms)*
                            _ => 0.0,
                        };
                    }
                });
            }
            (constraints, applied)
        }
    };
    // `let e = 0.0; e` would be `clippy::let_and_return`.
    let energy_body = if energies.is_empty() {
        quote!(0.0)
    } else {
        quote! {
            let mut e = 0.0;
            #(#energies)*
            e
        }
    };

    let update_locks = if spec.locks {
        quote! {
            fn update_locks(&self, pose: &[Pose], _twist: &[Twist], active: &mut [bool]) -> Option<usize> {
                let mut changed = None;
                for l in &self.locks {
                    if active[l.row] {
                        continue;
                    }
                    let th = forces::joint_angle(&l.geom, l.sign, self.pose_of(l.a, pose), self.pose_of(l.b, pose));
                    if (th - l.angle) * (l.theta0 - l.angle) <= 0.0 {
                        active[l.row] = true;
                        changed.get_or_insert(l.joint);
                    }
                }
                changed
            }
        }
    } else {
        quote!()
    };
    // The variant's name is the enum's own (`Debug` prints the bare variant name).
    let tree_kind = |k: JointKernel| -> Option<TokenStream> {
        k.is_tree().then(|| {
            let v = format_ident!("{}", format!("{k:?}"));
            quote!(JointKernel::#v)
        })
    };
    let has_tree = spec.joints.iter().any(|c| tree_kind(c.kernel).is_some());
    let tree_joint = if !has_tree {
        quote!()
    } else {
        let body = match unrolled {
            Some(u) => {
                let arms = u.joints.iter().enumerate().filter_map(|(i, j)| {
                    let k = tree_kind(spec.joints[j.combo].kernel)?;
                    let i = lit_usize(i);
                    Some(quote!(#i => Some((#k, &self.j[#i].geom)),))
                });
                quote! {
                    match joint {
                        #(#arms)*
                        _ => None,
                    }
                }
            }
            None => {
                let arms = spec.joints.iter().enumerate().filter_map(|(i, c)| {
                    let k = tree_kind(c.kernel)?;
                    let i = lit_usize(i);
                    Some(quote!(#i => Some((#k, &e.geom)),))
                });
                quote! {
                    let e = self.j.get(joint)?;
                    match e.combo {
                        #(#arms)*
                        _ => None,
                    }
                }
            }
        };
        quote! {
            fn tree_joint(&self, joint: usize) -> Option<(JointKernel, &JointGeom)> {
                #body
            }
        }
    };

    // ---- meshes: each block's element loop, monomorphized for its kernel (kind and
    // quadrature variant); the kernels' numbers (material, thickness, B-bar flag, hourglass
    // coefficient) stay data in the layout
    let (mesh_items, mesh_kernels) = if spec.meshes.is_empty() {
        (quote!(), quote!())
    } else {
        let blocks = spec.meshes.iter().map(|b| {
            let k = format_ident!("{}", b.kernel());
            if b.plastic {
                quote!(BlockKernel::plastic::<#k>())
            } else {
                quote!(BlockKernel::elastic::<#k>())
            }
        });
        (
            quote! {
                /// The meshes' element loops, block after block: each block's kernel
                /// (elastic or plastic), monomorphized; its constants are in the layout.
                static MESH_KERNELS: BlockKernels = BlockKernels::new(&[#(#blocks),*]);
            },
            quote! {
                fn mesh_kernels(&self) -> Option<&dyn core::any::Any> {
                    Some(&MESH_KERNELS)
                }
            },
        )
    };

    // ---- beams: each element variant the beams use, monomorphized (undamped, damped); the
    // sections' constants and damping coefficients stay data in the layout
    let (beam_items, beam_kernels) = if spec.beams.is_empty() {
        (quote!(), quote!())
    } else {
        let variants = spec.beams.iter().map(|v| {
            let c = format_ident!("{}", v.constructor());
            quote!(BeamKernel::#c())
        });
        (
            quote! {
                /// The beams' element variants: each beam's elements run the one of its
                /// damping; its section constants are in the layout.
                static BEAM_KERNELS: BeamKernels = BeamKernels::new(&[#(#variants),*]);
            },
            quote! {
                fn beam_kernels(&self) -> Option<&dyn core::any::Any> {
                    Some(&BEAM_KERNELS)
                }
            },
        )
    };

    // ---- the `System` methods whose parameters depend on the scene: a parameter the body
    // does not read is named `_name`.
    let applied_body = quote!(#gravity_applied #applied_terms);
    let used = idents(&applied_body);
    let [t, pose, twist] = ["t", "pose", "twist"].map(|p| param(p, &used));
    let applied = quote! {
        #[inline]
        fn applied(&self, #t: f64, #pose: &[Pose], #twist: &[Twist], out: &mut [Wrench]) {
            #applied_body
        }
    };
    let used = idents(&constraints_body);
    let [t, pose, twist, need, out] =
        ["t", "pose", "twist", "need", "out"].map(|p| param(p, &used));
    let constraints = quote! {
        #[inline]
        fn constraints(&self, #t: f64, #pose: &[Pose], #twist: &[Twist], #need: Need, #out: &mut ConstraintEval) {
            #constraints_body
        }
    };
    let pose = param("pose", &idents(&energy_body));
    let potential_energy = quote! {
        fn potential_energy(&self, _t: f64, #pose: &[Pose]) -> f64 {
            #energy_body
        }
    };
    let system_impl = quote! {
        impl System for Model {
            #[inline]
            fn layout(&self) -> &Layout {
                &self.layout
            }

            fn initial_state(&self, pose: &mut [Pose], twist: &mut [Twist]) {
                pose.copy_from_slice(&self.pose0);
                twist.copy_from_slice(&self.twist0);
            }

            #applied

            #constraints

            #potential_energy

            #update_locks

            #tree_joint

            #mesh_kernels

            #beam_kernels

            fn has_velocity_forces(&self) -> bool {
                self.velocity_forces
            }

            fn has_state_forces(&self) -> bool {
                self.state_forces
            }
        }
    };

    // ---- helpers of the table layout and of locks, where called
    let called = idents(&system_impl);
    let mut helpers = Vec::new();
    if called.contains("pose_of") {
        helpers.push(quote! {
            #[inline]
            fn pose_of<'a>(&'a self, b: Option<usize>, pose: &'a [Pose]) -> &'a Pose {
                match b {
                    Some(i) => &pose[i],
                    None => &self.ground_pose,
                }
            }
        });
    }
    if called.contains("twist_of") {
        helpers.push(quote! {
            #[inline]
            fn twist_of<'a>(&'a self, b: Option<usize>, twist: &'a [Twist]) -> &'a Twist {
                match b {
                    Some(i) => &twist[i],
                    None => &self.ground_twist,
                }
            }
        });
    }
    if called.contains("add_pair") {
        helpers.push(quote! {
            #[inline]
            fn add_pair(out: &mut [Wrench], a: Option<usize>, b: Option<usize>, w: (Wrench, Wrench)) {
                if let Some(i) = a {
                    forces::add_wrench(&mut out[i], &w.0);
                }
                if let Some(i) = b {
                    forces::add_wrench(&mut out[i], &w.1);
                }
            }
        });
    }

    // ---- the fields the code reads (an unread field is `dead_code`)
    let read = adjacent(&quote!(#system_impl #(#helpers)*), "self .", "");
    fields.retain(|(f, _, _)| read.contains(*f));
    let (decls, inits): (Vec<TokenStream>, Vec<TokenStream>) =
        fields.into_iter().map(|(_, d, i)| (d, i)).unzip();
    let d_binding = if idents(&quote!(#(#inits)*)).contains("d") {
        quote!(let d = plan.data;)
    } else {
        quote!()
    };

    let mod_docs = doc.iter().map(|d| quote!(#![doc = #d]));
    let body = quote! {
        #(#consts)*

        #(#shape_items)*

        #mesh_items

        #beam_items

        /// The scene as a `System`: structure in code, numbers in the fields.
        #[derive(Clone, Debug)]
        pub struct Model {
            #(#decls)*
        }

        impl Model {
            /// The model with the numbers of the scene it was generated from.
            ///
            /// # Panics
            /// Never for code generated by this version: the embedded scene was
            /// checked when the code was generated.
            pub fn new() -> Model {
                match Self::try_new() {
                    Ok(m) => m,
                    Err(e) => panic!("the embedded scene of `{}`: {e}", NAME),
                }
            }

            /// [`Model::new`] without panicking.
            pub fn try_new() -> Result<Model, CompiledError> {
                <Model as CompiledModel>::from_scene(&<Model as CompiledModel>::default_scene()?)
            }

            /// The scene the code was generated from.
            pub fn scene() -> Result<Scene, CompiledError> {
                <Model as CompiledModel>::default_scene()
            }

            fn from_plan(plan: Plan) -> Model {
                #d_binding
                Model {
                    #(#inits)*
                }
            }

            #(#helpers)*
        }

        impl Default for Model {
            fn default() -> Model {
                Model::new()
            }
        }

        impl CompiledModel for Model {
            const NAME: &'static str = NAME;
            const KEY: u64 = KEY;
            const MODE: Mode = #mode_tok;

            fn from_scene(scene: &Scene) -> Result<Model, CompiledError> {
                Ok(Model::from_plan(Plan::checked(scene, #mode_tok, KEY)?))
            }

            fn default_scene() -> Result<Scene, CompiledError> {
                compiled::scene_from_json(SCENE_JSON)
            }

            fn set_initial_state(&mut self, pose: &[Pose], twist: &[Twist]) {
                self.pose0.copy_from_slice(pose);
                self.twist0.copy_from_slice(twist);
            }
        }

        #system_impl
    };

    // ---- imports: each name only if the code uses it (a module through a `name::` path)
    let names = idents(&body);
    let paths = adjacent(&body, "", ": :");
    let uses = IMPORTS.iter().filter_map(|(path, items)| {
        let kept: Vec<Ident> = items
            .iter()
            .filter_map(|item| {
                let used = match *item {
                    "self" => paths.contains(path.rsplit("::").next().unwrap_or(path)),
                    _ => names.contains(*item),
                };
                used.then(|| format_ident!("{}", item))
            })
            .collect();
        let path: TokenStream = path.parse().unwrap_or_default();
        match kept.as_slice() {
            [] => None,
            [one] if one == "self" => Some(quote!(use #path;)),
            [one] => Some(quote!(use #path::#one;)),
            _ => Some(quote!(use #path::{#(#kept),*};)),
        }
    });

    quote! {
        pub mod #module_ident {
            #(#mod_docs)*
            #(#uses)*

            #body
        }
    }
}

/// The runtime's items the generated code may use: (module path, names), `self` for the
/// module itself (used through `module::` paths). Emitted in this order, each name only if
/// the code uses it.
const IMPORTS: &[(&str, &[&str])] = &[
    (
        "mbdc_runtime::compiled",
        &["self", "CompiledError", "CompiledModel", "Mode", "Plan"],
    ),
    ("mbdc_runtime::joints", &["self", "JointOut"]),
    ("mbdc_runtime::scene", &["Scene"]),
    (
        "mbdc_runtime::system",
        &[
            "ConstraintEval",
            "Layout",
            "Need",
            "Pose",
            "System",
            "Twist",
            "Wrench",
        ],
    ),
    ("mbdc_runtime::forces", &["self"]),
    ("mbdc_runtime::contact", &["self"]),
    ("mbdc_runtime::fn1", &["Jet2"]),
    ("mbdc_runtime::nalgebra", &["Vector3"]),
    ("mbdc_runtime::system", &["JointKernel"]),
    ("mbdc_runtime::joints", &["JointGeom"]),
    (
        "mbdc_runtime::integrators::mesh_kernels",
        &["BlockKernel", "BlockKernels"],
    ),
    (
        "mbdc_runtime::integrators::beam_kernels",
        &["BeamKernel", "BeamKernels"],
    ),
    (
        "mbdc_runtime::solid",
        &[
            "Bar2",
            "Hex8",
            "Hex8Reduced",
            "Quad4PlaneStrain",
            "Quad4PlaneStrainReduced",
            "Quad4PlaneStress",
            "Quad4PlaneStressReduced",
            "Tet4",
            "Tri3PlaneStrain",
            "Tri3PlaneStress",
        ],
    ),
];

fn unrolled_joint(cx: &Ctx<'_>, k: usize, j: &UJoint) -> TokenStream {
    let combo = &cx.spec.joints[j.combo];
    let s = Sides::fixed(j.a, j.b);
    let k = lit_usize(k);
    let (first, rows) = (lit_usize(j.first), lit_usize(j.rows));
    joint_call(
        cx,
        combo,
        &s,
        quote!(&self.j[#k].geom),
        quote!(self.j[#k].lock_angle),
        quote!(#first),
        quote!(#rows),
        (quote!(), quote!()),
        Some((j.c, j.tb)),
    )
}

fn unrolled_term(cx: &Ctx<'_>, t: &UTerm) -> TokenStream {
    let combo = &cx.spec.terms[t.combo];
    let s = Sides::fixed(t.a, t.b);
    let body = lit_usize(t.a.unwrap_or(0));
    let index = lit_usize(t.index);
    let code = term_applied(
        cx,
        combo,
        &s,
        quote!(#body),
        quote!(#index),
        (quote!(), quote!()),
        Some((t.c, t.tb, t.a, t.b)),
        &quote!(),
    );
    quote!({ #code })
}
