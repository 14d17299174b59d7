//! Configuration of the online estimator (`terraslip estimate --config`).
//!
//! One TOML file, every key optional (missing keys take the defaults shown by
//! `terraslip estimate --print-config`), unknown keys are an error. Units are
//! SI; noise "rates" are random-walk variances per second of elapsed time.

use serde::{Deserialize, Serialize};
use terraslip_core::filter::{FilterConfig, IcrBand, IcrNoise, Variant};
use terraslip_core::model::FactorCoords;
use terraslip_core::schedule::{IcrStd, ScheduleConfig};
use terraslip_core::terrain_belief::BeliefConfig;

/// Everything `estimate` needs besides the log.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EstimatorConfig {
    /// Gain rule and process noise of the filter.
    pub filter: FilterSection,
    /// Starting state and its uncertainty.
    pub init: InitSection,
    /// Measurement noise used when `pose.csv` has no `std_xy` / `std_yaw`.
    pub measurement: MeasurementSection,
    /// Physical band the ICRs are kept in, relative to the track width.
    pub band: BandSection,
    /// Reaction to terrain changes: boost, reset, memory.
    pub schedule: ScheduleSection,
    /// Terrain belief over classifier outputs (`--terrain-model`).
    pub belief: BeliefSection,
}

/// Gain rule of the filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum FilterVariant {
    /// Textbook EKF, Joseph form.
    Ekf,
    /// The papers' innovation-based EKF (windowed innovation covariance in the gain).
    Iekf,
    /// terraslip default: textbook gain, innovation-adapted bounded ICR noise.
    Adaptive,
}

/// How the filter carries the tread speed factors (`[filter] factor_coords`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FactorCoordsName {
    /// Common factor and difference `alpha_l - alpha_r` (before `est2`'s
    /// per-spread form; the same filter as on `alpha_l, alpha_r`).
    Difference,
    /// Common factor and `(alpha_l - alpha_r) / d`, 1/m: what the heading
    /// sees on a straight, so a straight does not move `d` (default).
    PerSpread,
}

/// Standard deviations of the slip parameters in the coordinates the data
/// tell apart: spread y_l - y_r (m), centre (y_l + y_r)/2 (m), x_c (m),
/// common speed factor (alpha_l + alpha_r)/2 and difference alpha_l - alpha_r.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlipStd {
    /// Spread y_l - y_r, m.
    pub spread: f64,
    /// Centre (y_l + y_r)/2, m.
    pub centre: f64,
    /// Longitudinal ICR offset x_c, m.
    pub x_c: f64,
    /// Common tread speed factor (alpha_l + alpha_r)/2 (dimensionless).
    pub alpha: f64,
    /// Tread speed factor difference alpha_l - alpha_r (dimensionless).
    pub alpha_diff: f64,
}

impl SlipStd {
    fn to_core(self) -> IcrStd {
        IcrStd {
            spread: self.spread,
            centre: self.centre,
            x_c: self.x_c,
            alpha: self.alpha,
            alpha_diff: self.alpha_diff,
        }
    }

    fn entries(&self) -> [f64; 5] {
        [
            self.spread,
            self.centre,
            self.x_c,
            self.alpha,
            self.alpha_diff,
        ]
    }
}

