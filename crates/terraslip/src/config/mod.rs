//! Configuration of the online estimator (`terraslip estimate --config`).
//!
//! One TOML file, every key optional (missing keys take the defaults shown by
//! `terraslip estimate --print-config`), unknown keys are an error. Units are
//! SI; noise "walks" are standard deviations grown per square-root second.
//! `[filter]` and `[measurement]` are the core's own
//! [`FilterConfig`] and [`MeasurementConfig`]: their defaults and their
//! validation live in one place, which the tests, benches and this command
//! share.

mod docs;
mod presets;

use serde::{Deserialize, Serialize};
use terraslip_core::filter::{FilterConfig, IcrBand, MeasurementConfig, Prior, SlipStd};
use terraslip_core::kinematics::CentripetalSlopes;
use terraslip_core::schedule::ScheduleConfig;
use terraslip_core::terrain_belief::BeliefConfig;
use terraslip_core::IcrParams;

/// Everything `estimate` needs besides the log.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EstimatorConfig {
    /// Gain rule, coordinates, process noise, gates and the slip-change
    /// detector of the filter.
    pub filter: FilterConfig,
    /// Starting slip parameters and their uncertainty.
    pub init: InitSection,
    /// The pose fixes' noise (used where `pose.csv` states none, and as the
    /// start of the noise learning) and clock.
    pub measurement: MeasurementConfig,
    /// Physical band the ICRs are kept in, relative to the track width.
    pub band: BandSection,
    /// Reaction to declared terrain changes: boost, reset, memory.
    pub schedule: ScheduleSection,
    /// Terrain belief over classifier outputs (`--terrain-model`).
    pub belief: BeliefConfig,
}

/// `[init]`
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InitSection {
    /// Track width used when `meta.toml` has none, m (a warning is printed).
    pub default_track_width: f64,
    /// Initial spread y_l - y_r as a multiple of the track width (without
    /// `--init`).
    pub spread_factor: f64,
    /// Initial std of the spread, as a multiple of the track width: real
    /// skid-steer robots turn as if 1-3 track widths wide.
    pub spread_std_factor: f64,
    /// Initial std of the centre (y_l + y_r)/2, m.
    pub std_centre: f64,
    /// Initial std of x_c, m.
    pub std_x_c: f64,
    /// Initial std of the common speed factor (around 1).
    pub std_alpha: f64,
    /// Initial std of the speed factor difference (around 0).
    pub std_alpha_diff: f64,
    /// Std of calibrated parameters from `--init`.
    pub calibrated_std: SlipStd,
    /// Starting slope of the turn law, s/m: the spread in effect is
    /// `1 + slope |V_r - V_l|` times the straight-line one (negative: the
    /// robot turns as if narrower in fast turns, as the treads' grip
    /// saturates). `--init` files from `calibrate` carry one.
    pub turn_law: f64,
    /// Std of the turn law's slope, s/m (0 = held at `turn_law`).
    pub std_turn_law: f64,
    /// Starting std of the centripetal term `k_x_speed` (starting at 0), s:
    /// `x_c` moves by `k_x_speed` m per m/s of mean tread speed, a lateral
    /// slip `-k_x_speed v omega`. Learned only with a position reference;
    /// 0 = held.
    pub std_k_x_speed: f64,
    /// Starting std of the centripetal term `k_spread_speed`, s/m: the
    /// spread scales by `1 + k_spread_speed |v|` at mean tread speed `v`.
    /// 0 = held at its starting value (0, or an `--init` file's): learning
    /// it lost on the family of worlds (docs/benchmarks.md).
    pub std_k_spread_speed: f64,
    /// Starting std of the speed factors' turn law (starting at 0), s/m: both speed factors in effect are
    /// `1 + slope |V_r - V_l|` times the straight-line ones (negative: the
    /// treads lose speed in a turn). Learned only with a position
    /// reference; 0 = held.
    pub std_speed_law: f64,
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
    /// q_max / q_min factor on the slip random walk after a declared terrain
    /// change (1 = off; the papers' boost).
    pub boost_factor: f64,
    /// Pose fixes the boost lasts (the papers' k).
    pub boost_updates: u32,
    /// Reset the slip covariance at a change to an unlearned terrain (chen2023).
    pub reset: bool,
    /// Reset std (chen2023's P_B).
    pub reset_std: SlipStd,
    /// Recall learned slip parameters when a terrain is revisited.
    pub memory: bool,
    /// Seconds of driving on a terrain before its parameters are remembered;
    /// under `--init`, also the seconds of estimates (taken after half of
    /// it) before a detected slip change falls back to their mean rather
    /// than to the given set.
    pub memory_min_dwell: f64,
    /// Time constant (s) of the running average of the slip parameters
    /// remembered for a terrain, taken after half of `memory_min_dwell`
    /// (0 = remember the estimate at the moment of leaving).
    pub memory_average: f64,
    /// Floor on recalled std: a remembered estimate is not trusted more.
    pub recall_floor: SlipStd,
}

