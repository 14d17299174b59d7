//! ROS 2 in and out for terraslip.
//!
//! - [`Bag`] opens a rosbag2 recording (MCAP or sqlite3 `.db3`, a directory
//!   with `metadata.yaml` versions 4-9 or a single file; zstd/lz4 compressed
//!   files, chunks or messages) and streams its raw CDR messages.
//! - [`msg`] decodes CDR from the `ros2msg` definitions stored in the bag, or
//!   from built-in ones ([`defs`]) for bags that carry none.
//! - [`import`] turns a bag into a terraslip drive log (`docs/log-format.md`):
//!   wheel tread speeds, pose (GNSS in ENU about the first good fix, heading),
//!   IMU and camera frames, choosing topics by type or from a [`TopicsConfig`].
//! - [`out`] writes estimates as ROS 2 messages into MCAP for Foxglove.
//! - [`diffdrive`] turns calibrated ICRs into `diff_drive_controller` parameters;
//!   [`controller_yaml`] reads such a file back as a controller takes it.
//!
//! Frames: REP-103 (body x forward, y left; world ENU, yaw counter-clockwise
//! from east). Units: SI.

pub mod bag;
pub mod controller_yaml;
pub mod defs;
pub mod diffdrive;
pub mod import;
pub mod metadata;
pub mod msg;
pub mod out;
pub mod twist;

pub use bag::{is_bag, Bag, HeldMessage, RawMessage, Topic};
pub use import::{import, import_within, ImportReport, TopicsConfig};

use std::path::PathBuf;

/// Errors reading or writing ROS 2 data. Each names the bag, and where it
/// concerns one message, its topic, type and index in the bag.
#[derive(Debug, thiserror::Error)]
pub enum Ros2Error {
    #[error("{bag}: {reason}")]
    Bag { bag: PathBuf, reason: String },
    #[error("{bag}: topic {topic} ({ty}), message {index}: {reason}")]
    Message {
        bag: PathBuf,
        topic: String,
        ty: String,
        index: u64,
        reason: String,
    },
    #[error(transparent)]
    Log(#[from] terraslip_io::LogError),
}
