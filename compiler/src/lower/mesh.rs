//! Finite-element meshes: generation (structured rectangles and boxes), Gmsh import,
//! node sets, boundary conditions and loads, ties of node sets to bodies, and glues of node
//! sets to other meshes' sets (resolved once every mesh is lowered, so that a mesh may glue
//! to one declared after it).

use std::collections::HashMap;

use mbdc_dsl::ast::{Block, Expr, ExprKind, ItemKind, Span};
use mbdc_runtime::scene::{
    BodyRef, ElementKind, Fn1, GlueTraction, HourglassControl, Mesh, MeshCondition,
    MeshFormulation, MeshIntegration, MeshKinematics, NodeSet, Vec3,
};

use super::body::num;
use super::eval::ident_of;
use super::msh;
use super::props::{one, req, Key, Prop};
use super::{EntKind, Lowerer, PDecl, Reported, Scope, R};
use crate::diag::{codes, Diagnostic};
use crate::env::BindKind;
use crate::source::{FileId, Sources};
use crate::units::Dim;
use crate::value::{Value, Q};

/// Most nodes or elements in one mesh.
pub const MAX_MESH_ITEMS: usize = 2_000_000;

const MESH_KEYS: &[Key] = &[
    Key {
        name: "element",
        min: 1,
        max: 2,
        repeat: false,
    },
    one("thickness"),
    one("integration"),
    one("hourglass"),
    one("strain"),
    one("generate"),
    one("material"),
    Key {
        name: "fix",
        min: 1,
        max: 1,
        repeat: true,
    },
    Key {
        name: "displace",
        min: 2,
        max: 2,
        repeat: true,
    },
    Key {
        name: "load",
        min: 2,
        max: 2,
        repeat: true,
    },
    Key {
        name: "traction",
        min: 2,
        max: 2,
        repeat: true,
    },
    one("body_force"),
    Key {
        name: "foundation",
        min: 2,
        max: 2,
        repeat: true,
    },
    Key {
        name: "tie",
        min: 2,
        max: 2,
        repeat: true,
    },
    Key {
        name: "glue",
        min: 2,
        max: 2,
        repeat: true,
    },
];

/// Highest degree of a glue's `traction polynomial(degree: P)` (the monomial basis is
/// ill-conditioned beyond: κ(B̄B̄ᵀ) ≈ 10¹³ at ten terms).
pub const MAX_GLUE_DEGREE: i64 = 10;

/// Most points of a glue's `traction bessel(points: N)`.
pub const MAX_GLUE_POINTS: i64 = 64;

/// A `glue SET, MESH.SET` of a lowered mesh, kept for [`Lowerer::resolve_glues`] (which
/// looks up the other set once every mesh is lowered) and for the checks of the analysis
/// (`check_glues`), which need its span.
#[derive(Clone, Debug)]
pub(crate) struct GlueSite {
    /// The mesh that writes the glue (index in declaration order, as in `Scene::meshes`).
    pub mesh: usize,
    /// The glue's index among that mesh's conditions.
    pub condition: usize,
    /// The other mesh.
    pub other_mesh: usize,
    /// The other set's name as written, and where (the `SET` of `MESH.SET`).
    pub other_set: String,
    pub other_set_span: Span,
    /// The whole `glue` item, and its file.
    pub span: Span,
    pub file: FileId,
}

const ELEMENT_KINDS: &[&str] = &["bar2", "tri3", "quad4", "tet4", "hex8"];

/// Structured rectangle in the x–y plane: nodes `j (nx+1) + i`; quads counter-clockwise,
/// or each quad split into two triangles along its (i, j)–(i+1, j+1) diagonal.
pub fn rect_mesh(
    origin: Vec3,
    size: [f64; 2],
    n: [usize; 2],
    tri: bool,
) -> (Vec<Vec3>, Vec<Vec<usize>>) {
    let (nx, ny) = (n[0], n[1]);
    let mut nodes = Vec::with_capacity((nx + 1) * (ny + 1));
    for j in 0..=ny {
        for i in 0..=nx {
            nodes.push([
                origin[0] + size[0] * i as f64 / nx as f64,
                origin[1] + size[1] * j as f64 / ny as f64,
                0.0,
            ]);
        }
    }
    let id = |i: usize, j: usize| j * (nx + 1) + i;
    let mut elems = Vec::with_capacity(nx * ny * if tri { 2 } else { 1 });
    for j in 0..ny {
        for i in 0..nx {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if tri {
                elems.push(vec![a, b, c]);
                elems.push(vec![a, c, d]);
            } else {
                elems.push(vec![a, b, c, d]);
            }
        }
    }
    (nodes, elems)
}

/// Structured box: nodes `k (nx+1)(ny+1) + j (nx+1) + i`; hex8 in the usual order (bottom
/// face counter-clockwise seen from above, then top), or each hex split into 6 tetrahedra
/// around its (0,0,0)–(1,1,1) diagonal (a conforming Kuhn split), all positively oriented.
pub fn box_mesh(
    origin: Vec3,
    size: Vec3,
    n: [usize; 3],
    tet: bool,
) -> (Vec<Vec3>, Vec<Vec<usize>>) {
    let (nx, ny, nz) = (n[0], n[1], n[2]);
    let mut nodes = Vec::with_capacity((nx + 1) * (ny + 1) * (nz + 1));
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                nodes.push([
                    origin[0] + size[0] * i as f64 / nx as f64,
                    origin[1] + size[1] * j as f64 / ny as f64,
                    origin[2] + size[2] * k as f64 / nz as f64,
                ]);
            }
        }
    }
    let id = |i: usize, j: usize, k: usize| k * (nx + 1) * (ny + 1) + j * (nx + 1) + i;
    let mut elems = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let c = |a: usize, b: usize, d: usize| id(i + a, j + b, k + d);
                if !tet {
                    elems.push(vec![
                        c(0, 0, 0),
                        c(1, 0, 0),
                        c(1, 1, 0),
                        c(0, 1, 0),
                        c(0, 0, 1),
                        c(1, 0, 1),
                        c(1, 1, 1),
                        c(0, 1, 1),
                    ]);
                    continue;
                }
                let paths: [[(usize, usize, usize); 2]; 6] = [
                    [(1, 0, 0), (1, 1, 0)],
                    [(1, 0, 0), (1, 0, 1)],
                    [(0, 1, 0), (1, 1, 0)],
                    [(0, 1, 0), (0, 1, 1)],
                    [(0, 0, 1), (1, 0, 1)],
                    [(0, 0, 1), (0, 1, 1)],
                ];
                for p in paths {
                    let mut t = vec![
                        c(0, 0, 0),
                        c(p[0].0, p[0].1, p[0].2),
                        c(p[1].0, p[1].1, p[1].2),
                        c(1, 1, 1),
                    ];
                    if tet_volume(&nodes, &t) < 0.0 {
                        t.swap(1, 2);
                    }
                    elems.push(t);
                }
            }
        }
    }
    (nodes, elems)
}

fn tet_volume(nodes: &[Vec3], t: &[usize]) -> f64 {
    let p = |i: usize| nalgebra::Vector3::from(nodes[t[i]]);
    (p(1) - p(0)).cross(&(p(2) - p(0))).dot(&(p(3) - p(0))) / 6.0
}

/// Faces (2-D: edges) that belong to exactly one element: (element, local face).
pub fn boundary_faces(kind: ElementKind, elements: &[Vec<usize>]) -> Vec<(usize, usize)> {
    let faces = kind.faces();
    let mut count: HashMap<Vec<usize>, (usize, usize, usize)> = HashMap::new();
    for (e, conn) in elements.iter().enumerate() {
        for (f, local) in faces.iter().enumerate() {
            let mut key: Vec<usize> = local.iter().map(|&i| conn[i]).collect();
            key.sort_unstable();
            count
                .entry(key)
                .and_modify(|c| c.0 += 1)
                .or_insert((1, e, f));
        }
    }
    let mut out: Vec<(usize, usize)> = count
        .into_values()
        .filter(|c| c.0 == 1)
        .map(|c| (c.1, c.2))
        .collect();
    out.sort_unstable();
    out
}

fn bbox(nodes: &[Vec3]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for n in nodes {
        for k in 0..3 {
            lo[k] = lo[k].min(n[k]);
            hi[k] = hi[k].max(n[k]);
        }
    }
    (lo, hi)
}

struct Imported {
    data: msh::MshData,
    tag_to_index: HashMap<usize, usize>,
    file: crate::source::FileId,
}

