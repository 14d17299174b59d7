//! Speed augmentation of training logs: a labelled log replayed as if
//! driven `r` times as fast, used only in training (feature extraction at
//! inference is unchanged).
//!
//! A ground's texture has a spatial frequency, so driving `r` times as
//! fast moves every vibration frequency `r` times up and shortens the run
//! by `r`. [`speed_copy`] builds that log from a real one:
//!
//! - IMU: each contiguous stretch (no gap over 5 sample periods) is
//!   resampled in time by `r` at the log's own rate, exactly in the
//!   frequency domain: the output spectrum at `f` is the input spectrum at
//!   `f / r`. For `r > 1` that truncates the input spectrum at
//!   `Nyquist / r` (an ideal low-pass: nothing aliases). For `r < 1` the
//!   output band `r · Nyquist .. Nyquist` has no source (it would come from
//!   above the recorded Nyquist); it keeps the input's own content at the
//!   same frequencies (power density unchanged: the sensor and motor noise
//!   floor rather than texture).
//! - Amplitude: the texture part (above [`MOTION_CUTOFF_HZ`]) of channel
//!   `c` is scaled by `r^β_c`, β_c from how the channel's
//!   log variance grows with the tread speed within terrains on the
//!   training windows (half the speed normalisation's slope of
//!   `<channel>_log_var`); below the cut-off the motion: angular rates
//!   scale by `r`, accelerations (gravity, tilt) stay.
//! - Treads: speeds times `r`, timestamps compressed by `r`: tread
//!   difference and commanded yaw rate scale by `r`, the spin share stays.
//! - Motor currents: the robot's own current baseline
//!   ([`crate::current::CurrentBaseline`], fitted on the training
//!   windows) says how the current grows with speed and turn:
//!   `ln I' = ln I + c1 · ln r + c3 · (r − 1) · |ω_cmd|`, ω_cmd the
//!   commanded yaw rate of the nearest tread sample, rad/s.
//! - Labels: times compressed by `r`; pose, truth and images are dropped.

use realfft::num_complex::Complex;
use realfft::RealFftPlanner;
use serde::{Deserialize, Serialize};
use terraslip_io::{DriveLog, ImuSample, MotorCurrent, TerrainLabel, WheelSample};

use crate::current::CurrentBaseline;
use crate::speed_norm::SpeedNormalisation;
use crate::vibration::CHANNEL_NAMES;
use crate::windows::{channel, imu_rate};

/// Below this frequency (Hz, after resampling) an IMU channel is the
/// robot's motion rather than the ground's texture.
pub const MOTION_CUTOFF_HZ: f64 = 0.5;

/// How `train` augments the training logs with speed copies.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedAugmentation {
    /// Speed factors `r` (each > 0): one copy of every training log per
    /// factor, driven `r` times as fast. A copy's window is kept only
    /// where the recorded windows of its terrain did not drive (outside
    /// the terrain's envelope, [`crate::envelope`]).
    pub factors: Vec<f64>,
}

impl Default for SpeedAugmentation {
    /// Copies at 0.6, 0.8, 1.25 and 1.6 times the recorded speeds
    /// (docs/benchmarks.md, "Speed copies").
    fn default() -> Self {
        Self {
            factors: vec![0.6, 0.8, 1.25, 1.6],
        }
    }
}

/// What [`speed_copy`] scales by, measured on the training windows.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SpeedLaw {
    /// Amplitude exponent β per IMU channel (order of [`CHANNEL_NAMES`]):
    /// the texture's RMS grows as v^β. 0 for a channel not measured.
    pub beta: [f64; 6],
    /// The robot's current baseline (`None`: currents not scaled).
    pub current: Option<CurrentBaseline>,
}

impl SpeedLaw {
    /// β_c = half the within-terrain slope of `<channel>_log_var` on ln v
    /// (the log variance is twice the log RMS).
    pub fn from_speed_normalisation(sn: &SpeedNormalisation, names: &[String]) -> Self {
        let mut beta = [0.0; 6];
        for (c, b) in beta.iter_mut().enumerate() {
            let name = format!("{}_log_var", CHANNEL_NAMES[c]);
            if let Some(j) = names.iter().position(|n| *n == name) {
                *b = 0.5 * sn.slopes.get(j).copied().unwrap_or(0.0);
            }
        }
        Self {
            beta,
            current: sn.current_baseline.clone(),
        }
    }
}

