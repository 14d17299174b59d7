//! terraslip as a library: what the `terraslip` binary's commands are built
//! from, for the demo, tests and other programs.
//!
//! * [`bag`]: a LOG argument read, a log directory or a ROS 2 bag;
//! * [`belief`]: whether the live estimate is believed enough to drive on;
//! * [`config`]: the estimator's TOML configuration and named presets;
//! * `controller_turn`: a `diff_drive_controller` parameter file applied as
//!   written, its odometry's turn against the GNSS course (feature `ros2`);
//! * [`glossary`]: the presets' and the papers' names, for `--help` and outputs;
//! * [`pipeline`]: runs the online estimator over a [`terraslip_io::DriveLog`];
//! * [`estimate`]: what `terraslip estimate` does, as values: configuration,
//!   terrain evidence, the run, `summary.json` and the `estimate.csv` columns;
//! * [`metrics`]: scores a run against ground truth;
//! * [`prediction_score`]: the 2 s motion-prediction error of a run against
//!   the log's pose reference;
//! * [`report`]: plots and an HTML page of an estimate against its log;
//! * [`validation`]: what `calibrate validate --json` reports, as values.

pub mod bag;
pub mod belief;
pub mod config;
#[cfg(feature = "ros2")]
pub mod controller_turn;
pub mod estimate;
pub mod glossary;
#[cfg(feature = "ros2")]
pub mod live_streams;
pub mod metrics;
pub mod pipeline;
pub mod report;
pub mod validation;

pub use config::EstimatorConfig;
pub use pipeline::{run, EstimateRow, EstimateRun, RunOptions, TerrainEvidence};
pub use terraslip_calib::prediction::{PredictionScore, PredictionSpec, Timed};
#[doc(hidden)]
pub mod testkit;

/// How well the model a run had at each time (each row's
/// `prediction_model`: the ICRs at that row's turn with the centripetal
/// terms) predicts the next 2 s of motion from the log's pose reference, read
/// with the clock offset the run had learned by then
/// (`terraslip_calib::prediction`); `None` without a pose reference.
pub fn prediction_score(
    log: &terraslip_io::DriveLog,
    run: &EstimateRun,
) -> Option<PredictionScore> {
    let timeline: Vec<_> = run.rows.iter().map(|r| (r.t, r.prediction_model)).collect();
    prediction_of(log, run.track_width, &timeline)
}

/// How well a timeline of ICR parameters and clock offsets (`(t, timed)`
/// in time order, each in effect from its `t` on) predicts the next 2 s of
/// motion from the log's pose reference; `None` without a pose reference.
/// `track_width` in m scales the no-slip baseline.
pub fn prediction_of(
    log: &terraslip_io::DriveLog,
    track_width: f64,
    timeline: &[(f64, Timed)],
) -> Option<PredictionScore> {
    let params_at = |t: f64| {
        let k = timeline.partition_point(|r| r.0 <= t).checked_sub(1)?;
        Some(timeline[k].1)
    };
    terraslip_calib::prediction::score_timed(
        &log.wheels,
        &log.pose,
        track_width,
        &params_at,
        PredictionSpec::default(),
    )
}

/// An error as one line, as the command prints it after `error: `: the
/// chain of causes joined by ": ". A cause that its parent's message
/// already quotes (an I/O error inside a file error, say) is not repeated.
pub fn one_line(e: &anyhow::Error) -> String {
    let mut msg = String::new();
    for cause in e.chain() {
        let text = cause.to_string().trim().replace('\n', " ");
        if msg.contains(&text) {
            continue;
        }
        if !msg.is_empty() {
            msg.push_str(": ");
        }
        msg.push_str(&text);
    }
    msg
}
