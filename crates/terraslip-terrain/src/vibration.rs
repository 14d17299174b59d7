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
use terraslip_io::{DriveLog, ImuSample, WheelSample};

use crate::error::{Result, TerrainError};

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
    /// `full` set only: number of spatial band powers per channel (0 = none):
    /// the Welch PSD mapped from temporal frequency f (Hz) to spatial
    /// frequency κ = f / v (cycles/m, v the window's mean tread speed) and
    /// integrated over log-spaced bands from `spatial_min_cpm` to
    /// `spatial_max_cpm`, as log powers and shares of their total. Terrain
    /// roughness is a spectrum over distance; at speed v it shakes the robot
    /// at f = κ v, so these bands move less with speed than the temporal ones.
    #[serde(default)]
    pub spatial_bands: usize,
    /// Lower edge of the spatial band grid, cycles/m.
    #[serde(default = "default_spatial_min")]
    pub spatial_min_cpm: f64,
    /// Upper edge of the spatial band grid, cycles/m.
    #[serde(default = "default_spatial_max")]
    pub spatial_max_cpm: f64,
    /// How a temporal PSD becomes a spatial one.
    #[serde(default)]
    pub spatial_scaling: SpatialScaling,
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
    /// speed; slower windows are left out of the slope fit.
    #[serde(default = "default_speed_norm_min")]
    pub speed_norm_min: f64,
}

fn default_speed_norm_ref() -> f64 {
    0.5
}

fn default_speed_norm_min() -> f64 {
    0.1
}

fn yes() -> bool {
    true
}

fn default_spatial_min() -> f64 {
    2.0
}

fn default_spatial_max() -> f64 {
    128.0
}

/// How the spatial band powers are scaled from the temporal PSD S_t(f).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpatialScaling {
    /// Only the change of variable: S_x(κ) = S_t(κ v) · v, the same signal
    /// as a density per cycle/m (power over a band is kept).
    #[default]
    Jacobian,
    /// The terrain profile a rigid robot following the ground would imply:
    /// accelerations as height (S_t / (2πf)⁴) and angular rates as slope
    /// angle (S_t / (2πf)²), then the Jacobian. At a fixed κ this scales
    /// the acceleration power by v⁻³ and the rate power by v⁻¹ instead of v.
    Profile,
}

/// Below this mean tread speed (m/s) the spatial bands are not measured
/// (κ = f / v runs off the grid): their log powers are set to the floor a
/// band without power gets, ln(1e-12), and their shares to 0, a value no
/// moving window takes, which a tree splits off.
pub const MIN_SPATIAL_SPEED: f64 = 0.05;

/// The log power the spatial bands take when they are not measured.
pub const SPATIAL_MISSING: f64 = -27.631021115928547; // ln(1e-12)

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
            spatial_bands: 0,
            spatial_min_cpm: default_spatial_min(),
            spatial_max_cpm: default_spatial_max(),
            spatial_scaling: SpatialScaling::Jacobian,
            speed_norm: true,
            speed_norm_ref: default_speed_norm_ref(),
            speed_norm_min: default_speed_norm_min(),
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
            spatial_bands: 0,
            spatial_min_cpm: default_spatial_min(),
            spatial_max_cpm: default_spatial_max(),
            spatial_scaling: SpatialScaling::Jacobian,
            speed_norm: false,
            speed_norm_ref: default_speed_norm_ref(),
            speed_norm_min: default_speed_norm_min(),
        }
    }

    fn channel_indices(&self) -> &'static [usize] {
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
                    for b in 0..self.spatial_bands {
                        names.push(format!("{ch}_sband{b}"));
                    }
                    for b in 0..self.spatial_bands {
                        names.push(format!("{ch}_sband{b}_share"));
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
                names
            }
        }
    }
}

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
    /// Spatial band edges, cycles/m (`spatial_bands + 1`, log-spaced).
    spatial_edges: Vec<f64>,
    /// Per PSD bin, the factor that turns an acceleration PSD into a height
    /// PSD (1/(2πf)⁴) and a rate PSD into an angle PSD (1/(2πf)²); 1 with
    /// the Jacobian scaling.
    profile_accel: Vec<f64>,
    profile_rate: Vec<f64>,
}