impl<'a> Lowerer<'a> {
    pub(crate) fn lower_mesh(&mut self, d: &PDecl<'a>) -> R<Mesh> {
        let sc = &d.sc;
        let what = format!("mesh `{}`", d.name);
        let Some(block) = d.block else {
            return Err(Reported);
        };
        let props = self.props(block, sc, &what, MESH_KEYS, &["set", "import"]);
        // Element kind.
        let kind = match props.get("element") {
            None => Err(self.missing(
                &props,
                "element",
                &what,
                sc,
                d.name_span,
                "element quad4, plane_stress",
            )),
            Some(p) => self.element_kind(p.values, sc),
        };
        let material = match props.value("material") {
            Some(e) => self.material_ref(e, sc),
            None => Err(self.missing(&props, "material", &what, sc, d.name_span, "material steel")),
        };
        let kind = kind?;
        let needs_thickness = kind.dim() == 2 || kind == ElementKind::Bar2;
        let thickness = match (props.value("thickness"), needs_thickness) {
            (Some(e), true) => {
                if kind == ElementKind::Bar2 {
                    self.positive(e, sc, Dim::AREA, "a bar cross-section area")
                } else {
                    self.positive(e, sc, Dim::LENGTH, "a thickness")
                }
            }
            (None, true) => Err(self.missing(
                &props,
                "thickness",
                &what,
                sc,
                d.name_span,
                if kind == ElementKind::Bar2 {
                    "thickness 1 cm^2  // the bar area"
                } else {
                    "thickness 5 mm"
                },
            )),
            (Some(e), false) => Err(self.report(
                Diagnostic::error(codes::MESH, "a 3-D mesh has no thickness")
                    .primary(sc.file, e.span, "")
                    .help("remove `thickness`; it is for 2-D elements (thickness) and bars (area)"),
            )),
            (None, false) => Ok(1.0),
        };
        let formulation = self.formulation(&props, sc, kind);
        // Nodes and elements.
        let mut imported: Option<Imported> = None;
        let imports: Vec<&mbdc_dsl::ast::Item> = props
            .decls
            .iter()
            .copied()
            .filter(|i| matches!(i.kind, ItemKind::Import { .. }))
            .collect();
        if imports.len() > 1 {
            self.report(
                Diagnostic::error(
                    codes::DUPLICATE_PROPERTY,
                    format!("`import` is given twice in {what}"),
                )
                .primary(sc.file, imports[1].span, "second")
                .secondary(sc.file, imports[0].span, "first"),
            );
        }
        let import = imports.first().and_then(|i| match &i.kind {
            ItemKind::Import { path } => Some((path, i.span)),
            _ => None,
        });
        let geometry: R<(Vec<Vec3>, Vec<Vec<usize>>)> = match (props.get("generate"), import) {
            (Some(g), None) => self.generate(&g.values[0], sc, kind),
            (None, Some((path, _))) => match self.import_msh(&path.value, path.span, sc, kind) {
                Ok((nodes, elems, imp)) => {
                    imported = Some(imp);
                    Ok((nodes, elems))
                }
                Err(r) => Err(r),
            },
            (None, None) => Err(self.report(
                Diagnostic::error(codes::MISSING_PROPERTY, format!("{what} has no nodes"))
                    .primary(sc.file, d.name_span, "")
                    .help("add `generate rect(...)`, `generate box(...)` or `import \"part.msh\"`"),
            )),
            (Some(g), Some((_, ispan))) => Err(self.report(
                Diagnostic::error(
                    codes::MESH,
                    format!("{what} has both `generate` and `import`"),
                )
                .primary(sc.file, g.span, "")
                .primary(sc.file, ispan, "")
                .help("keep one"),
            )),
        };
        let (material, thickness, formulation, (nodes, elements)) =
            (material?, thickness?, formulation?, geometry?);
        let (lo, hi) = bbox(&nodes);
        let diag =
            ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
        let tol = 1e-9 * if diag > 0.0 { diag } else { 1.0 };
        // Sets.
        let mut sets: Vec<NodeSet> = Vec::new();
        let mut set_spans: Vec<Span> = Vec::new();
        let mut boundary: Option<Vec<(usize, usize)>> = None;
        let mut ok = true;
        for item in &props.decls {
            let ItemKind::Decl {
                name, value, body, ..
            } = &item.kind
            else {
                continue;
            };
            let _ = Span::default();
            let (Some(name), Some(value), None) = (name, value, body) else {
                self.report(
                    Diagnostic::error(
                        codes::MESH,
                        "a set is `set NAME = nodes(PREDICATE)` or `set NAME = group(\"name\")`",
                    )
                    .primary(sc.file, item.span, ""),
                );
                ok = false;
                continue;
            };
            if !name.indices.is_empty() {
                self.report(
                    Diagnostic::error(codes::MESH, "set names cannot be indexed")
                        .primary(sc.file, name.span, ""),
                );
                ok = false;
                continue;
            }
            let sname = name.base.name.clone();
            if let Some(i) = sets.iter().position(|s| s.name == sname) {
                self.report(
                    Diagnostic::error(
                        codes::DUPLICATE_NAME,
                        format!("set `{sname}` is declared twice in {what}"),
                    )
                    .primary(sc.file, name.span, "second")
                    .secondary(sc.file, set_spans[i], "first"),
                );
                ok = false;
                continue;
            }
            let members = match self.set_members(value, sc, &nodes, tol, imported.as_ref()) {
                Ok(m) => m,
                Err(_) => {
                    ok = false;
                    continue;
                }
            };
            if members.is_empty() {
                self.report(
                    Diagnostic::error(codes::MESH, format!("set `{sname}` of {what} is empty"))
                        .primary(sc.file, value.span, "no node matches")
                        .help(format!(
                            "the nodes span x ∈ [{}, {}], y ∈ [{}, {}], z ∈ [{}, {}] m",
                            num(lo[0]),
                            num(hi[0]),
                            num(lo[1]),
                            num(hi[1]),
                            num(lo[2]),
                            num(hi[2])
                        )),
                );
                ok = false;
                sets.push(NodeSet {
                    name: sname,
                    nodes: members,
                    faces: Vec::new(),
                });
                set_spans.push(name.span);
                continue;
            }
            let bf = boundary.get_or_insert_with(|| boundary_faces(kind, &elements));
            let mut inset = vec![false; nodes.len()];
            for &m in &members {
                inset[m] = true;
            }
            let faces: Vec<(usize, usize)> = bf
                .iter()
                .copied()
                .filter(|&(e, f)| kind.faces()[f].iter().all(|&l| inset[elements[e][l]]))
                .collect();
            sets.push(NodeSet {
                name: sname,
                nodes: members,
                faces,
            });
            set_spans.push(name.span);
        }
        // Conditions, in order.
        let mut conditions = Vec::new();
        let mut spans = Vec::new();
        let mut body_force_seen = false;
        // (registered in expansion, so always found)
        let this = self.entities.get(&d.name).map_or(usize::MAX, |e| e.index);
        for p in &props.list {
            let key = p.key.name.as_str();
            if !matches!(
                key,
                "fix"
                    | "displace"
                    | "load"
                    | "traction"
                    | "body_force"
                    | "foundation"
                    | "tie"
                    | "glue"
            ) {
                continue;
            }
            if key == "glue" {
                match self.glue(p, sc, &sets, kind, this) {
                    Ok((c, other_set, other_set_span)) => {
                        if let MeshCondition::Glue { mesh, .. } = c {
                            self.glues.push(GlueSite {
                                mesh: this,
                                condition: conditions.len(),
                                other_mesh: mesh,
                                other_set,
                                other_set_span,
                                span: p.span,
                                file: sc.file,
                            });
                        }
                        conditions.push(c);
                        spans.push(p.span);
                    }
                    Err(_) => ok = false,
                }
                continue;
            }
            let r = self.condition(key, p.values, sc, &sets, kind);
            match r {
                Ok(c) => {
                    body_force_seen |= matches!(c, MeshCondition::BodyForce { .. });
                    conditions.push(c);
                    spans.push(p.span);
                }
                Err(_) => ok = false,
            }
        }
        let _ = body_force_seen;
        {
            // the conditions that lowered, whatever the others did
            let ties = Ties {
                what: &what,
                conditions: &conditions,
                spans: &spans,
                sets: &sets,
                nodes: &nodes,
            };
            ok &= self.check_ties(&ties, sc, formulation.kinematics);
        }
        if !ok {
            return Err(Reported);
        }
        self.mesh_condition_spans.insert(this, (sc.file, spans));
        Ok(Mesh {
            name: d.name.clone(),
            kind,
            material,
            thickness,
            nodes,
            elements,
            node_sets: sets,
            conditions,
            formulation,
            origin: Sources::origin(sc.file, d.span),
        })
    }

