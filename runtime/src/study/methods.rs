//! Which methods a study runs, with which options, and the order each should converge at.
//!
//! Asked-for methods are taken as they are; without a request, every method that can
//! start on the scene (the others are listed with the reason). A method gets the scene's
//! options when it is the scene's method, its defaults otherwise.

use crate::contract::scene::{Factorization, LintForm, MethodSpec, Scene};
use crate::integrators::{self, StartError, State};
use crate::interp::Interp;

use super::error::StudyError;
use super::interp_runner::guarded;

/// A method being studied.
#[derive(Clone, Debug, PartialEq)]
pub struct MethodEntry {
    /// Its name.
    pub name: &'static str,
    /// The method with the options used.
    pub spec: MethodSpec,
    /// The options in words (`ε = 1e-6 (the scene's)`).
    pub options: String,
    /// The theoretical order of convergence.
    pub theory: Option<f64>,
}

/// The theoretical order of a method (notes A §1): the constraint-stabilized methods are
/// second order (penalty's constraint error is O(h²) with its default ε = h²·max diag K);
/// `rk4` fourth; `dopri5` and `dop853` none in h (their error follows their tolerance).
pub fn theoretical_order(name: &str) -> Option<f64> {
    match name {
        "staggered"
        | "baumgarte"
        | "penalty"
        | "coordinate_partitioning"
        | "implicit_trapezoid"
        | "natural_partitioning" => Some(2.0),
        // at a fixed step; dopri5 and dop853 run to their tolerance, the step is only their
        // largest internal step
        "rk4" => Some(4.0),
        // quadratic time elements by Galerkin (notes F §1.10): the angle unknowns converge
        // at O(h³) in L2, but the positions and the direction cosines (whose drift from
        // orthonormal is O(h²)) at O(h²) in the largest error over the frames, which is
        // what a sweep measures (docs/methods.md, `state_time`, measured in the plane and
        // in space)
        "state_time" => Some(2.0),
        _ => None,
    }
}

/// The options of a method in words.
pub fn describe_options(spec: &MethodSpec) -> String {
    let eps = |e: &Option<f64>, rule: &str| match e {
        Some(v) => format!("ε = {v:e}"),
        None => format!("ε by the default rule ({rule})"),
    };
    match spec {
        MethodSpec::Staggered(o) => {
            let mut s = eps(&o.epsilon, "10⁻⁹·h²·K_rr");
            if o.single_stage {
                s.push_str(", single stage");
            }
            if o.lint == LintForm::Midpoint {
                s.push_str(", midpoint LINT");
            }
            if o.paper_literal {
                s.push_str(", paper-literal formulas");
            }
            match o.factorization {
                Factorization::Auto => {}
                Factorization::Dense => s.push_str(", dense factorization"),
                Factorization::Sparse => s.push_str(", sparse factorization"),
            }
            s
        }
        MethodSpec::Baumgarte { alpha, beta } => format!("α = {alpha} 1/s, β = {beta} 1/s"),
        MethodSpec::Penalty { epsilon } => eps(epsilon, "h²·max diag K"),
        MethodSpec::CoordinatePartitioning => String::new(),
        MethodSpec::ImplicitTrapezoid {
            tolerance,
            max_iterations,
        } => format!("Newton tolerance {tolerance:e}, ≤ {max_iterations} iterations"),
        MethodSpec::NaturalPartitioning {
            epsilon,
            tolerance,
            max_iterations,
        } => {
            let mut s = format!("{}, PCG tolerance {tolerance:e}", eps(epsilon, "default"));
            if let Some(n) = max_iterations {
                s.push_str(&format!(", ≤ {n} PCG iterations"));
            }
            s
        }
        MethodSpec::RungeKutta4 => String::new(),
        MethodSpec::DormandPrince { tolerance } | MethodSpec::DormandPrince853 { tolerance } => {
            format!("tolerance {tolerance:e}")
        }
        MethodSpec::StateTime {
            steps_per_element,
            window,
        } => {
            format!("{steps_per_element} steps per time element, windows of {window}")
        }
    }
}

/// The methods chosen for a study, and those left out.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    /// The methods that will run.
    pub methods: Vec<MethodEntry>,
    /// The methods left out (name, why).
    pub skipped: Vec<(String, String)>,
}

/// Choose the methods: those named in `requested` (in the order of
/// [`MethodSpec::NAMES`]), or, when it is empty, every method that can start on the scene
/// at step `h`, the others left out with the reason.
///
/// # Errors
/// A requested name that is not a method.
pub fn select(
    requested: &[String],
    scene: &Scene,
    sys: &Interp,
    h: f64,
) -> Result<Selection, StudyError> {
    if let Some(bad) = requested
        .iter()
        .find(|r| !MethodSpec::NAMES.contains(&r.as_str()))
    {
        return Err(StudyError::UnknownMethod(bad.clone()));
    }
    let names: Vec<&'static str> = if requested.is_empty() {
        MethodSpec::NAMES.to_vec()
    } else {
        MethodSpec::NAMES
            .iter()
            .copied()
            .filter(|n| requested.iter().any(|m| m == n))
            .collect()
    };
    let start = State::initial(sys);
    let mut out = Vec::new();
    let mut skipped = Vec::new();
    for name in names {
        let (spec, from_scene) = if scene.simulate.method.name() == name {
            (scene.simulate.method.clone(), true)
        } else {
            match MethodSpec::default_for(name) {
                Some(s) => (s, false),
                None => continue,
            }
        };
        if requested.is_empty() {
            match guarded(|| integrators::make(&spec, sys, h, &start).map(|_| ())) {
                Ok(Ok(())) => {}
                Ok(Err(StartError::Unsupported(_))) => {
                    skipped.push((name.to_string(), "not available yet".to_string()));
                    continue;
                }
                Ok(Err(e)) => {
                    skipped.push((name.to_string(), format!("does not apply: {e}")));
                    continue;
                }
                Err(panic) => {
                    skipped.push((
                        name.to_string(),
                        format!("cannot start: the runtime panicked ({panic})"),
                    ));
                    continue;
                }
            }
        }
        let mut options = describe_options(&spec);
        if from_scene && !options.is_empty() {
            options.push_str(" (the scene's)");
        }
        out.push(MethodEntry {
            name,
            spec,
            options,
            theory: theoretical_order(name),
        });
    }
    Ok(Selection {
        methods: out,
        skipped,
    })
}
