//! The beam plots of a run: per beam, `beam_<name>.svg` with its deflection and its section
//! forces and moments along the beam at the last frame.
//!
//! | panel | what |
//! |---|---|
//! | deflection | displacement of each node from its initial position, x, y, z (m), against the arc length s |
//! | section forces | `N1` (axial), `N2`, `N3` (shear) (N) at the elements' midpoints |
//! | section moments | `M1` (torsion), `M2`, `M3` (bending) (N·m) |
//!
//! Read from `beams.csv` (the section quantities) or, when the run wrote its beams in
//! `results.exo` (`format exodus`, no `beams.csv`), from that file's beam blocks; and from
//! `bodies.csv` (the nodes, bodies named `BEAM.node[k]`).

use std::path::{Path, PathBuf};

use super::data;
use super::figure::{color, Axis, Figure, LegendPos, Panel, Series, SeriesKind};
use super::PlotError;

/// One beam's rows of the last frame: (s, N1 N2 N3 M1 M2 M3) per element.
struct LastFrame {
    t: f64,
    rows: Vec<(f64, [f64; 6])>,
}

fn csv_err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError::Csv {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Per beam (in file order), its rows of the last complete frame of `beams.csv`.
fn last_frames(path: &Path) -> Result<Vec<(String, LastFrame)>, PlotError> {
    let mut r = csv::ReaderBuilder::new()
        .flexible(true)
        .from_path(path)
        .map_err(|e| csv_err(path, e))?;
    let width = r.headers().map_err(|e| csv_err(path, e))?.len();
    let mut out: Vec<(String, LastFrame)> = Vec::new();
    let mut rec = csv::StringRecord::new();
    loop {
        match r.read_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => return Err(csv_err(path, e)),
        }
        if rec.len() != width || width < 10 {
            break; // an incomplete last line
        }
        let num = |i: usize| -> Result<f64, PlotError> {
            rec.get(i).unwrap_or("").trim().parse::<f64>().map_err(|_| {
                csv_err(
                    path,
                    format!(
                        "line {}: `{}` is not a number",
                        rec.position().map_or(0, |p| p.line()),
                        rec.get(i).unwrap_or("")
                    ),
                )
            })
        };
        let (t, s) = (num(0)?, num(3)?);
        let mut v = [0.0; 6];
        for (k, x) in v.iter_mut().enumerate() {
            *x = num(4 + k)?;
        }
        let name = rec.get(1).unwrap_or("").to_string();
        let i = match out.iter().position(|(n, _)| *n == name) {
            Some(i) => i,
            None => {
                out.push((
                    name,
                    LastFrame {
                        t,
                        rows: Vec::new(),
                    },
                ));
                out.len() - 1
            }
        };
        let lf = &mut out[i].1;
        if t > lf.t {
            lf.t = t;
            lf.rows.clear();
        }
        if t == lf.t {
            lf.rows.push((s, v));
        }
    }
    Ok(out)
}

/// Per beam block of an Exodus file (the blocks with the beams' element variable `s`), its
/// rows of the last complete frame.
fn last_frames_exodus(path: &Path) -> Result<Vec<(String, LastFrame)>, PlotError> {
    use mbdc_runtime::output::{exodus, BEAM_COLUMNS};
    let err = |e: mbdc_runtime::output::OutputError| PlotError::Exodus(e.to_string());
    let file = exodus::read(path).map_err(err)?;
    let Some(last) = file.frames().checked_sub(1) else {
        return Ok(Vec::new());
    };
    let t = file.times().map_err(err)?.last().copied().unwrap_or(0.0);
    let mut out = Vec::new();
    for (k, block) in file.blocks().map_err(err)?.into_iter().enumerate() {
        if !file.has_element_variable("s", k) {
            continue;
        }
        let s = file.element("s", k, last, 1).map_err(err)?;
        let mut rows: Vec<(f64, [f64; 6])> = s.iter().map(|&s| (s, [0.0; 6])).collect();
        for (c, name) in BEAM_COLUMNS[..6].iter().enumerate() {
            let v = file.element(name, k, last, 1).map_err(err)?;
            for (row, x) in rows.iter_mut().zip(v) {
                row.1[c] = x;
            }
        }
        out.push((block.name, LastFrame { t, rows }));
    }
    Ok(out)
}

