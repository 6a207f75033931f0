//! The outputs of a sweep: `sweep.csv`, `sweep.json`, `sweep.svg`, and the terminal
//! report (markdown table, fitted orders, reference, "reading this").

use std::fmt::Write as _;
use std::path::Path;

use serde_json::json;

use crate::plot::figure::{
    color, short_sci, Axis, Figure, LegendPos, Panel, Series, SeriesKind, TopMarks,
};
use mbdc_runtime::study::fit::flagged;
use mbdc_runtime::study::{
    Cost, Excluded, Fit, Measure, ReferenceInfo, Status, StudyResult, StudyRun,
};

/// Columns of `sweep.csv`, in order.
pub const CSV_COLUMNS: [&str; 15] = [
    "method",
    "step_s",
    "status",
    "cpu_time_s",
    "repetitions",
    "pos_err_final_m",
    "pos_err_max_m",
    "rot_err_final_rad",
    "rot_err_max_rad",
    "max_violation",
    "energy_drift",
    "iterations_mean",
    "steps",
    "t_reached_s",
    "options",
];

/// The errors targets of the "cheapest method" lines.
const TARGETS: [f64; 2] = [1e-3, 1e-6];

fn csv_field(out: &mut String, s: &str) {
    if s.contains([',', '"', '\n', '\r']) {
        out.push('"');
        out.push_str(&s.replace('"', "\"\""));
        out.push('"');
    } else {
        out.push_str(s);
    }
}

fn num(x: Option<f64>) -> String {
    match x {
        Some(v) => format!("{v:e}"),
        None => String::new(),
    }
}

/// `sweep.csv`: one row per run; empty fields where a value does not exist (no reference
/// for that quantity, a run that did not finish, a method that does not iterate).
pub fn csv(r: &StudyResult) -> String {
    let mut s = CSV_COLUMNS.join(",");
    s.push('\n');
    for run in &r.runs {
        let m = &r.methods[run.method];
        let e = run.errors.unwrap_or_default();
        let o = &run.outcome;
        let fields = [
            m.name.to_string(),
            format!("{:e}", run.step),
            o.status.text(),
            format!("{:e}", o.cpu_time),
            run.repetitions.to_string(),
            num(e.pos_final),
            num(e.pos_max),
            num(e.rot_final),
            num(e.rot_max),
            format!("{:e}", o.max_violation),
            format!("{:e}", o.energy_drift),
            num(o.iterations),
            o.steps.to_string(),
            format!("{:e}", o.t_end),
            m.options.clone(),
        ];
        for (i, f) in fields.iter().enumerate() {
            if i > 0 {
                s.push(',');
            }
            csv_field(&mut s, f);
        }
        s.push('\n');
    }
    s
}

fn fit_json(f: &Fit, theory: Option<f64>) -> serde_json::Value {
    json!({
        "order": f.order,
        "theory": theory,
        "flagged": flagged(f, theory),
        "steps_used": f.used,
        "excluded": f.excluded.iter().map(|(h, why)| json!({"step_s": h, "why": why.text()})).collect::<Vec<_>>(),
        "local_orders": f.local.iter().map(|(a, b, p)| json!({"from_s": a, "to_s": b, "order": p})).collect::<Vec<_>>(),
        "stalls_below_s": f.stalls_below,
    })
}

