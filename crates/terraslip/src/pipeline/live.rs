//! The online estimator fed as a robot feeds it: samples of different
//! streams arrive late and out of order, and are put back in time order
//! by a short reorder buffer before they reach the estimator, through the
//! same steps a replay of a log takes. Samples in stamp order with a gap
//! no longer than the lag give the rows [`super::run`] gives of the same
//! samples, bit for bit.
//!
//! Time is the samples' own (header stamps): nothing here reads a clock,
//! so a recording played at any speed gives the same rows.

use std::collections::VecDeque;

use terraslip_core::estimator::Estimator;
use terraslip_io::{DriveLog, ImuSample, ParamsFile, PoseMount, PoseObs, WheelSample};

use super::decide::Decisions;
use super::replay::Feed;
use super::run::{finish, RunInfo};
use super::{setup, EstimateRun, PipelineError, RowSink, RunOptions, TerrainEvidence};
use crate::config::EstimatorConfig;

/// One sample of a live stream; times in s on the wheels' clock (the pose
/// stream's own offset is the estimator's to learn).
#[derive(Debug, Clone, PartialEq)]
pub enum Sample {
    /// Tread speeds (m/s).
    Wheels(WheelSample),
    /// A pose fix (ENU, m; yaw CCW from east, rad).
    Pose(PoseObs),
    /// An IMU sample in the base frame; its `gyro_z` (rad/s) is fused.
    Imu(ImuSample),
}

#[cfg(feature = "ros2")]
impl From<terraslip_ros2::import::LiveRow> for Sample {
    /// A row a live graph's message made, as the estimator's sample.
    fn from(r: terraslip_ros2::import::LiveRow) -> Self {
        use terraslip_ros2::import::LiveRow;
        match r {
            LiveRow::Wheels(w) => Self::Wheels(w),
            LiveRow::Pose(p) => Self::Pose(p),
            LiveRow::Imu(i) => Self::Imu(i),
        }
    }
}

impl Sample {
    /// Time of the sample, s.
    pub fn t(&self) -> f64 {
        match self {
            Sample::Wheels(w) => w.t,
            Sample::Pose(p) => p.t,
            Sample::Imu(s) => s.t,
        }
    }
}

/// Samples that came after the estimator had moved past their time (later
/// than the reorder lag), and what became of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LateCounts {
    /// Wheels rows dropped: the estimator cannot integrate backwards.
    pub wheels: u64,
    /// Pose fixes handed over late (the estimator fuses a fix whose time
    /// has passed at once).
    pub pose: u64,
    /// Gyro samples dropped.
    pub gyro: u64,
    /// Samples with a time that is not finite, dropped.
    pub bad_time: u64,
}

/// A queue kept in time order; samples of equal time keep their arrival
/// order (as the stable sort of a log import does).
#[derive(Debug)]
struct Queue<T> {
    items: VecDeque<(f64, T)>,
}

impl<T> Default for Queue<T> {
    fn default() -> Self {
        Self {
            items: VecDeque::new(),
        }
    }
}

impl<T> Queue<T> {
    fn insert(&mut self, t: f64, x: T) {
        // Arrivals are nearly in order: search from the back.
        let mut i = self.items.len();
        while i > 0 && self.items[i - 1].0 > t {
            i -= 1;
        }
        self.items.insert(i, (t, x));
    }
    fn front_t(&self) -> Option<f64> {
        self.items.front().map(|x| x.0)
    }
    fn pop_if(&mut self, upto: f64) -> Option<T> {
        (self.front_t()? <= upto).then(|| self.items.pop_front().map(|x| x.1))?
    }
    fn len(&self) -> usize {
        self.items.len()
    }
}

/// The reorder buffer: holds each stream's samples until the newest time
/// seen is `lag` s past them, then releases them as a replay merges a
/// log: for each wheels row, the pose fixes up to it, the gyro samples up
/// to it, the row.
#[derive(Debug)]
pub struct Reorder {
    lag: f64,
    gyro_delay: f64,
    wheels: Queue<WheelSample>,
    pose: Queue<PoseObs>,
    gyro: Queue<f64>,
    newest: f64,
    /// Time of the last wheels row released, s.
    released: Option<f64>,
    late: LateCounts,
}

/// What [`Reorder`] releases, in order.
#[derive(Debug, Clone, PartialEq)]
pub enum Released {
    Pose(PoseObs),
    /// Gyro rate (rad/s) at a time on the wheels' clock (s).
    Gyro(f64, f64),
    Wheels(WheelSample),
}

