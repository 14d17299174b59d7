//! Noise learned from the innovations: how noisy the pose fixes are, and
//! how wrong the kinematic model is while driving or turning.
//!
//! A fix's innovation variance is a sum of parts: the state's uncertainty
//! `A`, the sensor's noise `theta_r * r` (its stated or configured variance
//! times a scale), and the model noise added since the previous fix,
//! `theta_q * b`: for the heading `b = sum(omega^2 dt)` (the yaw rate is
//! wrong by a fraction that varies with the ground under each turn), for the
//! position `b = sum(v^2 dt)` (likewise the speed). The sensor part is the
//! same whatever the motion, the model part grows with it, so the data can
//! tell them apart.
//!
//! Covariance matching by regression: `E[nu^2] = A + theta_r r + theta_q b`
//! is fitted by exponentially forgetting weighted least squares (weights
//! `1 / S^2`, the inverse variance of `nu^2`), with `theta >= 0` and a
//! prior worth a few fixes. `nu^2` is capped at the gate so that one outlier counts a gate's
//! worth and no more; gated fixes still count, so a noise learned too small
//! cannot lock out the fixes that would correct it. Forgetting lowers the
//! weight of old evidence, never its value.

use nalgebra::{Matrix2, Vector2};

/// A sample weighs at most this many times the running mean weight.
const WEIGHT_CAP: f64 = 100.0;
/// Rate of the running mean of the weights, per sample.
const MEAN_RATE: f64 = 0.01;

/// Weight (fixes) below which forgetting stops.
const MIN_WEIGHT: f64 = 10.0;

/// Intensities kept within `[1e-8, 1e8]` times their start.
const LIMIT: f64 = 1e8;

/// The sensor scale and model intensity of one kind of fix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct NoiseFit {
    /// Normal equations of the data.
    m: Matrix2<f64>,
    v: Vector2<f64>,
    /// Running mean of the sample weights.
    mean_weight: f64,
    /// Whether each part's prior has been placed among the data yet.
    placed: [bool; 2],
    /// Weight of the priors, in fixes.
    weight0: Vector2<f64>,
    start: Vector2<f64>,
    theta: Vector2<f64>,
    /// Weight of the data, in fixes.
    count: f64,
    learns: bool,
}

impl NoiseFit {
    /// Starts at sensor scale `sensor` (worth `sensor_weight` fixes) and
    /// model intensity `model` (worth `model_weight` fixes).
    pub(super) fn new(sensor: f64, sensor_weight: f64, model: f64, model_weight: f64) -> Self {
        let start = Vector2::new(sensor.max(1e-30), model.max(1e-30));
        Self {
            m: Matrix2::zeros(),
            v: Vector2::zeros(),
            mean_weight: 0.0,
            placed: [false; 2],
            weight0: Vector2::new(sensor_weight, model_weight),
            start,
            theta: start,
            count: 0.0,
            learns: true,
        }
    }

    /// A fit that stays at its start (no learning).
    pub(super) fn fixed(sensor: f64, model: f64) -> Self {
        Self {
            learns: false,
            ..Self::new(sensor, 1.0, model, 1.0)
        }
    }

    /// Sensor scale (times the stated variance).
    pub(super) fn sensor(&self) -> f64 {
        self.theta[0]
    }

    /// Model intensity.
    pub(super) fn model(&self) -> f64 {
        self.theta[1]
    }

    /// Evidence behind the fit, fixes (priors included; infinite for a
    /// fit that does not learn: its noise is as stated).
    pub(super) fn count(&self) -> f64 {
        if !self.learns {
            f64::INFINITY
        } else if self.placed[0] {
            self.count
        } else {
            self.weight0[0]
        }
    }

    /// Whether the fit learns.
    pub(super) fn learns(&self) -> bool {
        self.learns
    }

    /// Replaces the sensor prior's weight (a stated std is trusted more
    /// than a configured guess). Before the first sample only.
    pub(super) fn set_sensor_weight(&mut self, weight: f64) {
        self.weight0[0] = weight;
    }

    /// Decays the data's weight by `keep` (in [0, 1]), never below
    /// [`MIN_WEIGHT`] fixes' worth: what was learned is kept until new
    /// evidence replaces it.
    pub(super) fn forget(&mut self, keep: f64) {
        if self.learns && self.count > MIN_WEIGHT {
            let k = keep.clamp(0.0, 1.0).max(MIN_WEIGHT / self.count);
            self.m *= k;
            self.v *= k;
            self.count *= k;
        }
    }

