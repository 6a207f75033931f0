//! CSV headers and rows: numbers in shortest round-trip form (ryu), names quoted when
//! they need it.

use crate::contract::system::Layout;

use super::Frame;

/// Append `x` in the shortest form that parses back to the same `f64` (`NaN`, `inf`,
/// `-inf` for the non-finite values, which Rust's `f64::from_str` accepts).
#[inline]
pub(crate) fn push_f64(out: &mut String, x: f64) {
    let mut b = ryu::Buffer::new();
    out.push_str(b.format(x));
}

/// Append a header field, quoted (RFC 4180) if it contains a comma, quote, line break or
/// leading/trailing space.
pub(crate) fn push_field(out: &mut String, name: &str) {
    let needs =
        name.contains([',', '"', '\n', '\r']) || name.starts_with(' ') || name.ends_with(' ');
    if needs {
        out.push('"');
        for c in name.chars() {
            if c == '"' {
                out.push('"');
            }
            out.push(c);
        }
        out.push('"');
    } else {
        out.push_str(name);
    }
}

fn header(fields: impl IntoIterator<Item = String>) -> String {
    let mut s = String::new();
    for (i, f) in fields.into_iter().enumerate() {
        if i > 0 {
            s.push(',');
        }
        push_field(&mut s, &f);
    }
    s.push('\n');
    s
}

/// Per-body column suffixes of `bodies.csv`.
pub const BODY_COLUMNS: [&str; 13] = [
    "x", "y", "z", "qw", "qx", "qy", "qz", "vx", "vy", "vz", "wx", "wy", "wz",
];

/// Columns of `energy.csv`.
pub const ENERGY_COLUMNS: [&str; 12] = [
    "t",
    "kinetic",
    "potential",
    "total",
    "work",
    "drift",
    "px",
    "py",
    "pz",
    "Lx",
    "Ly",
    "Lz",
];

/// Header line of `bodies.csv`.
pub fn bodies_header(layout: &Layout) -> String {
    header(
        std::iter::once("t".to_string()).chain(
            layout
                .body_names
                .iter()
                .flat_map(|b| BODY_COLUMNS.iter().map(move |c| format!("{b}.{c}"))),
        ),
    )
}

/// Header line of `energy.csv`.
pub fn energy_header() -> String {
    header(ENERGY_COLUMNS.iter().map(|c| c.to_string()))
}

/// Header line of `constraints.csv`: per joint `<joint>.violation`, then
/// `<joint>.velocity_violation` if it has nonholonomic rows, then `<joint>.lambda<k>`
/// for each of its rows (k from 0).
pub fn constraints_header(layout: &Layout) -> String {
    let mut cols = vec!["t".to_string()];
    for j in &layout.joints {
        cols.push(format!("{}.violation", j.name));
        if j.nonholonomic > 0 {
            cols.push(format!("{}.velocity_violation", j.name));
        }
        for k in 0..j.rows {
            cols.push(format!("{}.lambda{k}", j.name));
        }
    }
    header(cols)
}

/// Append a `bodies.csv` row.
pub(crate) fn bodies_row(out: &mut String, f: &Frame) {
    push_f64(out, f.t);
    for (p, v) in f.poses.iter().zip(&f.twists) {
        for x in [
            p.r.x, p.r.y, p.r.z, p.q.w, p.q.i, p.q.j, p.q.k, v.v.x, v.v.y, v.v.z, v.w.x, v.w.y,
            v.w.z,
        ] {
            out.push(',');
            push_f64(out, x);
        }
    }
    out.push('\n');
}

/// Append an `energy.csv` row.
pub(crate) fn energy_row(out: &mut String, f: &Frame, drift: f64) {
    push_f64(out, f.t);
    let [px, py, pz] = f.momentum;
    let [lx, ly, lz] = f.angular_momentum;
    for x in [
        f.kinetic,
        f.potential,
        f.kinetic + f.potential,
        f.work,
        drift,
        px,
        py,
        pz,
        lx,
        ly,
        lz,
    ] {
        out.push(',');
        push_f64(out, x);
    }
    out.push('\n');
}

/// Append a `constraints.csv` row.
pub(crate) fn constraints_row(out: &mut String, layout: &Layout, f: &Frame) {
    push_f64(out, f.t);
    for (j, jl) in layout.joints.iter().enumerate() {
        out.push(',');
        push_f64(out, f.violation[j]);
        if jl.nonholonomic > 0 {
            out.push(',');
            push_f64(out, f.velocity_violation[j]);
        }
        for &l in &f.lambda[jl.first_row..jl.first_row + jl.rows] {
            out.push(',');
            push_f64(out, l);
        }
    }
    out.push('\n');
}

/// Per-element columns of `beams.csv` after `t, beam, element, s`: the section resultants
/// (convected components: axial, shear 2, shear 3; torsion, bending 2, bending 3) and the
/// strains conjugate to them.
pub const BEAM_COLUMNS: [&str; 12] = [
    "N1", "N2", "N3", "M1", "M2", "M3", "gamma1", "gamma2", "gamma3", "kappa1", "kappa2", "kappa3",
];

/// Header line of `beams.csv` (one row per element and frame).
pub fn beams_header() -> String {
    header(
        ["t", "beam", "element", "s"]
            .into_iter()
            .chain(BEAM_COLUMNS)
            .map(str::to_string),
    )
}

/// Append the `beams.csv` rows of a frame: one per element (its [`Frame::sections`] entry:
/// the arc length `s` of its midpoint from the beam's start, unstrained, then
/// [`BEAM_COLUMNS`]).
pub(crate) fn beams_rows(out: &mut String, layout: &Layout, f: &Frame) {
    use std::fmt::Write as _;
    let bl = &layout.beams;
    for (e, el) in bl.elements.iter().enumerate() {
        let b = &bl.beams[el.beam];
        push_f64(out, f.t);
        out.push(',');
        push_field(out, &b.name);
        out.push(',');
        let _ = write!(out, "{}", e - b.first_element);
        for x in &f.sections[e] {
            out.push(',');
            push_f64(out, *x);
        }
        out.push('\n');
    }
}

/// The `mesh_energy.csv` header.
pub fn mesh_energy_header() -> String {
    let mut h = String::from("t");
    for c in super::MESH_ENERGY_COLUMNS {
        h.push(',');
        h.push_str(c);
    }
    h.push('\n');
    h
}

/// Append a `mesh_energy.csv` row.
pub(crate) fn mesh_energy_row(out: &mut String, f: &Frame) {
    push_f64(out, f.t);
    for x in f.mesh_energy {
        out.push(',');
        push_f64(out, x);
    }
    out.push('\n');
}