/// `[filter]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FilterSection {
    /// `ekf`, `iekf` or `adaptive`.
    pub variant: FilterVariant,
    /// IEKF innovation window N (1..=64), in pose fixes.
    pub iekf_window: usize,
    /// Learn the ICRs at all (false = the fixed no-slip / initial model).
    pub learn_icr: bool,
    /// Learn the tread speed factors alpha_l, alpha_r (false = the papers'
    /// six-state model: the factors stay at their initial values).
    pub learn_alpha: bool,
    /// Position fixes with a larger std (m) correct only the pose, not the
    /// slip parameters: GNSS errors correlated over tens of seconds would
    /// drag the weakly observable ones (RTK-grade fixes still teach them).
    pub slip_from_position_max_std: f64,
    /// Position random walk, m^2/s.
    pub q_pos: f64,
    /// Extra position noise per squared speed, m^2/s per (m/s)^2.
    pub q_pos_per_speed2: f64,
    /// Yaw random walk, rad^2/s.
    pub q_yaw: f64,
    /// Extra yaw noise per squared yaw rate, rad^2/s per (rad/s)^2.
    pub q_yaw_per_rate2: f64,
    /// Yaw noise per radian turned, rad^2/rad (0 = none): the kinematic
    /// model's heading error grows with the angle turned, independent of the
    /// slip states (its square root is the model's relative heading-rate
    /// error over one radian: 1e-4 = 1 %).
    pub q_yaw_per_rad: f64,
    /// Low-pass time constant of the tread speeds that correlate the slip
    /// parameters with the pose (s; 0 = raw): encoder flicker is no turn.
    pub slip_input_time_constant: f64,
    /// ICR random walk of the spread d = y_l - y_r, m^2/s (5e-6 since
    /// session 4a, 1e-5 before: the turn-rate law now carries the spread's
    /// change with the turn, and over a 30 s outage the walk alone grew the
    /// std of d from ~1 to ~2 cm, so that the returning compass swung d).
    pub q_spread: f64,
    /// ICR random walk of the centre (y_l + y_r)/2, m^2/s.
    pub q_centre: f64,
    /// ICR random walk of x_c, m^2/s.
    pub q_x_c: f64,
    /// Random walk of the common speed factor (alpha_l + alpha_r)/2, 1/s.
    pub q_alpha: f64,
    /// Random walk of the speed factor difference alpha_l - alpha_r, 1/s.
    /// A property of the robot (tyres, wear), not of the ground: it changes
    /// slowly (1e-8: 0.1 % per 100 s of std growth; 1e-7 before `est2`
    /// session 2).
    pub q_alpha_diff: f64,
    /// Coordinates of the factor difference inside the filter:
    /// `per-spread` ((alpha_l - alpha_r)/d, 1/m; default) or `difference`
    /// (alpha_l - alpha_r). `q_alpha_diff` and `init.std_alpha_diff` are on
    /// alpha_l - alpha_r either way.
    pub factor_coords: FactorCoordsName,
    /// Chi-square gate on the 2-dof position innovation (13.8 = 99.9 %; 0 = off).
    pub gate_position: f64,
    /// Chi-square gate on the 1-dof heading innovation (10.8 = 99.9 %; 0 = off).
    pub gate_yaw: f64,
    /// Consecutive gated fixes after which the filter re-anchors on the fix.
    pub max_rejections: u32,
    /// Tread speed below which the robot stands still (no ICR learning), m/s.
    pub still_speed: f64,
    /// A gap between wheels rows longer than this (s) is not integrated with
    /// held speeds: the pose uncertainty grows instead, and a warning is given.
    pub max_wheel_gap: f64,
    /// Time constant of the heading-NIS average (adaptive variant), s; with
    /// no heading fix for longer than this it forgets towards 1 at the same
    /// rate (session 4a: kept, it scaled the spread's walk through outages).
    pub adapt_time_constant: f64,
    /// Largest factor the adaptive variant applies to the ICR noise.
    pub adapt_max_scale: f64,
    /// Heading-NIS average above which the filter reports an innovation jump.
    pub jump_threshold: f64,
    /// Turn-rate law of the ICRs (the calibration's `rate_model`): relative
    /// change of the spread y_l - y_r per m/s of tread speed difference
    /// |V_r - V_l|, s/m (0 = constant ICRs; the papers' model).
    pub rate_k_spread: f64,
    /// Same law: relative change of both tread speed factors per m/s of
    /// difference, s/m.
    pub rate_k_alpha: f64,
    /// Learn the spread's slope online (a filter state, from
    /// `rate_k_spread` with std `init.std_rate_k_spread`; a robot property,
    /// so terrain resets and recalls leave it alone; default since session
    /// 3). false: fixed at `rate_k_spread` (or `--init`'s).
    pub learn_rate_k_spread: bool,
    /// Random walk of the learned spread slope, (s/m)^2/s.
    pub q_rate_k_spread: f64,
    /// The spread slope is kept within +- this, s/m.
    pub max_rate_k_spread: f64,
    /// Time constant of the low-pass on the tread speeds the turn-rate law
    /// reads, s (0 = raw speeds, the calibration's law as written): the
    /// ICRs follow the motion with a lag.
    pub rate_input_time_constant: f64,
    /// With `--init`, take the slopes (and the straight-line ICRs they go
    /// with) from the parameter file's `rate_model` when calibration
    /// selected it, in place of `rate_k_spread` / `rate_k_alpha`.
    pub rate_from_init: bool,
    /// What estimate.csv's `y_l, y_r, x_c, alpha_l, alpha_r` (and `d`) are
    /// when a turn-rate law is in use: `instantaneous` (default; those in
    /// effect at the row's tread speeds, what the plain ICR formula needs to
    /// give the filter's twist, and what a simulator's truth holds) or
    /// `straight` (the straight-line values the filter carries).
    pub report_icr: ReportIcr,
    /// Start-up split (session 4b; off by default, see
    /// docs/estimator.md): after the start (and every covariance reset,
    /// with `hold_alpha_at_reset`) that leaves std(d)/d above
    /// `hold_alpha_spread_rel_std`, heading fixes do not correct the common
    /// speed factor until the heading has turned by this much in all, rad
    /// (0 = off). The compass in turns sees alpha/d; linearised at a d tens
    /// of % off, the updates would give alpha a share of the spread's error
    /// far above its prior share (RTK position fixes still teach alpha).
    pub hold_alpha_turn: f64,
    /// Relative spread std std(d)/d above which the start or a reset holds
    /// the common factor (`hold_alpha_turn`); a calibrated (`--init`) or
    /// recalled spread below it is not held. While held, heading updates do
    /// not shrink std(d)/d below it: linearised at a d that far off they
    /// overstate what they teach about d.
    pub hold_alpha_spread_rel_std: f64,
    /// Covariance resets at terrain changes re-arm the hold (false: only
    /// the start of the drive).
    pub hold_alpha_at_reset: bool,
    /// Extrapolation guard of the turn-rate law (session 4b): the law's
    /// input |V_r - V_l| is capped at the largest value at which a heading
    /// fix was fused while moving, so turns faster than any seen are not
    /// extrapolated linearly (applies when the slope is learned).
    pub rate_dv_cap: bool,
    /// Re-acquisition after a gap in the pose fixes, s (0 = off): a
    /// position or heading fix more than this after the previous one of its
    /// kind, and those of that kind for `reacquire_time` s after it,
    /// correct the pose but not the slip parameters (consider states), and
    /// do not feed the adaptation. After a GNSS/compass outage the
    /// pose-slip cross-covariance comes from linearising along a
    /// dead-reckoned path that is off by the drift, mostly model error the
    /// slip states cannot represent; fusing the first fixes through it
    /// moves the slip parameters by centimetres. A few missed 1 Hz fixes
    /// are not a gap.
    pub reacquire_gap: f64,
    /// Length of a re-acquisition from its first fix, s (0 = that fix only).
    pub reacquire_time: f64,
}

