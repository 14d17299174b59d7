//! Vibration features from IMU windows (wang2018 §3.2.1, extended).
//!
//! A window is the last `window_s` seconds of IMU samples ending at a time
//! `t` (causal). The paper's features are computed from the vertical
//! acceleration with gravity removed: the number of sign changes, the mean
//! and the variance. The `full` set adds, for every IMU channel present
//! (accelerations in m/s², angular rates in rad/s, body frame), higher
//! moments, the zero-crossing rate and Welch band powers, plus the tread
//! speed from `wheels.csv` (vibration energy grows with speed, so the
//! classifier needs it to tell a rough terrain from a fast drive).

use std::sync::Arc;

use realfft::{RealFftPlanner, RealToComplex};
use serde::{Deserialize, Serialize};

use crate::error::{Result, TerrainError};
pub use crate::motion::{SpeedStats, MIN_YAW_EXCITATION};
pub use crate::windows::{imu_rate, log_windows, Window};

/// Standard gravity, m/s². The paper removes gravity as a constant DC term.
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// Names of the six IMU channels, in feature order.
pub const CHANNEL_NAMES: [&str; 6] = [
    "accel_x", "accel_y", "accel_z", "gyro_x", "gyro_y", "gyro_z",
];

/// Which features a vibration window yields.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VibrationFeatureSet {
    /// wang2018: sign changes, mean and variance of `accel_z - g` (3 features).
    Paper,
    /// Per channel: log variance, zero-crossing rate, skewness, kurtosis,
    /// `bands` log Welch band powers and their shares of the total; plus
    /// tread-speed and slip terms.
    Full,
}

/// Which IMU channels the `full` set reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ChannelSet {
    /// Vertical acceleration only (what every log has).
    AccelZ,
    /// All six channels; a log missing any of them is rejected.
    All,
}

/// Windowing and feature settings, recorded in the model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VibrationConfig {
    /// Window length, s.
    pub window_s: f64,
    /// Time between the ends of consecutive windows, s.
    pub hop_s: f64,
    pub feature_set: VibrationFeatureSet,
    pub channels: ChannelSet,
    /// Number of Welch band powers per channel (linear bands from 0 to Nyquist).
    pub bands: usize,
    /// Welch segment length, s (segments overlap by half, Hann window).
    pub welch_segment_s: f64,
    /// `full` set only: add the steering efficiency χ (gyro yaw rate
    /// regressed on the commanded one), its fit, the turning excitation and
    /// the spin share (turning in place vs driving straight). Off = the
    /// feature set of model format 1.
    #[serde(default = "yes")]
    pub slip: bool,
    /// `full` set only: map the amplitude-like features (log variances, log
    /// band powers) to the tread speed `speed_norm_ref` with per-feature
    /// slopes on ln v learnt from the training windows (see
    /// [`crate::speed_norm`]; the model file holds the slopes). On by
    /// default; a settings file without the field means off.
    #[serde(default)]
    pub speed_norm: bool,
    /// Reference tread speed of the speed normalisation, m/s.
    #[serde(default = "default_speed_norm_ref")]
    pub speed_norm_ref: f64,
    /// Below this tread speed (m/s) the speed normalisation takes this
    /// speed; slower windows are left out of the slope fit. `train` chooses
    /// it by inner cross-validation over [`SPEED_FLOOR_CANDIDATES`] unless
    /// told otherwise.
    #[serde(default = "default_speed_norm_min")]
    pub speed_norm_min: f64,
    /// `full` set only: add the drive-motor current features
    /// ([`crate::current`]); every log must then have `current_left,current_right`.
    #[serde(default)]
    pub currents: bool,
}

/// The speed floors (m/s) the inner cross-validation of `train` chooses
/// `speed_norm_min` from.
pub const SPEED_FLOOR_CANDIDATES: [f64; 3] = [0.05, 0.1, 0.2];

fn default_speed_norm_ref() -> f64 {
    0.5
}

fn default_speed_norm_min() -> f64 {
    0.1
}

fn yes() -> bool {
    true
}

