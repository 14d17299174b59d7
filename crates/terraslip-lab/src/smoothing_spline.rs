//! The cubic smoothing spline of a sampled signal, as DRIVE smooths the
//! lidar pose of each window (`scipy.interpolate.make_smoothing_spline`):
//! the function `g` minimising
//!
//! ```text
//! sum_i (y_i - g(t_i))^2  +  lambda * integral g''(t)^2 dt
//! ```
//!
//! a natural cubic spline with knots at the sample times, read back at
//! those times. Solved by Reinsch's algorithm (Green & Silverman,
//! "Nonparametric Regression and Generalized Linear Models", 1994, §2.3):
//! `(R + lambda Q^T Q) gamma = Q^T y`, `g = y - lambda Q gamma`.
//!
//! Written here rather than taken from a crate: the maintained one
//! (`csaps`) brings `ndarray` and `sprs` beside the workspace's `nalgebra`
//! (built without an allocator), for a 40-sample window whose system is
//! a 38 x 38 band.

/// Reinsch's system at fixed sample times, factored once.
#[derive(Debug, Clone)]
pub struct Smoother {
    /// Spacing of the sample times, s.
    h: Vec<f64>,
    lambda: f64,
    /// Lower Cholesky factor of `R + lambda Q^T Q`, row-major `m x m`
    /// (`m` = samples - 2).
    chol: Vec<f64>,
}

impl Smoother {
    /// The smoother of samples at strictly increasing `times` (s) with
    /// the roughness weight `lambda` (same units as scipy's `lam`);
    /// `None` when the times are not strictly increasing or `lambda` is
    /// negative or not finite.
    pub fn new(times: &[f64], lambda: f64) -> Option<Self> {
        if !(lambda >= 0.0 && lambda.is_finite()) || times.windows(2).any(|w| w[1] <= w[0]) {
            return None;
        }
        let h: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
        let m = times.len().saturating_sub(2);
        // A = R + lambda Q^T Q, symmetric, five diagonals.
        let mut a = vec![0.0; m * m];
        for j in 0..m {
            a[j * m + j] = (h[j] + h[j + 1]) / 3.0;
            if j + 1 < m {
                a[j * m + j + 1] = h[j + 1] / 6.0;
                a[(j + 1) * m + j] = h[j + 1] / 6.0;
            }
        }
        let q = |i: usize, j: usize| q_entry(&h, i, j);
        for i in 0..m {
            for j in i.saturating_sub(2)..(i + 3).min(m) {
                let dot: f64 = (j.max(i)..=(i.min(j) + 2)).map(|k| q(k, i) * q(k, j)).sum();
                a[i * m + j] += lambda * dot;
            }
        }
        let chol = cholesky(a, m)?;
        Some(Self { h, lambda, chol })
    }

    /// The smoothed samples of `y` (one per sample time); `None` when the
    /// length differs from the times'.
    pub fn apply(&self, y: &[f64]) -> Option<Vec<f64>> {
        let n = self.h.len() + 1;
        if y.len() != n {
            return None;
        }
        let m = n.saturating_sub(2);
        // Q^T y, then gamma from the factor, then g = y - lambda Q gamma.
        let mut g: Vec<f64> = (0..m)
            .map(|j| (j..j + 3).map(|k| q_entry(&self.h, k, j) * y[k]).sum())
            .collect();
        let l = &self.chol;
        for i in 0..m {
            let s: f64 = (0..i).map(|k| l[i * m + k] * g[k]).sum();
            g[i] = (g[i] - s) / l[i * m + i];
        }
        for i in (0..m).rev() {
            let s: f64 = (i + 1..m).map(|k| l[k * m + i] * g[k]).sum();
            g[i] = (g[i] - s) / l[i * m + i];
        }
        Some(
            (0..n)
                .map(|k| {
                    let qg: f64 = (k.saturating_sub(2)..=k.min(m.saturating_sub(1)))
                        .filter(|&j| j < m)
                        .map(|j| q_entry(&self.h, k, j) * g[j])
                        .sum();
                    y[k] - self.lambda * qg
                })
                .collect(),
        )
    }
}

/// Entry `(i, j)` of Reinsch's `Q` (`n x (n - 2)`; only `i` in
/// `j..=j + 2` is not zero), of the spacings `h`.
fn q_entry(h: &[f64], i: usize, j: usize) -> f64 {
    match i.wrapping_sub(j) {
        0 => 1.0 / h[j],
        1 => -1.0 / h[j] - 1.0 / h[j + 1],
        2 => 1.0 / h[j + 1],
        _ => 0.0,
    }
}

