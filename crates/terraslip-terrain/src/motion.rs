//! What the treads did over a window: tread speeds, the yaw rate they
//! command and the steering efficiency the gyro shows (the slip terms of
//! the `full` vibration set).

use terraslip_io::WheelSample;

/// Mean tread speeds over a window, m/s.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SpeedStats {
    /// Mean of (|v_left| + |v_right|) / 2.
    pub speed: f64,
    /// Mean of |v_right - v_left| (turning).
    pub diff: f64,
    /// Yaw rate the treads command without slip, (v_right - v_left) / track width, rad/s.
    pub yaw_rate: f64,
    /// Slope of the mean tread speed over the window, m/s².
    pub accel: f64,
    /// Steering efficiency χ: least-squares slope (through the origin) of
    /// the gyro yaw rate on the commanded yaw rate over the window; the
    /// no-slip value 1 when the window is not excited (see `yaw_excitation`).
    pub yaw_gain: f64,
    /// Share of the gyro yaw-rate energy the fit explains (R², 0..1; 0 when
    /// not excited).
    pub yaw_fit: f64,
    /// RMS of the commanded yaw rate over the window, rad/s: how much
    /// turning there was to measure the steering efficiency from.
    pub yaw_excitation: f64,
    /// Mean of |v_r − v_l| / (|v_l| + |v_r|): 0 driving straight, 1 spinning
    /// in place (the manoeuvre, free of speed).
    pub spin_share: f64,
}

/// Below this RMS commanded yaw rate (rad/s) a window's steering efficiency
/// is not measured (noise and gyro bias would dominate the ratio).
pub const MIN_YAW_EXCITATION: f64 = 0.05;

/// Mean tread speeds of the wheel samples in `[t0, t1]`; the nearest
/// earlier sample when the window holds none (slow encoders).
/// `gyro_at_wheels[k]` is the body yaw rate (gyro_z, rad/s) around wheel
/// sample `k` (empty without a gyro: the steering efficiency stays 1).
pub(crate) fn speed_stats(
    wheels: &[WheelSample],
    gyro_at_wheels: &[f64],
    t0: f64,
    t1: f64,
    track_width: f64,
) -> SpeedStats {
    let lo = wheels.partition_point(|w| w.t < t0);
    let hi = wheels.partition_point(|w| w.t <= t1);
    let (lo, hi) = if hi > lo {
        (lo, hi)
    } else if hi > 0 {
        (hi - 1, hi)
    } else {
        return SpeedStats::default();
    };
    let slice = &wheels[lo..hi];
    let n = slice.len() as f64;
    let mut s = SpeedStats::default();
    let b = if track_width > 1e-3 { track_width } else { 1.0 };
    let tm = slice.iter().map(|w| w.t).sum::<f64>() / n;
    let vm = slice
        .iter()
        .map(|w| 0.5 * (w.v_left + w.v_right))
        .sum::<f64>()
        / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    // Steering efficiency: a slope over the whole window, not a mean of
    // per-sample ratios (those blow up whenever the command nears zero).
    let (mut cmd2, mut cc, mut cg, mut gg) = (0.0, 0.0, 0.0, 0.0);
    for (k, w) in slice.iter().enumerate() {
        s.speed += 0.5 * (w.v_left.abs() + w.v_right.abs());
        s.diff += (w.v_right - w.v_left).abs();
        let cmd = (w.v_right - w.v_left) / b;
        s.yaw_rate += cmd;
        cmd2 += cmd * cmd;
        let sum = w.v_left.abs() + w.v_right.abs();
        if sum > 1e-6 {
            s.spin_share += (w.v_right - w.v_left).abs() / sum;
        }
        sxy += (w.t - tm) * (0.5 * (w.v_left + w.v_right) - vm);
        sxx += (w.t - tm) * (w.t - tm);
        if let Some(&g) = gyro_at_wheels.get(lo + k) {
            cc += cmd * cmd;
            cg += cmd * g;
            gg += g * g;
        }
    }
    s.speed /= n;
    s.diff /= n;
    s.yaw_rate /= n;
    s.spin_share /= n;
    s.accel = if sxx > 1e-9 { sxy / sxx } else { 0.0 };
    s.yaw_excitation = (cmd2 / n).sqrt();
    if s.yaw_excitation >= MIN_YAW_EXCITATION && cc > 0.0 {
        // Clamped: a gain far outside [-1, 2] is a sensor fault, not slip.
        s.yaw_gain = (cg / cc).clamp(-1.0, 2.0);
        s.yaw_fit = if gg > 1e-12 {
            (cg * cg / (cc * gg)).clamp(0.0, 1.0)
        } else {
            0.0
        };
    } else {
        s.yaw_gain = 1.0;
        s.yaw_fit = 0.0;
    }
    s
}