/// Which ICRs estimate.csv reports under a turn-rate law (`[filter] report_icr`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReportIcr {
    /// Those in effect at the row's tread speeds (default).
    Instantaneous,
    /// The straight-line values (`|V_r - V_l| = 0`).
    Straight,
}

/// `[init]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InitSection {
    /// Track width used when `meta.toml` has none, m (a warning is printed).
    pub default_track_width: f64,
    /// Initial spread as a multiple of the track width (without `--init`).
    pub spread_factor: f64,
    /// Initial std of the spread, as a multiple of the track width.
    pub std_spread_factor: f64,
    /// Initial std of the centre (y_l + y_r)/2, m: the weak symmetric prior.
    pub std_centre: f64,
    /// Initial std of x_c, m.
    pub std_x_c: f64,
    /// Initial std of the common speed factor (around 1).
    pub std_alpha: f64,
    /// Initial std of the speed factor difference (around 0).
    pub std_alpha_diff: f64,
    /// Std of calibrated parameters from `--init`.
    pub calibrated_std: SlipStd,
    /// Initial yaw std when the first fix has no heading, rad.
    pub std_yaw_unknown: f64,
    /// Prior std of the spread's turn-rate slope when it is learned
    /// (`filter.learn_rate_k_spread`), s/m.
    pub std_rate_k_spread: f64,
}

/// `[measurement]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MeasurementSection {
    /// Position std per axis when `pose.csv` has no `std_xy`, m.
    pub std_xy: f64,
    /// Heading std when `pose.csv` has no `std_yaw`, rad.
    pub std_yaw: f64,
    /// Encoder resolution on the tread, m per tick; 0 = from meta.toml
    /// (2 pi wheel_radius / ticks_per_rev), or unquantised if that is unknown.
    pub encoder_tick: f64,
    /// How late the pose stream is against the wheels, s: a pose stamped `t`
    /// describes the robot at wheel-clock time `t - pose_latency` (a lidar
    /// localiser stamping on arrival: 0.3-0.5 s on the DRIVE logs). 0 = take
    /// the latency `terraslip calibrate` stored in the `--init` file, if any.
    pub pose_latency: f64,
}

/// `[band]`: multiples of the track width W.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BandSection {
    /// Smallest spread y_l - y_r, x W.
    pub min_spread: f64,
    /// Largest spread, x W.
    pub max_spread: f64,
    /// Largest |y_l + y_r|/2, x W.
    pub max_centre: f64,
    /// Largest |x_c|, x W.
    pub max_x_c: f64,
    /// Smallest tread speed factor.
    pub min_alpha: f64,
    /// Largest tread speed factor.
    pub max_alpha: f64,
}

/// `[schedule]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScheduleSection {
    /// q_max / q_min factor on the ICR noise after a terrain change (1 = off).
    pub boost_factor: f64,
    /// Pose fixes the boost lasts (the papers' k).
    pub boost_updates: u32,
    /// Reset the ICR covariance at a change to an unlearned terrain (chen2023).
    pub reset: bool,
    /// Reset std (chen2023's P_B).
    pub reset_std: SlipStd,
    /// The reset keeps the learned tread speed factor difference
    /// alpha_l - alpha_r (a property of the robot, not of the ground);
    /// `reset_std.alpha_diff` is then unused.
    pub reset_keeps_alpha_diff: bool,
    /// Recall learned ICRs when a terrain is revisited.
    pub memory: bool,
    /// Seconds of driving on a terrain before its ICRs are remembered.
    pub memory_min_dwell: f64,
    /// Time constant (s) of the running average of the slip parameters
    /// remembered for a terrain, taken after half of `memory_min_dwell`
    /// (0 = remember the estimate at the moment of leaving).
    pub memory_average: f64,
    /// Floor on recalled std: a remembered estimate is not trusted more.
    pub recall_floor: SlipStd,
}

/// `[belief]` (wang2018 HMM + lambda vote), used with classifier evidence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BeliefSection {
    /// Probability of staying on a terrain between classifier windows.
    pub stay_prob: f64,
    /// Same, right after the filter's innovation jumped.
    pub stay_prob_on_jump: f64,
    /// Consecutive votes before a change is declared (odd).
    pub vote_lambda: u32,
}

impl Default for FilterSection {
    fn default() -> Self {
        Self {
            variant: FilterVariant::Adaptive,
            iekf_window: 10,
            learn_icr: true,
            learn_alpha: true,
            slip_from_position_max_std: 0.25,
            q_pos: 1e-4,
            q_pos_per_speed2: 1e-3,
            q_yaw: 1e-6,
            q_yaw_per_rate2: 1e-4,
            q_yaw_per_rad: 4e-4,
            slip_input_time_constant: 0.2,
            q_spread: 5e-6,
            q_centre: 1e-7,
            q_x_c: 1e-7,
            q_alpha: 1e-8,
            q_alpha_diff: 1e-8,
            factor_coords: FactorCoordsName::PerSpread,
            gate_position: 13.8,
            gate_yaw: 10.8,
            max_rejections: 10,
            still_speed: 0.02,
            max_wheel_gap: 1.0,
            adapt_time_constant: 5.0,
            adapt_max_scale: 50.0,
            jump_threshold: 4.0,
            rate_k_spread: 0.0,
            rate_k_alpha: 0.0,
            learn_rate_k_spread: true,
            q_rate_k_spread: 0.0,
            max_rate_k_spread: 1.0,
            rate_input_time_constant: 0.2,
            rate_from_init: true,
            report_icr: ReportIcr::Instantaneous,
            hold_alpha_turn: 0.0,
            hold_alpha_spread_rel_std: 0.05,
            hold_alpha_at_reset: false,
            rate_dv_cap: true,
            reacquire_gap: 0.0,
            reacquire_time: 0.0,
        }
    }
}

