//! Synthetic drives integrated with the ICR model itself, for tests,
//! benchmarks and examples: known parameters in, a log directory's worth of
//! wheel and pose samples out. The real simulator is `terraslip-sim`; this
//! is the minimum needed to check that calibration recovers what it should.

use terraslip_core::IcrParams;
use terraslip_io::{DriveLog, Meta, PoseObs, TerrainLabel, WheelSample};

use crate::ga::SplitMix64;
use crate::model::RateSlopes;
use crate::segment::ACC_HALF_WINDOW;

/// What kind of motion the synthetic driver commands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Manoeuvres {
    /// Random steps of forward speed and yaw rate, spins in place and
    /// straight runs among them (like Mandow's joystick paths).
    Mixed,
    /// Straight runs only, forward and back: the spread is unobservable.
    StraightOnly,
    /// A field robot's survey: half the holds straight runs at 50-100 %
    /// of the top speed, the rest turns and spins.
    Survey,
}

/// Synthetic drive settings (SI units).
#[derive(Debug, Clone, PartialEq)]
pub struct SynthConfig {
    pub duration: f64,
    pub wheel_rate: f64,
    pub pose_rate: f64,
    /// 1-sigma noise of the reference position (m) and heading (rad).
    pub pose_noise_xy: f64,
    pub pose_noise_yaw: f64,
    /// The pose stream is stamped this much later than the motion, s.
    pub pose_latency: f64,
    pub max_speed: f64,
    pub max_yaw_rate: f64,
    /// Each command is held for a random time in this range, s.
    pub hold: (f64, f64),
    pub manoeuvres: Manoeuvres,
    pub track_width: f64,
    /// Turn-rate dependence and traction term of the true ICRs (zero:
    /// Mandow's constant model).
    pub rate: RateSlopes,
    pub robot: Option<String>,
    pub wheel_radius: Option<f64>,
    pub seed: u64,
}

impl SynthConfig {
    /// A Pioneer P3-AT on Mandow's RTK set-up: 5 Hz poses with 1 cm noise,
    /// encoder speeds at 100 Hz, up to 0.7 m/s and 1.5 rad/s.
    pub fn p3at(duration: f64, seed: u64) -> Self {
        Self {
            duration,
            wheel_rate: 100.0,
            pose_rate: 5.0,
            pose_noise_xy: 0.01,
            pose_noise_yaw: 0.005,
            pose_latency: 0.0,
            max_speed: 0.7,
            max_yaw_rate: 1.5,
            hold: (1.5, 5.0),
            manoeuvres: Manoeuvres::Mixed,
            track_width: 0.4,
            rate: RateSlopes::NONE,
            robot: Some("pioneer-p3at".into()),
            wheel_radius: Some(0.11),
            seed,
        }
    }
}

/// Mandow et al. 2007, Table I, pneumatic tyres at 20 psi on asphalt.
pub fn mandow_table1() -> IcrParams {
    IcrParams::from_mandow(-0.2553, 0.3071, -0.0120, 0.9271, 0.9049)
}

/// Integrates `segments` of (duration, true params) back to back into a log:
/// each terrain patch drives with its own ICR parameters and gets a label.
pub fn drive(patches: &[(&str, IcrParams)], cfg: &SynthConfig) -> DriveLog {
    let mut rng = SplitMix64::new(cfg.seed);
    let dt = 1.0 / cfg.wheel_rate;
    let n = (cfg.duration * cfg.wheel_rate).round() as usize;
    let patch_len = n / patches.len().max(1);
    let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
    let mut log = DriveLog {
        meta: Meta {
            robot: cfg.robot.clone(),
            track_width: Some(cfg.track_width),
            wheel_radius: cfg.wheel_radius,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut truth: Vec<(f64, f64, f64, f64)> = Vec::with_capacity(n + 1);
    let mut params: Vec<IcrParams> = Vec::with_capacity(n + 1);
    let (mut v_cmd, mut w_cmd, mut until) = (0.0, 0.0, 0.0);
    for k in 0..=n {
        let t = k as f64 * dt;
        let p = patches[(k / patch_len.max(1)).min(patches.len() - 1)];
        if k % patch_len.max(1) == 0 && k / patch_len.max(1) < patches.len() {
            log.terrain.push(TerrainLabel {
                t,
                terrain: p.0.to_string(),
            });
        }
        if t >= until {
            until = t + cfg.hold.0 + rng.uniform() * (cfg.hold.1 - cfg.hold.0);
            let kind = rng.uniform();
            let v = (2.0 * rng.uniform() - 1.0) * cfg.max_speed;
            let w = (2.0 * rng.uniform() - 1.0) * cfg.max_yaw_rate;
            (v_cmd, w_cmd) = match cfg.manoeuvres {
                Manoeuvres::StraightOnly => (v, 0.0),
                Manoeuvres::Mixed if kind < 0.1 => (0.0, 0.0),
                Manoeuvres::Mixed if kind < 0.3 => (0.0, w),
                Manoeuvres::Mixed if kind < 0.5 => (v, 0.0),
                Manoeuvres::Mixed => (v, 0.7 * w),
                Manoeuvres::Survey if kind < 0.5 => {
                    (v.signum() * (0.5 * cfg.max_speed + 0.5 * v.abs()), 0.0)
                }
                Manoeuvres::Survey if kind < 0.6 => (0.0, w),
                Manoeuvres::Survey => (v, 0.7 * w),
            };
        }
        let (vl, vr) = p.1.tread_speeds(v_cmd, w_cmd);
        log.wheels.push(WheelSample {
            t,
            v_left: vl,
            v_right: vr,
        });
        params.push(p.1);
    }
    // The traction term reads the tread acceleration the calibration
    // computes (`segment::Step::acc`): a central difference of the mean
    // tread speed over `ACC_HALF_WINDOW` each side, positive when speeding up.
    let h = (ACC_HALF_WINDOW * cfg.wheel_rate).round().max(1.0) as usize;
    let w = &log.wheels;
    let mean = |i: usize| 0.5 * (w[i].v_left + w[i].v_right);
    for k in 0..=n {
        let (a, b) = (k.saturating_sub(h), (k + h).min(n));
        let acc = (mean(b) - mean(a)) / (2.0 * h as f64 * dt) * mean(k).signum();
        truth.push((w[k].t, x, y, th));
        let tw = cfg.rate.twist(&params[k], w[k].v_left, w[k].v_right, acc);
        // Midpoint integration at 100 Hz is exact to well below a millimetre.
        let mid = th + 0.5 * tw.omega * dt;
        x += (mid.cos() * tw.v_x - mid.sin() * tw.v_y) * dt;
        y += (mid.sin() * tw.v_x + mid.cos() * tw.v_y) * dt;
        th += tw.omega * dt;
    }
    let every = (cfg.wheel_rate / cfg.pose_rate).round().max(1.0) as usize;
    for (t, x, y, th) in truth.iter().step_by(every) {
        log.pose.push(PoseObs {
            t: t + cfg.pose_latency,
            east: Some(x + cfg.pose_noise_xy * rng.normal()),
            north: Some(y + cfg.pose_noise_xy * rng.normal()),
            yaw: Some(terraslip_core::angle::wrap(
                th + cfg.pose_noise_yaw * rng.normal(),
            )),
            std_xy: None,
            std_yaw: None,
        });
    }
    log
}
