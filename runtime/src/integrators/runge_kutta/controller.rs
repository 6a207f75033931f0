//! Step-size control of the embedded pairs: the weighted error norm and the PI controller
//! of Gustafsson as Hairer–Wanner use it in `DOPRI5` (Hairer–Nørsett–Wanner I, §II.4,
//! eq. 4.11; Hairer–Wanner II, §IV.2).

/// Safety factor on the optimal step.
pub const SAFETY: f64 = 0.9;
/// Smallest step ratio after a step.
pub const FAC_MIN: f64 = 0.2;
/// Largest step ratio after a step.
pub const FAC_MAX: f64 = 10.0;
/// The PI controller's β (Hairer's `DOPRI5` default 0.04): the weight of the previous
/// step's error, which damps the step-size oscillations of the plain (I) controller.
pub const BETA: f64 = 0.04;

/// The weighted RMS norm of an error estimate `err` for the step `y0 → y1`, each component
/// scaled by `tol (1 + max(|y0ᵢ|, |y1ᵢ|))` (absolute and relative tolerance both `tol`).
/// `≤ 1` accepts the step.
pub fn error_norm(err: &[f64], y0: &[f64], y1: &[f64], tol: f64) -> f64 {
    let n = err.len().max(1);
    let sum: f64 = err
        .iter()
        .zip(y0.iter().zip(y1))
        .map(|(e, (a, b))| {
            let sc = tol * (1.0 + a.abs().max(b.abs()));
            (e / sc) * (e / sc)
        })
        .sum();
    (sum / n as f64).sqrt()
}

/// The PI step-size controller for a method whose error estimate is of order `q`
/// (`err ∝ h^(q+1)`): after a step with error norm `err`, the next step is
/// `h · SAFETY · err^(−α) · err_prev^β` (`α = 1/(q+1) − 0.75 β`), the ratio kept in
/// `[FAC_MIN, FAC_MAX]`, and no increase right after a rejection.
#[derive(Clone, Debug)]
pub struct Controller {
    alpha: f64,
    /// The error norm of the last accepted step (1e-4 at the start, as `DOPRI5`).
    err_prev: f64,
    /// The last attempt was rejected.
    rejected: bool,
}

impl Controller {
    /// A controller for an error estimate of order `q`.
    pub fn new(q: u32) -> Controller {
        Controller {
            alpha: 1.0 / (q as f64 + 1.0) - 0.75 * BETA,
            err_prev: 1e-4,
            rejected: false,
        }
    }

    /// The verdict on a step of size `h` with error norm `err`: `(accepted, next step)`.
    /// A non-finite `err` rejects the step with the smallest ratio.
    pub fn next(&mut self, h: f64, err: f64) -> (bool, f64) {
        if !err.is_finite() {
            self.rejected = true;
            return (false, h * FAC_MIN);
        }
        let e = err.max(1e-10);
        if err <= 1.0 {
            let fac = SAFETY * e.powf(-self.alpha) * self.err_prev.powf(BETA);
            let hi = if self.rejected { 1.0 } else { FAC_MAX };
            self.err_prev = e;
            self.rejected = false;
            (true, h * fac.clamp(FAC_MIN, hi))
        } else {
            let fac = SAFETY * e.powf(-self.alpha);
            self.rejected = true;
            (false, h * fac.clamp(FAC_MIN, 1.0))
        }
    }
}

impl Controller {
    /// Save or load the controller's memory ([`crate::contract::persist`]).
    pub fn persist(&mut self, v: &mut dyn crate::contract::persist::StateVisitor) {
        crate::contract::persist::f64(v, "controller.err_prev", &mut self.err_prev);
        crate::contract::persist::bool(v, "controller.rejected", &mut self.rejected);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn norm_weights_by_size() {
        let n = error_norm(&[1e-9, 1e-9], &[0.0, 1.0], &[0.0, 1.0], 1e-9);
        assert!((n - ((1.0 + 0.25f64) / 2.0).sqrt()).abs() < 1e-12, "{n}");
    }

    #[test]
    fn controller_grows_shrinks_and_damps() {
        let mut c = Controller::new(4);
        let (ok, h) = c.next(1.0, 1e-3);
        assert!(ok && h > 1.0 && h <= FAC_MAX);
        let (ok, h2) = c.next(h, 50.0);
        assert!(!ok && h2 < h && h2 >= FAC_MIN * h);
        // no increase right after a rejection
        let (ok, h3) = c.next(h2, 1e-6);
        assert!(ok && h3 <= h2);
        let (ok, _) = c.next(1.0, f64::NAN);
        assert!(!ok);
        // at err = 1 the step stays about the same
        let mut c = Controller::new(4);
        c.next(1.0, 1.0);
        let (_, h) = c.next(1.0, 1.0);
        assert!((0.8..1.0).contains(&h), "{h}");
    }
}