    /// `integration full | reduced | bbar` (hex8 and quad4), `hourglass viscous(κ)` or
    /// `stiffness(κ)` (with `reduced` only; κ dimensionless in (0, 1], default viscous 0.1)
    /// and `strain small | green`.
    fn formulation(
        &mut self,
        props: &super::props::Props<'a>,
        sc: &Scope,
        kind: ElementKind,
    ) -> R<MeshFormulation> {
        let mut ok = true;
        let kinematics = match props.value("strain") {
            None => MeshKinematics::Small,
            Some(e) => match ident_of(e) {
                Some("small") => MeshKinematics::Small,
                Some("green") => MeshKinematics::Green,
                _ => {
                    self.report(
                        Diagnostic::error(codes::WRONG_KIND, "`strain` is `small` or `green`")
                            .primary(sc.file, e.span, "")
                            .help("`small`: linear elastic, small strain; `green`: Green–Lagrange strain with St Venant–Kirchhoff, for large rotations"),
                    );
                    ok = false;
                    MeshKinematics::Small
                }
            },
        };
        let reduced = match props.value("integration") {
            None => None,
            Some(e) => {
                let which = match ident_of(e) {
                    Some(w @ ("full" | "reduced" | "bbar")) => Some(w),
                    _ => {
                        self.report(
                            Diagnostic::error(
                                codes::WRONG_KIND,
                                "`integration` is `full`, `reduced` or `bbar`",
                            )
                            .primary(sc.file, e.span, "")
                            .help("`full`: 2×2×2 (hex8) or 2×2 (quad4) Gauss points; `reduced`: one point with hourglass control; `bbar`: full with the mean dilatation, against volumetric locking"),
                        );
                        ok = false;
                        None
                    }
                };
                if which.is_some() && !mbdc_runtime::mesh_model::takes_integration(kind) {
                    self.report(
                        Diagnostic::error(
                            codes::MESH,
                            format!(
                                "`integration` applies to hex8 and quad4 elements, not to {}",
                                element_name(kind)
                            ),
                        )
                        .primary(sc.file, e.span, "")
                        .help(format!(
                            "{} elements have one integration rule; remove `integration`",
                            element_name(kind)
                        )),
                    );
                    ok = false;
                }
                which.map(|w| (w, e.span))
            }
        };
        let hourglass = match props.value("hourglass") {
            None => None,
            Some(e) => match self.hourglass(e, sc) {
                Ok(h) => Some((h, e.span)),
                Err(_) => {
                    ok = false;
                    None
                }
            },
        };
        let integration = match (reduced, hourglass) {
            (Some(("reduced", _)), h) => MeshIntegration::Reduced {
                hourglass: h.map(|h| h.0).unwrap_or_default(),
            },
            (r, Some((_, hspan))) => {
                let mut d =
                    Diagnostic::error(codes::MESH, "`hourglass` needs `integration reduced`")
                        .primary(sc.file, hspan, "");
                if let Some((w, rspan)) = r {
                    d = d.secondary(sc.file, rspan, format!("the integration is `{w}`"));
                }
                self.report(d.help(
                    "hourglass control stabilises one-point elements; fully integrated elements have no hourglass modes",
                ));
                ok = false;
                MeshIntegration::Full
            }
            (Some(("bbar", _)), None) => MeshIntegration::Bbar,
            _ => MeshIntegration::Full,
        };
        if !ok {
            return Err(Reported);
        }
        Ok(MeshFormulation {
            integration,
            kinematics,
        })
    }

    /// `viscous(κ)` or `stiffness(κ)`, κ a plain number in (0, 1].
    fn hourglass(&mut self, e: &'a Expr, sc: &Scope) -> R<HourglassControl> {
        let form = "`hourglass` is `viscous(COEFFICIENT)` or `stiffness(COEFFICIENT)`";
        let ExprKind::Call { func, args } = &e.kind else {
            return Err(self.report(
                Diagnostic::error(codes::WRONG_KIND, form)
                    .primary(sc.file, e.span, "")
                    .help("for example `hourglass viscous(0.1)`; the coefficient is dimensionless, in (0, 1]"),
            ));
        };
        let stiffness = match func.name.as_str() {
            "viscous" => false,
            "stiffness" => true,
            other => {
                return Err(self.report(
                    Diagnostic::error(
                        codes::UNKNOWN_NAME,
                        format!("unknown hourglass control `{other}`"),
                    )
                    .primary(sc.file, func.span, "")
                    .help("`viscous(κ)` (dissipative) or `stiffness(κ)` (elastic)"),
                ))
            }
        };
        let a = self.call_args(func, args, &[super::props::pos("coefficient")], sc, e.span)?;
        let Some(ce) = a[0] else {
            return Err(Reported);
        };
        let q = self
            .eval(ce, sc)
            .and_then(|v| self.scalar_of(v, ce.span, sc))?;
        self.expect_dim(&q, Dim::NONE, ce.span, sc, "an hourglass coefficient")?;
        let c = self.constant_of(&q, ce.span, sc, "an hourglass coefficient")?;
        if !(c > 0.0 && c <= 1.0) {
            return Err(self.report(
                Diagnostic::error(
                    codes::INVALID_VALUE,
                    format!(
                        "the hourglass coefficient must lie in (0, 1], found {}",
                        num(c)
                    ),
                )
                .primary(sc.file, ce.span, "")
                .help("the usual values are 0.05–0.15 (Flanagan–Belytschko); 0.1 is the default"),
            ));
        }
        Ok(if stiffness {
            HourglassControl::Stiffness { coefficient: c }
        } else {
            HourglassControl::Viscous { coefficient: c }
        })
    }

