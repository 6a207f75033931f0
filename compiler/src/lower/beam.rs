//! Materials (elastic constants, and J2 plasticity for meshes) and flexible beams.
//!
//! Sections from a material and a shape: `A`, second moments `I2` (about section axis 2,
//! which lies along `up`) and `I3` (about axis 3), torsion constant `J`, and a shear
//! factor κ (5/6 for rectangles, 0.9 for circles and tubes):
//! `EA = E A`, `GA2 = GA3 = κ G A`, `EI2 = E I2`, `EI3 = E I3`, `GJ = G J`, `ρA`,
//! `ρI = ρ (I2 + I3)`, with `G = E / (2 (1 + ν))`. A rectangle's `height` lies along axis 2
//! (`up`) and its `width` along axis 3: `I2 = h w³/12`, `I3 = w h³/12`,
//! `J = a b³ (1/3 − 0.21 (b/a)(1 − b⁴/(12 a⁴)))` with `a ≥ b` the longer and shorter side.

use mbdc_dsl::ast::{Expr, ExprKind, ItemKind};
use mbdc_runtime::scene::{
    Attachment, Beam, BeamAttachment, BodyRef, Material, Plasticity, Section, Vec3,
};
use nalgebra::Vector3;

use super::body::num;
use super::eval::ident_of;
use super::props::{one, req, Key};
use super::{EntKind, Lowerer, PDecl, Reported, Scope, R};
use crate::diag::{codes, Diagnostic};
use crate::geom;
use crate::source::Sources;
use crate::units::Dim;
use crate::value::Value;

/// Most elements of a beam.
pub const MAX_BEAM_ELEMENTS: usize = 1_000_000;

const MATERIAL_KEYS: &[Key] = &[one("E"), one("nu"), one("rho")];
const PLASTIC_KEYS: &[Key] = &[one("yield"), one("hardening")];
const BEAM_KEYS: &[Key] = &[
    one("from"),
    one("to"),
    one("points"),
    one("elements"),
    one("up"),
    one("material"),
    one("shape"),
    one("damping"),
    one("rotary_inertia_scale"),
    one("velocity"),
    one("angular_velocity"),
    Key {
        name: "clamp",
        min: 1,
        max: 2,
        repeat: true,
    },
    Key {
        name: "pin",
        min: 1,
        max: 2,
        repeat: true,
    },
];
const SECTION_KEYS: &[Key] = &[
    one("EA"),
    one("GA2"),
    one("GA3"),
    one("EI2"),
    one("EI3"),
    one("GJ"),
    one("rhoA"),
    one("rhoI"),
];

/// Section properties of a shape with a material.
pub fn shape_section(m: &Material, shape: &ShapeDims) -> Section {
    let g = m.e / (2.0 * (1.0 + m.nu));
    let (a, i2, i3, j, kappa) = match *shape {
        ShapeDims::Rect {
            width: w,
            height: h,
        } => {
            let (la, lb) = if w >= h { (w, h) } else { (h, w) };
            let j = la
                * lb.powi(3)
                * (1.0 / 3.0 - 0.21 * (lb / la) * (1.0 - lb.powi(4) / (12.0 * la.powi(4))));
            (
                w * h,
                h * w.powi(3) / 12.0,
                w * h.powi(3) / 12.0,
                j,
                5.0 / 6.0,
            )
        }
        ShapeDims::Circle { radius: r } => {
            let i = std::f64::consts::PI * r.powi(4) / 4.0;
            (std::f64::consts::PI * r * r, i, i, 2.0 * i, 0.9)
        }
        ShapeDims::Tube { outer, inner } => {
            let i = std::f64::consts::PI * (outer.powi(4) - inner.powi(4)) / 4.0;
            (
                std::f64::consts::PI * (outer * outer - inner * inner),
                i,
                i,
                2.0 * i,
                0.9,
            )
        }
    };
    Section {
        ea: m.e * a,
        ga2: kappa * g * a,
        ga3: kappa * g * a,
        ei2: m.e * i2,
        ei3: m.e * i3,
        gj: g * j,
        rho_a: m.rho * a,
        rho_i: m.rho * (i2 + i3),
    }
}

