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
use super::terrain_trial::{Trial, Verdict};
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
#[derive(Clone)]
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
    /// Pose rows with a position.
    pub positions: usize,
    pub prediction: PredictionStream,
    pub outage: super::outage::OutageRun,
    /// The rows' ICRs over the whole drive.
    pub drive: super::recommend::DriveAverage,
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
            positions: 0,
            prediction: PredictionStream::new(track_width, PredictionSpec::default()),
            outage: super::outage::OutageRun::new(track_width),
            drive: Default::default(),
        }
    }

    fn pose(&mut self, p: &PoseObs) {
        self.stated |= p.std_xy.is_some() || p.std_yaw.is_some();
        self.std_xy = self.std_xy.or(p.std_xy);
        self.std_yaw = self.std_yaw.or(p.std_yaw);
        self.positions += usize::from(p.east.is_some() && p.north.is_some());
        self.prediction.pose(p);
        self.outage.pose(p);
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
/// the pose fixes up to each wheels row, then the gyro samples up to it,
/// then the row itself.
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
    let mut feed = Feed::new(dir, cfg, evidence, opts, track_width);
    for (i, w) in wheels.enumerate() {
        let w = w?;
        feed.advance(estimator, warnings, &w)?;
        while let Some(p) = pose.next_if(|p| p.as_ref().map_or(true, |p| p.t <= w.t)) {
            feed.pose(estimator, &p?)?;
        }
        while let Some(g) = gyro.next_if(|g| g.as_ref().map_or(true, |g| g.0 + gyro_delay <= w.t)) {
            let (t, rate) = g?;
            feed.gyro(estimator, t + gyro_delay, rate)?;
        }
        let r = feed.wheels(estimator, &w)?;
        sink.row(terrains, &r)?;
        if i % 4096 == 0 {
            progress(i);
        }
    }
    // Pose rows after the last wheels row are not fused, but they are
    // part of the pose reference.
    for p in pose {
        feed.totals.pose(&p?);
    }
    Ok(feed.finish())
}

/// What goes between a drive's samples and the estimator, one sample at a
/// time: the outage, the terrain evidence, the counters and totals of the
/// result. A replay and a live node call it in the same order: for each
/// wheels row [`Feed::advance`], the pose fixes and gyro samples up to it,
/// then [`Feed::wheels`].
pub(super) struct Feed<'a> {
    dir: &'a str,
    cfg: &'a EstimatorConfig,
    opts: RunOptions,
    band: terraslip_core::filter::IcrBand,
    totals: Totals,
    terrain: TerrainFeed<'a>,
    changes: Vec<TerrainChange>,
    dropped: usize,
    used: usize,
    t_prev: Option<f64>,
    /// The parameters and the pose clock offset of the latest row.
    params: Option<Timed>,
    /// A classifier's change of terrain on trial.
    trial: Option<Trial>,
}

impl<'a> Feed<'a> {
    pub fn new(
        dir: &'a str,
        cfg: &'a EstimatorConfig,
        evidence: &'a TerrainEvidence,
        opts: RunOptions,
        track_width: f64,
    ) -> Self {
        Self {
            dir,
            cfg,
            opts,
            band: cfg.band(track_width),
            totals: Totals::new(track_width),
            terrain: TerrainFeed::new(evidence, cfg),
            changes: Vec::new(),
            dropped: 0,
            used: 0,
            t_prev: None,
            params: None,
            trial: None,
        }
    }

    /// Gives an event at `t` (s) to the estimator in use and, while a
    /// change of terrain is on trial, to the other one.
    fn each_estimator(
        &mut self,
        estimator: &mut Estimator,
        t: f64,
        mut event: impl FnMut(&mut Estimator) -> Result<(), terraslip_core::FilterError>,
    ) -> Result<(), PipelineError> {
        let r = event(estimator).and_then(|()| match &mut self.trial {
            Some(trial) => event(&mut trial.other),
            None => Ok(()),
        });
        r.map_err(|e| self.filter_err(t, e))
    }

    fn filter_err(&self, t: f64, source: terraslip_core::FilterError) -> PipelineError {
        PipelineError::Filter {
            dir: self.dir.to_string(),
            t,
            source,
        }
    }

