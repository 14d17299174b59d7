//! The segment selection and the time offset, as calibrate and validate
//! both take them.

use anyhow::{bail, Context};
use serde::Serialize;
use terraslip_calib::OffsetChoice;

/// Segment selection shared by calibrate and validate.
#[derive(clap::Args, Clone, Serialize)]
#[serde(rename_all = "kebab-case")]
pub(super) struct SegmentArgs {
    /// Shortest segment between pose observations, s.
    #[arg(long, default_value_t = 1.0, value_name = "S")]
    pub(super) min_segment: f64,
    /// Only use poses at or after this time (log clock, s): for time splits.
    #[arg(long, value_name = "S")]
    pub(super) t_min: Option<f64>,
    /// Only use poses at or before this time (log clock, s).
    #[arg(long, value_name = "S")]
    pub(super) t_max: Option<f64>,
    /// Keep segments whose reference the treads cannot have produced
    /// (stalled or jumping poses) and poses stamped at the wrong time; both
    /// are dropped by default, alike for every model scored.
    #[arg(long)]
    pub(super) no_gate: bool,
}

impl SegmentArgs {
    pub(super) fn config(&self) -> anyhow::Result<terraslip_calib::SegmentConfig> {
        if !(self.min_segment.is_finite() && self.min_segment > 0.0) {
            bail!("--min-segment must be a positive number of seconds");
        }
        let mut c = terraslip_calib::SegmentConfig {
            min_duration: self.min_segment,
            max_duration: (3.0f64).max(3.0 * self.min_segment),
            reference_gate: !self.no_gate,
            drop_mistimed: !self.no_gate,
            ..Default::default()
        };
        if let Some(t) = self.t_min {
            c.t_min = t;
        }
        if let Some(t) = self.t_max {
            c.t_max = t;
        }
        Ok(c)
    }
}

/// `--time-offset`: `auto` (searched within +-0.5 s), seconds, or `params`
/// where `accepted` (the wording of the error) offers it.
pub(super) fn parse_offset(s: &str, accepted: &str) -> anyhow::Result<OffsetChoice> {
    match s {
        "params" if accepted.contains("params") => Ok(OffsetChoice::FromParams),
        "auto" => Ok(OffsetChoice::Auto {
            max: 0.5,
            step: 0.01,
        }),
        s => s
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .map(OffsetChoice::Fixed)
            .with_context(|| format!("--time-offset `{s}`: expected {accepted}")),
    }
}
