//! Dense output: the solution between the ends of an accepted step, for output frames at
//! fixed times whatever steps the controller takes.

use super::tableau::{DOP853_DENSE_D, DOP853_EXTRA_A, DOPRI5_DENSE};

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

/// The state of the extra stage `r` (0, 1, 2: stages 14, 15 and 16) of DOP853's
/// continuous extension for the step from `y0` of size `h`: `y0 + h Σ_j a_{14+r, j} k_j`
/// ([`DOP853_EXTRA_A`]) over the step's thirteen stage derivatives `k` (`k[12] = f(y1)`)
/// and the extra stage derivatives before it, `extra[..r]`, into `out`. Does not allocate.
pub fn dop853_extra_state(
    y0: &[f64],
    k: &[Vec<f64>],
    extra: &[Vec<f64>],
    h: f64,
    r: usize,
    out: &mut [f64],
) {
    let row = &DOP853_EXTRA_A[r];
    for (i, o) in out.iter_mut().enumerate() {
        let mut s = 0.0;
        for (j, a) in row[..13].iter().enumerate() {
            if *a != 0.0 {
                s += a * k[j][i];
            }
        }
        for (j, a) in row[13..13 + r].iter().enumerate() {
            s += a * extra[j][i];
        }
        *o = y0[i] + h * s;
    }
}

/// DOP853's continuous extension ([`DOP853_DENSE_D`], Hairer's `CONTD8`) of the step
/// `y0 → y1` of size `h`, with its thirteen stage derivatives `k` (`k[12] = f(y1)`) and the
/// three extra ones `extra` ([`dop853_extra_state`]), at `θ = (t − t₀)/h` in `[0, 1]`, into
/// `out`. Seventh order uniformly in θ; `θ = 0` and `θ = 1` give `y0` and `y1` to
/// round-off. Does not allocate.
pub fn dop853(
    y0: &[f64],
    y1: &[f64],
    k: &[Vec<f64>],
    extra: &[Vec<f64>],
    h: f64,
    theta: f64,
    out: &mut [f64],
) {
    let th1 = 1.0 - theta;
    for i in 0..out.len() {
        let d = y1[i] - y0[i];
        let r2 = h * k[0][i] - d;
        let r3 = d - h * k[12][i] - r2;
        let mut r = [0.0; 4];
        for (rr, drow) in r.iter_mut().zip(&DOP853_DENSE_D) {
            let mut s = 0.0;
            for (j, dj) in drow[..13].iter().enumerate() {
                if *dj != 0.0 {
                    s += dj * k[j][i];
                }
            }
            for (j, dj) in drow[13..].iter().enumerate() {
                s += dj * extra[j][i];
            }
            *rr = h * s;
        }
        let tail = r[0] + theta * (r[1] + th1 * (r[2] + theta * r[3]));
        out[i] = y0[i] + theta * (d + th1 * (r2 + theta * (r3 + th1 * tail)));
    }
}

#[cfg(test)]
mod tests {
    use super::super::tableau::{DOP853, DOP853_EXTRA_C, DOPRI5};
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

    /// One DOP853 step of the Riccati equation `y' = 1 + y²` from `y(0) = 0` (exact solution
    /// `tan t`), stages evaluated on the actual stage states (so the extra stages' rows
    /// count, not only the quadrature weights), interpolated: the ends are the step's, and
    /// interior points are within `O(h⁸)` of `tan t` (a seventh-order extension), measured
    /// by halving the step.
    #[test]
    fn interpolates_the_riccati_equation_to_seventh_order() {
        let f = |y: f64| 1.0 + y * y;
        let errs: Vec<f64> = [0.4, 0.2]
            .iter()
            .map(|&h: &f64| {
                let s = DOP853.stages();
                let mut k: Vec<Vec<f64>> = vec![vec![0.0]; s];
                for i in 0..s {
                    let yi: f64 = DOP853.a[i].iter().zip(&k).map(|(a, k)| a * k[0]).sum();
                    k[i][0] = f(h * yi);
                }
                let y1 = [h * DOP853.b.iter().zip(&k).map(|(b, k)| b * k[0]).sum::<f64>()];
                // the thirteenth stage is the derivative at the result
                assert!((k[12][0] - f(y1[0])).abs() < 1e-15);
                let mut extra = vec![vec![0.0]; 3];
                let mut ys = [0.0];
                for r in 0..3 {
                    dop853_extra_state(&[0.0], &k, &extra, h, r, &mut ys);
                    extra[r][0] = f(ys[0]);
                    // the extra stages are near the solution at their nodes
                    let exact = (DOP853_EXTRA_C[r] * h).tan();
                    assert!((ys[0] - exact).abs() < 1e-2 * h, "stage {r}: {}", ys[0]);
                }
                let mut out = [0.0];
                dop853(&[0.0], &y1, &k, &extra, h, 1.0, &mut out);
                assert!((out[0] - y1[0]).abs() < 1e-15);
                dop853(&[0.0], &y1, &k, &extra, h, 0.0, &mut out);
                assert_eq!(out[0], 0.0);
                [0.2, 0.5, 0.7]
                    .iter()
                    .map(|th| {
                        dop853(&[0.0], &y1, &k, &extra, h, *th, &mut out);
                        (out[0] - (th * h).tan()).abs()
                    })
                    .fold(0.0, f64::max)
            })
            .collect();
        let order = (errs[0] / errs[1]).log2();
        eprintln!("dop853 dense output on tan t: errors {errs:?}, local order {order:.2}");
        assert!(order > 7.5, "local order {order} ({errs:?})");
    }
}
