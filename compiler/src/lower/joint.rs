//! Joints, drivers and nonholonomic constraints.
//!
//! Axes are given in world components at the initial configuration. Each attachment's
//! `frame` is built so that its z axis is the joint axis (in body components) and both
//! joint frames coincide in world at t = 0: the world frame of a joint is
//! [`geom::frame_with_z`] of its axis (x = the world axis least parallel to the joint axis,
//! orthogonalised), or the world axes for joints without an axis. Universal joints are the
//! exception: a's z is `axis_a` and its x is `axis_b`; b's z is `axis_b` and its x is `axis_a`.

use mbdc_dsl::ast::{Expr, ExprKind, Span};
use mbdc_runtime::scene::{Attachment, BodyRef, Fn1, Joint, JointKind, Vec3};
use nalgebra::{Matrix3, Vector3};

use super::body::{body_rot, num};
use super::props::{opt, pos, req, ArgSpec};
use super::{EntKind, Lowerer, PDecl, Reported, Scope, R};
use crate::diag::{codes, Diagnostic};
use crate::env::BindKind;
use crate::fn1;
use crate::geom;
use crate::source::Sources;
use crate::units::Dim;
use crate::value::{PointSpec, Value, Var, Q};

/// Joint kinds (for messages).
pub(crate) const JOINT_KINDS: &[&str] = &[
    "spherical",
    "revolute",
    "prismatic",
    "cylindrical",
    "universal",
    "fixed",
    "planar",
    "distance",
    "drive_angle",
    "drive_displacement",
    "rolling",
    "point_velocity",
    "curve",
];

/// A resolved attachment with its initial world position.
#[derive(Clone, Debug)]
pub(crate) struct Att {
    pub body: BodyRef,
    /// Body components relative to the mass centre (world for ground).
    pub point: Vec3,
    /// World position at t = 0.
    pub world: Vector3<f64>,
    /// Body rotation (body → world) at t = 0.
    pub rot: Matrix3<f64>,
    pub span: Span,
}

impl Att {
    /// The attachment with a joint frame given by its world axes `w` (columns x, y, z).
    pub fn with_frame(&self, w: &Matrix3<f64>) -> Attachment {
        Attachment {
            body: self.body,
            point: self.point,
            frame: geom::quat_of(&(self.rot.transpose() * w)),
        }
    }
}

/// Whether a joint-kind name is a driver (lowered after the other joints).
pub(crate) fn is_driver(d: &PDecl<'_>) -> bool {
    matches!(d.value.map(|v| &v.kind), Some(ExprKind::Call { func, .. }) if func.name == "drive_angle" || func.name == "drive_displacement")
}

impl<'a> Lowerer<'a> {
    /// Resolves `BODY @ POINT`.
    pub(crate) fn attachment(&mut self, e: &Expr, sc: &Scope) -> R<Att> {
        let v = self.eval(e, sc)?;
        self.attachment_of(v, e.span, sc)
    }

    pub(crate) fn attachment_of(&mut self, v: Value, span: Span, sc: &Scope) -> R<Att> {
        let a = match v {
            Value::Attach(a) => a,
            other => {
                return Err(self.report(
                    Diagnostic::error(codes::WRONG_KIND, format!("expected an attachment `body @ point`, found {}", other.kind()))
                        .primary(sc.file, span, "")
                        .help("write `rod @ (0, 0, 0.5) m` (a point in the body's axes) or `rod @ world((1, 0, 0) m)`"),
                ))
            }
        };
        let body = self.body_ref(&Value::Name(a.body.clone()), a.body.span, sc)?;
        let (x, rot) = match body {
            BodyRef::Ground => (Vector3::zeros(), Matrix3::identity()),
            BodyRef::Body(_) => match self.body_data(body) {
                Some(b) => (geom::v(b.position), body_rot(Some(b))),
                None => return Err(Reported),
            },
        };
        let (point, world) = match a.point {
            PointSpec::Body(p) => (p, x + rot * geom::v(p)),
            PointSpec::World(p) => (geom::a(&(rot.transpose() * (geom::v(p) - x))), geom::v(p)),
        };
        Ok(Att {
            body,
            point,
            world,
            rot,
            span: a.span,
        })
    }

