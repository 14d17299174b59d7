//! A live run's warm-up: the first [`gyro_delay::SPAN`] s of samples (stamp
//! time) are held back, the decisions `estimate` makes from a log's start
//! ([`super::decide`]: the gyro's delay, whether it is the yaw rate, the
//! slip parameters held) are made from them with the same code, and then
//! the estimator runs over the held samples in their arrival order, so no
//! row is lost, and goes on live.

use terraslip_io::{ParamsFile, PoseMount, PoseReference};

use super::decide::{Decisions, Seen};
use super::gyro_delay::{self, GyroClock, MAX_DELAY};
use super::live::{LateCounts, Live, Sample};
use super::{EstimateRun, PipelineError, RowSink};
use crate::config::EstimatorConfig;

/// The reorder lag a live run waits by default, s of stamp time.
pub const LAG: f64 = 0.3;

/// The live estimator, behind its warm-up.
pub struct WarmUp<'a> {
    name: &'a str,
    cfg: &'a EstimatorConfig,
    track_width: f64,
    init: Option<ParamsFile>,
    lag: f64,
    span: f64,
    given_delay: Option<f64>,
    recalled_delay: Option<f64>,
    held: Vec<Sample>,
    first_wheels: Option<f64>,
    newest: f64,
    live: Option<Live<'a>>,
    decided: Option<Decisions>,
    pose_mount: Option<PoseMount>,
    pose_reference: Option<PoseReference>,
}

