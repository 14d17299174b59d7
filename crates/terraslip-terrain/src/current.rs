//! Drive-motor current features of a window (`wheels.csv` columns
//! `current_left,current_right`, A).
//!
//! The current a motor needs to hold a tread speed is the terrain's
//! resistance: sand and snow pull harder than flooring or asphalt, ice
//! slips with little current. Per window:
//!
//! - `current_log_mean`: ln of the mean motor current ((|I_l| + |I_r|) / 2);
//!   amplitude-like, so the learnt speed normalisation maps it to the
//!   reference tread speed (the current per unit tread speed, with a slope
//!   on ln v learnt within terrains and the speed floor chosen by inner
//!   cross-validation);
//! - `current_log_dev`: ln of the standard deviation of the mean current
//!   (its spectral power apart from DC);
//! - `current_log_transient`: ln of the mean |dI/dt| between samples
//!   (transients at speed changes, wheel hop);
//! - `current_hf_share`: the share of that power at high frequency,
//!   `Σ(ΔI)² / (2 Σ(I − Ī)²)` (1 − lag-1 autocorrelation: 0 for a slow
//!   drift, 1 for white noise, up to 2 for alternation);
//! - `current_turn_share`: the left/right difference in turns,
//!   `mean((|I_r| − |I_l|)·sign(v_r − v_l)) / mean(|I_l| + |I_r|)`: how much
//!   more the outer track pulls (0 straight or when both pull alike).
//!
//! Samples in `[t0, t1]` are used; the nearest earlier one when the window
//! holds none (at 6.5 Hz a 1 s window holds about six).
//!
//! The current also depends on how the robot is driven: a skid-steer
//! robot's turning resistance grows with the turn, and its treads pull
//! harder spinning in place than driving straight. [`CurrentBaseline`] is
//! what the robot draws at a tread speed and turn on an average ground,
//! fitted once per robot over the training windows of *every* terrain;
//! the feature [`EXCESS_FEATURE`] is a window's ln mean current minus that
//! baseline: the ground's share of the current, comparable between a
//! gentle and a hard spin, or a slow and a fast drive.

use serde::{Deserialize, Serialize};
use terraslip_io::{MotorCurrent, WheelSample};

/// Names of the current features, in order.
pub const FEATURE_NAMES: [&str; 5] = [
    "current_log_mean",
    "current_log_dev",
    "current_log_transient",
    "current_hf_share",
    "current_turn_share",
];

/// Name of the current in excess of the robot's baseline at the window's
/// speed and turn (ln A − ln A; see [`CurrentBaseline`]).
pub const EXCESS_FEATURE: &str = "current_excess";

/// The ln mean motor current the robot draws at a tread speed and turn,
/// over all grounds: `c0 + c1·ln(max(v, v_min) / v_ref) + c2·s + c3·e`,
/// v the mean tread speed (m/s), s the spin share (0 straight, 1 spinning
/// in place), e the RMS commanded yaw rate (rad/s), least squares over
/// the training windows of every terrain (one intercept for the robot,
/// not one per terrain, unlike the speed slopes of
/// [`crate::speed_norm`]). Applied by the speed normalisation, which
/// holds it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurrentBaseline {
    /// Index of [`EXCESS_FEATURE`] in the feature vector.
    pub index: usize,
    /// Index of the spin share feature.
    pub spin_index: usize,
    /// Index of the turning excitation feature (RMS commanded yaw rate).
    pub turn_index: usize,
    /// `[c0 (ln A), c1 (per unit ln v), c2 (per unit spin share), c3 (per rad/s)]`.
    pub coefficients: [f64; 4],
}