    fn two_atts(
        &mut self,
        a: Option<&Expr>,
        b: Option<&Expr>,
        sc: &Scope,
        kind: &str,
    ) -> R<(Att, Att)> {
        let (Some(a), Some(b)) = (a, b) else {
            return Err(Reported);
        };
        let ra = self.attachment(a, sc);
        let rb = self.attachment(b, sc);
        let (ra, rb) = (ra?, rb?);
        if ra.body == rb.body {
            let what = match ra.body {
                BodyRef::Ground => "ground to ground".to_string(),
                BodyRef::Body(i) => {
                    let n = self
                        .body_data(BodyRef::Body(i))
                        .map(|b| b.name.clone())
                        .unwrap_or_default();
                    format!("body `{n}` to itself")
                }
            };
            return Err(self.report(
                Diagnostic::error(codes::SELF_JOINT, format!("this {kind} connects {what}"))
                    .primary(sc.file, a.span, "first end")
                    .primary(sc.file, b.span, "second end, same body")
                    .help("a joint connects two different bodies (or a body and ground)"),
            ));
        }
        Ok((ra, rb))
    }

    /// Lowers a joint that is not a driver.
    pub(crate) fn lower_joint(&mut self, d: &PDecl<'a>) -> R<Joint> {
        let sc = &d.sc;
        let Some(value) = d.value else {
            return Err(Reported);
        };
        let ExprKind::Call { func, args } = &value.kind else {
            return Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    "a joint is `KIND(A @ POINT, B @ POINT, ...)`",
                )
                .primary(sc.file, value.span, "not a joint kind")
                .help(format!("joint kinds: {}", JOINT_KINDS.join(", "))),
            ));
        };
        let kind_name = func.name.as_str();
        let origin = Sources::origin(sc.file, d.span);
        let mk = |kind: JointKind, a: Attachment, b: Attachment| Joint {
            name: d.name.clone(),
            kind,
            a,
            b,
            origin,
        };
        let world_axes = Matrix3::identity();
        match kind_name {
            "spherical" | "fixed" => {
                let a = self.call_args(func, args, &[pos("a"), pos("b")], sc, value.span)?;
                let (ra, rb) = self.two_atts(a[0], a[1], sc, kind_name)?;
                let kind = if kind_name == "spherical" {
                    JointKind::Spherical
                } else {
                    JointKind::Fixed
                };
                Ok(mk(
                    kind,
                    ra.with_frame(&world_axes),
                    rb.with_frame(&world_axes),
                ))
            }
            "revolute" | "prismatic" | "cylindrical" | "planar" => {
                let an = if kind_name == "planar" {
                    "normal"
                } else {
                    "axis"
                };
                let a =
                    self.call_args(func, args, &[pos("a"), pos("b"), req(an)], sc, value.span)?;
                let atts = self.two_atts(a[0], a[1], sc, kind_name);
                let axis = match a[2] {
                    Some(e) => self.axis(
                        e,
                        sc,
                        if an == "axis" {
                            "a joint axis"
                        } else {
                            "a plane normal"
                        },
                    ),
                    None => Err(Reported),
                };
                let ((ra, rb), axis) = (atts?, axis?);
                let w = geom::frame_with_z(axis);
                let kind = match kind_name {
                    "revolute" => JointKind::Revolute,
                    "prismatic" => JointKind::Prismatic,
                    "cylindrical" => JointKind::Cylindrical,
                    _ => JointKind::Planar,
                };
                Ok(mk(kind, ra.with_frame(&w), rb.with_frame(&w)))
            }
            "universal" => {
                let a = self.call_args(
                    func,
                    args,
                    &[pos("a"), pos("b"), req("axis_a"), req("axis_b")],
                    sc,
                    value.span,
                )?;
                let atts = self.two_atts(a[0], a[1], sc, kind_name);
                let xa = a[2].map(|e| self.axis(e, sc, "a universal joint axis"));
                let xb = a[3].map(|e| self.axis(e, sc, "a universal joint axis"));
                let (Some(xa), Some(xb)) = (xa, xb) else {
                    return Err(Reported);
                };
                let ((ra, rb), xa, xb) = (atts?, xa?, xb?);
                let c = xa.dot(&xb);
                if c.abs() > 1e-6 {
                    let angle = c.clamp(-1.0, 1.0).acos().to_degrees();
                    let (sa, sb) = (
                        a[2].map(|e| e.span).unwrap_or(value.span),
                        a[3].map(|e| e.span).unwrap_or(value.span),
                    );
                    return Err(self.report(
                        Diagnostic::error(
                            codes::NOT_PERPENDICULAR,
                            format!("the axes of universal joint `{}` are not perpendicular (they are {}° apart)", d.name, num((angle * 1e6).round() / 1e6)),
                        )
                        .primary(sc.file, sa, "axis_a")
                        .primary(sc.file, sb, "axis_b")
                        .help("the cross of a universal joint has perpendicular arms; their dot product must be 0"),
                    ));
                }
                let wa = geom::frame_zx(xa, xb);
                let wb = geom::frame_zx(xb, xa);
                Ok(mk(
                    JointKind::Universal,
                    ra.with_frame(&wa),
                    rb.with_frame(&wb),
                ))
            }
            "distance" => {
                let a = self.call_args(
                    func,
                    args,
                    &[pos("a"), pos("b"), opt("length")],
                    sc,
                    value.span,
                )?;
                let atts = self.two_atts(a[0], a[1], sc, kind_name);
                let len = a[2].map(|e| (self.const_num(e, sc, Dim::LENGTH, "a distance"), e.span));
                let (ra, rb) = atts?;
                let initial = (rb.world - ra.world).norm();
                let length = match len {
                    Some((l, sp)) => {
                        let l = l?;
                        if l <= 0.0 {
                            return Err(self.report(
                                Diagnostic::error(
                                    codes::INVALID_VALUE,
                                    format!(
                                        "a distance joint needs a positive length, found {} m",
                                        num(l)
                                    ),
                                )
                                .primary(sc.file, sp, "")
                                .help("two points at zero distance are a spherical joint"),
                            ));
                        }
                        l
                    }
                    None => {
                        if initial < 1e-12 {
                            return Err(self.report(
                                Diagnostic::error(
                                    codes::INVALID_VALUE,
                                    "the points of this distance joint coincide initially",
                                )
                                .primary(sc.file, value.span, "initial distance 0")
                                .help("give `length:`, or use a spherical joint"),
                            ));
                        }
                        initial
                    }
                };
                Ok(mk(
                    JointKind::Distance { length },
                    ra.with_frame(&world_axes),
                    rb.with_frame(&world_axes),
                ))
            }
            "rolling" => {
                let a = self.call_args(
                    func,
                    args,
                    &[pos("a"), pos("b"), req("radius"), req("normal")],
                    sc,
                    value.span,
                )?;
                let atts = self.two_atts(a[0], a[1], sc, kind_name);
                let radius = a[2].map(|e| (self.const_num(e, sc, Dim::LENGTH, "a radius"), e.span));
                let normal = a[3].map(|e| self.axis(e, sc, "a plane normal"));
                let (Some((radius, rspan)), Some(normal)) = (radius, normal) else {
                    return Err(Reported);
                };
                let ((ra, rb), radius, normal) = (atts?, radius?, normal?);
                if radius <= 0.0 {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::INVALID_VALUE,
                            format!("a rolling radius must be positive, found {} m", num(radius)),
                        )
                        .primary(sc.file, rspan, ""),
                    ));
                }
                if rb.body != BodyRef::Ground {
                    return Err(self.report(
                        Diagnostic::error(codes::JOINT_KIND, "a ball rolls on a plane of the ground")
                            .primary(sc.file, rb.span, "expected `ground @ POINT`")
                            .help("write `rolling(ball @ (0, 0, 0), ground @ (0, 0, 0), radius: r, normal: (0, 0, 1))`"),
                    ));
                }
                if ra.body == BodyRef::Ground {
                    return Err(Reported);
                }
                let wb = geom::frame_with_z(normal);
                Ok(mk(
                    JointKind::Rolling { radius },
                    Attachment {
                        body: ra.body,
                        point: ra.point,
                        frame: geom::IDENTITY,
                    },
                    rb.with_frame(&wb),
                ))
            }
            "point_velocity" => {
                let a =
                    self.call_args(func, args, &[pos("at"), pos("velocity")], sc, value.span)?;
                let (Some(ae), Some(ve)) = (a[0], a[1]) else {
                    return Err(Reported);
                };
                let att = self.attachment(ae, sc);
                let vel = self.fvec3(ve, sc, Dim::VELOCITY, "a prescribed velocity");
                let (att, velocity) = (att?, vel?);
                if att.body == BodyRef::Ground {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::SELF_JOINT,
                            "a prescribed velocity needs a body, not ground",
                        )
                        .primary(sc.file, ae.span, ""),
                    ));
                }
                Ok(mk(
                    JointKind::PointVelocity { velocity },
                    Attachment {
                        body: att.body,
                        point: att.point,
                        frame: geom::IDENTITY,
                    },
                    Attachment {
                        body: BodyRef::Ground,
                        point: [0.0; 3],
                        frame: geom::IDENTITY,
                    },
                ))
            }
            "curve" => {
                let a = self.call_args(func, args, &[pos("at"), pos("y")], sc, value.span)?;
                let (Some(ae), Some(ye)) = (a[0], a[1]) else {
                    return Err(Reported);
                };
                let att = self.attachment(ae, sc);
                let curve = self.curve_fn(ye, sc);
                let (att, curve) = (att?, curve?);
                if att.body == BodyRef::Ground {
                    return Err(self.report(
                        Diagnostic::error(
                            codes::SELF_JOINT,
                            "a curve constraint needs a body, not ground",
                        )
                        .primary(sc.file, ae.span, ""),
                    ));
                }
                Ok(mk(
                    JointKind::Curve { curve },
                    Attachment {
                        body: att.body,
                        point: att.point,
                        frame: geom::IDENTITY,
                    },
                    Attachment {
                        body: BodyRef::Ground,
                        point: [0.0; 3],
                        frame: geom::IDENTITY,
                    },
                ))
            }
            "drive_angle" | "drive_displacement" => Err(Reported),
            other => {
                let mut dg =
                    Diagnostic::error(codes::UNKNOWN_NAME, format!("unknown joint kind `{other}`"))
                        .primary(sc.file, func.span, "not a joint kind");
                dg = dg.help(
                    match crate::suggest::closest(other, JOINT_KINDS.iter().copied()) {
                        Some(s) => format!("did you mean `{s}`?"),
                        None => format!("joint kinds: {}", JOINT_KINDS.join(", ")),
                    },
                );
                Err(self.report(dg))
            }
        }
    }

    /// `y = f(x)` of a curve, with `x` the point's x coordinate (m).
    fn curve_fn(&mut self, e: &Expr, sc: &Scope) -> R<Fn1> {
        let mut csc = sc.clone();
        let x = Q {
            f: Fn1::Var,
            dim: Dim::LENGTH,
            poly: false,
            var: Var::X,
        };
        csc.env = csc
            .env
            .bind("x", Value::Num(x), BindKind::Builtin, sc.file, e.span);
        let q = self.num(e, &csc)?;
        self.expect_dim(&q, Dim::LENGTH, e.span, sc, "a curve y = f(x)")?;
        if q.var == Var::T {
            return Err(self.report(
                Diagnostic::error(codes::TIME_DEPENDENT, "a curve cannot depend on `t`")
                    .primary(sc.file, e.span, "")
                    .help("the curve is y = f(x) with `x` the point's x coordinate"),
            ));
        }
        Ok(q.f)
    }

    /// Lowers a driver (`drive_angle`, `drive_displacement`) once the other joints are known.
    pub(crate) fn lower_driver(&mut self, d: &PDecl<'a>) -> R<Joint> {
        let sc = &d.sc;
        let Some(value) = d.value else {
            return Err(Reported);
        };
        let ExprKind::Call { func, args } = &value.kind else {
            return Err(Reported);
        };
        let angle = func.name == "drive_angle";
        let spec: [ArgSpec; 2] = [
            pos("joint"),
            pos(if angle { "angle" } else { "displacement" }),
        ];
        let a = self.call_args(func, args, &spec, sc, value.span)?;
        let (Some(je), Some(fe)) = (a[0], a[1]) else {
            return Err(Reported);
        };
        let jv = self.eval(je, sc);
        let f = if angle {
            self.fn_num(fe, sc, Dim::NONE, "a drive angle")
        } else {
            self.fn_num(fe, sc, Dim::LENGTH, "a drive displacement")
        };
        let jv = jv?;
        let Value::Name(n) = &jv else {
            return Err(self.report(
                Diagnostic::error(
                    codes::WRONG_KIND,
                    format!("expected the name of a joint, found {}", jv.kind()),
                )
                .primary(sc.file, je.span, ""),
            ));
        };
        let j = self.resolve(n, EntKind::Joint)?;
        let f = f?;
        let Some(driven) = self.scene_joints.get(j).cloned().flatten() else {
            if self.joints.get(j).is_some_and(super::joint::is_driver) {
                return Err(self.report(
                    Diagnostic::error(
                        codes::JOINT_KIND,
                        format!("`{}` is a driver; a driver drives a joint", n.path),
                    )
                    .primary(sc.file, je.span, ""),
                ));
            }
            return Err(Reported);
        };
        let ok = matches!(
            (&driven.kind, angle),
            (JointKind::Revolute | JointKind::Cylindrical, true)
                | (JointKind::Prismatic | JointKind::Cylindrical, false)
        );
        if !ok {
            let want = if angle {
                "a revolute or cylindrical joint"
            } else {
                "a prismatic or cylindrical joint"
            };
            return Err(self.report(
                Diagnostic::error(
                    codes::JOINT_KIND,
                    format!(
                        "`{}` drives {want}, but `{}` is {}",
                        func.name,
                        driven.name,
                        article(driven.kind.keyword())
                    ),
                )
                .primary(
                    sc.file,
                    je.span,
                    format!("a {} joint", driven.kind.keyword()),
                )
                .help(if angle {
                    "use `drive_displacement` for a slide"
                } else {
                    "use `drive_angle` for a rotation"
                }),
            ));
        }
        let origin = Sources::origin(sc.file, d.span);
        let kind = if angle {
            JointKind::DriveAngle { joint: j, angle: f }
        } else {
            // The slide is measured from the initial configuration.
            let s0 = self.initial_slide(&driven);
            JointKind::DriveDisplacement {
                joint: j,
                displacement: fn1::add(Fn1::Const(s0), f),
            }
        };
        Ok(Joint {
            name: d.name.clone(),
            kind,
            a: driven.a,
            b: driven.b,
            origin,
        })
    }

    /// `za · (pb − pa)` at t = 0.
    fn initial_slide(&self, j: &Joint) -> f64 {
        let pose = |b: BodyRef| match self.body_data(b) {
            Some(b) => (geom::v(b.position), geom::rot(b.orientation)),
            None => (Vector3::zeros(), Matrix3::identity()),
        };
        let (xa, ra) = pose(j.a.body);
        let (xb, rb) = pose(j.b.body);
        let pa = xa + ra * geom::v(j.a.point);
        let pb = xb + rb * geom::v(j.b.point);
        let za = ra * geom::rot(j.a.frame) * Vector3::z();
        za.dot(&(pb - pa))
    }
}

fn article(word: &str) -> String {
    match word.chars().next() {
        Some('a' | 'e' | 'i' | 'o' | 'u') => format!("an {word} joint"),
        _ => format!("a {word} joint"),
    }
}
