//! Step-size control of the embedded pairs: the weighted error norm and the PI controller
//! of Gustafsson as Hairer–Wanner use it in `DOPRI5` and `DOP853` (Hairer–Nørsett–Wanner I,
//! §II.4, eq. 4.11, and §II.10; Hairer–Wanner II, §IV.2).

/// The constants of the step-size controller of one method.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Constants {
    /// Safety factor on the optimal step.
    pub safety: f64,
    /// Smallest step ratio after a step.
    pub fac_min: f64,
    /// Largest step ratio after a step.
    pub fac_max: f64,
    /// The exponent of the current error norm: `1/(q+1) − c β` for an estimate with
    /// `err ∝ h^(q+1)`.
    pub alpha: f64,
    /// The PI controller's β: the weight of the previous step's error, which damps the
    /// step-size oscillations of the plain (I) controller (0: the I controller).
    pub beta: f64,
}

/// Hairer's `DOPRI5` defaults: safety 0.9, the ratio in `[0.2, 10]`, β = 0.04 and
/// `α = 1/5 − 0.75 β` (the fourth-order estimate, `err ∝ h⁵`).
pub const DOPRI5: Constants = Constants {
    safety: 0.9,
    fac_min: 0.2,
    fac_max: 10.0,
    alpha: 1.0 / 5.0 - 0.75 * 0.04,
    beta: 0.04,
};

/// Hairer's `DOP853` defaults: safety 0.9, the ratio in `[1/3, 6]`, β = 0 and
/// `α = 1/8 − 0.2 β` (`EXPO1`). The combined error estimate of DOP853 (see
/// [`dop853_combine`]) behaves like `h⁸`, so its exponent is `1/8`; with Hairer's default
/// β = 0 the PI controller reduces to the I controller (same code, no memory term).
pub const DOP853: Constants = Constants {
    safety: 0.9,
    fac_min: 1.0 / 3.0,
    fac_max: 6.0,
    alpha: 1.0 / 8.0,
    beta: 0.0,
};

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

/// The error estimate of `DOP853` from its two embedded estimates, following Hairer's
/// `dop853.f`: with `sc_i = tol (1 + max(|y0ᵢ|, |y1ᵢ|))`, `E₅² = Σ (err5ᵢ/scᵢ)²` (the
/// fifth-order estimate, `∝ h⁶`) and `E₃² = Σ (err3ᵢ/scᵢ)²` (the third-order one, `∝ h⁴`),
/// the step's error norm is
///
/// ```text
/// err = E₅² / √(N (E₅² + 0.01 E₃²)),
/// ```
///
/// which behaves like `h⁸` (`E₅²/(0.1 E₃)`) for small steps and like the fifth-order
/// estimate for large ones. (Hairer keeps `h` outside the sums; here both estimates already
/// carry it, which gives the same number.) That norm is the weighted RMS norm
/// ([`error_norm`]) of `ρ · err5` with `ρ = E₅ / √(E₅² + 0.01 E₃²)`: `err5` is scaled by `ρ`
/// in place, so it becomes the combined estimate in the state's units. Both zero: `ρ = 1`
/// (Hairer's `DENO = 1`), the estimate stays zero.
pub fn dop853_combine(err5: &mut [f64], err3: &[f64], y0: &[f64], y1: &[f64], tol: f64) {
    let (mut s5, mut s3) = (0.0, 0.0);
    for (i, (e5, e3)) in err5.iter().zip(err3).enumerate() {
        let sc = tol * (1.0 + y0[i].abs().max(y1[i].abs()));
        s5 += (e5 / sc) * (e5 / sc);
        s3 += (e3 / sc) * (e3 / sc);
    }
    let deno = s5 + 0.01 * s3;
    let rho = if deno > 0.0 { (s5 / deno).sqrt() } else { 1.0 };
    err5.iter_mut().for_each(|e| *e *= rho);
}

/// The PI step-size controller ([`Constants`]): after a step with error norm `err`, the
/// next step is `h · safety · err^(−α) · err_prev^β`, the ratio kept in
/// `[fac_min, fac_max]`, and no increase right after a rejection; after a rejected step
/// `h · safety · err^(−α)`, at least `fac_min h`.
#[derive(Clone, Debug)]
pub struct Controller {
    k: Constants,
    /// The error norm of the last accepted step (1e-4 at the start, as `DOPRI5`).
    err_prev: f64,
    /// The last attempt was rejected.
    rejected: bool,
}

