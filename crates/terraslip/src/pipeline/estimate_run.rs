//! What a run of the estimator gives: its rows, terrain changes,
//! figures, the parameters and noise it ended with.

use terraslip_calib::prediction::PredictionScore;
use terraslip_core::estimator::FixCounts;
use terraslip_core::filter::{IcrBand, SlipHold};
use terraslip_core::schedule::ChangeAction;
use terraslip_core::IcrParams;

use super::recommend;
use super::EstimateRow;

/// One terrain change the schedule acted on.
#[derive(Debug, Clone, PartialEq)]
pub struct TerrainChange {
    /// Time, s.
    pub t: f64,
    /// Index into [`EstimateRun::terrains`].
    pub terrain: usize,
    /// What the schedule did.
    pub action: ChangeAction,
}

/// Counters of one run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunStats {
    /// What happened to the fixes.
    pub fixes: FixCounts,
    /// Fixes given to the estimator.
    pub fixes_used: usize,
    /// Fixes dropped by [`RunOptions::outage`].
    pub dropped_fixes: usize,
}

/// The measurement noise the run used in the end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseUsed {
    /// Position std per axis, m (as learned, for fixes at the stated std).
    pub std_xy: f64,
    /// Heading std, rad.
    pub std_yaw: f64,
    /// Std of the slowly wandering part of the position error, m.
    pub correlated_std: f64,
    /// Model noise of the speed, m^2/s per (m/s)^2, and of the yaw rate,
    /// rad^2/s per (rad/s)^2 (learned with the rest).
    pub model: (f64, f64),
    /// Whether `pose.csv` stated the stds (`std_xy`, `std_yaw` columns).
    pub stated: bool,
    /// Whether the noise was learned from the residuals.
    pub learned: bool,
}

/// Result of [`run`].
#[derive(Debug, Clone, PartialEq)]
pub struct EstimateRun {
    /// One row per wheels row (empty when [`run_streams`] handed them to
    /// a sink instead).
    pub rows: Vec<EstimateRow>,
    /// How many rows the run made, and the first and the last of them.
    pub row_count: usize,
    pub first_row: Option<EstimateRow>,
    pub last_row: Option<EstimateRow>,
    /// The rows' ICRs averaged over the whole drive, with their
    /// uncertainty ([`recommend`]); `None` without rows.
    pub drive: Option<recommend::DriveFigures>,
    /// The 2 s motion-prediction error of the parameters the rows
    /// reported against the pose reference (what
    /// [`crate::prediction_score`] computes from the rows); `None` without
    /// a pose reference.
    pub prediction: Option<PredictionScore>,
    /// The outage yardstick: the estimate dead-reckoned through 10, 30
    /// and 60 s without pose fixes from starts every 10 s, beside no-slip
    /// odometry and odometry + gyro ([`outage`]); `None` without a pose
    /// reference or a start.
    pub outage: Option<terraslip_calib::outage::OutageScore>,
    /// Terrain names the rows' indices refer to.
    pub terrains: Vec<String>,
    /// Terrain changes the schedule acted on.
    pub changes: Vec<TerrainChange>,
    /// Track width used for the band and the prior, m.
    pub track_width: f64,
    /// The physical band the ICRs were kept in.
    pub band: IcrBand,
    /// Final slip parameters (straight-line values).
    pub final_icr: IcrParams,
    /// Final turn law slope and its std, s/m.
    pub turn_law: (f64, f64),
    /// Final slope of the speed factors' turn law and its std, s/m.
    pub speed_law: (f64, f64),
    /// Final centripetal terms (`k_x_speed` s, `k_spread_speed` s/m), their
    /// stds, and whether they were learned (false: held at their starting
    /// values, without a position reference or with a zero prior std).
    pub centripetal: (
        terraslip_core::kinematics::CentripetalSlopes,
        terraslip_core::kinematics::CentripetalSlopes,
        bool,
    ),
    /// The slip parameters the log's sensors could not teach, held at
    /// their starting values (decided from the log: positions, headings,
    /// gyro).
    pub hold: SlipHold,
    /// Where the starting slip parameters came from (`prior`, `init:<set>`).
    pub init_source: String,
    /// Final clock offset of the pose stream and its std, s.
    pub clock_offset: (f64, f64),
    /// Where the pose reference sits on the robot, as used in the end.
    pub lever_arm: LeverArm,
    /// The yaw-rate gyro as learned (all zero without one).
    pub gyro: terraslip_core::filter::GyroNoise,
    /// How late the wheels are stamped against the gyro, s.
    pub gyro_delay: f64,
    /// What the run decided before its first row (the gyro, the holds,
    /// the pose reference's kind): `decided:` lines, as the node gives them.
    pub decided: super::decide::Decisions,
    /// The measurement noise in the end.
    pub noise: NoiseUsed,
    /// Counters.
    pub stats: RunStats,
    /// Things the user should know (data used with caveats, parameters that
    /// sat on a limit).
    pub warnings: Vec<String>,
}

impl EstimateRun {
    /// Duration covered by the rows, s.
    pub fn duration(&self) -> f64 {
        match (self.first_row, self.last_row) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        }
    }

    /// Name of a row's terrain.
    pub fn terrain_name(&self, row: &EstimateRow) -> Option<&str> {
        row.terrain
            .and_then(|i| self.terrains.get(i))
            .map(|s| s.as_str())
    }
}

/// Where the pose reference sits on the robot (its lever arm from the
/// wheel axle's centre, body frame), apart from the slip parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeverArm {
    /// m, forward and left.
    pub x: f64,
    pub y: f64,
    /// `stated` (meta.toml's `[pose]`) or `config` (the configured
    /// `measurement.lever_arm_x`, `_y`, 0 by default).
    pub source: &'static str,
}

impl LeverArm {
    /// The lever arm `filter` ended with, for a log whose meta.toml
    /// states one or not.
    pub(super) fn of(filter: &terraslip_core::Filter, stated: bool) -> Self {
        let (x, y) = filter.lever_arm();
        let source = if stated { "stated" } else { "config" };
        Self { x, y, source }
    }
}