/// Cross-section shapes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShapeDims {
    /// Rectangle: width along section axis 3, height along axis 2 (`up`).
    Rect {
        /// m
        width: f64,
        /// m
        height: f64,
    },
    /// Solid circle.
    Circle {
        /// m
        radius: f64,
    },
    /// Circular tube.
    Tube {
        /// m
        outer: f64,
        /// m
        inner: f64,
    },
}

/// Splits `n` elements over segments proportionally to their lengths (each ≥ 1).
pub fn split_elements(lengths: &[f64], n: usize) -> Vec<usize> {
    let total: f64 = lengths.iter().sum();
    let ideal: Vec<f64> = lengths.iter().map(|l| n as f64 * l / total).collect();
    let mut k: Vec<usize> = ideal.iter().map(|x| (x.floor() as usize).max(1)).collect();
    let mut sum: usize = k.iter().sum();
    while sum < n {
        let (i, _) = ideal
            .iter()
            .enumerate()
            .map(|(i, x)| (i, x - k[i] as f64))
            .fold((0, f64::NEG_INFINITY), |b, c| if c.1 > b.1 { c } else { b });
        k[i] += 1;
        sum += 1;
    }
    while sum > n {
        let Some((i, _)) = ideal
            .iter()
            .enumerate()
            .filter(|(i, _)| k[*i] > 1)
            .map(|(i, x)| (i, x - k[i] as f64))
            .fold(None, |b: Option<(usize, f64)>, c| match b {
                Some(bb) if bb.1 <= c.1 => Some(bb),
                _ => Some(c),
            })
        else {
            break;
        };
        k[i] -= 1;
        sum -= 1;
    }
    k
}

impl<'a> Lowerer<'a> {
    pub(crate) fn lower_material(&mut self, d: &PDecl<'a>) -> R<Material> {
        let sc = &d.sc;
        let what = format!("material `{}`", d.name);
        let Some(block) = d.block else {
            return Err(Reported);
        };
        let props = self.props(block, sc, &what, MATERIAL_KEYS, &["plastic"]);
        let plastic = self.material_plastic(&props, sc, &what);
        let e = match props.value("E") {
            Some(x) => self.positive(x, sc, Dim::PRESSURE, "Young's modulus E"),
            None => Err(self.missing(&props, "E", &what, sc, d.name_span, "E 210 GPa")),
        };
        let nu = match props.value("nu") {
            Some(x) => self
                .const_num(x, sc, Dim::NONE, "Poisson's ratio nu")
                .and_then(|v| {
                    if v <= -1.0 || v >= 0.5 {
                        Err(self.report(
                            Diagnostic::error(
                                codes::INVALID_VALUE,
                                format!("Poisson's ratio must be in (−1, 0.5), found {}", num(v)),
                            )
                            .primary(sc.file, x.span, ""),
                        ))
                    } else {
                        Ok(v)
                    }
                }),
            None => Err(self.missing(&props, "nu", &what, sc, d.name_span, "nu 0.3")),
        };
        let rho = match props.value("rho") {
            Some(x) => self.positive(x, sc, Dim::DENSITY, "a density"),
            None => Err(self.missing(&props, "rho", &what, sc, d.name_span, "rho 7850 kg/m^3")),
        };
        Ok(Material {
            e: e?,
            nu: nu?,
            rho: rho?,
            plastic: plastic?,
        })
    }