impl<'a> WarmUp<'a> {
    /// Holds samples for `span` s of wheels (stamp time; [`gyro_delay::SPAN`]
    /// decides as `estimate` does), then builds [`Live`] with the other
    /// arguments as [`Live::decided`] takes them. `gyro_delay` (s), when
    /// given, replaces the delay the warm-up finds; `recalled_delay` (s,
    /// an earlier run's) is taken when the warm-up turns too little to
    /// tell.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: &'a str,
        cfg: &'a EstimatorConfig,
        track_width: f64,
        init: Option<ParamsFile>,
        lag: f64,
        span: f64,
        gyro_delay: Option<f64>,
        recalled_delay: Option<f64>,
    ) -> Result<Self, PipelineError> {
        cfg.validate().map_err(|e| PipelineError::Config(e.0))?;
        Ok(Self {
            name,
            cfg,
            track_width,
            init,
            lag: if lag.is_finite() { lag.max(0.0) } else { 0.0 },
            span: if span.is_finite() { span.max(0.0) } else { 0.0 },
            given_delay: gyro_delay.filter(|d| d.is_finite()),
            recalled_delay: recalled_delay.filter(|d| d.is_finite() && d.abs() <= MAX_DELAY),
            held: Vec::new(),
            first_wheels: None,
            newest: f64::NEG_INFINITY,
            live: None,
            decided: None,
            pose_mount: None,
            pose_reference: None,
        })
    }

    /// Stamp time a warm-up of `span` s with reorder lag `lag` s holds
    /// before it decides: the span, the gyro's look beyond it, and the lag.
    pub fn window(span: f64, lag: f64) -> f64 {
        span + MAX_DELAY + lag
    }

    /// The window of a warm-up with the node's defaults ([`gyro_delay::SPAN`]
    /// and [`LAG`]), s: `import` and `estimate` decide from a recording's
    /// first this many seconds, as the node does.
    pub fn default_window() -> f64 {
        Self::window(gyro_delay::SPAN, LAG)
    }

    /// Takes a sample and hands `sink` the rows now due; returns the
    /// decisions when this sample ended the warm-up.
    pub fn push(
        &mut self,
        s: Sample,
        sink: &mut dyn RowSink,
    ) -> Result<Option<Decisions>, PipelineError> {
        if let Some(live) = &mut self.live {
            live.push(s, sink)?;
            return Ok(None);
        }
        let t = s.t();
        if t.is_finite() {
            if let Sample::Wheels(w) = &s {
                self.first_wheels = Some(self.first_wheels.map_or(w.t, |f| f.min(w.t)));
            }
            self.newest = self.newest.max(t);
        }
        self.held.push(s);
        // Every sample the decisions read has come once the newest is
        // past the span, the gyro's look beyond it, and the lag.
        let due = self
            .first_wheels
            .is_some_and(|f| self.newest >= f + Self::window(self.span, self.lag));
        if due {
            return self.decide(sink).map(Some);
        }
        Ok(None)
    }

    /// Hands `sink` the rows of every sample held (at the end of a run),
    /// deciding first from what came when the warm-up has not ended.
    pub fn flush(&mut self, sink: &mut dyn RowSink) -> Result<Option<Decisions>, PipelineError> {
        let made = match self.live {
            Some(_) => None,
            None if self.held.is_empty() => return Ok(None),
            None => Some(self.decide(sink)?),
        };
        if let Some(live) = &mut self.live {
            live.flush(sink)?;
        }
        Ok(made)
    }

    /// Where the pose reference sits on the robot (its lever arm), for the
    /// estimator the warm-up builds; taken until the warm-up ends.
    pub fn set_pose_mount(&mut self, mount: Option<PoseMount>) {
        self.pose_mount = mount;
    }

    /// What the pose reference is, as a log's meta.toml `pose_reference`
    /// states it (a topics file's `[meta]`), for the decisions.
    pub fn set_pose_reference(&mut self, reference: Option<PoseReference>) {
        self.pose_reference = reference;
    }

    /// The decisions, once made.
    pub fn decisions(&self) -> Option<&Decisions> {
        self.decided.as_ref()
    }

    /// The estimator past its warm-up.
    pub fn live(&self) -> Option<&Live<'a>> {
        self.live.as_ref()
    }

    /// Late samples so far.
    pub fn late(&self) -> LateCounts {
        self.live.as_ref().map(Live::late).unwrap_or_default()
    }

    /// Samples held (the warm-up's, or the reorder buffer's).
    pub fn held(&self) -> usize {
        self.live.as_ref().map_or(self.held.len(), Live::held)
    }

    /// What `estimate` would report of the run so far (`None` during the
    /// warm-up).
    pub fn summary(&self) -> Option<EstimateRun> {
        self.live.as_ref().map(Live::summary)
    }

    /// Decides from the samples held, builds the estimator and runs it
    /// over them.
    fn decide(&mut self, sink: &mut dyn RowSink) -> Result<Decisions, PipelineError> {
        let finite = |t: f64| t.is_finite();
        let mut wheels: Vec<_> = self
            .held
            .iter()
            .filter_map(|s| match s {
                Sample::Wheels(w) if finite(w.t) => Some(*w),
                _ => None,
            })
            .collect();
        wheels.sort_by(|a, b| a.t.total_cmp(&b.t));
        let mut gyro: Vec<(f64, f64)> = self
            .held
            .iter()
            .filter_map(|s| match s {
                Sample::Imu(i) if finite(i.t) => Some((i.t, i.gyro_z?)),
                _ => None,
            })
            .collect();
        gyro.sort_by(|a, b| a.0.total_cmp(&b.0));
        let pose = || {
            self.held.iter().filter_map(|s| match s {
                Sample::Pose(p) => Some(p),
                _ => None,
            })
        };
        let gyro_clock = if self.cfg.measurement.std_gyro > 0.0 {
            let mut fixes: Vec<_> = pose().cloned().collect();
            fixes.sort_by(|a, b| a.t.total_cmp(&b.t));
            gyro_delay::gyro_delay_referenced(
                &mut wheels.iter().copied().map(Ok),
                &mut gyro.iter().copied().map(Ok),
                &mut fixes.into_iter().map(Ok),
            )
        } else {
            GyroClock::Unknown
        };
        let seen = Seen {
            gyro_clock,
            positions: pose().any(|p| p.east.is_some() && p.north.is_some()),
            headings: pose().any(|p| p.yaw.is_some()),
            gyro: !gyro.is_empty(),
            pose_reference: self.pose_reference,
        };
        let (mut d, warning) = Decisions::new(self.name, self.cfg, seen);
        let unknown = d.gyro_clock == GyroClock::Unknown;
        let recalled = self.recalled_delay.filter(|_| unknown);
        if let Some(delay) = self.given_delay.or(recalled).filter(|_| d.fuse_gyro) {
            d.gyro_delay = delay;
        }
        let mut live = Live::decided(
            self.name,
            self.cfg,
            self.track_width,
            self.init.as_ref(),
            self.lag,
            &d,
            pose().next().is_some(),
            self.pose_mount,
            warning.into_iter().collect(),
        )?;
        for s in std::mem::take(&mut self.held) {
            live.push(s, sink)?;
        }
        self.live = Some(live);
        self.decided = Some(d);
        Ok(d)
    }
}

#[cfg(test)]
mod tests;