/// `log` as if driven `r` times as fast (see the module doc), named
/// `<dir>/speed_x<r>`, with the amplitude exponents and current baseline of
/// `law`. `r` must be finite and positive.
pub fn speed_copy(log: &DriveLog, r: f64, law: &SpeedLaw) -> DriveLog {
    assert!(r.is_finite() && r > 0.0, "speed factor {r}");
    let t_start = [
        log.imu.first().map(|s| s.t),
        log.wheels.first().map(|s| s.t),
    ]
    .into_iter()
    .flatten()
    .fold(f64::INFINITY, f64::min);
    let t_start = if t_start.is_finite() { t_start } else { 0.0 };
    let warp = |t: f64| t_start + (t - t_start) / r;
    let wheels: Vec<WheelSample> = log
        .wheels
        .iter()
        .map(|w| WheelSample {
            t: warp(w.t),
            v_left: r * w.v_left,
            v_right: r * w.v_right,
        })
        .collect();
    let track_width = log.meta.track_width.filter(|w| *w > 1e-3).unwrap_or(1.0);
    let current_law = law.current.as_ref();
    let currents = log
        .currents
        .iter()
        .map(|c| {
            let gain = current_law.map_or(1.0, |b| {
                let k = log.wheels.partition_point(|w| w.t < c.t);
                let w = log
                    .wheels
                    .get(k)
                    .or_else(|| log.wheels.get(k.saturating_sub(1)));
                let cmd = w.map_or(0.0, |w| ((w.v_right - w.v_left) / track_width).abs());
                let [_, c1, _, c3] = b.coefficients;
                (c1 * r.ln() + c3 * (r - 1.0) * cmd).exp()
            });
            MotorCurrent {
                t: warp(c.t),
                left: gain * c.left,
                right: gain * c.right,
            }
        })
        .collect();
    DriveLog {
        dir: log.dir.join(format!("speed_x{r}")),
        imu: resample_imu(&log.imu, r, &law.beta, &warp),
        wheels,
        currents,
        terrain: log
            .terrain
            .iter()
            .map(|l| TerrainLabel {
                t: warp(l.t),
                terrain: l.terrain.clone(),
            })
            .collect(),
        meta: log.meta.clone(),
        ..Default::default()
    }
}

/// The IMU stream resampled by `r`, stretch by stretch (split at gaps over
/// 5 sample periods), at the stream's own rate.
fn resample_imu(
    imu: &[ImuSample],
    r: f64,
    beta: &[f64; 6],
    warp: &dyn Fn(f64) -> f64,
) -> Vec<ImuSample> {
    let Some(rate) = imu_rate(imu) else {
        return Vec::new();
    };
    let dt = 1.0 / rate;
    let mut out = Vec::new();
    let mut planner = RealFftPlanner::<f64>::new();
    let mut start = 0;
    while start < imu.len() {
        let mut end = start + 1;
        while end < imu.len() && imu[end].t - imu[end - 1].t <= 5.0 * dt {
            end += 1;
        }
        let part = &imu[start..end];
        let m = (part.len() as f64 / r).floor() as usize;
        if part.len() >= 2 && m >= 2 {
            let channels: [Option<Vec<f64>>; 6] = std::array::from_fn(|c| {
                let x: Option<Vec<f64>> = part.iter().map(|s| channel(s, c)).collect();
                // Angular rates (gyro channels) are motion: they scale by r.
                let motion_gain = if c >= 3 { r } else { 1.0 };
                x.map(|x| resample(&mut planner, &x, m, rate, motion_gain, r.powf(beta[c])))
            });
            let t0 = warp(part[0].t);
            for j in 0..m {
                let at = |c: usize| channels[c].as_ref().map(|x| x[j]);
                out.push(ImuSample {
                    t: t0 + j as f64 * dt,
                    accel_x: at(0),
                    accel_y: at(1),
                    accel_z: at(2).unwrap_or(0.0),
                    gyro_x: at(3),
                    gyro_y: at(4),
                    gyro_z: at(5),
                });
            }
        }
        start = end;
    }
    out
}

