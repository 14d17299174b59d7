//! Slip-change detector: a change of ground shows in the innovations as a
//! run of one sign, sensor noise as innovations of either sign.
//!
//! The normalised innovations `z = L^-1 nu` (`L L' = S`) of a consistent
//! filter are white with unit variance. Over the last `n` fixes their mean
//! `m` has covariance `I / n`, so `n |m|^2` is chi-square with as many
//! degrees of freedom as the part has (position 2, heading 1). Each entry is
//! clipped to `CLIP` first, so that one outlier (a multipath jump) cannot
//! fire the detector on its own however large it is: only a run can.

/// Largest window (fixes).
pub const MAX_CHANGE_WINDOW: usize = 128;

/// Fewest fixes a test uses.
const MIN_FIXES: usize = 4;

/// Each normalised innovation entry is clipped to +-this before averaging.
const CLIP: f64 = 3.0;

/// A window of normalised innovations of one part (position or heading).
#[derive(Debug, Clone, Copy)]
pub(super) struct Detector {
    z: [[f64; 2]; MAX_CHANGE_WINDOW],
    t: [f64; MAX_CHANGE_WINDOW],
    len: usize,
    next: usize,
}

impl Detector {
    pub(super) const fn new() -> Self {
        Self {
            z: [[0.0; 2]; MAX_CHANGE_WINDOW],
            t: [0.0; MAX_CHANGE_WINDOW],
            len: 0,
            next: 0,
        }
    }

    /// Forgets everything (after a reset: the old innovations no longer
    /// describe the model).
    pub(super) fn clear(&mut self) {
        self.len = 0;
        self.next = 0;
    }

    /// Adds the normalised innovation of a fix at `t` (s; `dims` = 1 or 2
    /// entries of `z`) and returns the statistic `n |mean|^2` over the
    /// fixes of the last `window` seconds (at most [`MAX_CHANGE_WINDOW`] of
    /// them), or `None` until `MIN_FIXES` fixes span the window.
    pub(super) fn push(&mut self, t: f64, z: [f64; 2], dims: usize, window: f64) -> Option<f64> {
        if !(window > 0.0) {
            return None;
        }
        let mut c = [0.0; 2];
        for k in 0..dims {
            c[k] = z[k].clamp(-CLIP, CLIP);
        }
        self.z[self.next] = c;
        self.t[self.next] = t;
        self.next = (self.next + 1) % MAX_CHANGE_WINDOW;
        self.len = (self.len + 1).min(MAX_CHANGE_WINDOW);
        let mut sum = [0.0; 2];
        let mut n = 0usize;
        let mut oldest = t;
        for i in 0..self.len {
            let idx = (self.next + MAX_CHANGE_WINDOW - 1 - i) % MAX_CHANGE_WINDOW;
            if t - self.t[idx] > window {
                break;
            }
            sum[0] += self.z[idx][0];
            sum[1] += self.z[idx][1];
            oldest = self.t[idx];
            n += 1;
        }
        // A window not yet covered (a start, a gap) is not tested.
        if n < MIN_FIXES || t - oldest < 0.5 * window {
            return None;
        }
        let n = n as f64;
        Some((sum[0] * sum[0] + sum[1] * sum[1]) / n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_outlier_does_not_fire_but_a_run_does() {
        let mut d = Detector::new();
        let mut stat = None;
        for (k, z) in [0.3, -0.5, 40.0, 0.2, -0.1].into_iter().enumerate() {
            stat = d.push(k as f64, [z, 0.0], 1, 4.0);
        }
        assert!(stat.unwrap() < 10.8, "{stat:?}");
        let mut d = Detector::new();
        for k in 0..5 {
            stat = d.push(k as f64, [2.5, 0.0], 1, 4.0);
        }
        assert!(stat.unwrap() > 10.8, "{stat:?}");
    }

    #[test]
    fn white_noise_rarely_fires() {
        let mut rng = crate::rng::SplitMix64::new(7);
        let mut d = Detector::new();
        let (mut fired, mut tested) = (0, 0);
        for k in 0..20_000 {
            if let Some(s) = d.push(0.2 * k as f64, [rng.normal(), rng.normal()], 2, 5.0) {
                tested += 1;
                if s > 13.8 {
                    fired += 1;
                }
            }
        }
        // 0.1 % nominal; allow sampling scatter.
        assert!(
            (fired as f64) < 0.003 * tested as f64,
            "{fired} of {tested}"
        );
    }
}