impl CurrentBaseline {
    /// The feature names the baseline reads: [`EXCESS_FEATURE`], the spin
    /// share and the turning excitation.
    const INPUTS: [&'static str; 3] = [EXCESS_FEATURE, "spin_share", "yaw_excitation"];

    /// Fits the baseline on the training windows `x` (features `names`;
    /// speed at `speed_index`, m/s); `None` when the features lack one of
    /// [`Self::INPUTS`] or the windows do not determine the four
    /// coefficients. Windows with a non-finite feature are left out.
    pub fn fit(
        x: &[Vec<f64>],
        names: &[String],
        speed_index: usize,
        v_ref: f64,
        v_min: f64,
    ) -> Option<Self> {
        let at = |n: &str| names.iter().position(|m| m == n);
        let [index, spin_index, turn_index] = Self::INPUTS.map(at);
        let (index, spin_index, turn_index) = (index?, spin_index?, turn_index?);
        let mut zz = nalgebra::Matrix4::<f64>::zeros();
        let mut zy = nalgebra::Vector4::<f64>::zeros();
        for row in x {
            if row.len() != names.len() || !row.iter().all(|f| f.is_finite()) {
                continue;
            }
            let u = (row[speed_index].max(v_min) / v_ref).ln();
            let z = nalgebra::Vector4::new(1.0, u, row[spin_index], row[turn_index]);
            zz += z * z.transpose();
            zy += z * row[index];
        }
        // A small ridge: a training set that never turns (or never spins)
        // leaves that coefficient at 0 rather than undetermined.
        zz += nalgebra::Matrix4::identity() * 1e-6;
        let c = zz.cholesky()?.solve(&zy);
        let coefficients = [c[0], c[1], c[2], c[3]];
        coefficients.iter().all(|c| c.is_finite()).then_some(Self {
            index,
            spin_index,
            turn_index,
            coefficients,
        })
    }

    /// Subtracts the baseline from [`EXCESS_FEATURE`] in place; `u` is
    /// ln(max(v, v_min) / v_ref) of the window.
    pub fn apply(&self, x: &mut [f64], u: f64) {
        let c = &self.coefficients;
        let (Some(&s), Some(&e)) = (x.get(self.spin_index), x.get(self.turn_index)) else {
            return;
        };
        if let Some(f) = x.get_mut(self.index) {
            *f -= c[0] + c[1] * u + c[2] * s + c[3] * e;
        }
    }

    /// Consistency with a model's feature list (for loading).
    pub fn check(&self, names: &[String]) -> std::result::Result<(), String> {
        let name = |i: usize| names.get(i).map(String::as_str);
        if [self.index, self.spin_index, self.turn_index].map(name) != Self::INPUTS.map(Some) {
            return Err("the current baseline does not match the feature list".into());
        }
        if self.coefficients.iter().any(|c| !c.is_finite()) {
            return Err("the current baseline has a non-finite coefficient".into());
        }
        Ok(())
    }
}

/// Added to currents (A) and rates (A/s) before their logarithm, so that a
/// motor at rest gives a finite feature.
const CURRENT_FLOOR: f64 = 0.05;

/// The current features of the samples in `[t0, t1]`; `None` when the log
/// has no current at or before `t1`.
pub fn features(
    currents: &[MotorCurrent],
    wheels: &[WheelSample],
    t0: f64,
    t1: f64,
) -> Option<[f64; 5]> {
    let lo = currents.partition_point(|c| c.t < t0);
    let hi = currents.partition_point(|c| c.t <= t1);
    let (lo, hi) = if hi > lo {
        (lo, hi)
    } else if hi > 0 {
        (hi - 1, hi)
    } else {
        return None;
    };
    let s = &currents[lo..hi];
    let n = s.len() as f64;
    let level = |c: &MotorCurrent| 0.5 * (c.left.abs() + c.right.abs());
    let mean = s.iter().map(level).sum::<f64>() / n;
    let (mut var, mut diff2, mut rate, mut turn) = (0.0, 0.0, 0.0, 0.0);
    let mut k = wheels.partition_point(|w| w.t < s[0].t);
    for (i, c) in s.iter().enumerate() {
        let d = level(c) - mean;
        var += d * d;
        if i > 0 {
            let dl = level(c) - level(&s[i - 1]);
            diff2 += dl * dl;
            let dt = c.t - s[i - 1].t;
            if dt > 1e-9 {
                rate += dl.abs() / dt;
            }
        }
        // The wheel sample at (or nearest before) the current sample.
        while k + 1 < wheels.len() && wheels[k + 1].t <= c.t {
            k += 1;
        }
        if let Some(w) = wheels.get(k) {
            let dv = w.v_right - w.v_left;
            if dv.abs() > 1e-6 {
                turn += (c.right.abs() - c.left.abs()) * dv.signum();
            }
        }
    }
    let pairs = (n - 1.0).max(1.0);
    let log = |x: f64| (x + CURRENT_FLOOR).ln();
    Some([
        log(mean),
        log((var / n).sqrt()),
        log(rate / pairs),
        if var > 1e-12 {
            (diff2 / (2.0 * var) * n / pairs).min(2.0)
        } else {
            0.0
        },
        turn / n / (2.0 * mean + CURRENT_FLOOR),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cur(t: f64, left: f64, right: f64) -> MotorCurrent {
        MotorCurrent { t, left, right }
    }

    #[test]
    fn steady_current_has_no_power_and_turns_show_the_outer_track() {
        let straight: Vec<WheelSample> = (0..20)
            .map(|k| WheelSample {
                t: k as f64 * 0.15,
                v_left: 0.5,
                v_right: 0.5,
            })
            .collect();
        let c: Vec<MotorCurrent> = (0..20).map(|k| cur(k as f64 * 0.15, 4.0, 6.0)).collect();
        let f = features(&c, &straight, 0.0, 3.0).unwrap();
        assert!((f[0] - (5.0 + CURRENT_FLOOR).ln()).abs() < 1e-12);
        assert!((f[1] - CURRENT_FLOOR.ln()).abs() < 1e-12);
        assert_eq!((f[3], f[4]), (0.0, 0.0));
        // Turning left (v_r > v_l): the right (outer) track pulls more.
        let left_turn: Vec<WheelSample> = straight
            .iter()
            .map(|w| WheelSample {
                v_left: 0.1,
                v_right: 0.6,
                ..*w
            })
            .collect();
        let f = features(&c, &left_turn, 0.0, 3.0).unwrap();
        assert!(
            (f[4] - 2.0 / (10.0 + CURRENT_FLOOR)).abs() < 1e-12,
            "{}",
            f[4]
        );
        // Turning right with the same currents: the inner track pulls more.
        let right_turn: Vec<WheelSample> = left_turn
            .iter()
            .map(|w| WheelSample {
                v_left: 0.6,
                v_right: 0.1,
                ..*w
            })
            .collect();
        assert!(features(&c, &right_turn, 0.0, 3.0).unwrap()[4] < 0.0);
    }

    #[test]
    fn alternating_current_is_high_frequency_and_a_drift_is_not() {
        let w: Vec<WheelSample> = Vec::new();
        let alt: Vec<MotorCurrent> = (0..40)
            .map(|k| {
                let a = if k % 2 == 0 { 3.0 } else { 5.0 };
                cur(k as f64 * 0.15, a, a)
            })
            .collect();
        let drift: Vec<MotorCurrent> = (0..40)
            .map(|k| {
                cur(
                    k as f64 * 0.15,
                    3.0 + 0.05 * k as f64,
                    3.0 + 0.05 * k as f64,
                )
            })
            .collect();
        let fa = features(&alt, &w, 0.0, 6.0).unwrap();
        let fd = features(&drift, &w, 0.0, 6.0).unwrap();
        assert!(fa[3] > 1.8 && fd[3] < 0.05, "{} {}", fa[3], fd[3]);
        assert!(fa[2] > fd[2]);
        // No current at or before the window: nothing to say.
        assert!(features(&alt, &w, -5.0, -1.0).is_none());
        assert!(features(&[], &w, 0.0, 6.0).is_none());
        // A window between samples takes the last one before it.
        assert!(features(&alt, &w, 0.16, 0.20).is_some());
    }

    #[test]
    fn the_baseline_is_the_robot_not_the_ground() {
        let names: Vec<String> = [
            "tread_speed",
            "spin_share",
            "yaw_excitation",
            EXCESS_FEATURE,
        ]
        .map(String::from)
        .to_vec();
        let (v_ref, v_min) = (0.5, 0.1);
        // Two grounds, 0.3 apart in ln current, each driven at every speed
        // and turn: the robot draws 1 + 0.4 ln(v / v_ref) + 0.8 s + 0.5 e.
        let law = |v: f64, s: f64, e: f64| 1.0 + 0.4 * (v / v_ref).ln() + 0.8 * s + 0.5 * e;
        let mut x = Vec::new();
        for ground in [-0.15, 0.15] {
            for v in [0.1, 0.2, 0.4, 0.8] {
                for s in [0.0, 0.5, 1.0] {
                    for e in [0.0, 0.3, 0.9] {
                        x.push(vec![v, s, e, law(v, s, e) + ground]);
                    }
                }
            }
        }
        // A broken window is left out of the fit, not allowed to spoil it.
        x.push(vec![0.3, 0.0, 0.0, f64::NAN]);
        let b = CurrentBaseline::fit(&x, &names, 0, v_ref, v_min).unwrap();
        for (got, want) in b.coefficients.iter().zip([1.0, 0.4, 0.8, 0.5]) {
            assert!((got - want).abs() < 1e-4, "{:?}", b.coefficients);
        }
        // What is left is the ground: the same for a gentle spin and a
        // fast straight drive on it.
        let mut spin = vec![0.1, 1.0, 0.4, law(0.1, 1.0, 0.4) + 0.15];
        let mut fast = vec![0.8, 0.0, 0.0, law(0.8, 0.0, 0.0) + 0.15];
        b.apply(&mut spin, (0.1f64 / v_ref).ln());
        b.apply(&mut fast, (0.8f64 / v_ref).ln());
        assert!((spin[3] - 0.15).abs() < 1e-3 && (fast[3] - 0.15).abs() < 1e-3);
        assert!(b.check(&names).is_ok());
        let mut other = names.clone();
        other.swap(1, 2);
        assert!(b.check(&other).is_err());
        // Without the turning features there is no baseline to fit.
        assert!(CurrentBaseline::fit(&x, &names[..1], 0, v_ref, v_min).is_none());
    }
}
