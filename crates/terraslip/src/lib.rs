//! terraslip as a library: what the `terraslip` binary's commands are built
//! from, for the demo, tests and other programs.
//!
//! * [`config`]: the estimator's TOML configuration and named presets;
//! * [`pipeline`]: runs the online estimator over a [`terraslip_io::DriveLog`];
//! * [`metrics`]: scores a run against ground truth.

pub mod config;
pub mod metrics;
pub mod pipeline;

pub use config::EstimatorConfig;
pub use pipeline::{run, EstimateRow, EstimateRun, RunOptions, TerrainEvidence};
#[doc(hidden)]
pub mod testkit;
