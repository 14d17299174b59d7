//! Extended Kalman filter over [`crate::model`]: pose, slip parameters,
//! the pose stream's clock offset and the slow part of the position fixes'
//! error, from tread speeds and absolute pose fixes.
//!
//! * `ekf.rs`: the [`Filter`] itself, started from a [`Prior`]
//!   (`prior.rs`) and kept in the [`IcrBand`] (`band.rs`) and the other
//!   states' limits (`limits.rs`); `readout.rs`: what it tells.
//! * `config.rs`, `measurement.rs`: its settings; `error.rs`: why a step
//!   was refused.
//! * [`predict`](Filter::predict) (`predict.rs`): one model step and
//!   `P = F P F' + Q`.
//! * [`update`](Filter::update) (`update.rs`): a pose fix (`fix.rs`:
//!   position, heading or both) compared with where the robot was when the
//!   fix was taken (`measure.rs`), chi-square gates per part, the Kalman
//!   gain (or the papers' innovation-adaptive one, `adaptive.rs`) with the
//!   rows of what must not learn zeroed (`gain.rs`) and the Joseph-form
//!   update; the first fixes taken as the pose (`anchor.rs`); a gated
//!   heading's unexplained variance taken into the heading (`gate.rs`).
//! * [`add_gyro`](Filter::add_gyro) (`gyro.rs`, `gyro_window.rs`): the
//!   gyro's heading change over a short window against the model's, its
//!   bias and noise learned.
//! * `detector.rs`: a slip-change detector on the normalised innovations
//!   that resets the slip uncertainty when the ground changes.
//! * `noise.rs`: the measurement noise scale learned from the residuals.
//! * `reset.rs`: covariance resets and recalls (the terrain schedule's).
//!
//! Frames: REP-103 body frame, ENU world frame, yaw counter-clockwise from
//! east. Units SI.

mod adaptive;
mod anchor;
mod band;
mod config;
pub(crate) mod detector;
mod ekf;
mod error;
mod fix;
mod gain;
mod gyro;
mod gyro_window;
mod history;
mod limits;
mod measure;
mod measurement;
mod noise;
mod predict;
mod prior;
mod readout;
mod reset;
mod update;

pub use band::IcrBand;
pub use config::{FilterConfig, SlipHold, SlipStd, Variant, MAX_WINDOW};
pub use ekf::Filter;
pub use error::FilterError;
pub use fix::{Fate, PoseFix, UpdateReport};
pub use gyro::{GyroNoise, GYRO_WINDOW};
pub use limits::{
    MAX_CLOCK_OFFSET, MAX_GYRO_SCALE, MAX_K_SPREAD_SPEED, MAX_K_X_SPEED, MAX_TURN_LAW,
};
pub use measurement::{MeasurementConfig, MAX_LEVER_ARM};
pub use predict::DeadReckoning;
pub use prior::Prior;

#[cfg(test)]
mod tests;
