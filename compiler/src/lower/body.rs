//! Bodies: mass, inertia, initial pose and velocities.

use mbdc_dsl::ast::{Expr, ExprKind};
use mbdc_runtime::scene::{Body, Mat3, Quat};
use nalgebra::{Matrix3, Vector3};

use super::eval::ident_of;
use super::props::{one, ArgSpec, Key};
use super::{Lowerer, PDecl, Reported, Scope, R};
use crate::diag::{codes, Diagnostic};
use crate::geom::{self, InertiaProblem};
use crate::source::Sources;
use crate::units::Dim;

const BODY_KEYS: &[Key] = &[
    one("mass"),
    one("inertia"),
    one("position"),
    one("orientation"),
    one("velocity"),
    Key {
        name: "angular_velocity",
        min: 1,
        max: 2,
        repeat: false,
    },
];

/// Formats a number for messages (short, exact enough).
pub(crate) fn num(x: f64) -> String {
    let s = format!("{x}");
    if s.len() > 12 {
        format!("{x:.6e}")
    } else {
        s
    }
}

impl<'a> Lowerer<'a> {
    pub(crate) fn lower_body(&mut self, d: &PDecl<'a>) -> R<Body> {
        let sc = &d.sc;
        let what = format!("body `{}`", d.name);
        let Some(block) = d.block else {
            return Err(Reported);
        };
        let props = self.props(block, sc, &what, BODY_KEYS, &[]);
        let mut ok = true;

        let mass = match props.value("mass") {
            Some(e) => match self.const_num(e, sc, Dim::MASS, "a mass") {
                Ok(m) if m > 0.0 => Some(m),
                Ok(m) => {
                    self.report(
                        Diagnostic::error(
                            codes::INVALID_VALUE,
                            format!("the mass of {what} must be positive, found {} kg", num(m)),
                        )
                        .primary(sc.file, e.span, "not positive"),
                    );
                    None
                }
                Err(_) => None,
            },
            None => {
                self.missing(&props, "mass", &what, sc, d.name_span, "mass 1 kg");
                None
            }
        };
        ok &= mass.is_some();

        let position = match props.value("position") {
            Some(e) => self.vec3(e, sc, Dim::LENGTH, "a position").ok(),
            None => Some([0.0; 3]),
        };
        ok &= position.is_some();

        let orientation = match props.value("orientation") {
            Some(e) => self.orientation(e, sc).ok(),
            None => Some(geom::IDENTITY),
        };
        ok &= orientation.is_some();

        let velocity = match props.value("velocity") {
            Some(e) => self.vec3(e, sc, Dim::VELOCITY, "a velocity").ok(),
            None => Some([0.0; 3]),
        };
        ok &= velocity.is_some();

        let omega = match props.get("angular_velocity") {
            Some(p) => {
                let w = self
                    .vec3(&p.values[0], sc, Dim::FREQUENCY, "an angular velocity")
                    .ok();
                let frame = match p.values.get(1) {
                    None => Some(false),
                    Some(f) => match ident_of(f) {
                        Some("body") => Some(true),
                        Some("world") => Some(false),
                        _ => {
                            self.report(
                                Diagnostic::error(codes::WRONG_KIND, "the frame of an angular velocity is `body` or `world`")
                                    .primary(sc.file, f.span, "")
                                    .help("write `angular_velocity (0, 0, 1) rad/s, body` for body components"),
                            );
                            None
                        }
                    },
                };
                match (w, frame, orientation) {
                    (Some(w), Some(true), _) => Some(w),
                    (Some(w), Some(false), Some(q)) => {
                        let wb = geom::rot(q).transpose() * geom::v(w);
                        Some(geom::a(&wb))
                    }
                    _ => None,
                }
            }
            None => Some([0.0; 3]),
        };
        ok &= omega.is_some();

        let inertia = match props.value("inertia") {
            Some(e) => match self.inertia(e, sc, mass) {
                Ok(Some(i)) => self.check_inertia(i, e, sc).ok(),
                Ok(None) => None,
                Err(_) => None,
            },
            None => {
                self.missing(
                    &props,
                    "inertia",
                    &what,
                    sc,
                    d.name_span,
                    "inertia sphere(radius: 10 cm)",
                );
                None
            }
        };
        ok &= inertia.is_some();

        match (ok, mass, inertia, position, orientation, velocity, omega) {
            (
                true,
                Some(mass),
                Some(inertia),
                Some(position),
                Some(orientation),
                Some(velocity),
                Some(angular_velocity),
            ) => Ok(Body {
                name: d.name.clone(),
                mass,
                inertia,
                position,
                orientation,
                velocity,
                angular_velocity,
                origin: Sources::origin(sc.file, d.span),
            }),
            _ => Err(Reported),
        }
    }