impl Default for VibrationConfig {
    fn default() -> Self {
        Self {
            window_s: 6.0,
            hop_s: 0.5,
            feature_set: VibrationFeatureSet::Full,
            channels: ChannelSet::All,
            bands: 12,
            welch_segment_s: 1.0,
            slip: true,
            speed_norm: true,
            speed_norm_ref: default_speed_norm_ref(),
            speed_norm_min: default_speed_norm_min(),
            currents: false,
        }
    }
}

impl VibrationConfig {
    /// The paper's setting: 1 s windows, three time-domain features of accel_z.
    pub fn paper() -> Self {
        Self {
            window_s: 1.0,
            hop_s: 1.0,
            feature_set: VibrationFeatureSet::Paper,
            channels: ChannelSet::AccelZ,
            bands: 0,
            welch_segment_s: 1.0,
            slip: false,
            speed_norm: false,
            speed_norm_ref: default_speed_norm_ref(),
            speed_norm_min: default_speed_norm_min(),
            currents: false,
        }
    }

    /// Whether the `full` set holds [`crate::current::EXCESS_FEATURE`]: with
    /// currents, the slip terms (spin share, turning excitation) and the
    /// speed normalisation (which holds the robot's current baseline).
    fn current_excess(&self) -> bool {
        self.currents && self.slip && self.speed_norm
    }

    pub(crate) fn channel_indices(&self) -> &'static [usize] {
        match (self.feature_set, self.channels) {
            (VibrationFeatureSet::Paper, _) | (_, ChannelSet::AccelZ) => &[2],
            (VibrationFeatureSet::Full, ChannelSet::All) => &[0, 1, 2, 3, 4, 5],
        }
    }

    /// Names of the features, in order.
    pub fn feature_names(&self) -> Vec<String> {
        match self.feature_set {
            VibrationFeatureSet::Paper => vec![
                "accel_z_sign_changes".into(),
                "accel_z_mean".into(),
                "accel_z_variance".into(),
            ],
            VibrationFeatureSet::Full => {
                let mut names = Vec::new();
                for &c in self.channel_indices() {
                    let ch = CHANNEL_NAMES[c];
                    for f in ["log_var", "zcr", "skew", "kurt"] {
                        names.push(format!("{ch}_{f}"));
                    }
                    for b in 0..self.bands {
                        names.push(format!("{ch}_band{b}"));
                    }
                    for b in 0..self.bands {
                        names.push(format!("{ch}_band{b}_share"));
                    }
                }
                names.extend(
                    [
                        "tread_speed",
                        "tread_speed_diff",
                        "log_az_std_per_speed",
                        "wheel_yaw_rate",
                        "yaw_rate_residual",
                        "wheel_accel",
                    ]
                    .map(String::from),
                );
                if self.slip {
                    names.extend(
                        ["yaw_gain", "yaw_fit", "yaw_excitation", "spin_share"].map(String::from),
                    );
                }
                if self.currents {
                    names.extend(crate::current::FEATURE_NAMES.map(String::from));
                    if self.current_excess() {
                        names.push(crate::current::EXCESS_FEATURE.into());
                    }
                }
                names
            }
        }
    }
}

/// Computes features of fixed-length windows; holds the FFT plan and
/// scratch buffers so that the per-window cost is arithmetic only.
pub struct VibrationExtractor {
    cfg: VibrationConfig,
    rate_hz: f64,
    n_window: usize,
    n_seg: usize,
    fft: Arc<dyn RealToComplex<f64>>,
    hann: Vec<f64>,
    hann_power: f64,
    seg_in: Vec<f64>,
    spec: Vec<realfft::num_complex::Complex<f64>>,
    scratch: Vec<realfft::num_complex::Complex<f64>>,
    /// One-sided Welch PSD of the current channel, (unit)²/Hz.
    psd: Vec<f64>,
    centred: Vec<f64>,
}

/// Longest window and hop a vibration model may state, s.
pub const MAX_WINDOW_S: f64 = 3600.0;

