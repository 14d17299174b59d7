//! How sure a simulated terrain classifier is of each verdict: the
//! confidences the BorealTC terrain model gave on runs it never saw, right
//! verdicts and misreads apart, drawn as a slowly varying sequence (the
//! windows of a run overlap, so consecutive verdicts are about as sure as
//! each other).
//!
//! Measured on the 3 265 verdicts at or above "unknown" (0.5) of the 46
//! BorealTC runs, each run classified by the model trained without its
//! outer fold (`terrain-trust --borealtc ... --evidence-cache`, the
//! defaults): 3 042 right, 223 misread. Right verdicts: median 0.9995,
//! 8 % below 0.8; misreads: median 0.65, 30 % at 0.8 or above, 16 % at 0.9
//! or above. Between consecutive frames (0.5 s apart) the normal scores of
//! the confidences correlate at 0.95.

use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// Confidence of a right verdict at the 0, 5, ..., 100 % points of its
/// distribution (BorealTC, outer folds).
pub const RIGHT: [f64; 21] = [
    0.5017, 0.5953, 0.8703, 0.953, 0.979, 0.9889, 0.9949, 0.9975, 0.9987, 0.9992, 0.9995, 0.9997,
    0.9998, 0.9998, 0.9999, 0.9999, 0.9999, 1.0, 1.0, 1.0, 1.0,
];

/// The same for a misread verdict (the confidence it gives the wrong
/// terrain).
pub const MISREAD: [f64; 21] = [
    0.5048, 0.5206, 0.5477, 0.5555, 0.5695, 0.5793, 0.5911, 0.5991, 0.6029, 0.639, 0.6507, 0.6757,
    0.7025, 0.7474, 0.798, 0.8432, 0.881, 0.9058, 0.941, 0.9781, 0.9976,
];

/// Correlation of consecutive verdicts' normal scores (frames 0.5 s apart).
pub const CORRELATION: f64 = 0.95;

/// Largest confidence handed out: the rest of the classes keep a little
/// probability.
const MAX_CONFIDENCE: f64 = 0.999;

/// The value at probability `u` (0..1) of a distribution given by its
/// 5 % points, linear in between.
fn at(points: &[f64; 21], u: f64) -> f64 {
    let x = u.clamp(0.0, 1.0) * 20.0;
    let i = (x.floor() as usize).min(19);
    let f = x - i as f64;
    points[i] + f * (points[i + 1] - points[i])
}

/// Standard normal distribution function.
fn phi(z: f64) -> f64 {
    0.5 * libm::erfc(-z / std::f64::consts::SQRT_2)
}

/// A sequence of verdict confidences: a standard normal AR(1) with
/// [`CORRELATION`], mapped through the right or misread distribution.
pub struct Sureness {
    rng: StdRng,
    z: f64,
}

impl Sureness {
    pub fn new(seed: u64) -> Self {
        let mut rng = StdRng::seed_from_u64(seed);
        let z = StandardNormal.sample(&mut rng);
        Self { rng, z }
    }

    /// The next verdict's confidence; `right` whether it reads the ground
    /// right.
    pub fn next(&mut self, right: bool) -> f64 {
        let e: f64 = StandardNormal.sample(&mut self.rng);
        let r = CORRELATION;
        self.z = r * self.z + (1.0 - r * r).sqrt() * e;
        let u = phi(self.z);
        at(if right { &RIGHT } else { &MISREAD }, u).min(MAX_CONFIDENCE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drawn_confidences_follow_the_measured_distributions() {
        let mut s = Sureness::new(3);
        let n = 20_000;
        let share = |v: &[f64], c: f64| v.iter().filter(|x| **x >= c).count() as f64 / n as f64;
        let right: Vec<f64> = (0..n).map(|_| s.next(true)).collect();
        let wrong: Vec<f64> = (0..n).map(|_| s.next(false)).collect();
        assert!(
            (share(&right, 0.8) - 0.92).abs() < 0.05,
            "{}",
            share(&right, 0.8)
        );
        assert!(
            (share(&wrong, 0.8) - 0.3).abs() < 0.08,
            "{}",
            share(&wrong, 0.8)
        );
        assert!(right.iter().chain(&wrong).all(|c| (0.5..1.0).contains(c)));
        // Consecutive verdicts are about as sure as each other.
        let steps = wrong
            .windows(2)
            .filter(|w| (w[1] - w[0]).abs() > 0.2)
            .count();
        assert!(steps < n / 20, "{steps}");
    }
}
