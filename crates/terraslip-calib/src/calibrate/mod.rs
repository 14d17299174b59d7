//! The whole offline calibration: segments, time offset, the three methods,
//! identifiability checks, one parameter set per terrain ([`calibrate()`]).
//!
//! - `run`: [`calibrate()`], the offset search then `per_terrain`'s sets,
//!   each calibrated by `set` (or by `position_only` from GNSS fixes alone);
//! - `config`: what is asked ([`CalibConfig`]);
//! - `identify`: which parameters the data pin down; `robot`: what
//!   `meta.toml` says of the robot; `offset_warnings`: offsets not pinned;
//! - `offset_profile`: the model-based second stage of the time offset;
//! - `rate`: the turn-rate and traction terms and the criterion that keeps them;
//! - `result`: what was found ([`Calibration`]) and the parameter file.

mod config;
mod criterion;
mod identify;
mod json;
mod method_fit;
mod offset_profile;
mod offset_warnings;
mod per_terrain;
mod position_only;
mod progress;
mod rate;
mod reduction;
mod result;
mod robot;
mod run;
mod set;

pub use config::{CalibConfig, GaSettings, Method, RateModel, TimeOffset};
pub use method_fit::MethodFit;
pub use per_terrain::FIT_SEGMENTS;
pub use progress::Progress;
pub use rate::RateChoice;
pub use reduction::ReductionChoice;
pub use result::{Calibration, DroppedSegment, SetCalibration, TurnFigures};
pub use run::calibrate;
pub use set::GA_SEGMENTS;
