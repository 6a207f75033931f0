//! What an error costs: along each method's work–precision line, the CPU time at which it
//! reaches a target error, and the methods ranked by it.

use super::result::{StudyResult, StudyRun};

/// What reaching an error costs a method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cost {
    /// Interpolated (log–log) between the two runs whose errors bracket the target, s.
    Interpolated(f64),
    /// Already reached at the coarsest finished run, which cost this much, s.
    AtMost(f64),
}

impl Cost {
    /// The CPU time, s.
    pub fn seconds(self) -> f64 {
        match self {
            Cost::Interpolated(c) | Cost::AtMost(c) => c,
        }
    }
}

impl StudyResult {
    /// The cheapest finished run whose error (the fitted measure) is at most `target`.
    pub fn cheapest(&self, target: f64) -> Option<&StudyRun> {
        self.runs
            .iter()
            .filter(|run| {
                run.outcome.status.is_ok()
                    && run
                        .errors
                        .as_ref()
                        .and_then(|e| self.measure.of(e))
                        .is_some_and(|e| e <= target)
            })
            .min_by(|a, b| a.outcome.cpu_time.total_cmp(&b.outcome.cpu_time))
    }

    /// The CPU time method `mi` needs for an error (the fitted measure) of `target`: along
    /// its work–precision line, between the finished runs that bracket the target (None if
    /// no finished run reaches it).
    pub fn cost_at(&self, mi: usize, target: f64) -> Option<Cost> {
        let mut pts: Vec<(f64, f64, f64)> = self
            .runs
            .iter()
            .filter(|x| x.method == mi && x.outcome.status.is_ok())
            .filter_map(|x| {
                let e = self.measure.of(x.errors.as_ref()?)?;
                (e.is_finite() && x.outcome.cpu_time > 0.0).then_some((
                    x.step,
                    e,
                    x.outcome.cpu_time,
                ))
            })
            .collect();
        pts.sort_by(|a, b| b.0.total_cmp(&a.0));
        let first = pts.iter().position(|p| p.1 <= target)?;
        if first == 0 {
            return Some(Cost::AtMost(pts[0].2));
        }
        let (a, b) = (pts[first - 1], pts[first]);
        if b.1 <= 0.0 {
            return Some(Cost::Interpolated(b.2));
        }
        let s = (target.ln() - a.1.ln()) / (b.1.ln() - a.1.ln());
        Some(Cost::Interpolated(
            (a.2.ln() + s * (b.2.ln() - a.2.ln())).exp(),
        ))
    }

    /// The methods that reach `target`, cheapest first.
    pub fn ranking(&self, target: f64) -> Vec<(usize, Cost)> {
        let mut v: Vec<(usize, Cost)> = (0..self.methods.len())
            .filter_map(|mi| Some((mi, self.cost_at(mi, target)?)))
            .collect();
        v.sort_by(|a, b| a.1.seconds().total_cmp(&b.1.seconds()));
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::{
        Errors, Measure, MethodEntry, Outcome, ReferenceInfo, Status, StudyRun, Track,
    };

    /// One method's runs: (step, error, CPU time); no error: a diverged run.
    fn result(points: &[(f64, Option<f64>, f64)]) -> StudyResult {
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
                spec: crate::contract::scene::MethodSpec::default_for("staggered").expect("known"),
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

    #[test]
    fn cost_is_interpolated_along_the_line() {
        // error 1e-2, 1e-4 at cpu 1, 100: error 1e-3 costs 10 (log-log midpoint)
        let r = result(&[
            (0.1, None, 0.5),
            (0.01, Some(1e-2), 1.0),
            (0.001, Some(1e-4), 100.0),
        ]);
        match r.cost_at(0, 1e-3) {
            Some(Cost::Interpolated(c)) => assert!((c - 10.0).abs() < 1e-9, "{c}"),
            other => panic!("{other:?}"),
        }
        assert_eq!(r.cost_at(0, 1e-1), Some(Cost::AtMost(1.0)));
        assert_eq!(r.cost_at(0, 1e-6), None);
        assert_eq!(r.ranking(1e-3).len(), 1);
        assert_eq!(r.cheapest(1e-3).map(|x| x.step), Some(0.001));
    }
}