    fn element_kind(&mut self, values: &[Expr], sc: &Scope) -> R<ElementKind> {
        let e = &values[0];
        let Some(k) = ident_of(e) else {
            return Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    "an element kind is one of bar2, tri3, quad4, tet4, hex8",
                )
                .primary(sc.file, e.span, ""),
            ));
        };
        let plane = match values.get(1) {
            None => None,
            Some(p) => match ident_of(p) {
                Some(s @ ("plane_stress" | "plane_strain")) => Some((s, p.span)),
                _ => {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::WRONG_KIND,
                            "the second value of `element` is `plane_stress` or `plane_strain`",
                        )
                        .primary(sc.file, p.span, ""),
                    ))
                }
            },
        };
        let strain = plane.is_some_and(|p| p.0 == "plane_strain");
        let kind = match k {
            "bar2" => ElementKind::Bar2,
            "tet4" => ElementKind::Tet4,
            "hex8" => ElementKind::Hex8,
            "tri3" if strain => ElementKind::Tri3PlaneStrain,
            "tri3" => ElementKind::Tri3PlaneStress,
            "quad4" if strain => ElementKind::Quad4PlaneStrain,
            "quad4" => ElementKind::Quad4PlaneStress,
            other => {
                let help = match crate::suggest::closest(other, ELEMENT_KINDS.iter().copied()) {
                    Some(s) => format!("did you mean `{s}`?"),
                    None => format!("element kinds: {}", ELEMENT_KINDS.join(", ")),
                };
                return Err(self.report(
                    Diagnostic::error(
                        codes::UNKNOWN_NAME,
                        format!("unknown element kind `{other}`"),
                    )
                    .primary(sc.file, e.span, "")
                    .help(help),
                ));
            }
        };
        if let Some((s, sp)) = plane {
            if kind.dim() != 2 {
                return Err(self.report(
                    Diagnostic::error(
                        codes::MESH,
                        format!("`{s}` applies to 2-D elements (tri3, quad4), not to {k}"),
                    )
                    .primary(sc.file, sp, ""),
                ));
            }
        }
        Ok(kind)
    }

    fn generate(
        &mut self,
        e: &'a Expr,
        sc: &Scope,
        kind: ElementKind,
    ) -> R<(Vec<Vec3>, Vec<Vec<usize>>)> {
        let ExprKind::Call { func, args } = &e.kind else {
            return Err(self.report(
                Diagnostic::error(codes::WRONG_KIND, "`generate` takes `rect(origin:, size:, divisions:)` or `box(origin:, size:, divisions:)`")
                    .primary(sc.file, e.span, ""),
            ));
        };
        let shape = func.name.as_str();
        if shape == "line" {
            return self.generate_line(func, args, sc, e.span, kind);
        }
        let is_rect = match shape {
            "rect" => true,
            "box" => false,
            other => {
                return Err(self.report(
                    Diagnostic::error(codes::UNKNOWN_NAME, format!("unknown mesh generator `{other}`"))
                        .primary(sc.file, func.span, "")
                        .help("generators: line(origin:, size:, divisions:) for bar2, rect(origin:, size:, divisions:) for tri3/quad4, box(origin:, size:, divisions:) for tet4/hex8"),
                ))
            }
        };
        let fits = if is_rect {
            kind.dim() == 2
        } else {
            matches!(kind, ElementKind::Tet4 | ElementKind::Hex8)
        };
        if !fits {
            return Err(self.report(
                Diagnostic::error(
                    codes::MESH,
                    format!("`{shape}` cannot generate {} elements", element_name(kind)),
                )
                .primary(sc.file, func.span, "")
                .help(if kind == ElementKind::Bar2 {
                    "use `line(origin:, size:, divisions:)` for bar2".to_string()
                } else if is_rect {
                    "use `box(...)` for tet4 and hex8".to_string()
                } else {
                    "use `rect(...)` for tri3 and quad4".to_string()
                }),
            ));
        }
        let a = self.call_args(
            func,
            args,
            &[req("origin"), req("size"), req("divisions")],
            sc,
            e.span,
        )?;
        let (Some(oe), Some(se), Some(de)) = (a[0], a[1], a[2]) else {
            return Err(Reported);
        };
        let origin = self.vec23(oe, sc, Dim::LENGTH, "a mesh origin");
        let n = if is_rect { 2 } else { 3 };
        let size = self.vector(se, sc).and_then(|v| {
            if v.len() != n {
                return Err(self.report(
                    Diagnostic::error(
                        codes::WRONG_KIND,
                        format!("`size` needs {n} components, found {}", v.len()),
                    )
                    .primary(sc.file, se.span, ""),
                ));
            }
            let mut out = [0.0; 3];
            for (i, q) in v.iter().enumerate() {
                self.expect_dim(q, Dim::LENGTH, se.span, sc, "a mesh size")?;
                out[i] = self.constant_of(q, se.span, sc, "a mesh size")?;
                if out[i] <= 0.0 {
                    return Err(self.report(
                        Diagnostic::error(codes::INVALID_VALUE, "mesh sizes must be positive")
                            .primary(sc.file, se.span, ""),
                    ));
                }
            }
            Ok(out)
        });
        let div = match self.eval(de, sc) {
            Ok(Value::Tuple(items)) if items.len() == n => {
                let mut out = [1usize; 3];
                let mut bad = false;
                for (i, it) in items.into_iter().enumerate() {
                    match self.scalar_of(it, de.span, sc) {
                        Ok(q)
                            if q.dim.is_none()
                                && q.constant()
                                    .is_some_and(|c| c >= 1.0 && c.fract() == 0.0 && c < 1e9) =>
                        {
                            out[i] = q.constant().unwrap_or(1.0) as usize
                        }
                        Ok(_) => {
                            self.report(
                                Diagnostic::error(
                                    codes::INVALID_VALUE,
                                    "divisions must be positive integers",
                                )
                                .primary(sc.file, de.span, ""),
                            );
                            bad = true;
                        }
                        Err(_) => bad = true,
                    }
                }
                if bad {
                    Err(Reported)
                } else {
                    Ok(out)
                }
            }
            Ok(other) => Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!("`divisions` needs {n} integers, found {}", other.kind()),
                )
                .primary(sc.file, de.span, ""),
            )),
            Err(r) => Err(r),
        };
        let (origin, size, div) = (origin?, size?, div?);
        if is_rect && origin[2] != 0.0 {
            return Err(self.report(
                Diagnostic::error(codes::MESH, "2-D meshes lie in the plane z = 0")
                    .primary(sc.file, oe.span, "")
                    .help("give a 2-D origin `(x, y)`"),
            ));
        }
        let nodes: u128 = div[..n].iter().map(|d| (*d + 1) as u128).product();
        let cells: u128 = div[..n].iter().map(|d| *d as u128).product::<u128>()
            * match kind {
                ElementKind::Tet4 => 6,
                ElementKind::Tri3PlaneStress | ElementKind::Tri3PlaneStrain => 2,
                _ => 1,
            };
        if nodes > MAX_MESH_ITEMS as u128 || cells > MAX_MESH_ITEMS as u128 {
            return Err(self.report(
                Diagnostic::error(
                    codes::LIMIT,
                    format!("this mesh would have {nodes} nodes and {cells} elements, more than the limit of {}", super::expand::fmt_count(MAX_MESH_ITEMS)),
                )
                .primary(sc.file, de.span, "")
                .help("reduce the divisions"),
            ));
        }
        let tri = matches!(
            kind,
            ElementKind::Tri3PlaneStress | ElementKind::Tri3PlaneStrain
        );
        Ok(if is_rect {
            rect_mesh(origin, [size[0], size[1]], [div[0], div[1]], tri)
        } else {
            box_mesh(
                origin,
                size,
                [div[0], div[1], div[2]],
                kind == ElementKind::Tet4,
            )
        })
    }

    /// `line(origin: VEC, size: VEC, divisions: N)`: N bar2 elements from `origin` to
    /// `origin + size`, nodes numbered from the origin.
    fn generate_line(
        &mut self,
        func: &mbdc_dsl::ast::Ident,
        args: &'a [mbdc_dsl::ast::Arg],
        sc: &Scope,
        span: Span,
        kind: ElementKind,
    ) -> R<(Vec<Vec3>, Vec<Vec<usize>>)> {
        if kind != ElementKind::Bar2 {
            return Err(self.report(
                Diagnostic::error(
                    codes::MESH,
                    format!("`line` cannot generate {} elements", element_name(kind)),
                )
                .primary(sc.file, func.span, "")
                .help("`line` generates bar2 elements; use `rect(...)` for tri3 and quad4, `box(...)` for tet4 and hex8"),
            ));
        }
        let a = self.call_args(
            func,
            args,
            &[req("origin"), req("size"), req("divisions")],
            sc,
            span,
        )?;
        let (Some(oe), Some(se), Some(de)) = (a[0], a[1], a[2]) else {
            return Err(Reported);
        };
        let origin = self.vec23(oe, sc, Dim::LENGTH, "a mesh origin");
        let size = self.vec23(se, sc, Dim::LENGTH, "a mesh size");
        let div = match self
            .eval(de, sc)
            .and_then(|v| self.scalar_of(v, de.span, sc))
        {
            Ok(q)
                if q.dim.is_none()
                    && q.constant().is_some_and(|c| {
                        c >= 1.0 && c.fract() == 0.0 && c <= MAX_MESH_ITEMS as f64
                    }) =>
            {
                Ok(q.constant().unwrap_or(1.0) as usize)
            }
            Ok(_) => Err(self.report(
                Diagnostic::error(
                    codes::INVALID_VALUE,
                    format!(
                        "`divisions` of a line is one positive integer, at most {}",
                        super::expand::fmt_count(MAX_MESH_ITEMS)
                    ),
                )
                .primary(sc.file, de.span, ""),
            )),
            Err(r) => Err(r),
        };
        let (origin, size, div) = (origin?, size?, div?);
        if size.iter().all(|&c| c == 0.0) {
            return Err(self.report(
                Diagnostic::error(codes::INVALID_VALUE, "a line's size must not be zero")
                    .primary(sc.file, se.span, "")
                    .help("`size` is the vector from the first node to the last"),
            ));
        }
        let nodes = (0..=div)
            .map(|i| {
                let f = i as f64 / div as f64;
                [
                    origin[0] + f * size[0],
                    origin[1] + f * size[1],
                    origin[2] + f * size[2],
                ]
            })
            .collect();
        let elements = (0..div).map(|i| vec![i, i + 1]).collect();
        Ok((nodes, elements))
    }

    fn import_msh(
        &mut self,
        rel: &str,
        espan: Span,
        sc: &Scope,
        kind: ElementKind,
    ) -> R<(Vec<Vec3>, Vec<Vec<usize>>, Imported)> {
        let rel = rel.to_string();
        struct E {
            span: Span,
        }
        let e = &E { span: espan };
        let dir = self.file_dir(sc.file);
        let path = match &dir {
            Some(d) => d.join(&rel),
            None => std::path::PathBuf::from(&rel),
        };
        let name_dir = std::path::Path::new(self.sources.name(sc.file))
            .parent()
            .map(|p| p.to_path_buf())
            .unwrap_or_default();
        let display = crate::load::normalize(&name_dir.join(&rel))
            .to_string_lossy()
            .replace('\\', "/");
        let text = match crate::load::read_input(&path, crate::load::MAX_MESH_BYTES) {
            Ok(t) => t,
            Err(err) => {
                return Err(self.report(
                    Diagnostic::error(
                        codes::IO,
                        format!(
                            "cannot read `{display}`: {}",
                            if err.kind() == std::io::ErrorKind::NotFound {
                                "no such file".to_string()
                            } else {
                                err.to_string()
                            }
                        ),
                    )
                    .primary(sc.file, e.span, "")
                    .help("mesh paths are relative to the .mbd file"),
                ))
            }
        };
        let fid = self.sources.add(display.clone(), Some(path), text.clone());
        let data = match msh::parse(&text) {
            Ok(d) => d,
            Err(err) => {
                let f = self.sources.get(fid);
                let (start, end) = f
                    .map(|f| {
                        let line = err.line.clamp(1, f.line_count().max(1));
                        let start: usize = f
                            .text
                            .split_inclusive('\n')
                            .take(line - 1)
                            .map(str::len)
                            .sum();
                        (start, start + f.line_text(line).len())
                    })
                    .unwrap_or((0, 0));
                return Err(self.report(
                    Diagnostic::error(
                        codes::MESH,
                        format!("cannot read the mesh `{display}`: {}", err.message),
                    )
                    .primary(fid, Span::new(start, end), "")
                    .secondary(sc.file, e.span, "imported here"),
                ));
            }
        };
        let want: u32 = match kind {
            ElementKind::Bar2 => 1,
            ElementKind::Tri3PlaneStress | ElementKind::Tri3PlaneStrain => 2,
            ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain => 3,
            ElementKind::Tet4 => 4,
            ElementKind::Hex8 => 5,
        };
        let mut tags: Vec<usize> = data
            .elements
            .iter()
            .filter(|el| el.etype == want)
            .flat_map(|el| el.nodes.iter().copied())
            .collect();
        if tags.is_empty() {
            let list = type_counts(data.elements.iter())
                .iter()
                .map(|(t, n)| format!("{} × {n}", msh::type_name(*t)))
                .collect::<Vec<_>>()
                .join(", ");
            return Err(self.report(
                Diagnostic::error(
                    codes::MESH,
                    format!("`{display}` has no {} elements", element_name(kind)),
                )
                .primary(sc.file, e.span, "")
                .help(if list.is_empty() {
                    "the file has no elements".to_string()
                } else {
                    format!("it has: {list}")
                }),
            ));
        }
        tags.sort_unstable();
        tags.dedup();
        self.warn_left_out(&data, want, kind, &tags, &display, sc, e.span);
        if tags.len() > MAX_MESH_ITEMS {
            return Err(self.report(
                Diagnostic::error(codes::LIMIT, "the imported mesh is too large")
                    .primary(sc.file, e.span, ""),
            ));
        }
        let tag_to_index: HashMap<usize, usize> =
            tags.iter().enumerate().map(|(i, t)| (*t, i)).collect();
        let two_d = kind.dim() == 2;
        let mut nodes = Vec::with_capacity(tags.len());
        for t in &tags {
            let mut p = data.nodes.get(t).copied().unwrap_or([0.0; 3]);
            if two_d {
                if p[2].abs() > 1e-12 {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::MESH,
                            format!("node {t} of the 2-D mesh `{display}` has z = {}", num(p[2])),
                        )
                        .primary(sc.file, e.span, "")
                        .help("2-D meshes lie in the plane z = 0"),
                    ));
                }
                p[2] = 0.0;
            }
            nodes.push(p);
        }
        let mut elements: Vec<Vec<usize>> = Vec::new();
        for el in data.elements.iter().filter(|el| el.etype == want) {
            if el.nodes.len() != kind.nodes() {
                return Err(self.report(
                    Diagnostic::error(
                        codes::MESH,
                        format!(
                            "an element of `{display}` has {} nodes, expected {}",
                            el.nodes.len(),
                            kind.nodes()
                        ),
                    )
                    .primary(sc.file, e.span, ""),
                ));
            }
            elements.push(
                el.nodes
                    .iter()
                    .map(|t| tag_to_index.get(t).copied().unwrap_or(0))
                    .collect(),
            );
        }
        self.warn_duplicate_nodes(&nodes, &tags, &display, sc, e.span);
        Ok((
            nodes,
            elements,
            Imported {
                data,
                tag_to_index,
                file: fid,
            },
        ))
    }

    /// Warns about what an import leaves out: elements of the mesh's dimension but of
    /// another type (a mixed mesh: the mesh would have holes where they were), and nodes
    /// that no element of the mesh's kind uses.
    #[allow(clippy::too_many_arguments)]
    fn warn_left_out(
        &mut self,
        data: &msh::MshData,
        want: u32,
        kind: ElementKind,
        tags: &[usize],
        display: &str,
        sc: &Scope,
        span: Span,
    ) {
        let dim = msh_dimension(want);
        let other = type_counts(
            data.elements
                .iter()
                .filter(|el| el.etype != want && msh_dimension(el.etype) == dim),
        );
        if !other.is_empty() {
            let list = other
                .iter()
                .map(|(t, n)| format!("{n} {}", msh::type_name(*t)))
                .collect::<Vec<_>>()
                .join(", ");
            self.report(
                Diagnostic::warning(
                    codes::MESH,
                    format!(
                        "`{display}` also has {list} element(s), which a {} mesh leaves out",
                        element_name(kind)
                    ),
                )
                .primary(sc.file, span, "")
                .help(format!(
                    "the mesh has holes where they were: mesh the part with {} elements only (for hex8 in Gmsh: `Mesh.RecombineAll = 1` and `Mesh.SubdivisionAlgorithm = 2`; quadratic elements: `Mesh.ElementOrder = 1`)",
                    element_name(kind)
                )),
            );
        }
        let unused = data.nodes.len().saturating_sub(tags.len());
        if unused > 0 {
            let mut first: Vec<usize> = data
                .nodes
                .keys()
                .copied()
                .filter(|t| tags.binary_search(t).is_err())
                .collect();
            first.sort_unstable();
            first.truncate(5);
            let list = first
                .iter()
                .map(|t| t.to_string())
                .collect::<Vec<_>>()
                .join(", ");
            self.report(
                Diagnostic::warning(
                    codes::MESH,
                    format!(
                        "{unused} of the {} nodes of `{display}` belong to no {} element and are left out (node {list}{})",
                        data.nodes.len(),
                        element_name(kind),
                        if unused > first.len() { ", …" } else { "" }
                    ),
                )
                .primary(sc.file, span, "")
                .help("loads and sets only see the nodes of the mesh's elements; remove the stray nodes in the mesher"),
            );
        }
    }

    /// Warns about nodes at the same place (within 1e-9 of the mesh's size): the elements
    /// on either side of them are not connected, so the mesh has a crack there.
    fn warn_duplicate_nodes(
        &mut self,
        nodes: &[Vec3],
        tags: &[usize],
        display: &str,
        sc: &Scope,
        span: Span,
    ) {
        let pairs = coincident_nodes(nodes);
        if let Some(&(a, b)) = pairs.first() {
            let p = nodes[a];
            self.report(
                Diagnostic::warning(
                    codes::MESH,
                    format!(
                        "`{display}` has {} pair(s) of nodes at the same place, first nodes {} and {} at ({}, {}, {})",
                        pairs.len(),
                        tags[a],
                        tags[b],
                        num(p[0]),
                        num(p[1]),
                        num(p[2])
                    ),
                )
                .primary(sc.file, span, "")
                .help("elements that share a place but not a node are not connected (a crack); merge them in the mesher (Gmsh: `Coherence Mesh;`, or `Geometry.Tolerance`)"),
            );
        }
    }

    fn set_members(
        &mut self,
        value: &'a Expr,
        sc: &Scope,
        nodes: &[Vec3],
        tol: f64,
        imported: Option<&Imported>,
    ) -> R<Vec<usize>> {
        let ExprKind::Call { func, args } = &value.kind else {
            return Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    "a set is `nodes(PREDICATE)` or `group(\"name\")`",
                )
                .primary(sc.file, value.span, ""),
            ));
        };
        match func.name.as_str() {
            "nodes" => {
                let a = self.call_args(
                    func,
                    args,
                    &[super::props::pos("predicate")],
                    sc,
                    value.span,
                )?;
                let Some(pred) = a[0] else {
                    return Err(Reported);
                };
                let mut out = Vec::new();
                let len = |v: f64| Value::Num(Q::c(v, Dim::LENGTH));
                for (i, p) in nodes.iter().enumerate() {
                    let mut psc = sc.clone();
                    psc.eq_tol = tol;
                    psc.env = psc
                        .env
                        .bind("x", len(p[0]), BindKind::Builtin, sc.file, pred.span)
                        .bind("y", len(p[1]), BindKind::Builtin, sc.file, pred.span)
                        .bind("z", len(p[2]), BindKind::Builtin, sc.file, pred.span);
                    if self.boolean(pred, &psc)? {
                        out.push(i);
                    }
                }
                Ok(out)
            }
            "group" => {
                let a = self.call_args(func, args, &[super::props::pos("name")], sc, value.span)?;
                let Some(ne) = a[0] else { return Err(Reported) };
                let gname = self.string(ne, sc, "a physical group name")?;
                let Some(imp) = imported else {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::MESH,
                            "`group(...)` selects a physical group of an imported mesh",
                        )
                        .primary(sc.file, value.span, "this mesh is generated")
                        .help("use `nodes(PREDICATE)` for generated meshes"),
                    ));
                };
                let groups: Vec<&(i32, i32, String)> = imp
                    .data
                    .physical_names
                    .iter()
                    .filter(|g| g.2 == gname)
                    .collect();
                if groups.is_empty() {
                    let names: Vec<&str> = imp
                        .data
                        .physical_names
                        .iter()
                        .map(|g| g.2.as_str())
                        .collect();
                    let help = crate::suggest::did_you_mean(&gname, names.iter().copied())
                        .unwrap_or_else(|| {
                            if names.is_empty() {
                                "the file defines no physical groups".into()
                            } else {
                                format!("physical groups: {}", names.join(", "))
                            }
                        });
                    return Err(self.report(
                        Diagnostic::error(
                            codes::MESH,
                            format!("the mesh has no physical group \"{gname}\""),
                        )
                        .primary(sc.file, ne.span, "")
                        .help(help),
                    ));
                }
                let _ = imp.file;
                let mut out = Vec::new();
                for (dim, tag, _) in groups {
                    for el in &imp.data.elements {
                        if el.entity_dim == *dim
                            && imp
                                .data
                                .entity_physicals
                                .get(&(el.entity_dim, el.entity_tag))
                                .is_some_and(|p| p.contains(tag))
                        {
                            out.extend(
                                el.nodes
                                    .iter()
                                    .filter_map(|t| imp.tag_to_index.get(t).copied()),
                            );
                        }
                    }
                }
                out.sort_unstable();
                out.dedup();
                Ok(out)
            }
            other => Err(self.report(
                Diagnostic::error(
                    codes::UNKNOWN_NAME,
                    format!("unknown set selector `{other}`"),
                )
                .primary(sc.file, func.span, "")
                .help("a set is `nodes(PREDICATE)` or `group(\"name\")`"),
            )),
        }
    }

    fn set_ref(&mut self, e: &Expr, sc: &Scope, sets: &[NodeSet]) -> R<usize> {
        let Some(name) = ident_of(e) else {
            return Err(self.report(
                Diagnostic::error(codes::WRONG_KIND, "expected the name of a node set")
                    .primary(sc.file, e.span, ""),
            ));
        };
        if let Some(i) = sets.iter().position(|s| s.name == name) {
            return Ok(i);
        }
        let help = crate::suggest::did_you_mean(name, sets.iter().map(|s| s.name.as_str()))
            .unwrap_or_else(|| {
                if sets.is_empty() {
                    "declare a set with `set NAME = nodes(PREDICATE)`".into()
                } else {
                    format!(
                        "sets: {}",
                        sets.iter()
                            .map(|s| s.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                }
            });
        Err(self.report(
            Diagnostic::error(codes::UNKNOWN_NAME, format!("unknown set `{name}`"))
                .primary(sc.file, e.span, "not declared in this mesh")
                .help(help),
        ))
    }

    fn condition(
        &mut self,
        key: &str,
        values: &[Expr],
        sc: &Scope,
        sets: &[NodeSet],
        kind: ElementKind,
    ) -> R<MeshCondition> {
        if key == "body_force" {
            let v = self.vec23(&values[0], sc, Dim::FOUNDATION, "a body force (per volume)")?;
            return Ok(MeshCondition::BodyForce { value: v });
        }
        let set = self.set_ref(&values[0], sc, sets)?;
        if matches!(key, "traction" | "foundation") {
            self.boundary_set(key, &values[0], sc, &sets[set], kind)?;
        }
        match key {
            "fix" => Ok(MeshCondition::Fixed { set }),
            "tie" => {
                let be = &values[1];
                let bv = self.eval(be, sc)?;
                match self.body_ref(&bv, be.span, sc)? {
                    BodyRef::Body(body) => Ok(MeshCondition::Tie { set, body }),
                    BodyRef::Ground => Err(self.report(
                        Diagnostic::error(
                            codes::MESH,
                            "a node set is tied to a body, not to ground",
                        )
                        .primary(sc.file, be.span, "")
                        .help(format!("`fix {}` holds the set in place", sets[set].name)),
                    )),
                }
            }
            "displace" => {
                let e = &values[1];
                let ExprKind::Tuple(items) = &e.kind else {
                    return Err(self.report(
                        Diagnostic::error(codes::WRONG_KIND, "a displacement is a vector `(ux, uy, uz)`; `free` leaves a component free")
                            .primary(sc.file, e.span, ""),
                    ));
                };
                if items.len() != 3 && !(items.len() == 2 && kind.dim() == 2) {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::WRONG_KIND,
                            format!(
                                "a displacement needs 3 components (2 in 2-D), found {}",
                                items.len()
                            ),
                        )
                        .primary(sc.file, e.span, ""),
                    ));
                }
                let mut out: [Option<Fn1>; 3] = [None, None, None];
                if items.len() == 2 {
                    out[2] = Some(Fn1::Const(0.0));
                }
                for (i, it) in items.iter().enumerate() {
                    if ident_of(it) == Some("free") && sc.env.get("free").is_none() {
                        out[i] = None;
                        continue;
                    }
                    out[i] = Some(self.fn_num(it, sc, Dim::LENGTH, "a displacement")?);
                }
                if kind.dim() == 2 && items.len() == 2 {
                    out[2] = None;
                }
                Ok(MeshCondition::Displacement { set, value: out })
            }
            "load" | "traction" => {
                let (d, what) = if key == "load" {
                    (Dim::FORCE, "a nodal load")
                } else {
                    (Dim::PRESSURE, "a traction")
                };
                let v = self.fvec23(&values[1], sc, d, what, kind.dim() == 2)?;
                Ok(if key == "load" {
                    MeshCondition::NodalLoad { set, value: v }
                } else {
                    MeshCondition::Traction { set, value: v }
                })
            }
            _ => {
                let m = self.positive(&values[1], sc, Dim::FOUNDATION, "a foundation modulus")?;
                Ok(MeshCondition::Foundation { set, modulus: m })
            }
        }
    }

    /// An error unless `set` (written at `e`) holds a boundary edge (2-D) or face of the
    /// mesh, which `key` acts on.
    fn boundary_set(
        &mut self,
        key: &str,
        e: &Expr,
        sc: &Scope,
        set: &NodeSet,
        kind: ElementKind,
    ) -> R<()> {
        if !set.faces.is_empty() {
            return Ok(());
        }
        let (face, faces) = if kind.dim() == 2 {
            ("edge", "edges")
        } else {
            ("face", "faces")
        };
        Err(self.report(
            Diagnostic::error(
                codes::MESH,
                format!("set `{}` contains no boundary {face}", set.name),
            )
            .primary(sc.file, e.span, "")
            .help(format!(
                "`{key}` acts on the element {faces} whose nodes all belong to the set"
            )),
        ))
    }

    /// `glue SET, MESH.SET [{ traction polynomial(degree: P) | bessel(points: N) }]` in the
    /// mesh of index `this`: the condition with this mesh's set (which must hold boundary
    /// edges) and the other mesh's index (it may be declared later), and the other set's
    /// name and span, looked up by [`Lowerer::resolve_glues`] once every mesh is lowered
    /// (`other_set` is `usize::MAX` until then). The traction defaults to
    /// [`GlueTraction::default`].
    fn glue(
        &mut self,
        p: &Prop<'a>,
        sc: &Scope,
        sets: &[NodeSet],
        kind: ElementKind,
        this: usize,
    ) -> R<(MeshCondition, String, Span)> {
        let set = self.set_ref(&p.values[0], sc, sets).and_then(|i| {
            self.boundary_set("glue", &p.values[0], sc, &sets[i], kind)
                .map(|_| i)
        });
        let other = self.glue_other(&p.values[1], sc, this, sets);
        let traction = self.glue_traction(p.block, sc);
        let (set, (mesh, other_set, other_set_span), traction) = (set?, other?, traction?);
        Ok((
            MeshCondition::Glue {
                set,
                mesh,
                other_set: usize::MAX,
                traction,
            },
            other_set,
            other_set_span,
        ))
    }

    /// The `MESH.SET` of a glue: the mesh's index (any mesh but `this`), the set's name and
    /// its span.
    fn glue_other(
        &mut self,
        e: &Expr,
        sc: &Scope,
        this: usize,
        sets: &[NodeSet],
    ) -> R<(usize, String, Span)> {
        let ExprKind::Member { base, member } = &e.kind else {
            let example = sets.first().map_or("left", |s| s.name.as_str());
            return Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    "a set is glued to a set of another mesh: `glue SET, MESH.SET`",
                )
                .primary(sc.file, e.span, "expected `MESH.SET`")
                .help(format!(
                    "name the other mesh and its set, e.g. `glue {example}, other.{example}`"
                )),
            ));
        };
        let v = self.eval(base, sc)?;
        let mesh = match &v {
            Value::Name(n) => self.resolve(n, EntKind::Mesh)?,
            other => {
                return Err(self.report(
                    Diagnostic::error(
                        codes::WRONG_KIND,
                        format!("expected the name of a mesh, found {}", other.kind()),
                    )
                    .primary(sc.file, base.span, "not a mesh name"),
                ))
            }
        };
        if mesh == this {
            return Err(self.report(
                Diagnostic::error(codes::MESH, "a mesh cannot be glued to itself")
                    .primary(sc.file, base.span, "the mesh of this `glue`")
                    .help("a glue joins a set of this mesh to a set of another mesh; the elements of one mesh are joined already"),
            ));
        }
        Ok((mesh, member.name.clone(), member.span))
    }

    /// The options block of a glue: `traction polynomial(degree: P)` (P an integer in
    /// 0..=[`MAX_GLUE_DEGREE`]) or `traction bessel(points: N)` (N in
    /// 1..=[`MAX_GLUE_POINTS`]); without a block or `traction`, the default.
    fn glue_traction(&mut self, block: Option<&'a Block>, sc: &Scope) -> R<GlueTraction> {
        let Some(block) = block else {
            return Ok(GlueTraction::default());
        };
        let props = self.props(block, sc, "the options of `glue`", &[one("traction")], &[]);
        let Some(e) = props.value("traction") else {
            return Ok(GlueTraction::default());
        };
        let form = "a glue's traction is `polynomial(degree: P)` or `bessel(points: N)`";
        let ExprKind::Call { func, args } = &e.kind else {
            return Err(self.report(
                Diagnostic::error(codes::WRONG_KIND, form)
                    .primary(sc.file, e.span, "")
                    .help("for example `traction bessel(points: 5)` (the default) or `traction polynomial(degree: 2)`"),
            ));
        };
        let (arg, what, max, min) = match func.name.as_str() {
            "polynomial" => (
                "degree",
                "the degree of a polynomial traction",
                MAX_GLUE_DEGREE,
                0,
            ),
            "bessel" => (
                "points",
                "the number of points of a Bessel traction",
                MAX_GLUE_POINTS,
                1,
            ),
            other => {
                let help = match crate::suggest::closest(other, ["polynomial", "bessel"]) {
                    Some(c) => format!("did you mean `{c}`? {form}"),
                    None => form.to_string(),
                };
                return Err(self.report(
                    Diagnostic::error(
                        codes::UNKNOWN_NAME,
                        format!("unknown glue traction `{other}`"),
                    )
                    .primary(sc.file, func.span, "")
                    .help(help),
                ));
            }
        };
        let a = self.call_args(func, args, &[req(arg)], sc, e.span)?;
        let Some(ve) = a[0] else {
            return Err(Reported);
        };
        let n = self.int(ve, sc, what)?;
        if !(min..=max).contains(&n) {
            let help = if arg == "degree" {
                format!("degree P gives P + 1 traction parameters per direction; above {MAX_GLUE_DEGREE} the monomials are too ill-conditioned: use `bessel(points: N)` for more parameters")
            } else {
                "N points give N traction parameters per direction (1: a constant traction)"
                    .to_string()
            };
            return Err(self.report(
                Diagnostic::error(
                    codes::INVALID_VALUE,
                    format!("{what} must lie in {min} to {max}, found {n}"),
                )
                .primary(sc.file, ve.span, "")
                .help(help),
            ));
        }
        let n = n as u32;
        Ok(if arg == "degree" {
            GlueTraction::Polynomial { degree: n }
        } else {
            GlueTraction::Bessel { points: n }
        })
    }

    /// Completes the glues once every mesh is lowered (`meshes[i]` is `None` for a mesh that
    /// failed, whose glues are skipped): looks up each glue's other set (an error names the
    /// mesh, with a suggestion), which must hold boundary edges; refuses a pair of sets
    /// glued twice (from either side), and a glued set all of whose nodes are fixed,
    /// displaced or tied in its mesh (a glued set may share some nodes with such a set, as
    /// where an interface meets a clamped edge). Keeps the sites for `check_glues`.
    pub(crate) fn resolve_glues(&mut self, meshes: &mut [Option<Mesh>]) {
        let sites = std::mem::take(&mut self.glues);
        // The pairs glued so far, each with the site that glued it first.
        type Side = (usize, usize); // (mesh, set)
        let mut seen: Vec<((Side, Side), usize)> = Vec::new();
        for (k, site) in sites.iter().enumerate() {
            let (Some(Some(this)), Some(Some(other))) =
                (meshes.get(site.mesh), meshes.get(site.other_mesh))
            else {
                continue;
            };
            let Some(&MeshCondition::Glue { set, .. }) = this.conditions.get(site.condition) else {
                continue;
            };
            let file = site.file;
            let Some(os) = other
                .node_sets
                .iter()
                .position(|s| s.name == site.other_set)
            else {
                let names = other.node_sets.iter().map(|s| s.name.as_str());
                let help =
                    crate::suggest::did_you_mean(&site.other_set, names).unwrap_or_else(|| {
                        if other.node_sets.is_empty() {
                            format!(
                                "mesh `{}` declares no set: add `set {} = nodes(PREDICATE)` to it",
                                other.name, site.other_set
                            )
                        } else {
                            format!(
                                "sets of mesh `{}`: {}",
                                other.name,
                                other
                                    .node_sets
                                    .iter()
                                    .map(|s| s.name.as_str())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            )
                        }
                    });
                self.report(
                    Diagnostic::error(
                        codes::UNKNOWN_NAME,
                        format!("unknown set `{}` in mesh `{}`", site.other_set, other.name),
                    )
                    .primary(
                        file,
                        site.other_set_span,
                        format!("not declared in mesh `{}`", other.name),
                    )
                    .help(help),
                );
                continue;
            };
            if other.node_sets[os].faces.is_empty() {
                let face = if other.kind.dim() == 2 {
                    "edge"
                } else {
                    "face"
                };
                self.report(
                    Diagnostic::error(
                        codes::MESH,
                        format!(
                            "set `{}` of mesh `{}` contains no boundary {face}",
                            site.other_set, other.name
                        ),
                    )
                    .primary(file, site.other_set_span, "")
                    .help(format!(
                        "`glue` acts on the element {face}s whose nodes all belong to the set"
                    )),
                );
                continue;
            }
            let (a, b) = ((site.mesh, set), (site.other_mesh, os));
            let pair = if a <= b { (a, b) } else { (b, a) };
            if let Some(&(_, first)) = seen.iter().find(|(p, _)| *p == pair) {
                let f = &sites[first];
                self.report(
                    Diagnostic::error(
                        codes::MESH,
                        format!(
                            "`{}.{}` and `{}.{}` are glued twice",
                            this.name, this.node_sets[set].name, other.name, site.other_set
                        ),
                    )
                    .primary(file, site.span, "glued again here")
                    .secondary(f.file, f.span, "first glued here")
                    .help("a glue joins the two sets both ways: keep one `glue`"),
                );
                continue;
            }
            seen.push((pair, k));
            self.held_glued_set(site, site.mesh, this, set);
            self.held_glued_set(site, site.other_mesh, other, os);
            if let Some(Some(m)) = meshes.get_mut(site.mesh) {
                if let Some(MeshCondition::Glue { other_set, .. }) =
                    m.conditions.get_mut(site.condition)
                {
                    *other_set = os;
                }
            }
        }
        self.glues = sites;
    }

    /// An error for each condition of `mesh` (of index `mi`) that fixes, displaces or ties
    /// every node of its set `set`, glued by `site`.
    fn held_glued_set(&mut self, site: &GlueSite, mi: usize, mesh: &Mesh, set: usize) {
        let Some((file, spans)) = self.mesh_condition_spans.get(&mi).cloned() else {
            return;
        };
        let glued = &mesh.node_sets[set];
        for (j, c) in mesh.conditions.iter().enumerate() {
            let (held, what) = match c {
                MeshCondition::Fixed { set } => (*set, "fixed".to_string()),
                MeshCondition::Displacement { set, value } if value.iter().any(Option::is_some) => {
                    (*set, "displaced".to_string())
                }
                MeshCondition::Tie { set, body } => (
                    *set,
                    format!(
                        "tied to body `{}`",
                        self.scene_bodies
                            .get(*body)
                            .and_then(|b| b.as_ref())
                            .map_or("?", |b| b.name.as_str())
                    ),
                ),
                _ => continue,
            };
            let theirs = &mesh.node_sets[held].nodes;
            if !glued.nodes.iter().all(|n| theirs.binary_search(n).is_ok()) {
                continue;
            }
            let Some(&there) = spans.get(j) else {
                continue;
            };
            let short = what.split(' ').next().unwrap_or("held");
            self.report(
                Diagnostic::error(
                    codes::MESH,
                    format!(
                        "set `{}` of mesh `{}` is glued and {what}",
                        glued.name, mesh.name
                    ),
                )
                .primary(site.file, site.span, "glued here")
                .secondary(file, there, format!("{short} here"))
                .help(format!("every node of `{}` is {what}, which leaves the glue nothing to join: remove one of the two (a glued set may share some nodes with a held set, as where the interface meets a clamped edge)", glued.name)),
            );
        }
    }

    /// The ties of a mesh against its other conditions: a tied node is neither fixed nor
    /// displaced, nor tied twice (errors with both conditions' spans); a tie of a mesh with
    /// small strain gets a warning (the body's rotations strain it spuriously). Whether
    /// everything is fine.
    fn check_ties(&mut self, t: &Ties<'_>, sc: &Scope, kinematics: MeshKinematics) -> bool {
        let mut ok = true;
        let mut warned = false;
        for (i, c) in t.conditions.iter().enumerate() {
            let MeshCondition::Tie { set, body } = *c else {
                continue;
            };
            let bname = self
                .scene_bodies
                .get(body)
                .and_then(|b| b.as_ref())
                .map(|b| b.name.clone())
                .unwrap_or_default();
            for (j, o) in t.conditions.iter().enumerate() {
                let (os, what) = match o {
                    MeshCondition::Fixed { set } => (*set, "fixed"),
                    MeshCondition::Displacement { set, value }
                        if value.iter().any(Option::is_some) =>
                    {
                        (*set, "displaced")
                    }
                    MeshCondition::Tie { set, .. } if j < i => (*set, "tied"),
                    _ => continue,
                };
                let theirs = &t.sets[os].nodes;
                let Some(&n) = t.sets[set]
                    .nodes
                    .iter()
                    .find(|n| theirs.binary_search(n).is_ok())
                else {
                    continue;
                };
                let x = t.nodes[n];
                let place = format!(
                    "node {n} at ({}, {}, {}) m",
                    num(x[0]),
                    num(x[1]),
                    num(x[2])
                );
                let (message, help) = if what == "tied" {
                    (
                        format!("{place} of {} is tied twice", t.what),
                        "a node moves with one body: make the tied sets disjoint",
                    )
                } else {
                    (
                        format!("{place} of {} is tied to body `{bname}` and {what}", t.what),
                        "a tied node moves with its body: take it out of one of the two sets",
                    )
                };
                let (here, there) = if what == "tied" {
                    ("tied again here".to_string(), "first tied here".to_string())
                } else {
                    ("tied here".to_string(), format!("{what} here"))
                };
                self.report(
                    Diagnostic::error(codes::MESH, message)
                        .primary(sc.file, t.spans[i], here)
                        .secondary(sc.file, t.spans[j], there)
                        .help(help),
                );
                ok = false;
            }
            if kinematics == MeshKinematics::Small && !warned {
                warned = true;
                self.report(
                    Diagnostic::warning(
                        codes::MESH,
                        format!(
                            "{} is tied to body `{bname}` with small strain: a rotation θ of the body stresses its elements by about E·θ²/2 where it should not (0.5 % of E at 0.1 rad)",
                            t.what
                        ),
                    )
                    .primary(sc.file, t.spans[i], "")
                    .help("use `strain green` (exact under large rotations), or keep the body's rotations small"),
                );
            }
        }
        ok
    }

    /// A vector of functions of time with 3 components, or 2 in 2-D (z = 0).
    fn fvec23(&mut self, e: &Expr, sc: &Scope, d: Dim, what: &str, allow2: bool) -> R<[Fn1; 3]> {
        let v = self.eval(e, sc)?;
        if let Value::Tuple(items) = &v {
            if allow2 && items.len() == 2 {
                let mut items = items.clone();
                items.push(Value::Num(Q {
                    f: Fn1::Const(0.0),
                    dim: d,
                    poly: true,
                    var: crate::value::Var::None,
                }));
                return self.fvec3_of(Value::Tuple(items), e.span, sc, d, what);
            }
        }
        self.fvec3_of(v, e.span, sc, d, what)
    }
}