/// The lower Cholesky factor of the symmetric `m x m` matrix `a`
/// (row-major); `None` when it is not positive definite.
fn cholesky(mut a: Vec<f64>, m: usize) -> Option<Vec<f64>> {
    for j in 0..m {
        let d = a[j * m + j] - (0..j).map(|k| a[j * m + k].powi(2)).sum::<f64>();
        if d.is_nan() || d <= 0.0 {
            return None;
        }
        let d = d.sqrt();
        a[j * m + j] = d;
        for i in j + 1..m {
            let s: f64 = (0..j).map(|k| a[i * m + k] * a[j * m + k]).sum();
            a[i * m + j] = (a[i * m + j] - s) / d;
        }
        for i in 0..j {
            a[i * m + j] = 0.0;
        }
    }
    Some(a)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn times(n: usize) -> Vec<f64> {
        (0..n).map(|k| 2.0 * k as f64 / (n - 1) as f64).collect()
    }

    #[test]
    fn a_straight_line_is_kept_whatever_the_weight() {
        let t = times(40);
        let y: Vec<f64> = t.iter().map(|t| 0.3 - 1.7 * t).collect();
        for lambda in [0.0, 0.8, 1e6] {
            let g = Smoother::new(&t, lambda).unwrap().apply(&y).unwrap();
            for (a, b) in g.iter().zip(&y) {
                assert!((a - b).abs() < 1e-9, "{lambda}: {a} {b}");
            }
        }
    }

    #[test]
    fn no_weight_interpolates_and_a_huge_one_is_the_least_squares_line() {
        let t = times(12);
        let y: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(k, t)| t * t + if k % 2 == 0 { 0.1 } else { -0.1 })
            .collect();
        let g = Smoother::new(&t, 0.0).unwrap().apply(&y).unwrap();
        for (a, b) in g.iter().zip(&y) {
            assert!((a - b).abs() < 1e-9);
        }
        // The least-squares line of (t, y).
        let n = t.len() as f64;
        let (mt, my) = (t.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
        let sxy: f64 = t.iter().zip(&y).map(|(t, y)| (t - mt) * (y - my)).sum();
        let sxx: f64 = t.iter().map(|t| (t - mt) * (t - mt)).sum();
        let slope = sxy / sxx;
        let g = Smoother::new(&t, 1e12).unwrap().apply(&y).unwrap();
        for (a, t) in g.iter().zip(&t) {
            assert!((a - (my + slope * (t - mt))).abs() < 1e-6, "{a}");
        }
    }

    #[test]
    fn drive_s_weight_takes_out_a_sample_to_sample_jitter() {
        // A lidar pose's jitter on a straight drive: the line stays, the
        // jitter goes.
        let t = times(40);
        let y: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(k, t)| 1.5 * t + if k % 2 == 0 { 0.05 } else { -0.05 })
            .collect();
        let g = Smoother::new(&t, 0.8).unwrap().apply(&y).unwrap();
        let worst = g
            .iter()
            .zip(&t)
            .skip(3)
            .take(34)
            .map(|(g, t)| (g - 1.5 * t).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.005, "{worst}");
    }

    #[test]
    fn matches_scipy_s_make_smoothing_spline() {
        // scipy 1.17.1: make_smoothing_spline(t, y, lam=0.8)(t) at
        // t = linspace(0, 2, 40), y = sin(3 t) + 0.1 ((7 k mod 5) - 2).
        let t = times(40);
        let y: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(k, t)| (3.0 * t).sin() + 0.1 * ((k * 7 % 5) as f64 - 2.0))
            .collect();
        let g = Smoother::new(&t, 0.8).unwrap().apply(&y).unwrap();
        let scipy = [
            (0, 0.7845808379950724),
            (10, 0.5300910251084094),
            (20, 0.0283517225518017),
            (39, -0.9475043374822161),
        ];
        for (k, v) in scipy {
            assert!((g[k] - v).abs() < 1e-9, "{k}: {} against {v}", g[k]);
        }
    }

    #[test]
    fn bad_times_or_weights_are_refused() {
        assert!(Smoother::new(&[0.0, 1.0, 1.0], 0.8).is_none());
        assert!(Smoother::new(&[0.0, 1.0, 2.0], -1.0).is_none());
        assert!(Smoother::new(&[0.0, 1.0, 2.0], f64::NAN).is_none());
        let s = Smoother::new(&[0.0, 1.0, 2.0], 0.8).unwrap();
        assert!(s.apply(&[1.0, 2.0]).is_none());
    }
}
