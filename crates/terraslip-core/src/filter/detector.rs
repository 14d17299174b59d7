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
pub const MAX_CHANGE_WINDOW: usize = 32;

/// Each normalised innovation entry is clipped to +-this before averaging.
const CLIP: f64 = 3.0;

/// A window of normalised innovations of one part (position or heading).
#[derive(Debug, Clone, Copy)]
pub(super) struct Detector {
    z: [[f64; 2]; MAX_CHANGE_WINDOW],
    len: usize,
    next: usize,
}

impl Detector {
    pub(super) const fn new() -> Self {
        Self {
            z: [[0.0; 2]; MAX_CHANGE_WINDOW],
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

    /// Adds a normalised innovation (`dims` = 1 or 2 entries of `z`) and
    /// returns the statistic `n |mean|^2` over the last `window` fixes, or
    /// `None` until the window is full.
    pub(super) fn push(&mut self, z: [f64; 2], dims: usize, window: usize) -> Option<f64> {
        if window == 0 {
            return None;
        }
        let window = window.min(MAX_CHANGE_WINDOW);
        let mut c = [0.0; 2];
        for k in 0..dims {
            c[k] = z[k].clamp(-CLIP, CLIP);
        }
        self.z[self.next] = c;
        self.next = (self.next + 1) % MAX_CHANGE_WINDOW;
        self.len = (self.len + 1).min(MAX_CHANGE_WINDOW);
        if self.len < window {
            return None;
        }
        let mut sum = [0.0; 2];
        for i in 0..window {
            let idx = (self.next + MAX_CHANGE_WINDOW - 1 - i) % MAX_CHANGE_WINDOW;
            sum[0] += self.z[idx][0];
            sum[1] += self.z[idx][1];
        }
        let n = window as f64;
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
        for z in [0.3, -0.5, 40.0, 0.2, -0.1] {
            stat = d.push([z, 0.0], 1, 5);
        }
        assert!(stat.unwrap() < 10.8, "{stat:?}");
        let mut d = Detector::new();
        for _ in 0..5 {
            stat = d.push([2.5, 0.0], 1, 5);
        }
        assert!(stat.unwrap() > 10.8, "{stat:?}");
    }

    #[test]
    fn white_noise_rarely_fires() {
        let mut rng = crate::rng::SplitMix64::new(7);
        let mut d = Detector::new();
        let (mut fired, mut tested) = (0, 0);
        for _ in 0..20_000 {
            if let Some(s) = d.push([rng.normal(), rng.normal()], 2, 5) {
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
