//! The closed loop: a controller drives the simulated robot. Every control
//! period the controller is handed what the robot's sensors recorded since
//! its previous call (never the truth) and returns the body twist it
//! commands; the drive turns that twist into tread set points as a nominal
//! differential-drive controller does (the robot's track width), with the
//! scenario's rate limits and wheel lag, and the terrain's slip model moves
//! the robot, exactly as in [`crate::simulate`].
//!
//! The ground is a map of the world, not a schedule: `ground(east, north)`
//! names the scenario segment under the robot (segment durations are not
//! used), and the ICRs blend over `slip.transition` s when the robot
//! crosses onto a different terrain.
//!
//! ```no_run
//! use terraslip_sim::closed_loop::{simulate_closed_loop, Controller, Sensed};
//! use terraslip_sim::Scenario;
//! use terraslip_core::kinematics::Twist;
//! struct Ahead;
//! impl Controller for Ahead {
//!     fn command(&mut self, s: &Sensed<'_>) -> Option<Twist> {
//!         (s.t < 10.0).then_some(Twist { v_x: 0.5, v_y: 0.0, omega: 0.0 })
//!     }
//! }
//! let sc = Scenario::builtin("papers").unwrap();
//! let run = simulate_closed_loop(&sc, &|_, _| 0, 0.0, 0.05, 60.0, &mut Ahead, 1).unwrap();
//! ```

use std::path::PathBuf;

use terraslip_core::kinematics::{IcrParams, Twist};
use terraslip_io::{DriveLog, ImuSample, PoseObs, TruthSample, WheelSample};

use crate::motion::Motion;
use crate::recorder::{Recorder, Recording};
use crate::timeline::{blend, Timeline};
use crate::{Scenario, SimError, SimRun};

/// What the robot recorded since the controller's previous call.
#[derive(Debug, Clone, Copy)]
pub struct Sensed<'a> {
    /// Time of this call, s.
    pub t: f64,
    /// Tread speeds from the encoders.
    pub wheels: &'a [WheelSample],
    /// GNSS fixes and heading.
    pub pose: &'a [PoseObs],
    /// IMU samples (gyro in the base frame).
    pub imu: &'a [ImuSample],
}

/// Whatever commands the robot: a path follower with its estimator.
pub trait Controller {
    /// The body twist to command from now until the next call (`v_x` m/s,
    /// `omega` rad/s, REP-103; `v_y` is ignored: a differential drive
    /// cannot command it), or `None` when the controller is done (the run
    /// ends).
    fn command(&mut self, sensed: &Sensed<'_>) -> Option<Twist>;
}

/// The terrain under the robot, blending into a new one over the
/// scenario's transition time after each crossing.
struct Ground {
    terrain: usize,
    from: IcrParams,
    since: f64,
}

impl Ground {
    /// The nominal ICRs and terrain index at `t` with the robot on terrain `now`.
    fn at(
        &mut self,
        t: f64,
        now: usize,
        timeline: &Timeline,
        transition: f64,
    ) -> (IcrParams, usize) {
        if now != self.terrain {
            // Crossing in the middle of a blend starts from where it was.
            self.from = self.nominal(t, timeline, transition);
            self.terrain = now;
            self.since = t;
        }
        (self.nominal(t, timeline, transition), self.terrain)
    }

    fn nominal(&self, t: f64, timeline: &Timeline, transition: f64) -> IcrParams {
        let here = timeline.nominal(self.terrain);
        if transition <= 0.0 || t - self.since >= transition {
            here
        } else {
            blend(&self.from, &here, (t - self.since) / transition)
        }
    }
}

/// Runs `controller` on the robot of `sc` from the origin heading `yaw0`
/// (rad, ENU), calling it every `period` s from t = 0 until it returns
/// `None` or `max_duration` s have passed. `ground(east, north)` is the
/// index of the scenario segment under the robot's centre (out of range:
/// the last one); the robot starts on segment 0's ground. Deterministic in
/// `seed` (the sensors' noise streams are those of [`crate::simulate`]).
#[allow(clippy::too_many_arguments)]
pub fn simulate_closed_loop(
    sc: &Scenario,
    ground: &dyn Fn(f64, f64) -> usize,
    yaw0: f64,
    period: f64,
    max_duration: f64,
    controller: &mut dyn Controller,
    seed: u64,
) -> Result<SimRun, SimError> {
    let bad = |reason: String| SimError::Scenario {
        path: PathBuf::from(format!("<scenario {}>", sc.name)),
        line: 0,
        reason,
    };
    sc.validate().map_err(bad)?;
    let finite = period.is_finite() && max_duration.is_finite();
    if !(finite && period > 0.0 && max_duration >= 0.0) {
        return Err(bad(format!(
            "control period {period} s and run length {max_duration} s must be finite and positive"
        )));
    }
    let timeline = Timeline::new(sc)?;
    let terrain_of = |east: f64, north: f64| {
        let last = sc.segments.len() - 1;
        timeline
            .segment_terrain(ground(east, north).min(last))
            .unwrap_or(0)
    };
    let mut motion = Motion::start(sc, &timeline, yaw0);
    let mut ground_state = Ground {
        terrain: motion.terrain,
        from: timeline.nominal(motion.terrain),
        since: f64::NEG_INFINITY,
    };
    let mut recorder = Recorder::new(sc, seed, max_duration);
    let mut rec = Recording {
        log: DriveLog {
            meta: crate::simulate::log_meta(sc),
            ..DriveLog::default()
        },
        ..Recording::default()
    };
    let mut terrain_changes = Vec::new();
    let mut seen = (0, 0, 0);
    let mut k_control: u64 = 0;
    let mut target = (0.0, 0.0);
    let mut t = 0.0_f64;
    loop {
        recorder.sample(t, &motion, &timeline, &mut rec);
        let next_control = k_control as f64 * period;
        if next_control <= t + 1e-9 {
            k_control += 1;
            let log = &rec.log;
            let sensed = Sensed {
                t,
                wheels: &log.wheels[seen.0..],
                pose: &log.pose[seen.1..],
                imu: &log.imu[seen.2..],
            };
            seen = (log.wheels.len(), log.pose.len(), log.imu.len());
            match controller.command(&sensed) {
                Some(tw) if tw.v_x.is_finite() && tw.omega.is_finite() => {
                    target = (tw.v_x, tw.omega)
                }
                // A command that is not a number stops the robot.
                Some(_) => target = (0.0, 0.0),
                None => break,
            }
        }
        if t >= max_duration - 1e-9 {
            break;
        }
        let next = recorder
            .next_time()
            .min(k_control as f64 * period)
            .min(max_duration);
        let t_next = crate::simulate::step_end(t, next, sc.integration.dt);
        let h = t_next - t;
        if h <= 0.0 {
            t = t_next + 1e-9;
            continue;
        }
        let here = terrain_of(motion.east, motion.north);
        if here != ground_state.terrain {
            terrain_changes.push(t);
        }
        let g = ground_state.at(t, here, &timeline, sc.slip.transition);
        motion.drive(h, target, g, sc);
        t = t_next;
    }

    let Recording {
        mut log,
        truth,
        frames,
    } = rec;
    log.truth = truth.iter().map(TruthSample::from).collect();
    Ok(SimRun {
        scenario: sc.clone(),
        seed,
        log,
        truth,
        terrains: timeline.terrains,
        frames,
        terrain_changes,
    })
}

#[cfg(test)]
mod tests;