    /// Before wheels row `w`: a gap before it, whether the robot moves,
    /// and the terrain in effect at its time.
    pub fn advance(
        &mut self,
        estimator: &mut Estimator,
        warnings: &mut Vec<String>,
        w: &WheelSample,
    ) -> Result<(), PipelineError> {
        let cfg = self.cfg;
        if let Some(tp) = self.t_prev {
            if w.t - tp > cfg.filter.max_wheel_gap
                && !warnings.iter().any(|w| w.contains("without tread speeds"))
            {
                warnings.push(format!(
                    "{}/wheels.csv: {:.1} s without tread speeds before t = {}; pose uncertainty widened instead of integrating",
                    self.dir,
                    w.t - tp,
                    w.t
                ));
            }
        }
        self.t_prev = Some(w.t);
        self.totals.moved |= w.v_left.abs().max(w.v_right.abs()) >= cfg.filter.still_speed;
        if let Some(c) = self
            .terrain
            .advance(estimator, w.t)
            .map_err(|e| self.filter_err(w.t, e))?
        {
            // The belief moved on: a trial still open ends with the
            // estimator in use.
            self.trial = None;
            if let Some(before) = self.terrain.take_before() {
                self.trial = Some(Trial::new(before, estimator, c.action));
            }
            self.changes.push(c);
        }
        Ok(())
    }

    /// A pose fix (dropped inside the run's outage).
    pub fn pose(&mut self, estimator: &mut Estimator, p: &PoseObs) -> Result<(), PipelineError> {
        self.totals.pose(p);
        if self
            .opts
            .outage
            .is_some_and(|(t0, t1)| p.t >= t0 && p.t < t1)
        {
            self.dropped += 1;
            return Ok(());
        }
        let fix = pose_fix(self.cfg, p);
        self.each_estimator(estimator, p.t, |e| e.on_pose(p.t, fix))?;
        self.used += 1;
        Ok(())
    }

    /// A gyro rate (rad/s) at `t` (s, on the wheels' clock).
    pub fn gyro(
        &mut self,
        estimator: &mut Estimator,
        t: f64,
        rate: f64,
    ) -> Result<(), PipelineError> {
        self.each_estimator(estimator, t, |e| e.on_gyro(t, rate))?;
        self.totals.outage.gyro(t, rate);
        Ok(())
    }

    /// Wheels row `w` into the estimator; the estimate after it.
    pub fn wheels(
        &mut self,
        estimator: &mut Estimator,
        w: &WheelSample,
    ) -> Result<EstimateRow, PipelineError> {
        // Starts of the prediction before this row take the previous
        // row's parameters and clock offset (those in effect then).
        let params = self.params;
        self.totals.prediction.wheels(*w, &mut |_| params);
        estimator
            .on_wheels(w.t, w.v_left, w.v_right)
            .map_err(|e| self.filter_err(w.t, e))?;
        let mut summary = estimator.take_fix_summary();
        if let Some(mut trial) = self.trial.take() {
            let r = trial.other.on_wheels(w.t, w.v_left, w.v_right);
            r.map_err(|e| self.filter_err(w.t, e))?;
            let other_summary = trial.other.take_fix_summary();
            let verdict = trial.verdict(estimator);
            let held = match verdict {
                Verdict::Open => trial.shows_held(estimator),
                Verdict::Kept => false,
                Verdict::Undone => true,
            };
            if held != trial.held_in_use {
                std::mem::swap(estimator, &mut trial.other);
                trial.held_in_use = held;
                summary = other_summary;
                if let Some(k) = estimator.schedule().current() {
                    self.changes.push(TerrainChange {
                        t: w.t,
                        terrain: k,
                        action: if held {
                            terraslip_core::ChangeAction::Undone
                        } else {
                            trial.action
                        },
                    });
                }
                self.terrain.current = estimator.schedule().current();
            }
            if verdict == Verdict::Open {
                self.trial = Some(trial);
            }
        }
        self.terrain.jump |= summary.change;
        let r = row(estimator, w.t, self.terrain.current, &summary);
        self.params = Some(r.prediction_model);
        self.totals.prediction.estimate_heading(r.yaw);
        self.totals.outage.wheels(w, estimator, r.clock_offset);
        self.totals.rows += 1;
        self.totals.band.add(&r, &self.band);
        self.totals.drive.add(&r);
        self.totals.first.get_or_insert(r);
        self.totals.last = Some(r);
        Ok(r)
    }

    /// What the run produced besides its rows.
    pub fn finish(self) -> Replay {
        Replay {
            changes: self.changes,
            used: self.used,
            dropped: self.dropped,
            totals: self.totals,
        }
    }

    /// [`Feed::finish`] of a copy, for a result while the run goes on.
    pub fn snapshot(&self) -> Replay {
        Replay {
            changes: self.changes.clone(),
            used: self.used,
            dropped: self.dropped,
            totals: self.totals.clone(),
        }
    }
}
