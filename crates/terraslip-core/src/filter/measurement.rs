//! How the pose fixes' and the gyro's errors behave (`[measurement]`).

use super::{FilterError, MAX_CLOCK_OFFSET, MAX_GYRO_SCALE};

/// Largest lever arm of the pose reference, m (a robot's length).
pub const MAX_LEVER_ARM: f64 = 50.0;

/// How the pose fixes' errors behave (`[measurement]`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct MeasurementConfig {
    /// Position std per axis assumed where `pose.csv` has no `std_xy`, m:
    /// the starting point of the noise learning (`filter.noise_memory`).
    pub std_xy: f64,
    /// Heading std assumed where `pose.csv` has no `std_yaw`, rad.
    pub std_yaw: f64,
    /// Std of the slowly wandering part of the position error, as a
    /// multiple of the position std. Every position source has one: GNSS
    /// errors wander over tens of seconds, RTK fixes with multipath, a lidar
    /// localiser with the local error of its map; read as motion, a
    /// wandering error would drag the speed factor and make the position
    /// std over-confident. A log whose meta.toml states
    /// `pose_reference = "localiser"` runs with 0.
    pub correlated_fraction: f64,
    /// Correlation time of the wandering part, s.
    pub correlation_time: f64,
    /// Encoder resolution on the tread, m per tick; 0 = from meta.toml
    /// (2 pi wheel_radius / ticks_per_rev), or unquantised if unknown.
    pub encoder_tick: f64,
    /// Starting value of the pose stream's clock offset, s: a pose stamped
    /// `t` describes the robot at wheel time `t - clock_offset` (a lidar
    /// localiser stamping on arrival is 0.3-0.5 s late). Learned from there
    /// (`filter.learn_clock`); `--init` files from `calibrate` carry one.
    pub clock_offset: f64,
    /// Prior std of the clock offset, s.
    pub clock_offset_std: f64,
    /// White noise of one sample of the yaw-rate gyro (`imu.csv`'s
    /// `gyro_z`), rad/s: the start of its noise learning. 0 = the gyro is
    /// not used.
    pub std_gyro: f64,
    /// Prior std of the gyro's bias, rad/s (a MEMS gyro's turn-on bias is
    /// up to about 1 deg/s).
    pub gyro_bias_std: f64,
    /// Random walk of the gyro's bias, rad/s per square-root second.
    pub gyro_bias_walk: f64,
    /// Starting value of the gyro's scale error `k_g`: the gyro reads
    /// `1 + k_g` times the true yaw rate (`--init` files carry the
    /// multiplier `gyro_scale` = `1 + k_g`).
    pub gyro_scale: f64,
    /// Prior std of the gyro's scale error (a MEMS gyro's is up to a few
    /// %); learned where positions or headings show the true turn, held
    /// otherwise ([`super::FilterConfig::hold_gyro_scale`]). 0 = held everywhere.
    pub gyro_scale_std: f64,
    /// Random walk of the gyro's scale error, per square-root second (3e-4:
    /// 0.5 % over 5 minutes), so that a scale learned off through a model
    /// heading error that persisted can come back; only where the scale is
    /// learned.
    pub gyro_scale_walk: f64,
    /// Where the pose reference sits on the robot, m, body frame (REP-103:
    /// x forward, y left of the wheel axle's centre): a position fix is of
    /// that point. A GNSS antenna, a ceiling tag or a lidar frame off the
    /// axle; 0 for a reference already of the body frame's origin.
    pub lever_arm_x: f64,
    /// See [`MeasurementConfig::lever_arm_x`], m.
    pub lever_arm_y: f64,
}

impl Default for MeasurementConfig {
    fn default() -> Self {
        Self {
            std_xy: 1.0,
            std_yaw: 2f64.to_radians(),
            correlated_fraction: 0.9,
            correlation_time: 30.0,
            encoder_tick: 0.0,
            clock_offset: 0.0,
            clock_offset_std: 0.1,
            std_gyro: 0.01,
            gyro_bias_std: 0.02,
            gyro_bias_walk: 1e-4,
            gyro_scale: 0.0,
            gyro_scale_std: 0.02,
            gyro_scale_walk: 3e-4,
            lever_arm_x: 0.0,
            lever_arm_y: 0.0,
        }
    }
}

impl MeasurementConfig {
    /// Checks every setting; the error names the key.
    pub fn validate(&self) -> Result<(), FilterError> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let checks: [(&'static str, bool); 14] = [
            (
                "measurement.std_xy must be finite and > 0",
                pos(self.std_xy),
            ),
            (
                "measurement.std_yaw must be finite and > 0",
                pos(self.std_yaw),
            ),
            (
                "measurement.correlated_fraction must be in 0..=10",
                (0.0..=10.0).contains(&self.correlated_fraction),
            ),
            (
                "measurement.correlation_time must be finite and > 0",
                pos(self.correlation_time),
            ),
            (
                "measurement.encoder_tick must be finite and >= 0",
                self.encoder_tick.is_finite() && self.encoder_tick >= 0.0,
            ),
            (
                "measurement.clock_offset must be within +-1 s",
                self.clock_offset.abs() <= MAX_CLOCK_OFFSET,
            ),
            (
                "measurement.clock_offset_std must be in 0..=2 s",
                (0.0..=2.0).contains(&self.clock_offset_std),
            ),
            (
                "measurement.std_gyro must be in 0..=1 rad/s",
                (0.0..=1.0).contains(&self.std_gyro),
            ),
            (
                "measurement.gyro_bias_std must be in 0..=1 rad/s",
                (0.0..=1.0).contains(&self.gyro_bias_std),
            ),
            (
                "measurement.gyro_bias_walk must be in 0..=0.01 rad/s/sqrt(s)",
                (0.0..=0.01).contains(&self.gyro_bias_walk),
            ),
            (
                "measurement.gyro_scale must be within +-0.2",
                self.gyro_scale.abs() <= MAX_GYRO_SCALE,
            ),
            (
                "measurement.gyro_scale_std must be in 0..=0.2",
                (0.0..=MAX_GYRO_SCALE).contains(&self.gyro_scale_std),
            ),
            (
                "measurement.gyro_scale_walk must be in 0..=0.01 per sqrt(s)",
                (0.0..=0.01).contains(&self.gyro_scale_walk),
            ),
            (
                "measurement.lever_arm_x and lever_arm_y must be within +-50 m",
                self.lever_arm_x.abs() <= MAX_LEVER_ARM && self.lever_arm_y.abs() <= MAX_LEVER_ARM,
            ),
        ];
        for (what, ok) in checks {
            if !ok {
                return Err(FilterError::BadConfig(what));
            }
        }
        Ok(())
    }

    /// Std (m) of the correlated part of position fixes of std `std_xy`.
    pub fn correlated_std(&self, std_xy: f64) -> f64 {
        self.correlated_fraction * std_xy
    }
}