impl VibrationExtractor {
    /// An extractor for IMU data sampled at `rate_hz`.
    pub fn new(cfg: &VibrationConfig, rate_hz: f64) -> Result<Self> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(TerrainError::Config(format!(
                "IMU rate {rate_hz} Hz is not positive"
            )));
        }
        if !(cfg.window_s.is_finite() && cfg.hop_s.is_finite() && cfg.hop_s > 0.0) {
            return Err(TerrainError::Config(
                "window_s and hop_s must be positive".into(),
            ));
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
        let nb = cfg.spatial_bands;
        let spatial_edges = if nb == 0 {
            Vec::new()
        } else {
            let (lo, hi) = (cfg.spatial_min_cpm, cfg.spatial_max_cpm);
            if nb > MAX_BANDS || !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > lo) {
                return Err(TerrainError::Config(format!(
                    "spatial bands: need 1..={MAX_BANDS} bands over 0 < min < max cycles/m, \
                     got {nb} over {lo}..{hi}"
                )));
            }
            (0..=nb)
                .map(|i| lo * (hi / lo).powf(i as f64 / nb as f64))
                .collect()
        };
        if cfg.bands > MAX_BANDS {
            return Err(TerrainError::Config(format!(
                "{} temporal bands; at most {MAX_BANDS}",
                cfg.bands
            )));
        }
        let n_bins = n_seg / 2 + 1;
        let df = rate_hz / n_seg as f64;
        let profile = |order: i32| -> Vec<f64> {
            (0..n_bins)
                .map(|k| match cfg.spatial_scaling {
                    SpatialScaling::Jacobian => 1.0,
                    SpatialScaling::Profile if k == 0 => 0.0,
                    SpatialScaling::Profile => {
                        (2.0 * std::f64::consts::PI * k as f64 * df).powi(-order)
                    }
                })
                .collect()
        };
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
            spatial_edges,
            profile_accel: profile(4),
            profile_rate: profile(2),
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
    /// [`Self::window_len`] samples. Appends to `out`.
    pub fn features(
        &mut self,
        channels: &[&[f64]; 6],
        speed: SpeedStats,
        out: &mut Vec<f64>,
    ) -> Result<()> {
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
                    if self.cfg.bands > 0 || self.cfg.spatial_bands > 0 {
                        self.welch_psd()?;
                        self.band_powers(out);
                        self.spatial_band_powers(speed.speed, c, out);
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

    /// `self.psd` of channel `c` mapped to spatial frequency κ = f / v
    /// (cycles/m) at tread speed `v` (m/s) and integrated over the
    /// log-spaced spatial bands: log powers, then shares of the total.
    fn spatial_band_powers(&mut self, v: f64, c: usize, out: &mut Vec<f64>) {
        let nb = self.cfg.spatial_bands;
        if nb == 0 {
            return;
        }
        // NaN and infinite speeds are refused too.
        if !(v.is_finite() && v >= MIN_SPATIAL_SPEED) {
            out.extend(std::iter::repeat_n(SPATIAL_MISSING, nb));
            out.extend(std::iter::repeat_n(0.0, nb));
            return;
        }
        let df = self.rate_hz / self.n_seg as f64;
        let profile = if c < 3 {
            &self.profile_accel
        } else {
            &self.profile_rate
        };
        let edges = &self.spatial_edges;
        let (mut sum, mut count) = ([0.0f64; MAX_BANDS], [0usize; MAX_BANDS]);
        let dk = df / v;
        let mut b = 0;
        // Bins are in increasing κ: one pass, no logarithm per bin.
        for (k, (p, w)) in self.psd.iter().zip(profile).enumerate().skip(1) {
            let kappa = k as f64 * dk;
            if kappa < edges[0] {
                continue;
            }
            while b < nb && kappa >= edges[b + 1] {
                b += 1;
            }
            if b == nb {
                break;
            }
            sum[b] += p * w;
            count[b] += 1;
        }
        let last = self.psd.len() - 1;
        let mut acc = [0.0f64; MAX_BANDS];
        for b in 0..nb {
            let mean = if count[b] > 0 {
                sum[b] / count[b] as f64
            } else {
                // No bin inside the band (narrower than the bin spacing
                // 1/v, or beyond the range the window's speed reaches): the
                // bin nearest the band centre stands in for it, so a band
                // out of reach adds no information rather than a fake zero.
                let centre = (edges[b] * edges[b + 1]).sqrt();
                let k = ((centre / dk).round() as usize).clamp(1, last);
                self.psd[k] * profile[k]
            };
            // Density per cycle/m: S_x(κ) = S_t(κ v) · v; times the width.
            acc[b] = mean * v * (edges[b + 1] - edges[b]);
        }
        push_log_and_shares(&acc[..nb], out);
    }
}

/// Most bands (temporal or spatial) per channel.
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
                let x = match c {
                    0 => s.accel_x,
                    1 => s.accel_y,
                    2 => Some(s.accel_z),
                    3 => s.gyro_x,
                    4 => s.gyro_y,
                    _ => s.gyro_z,
                };
                match x {
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
            let mut f = Vec::with_capacity(ex.n_features());
            ex.features(&slices, speed, &mut f)?;
            if f.iter().all(|v| v.is_finite()) {
                out.push((imu.t[end - 1], f));
            }
        }
        end += hop;
    }
    Ok((imu.rate_hz, out))
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

    /// Features of accel_z alone (`bands` temporal, 6 spatial over 2..128
    /// cycles/m), for a 6 s window at 100 Hz of `az` at tread speed `v`.
    fn spatial_features(az: &[f64], v: f64, scaling: SpatialScaling) -> Vec<f64> {
        let cfg = VibrationConfig {
            channels: ChannelSet::AccelZ,
            spatial_bands: 6,
            spatial_scaling: scaling,
            ..Default::default()
        };
        let mut ex = VibrationExtractor::new(&cfg, 100.0).unwrap();
        let mut f = Vec::new();
        let speed = SpeedStats {
            speed: v,
            ..Default::default()
        };
        ex.features(&[&[], &[], az, &[], &[], &[]], speed, &mut f)
            .unwrap();
        assert_eq!(f.len(), cfg.feature_names().len());
        assert_eq!(cfg.feature_names()[28], "accel_z_sband0");
        f
    }

    /// A terrain with one spatial wavelength (10 cycles/m) driven over at
    /// 0.3 and 0.6 m/s: the temporal peak moves from 3 to 6 Hz, the spatial
    /// one stays in the band holding 10 cycles/m, with the same power.
    #[test]
    fn spatial_bands_do_not_move_with_speed() {
        let kappa = 10.0;
        let profile = |v: f64, amp: f64| -> Vec<f64> {
            (0..600)
                .map(|i| {
                    let x = v * i as f64 / 100.0;
                    STANDARD_GRAVITY + amp * (2.0 * std::f64::consts::PI * kappa * x).sin()
                })
                .collect()
        };
        let argmax = |x: &[f64]| (0..x.len()).max_by(|&a, &b| x[a].total_cmp(&x[b])).unwrap();
        let slow = spatial_features(&profile(0.3, 1.0), 0.3, SpatialScaling::Jacobian);
        let fast = spatial_features(&profile(0.6, 1.0), 0.6, SpatialScaling::Jacobian);
        // Temporal bands (12 over 0..50 Hz): 3 Hz in band 0, 6 Hz in band 1.
        assert_eq!((argmax(&slow[4..16]), argmax(&fast[4..16])), (0, 1));
        // Spatial bands 2-4, 4-8, 8-16, ... cycles/m: 10 lies in band 2.
        let (s, f) = (&slow[28..34], &fast[28..34]);
        assert_eq!((argmax(s), argmax(f)), (2, 2), "{s:?} {f:?}");
        // Its power is the sine's (0.5 m²/s⁴) at either speed.
        for p in [s[2], f[2]] {
            assert!((p.exp() - 0.5).abs() < 0.05, "band power {}", p.exp());
        }
        assert!(
            slow[34 + 2] > 0.8 && fast[34 + 2] > 0.8,
            "shares {:?} {:?}",
            &slow[34..],
            &fast[34..]
        );
        assert!(s.iter().chain(f).all(|p| p.is_finite()));

        // Profile scaling: a height profile of 1 mm amplitude; the IMU sees
        // its second derivative, (2π κ v)² larger. The profile bands give
        // the height power back (5e-7 m²) at both speeds.
        for v in [0.3, 0.6] {
            let w = 2.0 * std::f64::consts::PI * kappa * v;
            let p = spatial_features(&profile(v, 1e-3 * w * w), v, SpatialScaling::Profile);
            let h = p[28 + 2].exp();
            assert!((h / 5e-7 - 1.0).abs() < 0.15, "v {v}: height power {h}");
        }
    }

    #[test]
    fn spatial_bands_of_a_standing_robot_are_marked_missing_not_nan() {
        let az: Vec<f64> = (0..600)
            .map(|i| STANDARD_GRAVITY + 0.1 * ((i * 7) as f64 * 0.37).sin())
            .collect();
        for v in [0.0, 0.049, -0.0, f64::NAN, f64::INFINITY] {
            let f = spatial_features(&az, v, SpatialScaling::Profile);
            assert!(f[28..34].iter().all(|&p| p == SPATIAL_MISSING), "v {v}");
            assert!(f[34..40].iter().all(|&p| p == 0.0), "v {v}");
            assert!(f[..28].iter().all(|p| p.is_finite()));
        }
        // Just above the threshold the grid is far off the bins (κ ≥ 19
        // cycles/m): the low bands borrow the lowest bin, all finite.
        let f = spatial_features(&az, 0.051, SpatialScaling::Jacobian);
        assert!(f[28..40].iter().all(|p| p.is_finite()));
        assert!(f[28..34].iter().all(|&p| p > SPATIAL_MISSING));
        let shares: f64 = f[34..40].iter().sum();
        assert!((shares - 1.0).abs() < 1e-2, "shares {shares}");
    }

    #[test]
    fn bad_spatial_settings_are_errors() {
        for (nb, lo, hi) in [
            (4, 10.0, 10.0),
            (4, 0.0, 10.0),
            (4, f64::NAN, 10.0),
            (MAX_BANDS + 1, 1.0, 10.0),
        ] {
            let cfg = VibrationConfig {
                spatial_bands: nb,
                spatial_min_cpm: lo,
                spatial_max_cpm: hi,
                ..Default::default()
            };
            assert!(
                matches!(
                    VibrationExtractor::new(&cfg, 100.0),
                    Err(TerrainError::Config(_))
                ),
                "{nb} {lo} {hi}"
            );
        }
        let cfg = VibrationConfig {
            bands: MAX_BANDS + 1,
            ..Default::default()
        };
        assert!(VibrationExtractor::new(&cfg, 100.0).is_err());
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
                &mut f
            )
            .is_err());
    }
}
