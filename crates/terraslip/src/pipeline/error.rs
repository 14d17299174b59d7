//! Why a run could not be made.

use terraslip_io::LogError;

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error("{dir}: wheels.csv has no rows; a drive needs at least one")]
    NoWheels { dir: String },
    #[error("invalid configuration: {0}")]
    Config(String),
    #[error("initial parameters: {0}")]
    Init(String),
    #[error(transparent)]
    Read(#[from] LogError),
    #[error("{path}: write failed: {source}; check the free space and permissions there")]
    Write {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{dir}: the estimator failed at t = {t} s: {source}; check that row of wheels.csv and pose.csv, meta.toml's sizes and any --init or --config")]
    Filter {
        dir: String,
        t: f64,
        #[source]
        source: terraslip_core::FilterError,
    },
}
