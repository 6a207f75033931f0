//! The curves under the 3-D view: the energy terms and the energy balance's drift from
//! `energy.csv`, the largest joint violation from `constraints.csv`.

use std::path::Path;

use serde::Serialize;

use super::ViewError;
use crate::plot::data;

/// Points per curve at most (every k-th row, and the last).
const MAX_POINTS: usize = 2000;

/// One time series.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(crate) struct Curve {
    /// Name.
    pub name: String,
    /// Unit.
    pub unit: String,
    /// Times, s.
    pub t: Vec<f64>,
    /// Values (non-finite ones are `null` in the JSON).
    pub v: Vec<f64>,
}

/// Every k-th point and the last, at most [`MAX_POINTS`].
fn thin(t: &[f64], v: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = t.len().min(v.len());
    let every = n.div_ceil(MAX_POINTS).max(1);
    let keep = super::frames::kept_frames(n, every);
    (
        keep.iter().map(|&i| t[i]).collect(),
        keep.iter().map(|&i| v[i]).collect(),
    )
}

/// The curves of the output folder (none where the files are absent).
pub(crate) fn read(dir: &Path) -> Result<Vec<Curve>, ViewError> {
    let err = |e: crate::plot::PlotError| ViewError(e.to_string());
    let mut out = Vec::new();
    let energy = dir.join("energy.csv");
    if energy.exists() {
        let names: Vec<String> = ["t", "kinetic", "potential", "total", "drift"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let cols = data::read(&energy, &names).map_err(err)?;
        let t = cols.get("t").unwrap_or(&[]).to_vec();
        for (name, unit) in [
            ("kinetic", "J"),
            ("potential", "J"),
            ("total", "J"),
            ("drift", "1"),
        ] {
            if let Some(v) = cols.get(name) {
                let (t, v) = thin(&t, v);
                let label = if name == "drift" {
                    "energy balance error"
                } else {
                    name
                };
                out.push(Curve {
                    name: label.into(),
                    unit: unit.into(),
                    t,
                    v,
                });
            }
        }
    }
    let constraints = dir.join("constraints.csv");
    if constraints.exists() {
        let head = data::header(&constraints).map_err(err)?;
        let idx: Vec<usize> = std::iter::once(0)
            .chain(
                head.iter()
                    .enumerate()
                    .filter(|(_, h)| h.ends_with(".violation"))
                    .map(|(i, _)| i),
            )
            .collect();
        if idx.len() > 1 {
            let (mut t, mut v) = (Vec::new(), Vec::new());
            data::for_each_row(&constraints, &idx, |vals| {
                t.push(vals[0]);
                v.push(vals[1..].iter().fold(0.0f64, |m, x| m.max(x.abs())));
            })
            .map_err(err)?;
            let (t, v) = thin(&t, &v);
            out.push(Curve {
                name: "largest joint violation".into(),
                unit: "m or rad".into(),
                t,
                v,
            });
        }
    }
    Ok(out)
}
