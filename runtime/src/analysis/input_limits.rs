//! Size and effort limits on the input: what a scene or a run may ask for before the
//! runtime refuses it with an error instead of trying (see docs/stability.md, "Bad input").
//!
//! Memory and time must stay bounded whatever a scene says. Most of the runtime's memory
//! is linear in the scene (a few hundred bytes per body, joint row and force term), so
//! the counts below only cut off the absurd; they are at least the compiler's own limit
//! of generated items (`mbdc_compiler`'s `MAX_ITEMS`, 10⁶), so that every scene the
//! compiler produces is accepted. What is not linear is refused separately: the dense
//! methods ([`MAX_DENSE_UNKNOWNS`]), the Newton iteration count
//! ([`MAX_NEWTON_ITERATIONS`]) and the number of steps of a run ([`MAX_STEPS`]).
//!
//! Where each limit is enforced:
//! - [`crate::interp::Interp::new`]: bodies, joints, force elements, contacts, the depth of
//!   time functions, and the scene's own step and duration ([`check_run`]);
//! - [`crate::app::run_config`] and [`crate::driver::run_loop::run`]: step and duration after the
//!   user's overrides ([`check_run`]);
//! - [`crate::integrators::make`]: the step, the method's options ([`check_method`]), and
//!   the size of the dense methods.

use crate::contract::scene::MethodSpec;

/// Most rigid bodies in a scene.
pub const MAX_BODIES: usize = 1_000_000;
/// Most joints in a scene (each has at most 6 constraint rows).
pub const MAX_JOINTS: usize = 1_000_000;
/// Most force elements (applied forces, torques, springs) in a scene.
pub const MAX_FORCES: usize = 1_000_000;
/// Most contact pairs in a scene.
pub const MAX_CONTACTS: usize = 1_000_000;
/// Deepest time-function expression tree (the kernel's own bound, [`crate::kernels::fn1::MAX_FN_DEPTH`]).
pub use crate::kernels::fn1::MAX_FN_DEPTH;
/// Most steps of one run (`duration / step`). At the fastest, a microsecond per step,
/// this is eleven days of computing.
pub const MAX_STEPS: f64 = 1e12;
/// Largest dense system the dense methods (`coordinate_partitioning`,
/// `implicit_trapezoid`) build: `6 · bodies + constraint rows` unknowns. Their matrices
/// take `8 n²` bytes each and `n³` operations per factorization, so 4096 unknowns (about
/// 370 links of a chain) already mean 130 MB per matrix and seconds per step; larger
/// scenes run with `staggered` or `natural_partitioning`, which are sparse.
pub const MAX_DENSE_UNKNOWNS: usize = 4096;
/// Most Newton iterations per step `implicit_trapezoid` may be asked for.
pub const MAX_NEWTON_ITERATIONS: u32 = 1000;
/// Most time elements in one `state_time` window: a window's unknowns, buffers and LU
/// grow with it (some 4000 unknowns per element for a 100-body spatial chain).
pub const MAX_STATE_TIME_WINDOW: u32 = 65_536;

/// Check a run's step and duration: the step positive and finite, the duration finite
/// and ≥ 0, at most [`MAX_STEPS`] steps. Returns the number of steps, or why not.
pub fn check_run(step: f64, duration: f64) -> Result<u64, String> {
    if !(step.is_finite() && step > 0.0) {
        return Err(format!("the step must be positive and finite, got {step}"));
    }
    if !(duration.is_finite() && duration >= 0.0) {
        return Err(format!(
            "the duration must be finite and ≥ 0, got {duration}"
        ));
    }
    let steps = (duration / step - 1e-9).ceil().max(0.0);
    if steps.is_nan() || steps > MAX_STEPS {
        return Err(format!(
            "a duration of {duration} s with a step of {step} s is {steps:.3e} steps, more than the limit of {MAX_STEPS:.0e}"
        ));
    }
    Ok(steps as u64)
}

