//! The convergence order of a method: the least-squares slope of log(error) against
//! log(h) over the runs in the converging range.
//!
//! A run is left out of the fit, with the reason reported, when
//! 1. it did not finish (diverged or stopped), or its error is not a finite positive number;
//! 2. its step is above the explicit stability limit h·ω_max > 2 (when the scene has a
//!    stability estimate);
//! 3. its error is above the *ceiling* — 10 % of the scene's length scale for positions,
//!    0.1 rad for orientations: such a run is not yet in the asymptotic range;
//! 4. its error is below the *floor* — what the reference can resolve: 8 × the numerical
//!    reference's estimated error, or 10⁻¹⁰ × the scale for an exact reference (round-off);
//! 5. it is one of the finest runs and its error no longer falls: walking from the finest
//!    run towards coarser ones, runs whose local order against the next coarser kept run is
//!    below 0.5 are dropped as *stalled* (a floor the rules above did not know: a
//!    regularization parameter, a tolerance). The threshold is far below any method's
//!    theoretical order so that a genuinely low order is measured, not hidden;
//! 6. it is outside the *asymptotic range*: the longest run of consecutive local orders
//!    (the slopes between neighbouring runs) that all lie within 0.3 of their median — the
//!    finer one when two are as long. Two error terms of different order and sign can
//!    cancel at moderate steps and make the error fall "too fast" or "too slowly" for a
//!    while, and the finest pair can feel the reference's own error; such runs say nothing
//!    about the order.
//!
//! At least two runs must remain. The fit is thus made over the finest runs that agree
//! with each other, which is what a convergence order means; study fine enough steps
//! (more [`levels`](super::StudyOptions::levels)) for three or more of them.
//!
//! A fitted order is [`flagged`] when it differs from the method's theoretical order by
//! more than [`FLAG_TOLERANCE`].

/// A fitted order further than this from the theoretical order is flagged.
pub const FLAG_TOLERANCE: f64 = 0.3;

/// One run as the fit sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Step, s.
    pub h: f64,
    /// The error measure (None if the run has none).
    pub error: Option<f64>,
    /// Whether the run finished.
    pub finished: bool,
}

/// The thresholds of rules 2–4.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rules {
    /// Errors below this are at the floor.
    pub floor: f64,
    /// Errors above this are pre-asymptotic.
    pub ceiling: f64,
    /// The explicit stability limit 2/ω_max, s.
    pub h_limit: Option<f64>,
}

/// Why a run is not in the fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Excluded {
    /// It did not finish.
    NotFinished,
    /// Its error is zero, missing or not finite.
    NoError,
    /// h·ω_max > 2.
    Unstable,
    /// Error above the ceiling.
    PreAsymptotic,
    /// Error below the floor.
    Floor,
    /// The error stopped falling.
    Stalled,
    /// Coarser than the asymptotic range.
    NotAsymptotic,
}

impl Excluded {
    /// A short phrase.
    pub fn text(self) -> &'static str {
        match self {
            Excluded::NotFinished => "did not finish",
            Excluded::NoError => "no positive finite error",
            Excluded::Unstable => "above the stability limit h·ω_max > 2",
            Excluded::PreAsymptotic => "error above the ceiling (not yet converging)",
            Excluded::Floor => "error at the floor",
            Excluded::Stalled => "error stalls",
            Excluded::NotAsymptotic => {
                "outside the asymptotic range (local order differs from the finest runs' by more than 0.3)"
            }
        }
    }
}

/// The result of a fit.
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    /// The fitted order (None: fewer than two runs in range).
    pub order: Option<f64>,
    /// Steps of the runs used, coarsest first.
    pub used: Vec<f64>,
    /// Runs left out and why.
    pub excluded: Vec<(f64, Excluded)>,
    /// Local orders between consecutive finished runs (coarser h, finer h, order).
    pub local: Vec<(f64, f64, f64)>,
    /// The finest step at which the error still fell, when finer runs stalled.
    pub stalls_below: Option<f64>,
}

fn slope(a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.1.ln() - b.1.ln()) / (a.0.ln() - b.0.ln())
}