    fn check_inertia(&mut self, i: Mat3, e: &Expr, sc: &Scope) -> R<Mat3> {
        match geom::check_inertia(&i) {
            Ok(_) => Ok(i),
            Err(p) => {
                let (msg, help) = match p {
                    InertiaProblem::NotFinite => ("the inertia is not finite".to_string(), "check the values".to_string()),
                    InertiaProblem::NotSymmetric(r, c) => (
                        format!(
                            "the inertia tensor is not symmetric: I[{}][{}] = {} but I[{}][{}] = {}",
                            r + 1,
                            c + 1,
                            num(i[r][c]),
                            c + 1,
                            r + 1,
                            num(i[c][r])
                        ),
                        "products of inertia appear twice, above and below the diagonal, with the same value".to_string(),
                    ),
                    InertiaProblem::NotPositiveDefinite(p) => (
                        format!(
                            "the inertia tensor is not positive definite (principal moments {}, {}, {} kg*m^2)",
                            num(p[0]),
                            num(p[1]),
                            num(p[2])
                        ),
                        "every principal moment must be positive; a slender rod needs a radius".to_string(),
                    ),
                    InertiaProblem::Triangle(p) => (
                        format!(
                            "the inertia violates the triangle inequality: {} > {} + {} kg*m^2",
                            num(p[2]),
                            num(p[0]),
                            num(p[1])
                        ),
                        "no rigid body has a principal moment larger than the sum of the other two".to_string(),
                    ),
                };
                Err(self.report(
                    Diagnostic::error(codes::BAD_INERTIA, msg)
                        .primary(sc.file, e.span, "")
                        .help(help),
                ))
            }
        }
    }

    /// The inertia tensor; `Ok(None)` if it needs the mass and the mass is unknown.
    fn inertia(&mut self, e: &'a Expr, sc: &Scope, mass: Option<f64>) -> R<Option<Mat3>> {
        if let ExprKind::Call { func, args } = &e.kind {
            let shape = func.name.as_str();
            if matches!(shape, "rod" | "cylinder" | "box" | "sphere") {
                let spec: &[ArgSpec] = match shape {
                    "rod" | "cylinder" => &[
                        ArgSpec {
                            name: "length",
                            positional: false,
                            required: true,
                        },
                        ArgSpec {
                            name: "radius",
                            positional: false,
                            required: true,
                        },
                        ArgSpec {
                            name: "axis",
                            positional: false,
                            required: false,
                        },
                    ],
                    "box" => &[ArgSpec {
                        name: "size",
                        positional: true,
                        required: true,
                    }],
                    _ => &[ArgSpec {
                        name: "radius",
                        positional: true,
                        required: true,
                    }],
                };
                let a = self.call_args(func, args, spec, sc, e.span)?;
                let m = mass.unwrap_or(f64::NAN);
                return match shape {
                    "rod" | "cylinder" => {
                        let (Some(le), Some(re)) = (a[0], a[1]) else {
                            return Err(Reported);
                        };
                        let l = self.const_num(le, sc, Dim::LENGTH, "a length");
                        let r = self.const_num(re, sc, Dim::LENGTH, "a radius");
                        let axis = match a[2] {
                            None => Ok(2),
                            Some(ax) => match ident_of(ax) {
                                Some("x") => Ok(0),
                                Some("y") => Ok(1),
                                Some("z") => Ok(2),
                                _ => Err(self.report(
                                    Diagnostic::error(codes::WRONG_KIND, "the axis of a rod is `x`, `y` or `z` (body axes)")
                                        .primary(sc.file, ax.span, "")
                                        .help("orient the body with `orientation` to point the rod elsewhere"),
                                )),
                            },
                        };
                        let (l, r, axis) = (l?, r?, axis?);
                        if l < 0.0 || r < 0.0 {
                            return Err(self.report(
                                Diagnostic::error(
                                    codes::INVALID_VALUE,
                                    format!("{shape} dimensions must not be negative"),
                                )
                                .primary(sc.file, e.span, ""),
                            ));
                        }
                        Ok(mass.map(|_| geom::rod_inertia(m, l, r, axis)))
                    }
                    "box" => {
                        let Some(se) = a[0] else { return Err(Reported) };
                        let s = self.vec3(se, sc, Dim::LENGTH, "a box size")?;
                        if s.iter().any(|x| *x <= 0.0) {
                            return Err(self.report(
                                Diagnostic::error(
                                    codes::INVALID_VALUE,
                                    "box edge lengths must be positive",
                                )
                                .primary(sc.file, se.span, ""),
                            ));
                        }
                        Ok(mass.map(|_| geom::box_inertia(m, s)))
                    }
                    _ => {
                        let Some(re) = a[0] else { return Err(Reported) };
                        let r = self.const_num(re, sc, Dim::LENGTH, "a radius")?;
                        if r <= 0.0 {
                            return Err(self.report(
                                Diagnostic::error(
                                    codes::INVALID_VALUE,
                                    format!("a sphere radius must be positive, found {} m", num(r)),
                                )
                                .primary(sc.file, re.span, ""),
                            ));
                        }
                        Ok(mass.map(|_| geom::sphere_inertia(m, r)))
                    }
                };
            }
        }
        let v = self.eval(e, sc)?;
        if matches!(v, crate::value::Value::Num(_)) {
            return Err(self.report(
                Diagnostic::error(codes::WRONG_KIND, "an inertia is a 3×3 tensor, not a number")
                    .primary(sc.file, e.span, "")
                    .help("write `diag(I, I, I) kg*m^2`, a full tensor, or a shape: `sphere(radius: r)`, `rod(length: L, radius: r)`, `box(size: (a, b, c))`"),
            ));
        }
        self.mat3_of(v, e.span, sc, Dim::INERTIA, "an inertia")
            .map(Some)
    }

