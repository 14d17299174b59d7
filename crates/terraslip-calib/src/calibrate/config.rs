//! What a calibration is asked to do: the method, the time offset, the GA
//! settings, the turn-rate and traction terms.

use crate::ga::GaConfig;
use crate::lm::LmConfig;
use crate::segment::SegmentConfig;
use crate::track::TrackConfig;

/// Identification method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Method {
    /// Robust Levenberg-Marquardt from the no-slip model.
    Lm,
    /// Mandow's genetic algorithm.
    Ga,
    /// Mandow's quick symmetric calibration (eqs. 11-12).
    Symmetric,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Lm => "lm",
            Method::Ga => "ga",
            Method::Symmetric => "symmetric",
        }
    }
}

/// How the wheel/pose time offset is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeOffset {
    /// Searched per log in `[-max, max]` s on a `step` grid.
    Auto { max: f64, step: f64 },
    /// The same given offset (s) for every log.
    Fixed(f64),
}

/// GA knobs exposed to users; the bounds default to ones scaled by the
/// robot's track width.
#[derive(Debug, Clone, PartialEq)]
pub struct GaSettings {
    pub population: usize,
    pub generations: usize,
    pub seed: u64,
    pub gene_bits: Option<u32>,
    pub bounds: Option<[(f64, f64); 5]>,
    pub threads: Option<usize>,
}

impl Default for GaSettings {
    fn default() -> Self {
        let d = GaConfig::for_track_width(1.0);
        Self {
            population: d.population,
            generations: d.generations,
            seed: d.seed,
            gene_bits: None,
            bounds: None,
            threads: None,
        }
    }
}

/// Calibration settings. Defaults are what `terraslip calibrate` uses.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibConfig {
    pub segment: SegmentConfig,
    /// Windows of fixes for a position-only reference (every log's pose
    /// rows without a heading, [`crate::track`]); its `t_min`/`t_max` are
    /// `segment`'s.
    pub track: TrackConfig,
    /// Weight between metres and radians in eq. 13, m/rad: a heading error
    /// of 1 rad costs as much as a position error of `yaw_weight` m.
    /// Mandow et al. use 1. The default 0.5 is about the sideways shift a
    /// heading error causes at the end of a 1 s segment driven at 1 m/s
    /// (`d * dphi / 2`); on the Warthog drives it predicted held-out
    /// positions better than 1 (see docs/research-log.md).
    pub yaw_weight: f64,
    /// `None` runs every method and keeps the best.
    pub method: Option<Method>,
    pub lm: LmConfig,
    pub ga: GaSettings,
    pub time_offset: TimeOffset,
    /// Fewest moving segments (after outlier removal) a set needs.
    pub min_segments: usize,
    /// Fewest segments turning more than 0.1 rad for the spread and x_c to
    /// be identifiable.
    pub min_turning_segments: usize,
    /// Instead of failing when the data cannot identify some parameters,
    /// keep those at their no-slip value, fit the rest and list them under
    /// `unidentified`.
    pub allow_partial: bool,
    /// Whether to fit the turn-rate dependent model ([`RateSlopes`](crate::model::RateSlopes)) next to
    /// the constant one.
    pub rate_model: RateModel,
    /// Whether to fit the traction term (`k_acc`, and `k_dir` with
    /// `traction_signed`) on top of the turn-rate model. `Auto` selects it
    /// by the same information criterion; `Off` unless `rate_model` is on.
    pub traction: RateModel,
    /// Let the traction term differ between accelerating and braking.
    pub traction_signed: bool,
    /// Whether to fit the centripetal terms (`k_x_speed`, `k_spread_speed`
    /// of [`RateSlopes`](crate::model::RateSlopes)) on top of the selected
    /// model. `Auto` selects them by the same information criterion.
    pub centripetal: RateModel,
    /// Whether to fit the reduced constant models ([`Reduction`](crate::reduction::Reduction):
    /// symmetric ICRs, `x_c` at 0, equal speed factors, and their
    /// combinations) next to the full one and keep the one of lowest
    /// information criterion; the variable models then hold its relations.
    pub reduced_models: bool,
}

/// Whether the turn-rate dependent ICR model ([`RateSlopes`](crate::model::RateSlopes)) is fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RateModel {
    /// Only Mandow's constant ICRs.
    Off,
    /// Fitted, and selected when it lowers the Bayesian information
    /// criterion over the constant model on the same segments and both
    /// slopes are identified.
    Auto,
    /// Fitted and selected whenever both slopes are identified.
    On,
}

impl RateModel {
    pub fn name(self) -> &'static str {
        match self {
            RateModel::Off => "off",
            RateModel::Auto => "auto",
            RateModel::On => "on",
        }
    }
}

impl Default for CalibConfig {
    fn default() -> Self {
        Self {
            // Fit on a segment from every pose (see `SegmentConfig::overlap`):
            // it uses all the data, and on simulated drives it recovers the
            // true parameters best of all the segmentations tried
            // (docs/research-log.md, `fit_segments`). Overlap costs
            // little: the LM integrates each drive once per parameter vector.
            segment: SegmentConfig {
                overlap: Some(0.0),
                ..SegmentConfig::default()
            },
            track: TrackConfig::default(),
            yaw_weight: 0.5,
            method: None,
            lm: LmConfig::default(),
            ga: GaSettings::default(),
            time_offset: TimeOffset::Auto {
                max: 0.5,
                step: 0.01,
            },
            min_segments: 10,
            min_turning_segments: 5,
            allow_partial: false,
            rate_model: RateModel::Auto,
            traction: RateModel::Auto,
            traction_signed: false,
            centripetal: RateModel::Auto,
            reduced_models: true,
        }
    }
}