/// The longest range `a..=b` of local orders (between `kept[i]` and `kept[i + 1]`) that all
/// lie within 0.3 of their median; the finest of equally long ranges.
fn asymptotic_window(kept: &[(f64, f64)]) -> (usize, usize) {
    let local: Vec<f64> = kept.windows(2).map(|w| slope(w[0], w[1])).collect();
    let n = local.len();
    let mut best = (n - 1, n - 1);
    for a in 0..n {
        for b in a..n {
            let mut w = local[a..=b].to_vec();
            w.sort_by(f64::total_cmp);
            let med = if w.len() % 2 == 1 {
                w[w.len() / 2]
            } else {
                0.5 * (w[w.len() / 2 - 1] + w[w.len() / 2])
            };
            let ok = w.iter().all(|p| (p - med).abs() <= 0.3);
            if ok && b - a >= best.1 - best.0 {
                best = (a, b);
            }
        }
    }
    best
}

/// Least-squares slope of ln(e) on ln(h).
pub fn least_squares(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let xs: Vec<f64> = points.iter().map(|p| p.0.ln()).collect();
    let ys: Vec<f64> = points.iter().map(|p| p.1.ln()).collect();
    let mx = xs.iter().sum::<f64>() / n;
    let my = ys.iter().sum::<f64>() / n;
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// Fit the order of one method's runs (any order of points).
pub fn fit(points: &[Point], rules: &Rules) -> Fit {
    let mut pts: Vec<Point> = points.to_vec();
    pts.sort_by(|a, b| b.h.total_cmp(&a.h));
    let mut excluded = Vec::new();
    let mut kept: Vec<(f64, f64)> = Vec::new();
    let finished: Vec<(f64, f64)> = pts
        .iter()
        .filter_map(|p| match p.error {
            Some(e) if p.finished && e.is_finite() && e > 0.0 => Some((p.h, e)),
            _ => None,
        })
        .collect();
    let local = finished
        .windows(2)
        .map(|w| (w[0].0, w[1].0, slope(w[0], w[1])))
        .collect();
    for p in &pts {
        if !p.finished {
            excluded.push((p.h, Excluded::NotFinished));
            continue;
        }
        let e = match p.error {
            Some(e) if e.is_finite() && e > 0.0 => e,
            _ => {
                excluded.push((p.h, Excluded::NoError));
                continue;
            }
        };
        if rules.h_limit.is_some_and(|l| p.h > l) {
            excluded.push((p.h, Excluded::Unstable));
        } else if e > rules.ceiling {
            excluded.push((p.h, Excluded::PreAsymptotic));
        } else if e < rules.floor {
            excluded.push((p.h, Excluded::Floor));
        } else {
            kept.push((p.h, e));
        }
    }
    let mut stalls_below = None;
    while kept.len() >= 2 {
        let n = kept.len();
        if slope(kept[n - 2], kept[n - 1]) < 0.5 {
            excluded.push((kept[n - 1].0, Excluded::Stalled));
            kept.pop();
            stalls_below = Some(kept[n - 2].0);
        } else {
            break;
        }
    }
    if kept.len() >= 3 {
        let (a, b) = asymptotic_window(&kept);
        for (i, p) in kept.iter().enumerate() {
            if i < a || i > b + 1 {
                excluded.push((p.0, Excluded::NotAsymptotic));
            }
        }
        kept = kept[a..=b + 1].to_vec();
    }
    excluded.sort_by(|a, b| b.0.total_cmp(&a.0));
    Fit {
        order: least_squares(&kept),
        used: kept.iter().map(|p| p.0).collect(),
        excluded,
        local,
        stalls_below,
    }
}

/// Whether a fitted order differs from the theoretical order `theory` by more than
/// [`FLAG_TOLERANCE`] (never without both).
pub fn flagged(f: &Fit, theory: Option<f64>) -> bool {
    matches!((f.order, theory), (Some(p), Some(t)) if (p - t).abs() > FLAG_TOLERANCE)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(hs: &[f64], f: impl Fn(f64) -> f64) -> Vec<Point> {
        hs.iter()
            .map(|&h| Point {
                h,
                error: Some(f(h)),
                finished: true,
            })
            .collect()
    }

    const RULES: Rules = Rules {
        floor: 1e-10,
        ceiling: 0.1,
        h_limit: None,
    };

    #[test]
    fn exact_power_laws() {
        let hs = [0.08, 0.04, 0.02, 0.01];
        let f = fit(&pts(&hs, |h| 3.0 * h * h), &RULES);
        assert!((f.order.expect("order") - 2.0).abs() < 1e-12);
        assert_eq!(f.used.len(), 4);
        assert!(f.local.iter().all(|l| (l.2 - 2.0).abs() < 1e-12));
        let f = fit(&pts(&hs, |h| 0.5 * h), &RULES);
        assert!(
            (f.order.expect("order") - 1.0).abs() < 1e-12,
            "a low order is measured"
        );
    }

    #[test]
    fn cancellation_before_the_asymptotic_range_is_left_out() {
        // e = h² (1 ± 40 h): the h³ term adds to (cancels part of) the h² one at coarse
        // steps, so the error falls faster (slower) than h² there: local orders
        // 2.36, 2.22, 2.13, … (0.42, 1.58, 1.83, …), tending to 2
        let hs: Vec<f64> = (0..9).map(|k| 0.02 / 2f64.powi(k)).collect();
        for sign in [1.0, -1.0] {
            let f = fit(&pts(&hs, |h| h * h * (1.0 + sign * 40.0 * h)), &RULES);
            let p = f.order.expect("order");
            assert!((p - 2.0).abs() < 0.1, "{sign}: {p} {f:?}");
            assert!(
                f.excluded.iter().any(|e| e.1 == Excluded::NotAsymptotic),
                "{f:?}"
            );
            assert!(f.used.len() >= 5, "{f:?}");
        }
        // the finest pair feels a floor (local order 1.6): the range before it counts
        let f = fit(&pts(&hs, |h| h * h + 3e-9), &RULES);
        assert!((f.order.expect("order") - 2.0).abs() < 0.05, "{f:?}");
        assert!(f.used.len() >= 7, "{f:?}");
    }

    #[test]
    fn floors_ceilings_and_stalls_are_left_out() {
        let hs = [0.4, 0.2, 0.1, 0.05, 0.025, 0.0125, 0.00625];
        // h = 0.4 above the ceiling; the finest two stall at 6.25e-4
        let e = |h: f64| (h * h).max(6.25e-4) + if h > 0.3 { 1.0 } else { 0.0 };
        let f = fit(&pts(&hs, e), &RULES);
        assert_eq!(f.excluded[0], (0.4, Excluded::PreAsymptotic));
        assert_eq!(
            f.excluded
                .iter()
                .filter(|e| e.1 == Excluded::Stalled)
                .count(),
            2,
            "{f:?}"
        );
        assert!((f.order.expect("order") - 2.0).abs() < 1e-9, "{f:?}");
        assert_eq!(f.stalls_below, Some(0.025));
        let rules = Rules {
            floor: 1e-3,
            ..RULES
        };
        let f = fit(&pts(&hs, |h| h * h), &rules);
        assert!(f.excluded.iter().any(|e| e.1 == Excluded::Floor));
        let mut p = pts(&hs, |h| h * h);
        p[1].finished = false;
        let f = fit(
            &p,
            &Rules {
                h_limit: Some(0.3),
                ..RULES
            },
        );
        assert!(f.excluded.contains(&(0.4, Excluded::Unstable)));
        assert!(f.excluded.contains(&(0.2, Excluded::NotFinished)));
        p[2].error = Some(0.0);
        let f = fit(&p, &RULES);
        assert!(f.excluded.contains(&(0.1, Excluded::NoError)));
        assert!(fit(&p[..1], &RULES).order.is_none());
    }

    #[test]
    fn flags() {
        let f = |p: Option<f64>| Fit {
            order: p,
            used: vec![],
            excluded: vec![(0.1, Excluded::Floor)],
            local: vec![],
            stalls_below: None,
        };
        assert!(!flagged(&f(Some(2.25)), Some(2.0)));
        assert!(flagged(&f(Some(1.6)), Some(2.0)));
        assert!(!flagged(&f(None), Some(2.0)));
        assert!(!flagged(&f(Some(1.0)), None));
    }
}
