//! Dense output: the solution between the ends of an accepted step, for output frames at
//! fixed times whatever steps the controller takes.

use super::tableau::DOPRI5_DENSE;

/// The Dormand–Prince continuous extension ([`DOPRI5_DENSE`]) of the step `y0 → y1` of
/// size `h` with stage derivatives `k` (seven, `k[6] = f(y1)`), at `θ = (t − t₀)/h` in
/// `[0, 1]`, into `out`. Fourth order uniformly in θ; `θ = 0` and `θ = 1` give `y0` and
/// `y1` to round-off. Does not allocate.
pub fn dopri5(y0: &[f64], y1: &[f64], k: &[Vec<f64>], h: f64, theta: f64, out: &mut [f64]) {
    let th1 = 1.0 - theta;
    for i in 0..out.len() {
        let d = y1[i] - y0[i];
        let r3 = h * k[0][i] - d;
        let r4 = d - h * k[6][i] - r3;
        let mut s = 0.0;
        for (j, dj) in DOPRI5_DENSE.iter().enumerate() {
            if *dj != 0.0 {
                s += dj * k[j][i];
            }
        }
        let r5 = h * s;
        out[i] = y0[i] + theta * (d + th1 * (r3 + theta * (r4 + th1 * r5)));
    }
}

#[cfg(test)]
mod tests {
    use super::super::tableau::DOPRI5;
    use super::*;

    /// One DOPRI5 step of `y' = cos t` from 0 (exact stage derivatives), interpolated:
    /// the ends are the step's, interior points within `O(h⁵)` of `sin t`.
    #[test]
    fn interpolates_quadrature_to_fourth_order() {
        let errs: Vec<f64> = [0.4, 0.2]
            .iter()
            .map(|&h: &f64| {
                let k: Vec<Vec<f64>> = DOPRI5.c.iter().map(|c| vec![(c * h).cos()]).collect();
                let y1 = [h * DOPRI5.b.iter().zip(&k).map(|(b, k)| b * k[0]).sum::<f64>()];
                let mut out = [0.0];
                dopri5(&[0.0], &y1, &k, h, 1.0, &mut out);
                assert!((out[0] - y1[0]).abs() < 1e-15);
                dopri5(&[0.0], &y1, &k, h, 0.0, &mut out);
                assert_eq!(out[0], 0.0);
                [0.25, 0.5, 0.75]
                    .iter()
                    .map(|th| {
                        dopri5(&[0.0], &y1, &k, h, *th, &mut out);
                        (out[0] - (th * h).sin()).abs()
                    })
                    .fold(0.0, f64::max)
            })
            .collect();
        let order = (errs[0] / errs[1]).log2();
        assert!(order > 4.5, "local order {order} ({errs:?})");
    }
}