    /// An orientation (body → world) as a unit quaternion.
    pub(crate) fn orientation(&mut self, e: &'a Expr, sc: &Scope) -> R<Quat> {
        let bad = |this: &mut Self| {
            this.report(
                Diagnostic::error(codes::WRONG_KIND, "an orientation is `axis_angle(AXIS, ANGLE)`, `quaternion(w, x, y, z)`, `euler_xyz(a, b, c)` or `matrix(M)`")
                    .primary(sc.file, e.span, "not an orientation"),
            )
        };
        let ExprKind::Call { func, args } = &e.kind else {
            return Err(bad(self));
        };
        match func.name.as_str() {
            "axis_angle" => {
                let a = self.call_args(
                    func,
                    args,
                    &[super::props::pos("axis"), super::props::pos("angle")],
                    sc,
                    e.span,
                )?;
                let (Some(ae), Some(an)) = (a[0], a[1]) else {
                    return Err(Reported);
                };
                let axis = self.axis(ae, sc, "a rotation axis")?;
                let angle = self.const_num(an, sc, Dim::NONE, "an angle")?;
                Ok(geom::axis_angle(axis, angle))
            }
            "quaternion" => {
                let spec = [
                    super::props::pos("w"),
                    super::props::pos("x"),
                    super::props::pos("y"),
                    super::props::pos("z"),
                ];
                let a = self.call_args(func, args, &spec, sc, e.span)?;
                let mut q = [0.0; 4];
                for (i, x) in a.iter().enumerate() {
                    let Some(x) = x else { return Err(Reported) };
                    q[i] = self.const_num(x, sc, Dim::NONE, "a quaternion component")?;
                }
                let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
                if n < 1e-12 {
                    return Err(self.report(
                        Diagnostic::error(codes::ORIENTATION, "a quaternion cannot be zero")
                            .primary(sc.file, e.span, ""),
                    ));
                }
                if (n - 1.0).abs() > 1e-9 {
                    self.report(
                        Diagnostic::warning(
                            codes::ORIENTATION,
                            format!("the quaternion was normalised (its norm was {})", num(n)),
                        )
                        .primary(sc.file, e.span, "not a unit quaternion")
                        .help("divide the components by the norm to silence this warning"),
                    );
                }
                let mut q = q.map(|c| c / n);
                if q[0] < 0.0 {
                    q.iter_mut().for_each(|c| *c = -*c);
                }
                Ok(q)
            }
            "euler_xyz" => {
                let spec = [
                    super::props::pos("a"),
                    super::props::pos("b"),
                    super::props::pos("c"),
                ];
                let a = self.call_args(func, args, &spec, sc, e.span)?;
                let mut ang = [0.0; 3];
                for (i, x) in a.iter().enumerate() {
                    let Some(x) = x else { return Err(Reported) };
                    ang[i] = self.const_num(x, sc, Dim::NONE, "an angle")?;
                }
                Ok(geom::quat_of(&geom::euler_xyz(ang[0], ang[1], ang[2])))
            }
            "matrix" => {
                let a = self.call_args(func, args, &[super::props::pos("m")], sc, e.span)?;
                let Some(me) = a[0] else { return Err(Reported) };
                let v = self.eval(me, sc)?;
                let m = self.mat3_of(v, me.span, sc, Dim::NONE, "a rotation matrix")?;
                let r = geom::m(&m);
                if !geom::is_rotation(&r, 1e-6) {
                    let det = r.determinant();
                    return Err(self.report(
                        Diagnostic::error(codes::ORIENTATION, "the matrix is not a rotation")
                            .primary(sc.file, me.span, if det < 0.0 { "it is a reflection (determinant −1)" } else { "its columns are not orthonormal" })
                            .help("the columns are the body axes in world components: unit length, mutually perpendicular, right-handed"),
                    ));
                }
                Ok(geom::quat_of(&r))
            }
            _ => Err(bad(self)),
        }
    }

    /// A non-zero dimensionless direction.
    pub(crate) fn axis(&mut self, e: &Expr, sc: &Scope, what: &str) -> R<Vector3<f64>> {
        let a = self.vec3(e, sc, Dim::NONE, what)?;
        let v = geom::v(a);
        if v.norm() < 1e-12 {
            return Err(self.report(
                Diagnostic::error(codes::ZERO_AXIS, format!("{what} cannot be zero"))
                    .primary(sc.file, e.span, "zero vector")
                    .help("give a direction, e.g. `(0, 0, 1)`"),
            ));
        }
        Ok(v.normalize())
    }
}

/// The rotation matrix of a body (identity for ground).
pub(crate) fn body_rot(b: Option<&Body>) -> Matrix3<f64> {
    b.map(|b| geom::rot(b.orientation))
        .unwrap_or_else(Matrix3::identity)
}
