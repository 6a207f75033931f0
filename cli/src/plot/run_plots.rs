//! The plots of a run, drawn from its output folder:
//!
//! | file | panels |
//! |---|---|
//! | `energy.svg` | kinetic, potential and total energy (J); relative drift `(E − E₀)/E_ref` |
//! | `mesh_energy.svg` | scenes with meshes: kinetic, strain, hourglass, foundation energy, the work of the loads, dissipation, plastic work, the work of the bodies through ties (J), and their balance |
//! | `constraints.svg` | holonomic violation `max |Φ|` per joint (log scale); velocity residual per nonholonomic joint |
//! | `trajectories.svg` | mass-centre x, y, z (m) of up to a few bodies |
//! | `beam_<name>.svg` | per beam: deflection, section forces and moments along it at the last frame ([`super::beam_plots`]) |
//!
//! A plot is drawn only when its CSV file exists and has something to show; what was
//! skipped is said in [`Drawn::notes`]. Plots are drawn from whatever frames the files
//! hold, so a run that stopped is plotted up to its last frame.

use std::path::{Path, PathBuf};

use mbdc_runtime::output::Summary;

use super::data::{self, Columns};
use super::figure::{color, decimate, Axis, Figure, LegendPos, Panel, Series, TopMarks};
use super::PlotError;

/// Most points drawn per series (longer series are thinned, keeping peaks).
pub const MAX_POINTS: usize = 3000;
/// Bodies shown in `trajectories.svg` when none are chosen.
pub const DEFAULT_BODIES: usize = 3;
/// Joints shown in `constraints.svg` when none are chosen (the largest violations).
pub const DEFAULT_JOINTS: usize = 8;

/// What to draw.
#[derive(Clone, Debug, Default)]
pub struct RunPlotOptions {
    /// Bodies for `trajectories.svg` (empty: the [`DEFAULT_BODIES`] that move most).
    pub bodies: Vec<String>,
    /// Joints for `constraints.svg` (empty: all, or the [`DEFAULT_JOINTS`] largest).
    pub joints: Vec<String>,
}

/// What [`draw_run_plots`] wrote.
#[derive(Clone, Debug, Default)]
pub struct Drawn {
    /// The SVG files written.
    pub files: Vec<PathBuf>,
    /// Plots that were skipped and why.
    pub notes: Vec<String>,
}

/// The titles' common part: the model and run settings from `summary.json`, if present.
fn context(dir: &Path) -> (String, Option<String>) {
    match Summary::read(&dir.join("summary.json")) {
        Ok(s) => {
            let mut sub = format!(
                "{}, h = {} s, t = 0 … {} s",
                s.method,
                super::figure::number_label(s.step),
                super::figure::number_label(s.final_time)
            );
            if let Some(f) = &s.failure {
                sub.push_str(&format!(
                    " — STOPPED at t = {} s: {} of {}",
                    super::figure::number_label(f.time),
                    f.quantity,
                    f.location
                ));
            } else if let Some(i) = &s.interrupted {
                sub.push_str(&format!(
                    " — interrupted by {} at t = {} s",
                    i.by,
                    super::figure::number_label(i.time)
                ));
            } else if !s.finished {
                sub.push_str(" — did not finish (killed, or still running)");
            }
            (s.model, Some(sub))
        }
        Err(_) => (
            dir.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "run".into()),
            None,
        ),
    }
}

fn xy(t: &[f64], y: &[f64]) -> Vec<(f64, f64)> {
    let pts: Vec<(f64, f64)> = t.iter().copied().zip(y.iter().copied()).collect();
    decimate(&pts, MAX_POINTS)
}

const TIME: &str = "time t (s)";

