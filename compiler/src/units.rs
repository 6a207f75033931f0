//! Dimensions and the table of units.
//!
//! A dimension is a triple of exponents of kg, m and s. Angles are dimensionless
//! (radians). Every unit converts to SI by a factor.

use std::fmt;

/// Exponents of (kg, m, s).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Dim(pub [i32; 3]);

/// Largest exponent magnitude accepted in a dimension.
pub const MAX_EXPONENT: i32 = 64;

impl Dim {
    /// Dimensionless (also angles).
    pub const NONE: Dim = Dim([0, 0, 0]);
    /// kg
    pub const MASS: Dim = Dim([1, 0, 0]);
    /// m
    pub const LENGTH: Dim = Dim([0, 1, 0]);
    /// s
    pub const TIME: Dim = Dim([0, 0, 1]);
    /// 1/s
    pub const FREQUENCY: Dim = Dim([0, 0, -1]);
    /// m/s
    pub const VELOCITY: Dim = Dim([0, 1, -1]);
    /// m/s²
    pub const ACCELERATION: Dim = Dim([0, 1, -2]);
    /// N
    pub const FORCE: Dim = Dim([1, 1, -2]);
    /// N·m
    pub const TORQUE: Dim = Dim([1, 2, -2]);
    /// Pa
    pub const PRESSURE: Dim = Dim([1, -1, -2]);
    /// kg·m²
    pub const INERTIA: Dim = Dim([1, 2, 0]);
    /// N/m
    pub const STIFFNESS: Dim = Dim([1, 0, -2]);
    /// N·s/m
    pub const DAMPING: Dim = Dim([1, 0, -1]);
    /// N·m·s (rotational damping per rad/s)
    pub const ROT_DAMPING: Dim = Dim([1, 2, -1]);
    /// kg/m³
    pub const DENSITY: Dim = Dim([1, -3, 0]);
    /// m²
    pub const AREA: Dim = Dim([0, 2, 0]);
    /// N·m²
    pub const BENDING: Dim = Dim([1, 3, -2]);
    /// kg/m
    pub const MASS_PER_LENGTH: Dim = Dim([1, -1, 0]);
    /// kg·m
    pub const MASS_LENGTH: Dim = Dim([1, 1, 0]);
    /// N/m³
    pub const FOUNDATION: Dim = Dim([1, -2, -2]);
    /// m/N = s²/kg (penalty parameter)
    pub const COMPLIANCE: Dim = Dim([-1, 0, 2]);

    /// Whether dimensionless.
    pub fn is_none(self) -> bool {
        self == Dim::NONE
    }

    /// Product, `None` if an exponent grows beyond [`MAX_EXPONENT`].
    pub fn times(self, o: Dim) -> Option<Dim> {
        let mut r = [0; 3];
        for (i, r) in r.iter_mut().enumerate() {
            *r = self.0[i] + o.0[i];
            if r.abs() > MAX_EXPONENT {
                return None;
            }
        }
        Some(Dim(r))
    }

    /// Quotient.
    pub fn per(self, o: Dim) -> Option<Dim> {
        self.times(Dim([-o.0[0], -o.0[1], -o.0[2]]))
    }

    /// Integer power.
    pub fn powi(self, n: i64) -> Option<Dim> {
        let mut r = [0; 3];
        for (i, r) in r.iter_mut().enumerate() {
            let v = (self.0[i] as i64).checked_mul(n)?;
            if v.abs() > MAX_EXPONENT as i64 {
                return None;
            }
            *r = v as i32;
        }
        Some(Dim(r))
    }

    /// Rational power `self^(p/q)` if all exponents stay integers.
    pub fn pow_ratio(self, p: i64, q: i64) -> Option<Dim> {
        if q == 0 {
            return None;
        }
        let mut r = [0; 3];
        for (i, r) in r.iter_mut().enumerate() {
            let v = (self.0[i] as i64).checked_mul(p)?;
            if v % q != 0 {
                return None;
            }
            let v = v / q;
            if v.abs() > MAX_EXPONENT as i64 {
                return None;
            }
            *r = v as i32;
        }
        Some(Dim(r))
    }