impl Default for InitSection {
    fn default() -> Self {
        Self {
            default_track_width: 0.5,
            spread_factor: 1.0,
            spread_std_factor: 0.5,
            std_centre: 0.05,
            std_x_c: 0.1,
            std_alpha: 0.1,
            std_alpha_diff: 0.01,
            calibrated_std: SlipStd {
                spread: 0.01,
                centre: 0.01,
                x_c: 0.02,
                alpha: 0.01,
                alpha_diff: 0.003,
            },
            turn_law: 0.0,
            std_turn_law: 0.1,
            std_k_x_speed: 0.1,
            std_k_spread_speed: 0.0,
            std_speed_law: 0.02,
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
            min_alpha: 0.3,
            max_alpha: 1.5,
        }
    }
}

impl Default for ScheduleSection {
    fn default() -> Self {
        let c = ScheduleConfig::default();
        Self {
            boost_factor: c.boost_factor,
            boost_updates: c.boost_updates,
            reset: c.reset.is_some(),
            reset_std: c.reset.unwrap_or(terraslip_core::schedule::RESET_STD),
            memory: c.memory,
            memory_min_dwell: c.memory_min_dwell,
            memory_average: c.memory_average,
            recall_floor: c.recall_floor,
        }
    }
}

/// One line: "line N: message" from a TOML error.
pub fn toml_error(text: &str, e: &toml::de::Error) -> ConfigError {
    ConfigError(toml_message(text, e))
}

