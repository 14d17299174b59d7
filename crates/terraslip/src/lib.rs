//! terraslip as a library: what the `terraslip` binary's commands are built
//! from, for the demo, tests and other programs.
//!
//! * [`config`]: the estimator's TOML configuration and named presets;
//! * [`pipeline`]: runs the online estimator over a [`terraslip_io::DriveLog`];
//! * [`metrics`]: scores a run against ground truth;
//! * [`prediction_score`]: the 2 s motion-prediction error of a run against
//!   the log's pose reference.

pub mod config;
pub mod metrics;
pub mod pipeline;

pub use config::EstimatorConfig;
pub use pipeline::{run, EstimateRow, EstimateRun, RunOptions, TerrainEvidence};
pub use terraslip_calib::prediction::{PredictionScore, PredictionSpec};
#[doc(hidden)]
pub mod testkit;

/// How well the ICRs a run reported at each time (those in effect at that
/// row) predict the next 2 s of motion from the log's pose reference
/// (`terraslip_calib::prediction`); `None` without a pose reference.
pub fn prediction_score(
    log: &terraslip_io::DriveLog,
    run: &EstimateRun,
) -> Option<PredictionScore> {
    let rows = &run.rows;
    let params_at = |t: f64| {
        let k = rows.partition_point(|r| r.t <= t).checked_sub(1)?;
        let r = &rows[k];
        Some(terraslip_core::IcrParams {
            y_l: r.y_l,
            y_r: r.y_r,
            x_c: r.x_c,
            alpha_l: r.alpha_l,
            alpha_r: r.alpha_r,
        })
    };
    terraslip_calib::prediction::score(
        &log.wheels,
        &log.pose,
        run.track_width,
        &params_at,
        PredictionSpec::default(),
    )
}