    /// A name for the quantity, if it is a common one.
    pub fn quantity(self) -> Option<&'static str> {
        NAMED.iter().find(|n| n.0 == self).map(|n| n.2)
    }

    /// The SI unit text (`m/s^2`, `N`, `kg*m^2`, `1` for dimensionless).
    pub fn unit_text(self) -> String {
        if let Some(n) = NAMED.iter().find(|n| n.0 == self) {
            return n.1.to_string();
        }
        let names = ["kg", "m", "s"];
        let mut num = Vec::new();
        let mut den = Vec::new();
        for (i, e) in self.0.iter().enumerate() {
            let e = *e;
            if e > 0 {
                num.push(if e == 1 {
                    names[i].to_string()
                } else {
                    format!("{}^{}", names[i], e)
                });
            } else if e < 0 {
                den.push(if e == -1 {
                    names[i].to_string()
                } else {
                    format!("{}^{}", names[i], -e)
                });
            }
        }
        let n = if num.is_empty() {
            "1".to_string()
        } else {
            num.join("*")
        };
        if den.is_empty() {
            n
        } else {
            format!("{}/{}", n, den.join("/"))
        }
    }

    /// `m (length)` or just `kg*m^3` when the quantity has no common name.
    pub fn describe(self) -> String {
        match self.quantity() {
            Some(q) => format!("{} ({})", self.unit_text(), q),
            None => self.unit_text(),
        }
    }
}

impl fmt::Display for Dim {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.unit_text())
    }
}

/// Dimensions with a conventional SI unit text and a quantity name.
const NAMED: &[(Dim, &str, &str)] = &[
    (Dim::NONE, "1", "dimensionless"),
    (Dim::MASS, "kg", "mass"),
    (Dim::LENGTH, "m", "length"),
    (Dim::TIME, "s", "time"),
    (Dim::FREQUENCY, "1/s", "frequency or angular velocity"),
    (Dim([0, 0, -2]), "1/s^2", "angular acceleration"),
    (Dim::VELOCITY, "m/s", "velocity"),
    (Dim::ACCELERATION, "m/s^2", "acceleration"),
    (Dim::FORCE, "N", "force"),
    (Dim::TORQUE, "N*m", "torque or energy"),
    (Dim::PRESSURE, "Pa", "pressure or stress"),
    (Dim::INERTIA, "kg*m^2", "moment of inertia"),
    (Dim::STIFFNESS, "N/m", "stiffness"),
    (Dim::DAMPING, "N*s/m", "damping"),
    (Dim::ROT_DAMPING, "N*m*s", "rotational damping"),
    (Dim::DENSITY, "kg/m^3", "density"),
    (Dim::AREA, "m^2", "area"),
    (Dim([0, 3, 0]), "m^3", "volume"),
    (Dim([0, 4, 0]), "m^4", "second moment of area"),
    (Dim::BENDING, "N*m^2", "bending stiffness"),
    (Dim::MASS_PER_LENGTH, "kg/m", "mass per length"),
    (Dim::MASS_LENGTH, "kg*m", "mass times length"),
    (Dim::FOUNDATION, "N/m^3", "foundation modulus"),
    (Dim::COMPLIANCE, "m/N", "compliance"),
    (Dim([1, 0, 0]), "kg", "mass"),
    (Dim([1, 1, -1]), "kg*m/s", "momentum"),
];

/// One unit: name, factor to SI, dimension.
#[derive(Clone, Copy, Debug)]
pub struct UnitDef {
    /// As written.
    pub name: &'static str,
    /// Multiply by this to get SI.
    pub factor: f64,
    /// Dimension.
    pub dim: Dim,
}

const PI: f64 = std::f64::consts::PI;

