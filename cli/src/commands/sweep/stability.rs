//! The stability estimate behind the default step series: the largest angular rate or
//! frequency ω_max the scene shows at t = 0.
//!
//! It is the runtime's estimate ([`mbdc_runtime::step_limits`]: body spin, springs with their
//! lever arms, rotational springs, contact, damping), completed here with one source the
//! runtime does not count: gravity on a hinged body, √(|g| / d) with d the distance from a
//! joint point to the body's mass centre (the simple-pendulum rate, an upper bound for the
//! physical pendulum). Without it a pendulum at rest would have no estimate at all.
//!
//! The explicit methods are stable for h·ω_max ≤ 2 and need about 20 steps per period to
//! be accurate (notes A §1.10), so the default series starts at h_max = T_min / 20 =
//! 2π / (20 ω_max), h_max·ω_max ≈ 0.31, and halves from there.

use mbdc_runtime::scene::Scene;

/// The largest rate found and where it comes from.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// ω_max, rad/s.
    pub omega_max: f64,
    /// What sets it, e.g. `spin of body 'top' at t = 0`.
    pub source: String,
}

impl Estimate {
    /// The shortest period 2π/ω_max, s.
    pub fn period(&self) -> f64 {
        std::f64::consts::TAU / self.omega_max
    }

    /// The largest step of the default series: 20 steps per shortest period.
    pub fn h_max(&self) -> f64 {
        self.period() / 20.0
    }

    /// The explicit stability limit h = 2/ω_max, s.
    pub fn h_limit(&self) -> f64 {
        2.0 / self.omega_max
    }
}

fn norm(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Estimate ω_max for `scene`; `None` when nothing in the scene sets a rate (a body at
/// rest under no forces), or when it has beams or meshes, whose element frequencies the
/// estimate does not cover (the scene's own step is then the best guide).
pub fn estimate(scene: &Scene) -> Option<Estimate> {
    if !scene.beams.is_empty() || !scene.meshes.is_empty() {
        return None;
    }
    let rt = mbdc_runtime::step_limits::estimate(scene);
    let mut best: Option<Estimate> = rt.fastest().map(|s| Estimate {
        omega_max: s.omega,
        source: s.what.clone(),
    });
    let mut offer = |omega: f64, source: String| {
        if omega.is_finite() && omega > 0.0 && best.as_ref().is_none_or(|b| omega > b.omega_max) {
            best = Some(Estimate {
                omega_max: omega,
                source,
            });
        }
    };
    if let Some(g) = scene.gravity {
        let g = norm(&g);
        if g > 0.0 {
            for j in &scene.joints {
                for at in [&j.a, &j.b] {
                    if let (Some(i), d) = (at.body.index(), norm(&at.point)) {
                        if d > 1e-9 {
                            offer(
                                (g / d).sqrt(),
                                format!(
                                    "gravity on body '{}' hinged {:.3} m from its mass centre (joint '{}')",
                                    scene.bodies[i].name, d, j.name
                                ),
                            );
                        }
                    }
                }
            }
        }
    }
    best
}

/// A geometric series of `levels` steps from `h_max` down, each `ratio` times smaller.
pub fn series(h_max: f64, levels: usize, ratio: f64) -> Vec<f64> {
    (0..levels).map(|k| h_max / ratio.powi(k as i32)).collect()
}

/// Shrink `h` so that `duration / h` is a whole number (every step of a series made
/// from it by halving then lands exactly on the end time).
pub fn fit_to_duration(h: f64, duration: f64) -> f64 {
    if duration <= 0.0 || h <= 0.0 {
        return h;
    }
    let n = (duration / h - 1e-9).ceil().max(1.0);
    duration / n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(text: &str) -> Scene {
        let l = mbdc_compiler::load_str("t.mbd", text, &[]);
        let text = l.render_plain();
        l.scene.unwrap_or_else(|| panic!("{text}"))
    }

    #[test]
    fn gravity_completes_the_runtime_estimate() {
        let s = load(
            "model a { gravity (0, 0, -9.81) m/s^2
               body b { mass 2 kg; inertia diag(1, 1, 1) kg*m^2; angular_velocity (0, 0, 3) rad/s }
               joint j = spherical(ground @ (0, 0, 0), b @ (0, 0, 0.5) m)
               simulate { duration 1 s; step 1 ms } }",
        );
        let e = estimate(&s).expect("estimate");
        assert!(
            (e.omega_max - (9.81f64 / 0.5).sqrt()).abs() < 1e-12,
            "{e:?}"
        );
        assert!(e.source.contains("gravity"), "{}", e.source);
        assert!((e.h_max() - std::f64::consts::TAU / 20.0 / e.omega_max).abs() < 1e-15);

        // a spring at the mass centre: the runtime's √(k/m)
        let s = load(
            "model a {
               body b { mass 2 kg; inertia diag(1, 1, 1) kg*m^2 }
               force k = spring(ground @ (-1, 0, 0) m, b @ (0, 0, 0), stiffness: 800 N/m)
               simulate { duration 1 s; step 1 ms } }",
        );
        let e = estimate(&s).expect("estimate");
        assert!((e.omega_max - 20.0).abs() < 1e-9, "{e:?}");

        let s = load(
            "model a { body b { mass 2 kg; inertia diag(1, 1, 1) kg*m^2 }
               simulate { duration 1 s; step 1 ms } }",
        );
        assert_eq!(estimate(&s), None);
    }

    #[test]
    fn series_and_duration() {
        let h = fit_to_duration(0.03, 1.0);
        assert!((1.0 / h - 34.0).abs() < 1e-9, "{h}");
        assert!(h <= 0.03);
        assert_eq!(fit_to_duration(0.25, 1.0), 0.25);
        let s = series(0.1, 3, 2.0);
        assert_eq!(s, vec![0.1, 0.05, 0.025]);
    }
}
