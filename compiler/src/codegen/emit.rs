//! The token emitter behind [`super::generate`].

use mbdc_runtime::compiled::{JointCombo, Mode, Plan, Spec, TermCombo, TermKind, UJoint, UTerm};
use mbdc_runtime::scene::{ForceFrame, Scene};
use mbdc_runtime::system::JointKernel;
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

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
                None => {
                    let (a, b) = (lit_usize(dc), lit_usize(dt));
                    (quote!(#c + #a), quote!(#tb + #b))
                }
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

/// The potential energy of one term.
fn term_energy(combo: &TermCombo, s: &Sides, index: TokenStream) -> TokenStream {
    let Sides { pa, pb, .. } = s;
    match combo.kind {
        TermKind::Point | TermKind::Torque => quote!(0.0),
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
    }
}

fn ty(s: &str) -> TokenStream {
    s.parse().unwrap_or_default()
}

/// The whole file.
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
    let has_fns = !spec.shapes.is_empty();
    let has_contact = [
        TermKind::SpherePlane,
        TermKind::SphereSphere,
        TermKind::BoxPlane,
    ]
    .iter()
    .any(|k| spec.has_term(*k));
    let has_forces = spec.gravity || spec.locks || !spec.terms.is_empty();
    let uses_vec3 =
        spec.gravity || spec.has_term(TermKind::Point) || spec.has_term(TermKind::Torque);
    let uses_jet = has_fns || spec.has_kernel(JointKernel::Lock);

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
        " [`Model`] implements `System`: run it with `mbdc_runtime::run_loop` or any integrator."
            .to_string(),
    ];

    // ---- imports
    let mut uses = vec![
        quote!(
            use mbdc_runtime::compiled::{self, CompiledError, CompiledModel, Mode, Plan};
        ),
        quote!(
            use mbdc_runtime::joints::{self, JointOut};
        ),
        quote!(
            use mbdc_runtime::scene::Scene;
        ),
        quote!(
            use mbdc_runtime::system::{ConstraintEval, Layout, Need, Pose, System, Twist, Wrench};
        ),
    ];
    if has_forces {
        uses.push(quote!(
            use mbdc_runtime::forces;
        ));
    }
    if has_contact {
        uses.push(quote!(
            use mbdc_runtime::contact;
        ));
    }
    if uses_jet {
        uses.push(quote!(
            use mbdc_runtime::fn1::Jet2;
        ));
    }
    if uses_vec3 {
        uses.push(quote!(
            use mbdc_runtime::nalgebra::Vector3;
        ));
    }

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

    // ---- fields and their initialisation from the plan
    let mut fields = vec![
        quote!(layout: Layout,),
        quote!(pose0: Vec<Pose>,),
        quote!(twist0: Vec<Twist>,),
        quote!(ground_pose: Pose,),
        quote!(ground_twist: Twist,),
        quote!(velocity_forces: bool,),
        quote!(state_forces: bool,),
    ];
    let mut inits = vec![
        quote!(layout: plan.interp.layout().clone(),),
        quote!(pose0: plan.interp.initial().0.to_vec(),),
        quote!(twist0: plan.interp.initial().1.to_vec(),),
        quote!(ground_pose: Pose::default(),),
        quote!(ground_twist: Twist::default(),),
        quote!(velocity_forces: plan.interp.has_velocity_forces(),),
        quote!(state_forces: plan.interp.has_state_forces(),),
    ];
    let arr = |src: TokenStream| -> TokenStream { quote!(core::array::from_fn(|i| #src[i])) };
    if spec.gravity {
        fields.push(quote!(g: Vector3<f64>,));
        inits.push(quote!(g: Vector3::from(d.gravity),));
        match unrolled {
            Some(u) => {
                let n = lit_usize(u.bodies);
                fields.push(quote!(m: [f64; #n],));
                inits.push(quote!(m: core::array::from_fn(|i| plan.interp.layout().mass[i].m),));
            }
            None => {
                fields.push(quote!(m: Vec<f64>,));
                inits.push(quote!(m: plan.interp.layout().mass.iter().map(|m| m.m).collect(),));
            }
        }
    }
    match unrolled {
        Some(u) => {
            if !u.joints.is_empty() {
                let n = lit_usize(u.joints.len());
                fields.push(quote!(j: [compiled::JointRow; #n],));
                let a = arr(quote!(d.joints));
                inits.push(quote!(j: #a,));
            }
            if has_fns {
                let n = lit_usize(u.consts);
                fields.push(quote!(c: [f64; #n],));
                let a = arr(quote!(d.fns.c));
                inits.push(quote!(c: #a,));
            }
            for (kind, field, t) in KIND_TABLES.iter() {
                let n = u.per_kind[*kind as usize];
                if n > 0 {
                    let (f, t, nn) = (format_ident!("{}", field), ty(t), lit_usize(n));
                    fields.push(quote!(#f: [#t; #nn],));
                    let a = arr(quote!(d.#f));
                    inits.push(quote!(#f: #a,));
                }
            }
        }
        None => {
            fields.push(quote!(j: Vec<compiled::JointRow>,));
            inits.push(quote!(j: d.joints,));
            fields.push(quote!(terms: Vec<compiled::TermRow>,));
            inits.push(quote!(terms: d.terms,));
            if has_fns {
                fields.push(quote!(c: Vec<f64>,));
                inits.push(quote!(c: d.fns.c,));
            }
            for (kind, field, t) in KIND_TABLES.iter() {
                if spec.has_term(*kind) {
                    let (f, t) = (format_ident!("{}", field), ty(t));
                    fields.push(quote!(#f: Vec<#t>,));
                    inits.push(quote!(#f: d.#f,));
                }
            }
        }
    }
    if cx.tables {
        fields.push(quote!(tb: Vec<Vec<[f64; 2]>>,));
        inits.push(quote!(tb: d.fns.tb,));
    }
    if spec.locks {
        fields.push(quote!(locks: Vec<mbdc_runtime::interp::Lock>,));
        inits.push(quote!(locks: d.locks,));
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
    let gravity_energy = if spec.gravity {
        match unrolled {
            Some(u) => {
                let v: Vec<TokenStream> = (0..u.bodies)
                    .map(|i| {
                        let i = lit_usize(i);
                        quote!(e += forces::gravity_energy(self.m[#i], &self.g, &pose[#i]);)
                    })
                    .collect();
                quote!(#(#v)*)
            }
            None => quote! {
                for (p, m) in pose.iter().zip(&self.m) {
                    e += forces::gravity_energy(*m, &self.g, p);
                }
            },
        }
    } else {
        quote!()
    };

    let (constraints_body, applied_terms, energy_terms) = match unrolled {
        Some(u) => {
            let joints: Vec<TokenStream> = u
                .joints
                .iter()
                .enumerate()
                .map(|(k, j)| unrolled_joint(&cx, k, j))
                .collect();
            let terms: Vec<TokenStream> = u.terms.iter().map(|t| unrolled_term(&cx, t)).collect();
            let energies: Vec<TokenStream> = u
                .terms
                .iter()
                .map(|t| {
                    let s = Sides::fixed(t.a, t.b);
                    let i = lit_usize(t.index);
                    let e = term_energy(&spec.terms[t.combo], &s, quote!(#i));
                    quote!(e += #e;)
                })
                .collect();
            (
                quote!(#(#joints)*),
                quote!(#(#terms)*),
                quote!(#(#energies)*),
            )
        }
        None => {
            let e = quote!(e);
            let s = Sides::table(&e);
            let arms: Vec<TokenStream> = spec
                .joints
                .iter()
                .enumerate()
                .map(|(i, combo)| {
                    let i = lit_usize(i);
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
                    quote!(#i => { #call })
                })
                .collect();
            let constraints = quote! {
                for e in &self.j {
                    match e.combo {
                        #(#arms)*
                        _ => {}
                    }
                }
            };
            let r = quote!(r);
            let s = Sides::table(&r);
            let arms: Vec<TokenStream> = spec
                .terms
                .iter()
                .enumerate()
                .map(|(i, combo)| {
                    let i = lit_usize(i);
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
                    quote!(#i => { #code })
                })
                .collect();
            let applied = if spec.terms.is_empty() {
                quote!()
            } else {
                quote! {
                    for r in &self.terms {
                        match r.combo {
                            #(#arms)*
                            _ => {}
                        }
                    }
                }
            };
            let arms: Vec<TokenStream> = spec
                .terms
                .iter()
                .enumerate()
                .map(|(i, combo)| {
                    let i = lit_usize(i);
                    let en = term_energy(combo, &s, quote!(r.index));
                    quote!(#i => #en,)
                })
                .collect();
            let energy = if spec.terms.is_empty() {
                quote!()
            } else {
                quote! {
                    for r in &self.terms {
                        e += match r.combo {
                            #(#arms)*
                            _ => 0.0,
                        };
                    }
                }
            };
            (constraints, applied, energy)
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
    if has_tree {
        uses.push(quote!(
            use mbdc_runtime::system::JointKernel;
        ));
        uses.push(quote!(
            use mbdc_runtime::joints::JointGeom;
        ));
    }
    let add_pair_helper = if spec.mode == Mode::Tables && !spec.terms.is_empty() {
        quote! {
            #[inline]
            fn add_pair(out: &mut [Wrench], a: Option<usize>, b: Option<usize>, w: (Wrench, Wrench)) {
                if let Some(i) = a {
                    forces::add_wrench(&mut out[i], &w.0);
                }
                if let Some(i) = b {
                    forces::add_wrench(&mut out[i], &w.1);
                }
            }
        }
    } else {
        quote!()
    };
    let energy_mut = if spec.gravity || !spec.terms.is_empty() {
        quote!(mut)
    } else {
        quote!()
    };

    let d_binding = quote!(let d = plan.data;);
    let mod_docs = doc.iter().map(|d| quote!(#![doc = #d]));
    quote! {
        #[allow(unused_imports, unused_variables, unused_mut, unused_parens, dead_code, non_snake_case, clippy::all)]
        pub mod #module_ident {
            #(#mod_docs)*
            #(#uses)*

            #(#consts)*

            #(#shape_items)*

            /// The scene as a `System`: structure in code, numbers in the fields.
            #[derive(Clone, Debug)]
            pub struct Model {
                #(#fields)*
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

                #[inline]
                fn pose_of<'a>(&'a self, b: Option<usize>, pose: &'a [Pose]) -> &'a Pose {
                    match b {
                        Some(i) => &pose[i],
                        None => &self.ground_pose,
                    }
                }

                #[inline]
                fn twist_of<'a>(&'a self, b: Option<usize>, twist: &'a [Twist]) -> &'a Twist {
                    match b {
                        Some(i) => &twist[i],
                        None => &self.ground_twist,
                    }
                }

                #add_pair_helper
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

            impl System for Model {
                #[inline]
                fn layout(&self) -> &Layout {
                    &self.layout
                }

                fn initial_state(&self, pose: &mut [Pose], twist: &mut [Twist]) {
                    pose.copy_from_slice(&self.pose0);
                    twist.copy_from_slice(&self.twist0);
                }

                #[inline]
                fn applied(&self, t: f64, pose: &[Pose], twist: &[Twist], out: &mut [Wrench]) {
                    #gravity_applied
                    #applied_terms
                }

                #[inline]
                fn constraints(&self, t: f64, pose: &[Pose], twist: &[Twist], need: Need, out: &mut ConstraintEval) {
                    #constraints_body
                }

                fn potential_energy(&self, _t: f64, pose: &[Pose]) -> f64 {
                    let #energy_mut e = 0.0;
                    #gravity_energy
                    #energy_terms
                    e
                }

                #update_locks

                #tree_joint

                fn has_velocity_forces(&self) -> bool {
                    self.velocity_forces
                }

                fn has_state_forces(&self) -> bool {
                    self.state_forces
                }
            }
        }
    }
}

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