impl Default for InitSection {
    fn default() -> Self {
        Self {
            default_track_width: 0.5,
            spread_factor: 1.0,
            std_spread_factor: 0.3,
            std_centre: 0.02,
            std_x_c: 0.05,
            std_alpha: 0.03,
            std_alpha_diff: 0.01,
            calibrated_std: SlipStd {
                spread: 0.01,
                centre: 0.01,
                x_c: 0.02,
                alpha: 0.01,
                alpha_diff: 0.003,
            },
            std_yaw_unknown: std::f64::consts::PI,
            std_rate_k_spread: 0.15,
        }
    }
}

impl Default for MeasurementSection {
    fn default() -> Self {
        Self {
            std_xy: 2.0,
            std_yaw: 1f64.to_radians(),
            encoder_tick: 0.0,
            pose_latency: 0.0,
        }
    }
}

impl Default for BandSection {
    fn default() -> Self {
        Self {
            min_spread: 0.8,
            max_spread: 4.0,
            max_centre: 0.25,
            max_x_c: 0.5,
            min_alpha: 0.5,
            max_alpha: 1.5,
        }
    }
}

impl Default for ScheduleSection {
    fn default() -> Self {
        Self {
            boost_factor: 1.0,
            boost_updates: 0,
            reset: true,
            reset_std: SlipStd {
                spread: 0.1,
                centre: 0.01,
                x_c: 0.02,
                alpha: 0.02,
                alpha_diff: 0.01,
            },
            reset_keeps_alpha_diff: true,
            memory: true,
            memory_min_dwell: 20.0,
            memory_average: 40.0,
            recall_floor: SlipStd {
                spread: 0.004,
                centre: 0.005,
                x_c: 0.01,
                alpha: 0.003,
                alpha_diff: 0.001,
            },
        }
    }
}

impl Default for BeliefSection {
    fn default() -> Self {
        let b = BeliefConfig::default();
        Self {
            stay_prob: b.stay_prob,
            stay_prob_on_jump: b.stay_prob_on_jump,
            vote_lambda: b.vote_lambda,
        }
    }
}

/// One line: "line N: message" from a TOML error.
pub fn toml_error(text: &str, e: &toml::de::Error) -> ConfigError {
    let msg = e.message().trim().replace('\n', " ");
    match e.span() {
        Some(span) => {
            let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
            ConfigError(format!("line {line}: {msg}"))
        }
        None => ConfigError(msg),
    }
}

/// A configuration that makes no sense (negative noise, empty band, ...).
#[derive(Debug, thiserror::Error)]
#[error("invalid estimator configuration: {0}")]
pub struct ConfigError(pub String);