/// A TOML error in `text` as one line, "line N: message".
pub fn toml_message(text: &str, e: &toml::de::Error) -> String {
    let msg = e.message().trim().replace('\n', " ");
    match e.span() {
        Some(span) => {
            let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
            format!("line {line}: {msg}")
        }
        None => msg,
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
    /// documentation as TOML comments (`estimate --print-config`).
    pub fn to_commented_toml(&self) -> String {
        let mut out = String::from(
            "# terraslip estimate configuration (`--config FILE`). Every key is optional:\n\
             # a missing key keeps the default shown. Units are SI; angles in rad.\n\
             # More in docs/estimator.md.\n\n",
        );
        out.push_str(&docs::annotate(&self.to_toml(), "EstimatorConfig"));
        out
    }

    /// Keys of [`Self::to_toml`] (as `table.key`) with no documentation.
    pub fn undocumented_keys(&self) -> Vec<String> {
        docs::documented_lines(&self.to_toml(), "EstimatorConfig")
            .filter_map(|(line, table, doc)| {
                let (key, _) = line.split_once('=')?;
                (doc.is_empty() && docs::toml_table(line.trim()).is_none())
                    .then(|| format!("{table}.{}", key.trim()))
            })
            .collect()
    }

    /// Checks ranges; every constant must be finite and of the right sign.
    /// The filter's and measurement's own checks are the core's.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let bad = |e: terraslip_core::FilterError| ConfigError(e.to_string());
        self.filter.validate().map_err(bad)?;
        self.measurement.validate().map_err(bad)?;
        let i = &self.init;
        let positive = [
            ("init.default_track_width", i.default_track_width),
            ("init.spread_factor", i.spread_factor),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(ConfigError(format!("{name} = {v} must be finite and > 0")));
            }
        }
        let nonneg = [
            ("init.spread_std_factor", i.spread_std_factor),
            ("init.std_centre", i.std_centre),
            ("init.std_x_c", i.std_x_c),
            ("init.std_alpha", i.std_alpha),
            ("init.std_alpha_diff", i.std_alpha_diff),
            ("init.std_turn_law", i.std_turn_law),
            ("init.std_k_x_speed", i.std_k_x_speed),
            ("init.std_k_spread_speed", i.std_k_spread_speed),
            ("init.std_speed_law", i.std_speed_law),
            ("schedule.boost_factor", self.schedule.boost_factor),
            ("schedule.memory_min_dwell", self.schedule.memory_min_dwell),
            ("schedule.memory_average", self.schedule.memory_average),
        ];
        for (name, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ConfigError(format!("{name} = {v} must be finite and >= 0")));
            }
        }
        for (name, s) in [
            ("init.calibrated_std", &i.calibrated_std),
            ("schedule.reset_std", &self.schedule.reset_std),
            ("schedule.recall_floor", &self.schedule.recall_floor),
        ] {
            if !s.is_valid() {
                return Err(ConfigError(format!(
                    "{name}: every entry must be finite and >= 0"
                )));
            }
        }
        let b = &self.band;
        if !(b.min_spread > 0.0
            && b.max_spread > b.min_spread
            && b.max_spread.is_finite()
            && b.max_centre >= 0.0
            && b.max_x_c >= 0.0
            && b.min_alpha > 0.0
            && b.max_alpha > b.min_alpha
            && b.max_alpha.is_finite())
        {
            return Err(ConfigError(
                "band: need 0 < min_spread < max_spread, max_centre >= 0, max_x_c >= 0, \
                 0 < min_alpha < max_alpha (all finite)"
                    .into(),
            ));
        }
        if i.turn_law.is_nan() || i.turn_law.abs() > 2.0 {
            return Err(ConfigError(format!(
                "init.turn_law = {} s/m must be within +-2",
                i.turn_law
            )));
        }
        if !(i.spread_factor >= b.min_spread && i.spread_factor <= b.max_spread) {
            return Err(ConfigError(format!(
                "init.spread_factor = {} lies outside band.min_spread..band.max_spread",
                i.spread_factor
            )));
        }
        let bc = &self.belief;
        if !((0.0..=1.0).contains(&bc.stay_prob) && (0.0..=1.0).contains(&bc.stay_prob_on_jump)) {
            return Err(ConfigError(
                "belief.stay_prob and belief.stay_prob_on_jump must be in 0..1".into(),
            ));
        }
        if bc.vote_lambda == 0 {
            return Err(ConfigError("belief.vote_lambda must be >= 1".into()));
        }
        Ok(())
    }

    /// The physical band for a robot of track width `w` (m).
    pub fn band(&self, w: f64) -> IcrBand {
        let b = &self.band;
        IcrBand {
            min_spread: b.min_spread * w,
            max_spread: b.max_spread * w,
            max_centre: b.max_centre * w,
            max_x_c: b.max_x_c * w,
            alpha_range: (b.min_alpha, b.max_alpha),
        }
    }

    /// The starting slip parameters for a robot of track width `w` (m)
    /// without calibration.
    pub fn prior(&self, w: f64) -> Prior {
        let i = &self.init;
        let d = i.spread_factor * w;
        Prior {
            icr: IcrParams::new(0.5 * d, -0.5 * d, 0.0),
            std: SlipStd {
                spread: i.spread_std_factor * w,
                centre: i.std_centre,
                x_c: i.std_x_c,
                alpha: i.std_alpha,
                alpha_diff: i.std_alpha_diff,
            },
            turn_law: i.turn_law,
            turn_law_std: i.std_turn_law,
            centripetal: CentripetalSlopes::NONE,
            centripetal_std: CentripetalSlopes {
                k_x_speed: i.std_k_x_speed,
                k_spread_speed: i.std_k_spread_speed,
            },
            speed_law: 0.0,
            speed_law_std: i.std_speed_law,
        }
    }

    /// The core schedule settings.
    pub fn schedule_config(&self) -> ScheduleConfig {
        let s = &self.schedule;
        ScheduleConfig {
            boost_factor: s.boost_factor,
            boost_updates: s.boost_updates,
            reset: s.reset.then_some(s.reset_std),
            memory: s.memory,
            memory_min_dwell: s.memory_min_dwell,
            memory_average: s.memory_average,
            recall_floor: s.recall_floor,
        }
    }
}

#[cfg(test)]
mod tests;