/// `x` (sampled at `rate` Hz) compressed in time to `m` samples at the same
/// rate: the output at frequency f is the input at f·n/m (= f / r). Below
/// [`MOTION_CUTOFF_HZ`] the content is scaled by `motion_gain`, above by
/// `texture_gain`; output bins with no source (m > n) take the input's
/// content at the same frequency, unscaled, at the same power density.
fn resample(
    planner: &mut RealFftPlanner<f64>,
    x: &[f64],
    m: usize,
    rate: f64,
    motion_gain: f64,
    texture_gain: f64,
) -> Vec<f64> {
    let n = x.len();
    let fwd = planner.plan_fft_forward(n);
    let inv = planner.plan_fft_inverse(m);
    let mut input = x.to_vec();
    let mut spec = fwd.make_output_vec();
    if fwd.process(&mut input, &mut spec).is_err() {
        return vec![0.0; m];
    }
    let mut out_spec = inv.make_input_vec();
    let (nf, mf) = (n as f64, m as f64);
    for (k, y) in out_spec.iter_mut().enumerate() {
        let f = k as f64 * rate / mf;
        let gain = if f < MOTION_CUTOFF_HZ {
            motion_gain
        } else {
            texture_gain
        };
        *y = if let Some(s) = spec.get(k) {
            // Same bin index: frequency k·rate/n in, k·rate/m out.
            *s * (gain * mf / nf)
        } else {
            // No source: the input's content at the same frequency.
            let ko = ((k as f64 * nf / mf).round() as usize).min(spec.len() - 1);
            spec[ko] * (mf / nf).sqrt()
        };
    }
    // The DC and (even m) Nyquist bins of a real signal are real.
    out_spec[0].im = 0.0;
    if m.is_multiple_of(2) {
        if let Some(last) = out_spec.last_mut() {
            *last = Complex::new(last.re, 0.0);
        }
    }
    let mut out = inv.make_output_vec();
    if inv.process(&mut out_spec, &mut out).is_err() {
        return vec![0.0; m];
    }
    // realfft's inverse is unnormalised.
    out.iter_mut().for_each(|v| *v /= mf);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn peak_hz(x: &[f64], rate: f64) -> f64 {
        let mut planner = RealFftPlanner::<f64>::new();
        let fwd = planner.plan_fft_forward(x.len());
        let mut input = x.to_vec();
        let mut spec = fwd.make_output_vec();
        fwd.process(&mut input, &mut spec).unwrap();
        let k = (1..spec.len())
            .max_by(|&a, &b| spec[a].norm().total_cmp(&spec[b].norm()))
            .unwrap();
        k as f64 * rate / x.len() as f64
    }

    /// A texture at 7 Hz driven 1.5 and 0.6 times as fast peaks at 10.5 and
    /// 4.2 Hz, with its RMS scaled by r^β and the DC (gravity) kept.
    #[test]
    fn resampling_moves_the_texture_peak_by_r() {
        let rate = 100.0;
        let n = 3000;
        let x: Vec<f64> = (0..n)
            .map(|i| 9.81 + (2.0 * std::f64::consts::PI * 7.0 * i as f64 / rate).sin())
            .collect();
        for (r, beta) in [(1.5, 1.0), (0.6, 0.5)] {
            let m = (n as f64 / r).floor() as usize;
            let mut planner = RealFftPlanner::<f64>::new();
            let y = resample(&mut planner, &x, m, rate, 1.0, r.powf(beta));
            assert_eq!(y.len(), m);
            let p = peak_hz(&y, rate);
            assert!((p - 7.0 * r).abs() < 0.1, "r {r}: peak {p} Hz");
            let mean = y.iter().sum::<f64>() / m as f64;
            assert!((mean - 9.81).abs() < 1e-6, "mean {mean}");
            let rms = (y.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / m as f64).sqrt();
            let want = r.powf(beta) / 2f64.sqrt();
            assert!(
                (rms / want - 1.0).abs() < 0.02,
                "r {r}: rms {rms}, want {want}"
            );
        }
    }

    /// Stretching up drops what would land above Nyquist (no aliasing):
    /// a 40 Hz tone at 100 Hz driven twice as fast is gone, not folded to 20 Hz.
    #[test]
    fn stretching_up_low_passes_instead_of_aliasing() {
        let rate = 100.0;
        let x: Vec<f64> = (0..2000)
            .map(|i| {
                let t = i as f64 / rate;
                (2.0 * std::f64::consts::PI * 40.0 * t).sin()
                    + 0.5 * (2.0 * std::f64::consts::PI * 10.0 * t).sin()
            })
            .collect();
        let mut planner = RealFftPlanner::<f64>::new();
        let y = resample(&mut planner, &x, 1000, rate, 1.0, 1.0);
        assert!((peak_hz(&y, rate) - 20.0).abs() < 0.1);
        let rms = (y.iter().map(|v| v * v).sum::<f64>() / y.len() as f64).sqrt();
        assert!((rms - 0.5 / 2f64.sqrt()).abs() < 0.01, "rms {rms}");
    }

    /// A copy driven 1.4 times as fast: tread speeds, gyro yaw rate and
    /// currents scale as stated, the run is 1.4 times shorter, labels move.
    #[test]
    fn speed_copy_scales_treads_turn_and_currents() {
        let rate = 100.0;
        let imu: Vec<ImuSample> = (0..1000)
            .map(|i| ImuSample {
                t: i as f64 / rate,
                accel_z: 9.81,
                gyro_z: Some(0.2),
                ..Default::default()
            })
            .collect();
        let wheels: Vec<WheelSample> = (0..65)
            .map(|i| WheelSample {
                t: i as f64 / 6.5,
                v_left: 0.2,
                v_right: 0.4,
            })
            .collect();
        let currents: Vec<MotorCurrent> = wheels
            .iter()
            .map(|w| MotorCurrent {
                t: w.t,
                left: 2.0,
                right: 3.0,
            })
            .collect();
        let mut log = DriveLog {
            imu,
            wheels,
            currents,
            terrain: vec![
                TerrainLabel {
                    t: 0.0,
                    terrain: "snow".into(),
                },
                TerrainLabel {
                    t: 7.0,
                    terrain: "ice".into(),
                },
            ],
            ..Default::default()
        };
        log.meta.track_width = Some(0.5);
        let law = SpeedLaw {
            beta: [1.0; 6],
            current: Some(CurrentBaseline {
                index: 0,
                spin_index: 1,
                turn_index: 2,
                coefficients: [1.0, 0.5, 0.3, 0.2],
            }),
        };
        let c = speed_copy(&log, 1.4, &law);
        assert_eq!(c.imu.len(), (1000.0f64 / 1.4).floor() as usize);
        assert!(c
            .imu
            .iter()
            .all(|s| (s.gyro_z.unwrap() - 0.28).abs() < 1e-9));
        assert!(c.imu.iter().all(|s| (s.accel_z - 9.81).abs() < 1e-9));
        assert!((c.wheels[0].v_right - 0.56).abs() < 1e-12);
        assert!((c.wheels[10].t - 10.0 / 6.5 / 1.4).abs() < 1e-12);
        assert!((c.terrain[1].t - 5.0).abs() < 1e-12);
        // ln gain = 0.5 ln 1.4 + 0.2 · 0.4 · |0.2 / 0.5|.
        let gain = (0.5 * 1.4f64.ln() + 0.2 * 0.4 * 0.4).exp();
        assert!((c.currents[3].right / 3.0 - gain).abs() < 1e-12);
        let plain = SpeedLaw {
            current: None,
            ..law
        };
        assert_eq!(speed_copy(&log, 1.4, &plain).currents[3].right, 3.0);
    }
}
