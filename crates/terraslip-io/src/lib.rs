//! The drive-log directory format, version 1 (`docs/log-format.md`).
//!
//! A log is a directory of CSV files sharing one clock. [`DriveLog::read`]
//! loads and validates one, reporting bad input with file, line and reason;
//! [`DriveLog::write`] writes one atomically file by file.
//!
//! Frames: world ENU metres, yaw radians counter-clockwise from east (wrapped
//! to (-pi, pi] on read); body REP-103.

mod angle;
pub mod atomic;
mod cell;
mod csv_table;
mod estimate;
pub mod guard;
pub mod params;
mod pose_steps;
mod read;
pub mod shared;
mod stream;
mod types;
mod write;

pub use angle::wrap_angle;
pub use atomic::{write_atomic, AtomicFile, DirLock};
pub use csv_table::{physical_limit, read_csv_table, CsvTable};
pub use estimate::{read_estimate, read_prediction, EstimateRecord, PredictionRecord};
pub use guard::{Inputs, Outputs, OverInput, SameOutput};
pub use params::{ParamEntry, ParamsFile, RateModelEntry};
pub use read::{read_images, read_imu, read_meta, read_terrain, read_truth, Streams};
pub use stream::{read_currents, read_pose, read_wheels, GyroStream, PoseStream, WheelStream};
pub use types::*;
pub use write::write_csv;
