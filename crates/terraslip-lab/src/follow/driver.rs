//! The robot's side of the closed loop: the online estimator fed by the
//! simulated sensors, the path follower steering on its estimate, and
//! what stands between the follower and the drive controller (nothing, a
//! static wheel separation multiplier, or live compensation).

use terraslip::config::EstimatorConfig;
use terraslip::pipeline::live::{Live, Sample};
use terraslip::pipeline::{EstimateRow, PipelineError, RowSink};
use terraslip_core::kinematics::Twist;
use terraslip_sim::closed_loop::{Controller, Sensed};

use super::course::Course;
use super::pursuit::{Pursuit, PursuitState};
use super::steering::Steering;

/// Keeps the newest estimate row.
#[derive(Default)]
struct Newest(Option<EstimateRow>);

impl RowSink for Newest {
    fn row(&mut self, _: &[String], row: &EstimateRow) -> Result<(), PipelineError> {
        self.0 = Some(*row);
        Ok(())
    }
}

/// Length of the course's GNSS outage, s.
pub const OUTAGE_S: f64 = 30.0;

/// A GNSS outage: no pose fix reaches the estimator for `duration` s from
/// when the robot believes it has driven `from_s` m of the course.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outage {
    /// m of course.
    pub from_s: f64,
    /// s
    pub duration: f64,
}

/// The follower with its estimator, as a [`Controller`].
pub struct Follower<'a> {
    course: &'a Course,
    pursuit: Pursuit,
    state: PursuitState,
    live: Live<'a>,
    newest: Newest,
    steering: Steering,
    outage: Outage,
    /// When the outage began, s.
    pub outage_start: Option<f64>,
    /// When the goal was reached, s.
    pub finished: Option<f64>,
    last_t: Option<f64>,
    /// The error the estimator returned, if any (the run then stops).
    pub error: Option<PipelineError>,
}

impl<'a> Follower<'a> {
    /// A follower of `course` for a robot of track width `track_width` m
    /// with estimator `cfg`.
    pub fn new(
        course: &'a Course,
        cfg: &'a EstimatorConfig,
        track_width: f64,
        pursuit: Pursuit,
        steering: Steering,
        outage: Outage,
    ) -> Result<Self, PipelineError> {
        Ok(Self {
            course,
            pursuit,
            state: PursuitState::default(),
            live: Live::new("follow", cfg, track_width, None, 0.0, 0.0)?,
            newest: Newest::default(),
            steering,
            outage,
            outage_start: None,
            finished: None,
            last_t: None,
            error: None,
        })
    }

    /// Whether a pose fix at `t` is lost to the outage.
    fn lost(&self, t: f64) -> bool {
        self.outage_start
            .is_some_and(|t0| t >= t0 && t < t0 + self.outage.duration)
    }

    /// Hands the estimator the new samples in time order (at one time:
    /// pose and gyro before the wheels row, as a log replay merges them).
    fn feed(&mut self, s: &Sensed<'_>) -> Result<(), PipelineError> {
        let mut samples: Vec<(f64, u8, Sample)> = Vec::new();
        for p in s.pose.iter().filter(|p| !self.lost(p.t)) {
            samples.push((p.t, 0, Sample::Pose(*p)));
        }
        for i in s.imu {
            samples.push((i.t, 1, Sample::Imu(*i)));
        }
        for w in s.wheels {
            samples.push((w.t, 2, Sample::Wheels(*w)));
        }
        samples.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (_, _, x) in samples {
            self.live.push(x, &mut self.newest)?;
        }
        Ok(())
    }
}

impl Controller for Follower<'_> {
    fn command(&mut self, s: &Sensed<'_>) -> Option<Twist> {
        if let Err(e) = self.feed(s) {
            self.error = Some(e);
            return None;
        }
        let dt = self.last_t.map_or(0.0, |t0| s.t - t0);
        self.last_t = Some(s.t);
        let Some(row) = self.newest.0 else {
            return Some(Twist::default());
        };
        let progress_s = self.course.points[self.state.progress].s;
        if self.outage_start.is_none() && progress_s >= self.outage.from_s {
            self.outage_start = Some(s.t);
        }
        let Some((v, omega)) = self.pursuit.command(
            self.course,
            &mut self.state,
            (row.east, row.north, row.yaw),
            dt,
        ) else {
            self.finished = Some(s.t);
            return None;
        };
        let desired = Twist {
            v_x: v,
            v_y: 0.0,
            omega,
        };
        Some(
            self.steering
                .command(s.t, desired, &row, self.live.estimator()),
        )
    }
}
