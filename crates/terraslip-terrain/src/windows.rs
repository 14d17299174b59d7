//! The windows of a log: its IMU split into channels, cut into windows
//! every `hop_s`, each with the tread motion and motor currents over it,
//! turned into features by [`VibrationExtractor`].

use terraslip_io::{DriveLog, ImuSample};

use crate::error::{Result, TerrainError};
use crate::motion::{gyro_at_wheels, speed_stats};
use crate::vibration::{VibrationConfig, VibrationExtractor, VibrationFeatureSet, CHANNEL_NAMES};

/// The IMU sample rate of a log (median sample spacing), Hz.
pub fn imu_rate(imu: &[ImuSample]) -> Option<f64> {
    let mut dts: Vec<f64> = imu
        .windows(2)
        .take(2000)
        .map(|w| w[1].t - w[0].t)
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    if dts.is_empty() {
        return None;
    }
    let mid = dts.len() / 2;
    let (_, m, _) = dts.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    Some(1.0 / *m)
}

/// Channel `c` of an IMU sample, in the order of [`CHANNEL_NAMES`].
pub(crate) fn channel(s: &ImuSample, c: usize) -> Option<f64> {
    match c {
        0 => s.accel_x,
        1 => s.accel_y,
        2 => Some(s.accel_z),
        3 => s.gyro_x,
        4 => s.gyro_y,
        _ => s.gyro_z,
    }
}

/// The IMU of a log split into channels, checked against what `cfg` reads.
pub(crate) struct ImuChannels {
    pub t: Vec<f64>,
    pub ch: [Vec<f64>; 6],
    pub rate_hz: f64,
}

impl ImuChannels {
    pub fn from_log(log: &DriveLog, cfg: &VibrationConfig) -> Result<Self> {
        let name = log.name();
        if log.imu.len() < 2 {
            return Err(TerrainError::MissingSource {
                log: name,
                sensor: "imu",
                reason: "imu.csv is missing or has fewer than 2 rows".into(),
            });
        }
        let rate_hz = imu_rate(&log.imu).ok_or_else(|| TerrainError::MissingSource {
            log: name.clone(),
            sensor: "imu",
            reason: "imu.csv timestamps do not advance".into(),
        })?;
        let mut ch: [Vec<f64>; 6] = Default::default();
        let t: Vec<f64> = log.imu.iter().map(|s| s.t).collect();
        for &c in cfg.channel_indices() {
            let mut v = Vec::with_capacity(log.imu.len());
            for (i, s) in log.imu.iter().enumerate() {
                match channel(s, c) {
                    Some(x) if x.is_finite() => v.push(x),
                    _ => {
                        return Err(TerrainError::MissingSource {
                            log: name,
                            sensor: "imu",
                            reason: format!(
                                "the model reads {} but imu.csv row {} (t = {}) has none; \
                                 train with --channels accel-z for such logs",
                                CHANNEL_NAMES[c],
                                i + 2,
                                s.t
                            ),
                        })
                    }
                }
            }
            ch[c] = v;
        }
        Ok(Self { t, ch, rate_hz })
    }
}

/// `(t_end, features)` of one window: end time, s, and its feature vector.
pub type Window = (f64, Vec<f64>);

/// Features of every window of a log: `(t_end, features)`, windows ending
/// every `hop_s` seconds. Windows spanning a gap in the IMU stream (a
/// sample spacing over 5x the nominal one) are skipped.
pub fn log_windows(log: &DriveLog, cfg: &VibrationConfig) -> Result<(f64, Vec<Window>)> {
    let imu = ImuChannels::from_log(log, cfg)?;
    if cfg.feature_set == VibrationFeatureSet::Full && log.wheels.is_empty() {
        return Err(TerrainError::MissingSource {
            log: log.name(),
            sensor: "wheels",
            reason: "the full feature set needs tread speeds from wheels.csv".into(),
        });
    }
    let currents = cfg.currents && cfg.feature_set == VibrationFeatureSet::Full;
    if currents && log.currents.is_empty() {
        return Err(TerrainError::MissingSource {
            log: log.name(),
            sensor: "currents",
            reason: "the model reads drive-motor currents but wheels.csv has no \
                     current_left,current_right; use a model trained with --no-currents"
                .into(),
        });
    }
    let mut ex = VibrationExtractor::new(cfg, imu.rate_hz)?;
    // Without a track width in meta.toml the yaw-rate features are in m/s,
    // still consistent within one robot.
    let track_width = log.meta.track_width.unwrap_or(1.0);
    let gyro_w = gyro_at_wheels(&imu.t, &imu.ch[5], &log.wheels);
    let n = ex.window_len();
    let hop = ((cfg.hop_s * imu.rate_hz).round() as usize).max(1);
    let max_gap = 5.0 / imu.rate_hz;
    let mut out = Vec::new();
    let mut end = n;
    let gaps: Vec<usize> = imu
        .t
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[1] - w[0] > max_gap)
        .map(|(i, _)| i + 1)
        .collect();
    while end <= imu.t.len() {
        let start = end - n;
        // A gap at index g means samples g-1 and g are far apart.
        let gap_inside = gaps.iter().any(|&g| g > start && g < end);
        if !gap_inside {
            let slices: [&[f64]; 6] = std::array::from_fn(|c| {
                if imu.ch[c].is_empty() {
                    &[][..]
                } else {
                    &imu.ch[c][start..end]
                }
            });
            let speed = speed_stats(
                &log.wheels,
                &gyro_w,
                imu.t[start],
                imu.t[end - 1],
                track_width,
            );
            let (t0, t1) = (imu.t[start], imu.t[end - 1]);
            let current = if currents {
                match crate::current::features(&log.currents, &log.wheels, t0, t1) {
                    Some(c) => c.to_vec(),
                    // Before the first current sample: no window.
                    None => {
                        end = end.saturating_add(hop);
                        continue;
                    }
                }
            } else {
                Vec::new()
            };
            let mut f = Vec::with_capacity(ex.n_features());
            ex.features(&slices, speed, &current, &mut f)?;
            if f.iter().all(|v| v.is_finite()) {
                out.push((imu.t[end - 1], f));
            }
        }
        end = end.saturating_add(hop);
    }
    Ok((imu.rate_hz, out))
}
