//! terraslip-calib: offline identification of the ICR kinematic parameters
//! of a skid-steering robot from logged drives with a pose reference,
//! following Mandow et al. 2007 and going past it.
//!
//! Pipeline ([`calibrate()`]):
//! 1. [`segment`]: the drive is cut into segments between pose observations
//!    at least 1 s apart; held (repeated) poses are dropped, stationary
//!    segments skipped, increments expressed in the frame of each segment start.
//!    The fit uses a segment from every pose (overlapping); each log's
//!    wheel steps form one timeline that the segments share, so the LM
//!    integrates a drive once per parameter vector ([`model::residuals_rate`]).
//! 2. [`offset`]: the wheel/pose time offset is estimated per log (every
//!    candidate scored on the same segments), then refined by the profile
//!    of the LM fit.
//! 3. [`lm`]: a robust Levenberg-Marquardt fit from the no-slip model sets
//!    the residual scale and drops outlier segments (reported).
//! 4. The methods minimise eq. 13 (Cauchy-robust, over the inliers):
//!    [`lm`], the paper's [`ga`], and the symmetric quick calibration
//!    ([`symmetric`], eqs. 11-12). The lowest robust cost wins.
//! 5. Past the paper, a turn-rate dependent model ([`model::RateSlopes`]:
//!    spread and speed factors that change with the tread speed difference)
//!    is fitted next to the constant winner and kept when it lowers the
//!    information criterion ([`RateModel`]).
//! 6. One set per terrain of `terrain.csv`; steering efficiency, eccentricity,
//!    uncertainties, and Pioneer Ticksmm/Revcount in the output.
//!
//! A position-only reference (GNSS fixes, no heading on any row of any
//! log) is fitted instead on windows of fixes, each window's start heading
//! and position profiled out ([`track`], fitted by [`track_fit`]).
//!
//! [`validate()`] scores a parameter file on other drives against the no-slip
//! model, per segment (Mandow Table III), with the turn-rate model where the
//! file selected one and the constant model alongside.
//!
//! Frames: REP-103 (body x forward, y left; world ENU). Units: SI.

pub mod calibrate;
pub mod course;
pub mod ga;
pub mod lever_arm;
pub mod lm;
pub mod model;
pub mod offset;
pub mod outage;
pub mod position_prediction;
pub mod prediction;
mod prediction_stream;
pub mod reduction;
pub mod sandwich;
pub mod segment;
pub mod symmetric;
pub mod synthetic;
pub mod track;
pub mod track_fit;
pub mod validate;

use std::path::PathBuf;

pub use calibrate::{
    calibrate, CalibConfig, Calibration, GaSettings, Method, MethodFit, Progress, RateChoice,
    RateModel, SetCalibration, TimeOffset,
};
pub use model::RateSlopes;
pub use segment::{Increment, SegmentConfig, Segments};
pub use validate::{validate, ModelChoice, Mse, OffsetChoice, ValidateConfig, Validation};

/// Why a calibration or validation could not be done.
#[derive(Debug, thiserror::Error)]
pub enum CalibError {
    #[error("no log given")]
    NoLogs,
    #[error(
        "{log}: no pose reference (pose.csv is missing or has no rows); calibration needs one"
    )]
    NoPose { log: PathBuf },
    #[error(
        "{log}: meta.toml has no track_width, so the no-slip model to compare against is undefined"
    )]
    NoTrackWidth { log: PathBuf },
    #[error("set `{set}`: only {moving} usable moving segments, need at least {needed} ({hint})")]
    TooFewSegments {
        set: String,
        moving: usize,
        needed: usize,
        /// What to look at, from why pose rows and segments were dropped.
        hint: String,
    },
    #[error("set `{set}`: cannot identify {}: {reason}", params.join(", "))]
    Unobservable {
        set: String,
        params: Vec<&'static str>,
        reason: String,
    },
    #[error("parameter set `{set}`: rate_model is selected but unusable: {reason}")]
    BadRateModel { set: String, reason: String },
    #[error("set `{set}`: the symmetric calibration needs {what}, the drive has none")]
    SymmetricNeeds { set: String, what: &'static str },
}