/// The unit table (docs/language.md, "Units").
pub const UNITS: &[UnitDef] = &[
    UnitDef {
        name: "m",
        factor: 1.0,
        dim: Dim::LENGTH,
    },
    UnitDef {
        name: "mm",
        factor: 1e-3,
        dim: Dim::LENGTH,
    },
    UnitDef {
        name: "cm",
        factor: 1e-2,
        dim: Dim::LENGTH,
    },
    UnitDef {
        name: "km",
        factor: 1e3,
        dim: Dim::LENGTH,
    },
    UnitDef {
        name: "um",
        factor: 1e-6,
        dim: Dim::LENGTH,
    },
    UnitDef {
        name: "in",
        factor: 0.0254,
        dim: Dim::LENGTH,
    },
    UnitDef {
        name: "ft",
        factor: 0.3048,
        dim: Dim::LENGTH,
    },
    UnitDef {
        name: "kg",
        factor: 1.0,
        dim: Dim::MASS,
    },
    UnitDef {
        name: "g",
        factor: 1e-3,
        dim: Dim::MASS,
    },
    UnitDef {
        name: "tonne",
        factor: 1e3,
        dim: Dim::MASS,
    },
    UnitDef {
        name: "lb",
        factor: 0.453_592_37,
        dim: Dim::MASS,
    },
    UnitDef {
        name: "s",
        factor: 1.0,
        dim: Dim::TIME,
    },
    UnitDef {
        name: "ms",
        factor: 1e-3,
        dim: Dim::TIME,
    },
    UnitDef {
        name: "us",
        factor: 1e-6,
        dim: Dim::TIME,
    },
    UnitDef {
        name: "min",
        factor: 60.0,
        dim: Dim::TIME,
    },
    UnitDef {
        name: "rad",
        factor: 1.0,
        dim: Dim::NONE,
    },
    UnitDef {
        name: "deg",
        factor: PI / 180.0,
        dim: Dim::NONE,
    },
    UnitDef {
        name: "rev",
        factor: 2.0 * PI,
        dim: Dim::NONE,
    },
    UnitDef {
        name: "N",
        factor: 1.0,
        dim: Dim::FORCE,
    },
    UnitDef {
        name: "kN",
        factor: 1e3,
        dim: Dim::FORCE,
    },
    UnitDef {
        name: "lbf",
        factor: 4.448_221_615_260_5,
        dim: Dim::FORCE,
    },
    UnitDef {
        name: "J",
        factor: 1.0,
        dim: Dim::TORQUE,
    },
    UnitDef {
        name: "Pa",
        factor: 1.0,
        dim: Dim::PRESSURE,
    },
    UnitDef {
        name: "kPa",
        factor: 1e3,
        dim: Dim::PRESSURE,
    },
    UnitDef {
        name: "MPa",
        factor: 1e6,
        dim: Dim::PRESSURE,
    },
    UnitDef {
        name: "GPa",
        factor: 1e9,
        dim: Dim::PRESSURE,
    },
    UnitDef {
        name: "psi",
        factor: 6_894.757_293_168_361,
        dim: Dim::PRESSURE,
    },
    UnitDef {
        name: "Hz",
        factor: 1.0,
        dim: Dim::FREQUENCY,
    },
    UnitDef {
        name: "rpm",
        factor: 2.0 * PI / 60.0,
        dim: Dim::FREQUENCY,
    },
];

/// Looks a unit up by name.
pub fn unit(name: &str) -> Option<&'static UnitDef> {
    UNITS.iter().find(|u| u.name == name)
}

/// All unit names (for suggestions).
pub fn unit_names() -> impl Iterator<Item = &'static str> {
    UNITS.iter().map(|u| u.name)
}

/// Combines unit factors `(name, exponent)` into an SI factor and a dimension.
/// `Err(name)` names the first unknown unit; `Err("")` means the exponents are too large.
pub fn combine<'a>(
    factors: impl IntoIterator<Item = (&'a str, i32)>,
) -> Result<(f64, Dim), &'a str> {
    let mut f = 1.0;
    let mut d = Dim::NONE;
    for (name, e) in factors {
        let u = unit(name).ok_or(name)?;
        if e.abs() > MAX_EXPONENT {
            return Err("");
        }
        f *= u.factor.powi(e);
        d = d.times(u.dim.powi(e as i64).ok_or("")?).ok_or("")?;
    }
    Ok((f, d))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions() {
        let (f, d) = combine([("m", 1), ("s", -2)]).unwrap();
        assert_eq!((f, d), (1.0, Dim::ACCELERATION));
        let (f, d) = combine([("cm", 1)]).unwrap();
        assert!((f - 0.01).abs() < 1e-15 && d == Dim::LENGTH);
        let (f, d) = combine([("kg", 1), ("m", 2)]).unwrap();
        assert_eq!((f, d), (1.0, Dim::INERTIA));
        let (f, d) = combine([("deg", 1)]).unwrap();
        assert!((f - PI / 180.0).abs() < 1e-15 && d.is_none());
        let (f, d) = combine([("N", 1), ("s", 1), ("m", -1)]).unwrap();
        assert_eq!((f, d), (1.0, Dim::DAMPING));
        let (f, d) = combine([("GPa", 1)]).unwrap();
        assert_eq!((f, d), (1e9, Dim::PRESSURE));
        let (f, _) = combine([("rpm", 1)]).unwrap();
        assert!((f - 2.0 * PI / 60.0).abs() < 1e-15);
        let (f, d) = combine([("mm", 2)]).unwrap();
        assert!((f - 1e-6).abs() < 1e-20 && d == Dim::AREA);
        assert_eq!(combine([("furlong", 1)]), Err("furlong"));
        assert_eq!(combine([("m", 1000)]), Err(""));
    }

    #[test]
    fn texts() {
        assert_eq!(Dim::ACCELERATION.unit_text(), "m/s^2");
        assert_eq!(Dim([1, 3, -1]).unit_text(), "kg*m^3/s");
        assert_eq!(Dim([0, -1, 0]).unit_text(), "1/m");
        assert_eq!(Dim::LENGTH.describe(), "m (length)");
        assert_eq!(Dim([2, 0, 0]).describe(), "kg^2");
    }
}
