//! The `[wheels]`, `[gnss]`, `[compass]`, `[imu]` and `[camera]` tables of a
//! scenario: each sensor's rate and imperfections.

use serde::{Deserialize, Serialize};

/// Wheel encoders.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Wheels {
    /// Hz
    pub rate: f64,
    /// Encoder ticks per wheel revolution.
    pub ticks_per_rev: f64,
}

impl Default for Wheels {
    fn default() -> Self {
        Self {
            rate: 50.0,
            ticks_per_rev: 540.0,
        }
    }
}

/// A time window, s from the start of the drive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Window {
    pub start: f64,
    pub duration: f64,
}

/// A scheduled multipath jump.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Jump {
    pub start: f64,
    pub duration: f64,
    /// Offset of the reported position, m east and north.
    pub east: f64,
    pub north: f64,
}

/// GNSS receiver (position only; heading comes from [`Compass`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Gnss {
    /// Hz; 0 disables the receiver.
    pub rate: f64,
    /// White error per axis, 1-sigma m.
    pub white_std: f64,
    /// Stationary std of the first-order Gauss-Markov error per axis, m.
    pub markov_std: f64,
    /// Correlation time of the Gauss-Markov error, s.
    pub markov_tau: f64,
    /// The `std_xy` the receiver reports in `pose.csv`, m.
    pub reported_std: f64,
    /// Random multipath jumps per second (Poisson).
    pub multipath_rate: f64,
    /// Size of a random multipath jump, m (direction drawn at random).
    pub multipath_jump: f64,
    /// Length of a random multipath jump, [min, max] s.
    pub multipath_duration: [f64; 2],
    /// Scheduled jumps (for tests and demos that need one at a known time).
    pub jumps: Vec<Jump>,
    /// Outages: no position fixes in these windows.
    pub outages: Vec<Window>,
    /// Where the antenna sits on the robot, `[x, y]` m, body frame
    /// (REP-103: forward, left of the wheel axle's centre): its fixes are
    /// of that point. Recorded in meta.toml's `[pose]` (with
    /// `pose_reference = "gnss"`) when the receiver is on.
    pub lever_arm: [f64; 2],
}

impl Default for Gnss {
    /// lv2019's receiver: 1 Hz, "2 m", the error correlated over tens of seconds.
    fn default() -> Self {
        Self {
            rate: 1.0,
            white_std: 0.8,
            markov_std: 1.8,
            markov_tau: 30.0,
            reported_std: 2.0,
            multipath_rate: 0.002,
            multipath_jump: 30.0,
            multipath_duration: [1.0, 3.0],
            jumps: Vec::new(),
            outages: Vec::new(),
            lever_arm: [0.0; 2],
        }
    }
}

impl Gnss {
    /// An RTK-grade receiver: centimetre white error, no multipath.
    pub fn rtk(rate: f64) -> Self {
        Self {
            rate,
            white_std: 0.01,
            markov_std: 0.01,
            markov_tau: 20.0,
            reported_std: 0.015,
            multipath_rate: 0.0,
            multipath_jump: 0.0,
            multipath_duration: [1.0, 1.0],
            jumps: Vec::new(),
            outages: Vec::new(),
            lever_arm: [0.0; 2],
        }
    }

    /// Total 1-sigma error per axis, m (without jumps).
    pub fn total_std(&self) -> f64 {
        self.white_std.hypot(self.markov_std)
    }

    pub(super) fn is_rtk(&self) -> bool {
        self.total_std() < 0.05
    }
}

/// Heading sensor (compass or dual-antenna GNSS heading).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Compass {
    /// Hz; 0 disables it.
    pub rate: f64,
    /// White noise, 1-sigma degrees.
    pub std_deg: f64,
    /// Constant bias, degrees (magnetic declination left uncorrected, mounting).
    pub bias_deg: f64,
    /// The `std_yaw` reported in `pose.csv`, degrees.
    pub reported_std_deg: f64,
}

impl Default for Compass {
    fn default() -> Self {
        Self {
            rate: 1.0,
            std_deg: 1.0,
            bias_deg: 0.5,
            reported_std_deg: 1.0,
        }
    }
}

/// Inertial unit mounted on the chassis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Imu {
    /// Hz; 0 disables it.
    pub rate: f64,
    /// Accelerometer white noise, m/s^2.
    pub accel_noise: f64,
    /// Gyro white noise, rad/s.
    pub gyro_noise: f64,
    /// Gyro z bias, rad/s.
    pub gyro_bias: f64,
    /// Gyro z scale: it reads `gyro_scale` times the true yaw rate (1 =
    /// exact; a MEMS gyro is off by up to a few %).
    pub gyro_scale: f64,
    /// Scales every terrain's vibration (1 = catalogue values).
    pub vibration_gain: f64,
}

impl Default for Imu {
    fn default() -> Self {
        Self {
            rate: 200.0,
            accel_noise: 0.02,
            gyro_noise: 0.004,
            gyro_bias: 0.003,
            gyro_scale: 1.0,
            vibration_gain: 1.0,
        }
    }
}

/// Downward-looking ground camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Camera {
    /// Frames per second; 0 disables the camera.
    pub rate: f64,
    /// Pixels.
    pub width: u32,
    pub height: u32,
    /// Width of the ground patch seen at nominal height, m.
    pub footprint: f64,
    /// Relative variation of the footprint (camera height, pitch), e.g. 0.15.
    pub scale_variation: f64,
    /// Brightness gain range [min, max] (sun, cloud, shadow).
    pub lighting: [f64; 2],
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            rate: 0.5,
            width: 320,
            height: 240,
            footprint: 0.5,
            scale_variation: 0.15,
            lighting: [0.6, 1.3],
        }
    }
}
