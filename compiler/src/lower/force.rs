//! Applied forces, springs and dampers.

use mbdc_dsl::ast::{Expr, ExprKind};
use mbdc_runtime::scene::{Attachment, BodyRef, Force, ForceFrame, ForceKind, JointKind};

use super::body::num;
use super::eval::ident_of;
use super::props::{opt, pos, req};
use super::{EntKind, Lowerer, PDecl, Reported, Scope, R};
use crate::diag::{codes, Diagnostic};
use crate::geom;
use crate::source::Sources;
use crate::units::Dim;
use crate::value::Value;

const FORCE_KINDS: &[&str] = &[
    "point",
    "torque",
    "spring",
    "damper",
    "rotational_spring",
    "rotational_damper",
];

impl<'a> Lowerer<'a> {
    /// Lowers a force; `Ok(None)` for a force with no effect (on ground), which is warned about.
    pub(crate) fn lower_force(&mut self, d: &PDecl<'a>) -> R<Option<Force>> {
        let sc = &d.sc;
        let Some(value) = d.value else {
            return Err(Reported);
        };
        let ExprKind::Call { func, args } = &value.kind else {
            return Err(self.report(
                Diagnostic::error(codes::WRONG_KIND, "a force is `KIND(...)`")
                    .primary(sc.file, value.span, "not a force kind")
                    .help(format!("force kinds: {}", FORCE_KINDS.join(", "))),
            ));
        };
        let origin = Sources::origin(sc.file, d.span);
        let mk = |kind: ForceKind| {
            Some(Force {
                name: d.name.clone(),
                kind,
                origin,
            })
        };
        match func.name.as_str() {
            "point" => {
                let a = self.call_args(
                    func,
                    args,
                    &[pos("at"), pos("force"), opt("frame")],
                    sc,
                    value.span,
                )?;
                let (Some(ae), Some(fe)) = (a[0], a[1]) else {
                    return Err(Reported);
                };
                let att = self.attachment(ae, sc);
                let f = self.fvec3(fe, sc, Dim::FORCE, "a force");
                let frame = self.force_frame(a[2], sc);
                let (att, value, frame) = (att?, f?, frame?);
                if att.body == BodyRef::Ground {
                    self.on_ground(d, ae);
                    return Ok(None);
                }
                let at = Attachment {
                    body: att.body,
                    point: att.point,
                    frame: geom::IDENTITY,
                };
                Ok(mk(ForceKind::Point { at, value, frame }))
            }
            "torque" => {
                let a = self.call_args(
                    func,
                    args,
                    &[pos("body"), pos("torque"), opt("frame")],
                    sc,
                    value.span,
                )?;
                let (Some(be), Some(te)) = (a[0], a[1]) else {
                    return Err(Reported);
                };
                let bv = self.eval(be, sc);
                let t = self.fvec3(te, sc, Dim::TORQUE, "a torque");
                let frame = self.force_frame(a[2], sc);
                let bv = bv?;
                let body = self.body_ref(&bv, be.span, sc)?;
                let (value, frame) = (t?, frame?);
                if body == BodyRef::Ground {
                    self.on_ground(d, be);
                    return Ok(None);
                }
                Ok(mk(ForceKind::Torque { body, value, frame }))
            }
            "spring" | "damper" => {
                let spring = func.name == "spring";
                let spec = if spring {
                    vec![
                        pos("a"),
                        pos("b"),
                        req("stiffness"),
                        opt("length"),
                        opt("damping"),
                    ]
                } else {
                    vec![pos("a"), pos("b"), req("damping")]
                };
                let a = self.call_args(func, args, &spec, sc, value.span)?;
                let (Some(ae), Some(be)) = (a[0], a[1]) else {
                    return Err(Reported);
                };
                let ra = self.attachment(ae, sc);
                let rb = self.attachment(be, sc);
                let (k, len, c) = if spring {
                    (
                        a[2].map(|e| self.nonneg(e, sc, Dim::STIFFNESS, "a stiffness"))
                            .transpose(),
                        a[3].map(|e| self.nonneg(e, sc, Dim::LENGTH, "a rest length"))
                            .transpose(),
                        a[4].map(|e| self.nonneg(e, sc, Dim::DAMPING, "a damping"))
                            .transpose(),
                    )
                } else {
                    (
                        Ok(Some(0.0)),
                        Ok(None),
                        a[2].map(|e| self.nonneg(e, sc, Dim::DAMPING, "a damping"))
                            .transpose(),
                    )
                };
                let (ra, rb, k, len, c) = (ra?, rb?, k?, len?, c?);
                if ra.body == rb.body {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::SELF_JOINT,
                            format!("this {} connects a body to itself", func.name),
                        )
                        .primary(sc.file, ae.span, "first end")
                        .primary(sc.file, be.span, "second end, same body"),
                    ));
                }
                let rest_length = len.unwrap_or_else(|| (rb.world - ra.world).norm());
                let id = geom::IDENTITY;
                Ok(mk(ForceKind::Spring {
                    a: Attachment {
                        body: ra.body,
                        point: ra.point,
                        frame: id,
                    },
                    b: Attachment {
                        body: rb.body,
                        point: rb.point,
                        frame: id,
                    },
                    stiffness: k.unwrap_or(0.0),
                    rest_length,
                    damping: c.unwrap_or(0.0),
                }))
            }
            "rotational_spring" | "rotational_damper" => {
                let spring = func.name == "rotational_spring";
                let spec = if spring {
                    vec![
                        pos("joint"),
                        req("stiffness"),
                        opt("angle"),
                        opt("damping"),
                        opt("lock"),
                    ]
                } else {
                    vec![pos("joint"), req("damping")]
                };
                let a = self.call_args(func, args, &spec, sc, value.span)?;
                let Some(je) = a[0] else { return Err(Reported) };
                let joint = self.joint_for_spring(je, sc, &func.name);
                let (k, rest, c, lock) = if spring {
                    (
                        a[1].map(|e| self.nonneg(e, sc, Dim::TORQUE, "a rotational stiffness"))
                            .transpose(),
                        a[2].map(|e| self.const_num(e, sc, Dim::NONE, "a rest angle"))
                            .transpose(),
                        a[3].map(|e| self.nonneg(e, sc, Dim::ROT_DAMPING, "a rotational damping"))
                            .transpose(),
                        a[4].map(|e| self.const_num(e, sc, Dim::NONE, "a lock angle"))
                            .transpose(),
                    )
                } else {
                    (
                        Ok(Some(0.0)),
                        Ok(None),
                        a[1].map(|e| self.nonneg(e, sc, Dim::ROT_DAMPING, "a rotational damping"))
                            .transpose(),
                        Ok(None),
                    )
                };
                let (joint, k, rest, c, lock) = (joint?, k?, rest?, c?, lock?);
                if let (Some(l), Some(le)) = (lock, a.get(4).copied().flatten()) {
                    if l.abs() >= 2.0 * std::f64::consts::PI {
                        return Err(self.report(
                            Diagnostic::error(
                                codes::INVALID_VALUE,
                                format!("a lock angle must be within ±360°, found {} rad", num(l)),
                            )
                            .primary(sc.file, le.span, ""),
                        ));
                    }
                    if l == 0.0 {
                        self.report(
                            Diagnostic::warning(
                                codes::INVALID_VALUE,
                                "a lock angle of 0 locks the joint at the start",
                            )
                            .primary(sc.file, le.span, "")
                            .help("angles are measured from the initial configuration"),
                        );
                    }
                }
                Ok(mk(ForceKind::RotationalSpring {
                    joint,
                    stiffness: k.unwrap_or(0.0),
                    rest_angle: rest.unwrap_or(0.0),
                    damping: c.unwrap_or(0.0),
                    lock_angle: lock,
                }))
            }
            other => {
                let help = match crate::suggest::closest(other, FORCE_KINDS.iter().copied()) {
                    Some(s) => format!("did you mean `{s}`?"),
                    None => format!("force kinds: {}", FORCE_KINDS.join(", ")),
                };
                Err(self.report(
                    Diagnostic::error(codes::UNKNOWN_NAME, format!("unknown force kind `{other}`"))
                        .primary(sc.file, func.span, "not a force kind")
                        .help(help),
                ))
            }
        }
    }

    fn on_ground(&mut self, d: &PDecl<'a>, e: &Expr) {
        self.report(
            Diagnostic::warning(
                codes::NO_EFFECT,
                format!("force `{}` acts on ground and has no effect", d.name),
            )
            .primary(d.sc.file, e.span, "ground does not move"),
        );
    }

    fn force_frame(&mut self, e: Option<&Expr>, sc: &Scope) -> R<ForceFrame> {
        match e {
            None => Ok(ForceFrame::World),
            Some(e) => match ident_of(e) {
                Some("world") => Ok(ForceFrame::World),
                Some("body") => Ok(ForceFrame::Body),
                _ => Err(self.report(
                    Diagnostic::error(codes::WRONG_KIND, "`frame:` is `world` or `body`")
                        .primary(sc.file, e.span, ""),
                )),
            },
        }
    }

    /// A constant ≥ 0 of a dimension.
    pub(crate) fn nonneg(&mut self, e: &Expr, sc: &Scope, d: Dim, what: &str) -> R<f64> {
        let v = self.const_num(e, sc, d, what)?;
        if v < 0.0 {
            return Err(self.report(
                Diagnostic::error(
                    codes::INVALID_VALUE,
                    format!(
                        "{what} must not be negative, found {} {}",
                        num(v),
                        d.unit_text()
                    ),
                )
                .primary(sc.file, e.span, "negative"),
            ));
        }
        Ok(v)
    }

    /// A constant > 0 of a dimension.
    pub(crate) fn positive(&mut self, e: &Expr, sc: &Scope, d: Dim, what: &str) -> R<f64> {
        let v = self.const_num(e, sc, d, what)?;
        if v <= 0.0 {
            let unit = if d.is_none() {
                String::new()
            } else {
                format!(" {}", d.unit_text())
            };
            return Err(self.report(
                Diagnostic::error(
                    codes::INVALID_VALUE,
                    format!("{what} must be positive, found {}{unit}", num(v)),
                )
                .primary(sc.file, e.span, "not positive"),
            ));
        }
        Ok(v)
    }

    fn joint_for_spring(&mut self, je: &Expr, sc: &Scope, what: &str) -> R<usize> {
        let v = self.eval(je, sc)?;
        let Value::Name(n) = &v else {
            return Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!("expected the name of a joint, found {}", v.kind()),
                )
                .primary(sc.file, je.span, ""),
            ));
        };
        let j = self.resolve(n, EntKind::Joint)?;
        let Some(joint) = self.scene_joints.get(j).cloned().flatten() else {
            return Err(Reported);
        };
        match joint.kind {
            JointKind::Revolute | JointKind::Cylindrical => Ok(j),
            _ => Err(self.report(
                Diagnostic::error(
                    codes::JOINT_KIND,
                    format!("a {what} acts about the axis of a revolute or cylindrical joint, but `{}` is {}", joint.name, joint.kind.keyword()),
                )
                .primary(sc.file, je.span, format!("a {} joint", joint.kind.keyword())),
            )),
        }
    }
}
