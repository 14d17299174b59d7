//! An IMU not mounted z-up: rotated into base_link by the bag's /tf_static
//! or by the topics file, on synthetic bags; a pose reference placed on
//! the robot (its lever arm) by /tf_static.

use std::path::Path;

use terraslip_ros2::defs::definition_of;
use terraslip_ros2::import::mount::{from_rpy, mul, rotate, Quat};
use terraslip_ros2::msg::CdrWriter;
use terraslip_ros2::out::EstimateMcap;
use terraslip_ros2::{import, TopicsConfig};

const T0: u64 = 1_700_000_000_000_000_000;
/// The robot's heading in the world, rad.
const YAW: f64 = 0.3;
/// Yaw rate, rad/s, and the base frame's specific force at rest, m/s².
const GYRO: [f64; 3] = [0.0, 0.0, 0.1];
const ACCEL: [f64; 3] = [0.0, 0.0, 9.81];

/// The Husky of robot_localization's test bag: IMU rolled +90°, then yawed
/// −90° about base z (its y axis is up).
fn mounting() -> Quat {
    from_rpy(90f64.to_radians(), 0.0, -90f64.to_radians())
}

fn vec3(w: &mut CdrWriter, v: [f64; 3]) {
    for c in v {
        w.f64(c);
    }
}

fn quat(w: &mut CdrWriter, q: Quat) {
    for c in q {
        w.f64(c);
    }
}

/// An Imu message measured in frame `imu_link` mounted `m` on a base
/// heading [`YAW`] with rate [`GYRO`] and specific force [`ACCEL`].
fn imu(w: &mut CdrWriter, ns: u64, m: Quat) {
    let inv = [-m[0], -m[1], -m[2], m[3]];
    w.header(ns, "imu_link");
    quat(w, mul(from_rpy(0.0, 0.0, YAW), m));
    vec3(w, [0.0; 3]);
    vec3(w, [0.0; 3]);
    vec3(w, [0.0; 3]);
    vec3(w, rotate(inv, GYRO));
    for _ in 0..9 {
        w.f64(0.0);
    }
    vec3(w, rotate(inv, ACCEL));
    for _ in 0..9 {
        w.f64(0.0);
    }
}

/// A TFMessage: base_link -> plate (yawed −90°), plate -> imu_link (rolled
/// +90°): the chain composes to [`mounting`]; and one unrelated transform.
fn tf_chain(w: &mut CdrWriter, ns: u64) {
    w.u32(3);
    for (parent, child, q) in [
        (
            "base_link",
            "plate",
            from_rpy(0.0, 0.0, -90f64.to_radians()),
        ),
        ("plate", "imu_link", from_rpy(90f64.to_radians(), 0.0, 0.0)),
        ("base_link", "gps", from_rpy(0.0, 0.0, 1.0)),
    ] {
        w.header(ns, parent);
        w.string(child);
        vec3(w, [0.1, 0.0, 0.5]);
        quat(w, q);
    }
}

/// A TFMessage that mounts imu_link yawed 180° (wrong for this IMU).
fn tf_wrong(w: &mut CdrWriter, ns: u64) {
    w.u32(1);
    w.header(ns, "/base_link");
    w.string("imu_link");
    vec3(w, [0.0; 3]);
    quat(w, from_rpy(0.0, 0.0, std::f64::consts::PI));
}

/// A JointState of `left_wheel`, `right_wheel` with velocities `v` (rad/s).
fn joint_state(ns: u64, v: [f64; 2]) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.header(ns, "base_link");
    w.u32(2).string("left_wheel").string("right_wheel");
    w.u32(0);
    w.u32(2).f64(v[0]).f64(v[1]);
    w.u32(0);
    w.finish()
}

