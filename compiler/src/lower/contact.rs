//! Penalty contact pairs.

use mbdc_dsl::ast::ExprKind;
use mbdc_runtime::scene::{Attachment, Contact, Shape};

use super::props::{opt, pos, req, ArgSpec};
use super::{Lowerer, PDecl, Reported, R};
use crate::diag::{codes, Diagnostic};
use crate::geom;
use crate::source::Sources;
use crate::units::Dim;

const CONTACT_KINDS: &[&str] = &["sphere_plane", "sphere_sphere", "box_plane"];

impl<'a> Lowerer<'a> {
    pub(crate) fn lower_contact(&mut self, d: &PDecl<'a>) -> R<Contact> {
        let sc = &d.sc;
        let Some(value) = d.value else {
            return Err(Reported);
        };
        let ExprKind::Call { func, args } = &value.kind else {
            return Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    "a contact is `KIND(A @ POINT, B @ POINT, ...)`",
                )
                .primary(sc.file, value.span, "not a contact kind")
                .help(format!("contact kinds: {}", CONTACT_KINDS.join(", "))),
            ));
        };
        let kind = func.name.as_str();
        let mut spec: Vec<ArgSpec> = vec![pos("a"), pos("b")];
        match kind {
            "sphere_plane" => spec.extend([req("radius"), req("normal")]),
            "sphere_sphere" => spec.extend([req("radius_a"), req("radius_b")]),
            "box_plane" => spec.extend([req("size"), req("normal")]),
            other => {
                let help = match crate::suggest::closest(other, CONTACT_KINDS.iter().copied()) {
                    Some(s) => format!("did you mean `{s}`?"),
                    None => format!("contact kinds: {}", CONTACT_KINDS.join(", ")),
                };
                return Err(self.report(
                    Diagnostic::error(
                        codes::UNKNOWN_NAME,
                        format!("unknown contact kind `{other}`"),
                    )
                    .primary(sc.file, func.span, "")
                    .help(help),
                ));
            }
        }
        spec.extend([req("stiffness"), opt("damping"), opt("friction")]);
        let a = self.call_args(func, args, &spec, sc, value.span)?;
        let (Some(ae), Some(be)) = (a[0], a[1]) else {
            return Err(Reported);
        };
        let ra = self.attachment(ae, sc);
        let rb = self.attachment(be, sc);
        let g1 = match (kind, a[2]) {
            ("box_plane", Some(e)) => self.vec3(e, sc, Dim::LENGTH, "a box size").and_then(|s| {
                if s.iter().any(|x| *x <= 0.0) {
                    Err(self.report(
                        Diagnostic::error(
                            codes::INVALID_VALUE,
                            "box edge lengths must be positive",
                        )
                        .primary(sc.file, e.span, ""),
                    ))
                } else {
                    Ok(Shape::Box {
                        half_extents: s.map(|x| x / 2.0),
                    })
                }
            }),
            (_, Some(e)) => self
                .positive(e, sc, Dim::LENGTH, "a radius")
                .map(|radius| Shape::Sphere { radius }),
            _ => Err(Reported),
        };
        let second = match (kind, a[3]) {
            ("sphere_sphere", Some(e)) => self
                .positive(e, sc, Dim::LENGTH, "a radius")
                .map(|radius| (Some(Shape::Sphere { radius }), None)),
            (_, Some(e)) => self.axis(e, sc, "a plane normal").map(|n| (None, Some(n))),
            _ => Err(Reported),
        };
        let k = a[4]
            .map(|e| self.positive(e, sc, Dim::STIFFNESS, "a contact stiffness"))
            .transpose();
        let c = a[5]
            .map(|e| self.nonneg(e, sc, Dim::DAMPING, "a contact damping"))
            .transpose();
        let mu = a[6]
            .map(|e| self.nonneg(e, sc, Dim::NONE, "a friction coefficient"))
            .transpose();
        let (ra, rb, g1, second, k, c, mu) = (ra?, rb?, g1?, second?, k?, c?, mu?);
        if ra.body == rb.body {
            return Err(self.report(
                Diagnostic::error(
                    codes::SELF_JOINT,
                    "a contact pair needs two different bodies (or a body and ground)",
                )
                .primary(sc.file, ae.span, "first")
                .primary(sc.file, be.span, "second, same body"),
            ));
        }
        let id = geom::IDENTITY;
        let a_att = Attachment {
            body: ra.body,
            point: ra.point,
            frame: id,
        };
        let (b_att, g2) = match second {
            (Some(s), _) => (
                Attachment {
                    body: rb.body,
                    point: rb.point,
                    frame: id,
                },
                s,
            ),
            (None, Some(n)) => (rb.with_frame(&geom::frame_with_z(n)), Shape::Plane),
            _ => return Err(Reported),
        };
        Ok(Contact {
            name: d.name.clone(),
            a: (a_att, g1),
            b: (b_att, g2),
            stiffness: k.unwrap_or(0.0),
            damping: c.unwrap_or(0.0),
            friction: mu.unwrap_or(0.0),
            origin: Sources::origin(sc.file, d.span),
        })
    }
}