    /// The material's `plastic { yield ...; hardening ... }` block, if any: J2 plasticity
    /// with the initial yield stress (> 0) and the linear isotropic hardening modulus
    /// (≥ 0, default 0: perfectly plastic), both stresses.
    fn material_plastic(
        &mut self,
        props: &super::props::Props<'a>,
        sc: &Scope,
        what: &str,
    ) -> R<Option<Plasticity>> {
        let Some(&item) = props.decls.first() else {
            return Ok(None);
        };
        if let Some(second) = props.decls.get(1) {
            return Err(self.report(
                Diagnostic::error(
                    codes::DUPLICATE_PROPERTY,
                    format!("`plastic` is given twice in {what}"),
                )
                .primary(sc.file, second.span, "second")
                .secondary(sc.file, item.span, "first"),
            ));
        }
        let form =
            "`plastic` is written with a block: `plastic { yield 250 MPa; hardening 1 GPa }`";
        let ItemKind::Decl {
            body: Some(block),
            name: None,
            value: None,
            ..
        } = &item.kind
        else {
            return Err(self.report(
                Diagnostic::error(codes::WRONG_KIND, form).primary(sc.file, item.span, ""),
            ));
        };
        let inner = format!("the `plastic` block of {what}");
        let pp = self.props(block, sc, &inner, PLASTIC_KEYS, &[]);
        let yield_stress = match pp.value("yield") {
            Some(x) => self.positive(x, sc, Dim::PRESSURE, "the yield stress"),
            None => Err(self.missing(&pp, "yield", &inner, sc, item.span, "yield 250 MPa")),
        };
        let hardening = match pp.value("hardening") {
            Some(x) => self.nonneg(x, sc, Dim::PRESSURE, "the hardening modulus"),
            None => Ok(0.0),
        };
        Ok(Some(Plasticity {
            yield_stress: yield_stress?,
            hardening: hardening?,
        }))
    }