/// JointState wheels and an Imu mounted as [`mounting`], 20 samples from
/// `T0`; `tf`, when given, writes a /tf_static message recorded 1.5 s
/// before them.
fn write_bag(p: &Path, tf: Option<fn(&mut CdrWriter, u64)>) {
    let mut m = EstimateMcap::create(p).unwrap();
    let ch = |m: &mut EstimateMcap, topic: &str, ty: &str| {
        m.channel(topic, ty, &definition_of(ty).unwrap()).unwrap()
    };
    let js = ch(&mut m, "/joint_states", "sensor_msgs/msg/JointState");
    let i = ch(&mut m, "/imu/data", "sensor_msgs/msg/Imu");
    if let Some(f) = tf {
        let c = ch(&mut m, "/tf_static", "tf2_msgs/msg/TFMessage");
        let mut w = CdrWriter::new();
        f(&mut w, T0 - 1_500_000_000);
        m.write(c, T0 - 1_500_000_000, &w.finish()).unwrap();
    }
    for k in 0..20u64 {
        let ns = T0 + k * 100_000_000;
        m.write(js, ns, &joint_state(ns, [1.0, 1.2])).unwrap();
        let mut w = CdrWriter::new();
        imu(&mut w, ns, mounting());
        m.write(i, ns, &w.finish()).unwrap();
    }
    m.finish().unwrap();
}

fn cfg(extra: &str) -> TopicsConfig {
    toml::from_str(&format!(
        "[wheels]\nwheel_radius = 0.1\n[heading]\ntopic = \"/imu/data\"\n{extra}"
    ))
    .unwrap()
}

/// Writes the bag (with `tf`) and imports it with the topics-file lines `extra`.
fn imported(
    tf: Option<fn(&mut CdrWriter, u64)>,
    extra: &str,
) -> (terraslip_io::DriveLog, terraslip_ros2::ImportReport) {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("b.mcap");
    write_bag(&p, tf);
    import(&p, &cfg(extra), None).unwrap()
}

/// The imported IMU and heading are the base frame's.
fn assert_in_base(log: &terraslip_io::DriveLog) {
    assert_eq!(log.imu.len(), 20);
    for s in &log.imu {
        let a = [s.accel_x.unwrap(), s.accel_y.unwrap(), s.accel_z];
        let g = [s.gyro_x.unwrap(), s.gyro_y.unwrap(), s.gyro_z.unwrap()];
        for k in 0..3 {
            assert!((a[k] - ACCEL[k]).abs() < 1e-9, "accel {a:?}");
            assert!((g[k] - GYRO[k]).abs() < 1e-9, "gyro {g:?}");
        }
    }
    let yaws: Vec<f64> = log.pose.iter().filter_map(|p| p.yaw).collect();
    assert_eq!(yaws.len(), 20);
    for y in yaws {
        assert!((y - YAW).abs() < 1e-9, "yaw {y}");
    }
}

#[test]
fn tf_static_rotates_the_imu_into_base_link() {
    let (log, report) = imported(Some(tf_chain), "");
    assert_in_base(&log);
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    let text = report.to_text();
    assert!(
        text.contains("/imu/data (frame `imu_link`): mounted roll 90.0°, pitch 0.0°, yaw -90.0° in base_link, from /tf_static"),
        "{text}"
    );
    // The static transforms, recorded 1.5 s before, set no time: the
    // origin is the first IMU or wheel message's, as without them.
    assert_eq!(report.time_origin_ns, T0);
}

#[test]
fn the_topics_file_gives_the_mounting_and_overrides_tf_static() {
    let mount = "[imu]\nmount_rpy_deg = [90, 0, -90]\n";
    let (log, report) = imported(None, mount);
    assert_in_base(&log);
    assert!(report.to_text().contains("from the topics file"));

    // A bag whose /tf_static says otherwise: the topics file wins.
    assert_in_base(&imported(Some(tf_wrong), mount).0);
    // Without it, the recorded mounting is used as it is.
    let (log, report) = imported(Some(tf_wrong), "");
    assert!((log.imu[0].accel_z - ACCEL[2]).abs() > 1.0);
    assert!(
        report.to_text().contains("yaw 180.0°"),
        "{}",
        report.to_text()
    );
}