/// The node displacements of `beam` at the last frame of `bodies.csv`: (k, ux, uy, uz).
fn deflection(bodies: &Path, beam: &str) -> Result<Vec<[f64; 4]>, PlotError> {
    let head = data::header(bodies)?;
    let mut idx = Vec::new();
    for k in 0.. {
        let col = |c: &str| {
            head.iter()
                .position(|h| *h == format!("{beam}.node[{k}].{c}"))
        };
        match (col("x"), col("y"), col("z")) {
            (Some(x), Some(y), Some(z)) => idx.extend([x, y, z]),
            _ => break,
        }
    }
    if idx.is_empty() {
        return Ok(Vec::new());
    }
    let (mut first, mut last) = (None::<Vec<f64>>, Vec::new());
    data::for_each_row(bodies, &idx, |v| {
        if first.is_none() {
            first = Some(v.to_vec());
        }
        last.clear();
        last.extend_from_slice(v);
    })?;
    let first = first.unwrap_or_default();
    Ok((0..idx.len() / 3)
        .map(|k| {
            [
                k as f64,
                last[3 * k] - first[3 * k],
                last[3 * k + 1] - first[3 * k + 1],
                last[3 * k + 2] - first[3 * k + 2],
            ]
        })
        .collect())
}

/// Draw `beam_<name>.svg` for every beam of the run in `dir`. Returns the files written
/// and notes on what was skipped; nothing when the run has neither `beams.csv` nor beams in
/// `results.exo`.
pub fn draw_beam_plots(
    dir: &Path,
    model: &str,
    sub: &Option<String>,
) -> Result<(Vec<PathBuf>, Vec<String>), PlotError> {
    let (csv, exo) = (dir.join("beams.csv"), dir.join("results.exo"));
    let (mut files, mut notes) = (Vec::new(), Vec::new());
    let beams = if csv.exists() {
        let beams = last_frames(&csv)?;
        if beams.is_empty() {
            notes.push("beam plots: beams.csv has no frames".into());
        }
        beams
    } else if exo.exists() {
        last_frames_exodus(&exo)?
    } else {
        return Ok((files, notes));
    };
    for (name, lf) in beams {
        // a colour per series across the panels, so each polyline is tagged with its own
        let line = |label: &str, c: usize, pts: Vec<(f64, f64)>| Series {
            kind: SeriesKind::LinePoints,
            ..Series::line(label, color(c), pts)
        };
        let s_of = |i: usize| {
            lf.rows
                .iter()
                .map(move |r| (r.0, r.1[i]))
                .collect::<Vec<_>>()
        };
        let mut panels = Vec::new();
        let bodies = dir.join("bodies.csv");
        if bodies.exists() {
            let d = deflection(&bodies, &name)?;
            if d.len() >= 2 {
                // node k sits at the arc length of the element boundaries
                let mut s_nodes = vec![0.0];
                let mut prev = 0.0;
                for r in &lf.rows {
                    let end = prev + 2.0 * (r.0 - prev);
                    s_nodes.push(end);
                    prev = end;
                }
                let pts = |c: usize| -> Vec<(f64, f64)> {
                    d.iter().zip(&s_nodes).map(|(u, s)| (*s, u[c])).collect()
                };
                panels.push(Panel {
                    title: format!("Deflection of '{name}' at t = {} s", lf.t),
                    x: Axis::linear("arc length s (m)"),
                    y: Axis::linear("displacement (m)"),
                    series: vec![
                        line("ux", 0, pts(1)),
                        line("uy", 1, pts(2)),
                        line("uz", 2, pts(3)),
                    ],
                    legend: LegendPos::UpperRight,
                    ..Panel::default()
                });
            }
        }
        panels.push(Panel {
            title: "Section forces (convected frame)".into(),
            x: Axis::linear("arc length s (m)"),
            y: Axis::linear("force (N)"),
            series: vec![
                line("N1 axial", 3, s_of(0)),
                line("N2 shear", 4, s_of(1)),
                line("N3 shear", 5, s_of(2)),
            ],
            legend: LegendPos::UpperRight,
            ..Panel::default()
        });
        panels.push(Panel {
            title: "Section moments (convected frame)".into(),
            x: Axis::linear("arc length s (m)"),
            y: Axis::linear("moment (N·m)"),
            series: vec![
                line("M1 torsion", 6, s_of(3)),
                line("M2 bending", 7, s_of(4)),
                line("M3 bending", 8, s_of(5)),
            ],
            legend: LegendPos::UpperRight,
            ..Panel::default()
        });
        let fig = Figure {
            title: format!("{model}: beam '{name}' at t = {} s", lf.t),
            subtitle: sub.clone(),
            panels,
            columns: 1,
            panel_size: (960, 300),
        };
        let safe: String = name
            .chars()
            .map(|c| {
                if c.is_alphanumeric() || c == '_' || c == '-' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        let out = dir.join(format!("beam_{safe}.svg"));
        fig.save(&out)?;
        files.push(out);
    }
    Ok((files, notes))
}