/// Draw every run plot of `dir` that its files allow.
///
/// # Errors
/// A file that exists but cannot be read, a requested body or joint that does not exist,
/// or a file that cannot be written.
pub fn draw_run_plots(dir: &Path, opts: &RunPlotOptions) -> Result<Drawn, PlotError> {
    if !dir.is_dir() {
        return Err(PlotError::Request(format!(
            "{} is not an output folder (run `mbdc run FILE -o {}` first)",
            dir.display(),
            dir.display()
        )));
    }
    let (model, sub) = context(dir);
    let mut drawn = Drawn::default();
    let mut any_file = false;
    for (file, f) in [
        ("energy.csv", energy_figure as FigFn),
        ("constraints.csv", constraints_figure as FigFn),
        ("bodies.csv", trajectories_figure as FigFn),
        ("mesh_energy.csv", mesh_energy_figure as FigFn),
    ] {
        let path = dir.join(file);
        if !path.exists() {
            continue;
        }
        any_file = true;
        match f(&path, &model, &sub, opts)? {
            Ok((name, fig)) => {
                let out = dir.join(name);
                fig.save(&out)?;
                drawn.files.push(out);
            }
            Err(note) => drawn.notes.push(note),
        }
    }
    if !any_file {
        return Err(PlotError::Request(format!(
            "{} has none of bodies.csv, energy.csv, constraints.csv",
            dir.display()
        )));
    }
    let (files, notes) = super::beam_plots::draw_beam_plots(dir, &model, &sub)?;
    drawn.files.extend(files);
    drawn.notes.extend(notes);
    Ok(drawn)
}

