//! Built-in `ros2msg` definitions of the message types terraslip reads and
//! writes, for bags that carry none (sqlite3 bags before Iron). Layouts as in
//! the ROS 2 interface packages (unchanged from Foxy to Jazzy).

/// Every built-in type, as `MSG:` sections.
pub const BUILTIN: &str = "================================================================================\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n\
================================================================================\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
================================================================================\nMSG: std_msgs/String\nstring data\n\
================================================================================\nMSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n\
================================================================================\nMSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n\
================================================================================\nMSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w\n\
================================================================================\nMSG: geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n\
================================================================================\nMSG: geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\nfloat64[36] covariance\n\
================================================================================\nMSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n\
================================================================================\nMSG: geometry_msgs/TwistWithCovariance\ngeometry_msgs/Twist twist\nfloat64[36] covariance\n\
================================================================================\nMSG: geometry_msgs/PoseStamped\nstd_msgs/Header header\ngeometry_msgs/Pose pose\n\
================================================================================\nMSG: geometry_msgs/PoseWithCovarianceStamped\nstd_msgs/Header header\ngeometry_msgs/PoseWithCovariance pose\n\
================================================================================\nMSG: geometry_msgs/TwistStamped\nstd_msgs/Header header\ngeometry_msgs/Twist twist\n\
================================================================================\nMSG: geometry_msgs/Transform\ngeometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n\
================================================================================\nMSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n\
================================================================================\nMSG: tf2_msgs/TFMessage\ngeometry_msgs/TransformStamped[] transforms\n\
================================================================================\nMSG: nav_msgs/Odometry\nstd_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n\
================================================================================\nMSG: sensor_msgs/JointState\nstd_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n\
================================================================================\nMSG: sensor_msgs/Imu\nstd_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance\n\
================================================================================\nMSG: sensor_msgs/NavSatStatus\nint8 STATUS_NO_FIX=-1\nint8 STATUS_FIX=0\nint8 status\nuint16 service\n\
================================================================================\nMSG: sensor_msgs/NavSatFix\nuint8 COVARIANCE_TYPE_UNKNOWN=0\nuint8 COVARIANCE_TYPE_APPROXIMATED=1\nuint8 COVARIANCE_TYPE_DIAGONAL_KNOWN=2\nuint8 COVARIANCE_TYPE_KNOWN=3\nstd_msgs/Header header\nsensor_msgs/NavSatStatus status\nfloat64 latitude\nfloat64 longitude\nfloat64 altitude\nfloat64[9] position_covariance\nuint8 position_covariance_type\n\
================================================================================\nMSG: sensor_msgs/Image\nstd_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data\n\
================================================================================\nMSG: sensor_msgs/CompressedImage\nstd_msgs/Header header\nstring format\nuint8[] data\n\
================================================================================\nMSG: diagnostic_msgs/KeyValue\nstring key\nstring value\n\
================================================================================\nMSG: diagnostic_msgs/DiagnosticStatus\nbyte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\nstring name\nstring message\nstring hardware_id\ndiagnostic_msgs/KeyValue[] values\n\
================================================================================\nMSG: diagnostic_msgs/DiagnosticArray\nstd_msgs/Header header\ndiagnostic_msgs/DiagnosticStatus[] status\n";

/// Whether `ty` (`pkg/Name` or `pkg/msg/Name`) has a built-in definition.
pub fn has_builtin(ty: &str) -> bool {
    let t = crate::msg::short_type(ty);
    BUILTIN
        .lines()
        .any(|l| l.strip_prefix("MSG: ") == Some(t.as_str()))
}
fn section(ty: &str) -> Option<&'static str> {
    let head = format!("MSG: {ty}\n");
    let start = BUILTIN.find(&head)? + head.len();
    let end = BUILTIN[start..]
        .find("====")
        .map_or(BUILTIN.len(), |e| start + e);
    Some(&BUILTIN[start..end])
}

/// The full `ros2msg` definition of a built-in type as a bag or MCAP schema
/// stores it: the type's fields, then each dependency once as a `MSG:` section.
pub fn definition_of(ty: &str) -> Option<String> {
    let root = crate::msg::short_type(ty);
    let mut out = section(&root)?.to_string();
    let mut seen = vec![root.clone()];
    let mut stack = vec![root];
    while let Some(t) = stack.pop() {
        for line in section(&t).unwrap_or("").lines() {
            let Some(ft) = line.split_whitespace().next() else {
                continue;
            };
            let base = ft.split('[').next().unwrap_or(ft);
            if base.contains('/') && !seen.iter().any(|s| s == base) {
                if let Some(body) = section(base) {
                    out.push_str("================================================================================\nMSG: ");
                    out.push_str(base);
                    out.push('\n');
                    out.push_str(body);
                    seen.push(base.to_string());
                    stack.push(base.to_string());
                }
            }
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_parses_alone_and_from_its_own_definition() {
        for line in BUILTIN.lines() {
            if let Some(ty) = line.strip_prefix("MSG: ") {
                let def = definition_of(ty).unwrap();
                crate::msg::Registry::parse(ty, &def, None)
                    .unwrap_or_else(|e| panic!("{ty}: {e}\n{def}"));
            }
        }
        assert!(has_builtin("nav_msgs/msg/Odometry"));
        assert!(!has_builtin("nav_msgs/msg/Path"));
        assert!(definition_of("nav_msgs/msg/Odometry")
            .unwrap()
            .contains("MSG: builtin_interfaces/Time"));
    }
}
