//! The papers' innovation-adaptive gain (lv2019 eq. 12, wang2018): the
//! Kalman gain computed with the mean outer product of the last
//! innovations in place of the predicted innovation covariance. Only the
//! `ta-iekf` preset uses it; the default gain is the textbook one.

use nalgebra::{Matrix3, Vector3};

use super::MAX_WINDOW;

/// The last innovations, for the papers' innovation-adaptive gain.
#[derive(Debug, Clone)]
pub(super) struct InnovationWindow {
    nu: [Vector3<f64>; MAX_WINDOW],
    mask: [[bool; 3]; MAX_WINDOW],
    len: usize,
    next: usize,
}

impl InnovationWindow {
    pub(super) fn new() -> Self {
        Self {
            nu: [Vector3::zeros(); MAX_WINDOW],
            mask: [[false; 3]; MAX_WINDOW],
            len: 0,
            next: 0,
        }
    }

    pub(super) fn push(&mut self, nu: &Vector3<f64>, mask: &[bool; 3]) {
        self.nu[self.next] = *nu;
        self.mask[self.next] = *mask;
        self.next = (self.next + 1) % MAX_WINDOW;
        self.len = (self.len + 1).min(MAX_WINDOW);
    }

    /// lv2019 eq. 12: the mean of `nu nu'` over the last `window`
    /// innovations, per entry over those where both components were
    /// measured; rows not measured now get a unit entry. `None` until the
    /// window is full (a rank-deficient mean has no inverse; the paper does
    /// not say how it starts, the textbook `S` is used meanwhile).
    pub(super) fn covariance(&self, window: usize, used: &[bool; 3]) -> Option<Matrix3<f64>> {
        if self.len < window {
            return None;
        }
        let mut sum = Matrix3::<f64>::zeros();
        let mut cnt = Matrix3::<f64>::zeros();
        for k in 0..window {
            let idx = (self.next + MAX_WINDOW - 1 - k) % MAX_WINDOW;
            let (v, m) = (&self.nu[idx], &self.mask[idx]);
            for i in 0..3 {
                for j in 0..3 {
                    if m[i] && m[j] {
                        sum[(i, j)] += v[i] * v[j];
                        cnt[(i, j)] += 1.0;
                    }
                }
            }
        }
        let mut D = Matrix3::<f64>::zeros();
        for i in 0..3 {
            for j in 0..3 {
                if used[i] && used[j] && cnt[(i, j)] > 0.0 {
                    D[(i, j)] = sum[(i, j)] / cnt[(i, j)];
                }
            }
            if !used[i] {
                D[(i, i)] = 1.0;
            }
        }
        Some(D)
    }
}