    /// The material a name refers to.
    pub(crate) fn material_ref(&mut self, e: &Expr, sc: &Scope) -> R<Material> {
        let v = self.eval(e, sc)?;
        let Value::Name(n) = &v else {
            return Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!("expected the name of a material, found {}", v.kind()),
                )
                .primary(sc.file, e.span, ""),
            ));
        };
        let i = self.resolve(n, EntKind::Material)?;
        self.scene_materials
            .get(i)
            .copied()
            .flatten()
            .ok_or(Reported)
    }

    pub(crate) fn lower_beam(&mut self, d: &PDecl<'a>) -> R<Beam> {
        let sc = &d.sc;
        let what = format!("beam `{}`", d.name);
        let Some(block) = d.block else {
            return Err(Reported);
        };
        let props = self.props(block, sc, &what, BEAM_KEYS, &["section"]);
        // Geometry.
        let pts: R<Vec<Vec3>> = match (props.get("from"), props.get("to"), props.get("points")) {
            (Some(f), Some(t), None) => {
                let a = self.vec3(&f.values[0], sc, Dim::LENGTH, "a beam end");
                let b = self.vec3(&t.values[0], sc, Dim::LENGTH, "a beam end");
                Ok(vec![a?, b?])
            }
            (None, None, Some(p)) => {
                let e = &p.values[0];
                match self.eval(e, sc) {
                    Ok(Value::List(items)) if items.len() >= 2 => {
                        let mut out = Vec::new();
                        let mut bad = false;
                        for it in items {
                            match self.vec3_of(it, e.span, sc, Dim::LENGTH, "a beam point") {
                                Ok(p) => out.push(p),
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
                            format!(
                                "`points` needs a list of at least two points, found {}",
                                other.kind()
                            ),
                        )
                        .primary(sc.file, e.span, "")
                        .help("write `points [(0, 0, 0) m, (1, 0, 0) m, (1, 1, 0) m]`"),
                    )),
                    Err(r) => Err(r),
                }
            }
            (f, t, p) => {
                let span = [f, t, p]
                    .iter()
                    .flatten()
                    .map(|p| p.span)
                    .next()
                    .unwrap_or(d.name_span);
                Err(self.report(
                    Diagnostic::error(
                        codes::BEAM,
                        format!("{what} needs either `from` and `to`, or `points`"),
                    )
                    .primary(sc.file, span, "")
                    .help("write `from (0, 0, 0) m` and `to (1, 0, 0) m`, or `points [...]`"),
                ))
            }
        };
        let elements = match props.value("elements") {
            Some(e) => self.int(e, sc, "a number of elements").and_then(|n| {
                if n < 1 || n as usize > MAX_BEAM_ELEMENTS {
                    Err(self.report(
                        Diagnostic::error(
                            codes::INVALID_VALUE,
                            format!(
                                "a beam needs 1 to {} elements, found {n}",
                                super::expand::fmt_count(MAX_BEAM_ELEMENTS)
                            ),
                        )
                        .primary(sc.file, e.span, ""),
                    ))
                } else {
                    Ok((n as usize, e.span))
                }
            }),
            None => Err(self.missing(&props, "elements", &what, sc, d.name_span, "elements 10")),
        };
        let up_given = props
            .value("up")
            .map(|e| (self.axis(e, sc, "an up direction"), e.span));
        let section = self.beam_section(&props, sc, &what, d);
        let damping = match props.value("damping") {
            Some(e) => self.nonneg(e, sc, Dim::TIME, "a beam's damping coefficient"),
            None => Ok(0.0),
        };
        let rotary_inertia_scale = match props.value("rotary_inertia_scale") {
            Some(e) => self
                .positive(e, sc, Dim::NONE, "a rotary-inertia scale")
                .and_then(|v| {
                    if v < 1.0 {
                        Err(self.report(
                            Diagnostic::error(
                                codes::INVALID_VALUE,
                                format!(
                                    "a rotary-inertia scale below 1 ({}) would raise the beam's highest frequency and lower its step limit",
                                    num(v)
                                ),
                            )
                            .primary(sc.file, e.span, "below 1")
                            .help("give a factor of 1 or more (1: the section's own rotary inertia)"),
                        ))
                    } else {
                        Ok(v)
                    }
                }),
            None => Ok(1.0),
        };
        // Initial rigid motion: the first node's velocity and a rotation about it (world).
        let velocity = match props.value("velocity") {
            Some(e) => self.vec3(e, sc, Dim::VELOCITY, "a velocity"),
            None => Ok([0.0; 3]),
        };
        let angular_velocity = match props.value("angular_velocity") {
            Some(e) => self.vec3(e, sc, Dim::FREQUENCY, "an angular velocity"),
            None => Ok([0.0; 3]),
        };
        let (velocity, angular_velocity) = (velocity?, angular_velocity?);
        let (pts, (elements, espan), section) = (pts?, elements?, section?);
        let (damping, rotary_inertia_scale) = (damping?, rotary_inertia_scale?);
        // Subdivide.
        let lengths: Vec<f64> = pts
            .windows(2)
            .map(|w| (geom::v(w[1]) - geom::v(w[0])).norm())
            .collect();
        if let Some(i) = lengths.iter().position(|l| *l < 1e-12) {
            return Err(self.report(
                Diagnostic::error(
                    codes::BEAM,
                    format!(
                        "{what} has a segment of zero length (points {} and {})",
                        i,
                        i + 1
                    ),
                )
                .primary(sc.file, d.name_span, "")
                .help("remove the repeated point"),
            ));
        }
        if elements < lengths.len() {
            return Err(self.report(
                Diagnostic::error(
                    codes::BEAM,
                    format!(
                        "{what} has {} segments but only {elements} elements",
                        lengths.len()
                    ),
                )
                .primary(sc.file, espan, "")
                .help("every segment needs at least one element"),
            ));
        }
        let split = split_elements(&lengths, elements);
        let mut nodes: Vec<Vec3> = vec![pts[0]];
        for (s, k) in split.iter().enumerate() {
            let (a, b) = (geom::v(pts[s]), geom::v(pts[s + 1]));
            for j in 1..=*k {
                nodes.push(geom::a(&(a + (b - a) * (j as f64 / *k as f64))));
            }
        }
        let total: f64 = lengths.iter().sum();
        // Up direction.
        let dirs: Vec<Vector3<f64>> = pts
            .windows(2)
            .map(|w| (geom::v(w[1]) - geom::v(w[0])).normalize())
            .collect();
        let up = match up_given {
            Some((u, span)) => {
                let u = u?;
                if dirs.iter().any(|t| t.cross(&u).norm() < 1e-6) {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::BEAM,
                            format!("the `up` direction of {what} is parallel to the beam"),
                        )
                        .primary(sc.file, span, "")
                        .help("`up` fixes the section's axis 2 and must not be along the beam"),
                    ));
                }
                u
            }
            None => {
                let t = dirs[0];
                let e = if t.z.abs() > 0.9 {
                    Vector3::x()
                } else {
                    Vector3::z()
                };
                (e - t * t.dot(&e)).normalize()
            }
        };
        // Attachments.
        let mut attachments: Vec<BeamAttachment> = Vec::new();
        let mut ok = true;
        for p in props
            .list
            .iter()
            .filter(|p| p.key.name == "clamp" || p.key.name == "pin")
        {
            let clamped = p.key.name == "clamp";
            let node = match self.node_ref(&p.values[0], sc, elements) {
                Ok(n) => n,
                Err(_) => {
                    ok = false;
                    continue;
                }
            };
            if attachments.iter().any(|a| a.node == node) {
                self.report(
                    Diagnostic::error(
                        codes::BEAM,
                        format!("node {node} of {what} is attached twice"),
                    )
                    .primary(sc.file, p.span, "second attachment"),
                );
                ok = false;
                continue;
            }
            let pos = geom::v(nodes[node]);
            let to = match p.values.get(1) {
                None => Attachment {
                    body: BodyRef::Ground,
                    point: nodes[node],
                    frame: geom::IDENTITY,
                },
                Some(ae) => match self.attachment(ae, sc) {
                    Ok(att) => {
                        let gap = (att.world - pos).norm();
                        if gap > 1e-9 * total.max(1e-300) + 1e-12 {
                            self.report(
                                Diagnostic::warning(
                                    codes::INITIAL_VIOLATION,
                                    format!("the attachment point is {} m from node {node} of {what}", num(gap)),
                                )
                                .primary(sc.file, ae.span, "")
                                .help("the node is tied to the point as it is at t = 0; move the point onto the node"),
                            );
                        }
                        att.with_frame(&nalgebra::Matrix3::identity())
                    }
                    Err(_) => {
                        ok = false;
                        continue;
                    }
                },
            };
            attachments.push(BeamAttachment { node, to, clamped });
        }
        if !ok {
            return Err(Reported);
        }
        Ok(Beam {
            name: d.name.clone(),
            nodes,
            up: geom::a(&up),
            section,
            attachments,
            damping,
            rotary_inertia_scale,
            velocity,
            angular_velocity,
            origin: Sources::origin(sc.file, d.span),
        })
    }

    fn node_ref(&mut self, e: &Expr, sc: &Scope, elements: usize) -> R<usize> {
        match ident_of(e) {
            Some("start") => return Ok(0),
            Some("end") => return Ok(elements),
            _ => {}
        }
        let i = self.int(e, sc, "a node index")?;
        if i < 0 || i as usize > elements {
            return Err(self.report(
                Diagnostic::error(
                    codes::BEAM,
                    format!("node {i} does not exist: the beam has nodes 0 to {elements}"),
                )
                .primary(sc.file, e.span, "")
                .help("use `start`, `end` or an index"),
            ));
        }
        Ok(i as usize)
    }

    fn beam_section(
        &mut self,
        props: &super::props::Props<'a>,
        sc: &Scope,
        what: &str,
        d: &PDecl<'a>,
    ) -> R<Section> {
        let section_decl = props.decls.first().copied();
        if props.decls.len() > 1 {
            self.report(
                Diagnostic::error(
                    codes::DUPLICATE_PROPERTY,
                    format!("`section` is given twice in {what}"),
                )
                .primary(sc.file, props.decls[1].span, "second"),
            );
            return Err(Reported);
        }
        let mat = props.get("material");
        let shape = props.get("shape");
        match (section_decl, mat, shape) {
            (Some(item), None, None) => {
                let ItemKind::Decl { body: Some(block), name, value, .. } = &item.kind else {
                    return Err(self.report(
                        Diagnostic::error(codes::BEAM, "`section` is written with a block: `section { EA ...; ... }`")
                            .primary(sc.file, item.span, ""),
                    ));
                };
                if name.is_some() || value.is_some() {
                    return Err(self.report(
                        Diagnostic::error(codes::BEAM, "`section` is written with a block: `section { EA ...; ... }`")
                            .primary(sc.file, item.span, ""),
                    ));
                }
                let sp = self.props(block, sc, "a section", SECTION_KEYS, &[]);
                let dims = [
                    ("EA", Dim::FORCE),
                    ("GA2", Dim::FORCE),
                    ("GA3", Dim::FORCE),
                    ("EI2", Dim::BENDING),
                    ("EI3", Dim::BENDING),
                    ("GJ", Dim::BENDING),
                    ("rhoA", Dim::MASS_PER_LENGTH),
                    ("rhoI", Dim::MASS_LENGTH),
                ];
                let mut vals = [0.0; 8];
                let mut ok = true;
                for (i, (k, dim)) in dims.iter().enumerate() {
                    match sp.value(k) {
                        Some(e) => match self.positive(e, sc, *dim, k) {
                            Ok(v) => vals[i] = v,
                            Err(_) => ok = false,
                        },
                        None => {
                            self.missing(&sp, k, "the section", sc, item.span, &format!("{k} VALUE"));
                            ok = false;
                        }
                    }
                }
                if !ok {
                    return Err(Reported);
                }
                Ok(Section {
                    ea: vals[0],
                    ga2: vals[1],
                    ga3: vals[2],
                    ei2: vals[3],
                    ei3: vals[4],
                    gj: vals[5],
                    rho_a: vals[6],
                    rho_i: vals[7],
                })
            }
            (None, Some(m), Some(s)) => {
                let mat = self.material_ref(&m.values[0], sc);
                let dims = self.shape_dims(&s.values[0], sc);
                let mat = mat?;
                if mat.plastic.is_some() {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::BEAM,
                            format!("{what} uses a plastic material; beams are elastic"),
                        )
                        .primary(sc.file, m.span, "this material has a `plastic` block")
                        .help("give the beam a material without `plastic` (plasticity is for meshes), or model the part as a mesh"),
                    ));
                }
                Ok(shape_section(&mat, &dims?))
            }
            (None, None, None) => Err(self.report(
                Diagnostic::error(codes::MISSING_PROPERTY, format!("{what} has no section"))
                    .primary(sc.file, d.name_span, "")
                    .help("add `material NAME` and `shape rect(width: w, height: h)`, or `section { EA ...; GA2 ...; GA3 ...; EI2 ...; EI3 ...; GJ ...; rhoA ...; rhoI ... }`"),
            )),
            (None, Some(m), None) => Err(self.missing(props, "shape", what, sc, m.span, "shape rect(width: 2 cm, height: 1 cm)")),
            (None, None, Some(s)) => Err(self.missing(props, "material", what, sc, s.span, "material steel")),
            (Some(item), _, _) => Err(self.report(
                Diagnostic::error(codes::BEAM, format!("{what} has both a `section` and a material/shape"))
                    .primary(sc.file, item.span, "")
                    .help("give either explicit section values or a material and a shape"),
            )),
        }
    }

    fn shape_dims(&mut self, e: &'a Expr, sc: &Scope) -> R<ShapeDims> {
        let ExprKind::Call { func, args } = &e.kind else {
            return Err(self.report(
                Diagnostic::error(codes::WRONG_KIND, "a shape is `rect(width:, height:)`, `circle(radius:)` or `tube(outer:, inner:)`")
                    .primary(sc.file, e.span, ""),
            ));
        };
        match func.name.as_str() {
            "rect" => {
                let a = self.call_args(func, args, &[req("width"), req("height")], sc, e.span)?;
                let (Some(w), Some(h)) = (a[0], a[1]) else {
                    return Err(Reported);
                };
                let w = self.positive(w, sc, Dim::LENGTH, "a width");
                let h = self.positive(h, sc, Dim::LENGTH, "a height");
                Ok(ShapeDims::Rect {
                    width: w?,
                    height: h?,
                })
            }
            "circle" => {
                let a = self.call_args(func, args, &[req("radius")], sc, e.span)?;
                let Some(r) = a[0] else { return Err(Reported) };
                Ok(ShapeDims::Circle {
                    radius: self.positive(r, sc, Dim::LENGTH, "a radius")?,
                })
            }
            "tube" => {
                let a = self.call_args(func, args, &[req("outer"), req("inner")], sc, e.span)?;
                let (Some(o), Some(i)) = (a[0], a[1]) else {
                    return Err(Reported);
                };
                let ro = self.positive(o, sc, Dim::LENGTH, "an outer radius");
                let ri = self.nonneg(i, sc, Dim::LENGTH, "an inner radius");
                let (ro, ri) = (ro?, ri?);
                if ri >= ro {
                    return Err(self.report(
                        Diagnostic::error(codes::INVALID_VALUE, format!("a tube's inner radius ({} m) must be smaller than its outer radius ({} m)", num(ri), num(ro)))
                            .primary(sc.file, e.span, ""),
                    ));
                }
                Ok(ShapeDims::Tube {
                    outer: ro,
                    inner: ri,
                })
            }
            other => {
                let help = match crate::suggest::closest(other, ["rect", "circle", "tube"]) {
                    Some(s) => format!("did you mean `{s}`?"),
                    None => "shapes: rect(width:, height:), circle(radius:), tube(outer:, inner:)"
                        .into(),
                };
                Err(self.report(
                    Diagnostic::error(
                        codes::UNKNOWN_NAME,
                        format!("unknown section shape `{other}`"),
                    )
                    .primary(sc.file, func.span, "")
                    .help(help),
                ))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits() {
        assert_eq!(split_elements(&[1.0], 10), vec![10]);
        assert_eq!(split_elements(&[1.0, 1.0], 10), vec![5, 5]);
        assert_eq!(split_elements(&[1.0, 3.0], 4), vec![1, 3]);
        assert_eq!(split_elements(&[0.01, 1.0, 1.0], 3), vec![1, 1, 1]);
        let s = split_elements(&[0.3, 0.3, 0.4], 7);
        assert_eq!(s.iter().sum::<usize>(), 7);
    }

    #[test]
    fn sections() {
        let steel = Material {
            e: 210e9,
            nu: 0.3,
            rho: 7850.0,
            plastic: None,
        };
        let s = shape_section(
            &steel,
            &ShapeDims::Rect {
                width: 0.02,
                height: 0.01,
            },
        );
        assert!((s.ei3 - 210e9 * 0.02 * 1e-6 / 12.0).abs() < 1e-6);
        assert!((s.ei2 - 210e9 * 0.01 * 8e-6 / 12.0).abs() < 1e-6);
        assert!((s.rho_a - 7850.0 * 2e-4).abs() < 1e-12);
        let g = 210e9 / 2.6;
        assert!((s.ga2 - 5.0 / 6.0 * g * 2e-4).abs() < 1e-3);
        let c = shape_section(&steel, &ShapeDims::Circle { radius: 0.01 });
        assert!((c.gj - g * std::f64::consts::PI * 1e-8 / 2.0).abs() < 1e-6);
        // A square's torsion constant is ≈ 0.1406 a⁴.
        let q = shape_section(
            &steel,
            &ShapeDims::Rect {
                width: 1.0,
                height: 1.0,
            },
        );
        assert!((q.gj / g - 0.1406).abs() < 1e-3);
    }
}