/// How many elements of each Gmsh type, by type.
fn type_counts<'e>(elements: impl Iterator<Item = &'e msh::MshElement>) -> Vec<(u32, usize)> {
    let mut have: std::collections::BTreeMap<u32, usize> = Default::default();
    for el in elements {
        *have.entry(el.etype).or_default() += 1;
    }
    have.into_iter().collect()
}

/// The dimension of a Gmsh element type (0 for points and types mbdc does not know).
fn msh_dimension(etype: u32) -> u8 {
    match etype {
        1 | 8 | 26..=28 => 1,
        2 | 3 | 9 | 10 | 16 | 20..=25 => 2,
        4..=7 | 11..=14 | 17..=19 | 29..=31 => 3,
        _ => 0,
    }
}

/// The pairs of nodes within 1e-9 of the bounding-box diagonal of each other, sorted: a
/// hash grid of cells the size of the tolerance, each node compared with the nodes of the
/// 27 cells around it (linear time for any mesh, also when many nodes share a coordinate).
pub fn coincident_nodes(nodes: &[Vec3]) -> Vec<(usize, usize)> {
    let (lo, hi) = bbox(nodes);
    let diag = ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
    let tol = 1e-9 * if diag > 0.0 { diag } else { 1.0 };
    let cell =
        |p: &Vec3| -> [i64; 3] { std::array::from_fn(|k| ((p[k] - lo[k]) / tol).floor() as i64) };
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::with_capacity(nodes.len());
    for (i, p) in nodes.iter().enumerate() {
        grid.entry(cell(p)).or_default().push(i);
    }
    let mut pairs = Vec::new();
    for (a, p) in nodes.iter().enumerate() {
        let c = cell(p);
        for d in 0..27i64 {
            let key = [c[0] + d % 3 - 1, c[1] + (d / 3) % 3 - 1, c[2] + d / 9 - 1];
            for &b in grid.get(&key).map_or(&[][..], |v| v.as_slice()) {
                let d2 = (0..3).map(|k| (p[k] - nodes[b][k]).powi(2)).sum::<f64>();
                if b > a && d2 <= tol * tol {
                    pairs.push((a, b));
                }
            }
        }
    }
    pairs.sort_unstable();
    pairs
}