impl VibrationExtractor {
    /// An extractor for IMU data sampled at `rate_hz`.
    pub fn new(cfg: &VibrationConfig, rate_hz: f64) -> Result<Self> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(TerrainError::Config(format!(
                "IMU rate {rate_hz} Hz is not positive"
            )));
        }
        let seconds = 0.0..=MAX_WINDOW_S;
        if !(seconds.contains(&cfg.window_s) && seconds.contains(&cfg.hop_s) && cfg.hop_s > 0.0) {
            return Err(TerrainError::Config(format!(
                "window_s {} and hop_s {} must be positive and at most {MAX_WINDOW_S} s",
                cfg.window_s, cfg.hop_s
            )));
        }
        let n_window = (cfg.window_s * rate_hz).round() as usize;
        if n_window < 8 {
            return Err(TerrainError::Config(format!(
                "a {} s window at {rate_hz:.1} Hz holds {n_window} samples; need at least 8",
                cfg.window_s
            )));
        }
        let n_seg = ((cfg.welch_segment_s * rate_hz).round() as usize).clamp(8, n_window);
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(n_seg);
        let hann: Vec<f64> = (0..n_seg)
            .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n_seg as f64).cos())
            .collect();
        let hann_power = hann.iter().map(|w| w * w).sum::<f64>();
        if cfg.bands > MAX_BANDS {
            return Err(TerrainError::Config(format!(
                "{} temporal bands; at most {MAX_BANDS}",
                cfg.bands
            )));
        }
        let n_bins = n_seg / 2 + 1;
        Ok(Self {
            cfg: cfg.clone(),
            rate_hz,
            n_window,
            n_seg,
            seg_in: fft.make_input_vec(),
            spec: fft.make_output_vec(),
            scratch: fft.make_scratch_vec(),
            psd: vec![0.0; n_bins],
            centred: vec![0.0; n_window],
            fft,
            hann,
            hann_power,
        })
    }

    /// Samples per window.
    pub fn window_len(&self) -> usize {
        self.n_window
    }

    /// Number of features per window.
    pub fn n_features(&self) -> usize {
        self.cfg.feature_names().len()
    }

    /// Features of one window. `channels[c]` are the window's samples of
    /// channel `c` in [`CHANNEL_NAMES`] order (empty slices for channels
    /// the feature set does not read); all used slices have
    /// [`Self::window_len`] samples. `current` holds the window's
    /// [`crate::current::features`] when the settings read currents (empty
    /// otherwise). Appends to `out`.
    pub fn features(
        &mut self,
        channels: &[&[f64]; 6],
        speed: SpeedStats,
        current: &[f64],
        out: &mut Vec<f64>,
    ) -> Result<()> {
        let n_current = if self.cfg.currents && self.cfg.feature_set == VibrationFeatureSet::Full {
            crate::current::FEATURE_NAMES.len()
        } else {
            0
        };
        if current.len() != n_current {
            return Err(TerrainError::Data(format!(
                "{} current features for a window, expected {n_current}",
                current.len()
            )));
        }
        for &c in self.cfg.channel_indices() {
            if channels[c].len() != self.n_window {
                return Err(TerrainError::Data(format!(
                    "{} window has {} samples, expected {}",
                    CHANNEL_NAMES[c],
                    channels[c].len(),
                    self.n_window
                )));
            }
        }
        match self.cfg.feature_set {
            VibrationFeatureSet::Paper => {
                let a = channels[2];
                let mean = a.iter().sum::<f64>() / a.len() as f64;
                let var = a.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / a.len() as f64;
                // Sign changes around the window's DC level: with a biased
                // accelerometer, `a - g` may never change sign at all.
                out.push(zero_crossings(a, mean) as f64);
                out.push(mean - STANDARD_GRAVITY);
                out.push(var);
            }
            VibrationFeatureSet::Full => {
                let mut az_std = 0.0;
                for &c in self.cfg.channel_indices() {
                    let x = channels[c];
                    let n = x.len() as f64;
                    let mean = x.iter().sum::<f64>() / n;
                    let (mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0);
                    for (d, &v) in self.centred.iter_mut().zip(x) {
                        *d = v - mean;
                        let d2 = *d * *d;
                        m2 += d2;
                        m3 += d2 * *d;
                        m4 += d2 * d2;
                    }
                    m2 /= n;
                    m3 /= n;
                    m4 /= n;
                    let sd = m2.sqrt();
                    if c == 2 {
                        az_std = sd;
                    }
                    // No channel means: they carry the slope and the sensor
                    // mounting of a run more than its terrain, and cost
                    // accuracy on runs left out of training.
                    out.push((m2 + 1e-12).ln());
                    out.push(zero_crossings(x, mean) as f64 / n);
                    out.push(if sd > 1e-9 { m3 / (sd * sd * sd) } else { 0.0 });
                    out.push(if m2 > 1e-18 { m4 / (m2 * m2) } else { 3.0 });
                    if self.cfg.bands > 0 {
                        self.welch_psd()?;
                        self.band_powers(out);
                    }
                }
                out.push(speed.speed);
                out.push(speed.diff);
                out.push((az_std / speed.speed.max(0.05)).max(1e-9).ln());
                // Slip shows as a gap between the yaw rate the treads ask
                // for and the one the gyro sees (large on ice), and between
                // tread and body acceleration.
                let gyro_z = channels[5];
                let gz = if gyro_z.is_empty() {
                    0.0
                } else {
                    gyro_z.iter().sum::<f64>() / gyro_z.len() as f64
                };
                out.push(speed.yaw_rate);
                out.push(gz - speed.yaw_rate);
                out.push(speed.accel);
                if self.cfg.slip {
                    out.extend([
                        speed.yaw_gain,
                        speed.yaw_fit,
                        speed.yaw_excitation,
                        speed.spin_share,
                    ]);
                }
                out.extend_from_slice(current);
                // ln mean current; the speed normalisation subtracts the
                // robot's baseline at this speed and turn.
                if self.cfg.current_excess() {
                    out.push(current[0]);
                }
            }
        }
        Ok(())
    }

    /// Welch PSD of `self.centred` into `self.psd`, (unit)²/Hz.
    fn welch_psd(&mut self) -> Result<()> {
        let n_seg = self.n_seg;
        let hop = (n_seg / 2).max(1);
        self.psd.iter_mut().for_each(|p| *p = 0.0);
        let mut segments = 0usize;
        let mut start = 0;
        while start + n_seg <= self.n_window {
            for i in 0..n_seg {
                self.seg_in[i] = self.centred[start + i] * self.hann[i];
            }
            self.fft
                .process_with_scratch(&mut self.seg_in, &mut self.spec, &mut self.scratch)
                .map_err(|e| TerrainError::Data(format!("FFT failed: {e}")))?;
            for (p, s) in self.psd.iter_mut().zip(&self.spec) {
                *p += s.norm_sqr();
            }
            segments += 1;
            start += hop;
        }
        // One-sided PSD in (unit)²/Hz; the factor 2 for non-DC bins is
        // irrelevant to a log feature but keeps the units honest.
        let scale = 2.0 / (self.rate_hz * self.hann_power * segments.max(1) as f64);
        self.psd.iter_mut().for_each(|p| *p *= scale);
        Ok(())
    }

    /// `self.psd` integrated over linear temporal bands: log powers, then
    /// shares of the total.
    fn band_powers(&mut self, out: &mut Vec<f64>) {
        let bands = self.cfg.bands;
        if bands == 0 {
            return;
        }
        let df = self.rate_hz / self.n_seg as f64;
        let nyquist = self.rate_hz / 2.0;
        let mut acc = [0.0f64; MAX_BANDS];
        for (k, p) in self.psd.iter().enumerate().skip(1) {
            let f = k as f64 * df;
            let b = (((f / nyquist) * bands as f64).ceil() as usize).clamp(1, bands) - 1;
            acc[b] += p * df;
        }
        push_log_and_shares(&acc[..bands], out);
    }
}

