//! Runs the online estimator over a drive log: the streams (tread speeds,
//! pose fixes, terrain evidence) are merged by time and handed to
//! [`terraslip_core::Estimator`] event by event, exactly as a robot would;
//! one [`EstimateRow`] is taken after each wheels row.

pub mod decide;
mod error;
mod estimate_row;
mod estimate_run;
mod evidence;
mod gyro_delay;
pub mod live;
mod options;
pub mod outage;
pub mod recommend;
mod replay;
pub mod row;
mod run;
mod setup;
mod start;
mod terrain_feed;
mod terrain_onset;
mod terrain_trial;
pub mod warmup;

pub use error::PipelineError;
pub use estimate_row::EstimateRow;
pub use estimate_run::{EstimateRun, LeverArm, NoiseUsed, RunStats, TerrainChange};
pub use evidence::TerrainEvidence;
pub use gyro_delay::SPAN as DECISION_SPAN;
pub use gyro_delay::{gyro_delay, gyro_delay_in, gyro_delay_referenced, GyroClock};
pub use options::RunOptions;
pub use replay::{RowSink, Streams};
pub use row::row;
pub use run::{run, run_streams, run_with};
pub use start::{estimator, pose_fix, seed_terrain};