    /// Adds one innovation dimension: `nu2` its (capped) square, `s` its
    /// predicted variance, `r` the stated sensor variance and `b` the model
    /// basis since the previous fix.
    pub(super) fn add(&mut self, nu2: f64, s: f64, r: f64, b: f64) {
        if !(self.learns && s > 0.0 && nu2.is_finite() && r > 0.0 && b >= 0.0) {
            return;
        }
        let x = Vector2::new(r, b);
        // Weighted by the inverse variance of nu^2 (samples buried under the
        // state's own uncertainty count little), capped at a multiple of
        // the running mean weight so that no transient of the fit can weigh
        // its own samples up.
        let mut w = 1.0 / (s * s);
        if self.mean_weight > 0.0 {
            w = w.min(WEIGHT_CAP * self.mean_weight);
        }
        self.mean_weight = if self.mean_weight > 0.0 {
            (1.0 - MEAN_RATE) * self.mean_weight + MEAN_RATE * w
        } else {
            w
        };
        for k in 0..2 {
            if !self.placed[k] && x[k] > 0.0 {
                // The prior as pseudo-observations of this part alone, as
                // heavy as this sample; they age like data.
                self.placed[k] = true;
                let wk = self.weight0[k] * w * x[k] * x[k];
                self.m[(k, k)] += wk;
                self.v[k] += wk * self.start[k];
                self.count += self.weight0[k];
            }
        }
        // What the other parts of S explain.
        let a = s - self.theta.dot(&x);
        self.m += w * x * x.transpose();
        self.v += w * x * (nu2 - a);
        self.count += 1.0;
        self.solve();
    }

    fn solve(&mut self) {
        let mut m = self.m;
        let mut v = self.v;
        for k in 0..2 {
            if m[(k, k)] <= 0.0 {
                // Nothing about this part yet: hold it at its start.
                m[(k, k)] = 1.0;
                v[k] = self.start[k];
            }
        }
        let mut theta = m.try_inverse().map_or(self.theta, |inv| inv * v);
        // Non-negative: a part fitted below its floor is held there and the
        // other is fitted alone.
        for k in 0..2 {
            let floor = self.start[k] / LIMIT;
            if !(theta[k] >= floor) {
                let o = 1 - k;
                theta[k] = floor;
                theta[o] = (v[o] - m[(o, k)] * floor) / m[(o, o)];
            }
        }
        for k in 0..2 {
            theta[k] = theta[k].clamp(self.start[k] / LIMIT, self.start[k] * LIMIT);
        }
        if theta.iter().all(|v| v.is_finite()) {
            self.theta = theta;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separates_sensor_noise_from_model_noise() {
        // Innovations whose variance is 0.01 + 0.04 b, with b the model
        // basis of each fix (turning between fixes, or none), starting far
        // from both.
        let mut rng = crate::rng::SplitMix64::new(3);
        let mut fit = NoiseFit::new(1.0, 1e-3, 1e-4, 1.0);
        for i in 0..5_000 {
            let b = if i % 3 == 0 { 0.0 } else { 2.0 * rng.uniform() };
            let var = 0.01 + 0.04 * b;
            let nu = var.sqrt() * rng.normal();
            let s = fit.sensor() + fit.model() * b;
            fit.add(nu * nu, s, 1.0, b);
            fit.forget(0.999);
        }
        assert!((fit.sensor() / 0.01 - 1.0).abs() < 0.15, "{}", fit.sensor());
        assert!((fit.model() / 0.04 - 1.0).abs() < 0.15, "{}", fit.model());
    }

    #[test]
    fn learns_a_sensor_far_from_its_guess_at_once() {
        let mut rng = crate::rng::SplitMix64::new(5);
        let mut fit = NoiseFit::new(1.0, 1e-3, 1e-3, 1.0);
        for _ in 0..30 {
            let nu = 0.03 * rng.normal();
            let s = fit.sensor();
            fit.add(nu * nu, s, 1.0, 0.0);
        }
        assert!(fit.sensor() < 3.0 * 0.03f64.powi(2), "{}", fit.sensor());
        assert_eq!(fit.model(), 1e-3);
    }

    #[test]
    fn forgetting_follows_a_sensor_that_changes() {
        let mut fit = NoiseFit::new(1.0, 2.0, 1e-3, 1.0);
        for _ in 0..500 {
            fit.add(100.0, fit.sensor(), 1.0, 0.0);
            fit.forget(0.99);
        }
        assert!(fit.sensor() > 50.0, "{}", fit.sensor());
        for _ in 0..500 {
            fit.forget(0.9);
        }
        assert!(fit.sensor() > 50.0, "{}", fit.sensor());
        for _ in 0..1000 {
            fit.add(0.01, fit.sensor(), 1.0, 0.0);
            fit.forget(0.99);
        }
        assert!(fit.sensor() < 0.02, "{}", fit.sensor());
        let f = NoiseFit::fixed(2.0, 0.5);
        assert_eq!((f.sensor(), f.model()), (2.0, 0.5));
    }
}