impl EstimatorConfig {
    /// Parses TOML text (unknown keys are errors, reported as one line
    /// with the line number in `text`).
    pub fn from_toml(text: &str) -> Result<Self, ConfigError> {
        let cfg: Self = toml::from_str(text).map_err(|e| toml_error(text, &e))?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// The configuration as TOML.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }

    /// [`Self::to_toml`] with every table and key preceded by its
    /// documentation as TOML comments (`estimate --print-config`): the doc
    /// comments of these structs, collected at build time.
    pub fn to_commented_toml(&self) -> String {
        let mut out = String::from(
            "# terraslip estimate configuration (`--config FILE`). Every key is optional:\n\
             # a missing key keeps the default shown. Units are SI; angles in rad.\n\
             # More in docs/estimator.md.\n\n",
        );
        out.push_str(&annotate(&self.to_toml(), "EstimatorConfig"));
        out
    }

    /// Keys of [`Self::to_toml`] (as `table.key`) with no documentation.
    pub fn undocumented_keys(&self) -> Vec<String> {
        documented_lines(&self.to_toml(), "EstimatorConfig")
            .filter_map(|(line, table, doc)| {
                let (key, _) = line.split_once('=')?;
                (doc.is_empty() && toml_table(line.trim()).is_none())
                    .then(|| format!("{table}.{}", key.trim()))
            })
            .collect()
    }

    /// Checks ranges; every constant must be finite and of the right sign.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let f = &self.filter;
        let nonneg = [
            ("filter.q_pos", f.q_pos),
            ("filter.q_pos_per_speed2", f.q_pos_per_speed2),
            ("filter.q_yaw", f.q_yaw),
            ("filter.q_yaw_per_rate2", f.q_yaw_per_rate2),
            ("filter.q_yaw_per_rad", f.q_yaw_per_rad),
            ("filter.q_spread", f.q_spread),
            ("filter.q_centre", f.q_centre),
            ("filter.q_x_c", f.q_x_c),
            ("filter.q_alpha", f.q_alpha),
            ("filter.q_alpha_diff", f.q_alpha_diff),
            ("filter.gate_position", f.gate_position),
            ("filter.gate_yaw", f.gate_yaw),
            ("filter.still_speed", f.still_speed),
            ("filter.reacquire_gap", f.reacquire_gap),
            ("filter.reacquire_time", f.reacquire_time),
            (
                "filter.slip_from_position_max_std",
                f.slip_from_position_max_std,
            ),
        ];
        let pos = [
            ("filter.adapt_time_constant", f.adapt_time_constant),
            ("filter.max_wheel_gap", f.max_wheel_gap),
            ("filter.adapt_max_scale", f.adapt_max_scale),
            ("filter.jump_threshold", f.jump_threshold),
            ("init.default_track_width", self.init.default_track_width),
            ("init.spread_factor", self.init.spread_factor),
            ("init.std_spread_factor", self.init.std_spread_factor),
            ("init.std_centre", self.init.std_centre),
            ("init.std_x_c", self.init.std_x_c),
            ("init.std_alpha", self.init.std_alpha),
            ("init.std_alpha_diff", self.init.std_alpha_diff),
            ("init.std_yaw_unknown", self.init.std_yaw_unknown),
            ("measurement.std_xy", self.measurement.std_xy),
            ("measurement.std_yaw", self.measurement.std_yaw),
            ("band.min_spread", self.band.min_spread),
            ("band.max_spread", self.band.max_spread),
            ("band.max_centre", self.band.max_centre),
            ("band.max_x_c", self.band.max_x_c),
            ("schedule.boost_factor", self.schedule.boost_factor),
        ];
        let lat = self.measurement.pose_latency;
        if !(lat.is_finite() && lat.abs() <= 10.0) {
            return Err(ConfigError(format!(
                "measurement.pose_latency = {lat} must be finite and within ±10 s"
            )));
        }
        for (name, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ConfigError(format!("{name} = {v} must be finite and >= 0")));
            }
        }
        for (name, v) in pos {
            if !(v.is_finite() && v > 0.0) {
                return Err(ConfigError(format!("{name} = {v} must be finite and > 0")));
            }
        }
        for (name, v) in [
            ("init.calibrated_std", self.init.calibrated_std),
            ("schedule.reset_std", self.schedule.reset_std),
            ("schedule.recall_floor", self.schedule.recall_floor),
        ] {
            if v.entries().iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                return Err(ConfigError(format!(
                    "{name} = {v:?}: every entry must be > 0"
                )));
            }
        }
        if !(1..=terraslip_core::filter::MAX_WINDOW).contains(&f.iekf_window) {
            return Err(ConfigError(format!(
                "filter.iekf_window = {} must be in 1..={}",
                f.iekf_window,
                terraslip_core::filter::MAX_WINDOW
            )));
        }
        if !(self.band.min_alpha > 0.0 && self.band.min_alpha < 1.0 && self.band.max_alpha > 1.0) {
            return Err(ConfigError(
                "band.min_alpha must be in (0, 1) and band.max_alpha > 1".into(),
            ));
        }
        if self.band.min_spread >= self.band.max_spread {
            return Err(ConfigError(
                "band.min_spread must be < band.max_spread".into(),
            ));
        }
        let b = &self.belief;
        if !(0.0..=1.0).contains(&b.stay_prob) || !(0.0..=1.0).contains(&b.stay_prob_on_jump) {
            return Err(ConfigError(
                "belief stay probabilities must be in [0, 1]".into(),
            ));
        }
        if !self.schedule.memory_min_dwell.is_finite() || self.schedule.memory_min_dwell < 0.0 {
            return Err(ConfigError("schedule.memory_min_dwell must be >= 0".into()));
        }
        if !self.schedule.memory_average.is_finite() || self.schedule.memory_average < 0.0 {
            return Err(ConfigError("schedule.memory_average must be >= 0".into()));
        }
        for (key, k) in [
            ("filter.rate_k_spread", self.filter.rate_k_spread),
            ("filter.rate_k_alpha", self.filter.rate_k_alpha),
        ] {
            if !(k.is_finite() && k.abs() <= 10.0) {
                return Err(ConfigError(format!(
                    "{key} = {k} must be a finite slope within +-10 s/m"
                )));
            }
        }
        let f = &self.filter;
        if !(f.max_rate_k_spread.is_finite()
            && f.max_rate_k_spread >= 0.0
            && f.rate_k_spread.abs() <= f.max_rate_k_spread)
        {
            return Err(ConfigError(format!(
                "filter.max_rate_k_spread = {} must be >= 0 and >= |rate_k_spread| = {}",
                f.max_rate_k_spread,
                f.rate_k_spread.abs()
            )));
        }
        if !(f.q_rate_k_spread.is_finite() && f.q_rate_k_spread >= 0.0) {
            return Err(ConfigError("filter.q_rate_k_spread must be >= 0".into()));
        }
        if !(f.rate_input_time_constant.is_finite() && f.rate_input_time_constant >= 0.0) {
            return Err(ConfigError(
                "filter.rate_input_time_constant must be >= 0 (s)".into(),
            ));
        }
        for (key, v) in [
            ("filter.hold_alpha_turn", f.hold_alpha_turn),
            (
                "filter.hold_alpha_spread_rel_std",
                f.hold_alpha_spread_rel_std,
            ),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ConfigError(format!("{key} = {v} must be finite and >= 0")));
            }
        }
        let sk = self.init.std_rate_k_spread;
        if !(sk.is_finite() && sk > 0.0) {
            return Err(ConfigError(format!(
                "init.std_rate_k_spread = {sk} must be > 0 (s/m)"
            )));
        }
        Ok(())
    }

    /// The core filter settings for a robot of track width `w` (m).
    pub fn filter_config(&self, w: f64) -> FilterConfig {
        let f = &self.filter;
        let variant = match f.variant {
            FilterVariant::Ekf => Variant::Ekf,
            FilterVariant::Iekf => Variant::Iekf {
                window: f.iekf_window,
            },
            FilterVariant::Adaptive => Variant::Adaptive,
        };
        let q_icr = IcrNoise {
            spread: f.q_spread,
            centre: f.q_centre,
            x_c: f.q_x_c,
            alpha: f.q_alpha,
            alpha_diff: f.q_alpha_diff,
        };
        FilterConfig {
            variant,
            q_pos: f.q_pos,
            q_pos_per_speed2: f.q_pos_per_speed2,
            q_yaw: f.q_yaw,
            q_yaw_per_rate2: f.q_yaw_per_rate2,
            q_yaw_per_rad: f.q_yaw_per_rad,
            encoder_tick: self.measurement.encoder_tick,
            slip_input_time_constant: f.slip_input_time_constant,
            q_icr,
            learn_icr: f.learn_icr,
            learn_alpha: f.learn_alpha,
            slip_from_position_max_std: f.slip_from_position_max_std,
            gate_position: f.gate_position,
            gate_yaw: f.gate_yaw,
            max_rejections: f.max_rejections,
            still_speed: f.still_speed,
            adapt_time_constant: f.adapt_time_constant,
            adapt_max_scale: f.adapt_max_scale,
            jump_threshold: f.jump_threshold,
            band: IcrBand {
                min_spread: self.band.min_spread * w,
                max_spread: self.band.max_spread * w,
                max_centre: self.band.max_centre * w,
                max_x_c: self.band.max_x_c * w,
                alpha_range: (self.band.min_alpha, self.band.max_alpha),
            },
            factor_coords: match f.factor_coords {
                FactorCoordsName::Difference => FactorCoords::Difference,
                FactorCoordsName::PerSpread => FactorCoords::PerSpread,
            },
            rate_k_alpha: f.rate_k_alpha,
            learn_rate_k_spread: f.learn_rate_k_spread,
            q_rate_k_spread: f.q_rate_k_spread,
            max_rate_k_spread: f.max_rate_k_spread,
            rate_input_time_constant: f.rate_input_time_constant,
            hold_alpha_turn: f.hold_alpha_turn,
            hold_alpha_spread_rel_std: f.hold_alpha_spread_rel_std,
            hold_alpha_at_reset: f.hold_alpha_at_reset,
            rate_dv_cap: f.rate_dv_cap,
            reacquire_gap: f.reacquire_gap,
            reacquire_time: f.reacquire_time,
        }
    }

    /// The core schedule settings.
    pub fn schedule_config(&self) -> ScheduleConfig {
        let s = &self.schedule;
        ScheduleConfig {
            boost_factor: s.boost_factor,
            boost_updates: s.boost_updates,
            reset: s.reset.then(|| s.reset_std.to_core()),
            reset_keeps_alpha_diff: s.reset_keeps_alpha_diff,
            memory: s.memory,
            memory_min_dwell: s.memory_min_dwell,
            memory_average: s.memory_average,
            recall_floor: s.recall_floor.to_core(),
        }
    }

    /// Std of calibrated ICRs from `--init`.
    pub fn calibrated_std(&self) -> IcrStd {
        self.init.calibrated_std.to_core()
    }

    /// The terrain-belief settings.
    pub fn belief_config(&self) -> BeliefConfig {
        BeliefConfig {
            stay_prob: self.belief.stay_prob,
            stay_prob_on_jump: self.belief.stay_prob_on_jump,
            vote_lambda: self.belief.vote_lambda,
        }
    }

    /// The estimator variants the demo compares, by name. The papers'
    /// `q_min`/`q_max` keep their ratio (10^4) but are scaled to metres on a
    /// 1 Hz pose rate: the published 0.01 and 100 m^2/s would let the ICRs
    /// swing by metres.
    pub fn presets() -> Vec<(&'static str, EstimatorConfig)> {
        const Q_MIN: f64 = 1e-6;
        const Q_MAX: f64 = 1e-2;
        let papers = |q: f64| {
            let n = IcrNoise::papers(q);
            let mut c = EstimatorConfig::default();
            c.filter.variant = FilterVariant::Ekf;
            c.filter.q_spread = n.spread;
            c.filter.q_centre = n.centre;
            c.filter.q_x_c = n.x_c;
            // The papers' six-state model: fixed speed factors (at 1, with
            // no uncertainty of their own), a vague ICR prior, no memory.
            c.filter.learn_alpha = false;
            // ... and constant ICRs (no turn-rate law).
            c.filter.rate_from_init = false;
            c.filter.learn_rate_k_spread = false;
            c.filter.rate_dv_cap = false;
            c.filter.hold_alpha_turn = 0.0;
            // ... and every fix teaches the slip, also after an outage.
            c.filter.reacquire_gap = 0.0;
            c.filter.q_yaw_per_rad = 0.0;
            c.filter.slip_from_position_max_std = 1e9;
            c.init.std_alpha = 1e-6;
            c.init.std_alpha_diff = 1e-6;
            c.init.std_centre = 0.1;
            c.init.std_x_c = 0.1;
            c.schedule.reset = false;
            c.schedule.memory = false;
            c
        };
        let mut no_slip = papers(Q_MIN);
        no_slip.filter.learn_icr = false;

        let ekf_qmin = papers(Q_MIN);
        let ekf_qmax = papers(Q_MAX);

        let mut ta_ekf = papers(Q_MIN);
        ta_ekf.schedule.boost_factor = Q_MAX / Q_MIN;
        ta_ekf.schedule.boost_updates = 5;

        let mut ta_iekf = ta_ekf.clone();
        ta_iekf.filter.variant = FilterVariant::Iekf;

        let mut reset = papers(Q_MIN);
        reset.schedule.reset = true;
        // P_B: 0.1 m on each of y_l, y_r, x_c, independent.
        reset.schedule.reset_std = SlipStd {
            spread: 0.1 * 2f64.sqrt(),
            centre: 0.1 / 2f64.sqrt(),
            x_c: 0.1,
            alpha: 1e-6,
            alpha_diff: 1e-6,
        };

        vec![
            ("no-slip", no_slip),
            ("ekf-qmin", ekf_qmin),
            ("ekf-qmax", ekf_qmax),
            ("ta-ekf-boost", ta_ekf),
            ("ta-iekf", ta_iekf),
            ("ekf-reset", reset),
            ("terraslip", EstimatorConfig::default()),
        ]
    }

    /// A preset by name.
    pub fn preset(name: &str) -> Option<EstimatorConfig> {
        Self::presets()
            .into_iter()
            .find(|(n, _)| *n == name)
            .map(|(_, c)| c)
    }
}