/// Most bands per channel.
pub const MAX_BANDS: usize = 64;

/// Log band powers, then the share of each band in their total (spectral
/// shape apart from amplitude).
fn push_log_and_shares(acc: &[f64], out: &mut Vec<f64>) {
    out.extend(acc.iter().map(|p| (p + 1e-12).ln()));
    let total: f64 = acc.iter().sum::<f64>() + 1e-12;
    out.extend(acc.iter().map(|p| p / total));
}

fn zero_crossings(x: &[f64], level: f64) -> usize {
    let mut count = 0;
    let mut prev = 0.0f64;
    for &v in x {
        let d = v - level;
        // Exact zeros are skipped, as in the paper (the sign is undefined).
        if d != 0.0 {
            if prev * d < 0.0 {
                count += 1;
            }
            prev = d;
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_power_peaks_where_the_sine_is() {
        let cfg = VibrationConfig {
            channels: ChannelSet::AccelZ,
            bands: 10,
            window_s: 1.0,
            ..Default::default()
        };
        let rate = 100.0;
        let mut ex = VibrationExtractor::new(&cfg, rate).unwrap();
        // 22 Hz lies in band 4 of 10 linear bands over 0..50 Hz.
        let az: Vec<f64> = (0..100)
            .map(|i| STANDARD_GRAVITY + (2.0 * std::f64::consts::PI * 22.0 * i as f64 / rate).sin())
            .collect();
        let mut f = Vec::new();
        ex.features(
            &[&[], &[], &az, &[], &[], &[]],
            SpeedStats {
                speed: 1.0,
                ..Default::default()
            },
            &[],
            &mut f,
        )
        .unwrap();
        let bands = &f[4..14];
        let best = (0..10)
            .max_by(|&a, &b| bands[a].total_cmp(&bands[b]))
            .unwrap();
        assert_eq!(best, 4, "bands {bands:?}");
        // Parseval: band powers sum to about the variance (0.5).
        let total: f64 = bands.iter().map(|b| b.exp()).sum();
        assert!((total - 0.5).abs() < 0.1, "total power {total}");
        // Zero-crossing rate about 2 * 22 / 100; shares sum to 1.
        assert!((f[1] - 0.44).abs() < 0.03, "zcr {}", f[1]);
        let shares: f64 = f[14..24].iter().sum();
        assert!((shares - 1.0).abs() < 1e-6);
    }

    #[test]
    fn paper_features_match_hand_computation() {
        let cfg = VibrationConfig::paper();
        let mut ex = VibrationExtractor::new(&cfg, 10.0).unwrap();
        let az = [10.0, 9.0, 10.0, 9.0, 10.0, 9.0, 10.0, 9.0, 10.0, 9.0];
        let mut f = Vec::new();
        ex.features(
            &[&[], &[], &az, &[], &[], &[]],
            SpeedStats::default(),
            &[],
            &mut f,
        )
        .unwrap();
        assert_eq!(f[0], 9.0);
        assert!((f[1] - (9.5 - STANDARD_GRAVITY)).abs() < 1e-12);
        assert!((f[2] - 0.25).abs() < 1e-12);
    }

    #[test]
    fn wrong_window_length_and_bad_settings_are_errors() {
        let cfg = VibrationConfig::paper();
        assert!(VibrationExtractor::new(&cfg, 0.0).is_err());
        assert!(VibrationExtractor::new(&cfg, 4.0).is_err());
        let mut ex = VibrationExtractor::new(&cfg, 100.0).unwrap();
        let mut f = Vec::new();
        let short = [9.8; 10];
        assert!(ex
            .features(
                &[&[], &[], &short, &[], &[], &[]],
                SpeedStats::default(),
                &[],
                &mut f
            )
            .is_err());
        // A window or hop no IMU log could hold (a corrupt model file) is
        // refused, not turned into an index past the end of the samples.
        for (window_s, hop_s) in [(1e308, 0.5), (1.0, 1e308), (1.0, -1.0)] {
            let cfg = VibrationConfig {
                window_s,
                hop_s,
                ..VibrationConfig::paper()
            };
            assert!(
                VibrationExtractor::new(&cfg, 100.0).is_err(),
                "{window_s} {hop_s}"
            );
        }
    }
}
