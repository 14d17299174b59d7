//! Running a scenario: the operator drives, the robot moves on the
//! terrain timeline, the recorder samples the sensors.

use std::path::PathBuf;

use rand::Rng;
use terraslip_io::{DriveLog, Meta, TruthSample};

use crate::motion::Motion;
use crate::operator::Operator;
use crate::recorder::{Recorder, Recording};
use crate::streams::stream;
use crate::timeline::Timeline;
use crate::{Scenario, SimError, SimRun};

/// Runs `scenario` with `seed`. Deterministic: the same scenario and seed
/// give bit-identical logs. Cheap (tens of ms for a few minutes of driving):
/// camera frames are only described here and rendered by [`SimRun::write`]
/// or [`SimRun::render_frame`].
pub fn simulate(scenario: &Scenario, seed: u64) -> Result<SimRun, SimError> {
    simulate_draw(scenario, seed, 0)
}

/// [`simulate`] with the sensors' noise (GNSS, compass, IMU, camera) drawn
/// afresh: draw `sensor_draw` of seed `seed`. The operator's driving, and
/// so the path, the terrain and the wheels, are those of `seed`; draw 0 is
/// [`simulate`]'s. Two draws of one world tell what an estimator's figures
/// owe to the sensors' particular noise.
pub fn simulate_draw(scenario: &Scenario, seed: u64, sensor_draw: u64) -> Result<SimRun, SimError> {
    let sc = scenario;
    sc.validate().map_err(|reason| SimError::Scenario {
        path: PathBuf::from(format!("<scenario {}>", sc.name)),
        line: 0,
        reason,
    })?;
    let robot = &sc.robot;
    let timeline = Timeline::new(sc)?;
    let duration = timeline.duration;

    let mut rng_operator = stream(seed, "operator");
    let yaw0 = rng_operator.gen_range(-std::f64::consts::PI..std::f64::consts::PI);
    let mut operator = Operator::new(sc.drive.clone(), rng_operator, robot.track_width);
    let mut motion = Motion::start(sc, &timeline, yaw0);
    let sensor_seed = seed ^ sensor_draw.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    let mut recorder = Recorder::new(sc, sensor_seed, duration);
    let mut rec = Recording {
        log: DriveLog {
            meta: log_meta(sc),
            terrain: timeline.labels.clone(),
            ..DriveLog::default()
        },
        ..Recording::default()
    };

    let mut t = 0.0_f64;
    loop {
        recorder.sample(t, &motion, &timeline, &mut rec);
        if t >= duration - 1e-9 {
            break;
        }
        let t_next = step_end(t, recorder.next_time().min(duration), sc.integration.dt);
        let h = t_next - t;
        if h <= 0.0 {
            // A sample time at t that was not consumed cannot happen (every
            // clock was polled above); guard against an endless loop anyway.
            t = t_next + 1e-9;
            continue;
        }
        motion.advance(t, h, &mut operator, sc, &timeline);
        t = t_next;
    }

    let Recording {
        mut log,
        truth,
        frames,
    } = rec;
    log.truth = truth.iter().map(TruthSample::from).collect();
    let terrain_changes = timeline.changes();
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

/// The log's `meta.toml` for the robot and sensors of `sc`.
pub(crate) fn log_meta(sc: &Scenario) -> Meta {
    let robot = &sc.robot;
    Meta {
        robot: Some(robot.name.clone()),
        track_width: Some(robot.track_width),
        wheel_radius: Some(robot.wheel_radius),
        length: Some(robot.length),
        ticks_per_rev: Some(sc.wheels.ticks_per_rev),
        // The receiver's mount and kind are known: stated, as a user with
        // the robot's drawings states them.
        pose: (sc.gnss.rate > 0.0).then_some(terraslip_io::PoseMount {
            lever_arm_x: sc.gnss.lever_arm[0],
            lever_arm_y: sc.gnss.lever_arm[1],
        }),
        pose_reference: (sc.gnss.rate > 0.0).then_some(terraslip_io::PoseReference::Gnss),
        ..Default::default()
    }
}

/// Where an integration step from `t` ends: at most `dt` later, and at the
/// next sample time `next` (s) when it would stop just short of it (sample
/// times are exact, k / rate; the running sum of steps rounds).
pub(crate) fn step_end(t: f64, next: f64, dt: f64) -> f64 {
    if t + dt < next - 1e-6 {
        t + dt
    } else {
        next
    }
}
