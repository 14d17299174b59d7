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

use terraslip_io::{MotorCurrent, WheelSample};

/// Names of the current features, in order.
pub const FEATURE_NAMES: [&str; 5] = [
    "current_log_mean",
    "current_log_dev",
    "current_log_transient",
    "current_hf_share",
    "current_turn_share",
];

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
}