/// The mean gyro_z (rad/s) of the IMU samples around each wheel sample:
/// half-way to the previous and to the next wheel sample, so that the
/// two streams are compared at the same instants; the nearest IMU sample
/// when none falls in that span. Empty when the log has no gyro_z.
pub(crate) fn gyro_at_wheels(imu_t: &[f64], gyro_z: &[f64], wheels: &[WheelSample]) -> Vec<f64> {
    if gyro_z.is_empty() || gyro_z.len() != imu_t.len() {
        return Vec::new();
    }
    let mut out = Vec::with_capacity(wheels.len());
    for (k, w) in wheels.iter().enumerate() {
        let prev = if k > 0 { wheels[k - 1].t } else { w.t };
        let next = wheels.get(k + 1).map_or(w.t, |n| n.t);
        let a = 0.5 * (prev + w.t);
        let b = 0.5 * (w.t + next);
        let lo = imu_t.partition_point(|&t| t < a);
        let hi = imu_t.partition_point(|&t| t <= b);
        let g = if hi > lo {
            gyro_z[lo..hi].iter().sum::<f64>() / (hi - lo) as f64
        } else {
            let i = lo.min(gyro_z.len() - 1);
            gyro_z[i]
        };
        out.push(g);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wheel(t: f64, v_left: f64, v_right: f64) -> WheelSample {
        WheelSample { t, v_left, v_right }
    }

    #[test]
    fn steering_efficiency_is_the_slope_of_gyro_on_command() {
        let b = 0.5;
        // Turning at varying rates; the body turns at 0.6x the command,
        // plus a small gyro bias.
        let wheels: Vec<WheelSample> = (0..60)
            .map(|k| {
                let d = 0.1 + 0.1 * (k as f64 * 0.3).sin();
                wheel(k as f64 * 0.1, 0.3 - d, 0.3 + d)
            })
            .collect();
        let imu_t: Vec<f64> = (0..600).map(|i| i as f64 * 0.01).collect();
        let gyro: Vec<f64> = imu_t
            .iter()
            .map(|&t| {
                let k = (t / 0.1).round();
                0.6 * 2.0 * (0.1 + 0.1 * (k * 0.3).sin()) / b + 0.002
            })
            .collect();
        let g = gyro_at_wheels(&imu_t, &gyro, &wheels);
        assert_eq!(g.len(), wheels.len());
        let s = speed_stats(&wheels, &g, 0.0, 6.0, b);
        assert!((s.yaw_gain - 0.6).abs() < 0.02, "gain {}", s.yaw_gain);
        assert!(s.yaw_fit > 0.99, "fit {}", s.yaw_fit);
        assert!(s.yaw_excitation > MIN_YAW_EXCITATION);
        assert!(s.spin_share > 0.1 && s.spin_share < 0.9, "{}", s.spin_share);

        // Straight: nothing to measure, neutral gain and no fit.
        let straight: Vec<WheelSample> = (0..60).map(|k| wheel(k as f64 * 0.1, 0.5, 0.5)).collect();
        let g = gyro_at_wheels(&imu_t, &gyro, &straight);
        let s = speed_stats(&straight, &g, 0.0, 6.0, b);
        assert_eq!((s.yaw_gain, s.yaw_fit, s.spin_share), (1.0, 0.0, 0.0));
        // Spinning in place on a surface that does not let the body turn.
        let spin: Vec<WheelSample> = (0..60).map(|k| wheel(k as f64 * 0.1, -0.2, 0.2)).collect();
        let still = vec![0.0; imu_t.len()];
        let g = gyro_at_wheels(&imu_t, &still, &spin);
        let s = speed_stats(&spin, &g, 0.0, 6.0, b);
        assert!(s.yaw_gain.abs() < 1e-12 && (s.spin_share - 1.0).abs() < 1e-12);
        // No gyro: the gain stays neutral rather than reading as full slip.
        let s = speed_stats(&spin, &[], 0.0, 6.0, b);
        assert_eq!((s.yaw_gain, s.yaw_fit), (1.0, 0.0));
        assert!((s.yaw_excitation - 0.8).abs() < 1e-12);
        assert!(gyro_at_wheels(&imu_t, &[], &spin).is_empty());
    }
}