/// `sweep.json`: the settings, the reference, the fits and the runs.
pub fn json(r: &StudyResult) -> serde_json::Value {
    let reference = match &r.reference {
        ReferenceInfo::Analytic => json!({"kind": "analytic"}),
        ReferenceInfo::Table(p) => json!({"kind": "table", "path": p.display().to_string()}),
        ReferenceInfo::Numerical {
            method,
            step,
            estimate,
            chosen,
        } => json!({
            "kind": "numerical",
            "method": method,
            "step_s": step,
            "chosen": chosen,
            "estimated_error": {
                "pos_err_final_m": estimate.pos_final,
                "pos_err_max_m": estimate.pos_max,
                "rot_err_final_rad": estimate.rot_final,
                "rot_err_max_rad": estimate.rot_max,
            }
        }),
        ReferenceInfo::Unavailable(why) => json!({"kind": "none", "why": why}),
    };
    let methods: Vec<_> = r
        .methods
        .iter()
        .zip(&r.fits)
        .map(|(m, (p, s))| {
            json!({
                "name": m.name,
                "options": m.options,
                "theory_order": m.theory,
                "fit": fit_json(p, m.theory),
                "fit_secondary": s.as_ref().map(|s| fit_json(s, m.theory)),
            })
        })
        .collect();
    let runs: Vec<_> = r
        .runs
        .iter()
        .map(|run| {
            let e = run.errors.unwrap_or_default();
            let o = &run.outcome;
            json!({
                "method": r.methods[run.method].name,
                "step_s": run.step,
                "status": o.status.word(),
                "status_text": o.status.text(),
                "cpu_time_s": o.cpu_time,
                "repetitions": run.repetitions,
                "pos_err_final_m": e.pos_final,
                "pos_err_max_m": e.pos_max,
                "rot_err_final_rad": e.rot_final,
                "rot_err_max_rad": e.rot_max,
                "max_violation": o.max_violation,
                "energy_drift": o.energy_drift,
                "iterations_mean": o.iterations,
                "steps": o.steps,
                "t_reached_s": o.t_end,
                "frames_compared": o.track.frames(),
                "output_every": run.every,
            })
        })
        .collect();
    json!({
        "model": r.model,
        "duration_s": r.duration,
        "runner": r.runner,
        "stability": r.estimate.as_ref().map(|e| json!({
            "omega_max_rad_s": e.omega_max, "source": e.source,
            "h_limit_s": e.h_limit(), "h_20_per_period_s": e.h_max()})),
        "steps_note": r.steps_note,
        "measure": r.measure.short(),
        "secondary_measure": r.secondary.map(Measure::short),
        "length_scale_m": r.length_scale,
        "energy_sources": r.energy_sources,
        "reference": reference,
        "methods": methods,
        "cost_at": TARGETS.iter().map(|t| json!({
            "error": t,
            "methods": r.ranking(*t).iter().map(|(mi, c)| json!({
                "name": r.methods[*mi].name,
                "cpu_time_s": c.seconds(),
                "interpolated": matches!(c, Cost::Interpolated(_)),
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "skipped_methods": r.skipped.iter().map(|(n, w)| json!({"name": n, "why": w})).collect::<Vec<_>>(),
        "interrupted": r.interrupted,
        "runs": runs,
    })
}

fn sci(x: Option<f64>) -> String {
    match x {
        Some(v) if v.is_finite() => format!("{v:.2e}"),
        Some(v) => format!("{v}"),
        None => "—".into(),
    }
}

/// The markdown table of the runs.
pub fn markdown(r: &StudyResult) -> String {
    let mut s = String::new();
    s.push_str("| method | h (s) | status | CPU (s) | reps | pos err final (m) | pos err max (m) | rot err final (rad) | rot err max (rad) | max violation | energy drift | iterations |\n");
    s.push_str("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for run in &r.runs {
        let e = run.errors.unwrap_or_default();
        let o = &run.outcome;
        let status = match &o.status {
            Status::Ok => "ok".to_string(),
            st => format!("{} (t = {:.3} s)", st.word(), st.time().unwrap_or(o.t_end)),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2e} | {} | {} | {} | {} | {} | {:.2e} | {} | {} |",
            r.methods[run.method].name,
            short_sci(run.step),
            status,
            o.cpu_time,
            run.repetitions,
            sci(e.pos_final),
            sci(e.pos_max),
            sci(e.rot_final),
            sci(e.rot_max),
            o.max_violation,
            sci(Some(o.energy_drift)),
            o.iterations.map_or("—".into(), |i| format!("{i:.2}")),
        );
    }
    s
}

fn order_text(f: &Fit) -> String {
    match f.order {
        Some(p) => format!("{p:.2}"),
        None => "n/a".into(),
    }
}

fn fit_line(name: &str, f: &Fit, theory: Option<f64>) -> String {
    let mut s = format!("  {name:<24} {:>5}", order_text(f));
    match (f.used.first(), f.used.last()) {
        (Some(a), Some(b)) if f.used.len() >= 2 => {
            let _ = write!(
                s,
                "  ({} runs, h = {} … {} s)",
                f.used.len(),
                short_sci(*b),
                short_sci(*a)
            );
        }
        _ => s.push_str("  (fewer than two runs in the converging range)"),
    }
    if let Some(t) = theory {
        let _ = write!(s, "  theory {t}");
    }
    if flagged(f, theory) {
        s.push_str("  ⚠ differs from theory by more than 0.3");
    }
    if let Some(h) = f.stalls_below {
        let _ = write!(s, "; stops converging below h = {} s", short_sci(h));
    }
    let out: Vec<String> = f
        .excluded
        .iter()
        .map(|(h, w)| format!("{}: {}", short_sci(*h), w.text()))
        .collect();
    if !out.is_empty() {
        let _ = write!(s, "\n  {:<24} left out: {}", "", out.join("; "));
    }
    s
}

fn reference_text(r: &StudyResult) -> String {
    match &r.reference {
        ReferenceInfo::Analytic => "the scene's analytic reference (exact at every frame time)".into(),
        ReferenceInfo::Table(p) => format!("the scene's reference table {} (interpolated in time)", p.display()),
        ReferenceInfo::Numerical {
            method,
            step,
            estimate,
            chosen,
        } => format!(
            "a numerical run of {method} at h = {} s ({chosen}); its own error, estimated by Richardson extrapolation from a run at 2h: position {} m final / {} m max, orientation {} rad final / {} rad max",
            short_sci(*step),
            sci(estimate.pos_final),
            sci(estimate.pos_max),
            sci(estimate.rot_final),
            sci(estimate.rot_max),
        ),
        ReferenceInfo::Unavailable(why) => format!("none ({why}); no errors are reported"),
    }
}

/// The "reading this" text.
pub fn reading(r: &StudyResult) -> String {
    let mut s = String::new();
    let unit = r.measure.unit();
    s.push_str("Reading this:\n");
    let _ = writeln!(
        s,
        "- sweep.svg, left: work–precision. Each line is a method, each point a step size (labelled). Lower is more accurate, further left is cheaper: at a given error, the leftmost line is the cheapest method there."
    );
    let _ = writeln!(
        s,
        "- sweep.svg, right: error against step. The slope is the convergence order (fitted, in the legend; the dashed line has slope 2). Where a line flattens, the method has stopped converging: it has reached the reference's own error, round-off, or a floor of its own (a regularization, a tolerance). Crosses along the top are runs that diverged or stopped."
    );
    for target in TARGETS {
        let rank = r.ranking(target);
        if rank.is_empty() {
            let _ = writeln!(
                s,
                "- No run reached error ≤ {target:e} {unit}; sweep finer steps (--levels, --steps) to see what it costs."
            );
            continue;
        }
        let list: Vec<String> = rank
            .iter()
            .map(|(mi, c)| match c {
                Cost::Interpolated(t) => format!("{} {t:.2e} s", r.methods[*mi].name),
                Cost::AtMost(t) => {
                    format!("{} ≤ {t:.2e} s (at its coarsest step)", r.methods[*mi].name)
                }
            })
            .collect();
        let _ = writeln!(
            s,
            "- CPU time for error {target:e} {unit} (interpolated between the runs that bracket it), cheapest first: {}.",
            list.join(", ")
        );
        if let Some(run) = r.cheapest(target) {
            let _ = writeln!(
                s,
                "  Cheapest measured run at or below it: {} at h = {} s, {:.2e} s.",
                r.methods[run.method].name,
                short_sci(run.step),
                run.outcome.cpu_time
            );
        }
    }
    let failed: Vec<String> = r
        .runs
        .iter()
        .filter(|run| !run.outcome.status.is_ok())
        .map(|run| {
            format!(
                "{} at h = {} s ({})",
                r.methods[run.method].name,
                short_sci(run.step),
                run.outcome.status.word()
            )
        })
        .collect();
    if !failed.is_empty() {
        let _ = writeln!(
            s,
            "- Runs that did not finish: {} (sweep.csv has where and why).",
            failed.join(", ")
        );
    }
    for (m, (f, _)) in r.methods.iter().zip(&r.fits) {
        if flagged(f, m.theory) {
            let _ = writeln!(
                s,
                "- {}: the measured order {} is not the theoretical {} — look at the local orders in sweep.json and at the right panel: a floor inside the fitted range, a reference not accurate enough, or a real loss of order.{}",
                m.name,
                order_text(f),
                m.theory.unwrap_or(f64::NAN),
                finer_hint(f)
            );
        }
    }
    s
}

/// When finer runs than the fitted ones were left out as outside the asymptotic range (a
/// longer stretch of coarser runs agreed with itself), their local order: the fitted
/// stretch may be a pre-asymptotic one, and only finer steps tell which persists.
fn finer_hint(f: &Fit) -> String {
    let Some(h_fit) = f.used.iter().copied().reduce(f64::min) else {
        return String::new();
    };
    let finer_left_out = f
        .excluded
        .iter()
        .any(|(h, why)| *why == Excluded::NotAsymptotic && *h < h_fit);
    match f.local.iter().min_by(|a, b| a.1.total_cmp(&b.1)) {
        Some(&(_, h_fine, p)) if finer_left_out && h_fine < h_fit => format!(
            " Its finest runs (down to h = {} s), left out of the fit, have local order {p:.2}: the fitted range may be pre-asymptotic; sweep finer steps (--levels) to see which order persists.",
            short_sci(h_fine)
        ),
        _ => String::new(),
    }
}

/// The figure: work–precision and error vs step.
pub fn figure(r: &StudyResult) -> Figure {
    let ylabel = r.measure.label();
    let mut wp = Vec::new();
    let mut es = Vec::new();
    let mut wp_marks = Vec::new();
    let mut es_marks = Vec::new();
    for (mi, m) in r.methods.iter().enumerate() {
        let c = color(mi);
        let mut mine: Vec<&StudyRun> = r.runs.iter().filter(|x| x.method == mi).collect();
        mine.sort_by(|a, b| b.step.total_cmp(&a.step));
        let ok: Vec<(&StudyRun, f64)> = mine
            .iter()
            .filter(|x| x.outcome.status.is_ok())
            .filter_map(|x| Some((*x, x.errors.as_ref().and_then(|e| r.measure.of(e))?)))
            .collect();
        for x in mine.iter().filter(|x| !x.outcome.status.is_ok()) {
            wp_marks.push((x.outcome.cpu_time, c));
            es_marks.push((x.step, c));
        }
        // label every point of short lines; every other one (and the last) of long ones
        let thin = ok.len() > 5;
        let labels: Vec<String> = ok
            .iter()
            .enumerate()
            .map(|(i, (x, _))| {
                if !thin || i % 2 == 0 || i + 1 == ok.len() {
                    short_sci(x.step)
                } else {
                    String::new()
                }
            })
            .collect();
        let none = if ok.is_empty() {
            " (no run with an error)"
        } else {
            ""
        };
        wp.push(Series {
            name: format!("{}{none}", m.name),
            tag: m.name.to_string(),
            color: c,
            kind: SeriesKind::LinePoints,
            points: ok.iter().map(|(x, e)| (x.outcome.cpu_time, *e)).collect(),
            labels,
        });
        let f = &r.fits[mi].0;
        let mut name = if ok.is_empty() {
            format!("{}{none}", m.name)
        } else {
            format!("{} — order {}", m.name, order_text(f))
        };
        if flagged(f, m.theory) {
            name.push_str(" ⚠");
        }
        es.push(Series {
            name,
            tag: m.name.to_string(),
            color: c,
            kind: SeriesKind::LinePoints,
            points: ok.iter().map(|(x, e)| (x.step, *e)).collect(),
            labels: Vec::new(),
        });
    }
    // slope-2 guide below the data, across the swept steps
    let pts: Vec<(f64, f64)> = es
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|p| p.1 > 0.0 && p.1.is_finite())
        .collect();
    if let (Some(hmin), Some(hmax)) = (
        pts.iter().map(|p| p.0).reduce(f64::min),
        pts.iter().map(|p| p.0).reduce(f64::max),
    ) {
        if hmax > hmin {
            let at_min = pts
                .iter()
                .filter(|p| p.0 <= hmin * (1.0 + 1e-9))
                .map(|p| p.1)
                .fold(f64::INFINITY, f64::min);
            let e0 = at_min / 3.0;
            es.push(Series {
                name: "slope 2 (guide)".into(),
                tag: String::new(),
                color: plotters::style::RGBColor(120, 120, 120),
                kind: SeriesKind::Dashed,
                points: vec![(hmin, e0), (hmax, e0 * (hmax / hmin).powi(2))],
                labels: Vec::new(),
            });
        }
    }
    // the numerical reference's own error
    if let ReferenceInfo::Numerical { estimate, .. } = &r.reference {
        if let Some(e) = r.measure.of(estimate).filter(|e| *e > 0.0) {
            for (panel, xs) in [
                (
                    &mut wp,
                    r.runs
                        .iter()
                        .map(|x| x.outcome.cpu_time)
                        .collect::<Vec<_>>(),
                ),
                (&mut es, r.runs.iter().map(|x| x.step).collect::<Vec<_>>()),
            ] {
                let lo = xs
                    .iter()
                    .copied()
                    .filter(|x| *x > 0.0)
                    .fold(f64::INFINITY, f64::min);
                let hi = xs.iter().copied().fold(0.0, f64::max);
                if lo.is_finite() && hi > 0.0 {
                    panel.push(Series {
                        name: "reference's estimated error".into(),
                        tag: String::new(),
                        color: plotters::style::RGBColor(90, 90, 90),
                        kind: SeriesKind::Dashed,
                        points: vec![(lo, e), (hi, e)],
                        labels: Vec::new(),
                    });
                }
            }
        }
    }
    dodge(&mut es_marks);
    dodge(&mut wp_marks);
    let marks_label = "diverged or stopped".to_string();
    Figure {
        title: format!("{}: what accuracy costs", r.model),
        subtitle: Some(format!(
            "t = 0 … {} s; reference: {}; {}",
            crate::plot::figure::number_label(r.duration),
            match &r.reference {
                ReferenceInfo::Analytic => "analytic".to_string(),
                ReferenceInfo::Table(_) => "table".to_string(),
                ReferenceInfo::Numerical { method, step, .. } =>
                    format!("{method} at h = {} s", short_sci(*step)),
                ReferenceInfo::Unavailable(_) => "none".to_string(),
            },
            if r.runner.starts_with("interpreter") {
                "interpreter"
            } else {
                "compiled"
            }
        )),
        panels: vec![
            Panel {
                title: "Work–precision (points labelled by step h in s)".into(),
                x: Axis::log("CPU time per run (s)"),
                y: Axis::log(ylabel),
                series: wp,
                top: TopMarks {
                    label: marks_label.clone(),
                    marks: wp_marks,
                },
                note: None,
                legend: LegendPos::LowerLeft,
            },
            Panel {
                title: "Error vs step, with the fitted order".into(),
                x: Axis::log("step h (s)"),
                y: Axis::log(ylabel),
                series: es,
                top: TopMarks {
                    label: marks_label,
                    marks: es_marks,
                },
                note: None,
                legend: LegendPos::LowerRight,
            },
        ],
        columns: 2,
        panel_size: (720, 560),
    }
}

/// Spread marks that fall on the same x (failed runs of several methods at one step) by a
/// few per cent on the log axis, so that each method's cross stays visible instead of
/// being drawn over by the next one's. Marks alone at their x are not moved.
fn dodge(marks: &mut [(f64, plotters::style::RGBColor)]) {
    const SPREAD: f64 = 1.07;
    let same = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
    let xs: Vec<f64> = marks.iter().map(|m| m.0).collect();
    let mut seen = vec![false; marks.len()];
    for i in 0..marks.len() {
        if seen[i] {
            continue;
        }
        let group: Vec<usize> = (i..marks.len()).filter(|&j| same(xs[i], xs[j])).collect();
        let n = group.len();
        for (k, &j) in group.iter().enumerate() {
            seen[j] = true;
            let offset = k as f64 - (n as f64 - 1.0) / 2.0;
            marks[j].0 = xs[j] * SPREAD.powf(offset);
        }
    }
}

/// Write the files and print the report.
///
/// # Errors
/// If the folder or a file cannot be written.
pub fn write_all(r: &StudyResult, dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| format!("writing {}: {e}", p.display()))
    };
    write("sweep.csv", &csv(r))?;
    let j = serde_json::to_string_pretty(&json(r)).map_err(|e| e.to_string())?;
    write("sweep.json", &(j + "\n"))?;
    figure(r)
        .save(&dir.join("sweep.svg"))
        .map_err(|e| e.to_string())?;

    println!(
        "# {} — sweep over t = 0 … {} s ({})\n",
        r.model, r.duration, r.runner
    );
    println!("Steps: {}.", r.steps_note);
    if let Some(by) = &r.interrupted {
        println!(
            "Interrupted by {by}: the {} run(s) done before it (the run in progress is left out).",
            r.runs.len()
        );
    }
    if let Some(e) = &r.estimate {
        println!(
            "Stability: ω_max ≈ {:.4} rad/s ({}): explicit limit h ≤ 2/ω_max = {} s.",
            e.omega_max,
            e.source,
            short_sci(e.h_limit())
        );
    }
    for m in &r.methods {
        if !m.options.is_empty() {
            println!("Method {}: {}.", m.name, m.options);
        }
    }
    for (n, w) in &r.skipped {
        println!("Not swept: {n} ({w}).");
    }
    println!("Reference: {}.", reference_text(r));
    println!(
        "Errors: RMS over bodies of |r − r_ref| (m) and of the rotation angle of q_ref⁻¹q (rad), at the final time and the maximum over the frames. CPU time: best of the repetitions. Max violation: largest |Φ| over the compared frames."
    );
    println!("Energy drift: the energy balance's largest error |K + V − W − E₀| / E_ref over every step (W: the work of applied forces, dampers, contact damping and drivers; E_ref: the energy in play).\n");
    print!("{}", markdown(r));
    println!(
        "\nConvergence order (least-squares slope of log error on log h, {}):",
        r.measure.short()
    );
    for (m, (f, _)) in r.methods.iter().zip(&r.fits) {
        println!("{}", fit_line(m.name, f, m.theory));
    }
    if let Some(sec) = r.secondary {
        println!("Convergence order of {}:", sec.short());
        for (m, (_, f)) in r.methods.iter().zip(&r.fits) {
            if let Some(f) = f {
                println!("{}", fit_line(m.name, f, m.theory));
            }
        }
    }
    println!();
    print!("{}", reading(r));
    println!(
        "\nWrote {}, {} and {}.",
        dir.join("sweep.csv").display(),
        dir.join("sweep.json").display(),
        dir.join("sweep.svg").display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use mbdc_runtime::study::fit;

    #[test]
    fn csv_quoting() {
        let mut s = String::new();
        csv_field(&mut s, "a, \"b\"");
        assert_eq!(s, "\"a, \"\"b\"\"\"");
        let mut s = String::new();
        csv_field(&mut s, "plain");
        assert_eq!(s, "plain");
    }

    fn result(points: &[(f64, Option<f64>, f64)]) -> StudyResult {
        use mbdc_runtime::study::{Errors, MethodEntry, Outcome, Track};
        let runs = points
            .iter()
            .map(|&(h, e, cpu)| StudyRun {
                method: 0,
                step: h,
                every: 1,
                outcome: Outcome {
                    status: if e.is_some() {
                        Status::Ok
                    } else {
                        Status::Diverged {
                            t: 0.1,
                            what: "x".into(),
                        }
                    },
                    cpu_time: cpu,
                    steps: 1,
                    t_end: 1.0,
                    track: Track::new(1),
                    max_violation: 0.0,
                    energy_drift: 0.0,
                    iterations: None,
                },
                repetitions: 1,
                errors: e.map(|e| Errors {
                    pos_max: Some(e),
                    ..Errors::default()
                }),
            })
            .collect();
        StudyResult {
            model: "m".into(),
            duration: 1.0,
            runner: "interpreter".into(),
            estimate: None,
            steps_note: String::new(),
            methods: vec![MethodEntry {
                name: "staggered",
                spec: mbdc_runtime::scene::MethodSpec::default_for("staggered").expect("known"),
                options: String::new(),
                theory: Some(2.0),
            }],
            skipped: vec![],
            runs,
            reference: ReferenceInfo::Analytic,
            measure: Measure::PosMax,
            secondary: None,
            length_scale: 1.0,
            energy_sources: false,
            fits: vec![],
            interrupted: None,
        }
    }

    /// The interpolated cost itself is tested with the engine (`mbdc_runtime::study::cost`);
    /// here, what the reading says of it.
    #[test]
    fn reading_names_the_interpolated_cost_and_the_failures() {
        // error 1e-2, 1e-4 at cpu 1, 100: error 1e-3 costs 10 (log-log midpoint)
        let r = result(&[
            (0.1, None, 0.5),
            (0.01, Some(1e-2), 1.0),
            (0.001, Some(1e-4), 100.0),
        ]);
        let text = reading(&r);
        assert!(text.contains("staggered 1.00e1 s"), "{text}");
        assert!(text.contains("No run reached error ≤ 1e-6 m"), "{text}");
        assert!(
            text.contains("staggered at h = 1e-1 s (diverged)"),
            "{text}"
        );
    }

    #[test]
    fn failed_runs_at_one_step_stay_visible() {
        use plotters::style::RGBColor;
        let (a, b, c) = (RGBColor(1, 0, 0), RGBColor(0, 1, 0), RGBColor(0, 0, 1));
        let mut m = vec![(0.1, a), (0.05, a), (0.1, b), (0.1, c)];
        dodge(&mut m);
        assert_eq!(m[1].0, 0.05, "a mark alone is not moved");
        let xs = [m[0].0, m[2].0, m[3].0];
        assert!(xs[0] < xs[1] && xs[1] < xs[2], "{xs:?}");
        assert!((xs[1] - 0.1).abs() < 1e-15, "centred on the step: {xs:?}");
        assert!(xs[2] / xs[0] < 1.2, "{xs:?}");
    }

    #[test]
    fn a_pre_asymptotic_fit_points_at_the_finer_runs() {
        // local orders 3.3, 3.2 over the coarse runs, 1.85 over the finest pair (the 3-D
        // double pendulum's implicit_trapezoid at five levels): the longer coarse stretch is
        // fitted and flagged, and the reading names the finest runs' order
        let mut r = result(&[
            (0.08, Some(0.2), 1.0),
            (0.04, Some(0.2 / 2f64.powf(3.3)), 2.0),
            (0.02, Some(0.2 / 2f64.powf(6.5)), 4.0),
            (0.01, Some(0.2 / 2f64.powf(8.35)), 8.0),
        ]);
        let pts: Vec<fit::Point> = r
            .runs
            .iter()
            .map(|x| fit::Point {
                h: x.step,
                error: x.errors.as_ref().and_then(|e| e.pos_max),
                finished: true,
            })
            .collect();
        let rules = fit::Rules {
            floor: 1e-12,
            ceiling: 1.0,
            h_limit: None,
        };
        let f = fit::fit(&pts, &rules);
        assert!(f.order.is_some_and(|p| p > 3.0), "{f:?}");
        r.fits = vec![(f, None)];
        let text = reading(&r);
        assert!(text.contains("the measured order 3.2"), "{text}");
        assert!(
            text.contains(
                "Its finest runs (down to h = 1e-2 s), left out of the fit, have local order 1.85"
            ),
            "{text}"
        );
        // a fit over the finest runs gets no such hint
        let mut g = r.fits[0].0.clone();
        g.excluded.clear();
        assert_eq!(finer_hint(&g), "");
    }
}
