//! One estimator variant's run on the demo drive and its scores.

use terraslip::glossary;
use terraslip::metrics::Scorecard;
use terraslip::pipeline::EstimateRun;

/// Who each variant is, in a few words (the glossary's short form).
pub(super) fn short(name: &str) -> &'static str {
    glossary::short(name).unwrap_or("")
}

/// One variant's run and scores.
pub(super) struct Outcome {
    pub(super) name: String,
    pub(super) run: EstimateRun,
    pub(super) card: Scorecard,
}

/// Seconds after a change in which the steady-state error is not counted.
pub(super) const SETTLE: f64 = 20.0;