impl Reorder {
    /// A buffer holding samples `lag` s (>= 0); gyro samples are moved
    /// `gyro_delay` s later, onto the wheels' clock.
    pub fn new(lag: f64, gyro_delay: f64) -> Self {
        Self {
            lag: if lag.is_finite() { lag.max(0.0) } else { 0.0 },
            gyro_delay: if gyro_delay.is_finite() {
                gyro_delay
            } else {
                0.0
            },
            wheels: Queue::default(),
            pose: Queue::default(),
            gyro: Queue::default(),
            newest: f64::NEG_INFINITY,
            released: None,
            late: LateCounts::default(),
        }
    }

    /// The late samples so far.
    pub fn late(&self) -> LateCounts {
        self.late
    }

    /// Samples held.
    pub fn held(&self) -> usize {
        self.wheels.len() + self.pose.len() + self.gyro.len()
    }

    /// Takes a sample (an IMU sample without a yaw rate is ignored).
    pub fn push(&mut self, s: Sample) {
        let t = s.t();
        if !t.is_finite() {
            self.late.bad_time += 1;
            return;
        }
        let done = self.released.unwrap_or(f64::NEG_INFINITY);
        match s {
            Sample::Wheels(w) if w.t < done => self.late.wheels += 1,
            Sample::Wheels(w) => self.wheels.insert(w.t, w),
            Sample::Pose(p) => {
                if p.t <= done {
                    self.late.pose += 1;
                }
                self.pose.insert(p.t, p)
            }
            Sample::Imu(i) => {
                let Some(rate) = i.gyro_z else { return };
                let t = i.t + self.gyro_delay;
                if t <= done {
                    self.late.gyro += 1;
                    return;
                }
                self.gyro.insert(t, rate)
            }
        }
        self.newest = self.newest.max(t);
    }

    /// The next sample due: anything up to the next wheels row once that
    /// row is `lag` s old (all of it with `flush`), and a late pose fix at
    /// once.
    pub fn next(&mut self, flush: bool) -> Option<Released> {
        let done = self.released.unwrap_or(f64::NEG_INFINITY);
        if let Some(p) = self.pose.pop_if(done) {
            return Some(Released::Pose(p));
        }
        let w = self.wheels.front_t()?;
        if !flush && w > self.newest - self.lag {
            return None;
        }
        if let Some(p) = self.pose.pop_if(w) {
            return Some(Released::Pose(p));
        }
        if let Some(t) = self.gyro.front_t().filter(|&t| t <= w) {
            let rate = self.gyro.pop_if(t)?;
            return Some(Released::Gyro(t, rate));
        }
        let w = self.wheels.pop_if(w)?;
        self.released = Some(w.t);
        Some(Released::Wheels(w))
    }
}

/// The estimator with its reorder buffer: samples in, an estimate row per
/// wheels row out (to a [`RowSink`]), `lag` s after the row's time.
pub struct Live<'a> {
    cfg: &'a EstimatorConfig,
    log: DriveLog,
    estimator: Estimator,
    feed: Feed<'a>,
    buffer: Reorder,
    info: RunInfo,
    fuse_gyro: bool,
}

static NO_EVIDENCE: TerrainEvidence = TerrainEvidence::None;

impl<'a> Live<'a> {
    /// The estimator `run` builds for a robot of track width `track_width`
    /// (m), started from `init` as `estimate --init` starts; `name` names
    /// the source in messages (`dir`), `lag` (s) is how long samples wait
    /// for earlier ones, `gyro_delay` (s) how late the wheels are stamped
    /// against the gyro; the configuration's holds as they are.
    pub fn new(
        name: &'a str,
        cfg: &'a EstimatorConfig,
        track_width: f64,
        init: Option<&ParamsFile>,
        lag: f64,
        gyro_delay: f64,
    ) -> Result<Self, PipelineError> {
        let fuse_gyro = cfg.measurement.std_gyro > 0.0;
        let decided = Decisions {
            gyro_clock: super::GyroClock::Unknown,
            fuse_gyro,
            gyro_delay: if fuse_gyro { gyro_delay } else { 0.0 },
            hold: cfg.filter.hold,
            hold_gyro_scale: cfg.filter.hold_gyro_scale,
            pose_reference: None,
        };
        Self::decided(
            name,
            cfg,
            track_width,
            init,
            lag,
            &decided,
            true,
            None,
            Vec::new(),
        )
    }