#[test]
fn an_imu_not_z_up_with_no_mounting_is_warned_about() {
    let (log, report) = imported(None, "");
    // As recorded: gravity along the IMU's y.
    assert!((log.imu[0].accel_y.unwrap() - 9.81).abs() < 1e-9);
    assert!(report.mounts.is_empty());
    let w = report.warnings.join("\n");
    assert!(
        w.contains("/imu/data") && w.contains("not along +z") && w.contains("mount_rpy_deg"),
        "{w}"
    );
}

#[test]
fn a_frame_missing_from_tf_static_is_named() {
    let (_, report) = imported(Some(tf_chain), "[tf]\nbase_frame = \"base_footprint\"\n");
    let w = report.warnings.join("\n");
    assert!(
        w.contains("`imu_link` has no static transform to base_footprint in /tf_static"),
        "{w}"
    );
}

// The pose reference's lever arm: an Odometry whose child frame is a
// lidar's (a lidar localisation's output), placed by /tf_static.

/// JointState wheels and an Odometry of `os_sensor` in `map`, 20 samples;
/// `/tf_static` places `os_sensor` at `origin` from base_link.
fn write_lidar_bag(p: &Path, origin: [f64; 3]) {
    let mut m = EstimateMcap::create(p).unwrap();
    let ch = |m: &mut EstimateMcap, topic: &str, ty: &str| {
        m.channel(topic, ty, &definition_of(ty).unwrap()).unwrap()
    };
    let js = ch(&mut m, "/joint_states", "sensor_msgs/msg/JointState");
    let odom = ch(&mut m, "/lidar/odometry", "nav_msgs/msg/Odometry");
    let tf = ch(&mut m, "/tf_static", "tf2_msgs/msg/TFMessage");
    let mut w = CdrWriter::new();
    w.u32(1).header(T0, "base_link").string("os_sensor");
    for c in origin.into_iter().chain([0.0, 0.0, 0.0, 1.0]) {
        w.f64(c);
    }
    m.write(tf, T0, &w.finish()).unwrap();
    for k in 0..20u64 {
        let ns = T0 + k * 100_000_000;
        m.write(js, ns, &joint_state(ns, [1.0, 1.0])).unwrap();
        let mut w = CdrWriter::new();
        w.header(ns, "map").string("os_sensor");
        for c in [0.01 * k as f64, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
            w.f64(c);
        }
        for _ in 0..36 {
            w.f64(0.0);
        }
        for _ in 0..6 {
            w.f64(0.0);
        }
        for _ in 0..36 {
            w.f64(0.0);
        }
        m.write(odom, ns, &w.finish()).unwrap();
    }
    m.finish().unwrap();
}

fn imported_lidar(origin: [f64; 3]) -> (terraslip_io::DriveLog, terraslip_ros2::ImportReport) {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("b.mcap");
    write_lidar_bag(&p, origin);
    import(&p, &TopicsConfig::default(), None).unwrap()
}

#[test]
fn a_lidar_odometry_is_placed_by_its_child_frame() {
    let (log, report) = imported_lidar([-0.25, 0.1, 0.6]);
    let pose = log.meta.pose.expect("a lever arm from /tf_static");
    assert_eq!((pose.lever_arm_x, pose.lever_arm_y), (-0.25, 0.1));
    assert!(
        report
            .decisions
            .iter()
            .any(|d| d.contains("/lidar/odometry (frame `os_sensor`)") && d.contains("/tf_static")),
        "{:?}",
        report.decisions
    );
}

#[test]
fn a_frame_beyond_a_robots_size_is_not_a_lever_arm() {
    let (log, report) = imported_lidar([120.0, 0.0, 0.0]);
    assert_eq!(log.meta.pose, None);
    assert!(
        report
            .warnings
            .iter()
            .any(|w| w.contains("beyond a robot's size")),
        "{:?}",
        report.warnings
    );
}
