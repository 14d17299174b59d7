//! The roles a bag's topics play: which stream of the drive log each feeds,
//! and the message types each accepts.

/// The stream a topic feeds in the drive log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Role {
    Wheels,
    Pose,
    Heading,
    Imu,
    Images,
    /// Static transforms: sensor mountings and the pose reference's lever arm.
    Tf,
}

impl Role {
    /// The role's section in the topics file (`[wheels]`, `[pose]`, ...).
    pub(super) fn key(self) -> &'static str {
        match self {
            Role::Wheels => "wheels",
            Role::Pose => "pose",
            Role::Heading => "heading",
            Role::Imu => "imu",
            Role::Images => "images",
            Role::Tf => "tf",
        }
    }
    /// Accepted types, in order of preference when choosing by type.
    pub(super) fn types(self) -> &'static [&'static [&'static str]] {
        match self {
            Role::Wheels => &[
                &["sensor_msgs/JointState"],
                &["nav_msgs/Odometry", "geometry_msgs/TwistStamped"],
            ],
            Role::Pose => &[
                &["sensor_msgs/NavSatFix"],
                &[
                    "geometry_msgs/PoseWithCovarianceStamped",
                    "geometry_msgs/PoseStamped",
                ],
                &["nav_msgs/Odometry"],
            ],
            Role::Heading | Role::Imu => &[&["sensor_msgs/Imu"]],
            Role::Images => &[&["sensor_msgs/CompressedImage"], &["sensor_msgs/Image"]],
            Role::Tf => &[&["tf2_msgs/TFMessage"]],
        }
    }
}