/// Check a method's options: ε positive and finite where given, Baumgarte's α and β
/// finite and ≥ 0, tolerances positive and finite, `max_iterations` in
/// `1..=`[`MAX_NEWTON_ITERATIONS`], `steps_per_element` ≥ 1, `window` in
/// `1..=`[`MAX_STATE_TIME_WINDOW`]. Returns why not.
pub fn check_method(method: &MethodSpec) -> Result<(), String> {
    let name = method.name();
    let positive = |what: &str, x: f64| {
        if x.is_finite() && x > 0.0 {
            Ok(())
        } else {
            Err(format!(
                "{name}: {what} must be positive and finite, got {x}"
            ))
        }
    };
    let epsilon = |e: &Option<f64>| e.map_or(Ok(()), |e| positive("epsilon", e));
    match method {
        MethodSpec::Staggered(o) => epsilon(&o.epsilon),
        MethodSpec::Baumgarte { alpha, beta } => {
            for (what, x) in [("alpha", alpha), ("beta", beta)] {
                if !(x.is_finite() && *x >= 0.0) {
                    return Err(format!("{name}: {what} must be finite and ≥ 0, got {x}"));
                }
            }
            Ok(())
        }
        MethodSpec::Penalty { epsilon: e } => epsilon(e),
        MethodSpec::CoordinatePartitioning => Ok(()),
        MethodSpec::ImplicitTrapezoid {
            tolerance,
            max_iterations,
        } => {
            positive("tolerance", *tolerance)?;
            if !(1..=MAX_NEWTON_ITERATIONS).contains(max_iterations) {
                return Err(format!(
                    "{name}: max_iterations must be between 1 and {MAX_NEWTON_ITERATIONS}, got {max_iterations}"
                ));
            }
            Ok(())
        }
        MethodSpec::NaturalPartitioning {
            epsilon: e,
            tolerance,
            max_iterations,
        } => {
            epsilon(e)?;
            if let Some(n) = max_iterations {
                if *n == 0 {
                    return Err(format!("{name}: max_iterations must be at least 1"));
                }
            }
            positive("tolerance", *tolerance)
        }
        MethodSpec::RungeKutta4 => Ok(()),
        MethodSpec::DormandPrince { tolerance } | MethodSpec::DormandPrince853 { tolerance } => {
            positive("tolerance", *tolerance)
        }
        MethodSpec::StateTime {
            steps_per_element,
            window,
        } => {
            if *steps_per_element == 0 {
                Err(format!("{name}: steps_per_element must be at least 1"))
            } else if !(1..=MAX_STATE_TIME_WINDOW).contains(window) {
                Err(format!(
                    "{name}: window must be between 1 and {MAX_STATE_TIME_WINDOW} time elements (it is {window})"
                ))
            } else {
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_lengths() {
        assert_eq!(check_run(1e-3, 1.0), Ok(1000));
        assert_eq!(check_run(0.3, 1.0), Ok(4));
        assert_eq!(check_run(1e-3, 0.0), Ok(0));
        for (h, d) in [
            (0.0, 1.0),
            (-1.0, 1.0),
            (f64::NAN, 1.0),
            (f64::INFINITY, 1.0),
            (1e-3, -1.0),
            (1e-3, f64::NAN),
            (1e-3, f64::INFINITY),
            (5e-324, 1.0),
            (1e-300, 1e300),
        ] {
            assert!(check_run(h, d).is_err(), "{h} {d}");
        }
    }

    #[test]
    fn method_options() {
        for name in MethodSpec::NAMES {
            let m = MethodSpec::default_for(name).unwrap();
            assert_eq!(check_method(&m), Ok(()), "{name}");
        }
        let bad = [
            MethodSpec::Penalty { epsilon: Some(0.0) },
            MethodSpec::Baumgarte {
                alpha: f64::NAN,
                beta: 1.0,
            },
            MethodSpec::ImplicitTrapezoid {
                tolerance: 1e-10,
                max_iterations: u32::MAX,
            },
            MethodSpec::ImplicitTrapezoid {
                tolerance: 0.0,
                max_iterations: 10,
            },
            MethodSpec::NaturalPartitioning {
                epsilon: Some(f64::INFINITY),
                tolerance: 1e-12,
                max_iterations: None,
            },
            MethodSpec::NaturalPartitioning {
                epsilon: None,
                tolerance: 1e-12,
                max_iterations: Some(0),
            },
            MethodSpec::StateTime {
                steps_per_element: 4,
                window: 0,
            },
            MethodSpec::StateTime {
                steps_per_element: 4,
                window: MAX_STATE_TIME_WINDOW + 1,
            },
        ];
        for m in bad {
            let e = check_method(&m).unwrap_err();
            assert!(e.starts_with(m.name()), "{e}");
        }
    }
}