/// `(struct, field, field type, doc comment)` for every field of the
/// configuration structs in this file (generated by `build.rs`).
const CONFIG_DOCS: &[(&str, &str, &str, &str)] =
    include!(concat!(env!("OUT_DIR"), "/config_docs.rs"));

fn field_doc(owner: &str, field: &str) -> Option<(&'static str, &'static str)> {
    CONFIG_DOCS
        .iter()
        .find(|(o, f, _, _)| *o == owner && *f == field)
        .map(|&(_, _, ty, doc)| (ty, doc))
}

fn toml_table(line: &str) -> Option<&str> {
    line.strip_prefix('[')?.strip_suffix(']')
}

/// The struct a dotted TOML table path names, starting from `root`, and
/// the doc comment of its last field.
fn resolve_table(path: &str, root: &'static str) -> (Option<&'static str>, &'static str) {
    let (mut owner, mut doc) = (Some(root), "");
    for part in path.split('.') {
        match owner.and_then(|o| field_doc(o, part)) {
            Some((ty, d)) => (owner, doc) = (Some(ty), d),
            None => return (None, ""),
        }
    }
    (owner, doc)
}

/// Prefixes every table header and key of `toml` with its doc comment.
fn annotate(toml: &str, root: &'static str) -> String {
    let mut out = String::new();
    for (line, _, doc) in documented_lines(toml, root) {
        push_comment(&mut out, doc);
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// Every line of `toml` with the table it is in and the doc comment of the
/// table or key it declares (empty for other lines and undocumented keys).
fn documented_lines<'a>(
    toml: &'a str,
    root: &'static str,
) -> impl Iterator<Item = (&'a str, &'a str, &'static str)> {
    let (mut owner, mut table) = (Some(root), "");
    toml.lines().map(move |line| {
        let t = line.trim();
        let doc = if let Some(path) = toml_table(t) {
            let (o, d) = resolve_table(path, root);
            (owner, table) = (o, path);
            d
        } else if let Some((key, _)) = t.split_once('=') {
            owner
                .and_then(|o| field_doc(o, key.trim()))
                .map_or("", |(_, d)| d)
        } else {
            ""
        };
        (line, table, doc)
    })
}

/// `doc` as `# ` lines of at most about 78 columns; rustdoc link brackets
/// dropped.
fn push_comment(out: &mut String, doc: &str) {
    let doc = doc.replace("[`", "`").replace("`]", "`");
    let mut line = String::from("#");
    for word in doc.split_whitespace() {
        if line.len() + 1 + word.len() > 78 && line.len() > 1 {
            out.push_str(&line);
            out.push('\n');
            line = String::from("#");
        }
        line.push(' ');
        line.push_str(word);
    }
    if line.len() > 1 {
        out.push_str(&line);
        out.push('\n');
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_round_trips_through_toml() {
        let c = EstimatorConfig::default();
        let back = EstimatorConfig::from_toml(&c.to_toml()).unwrap();
        assert_eq!(c, back);
    }

    #[test]
    fn print_config_documents_every_key_and_round_trips() {
        let mut c = EstimatorConfig::preset("ta-iekf").unwrap();
        c.filter.q_spread = 3e-6;
        assert_eq!(c.undocumented_keys(), Vec::<String>::new());
        let text = c.to_commented_toml();
        // One comment block per key at least, and above the table headers.
        let keys = text
            .lines()
            .filter(|l| l.contains(" = ") && !l.starts_with('#'));
        let comments = text.lines().filter(|l| l.starts_with("# ")).count();
        assert!(comments > keys.count(), "{text}");
        assert!(text.contains("# Gain rule and process noise of the filter.\n[filter]\n"));
        assert!(text.contains("# Spread y_l - y_r, m.\nspread = "));
        assert_eq!(EstimatorConfig::from_toml(&text).unwrap(), c);
    }

    #[test]
    fn unknown_keys_and_bad_values_are_errors() {
        let e = EstimatorConfig::from_toml("[filter]\nq_spred = 1.0\n").unwrap_err();
        assert!(e.to_string().contains("q_spred"), "{e}");
        let e = EstimatorConfig::from_toml("[filter]\nq_spread = -1.0\n").unwrap_err();
        assert!(e.to_string().contains("q_spread"), "{e}");
        let e = EstimatorConfig::from_toml("[filter]\niekf_window = 0\n").unwrap_err();
        assert!(e.to_string().contains("iekf_window"), "{e}");
        let e = EstimatorConfig::from_toml("[band]\nmin_spread = 5.0\n").unwrap_err();
        assert!(e.to_string().contains("min_spread"), "{e}");
        let e = EstimatorConfig::from_toml("[filter]\nrate_k_spread = 20.0\n").unwrap_err();
        assert!(e.to_string().contains("rate_k_spread"), "{e}");
        let e = EstimatorConfig::from_toml("[filter]\nreport_icr = \"mean\"\n").unwrap_err();
        assert!(e.to_string().contains("mean"), "{e}");
        let c =
            EstimatorConfig::from_toml("[filter]\nrate_k_spread = 0.15\nrate_k_alpha = -0.02\n")
                .unwrap();
        assert_eq!(c.filter_config(0.5).rate_k_alpha, -0.02);
        assert_eq!(c.filter.rate_k_spread, 0.15);
        let e =
            EstimatorConfig::from_toml("[filter]\nrate_k_spread = 0.5\nmax_rate_k_spread = 0.3\n")
                .unwrap_err();
        assert!(e.to_string().contains("max_rate_k_spread"), "{e}");
        let e = EstimatorConfig::from_toml("[init]\nstd_rate_k_spread = -1.0\n").unwrap_err();
        assert!(e.to_string().contains("std_rate_k_spread"), "{e}");
        let e = EstimatorConfig::from_toml("[filter]\nfactor_coords = \"ratio\"\n").unwrap_err();
        assert!(e.to_string().contains("ratio"), "{e}");
    }

    #[test]
    fn rate_cap_on_and_startup_hold_off_by_default_both_selectable() {
        let c = EstimatorConfig::default().filter_config(0.5);
        assert_eq!(c.hold_alpha_turn, 0.0);
        assert!(!c.hold_alpha_at_reset && c.rate_dv_cap);
        let c = EstimatorConfig::from_toml(
            "[filter]\nhold_alpha_turn = 2.5\nrate_dv_cap = false\nhold_alpha_at_reset = true\n",
        )
        .unwrap()
        .filter_config(0.5);
        assert!(c.hold_alpha_turn == 2.5 && !c.rate_dv_cap && c.hold_alpha_at_reset);
        for bad in ["hold_alpha_turn = -1.0", "hold_alpha_spread_rel_std = -0.1"] {
            let key = bad.split(' ').next().unwrap();
            let e = EstimatorConfig::from_toml(&format!("[filter]\n{bad}\n")).unwrap_err();
            assert!(e.to_string().contains(key), "{e}");
        }
        // The papers' presets have neither.
        let p = EstimatorConfig::preset("ekf-reset")
            .unwrap()
            .filter_config(0.5);
        assert!(p.hold_alpha_turn == 0.0 && !p.rate_dv_cap);
    }

    #[test]
    fn factor_coordinates_are_selectable() {
        let c = EstimatorConfig::default();
        assert_eq!(c.filter_config(0.5).factor_coords, FactorCoords::PerSpread);
        let c = EstimatorConfig::from_toml("[filter]\nfactor_coords = \"difference\"\n").unwrap();
        assert_eq!(c.filter_config(0.5).factor_coords, FactorCoords::Difference);
    }

    #[test]
    fn heading_model_noise_and_reacquisition_are_configurable() {
        let c = EstimatorConfig::default();
        let f = c.filter_config(0.5);
        assert_eq!(f.q_yaw_per_rad, 4e-4);
        assert_eq!(f.q_icr.spread, 5e-6);
        assert_eq!((f.reacquire_gap, f.reacquire_time), (0.0, 0.0));
        let text = "[filter]\nq_yaw_per_rad = 1e-3\nreacquire_gap = 5.0\nreacquire_time = 20.0\n";
        let c = EstimatorConfig::from_toml(text).unwrap();
        let f = c.filter_config(0.5);
        assert_eq!(f.q_yaw_per_rad, 1e-3);
        assert_eq!((f.reacquire_gap, f.reacquire_time), (5.0, 20.0));
        assert_eq!(EstimatorConfig::from_toml(&c.to_toml()).unwrap(), c);
        for key in ["q_yaw_per_rad", "reacquire_gap", "reacquire_time"] {
            let e = EstimatorConfig::from_toml(&format!("[filter]\n{key} = -1.0\n")).unwrap_err();
            assert!(e.to_string().contains(key), "{e}");
        }
        // The papers' presets keep their model: no heading model noise, no
        // re-acquisition rule.
        for (name, p) in EstimatorConfig::presets() {
            if name != "terraslip" {
                assert_eq!(p.filter.q_yaw_per_rad, 0.0, "{name}");
                assert_eq!(p.filter.reacquire_gap, 0.0, "{name}");
            }
        }
    }

    #[test]
    fn partial_file_keeps_defaults() {
        let c = EstimatorConfig::from_toml("[filter]\nvariant = \"iekf\"\n").unwrap();
        assert_eq!(c.filter.variant, FilterVariant::Iekf);
        assert_eq!(c.init, InitSection::default());
    }

    #[test]
    fn presets_are_valid_and_distinct() {
        let p = EstimatorConfig::presets();
        assert_eq!(p.len(), 7);
        for (name, c) in &p {
            c.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                assert_ne!(p[i].1, p[j].1, "{} == {}", p[i].0, p[j].0);
            }
        }
        assert!(EstimatorConfig::preset("terraslip").is_some());
        assert!(EstimatorConfig::preset("nope").is_none());
    }
}