/// A mesh's lowered conditions with what [`Lowerer::check_ties`] needs to judge its ties.
struct Ties<'t> {
    what: &'t str,
    conditions: &'t [MeshCondition],
    /// The span of each condition's property.
    spans: &'t [Span],
    sets: &'t [NodeSet],
    nodes: &'t [Vec3],
}

/// The element keyword of a kind (`quad4` for both quad4 kinds).
pub(crate) fn element_name(k: ElementKind) -> &'static str {
    match k {
        ElementKind::Bar2 => "bar2",
        ElementKind::Tri3PlaneStress | ElementKind::Tri3PlaneStrain => "tri3",
        ElementKind::Quad4PlaneStress | ElementKind::Quad4PlaneStrain => "quad4",
        ElementKind::Tet4 => "tet4",
        ElementKind::Hex8 => "hex8",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_meshes() {
        let (n, e) = rect_mesh([0.0; 3], [1.0, 0.5], [2, 1], false);
        assert_eq!(n.len(), 6);
        assert_eq!(e, vec![vec![0, 1, 4, 3], vec![1, 2, 5, 4]]);
        let (_, t) = rect_mesh([0.0; 3], [1.0, 0.5], [2, 1], true);
        assert_eq!(t.len(), 4);
        let (n, h) = box_mesh([0.0; 3], [1.0, 1.0, 1.0], [2, 2, 2], false);
        assert_eq!((n.len(), h.len()), (27, 8));
        let (n, t) = box_mesh([0.0; 3], [1.0, 2.0, 3.0], [2, 1, 1], true);
        assert_eq!(t.len(), 12);
        let total: f64 = t.iter().map(|t| tet_volume(&n, t)).sum();
        assert!((total - 6.0).abs() < 1e-12);
        assert!(t.iter().all(|t| tet_volume(&n, t) > 0.0));
        // A conforming split: interior faces pair up, so the boundary has 2 triangles per
        // outer quad face: 2 * (2*1 + 2*1 + 1*1) * 2 = 20.
        assert_eq!(boundary_faces(ElementKind::Tet4, &t).len(), 20);
        let b = boundary_faces(ElementKind::Quad4PlaneStress, &e);
        assert_eq!(b.len(), 6);
    }

    #[test]
    fn coincident_nodes_are_found_within_the_tolerance_only() {
        let (mut n, _) = box_mesh([0.0; 3], [1.0, 1.0, 1.0], [10, 10, 10], false);
        assert!(coincident_nodes(&n).is_empty());
        let diag = 3f64.sqrt();
        let mut twin = n[17];
        twin[1] += 0.5e-9 * diag;
        n.push(twin);
        let mut apart = n[500];
        apart[2] += 2e-9 * diag;
        n.push(apart);
        n.push(n[3]);
        assert_eq!(coincident_nodes(&n), vec![(3, 1333), (17, 1331)]);
    }
}