/// A figure and its file name, or why there is nothing to draw.
type FigResult = Result<(&'static str, Figure), String>;
type FigFn = fn(&Path, &str, &Option<String>, &RunPlotOptions) -> Result<FigResult, PlotError>;

fn energy_figure(
    path: &Path,
    model: &str,
    sub: &Option<String>,
    _opts: &RunPlotOptions,
) -> Result<FigResult, PlotError> {
    let names: Vec<String> = ["t", "kinetic", "potential", "total", "drift"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let c = data::read(path, &names)?;
    if c.rows() == 0 {
        return Ok(Err("energy.svg: energy.csv has no frames".into()));
    }
    let t = c.get("t").unwrap_or_default();
    let col = |n: &str| c.get(n).unwrap_or_default();
    let energies = Panel {
        title: "Energy".into(),
        x: Axis::linear(TIME),
        y: Axis::linear("energy (J)"),
        series: vec![
            Series::line("kinetic", color(0), xy(t, col("kinetic"))),
            Series::line("potential", color(1), xy(t, col("potential"))),
            Series::line("total", BLACKISH, xy(t, col("total"))),
        ],
        legend: LegendPos::UpperRight,
        ..Panel::default()
    };
    let drift = Panel {
        title: "Relative energy drift (E − E₀) / E_ref".into(),
        x: Axis::linear(TIME),
        y: Axis::linear("relative drift (1)"),
        series: vec![Series::line("drift", color(2), xy(t, col("drift")))],
        note: Some("E_ref = max(|E₀|, K_max + V_max − V_min): the energy in play".into()),
        legend: LegendPos::UpperRight,
        ..Panel::default()
    };
    Ok(Ok((
        "energy.svg",
        Figure {
            title: format!("{model}: energy"),
            subtitle: sub.clone(),
            panels: vec![energies, drift],
            columns: 1,
            panel_size: (960, 340),
        },
    )))
}

/// The meshes' energy balance: the terms, and the balance against the energy in play.
fn mesh_energy_figure(
    path: &Path,
    model: &str,
    sub: &Option<String>,
    _opts: &RunPlotOptions,
) -> Result<FigResult, PlotError> {
    let names: Vec<String> = [
        "t",
        "kinetic",
        "strain",
        "hourglass",
        "foundation",
        "external_work",
        "dissipated",
        "plastic",
        "tie_work",
        "balance",
    ]
    .iter()
    .map(|s| s.to_string())
    // `plastic` and `tie_work` are absent from the files of runs before plasticity and ties.
    .filter(|n| {
        (n != "plastic" && n != "tie_work") || data::header(path).is_ok_and(|h| h.contains(n))
    })
    .collect();
    let c = data::read(path, &names)?;
    if c.rows() == 0 {
        return Ok(Err("mesh_energy.svg: mesh_energy.csv has no frames".into()));
    }
    let t = c.get("t").unwrap_or_default();
    let col = |n: &str| c.get(n).unwrap_or_default();
    let mut series = vec![
        Series::line("kinetic", color(0), xy(t, col("kinetic"))),
        Series::line("strain", color(1), xy(t, col("strain"))),
        Series::line("work of the loads", color(2), xy(t, col("external_work"))),
    ];
    for (i, n) in [
        "hourglass",
        "foundation",
        "dissipated",
        "plastic",
        "tie_work",
    ]
    .iter()
    .enumerate()
    {
        if col(n).iter().any(|v| *v != 0.0) {
            series.push(Series::line(*n, color(3 + i), xy(t, col(n))));
        }
    }
    let terms = Panel {
        title: "Mesh energy".into(),
        x: Axis::linear(TIME),
        y: Axis::linear("energy (J)"),
        series,
        legend: LegendPos::LowerRight,
        ..Panel::default()
    };
    let balance = Panel {
        title:
            "Balance K + U + U_hg + U_f − W − W_tie + D + D_p (constant up to the method's error)"
                .into(),
        x: Axis::linear(TIME),
        y: Axis::linear("energy (J)"),
        series: vec![Series::line("balance", BLACKISH, xy(t, col("balance")))],
        legend: LegendPos::UpperRight,
        ..Panel::default()
    };
    Ok(Ok((
        "mesh_energy.svg",
        Figure {
            title: format!("{model}: mesh energy balance"),
            subtitle: sub.clone(),
            panels: vec![terms, balance],
            columns: 1,
            panel_size: (960, 340),
        },
    )))
}

/// Near-black for the total energy line (pure black is reserved for axes).
const BLACKISH: plotters::style::RGBColor = plotters::style::RGBColor(40, 40, 40);

fn constraints_figure(
    path: &Path,
    model: &str,
    sub: &Option<String>,
    opts: &RunPlotOptions,
) -> Result<FigResult, PlotError> {
    let head = data::header(path)?;
    let index = data::column_index(&head);
    let joints: Vec<String> = head
        .iter()
        .filter_map(|h| h.strip_suffix(".violation").map(str::to_string))
        .collect();
    if joints.is_empty() {
        return Ok(Err("constraints.svg: the scene has no joints".into()));
    }
    let chosen: Vec<String> = if opts.joints.is_empty() {
        joints.clone()
    } else {
        for j in &opts.joints {
            if !index.contains_key(format!("{j}.violation").as_str()) {
                return Err(PlotError::Request(format!(
                    "no joint `{j}` in {}{}",
                    path.display(),
                    data::suggest(j, &joints)
                )));
            }
        }
        opts.joints.clone()
    };
    let vel: Vec<String> = chosen
        .iter()
        .filter(|j| index.contains_key(format!("{j}.velocity_violation").as_str()))
        .cloned()
        .collect();
    let mut names = vec!["t".to_string()];
    names.extend(chosen.iter().map(|j| format!("{j}.violation")));
    names.extend(vel.iter().map(|j| format!("{j}.velocity_violation")));
    let c = data::read(path, &names)?;
    if c.rows() == 0 {
        return Ok(Err("constraints.svg: constraints.csv has no frames".into()));
    }
    let t = c.get("t").unwrap_or_default();
    let largest = |cols: &[String], suffix: &str| -> (Vec<String>, usize) {
        let mut v: Vec<(f64, &String)> = cols
            .iter()
            .map(|j| {
                let m = c
                    .get(&format!("{j}.{suffix}"))
                    .unwrap_or_default()
                    .iter()
                    .copied()
                    .filter(|x| x.is_finite())
                    .fold(0.0, f64::max);
                (m, j)
            })
            .collect();
        let total = v.len();
        if opts.joints.is_empty() && v.len() > DEFAULT_JOINTS {
            v.sort_by(|a, b| b.0.total_cmp(&a.0));
            v.truncate(DEFAULT_JOINTS);
        }
        (v.into_iter().map(|(_, j)| j.clone()).collect(), total)
    };
    let mut panels = Vec::new();
    let (shown, total) = largest(&chosen, "violation");
    let series: Vec<Series> = shown
        .iter()
        .enumerate()
        .map(|(i, j)| {
            Series::line(
                j.clone(),
                color(i),
                xy(t, c.get(&format!("{j}.violation")).unwrap_or_default()),
            )
        })
        .collect();
    let all_zero = series
        .iter()
        .all(|s| s.points.iter().all(|p| !(p.1 > 0.0 && p.1.is_finite())));
    let mut notes = Vec::new();
    if shown.len() < total {
        notes.push(format!(
            "the {} joints with the largest violation of {total}",
            shown.len()
        ));
    }
    if all_zero {
        notes.push("every violation is exactly 0 (nothing to show on a log scale)".into());
    }
    notes.push("zero values are not drawn".into());
    panels.push(Panel {
        title: "Constraint violation per joint: max |Φ| over its position rows".into(),
        x: Axis::linear(TIME),
        y: Axis::log("violation |Φ| (m; rad for angular rows)"),
        series,
        top: TopMarks::default(),
        note: Some(notes.join("; ")),
        legend: LegendPos::LowerRight,
    });
    if !vel.is_empty() {
        let (shown, _) = largest(&vel, "velocity_violation");
        panels.push(Panel {
            title: "Velocity residual per nonholonomic joint: max |B u̇ + b|".into(),
            x: Axis::linear(TIME),
            y: Axis::log("residual (m/s; rad/s for angular rows)"),
            series: shown
                .iter()
                .enumerate()
                .map(|(i, j)| {
                    Series::line(
                        j.clone(),
                        color(i),
                        xy(
                            t,
                            c.get(&format!("{j}.velocity_violation"))
                                .unwrap_or_default(),
                        ),
                    )
                })
                .collect(),
            note: Some("zero values are not drawn".into()),
            legend: LegendPos::LowerRight,
            ..Panel::default()
        });
    }
    Ok(Ok((
        "constraints.svg",
        Figure {
            title: format!("{model}: constraint violation"),
            subtitle: sub.clone(),
            panels,
            columns: 1,
            panel_size: (960, 360),
        },
    )))
}

/// Bodies in `bodies.csv` (from its `<body>.x` columns).
pub fn body_names(head: &[String]) -> Vec<String> {
    let index = data::column_index(head);
    head.iter()
        .filter_map(|h| h.strip_suffix(".x").map(str::to_string))
        .filter(|b| index.contains_key(format!("{b}.qw").as_str()))
        .collect()
}

fn trajectories_figure(
    path: &Path,
    model: &str,
    sub: &Option<String>,
    opts: &RunPlotOptions,
) -> Result<FigResult, PlotError> {
    let head = data::header(path)?;
    let bodies = body_names(&head);
    if bodies.is_empty() {
        return Ok(Err("trajectories.svg: the scene has no rigid bodies".into()));
    }
    let chosen: Vec<String> = if opts.bodies.is_empty() {
        most_moving(path, &head, &bodies, DEFAULT_BODIES)?
    } else {
        let known: std::collections::HashSet<&str> = bodies.iter().map(String::as_str).collect();
        for b in &opts.bodies {
            if !known.contains(b.as_str()) {
                return Err(PlotError::Request(format!(
                    "no body `{b}` in {}{}",
                    path.display(),
                    data::suggest(b, &bodies)
                )));
            }
        }
        opts.bodies.clone()
    };
    let mut names = vec!["t".to_string()];
    for b in &chosen {
        for a in ["x", "y", "z"] {
            names.push(format!("{b}.{a}"));
        }
    }
    let c: Columns = data::read(path, &names)?;
    if c.rows() == 0 {
        return Ok(Err("trajectories.svg: bodies.csv has no frames".into()));
    }
    let t = c.get("t").unwrap_or_default();
    let panels = ["x", "y", "z"]
        .iter()
        .map(|a| Panel {
            title: format!("Mass-centre {a} (world)"),
            x: Axis::linear(TIME),
            y: Axis::linear(format!("{a} (m)")),
            series: chosen
                .iter()
                .enumerate()
                .map(|(i, b)| {
                    Series::line(
                        b.clone(),
                        color(i),
                        xy(t, c.get(&format!("{b}.{a}")).unwrap_or_default()),
                    )
                })
                .collect(),
            legend: LegendPos::UpperRight,
            ..Panel::default()
        })
        .collect();
    let which = if opts.bodies.is_empty() && bodies.len() > chosen.len() {
        format!(
            " ({} of {} bodies: those that move most; choose with `mbdc plot DIR --bodies A,B`)",
            chosen.len(),
            bodies.len()
        )
    } else {
        String::new()
    };
    Ok(Ok((
        "trajectories.svg",
        Figure {
            title: format!("{model}: trajectories{which}"),
            subtitle: sub.clone(),
            panels,
            columns: 1,
            panel_size: (960, 300),
        },
    )))
}

/// The `n` bodies whose mass centres sweep the largest box (ties: file order).
fn most_moving(
    path: &Path,
    head: &[String],
    bodies: &[String],
    n: usize,
) -> Result<Vec<String>, PlotError> {
    if bodies.len() <= n {
        return Ok(bodies.to_vec());
    }
    let index = data::column_index(head);
    let mut idx = Vec::with_capacity(3 * bodies.len());
    for b in bodies {
        for a in ["x", "y", "z"] {
            let name = format!("{b}.{a}");
            let i = *index.get(name.as_str()).ok_or_else(|| PlotError::Csv {
                path: path.to_path_buf(),
                message: format!("no column `{name}`"),
            })?;
            idx.push(i);
        }
    }
    let mut lo = vec![f64::INFINITY; idx.len()];
    let mut hi = vec![f64::NEG_INFINITY; idx.len()];
    data::for_each_row(path, &idx, |v| {
        for (k, x) in v.iter().enumerate() {
            if x.is_finite() {
                lo[k] = lo[k].min(*x);
                hi[k] = hi[k].max(*x);
            }
        }
    })?;
    let mut score: Vec<(f64, usize)> = (0..bodies.len())
        .map(|b| {
            let s: f64 = (0..3)
                .map(|a| {
                    let k = 3 * b + a;
                    if hi[k] >= lo[k] {
                        (hi[k] - lo[k]).powi(2)
                    } else {
                        0.0
                    }
                })
                .sum();
            (s, b)
        })
        .collect();
    score.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut pick: Vec<usize> = score.iter().take(n).map(|s| s.1).collect();
    pick.sort_unstable();
    Ok(pick.into_iter().map(|b| bodies[b].clone()).collect())
}

/// The unit of an output column, from its name and file.
pub fn unit_of(file: &str, column: &str) -> &'static str {
    let suffix = column.rsplit_once('.').map_or(column, |(_, s)| s);
    match file {
        "bodies.csv" => match suffix {
            "x" | "y" | "z" => "m",
            "qw" | "qx" | "qy" | "qz" => "1",
            "vx" | "vy" | "vz" => "m/s",
            "wx" | "wy" | "wz" => "rad/s",
            _ => "?",
        },
        "energy.csv" => match column {
            "kinetic" | "potential" | "total" => "J",
            "drift" => "1",
            "px" | "py" | "pz" => "kg·m/s",
            "Lx" | "Ly" | "Lz" => "kg·m²/s",
            _ => "?",
        },
        _ => {
            if suffix == "violation" {
                "m or rad"
            } else if suffix == "velocity_violation" {
                "m/s or rad/s"
            } else if suffix.starts_with("lambda") {
                "N or N·m"
            } else {
                "?"
            }
        }
    }
}

const FILES: [&str; 3] = ["bodies.csv", "energy.csv", "constraints.csv"];

/// A figure of the named quantities against time: any columns of the output files, by
/// name (`rod1.x`, `total`, `shoulder.violation`), or `FILE:COLUMN` (`energy:total`) where
/// a name is in more than one file. Quantities with the same unit share a panel.
///
/// # Errors
/// An unknown or ambiguous name (with suggestions), or an unreadable file.
pub fn quantities_figure(dir: &Path, names: &[String], log: bool) -> Result<Figure, PlotError> {
    if names.is_empty() {
        return Err(PlotError::Request("name at least one quantity".into()));
    }
    let heads: Vec<(&str, Vec<String>)> = FILES
        .iter()
        .filter_map(|f| {
            let p = dir.join(f);
            p.exists().then(|| data::header(&p).map(|h| (*f, h)))
        })
        .collect::<Result<_, _>>()?;
    if heads.is_empty() {
        return Err(PlotError::Request(format!(
            "{} has none of {}",
            dir.display(),
            FILES.join(", ")
        )));
    }
    // resolve every name to (file, column)
    let mut wanted: Vec<(&str, String)> = Vec::new();
    for n in names {
        let (file, col) = match n.split_once(':') {
            Some((f, c)) => {
                let file = FILES
                    .iter()
                    .find(|x| x.trim_end_matches(".csv") == f || **x == f)
                    .ok_or_else(|| {
                        PlotError::Request(format!(
                            "`{f}` in `{n}` is not an output file (bodies, energy, constraints)"
                        ))
                    })?;
                (Some(*file), c.to_string())
            }
            None => (None, n.clone()),
        };
        if col == "t" {
            return Err(PlotError::Request(
                "`t` is the horizontal axis of every plot".into(),
            ));
        }
        let hits: Vec<&str> = heads
            .iter()
            .filter(|(f, h)| file.is_none_or(|x| x == *f) && h.contains(&col))
            .map(|(f, _)| *f)
            .collect();
        match hits.as_slice() {
            [f] => wanted.push((f, col)),
            [] => {
                let all: Vec<String> = heads
                    .iter()
                    .flat_map(|(_, h)| h.iter().filter(|c| *c != "t").cloned())
                    .collect();
                return Err(PlotError::Request(format!(
                    "no quantity `{n}` in {}{}",
                    dir.display(),
                    data::suggest(&col, &all)
                )));
            }
            many => {
                let opts: Vec<String> = many
                    .iter()
                    .map(|f| format!("`{}:{col}`", f.trim_end_matches(".csv")))
                    .collect();
                return Err(PlotError::Request(format!(
                    "`{n}` is in several files; write {}",
                    opts.join(" or ")
                )));
            }
        }
    }
    // read per file, group by unit
    let mut groups: Vec<(&'static str, Vec<Series>)> = Vec::new();
    let mut k = 0usize;
    for file in FILES {
        let cols: Vec<String> = wanted
            .iter()
            .filter(|(f, _)| *f == file)
            .map(|(_, c)| c.clone())
            .collect();
        if cols.is_empty() {
            continue;
        }
        let mut req = vec!["t".to_string()];
        req.extend(cols.iter().cloned());
        let c = data::read(&dir.join(file), &req)?;
        let t = c.get("t").unwrap_or_default();
        for col in &cols {
            let unit = unit_of(file, col);
            let s = Series::line(col.clone(), color(k), xy(t, c.get(col).unwrap_or_default()));
            k += 1;
            match groups.iter_mut().find(|g| g.0 == unit) {
                Some(g) => g.1.push(s),
                None => groups.push((unit, vec![s])),
            }
        }
    }
    let (model, sub) = context(dir);
    let panels = groups
        .into_iter()
        .map(|(unit, series)| {
            let title = series
                .iter()
                .map(|s| s.name.as_str())
                .collect::<Vec<_>>()
                .join(", ");
            let label = format!("value ({unit})");
            Panel {
                title,
                x: Axis::linear(TIME),
                y: if log {
                    Axis::log(label)
                } else {
                    Axis::linear(label)
                },
                note: log.then(|| "zero and negative values are not drawn".to_string()),
                series,
                legend: LegendPos::UpperRight,
                ..Panel::default()
            }
        })
        .collect();
    Ok(Figure {
        title: format!("{model}: {}", names.join(", ")),
        subtitle: sub,
        panels,
        columns: 1,
        panel_size: (960, 320),
    })
}

/// Draw the run plots after `mbdc run` and report on the terminal: the files written
/// (unless `quiet`), and any problem as a warning (a plot never fails a run).
pub fn after_run(dir: &Path, quiet: bool) {
    match draw_run_plots(dir, &RunPlotOptions::default()) {
        Ok(d) => {
            if !quiet && !d.files.is_empty() {
                let names: Vec<String> = d
                    .files
                    .iter()
                    .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()))
                    .collect();
                println!("  plots: {}", names.join(", "));
            }
        }
        Err(e) => eprintln!("warning: no plots: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The trajectory and constraint plots of a 100 000-body run searched the header once
    /// per body (1.3 million columns, 13 per body): over ten minutes. With the header indexed
    /// they take well under a second; the bound leaves room for a loaded machine.
    #[test]
    fn plots_of_a_huge_run_are_linear_in_its_columns() {
        const N: usize = 100_000;
        let dir = std::env::temp_dir().join(format!("mbdc-plot-huge-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let suffixes = [
            "x", "y", "z", "qw", "qx", "qy", "qz", "vx", "vy", "vz", "wx", "wy", "wz",
        ];
        let mut bodies = String::from("t");
        let mut joints = String::from("t");
        for b in 0..N {
            for s in suffixes {
                bodies.push_str(&format!(",b{b}.{s}"));
            }
            joints.push_str(&format!(",j{b}.violation,j{b}.velocity_violation"));
        }
        for row in 0..3 {
            bodies.push_str(&format!("\n{row}"));
            joints.push_str(&format!("\n{row}"));
            for b in 0..N {
                // body b moves by b·row in x: the last bodies move most
                bodies.push_str(&format!(",{},0,0,1,0,0,0,0,0,0,0,0,0", b * row));
                joints.push_str(&format!(",{},0", (b % 97) * row));
            }
        }
        bodies.push('\n');
        joints.push('\n');
        let (bp, jp) = (dir.join("bodies.csv"), dir.join("constraints.csv"));
        std::fs::write(&bp, bodies).expect("write");
        std::fs::write(&jp, joints).expect("write");
        let start = std::time::Instant::now();
        let opts = RunPlotOptions::default();
        let (_, fig) = trajectories_figure(&bp, "m", &None, &opts)
            .expect("read")
            .expect("a figure");
        assert!(
            fig.title.contains(&format!("3 of {N} bodies")),
            "{}",
            fig.title
        );
        let names: Vec<&str> = fig.panels[0]
            .series
            .iter()
            .map(|s| s.name.as_str())
            .collect();
        assert_eq!(names, ["b99997", "b99998", "b99999"]);
        let (_, fig) = constraints_figure(&jp, "m", &None, &opts)
            .expect("read")
            .expect("a figure");
        assert_eq!(fig.panels[0].series.len(), DEFAULT_JOINTS);
        let took = start.elapsed();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(took.as_secs_f64() < 20.0, "took {took:?}");
    }
}