    /// [`Self::new`] with the decisions a warm-up made (`has_pose`: pose
    /// rows came; `pose_mount`: where the pose reference sits on the robot,
    /// as a log's meta.toml `[pose]` states it; `warnings`: those it gave).
    #[allow(clippy::too_many_arguments)]
    pub fn decided(
        name: &'a str,
        cfg: &'a EstimatorConfig,
        track_width: f64,
        init: Option<&ParamsFile>,
        lag: f64,
        decided: &Decisions,
        has_pose: bool,
        pose_mount: Option<PoseMount>,
        mut warnings: Vec<String>,
    ) -> Result<Self, PipelineError> {
        cfg.validate().map_err(|e| PipelineError::Config(e.0))?;
        let mut log = DriveLog {
            dir: name.into(),
            ..Default::default()
        };
        log.meta.track_width = Some(track_width);
        log.meta.pose = pose_mount;
        let s = setup::setup(&log, &decided.filter_config(cfg), &NO_EVIDENCE, init)?;
        warnings.splice(0..0, s.warnings);
        warnings.extend(super::decide::warnings(
            name,
            cfg,
            decided,
            s.track_width,
            has_pose,
            &s.init_source,
        ));
        let gyro_delay = decided.gyro_delay;
        Ok(Self {
            cfg,
            feed: Feed::new(
                name,
                cfg,
                &NO_EVIDENCE,
                RunOptions::default(),
                s.track_width,
            ),
            log,
            estimator: s.estimator,
            buffer: Reorder::new(lag, gyro_delay),
            info: RunInfo {
                terrains: s.terrains,
                track_width: s.track_width,
                init_source: s.init_source,
                warnings,
                decided: *decided,
            },
            fuse_gyro: decided.fuse_gyro,
        })
    }

    /// Takes a sample and hands `sink` the rows now due.
    pub fn push(&mut self, s: Sample, sink: &mut dyn RowSink) -> Result<(), PipelineError> {
        if matches!(s, Sample::Imu(_)) && !self.fuse_gyro {
            return Ok(());
        }
        self.buffer.push(s);
        self.release(false, sink)
    }

    /// Hands `sink` the rows of every sample held (at the end of a run).
    pub fn flush(&mut self, sink: &mut dyn RowSink) -> Result<(), PipelineError> {
        self.release(true, sink)
    }

    fn release(&mut self, flush: bool, sink: &mut dyn RowSink) -> Result<(), PipelineError> {
        while let Some(r) = self.buffer.next(flush) {
            match r {
                Released::Pose(p) => self.feed.pose(&mut self.estimator, &p)?,
                Released::Gyro(t, rate) => self.feed.gyro(&mut self.estimator, t, rate)?,
                Released::Wheels(w) => {
                    self.feed
                        .advance(&mut self.estimator, &mut self.info.warnings, &w)?;
                    let row = self.feed.wheels(&mut self.estimator, &w)?;
                    sink.row(&self.info.terrains, &row)?;
                }
            }
        }
        Ok(())
    }

    /// Late samples so far.
    pub fn late(&self) -> LateCounts {
        self.buffer.late()
    }

    /// Samples waiting in the reorder buffer.
    pub fn held(&self) -> usize {
        self.buffer.held()
    }

    /// The estimator.
    pub fn estimator(&self) -> &Estimator {
        &self.estimator
    }

    /// What `estimate` would report of the run so far (learned parameters,
    /// noise, clock offset, warnings); its `rows` are empty.
    pub fn summary(&self) -> EstimateRun {
        finish(
            &self.log,
            self.cfg,
            &self.estimator,
            self.feed.snapshot(),
            self.info.clone(),
        )
    }
}

impl EstimateRun {
    /// The parameters the run learned as a parameters file (the format
    /// `calibrate` writes and `--init` reads): the straight-line ICRs with
    /// their stds, the turn laws (of the spread, `k_spread`, and of the speed
    /// factors, `k_alpha`) when they are not flat, the gyro's delay (and
    /// its scale where the run learned one) and the pose stream's clock
    /// offset. One pooled set: without terrain
    /// evidence the run cannot tell grounds apart.
    pub fn params_file(&self) -> ParamsFile {
        let p = self.final_icr;
        let mut pf = ParamsFile {
            params: Some(p),
            ..Default::default()
        };
        let json = |x: f64| serde_json::json!(x);
        if let Some(r) = self.last_row {
            pf.extra.insert(
                "std".into(),
                serde_json::json!({
                    "y_l": r.std[3], "y_r": r.std[4], "x_c": r.std[5],
                    "alpha_l": r.std[6], "alpha_r": r.std[7],
                }),
            );
        }
        if self.turn_law.0 != 0.0 || self.speed_law.0 != 0.0 {
            pf.extra.insert(
                "rate_model".into(),
                serde_json::json!({
                    "selected": true,
                    "k_spread": self.turn_law.0,
                    "k_alpha": self.speed_law.0,
                    "params": p,
                }),
            );
        }
        if self.gyro.fused > 0 && self.gyro.scale_learned {
            pf.extra.insert("gyro_scale".into(), json(self.gyro.scale));
        }
        pf.extra
            .insert("gyro_delay_s".into(), json(self.gyro_delay));
        pf.extra
            .insert("clock_offset_s".into(), json(self.clock_offset.0));
        pf.extra.insert("source".into(), json_str("terraslip node"));
        pf
    }
}

fn json_str(s: &str) -> serde_json::Value {
    serde_json::Value::String(s.into())
}

#[cfg(test)]
mod tests;