impl Controller {
    /// A controller with the constants `k`.
    pub fn new(k: Constants) -> Controller {
        Controller {
            k,
            err_prev: 1e-4,
            rejected: false,
        }
    }

    /// The verdict on a step of size `h` with error norm `err`: `(accepted, next step)`.
    /// A non-finite `err` rejects the step with the smallest ratio.
    pub fn next(&mut self, h: f64, err: f64) -> (bool, f64) {
        let k = &self.k;
        if !err.is_finite() {
            self.rejected = true;
            return (false, h * k.fac_min);
        }
        let e = err.max(1e-10);
        if err <= 1.0 {
            let fac = k.safety * e.powf(-k.alpha) * self.err_prev.powf(k.beta);
            let hi = if self.rejected { 1.0 } else { k.fac_max };
            self.err_prev = e;
            self.rejected = false;
            (true, h * fac.clamp(k.fac_min, hi))
        } else {
            let fac = k.safety * e.powf(-k.alpha);
            self.rejected = true;
            (false, h * fac.clamp(k.fac_min, 1.0))
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
        let mut c = Controller::new(DOPRI5);
        let (ok, h) = c.next(1.0, 1e-3);
        assert!(ok && h > 1.0 && h <= DOPRI5.fac_max);
        let (ok, h2) = c.next(h, 50.0);
        assert!(!ok && h2 < h && h2 >= DOPRI5.fac_min * h);
        // no increase right after a rejection
        let (ok, h3) = c.next(h2, 1e-6);
        assert!(ok && h3 <= h2);
        let (ok, _) = c.next(1.0, f64::NAN);
        assert!(!ok);
        // at err = 1 the step stays about the same
        let mut c = Controller::new(DOPRI5);
        c.next(1.0, 1.0);
        let (_, h) = c.next(1.0, 1.0);
        assert!((0.8..1.0).contains(&h), "{h}");
    }

    /// DOP853's constants: the exponent of an `h⁸` estimate, β = 0 (no memory of the
    /// previous error), the ratio in `[1/3, 6]`.
    #[test]
    fn dop853_controller_is_eighth_order_i_control() {
        let mut c = Controller::new(DOP853);
        // err = 2⁻⁸ asks for twice the step (times the safety factor), whatever came before
        let (ok, h) = c.next(1.0, 2f64.powi(-8));
        assert!(ok && (h - 2.0 * 0.9).abs() < 1e-12, "{h}");
        let (ok, h) = c.next(1.0, 2f64.powi(-8));
        assert!(ok && (h - 2.0 * 0.9).abs() < 1e-12, "{h}");
        let (_, h) = c.next(1.0, 1e-12);
        assert_eq!(h, 6.0);
        let (ok, h) = c.next(1.0, 1e6);
        assert!(!ok && (h - 1.0 / 3.0).abs() < 1e-15, "{h}");
    }

    /// The DOP853 combination: the norm of the combined estimate is
    /// `E₅²/√(N(E₅² + 0.01 E₃²))`, and it follows the fifth-order estimate when the
    /// third-order one is small.
    #[test]
    fn dop853_combination_follows_hairer() {
        let (y0, y1) = ([0.0, 1.0], [0.0, 1.0]);
        let tol = 1e-6;
        let mut e5: [f64; 2] = [1e-7, -2e-7];
        let e3: [f64; 2] = [3e-5, 1e-5];
        let sc = [tol, 2.0 * tol];
        let s5: f64 = (0..2).map(|i| (e5[i] / sc[i]).powi(2)).sum();
        let s3: f64 = (0..2).map(|i| (e3[i] / sc[i]).powi(2)).sum();
        let want = s5 / (2.0 * (s5 + 0.01 * s3)).sqrt();
        dop853_combine(&mut e5, &e3, &y0, &y1, tol);
        let got = error_norm(&e5, &y0, &y1, tol);
        assert!((got - want).abs() < 1e-14 * want, "{got} vs {want}");
        let mut e5 = [1e-7, -2e-7];
        dop853_combine(&mut e5, &[0.0, 0.0], &y0, &y1, tol);
        assert_eq!(e5, [1e-7, -2e-7]);
        let mut z = [0.0, 0.0];
        dop853_combine(&mut z, &[0.0, 0.0], &y0, &y1, tol);
        assert_eq!(z, [0.0, 0.0]);
    }
}
