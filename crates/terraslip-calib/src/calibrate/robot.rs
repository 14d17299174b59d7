//! What the logs' `meta.toml` tell about the robot.

use terraslip_io::DriveLog;

/// What the logs' `meta.toml` tell about the robot.
pub(super) struct RobotFacts {
    /// m, of the first log that gives one.
    pub(super) track_width: Option<f64>,
    pub(super) wheel_radius: Option<f64>,
    /// A Pioneer P3-AT (its server settings are written).
    pub(super) pioneer: bool,
}

impl RobotFacts {
    pub(super) fn of(logs: &[DriveLog]) -> Self {
        Self {
            track_width: logs.iter().find_map(|l| l.meta.track_width),
            wheel_radius: logs.iter().find_map(|l| l.meta.wheel_radius),
            pioneer: logs.iter().any(|l| {
                l.meta.robot.as_deref().is_some_and(|r| {
                    let r = r.to_ascii_lowercase();
                    r.contains("p3at") || r.contains("p3-at") || r.contains("pioneer")
                })
            }),
        }
    }
}
