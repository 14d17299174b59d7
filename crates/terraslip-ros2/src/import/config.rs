//! The topics file (`--topics FILE.toml`).

use serde::Deserialize;

/// `--topics FILE.toml`: which topic feeds which stream, and the numbers a
/// bag cannot tell (wheel radius, the controller's separation, heading offsets).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TopicsConfig {
    #[serde(default)]
    pub wheels: WheelsConfig,
    #[serde(default)]
    pub pose: PoseConfig,
    #[serde(default)]
    pub heading: HeadingConfig,
    #[serde(default)]
    pub imu: ImuConfig,
    #[serde(default)]
    pub images: TopicOnly,
    #[serde(default)]
    pub time: TimeConfig,
    #[serde(default)]
    pub tf: TfConfig,
    /// Written to the log's `meta.toml`.
    #[serde(default)]
    pub meta: terraslip_io::Meta,
    /// Refuse the bag at the first message that cannot be physical (not
    /// finite, beyond the log's physical range, a stamp out of order or
    /// repeated) instead of skipping it with a warning; `--strict`.
    #[serde(default)]
    pub strict: bool,
}

/// `[wheels]`: the tread speed source.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelsConfig {
    /// sensor_msgs/JointState, nav_msgs/Odometry or geometry_msgs/TwistStamped.
    pub topic: Option<String>,
    /// JointState: wheel radius, m (velocities in rad/s times this).
    pub wheel_radius: Option<f64>,
    /// JointState: a joint is a left wheel when its name contains one of these (case-insensitive).
    #[serde(default = "left")]
    pub left: Vec<String>,
    /// JointState: right wheel joint name patterns.
    #[serde(default = "right")]
    pub right: Vec<String>,
    /// Odometry / TwistStamped: the controller's effective wheel separation
    /// S = wheel_separation × wheel_separation_multiplier, m. Tread speeds are
    /// v ∓ ω·S/2.
    pub separation: Option<f64>,
}

fn left() -> Vec<String> {
    vec!["left".into()]
}
fn right() -> Vec<String> {
    vec!["right".into()]
}

impl Default for WheelsConfig {
    fn default() -> Self {
        Self {
            topic: None,
            wheel_radius: None,
            left: left(),
            right: right(),
            separation: None,
        }
    }
}

/// `[pose]`: the absolute pose reference.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseConfig {
    /// sensor_msgs/NavSatFix, nav_msgs/Odometry, geometry_msgs/PoseStamped or
    /// PoseWithCovarianceStamped; `""` for none.
    pub topic: Option<String>,
    /// Where the reference sits on the robot: its lever arm `[x, y]` from
    /// the base frame's origin (the wheel axle's centre), m, base frame
    /// (x forward, y left). Overrides the bag's static transforms; written
    /// to the log's meta.toml `[pose]`.
    pub lever_arm: Option<[f64; 2]>,
}

/// `[heading]`: yaw from an IMU's orientation, for a GNSS pose source.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadingConfig {
    /// sensor_msgs/Imu with orientation; `""` for none.
    pub topic: Option<String>,
    /// Added to the IMU's yaw, degrees counter-clockwise.
    #[serde(default)]
    pub yaw_offset_deg: f64,
    /// Magnetic declination, degrees, east positive (as charts give it), for
    /// an IMU whose yaw is measured from magnetic rather than true east:
    /// yaw = imu_yaw + yaw_offset − declination.
    #[serde(default)]
    pub declination_deg: f64,
    /// 1σ of the heading when the message's covariance states none, degrees.
    #[serde(default = "heading_std")]
    pub std_deg: f64,
    /// The heading IMU's mounting in the base frame (see [`ImuConfig`]);
    /// when absent, `[imu]`'s if it is the same topic, else the bag's static
    /// transforms.
    pub mount_rpy_deg: Option<[f64; 3]>,
}

fn heading_std() -> f64 {
    5.0
}

impl Default for HeadingConfig {
    fn default() -> Self {
        Self {
            topic: None,
            yaw_offset_deg: 0.0,
            declination_deg: 0.0,
            std_deg: heading_std(),
            mount_rpy_deg: None,
        }
    }
}

/// `[imu]`: accelerations and rates for the vibration channels.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuConfig {
    /// sensor_msgs/Imu; `""` for none.
    pub topic: Option<String>,
    /// The IMU's mounting: roll, pitch, yaw in degrees of its frame in the
    /// base frame (about fixed x, y, z in that order: URDF `<origin rpy>`,
    /// `static_transform_publisher`'s yaw pitch roll reversed). Overrides the
    /// bag's static transforms. Accelerations, rates and the orientation are
    /// rotated into the base frame with it.
    pub mount_rpy_deg: Option<[f64; 3]>,
}

/// `[tf]`: where sensor mountings come from when the topics file gives none.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TfConfig {
    /// tf2_msgs/TFMessage topic of static transforms (default `/tf_static`
    /// when the bag has it); `""` for none.
    pub topic: Option<String>,
    /// The body frame (REP-103: x forward, y left, z up) sensors are rotated into.
    #[serde(default = "base_frame")]
    pub base_frame: String,
}

fn base_frame() -> String {
    "base_link".into()
}

impl Default for TfConfig {
    fn default() -> Self {
        Self {
            topic: None,
            base_frame: base_frame(),
        }
    }
}

/// A stream given by its topic alone; `""` for none.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TopicOnly {
    pub topic: Option<String>,
}

/// `[time]`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeConfig {
    /// `header` (default: header stamp, receive time when the stamp is zero)
    /// or `receive`.
    pub stamp: Option<String>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_topics_file_keys_are_errors() {
        assert!(toml::from_str::<TopicsConfig>("[wheels]\nseperation = 1.0\n").is_err());
        let c: TopicsConfig =
            toml::from_str("[wheels]\nseparation = 1.04\n[heading]\ndeclination_deg = 3\n")
                .unwrap();
        assert_eq!(c.wheels.separation, Some(1.04));
        assert_eq!(c.wheels.left, vec!["left"]);
        assert_eq!(c.tf.base_frame, "base_link");
        let c: TopicsConfig =
            toml::from_str("[imu]\nmount_rpy_deg = [90, 0, -90]\n[tf]\ntopic = \"\"\n").unwrap();
        assert_eq!(c.imu.mount_rpy_deg, Some([90.0, 0.0, -90.0]));
        assert!(toml::from_str::<TopicsConfig>("[imu]\nmount_rpy_deg = [90, 0]\n").is_err());
    }
}
