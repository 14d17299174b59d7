//! The run itself: the log's wheels and pose rows merged by time into the
//! estimator, each row handed to a [`RowSink`] as it is made, and only what
//! the result needs kept on the way (running counts, the first and last
//! row, the open starts of the 2 s prediction), so memory does not grow
//! with the log.

use std::iter::Peekable;

use terraslip_calib::prediction::{PredictionSpec, PredictionStream, Timed};
use terraslip_core::estimator::Estimator;
use terraslip_io::{LogError, PoseObs, WheelSample};

use super::row::{row, BandCounts};
use super::terrain_feed::TerrainFeed;
use super::{pose_fix, EstimateRow, PipelineError, RunOptions, TerrainChange, TerrainEvidence};
use crate::config::EstimatorConfig;

/// Where a run's rows go, one at a time, in time order.
pub trait RowSink {
    /// Takes the next row; `terrains` names its terrain index.
    fn row(&mut self, terrains: &[String], row: &EstimateRow) -> Result<(), PipelineError>;
}

impl RowSink for Vec<EstimateRow> {
    fn row(&mut self, _: &[String], row: &EstimateRow) -> Result<(), PipelineError> {
        self.push(*row);
        Ok(())
    }
}

/// A log's wheels rows, pose rows and gyro rates (`(t, gyro_z)`, s and
/// rad/s), each in time order, as a run reads them (from memory, or from
/// the files row by row), and what the drive's start says of the gyro's
/// clock ([`super::gyro_delay`]; `Unknown` when it was not looked at).
pub struct Streams<'a> {
    pub wheels: &'a mut dyn Iterator<Item = Result<WheelSample, LogError>>,
    pub pose: &'a mut dyn Iterator<Item = Result<PoseObs, LogError>>,
    pub gyro: &'a mut dyn Iterator<Item = Result<(f64, f64), LogError>>,
    pub gyro_clock: super::GyroClock,
}

type Pose<'a> = Peekable<&'a mut dyn Iterator<Item = Result<PoseObs, LogError>>>;
type Gyro<'a> = Peekable<&'a mut dyn Iterator<Item = Result<(f64, f64), LogError>>>;

/// What replaying a log produced, besides the rows.
pub(super) struct Replay {
    pub changes: Vec<TerrainChange>,
    /// Pose fixes handed to the estimator, and those dropped by the outage.
    pub used: usize,
    pub dropped: usize,
    pub totals: Totals,
}

/// What the result needs of the rows and samples that went by.
pub(super) struct Totals {
    pub rows: usize,
    pub first: Option<EstimateRow>,
    pub last: Option<EstimateRow>,
    pub band: BandCounts,
    /// A tread speed reached `still_speed`.
    pub moved: bool,
    /// Some pose row states its noise; the first stated stds.
    pub stated: bool,
    pub std_xy: Option<f64>,
    pub std_yaw: Option<f64>,
    pub prediction: PredictionStream,
}

impl Totals {
    fn new(track_width: f64) -> Self {
        Self {
            rows: 0,
            first: None,
            last: None,
            band: BandCounts::default(),
            moved: false,
            stated: false,
            std_xy: None,
            std_yaw: None,
            prediction: PredictionStream::new(track_width, PredictionSpec::default()),
        }
    }

    fn pose(&mut self, p: &PoseObs) {
        self.stated |= p.std_xy.is_some() || p.std_yaw.is_some();
        self.std_xy = self.std_xy.or(p.std_xy);
        self.std_yaw = self.std_yaw.or(p.std_yaw);
        self.prediction.pose(p);
    }
}

/// The estimator and what a replay reads and writes.
pub(super) struct Context<'a> {
    pub dir: &'a str,
    pub cfg: &'a EstimatorConfig,
    pub evidence: &'a TerrainEvidence,
    pub opts: RunOptions,
    pub terrains: &'a [String],
    pub track_width: f64,
    pub estimator: &'a mut Estimator,
    pub warnings: &'a mut Vec<String>,
    pub sink: &'a mut dyn RowSink,
    pub progress: &'a mut dyn FnMut(usize),
}

/// Merges the streams by time into the estimator: terrain evidence, then
/// the pose fixes up to each wheels row, then the row itself.
pub(super) fn replay(
    cx: Context,
    wheels: &mut dyn Iterator<Item = Result<WheelSample, LogError>>,
    pose: &mut Pose,
    gyro: &mut Gyro,
    gyro_delay: f64,
) -> Result<Replay, PipelineError> {
    let Context {
        dir,
        cfg,
        evidence,
        opts,
        terrains,
        track_width,
        estimator,
        warnings,
        sink,
        progress,
    } = cx;
    let filter_err = |t: f64, source| PipelineError::Filter {
        dir: dir.to_string(),
        t,
        source,
    };
    let band = cfg.band(track_width);
    let mut totals = Totals::new(track_width);
    let mut terrain = TerrainFeed::new(evidence, cfg);
    let mut changes = Vec::new();
    let mut dropped = 0usize;
    let mut used = 0usize;
    let mut t_prev: Option<f64> = None;
    let mut params: Option<Timed> = None;
    for (i, w) in wheels.enumerate() {
        let w = w?;
        if let Some(tp) = t_prev {
            if w.t - tp > cfg.filter.max_wheel_gap
                && !warnings.iter().any(|w| w.contains("without tread speeds"))
            {
                warnings.push(format!(
                    "{dir}/wheels.csv: {:.1} s without tread speeds before t = {}; pose uncertainty widened instead of integrating",
                    w.t - tp,
                    w.t
                ));
            }
        }
        t_prev = Some(w.t);
        totals.moved |= w.v_left.abs().max(w.v_right.abs()) >= cfg.filter.still_speed;
        if let Some(c) = terrain
            .advance(estimator, w.t)
            .map_err(|e| filter_err(w.t, e))?
        {
            changes.push(c);
        }
        while let Some(p) = pose.next_if(|p| p.as_ref().map_or(true, |p| p.t <= w.t)) {
            let p = p?;
            totals.pose(&p);
            if opts.outage.is_some_and(|(t0, t1)| p.t >= t0 && p.t < t1) {
                dropped += 1;
                continue;
            }
            estimator
                .on_pose(p.t, pose_fix(cfg, &p))
                .map_err(|e| filter_err(p.t, e))?;
            used += 1;
        }
        while let Some(g) = gyro.next_if(|g| g.as_ref().map_or(true, |g| g.0 + gyro_delay <= w.t)) {
            let (t, rate) = g?;
            let t = t + gyro_delay;
            estimator.on_gyro(t, rate).map_err(|e| filter_err(t, e))?;
        }
        // Starts of the prediction before this row take the previous
        // row's parameters and clock offset (those in effect then).
        totals.prediction.wheels(w, &mut |_| params);
        estimator
            .on_wheels(w.t, w.v_left, w.v_right)
            .map_err(|e| filter_err(w.t, e))?;
        let summary = estimator.take_fix_summary();
        terrain.jump |= summary.change;
        let r = row(estimator, w.t, terrain.current, &summary);
        sink.row(terrains, &r)?;
        params = Some(Timed {
            params: r.icr(),
            clock_offset: r.clock_offset,
        });
        totals.rows += 1;
        totals.band.add(&r, &band);
        totals.first.get_or_insert(r);
        totals.last = Some(r);
        if i % 4096 == 0 {
            progress(i);
        }
    }
    // Pose rows after the last wheels row are not fused, but they are
    // part of the pose reference.
    for p in pose {
        totals.pose(&p?);
    }
    Ok(Replay {
        changes,
        used,
        dropped,
        totals,
    })
}
