//! Bags imported with no topics file, as a ROS 2 engineer records them: an
//! odometry twist with no separation given (with and without a URDF), an
//! IMU mounted y-up with no /tf_static, a heading biased against the GNSS
//! course, no pose at all. One synthetic drive: straight legs at a speed
//! that swings between 0.6 and 1.4 m/s, each followed by a 90° left turn in
//! 4 s (legs of 12 s).

use std::f64::consts::{FRAC_PI_2, PI};
use std::path::Path;

use terraslip_io::DriveLog;
use terraslip_ros2::defs::definition_of;
use terraslip_ros2::import::mount::{conj, from_rpy, mul, rotate, Quat};
use terraslip_ros2::import::scale::DEFAULT_SEPARATION;
use terraslip_ros2::msg::CdrWriter;
use terraslip_ros2::out::EstimateMcap;
use terraslip_ros2::{import, ImportReport, TopicsConfig};

const T0: u64 = 1_700_000_000_000_000_000;
const HZ: u64 = 50;
const SECONDS: u64 = 140;

/// The true motion at `t` s: forward speed (m/s), its rate (m/s²), yaw
/// rate (rad/s).
fn motion(t: f64) -> (f64, f64, f64) {
    let w = 2.0 * PI / 5.0;
    let v = 1.0 + 0.4 * (w * t).sin();
    let dv = 0.4 * w * (w * t).cos();
    let turning = t % 16.0 >= 12.0;
    (v, dv, if turning { FRAC_PI_2 / 4.0 } else { 0.0 })
}

#[derive(Clone, Copy)]
struct Kind {
    urdf: bool,
    /// The IMU's mounting in base_link, and whether it is recorded.
    imu: Option<Quat>,
    /// Added to the IMU orientation's yaw, rad.
    heading_bias: f64,
    gnss: bool,
}

const URDF: &str = r#"<robot name="r">
  <link name="base_link"/>
  <link name="left_wheel_link"><collision><geometry><cylinder radius="0.12" length="0.05"/></geometry></collision></link>
  <link name="right_wheel_link"><collision><geometry><cylinder radius="0.12" length="0.05"/></geometry></collision></link>
  <joint name="left_wheel" type="continuous"><parent link="base_link"/><child link="left_wheel_link"/><origin xyz="0 0.3 0"/></joint>
  <joint name="right_wheel" type="continuous"><parent link="base_link"/><child link="right_wheel_link"/><origin xyz="0 -0.3 0"/></joint>
</robot>"#;

fn vec3(w: &mut CdrWriter, v: [f64; 3]) {
    for c in v {
        w.f64(c);
    }
}

fn write_bag(p: &Path, k: Kind) {
    let mut m = EstimateMcap::create(p).unwrap();
    let ch = |m: &mut EstimateMcap, topic: &str, ty: &str| {
        m.channel(topic, ty, &definition_of(ty).unwrap()).unwrap()
    };
    let odom = ch(&mut m, "/controller/odom", "nav_msgs/msg/Odometry");
    let imu = k
        .imu
        .map(|_| ch(&mut m, "/imu/data", "sensor_msgs/msg/Imu"));
    let fix = k
        .gnss
        .then(|| ch(&mut m, "/fix", "sensor_msgs/msg/NavSatFix"));
    if k.urdf {
        let c = ch(&mut m, "/robot_description", "std_msgs/msg/String");
        let mut w = CdrWriter::new();
        w.string(URDF);
        m.write(c, T0, &w.finish()).unwrap();
    }
    let (mut e, mut n, mut yaw) = (0.0f64, 0.0f64, 0.3f64);
    let dt = 1.0 / HZ as f64;
    for i in 0..SECONDS * HZ {
        let t = i as f64 * dt;
        let ns = T0 + i * (1_000_000_000 / HZ);
        let (v, dv, wz) = motion(t);
        e += dt * v * yaw.cos();
        n += dt * v * yaw.sin();
        yaw += dt * wz;
        let mut w = CdrWriter::new();
        w.header(ns, "odom").string("base_link");
        for _ in 0..7 + 36 {
            w.f64(0.0);
        }
        vec3(&mut w, [v, 0.0, 0.0]);
        vec3(&mut w, [0.0, 0.0, wz]);
        for _ in 0..36 {
            w.f64(0.0);
        }
        m.write(odom, ns, &w.finish()).unwrap();
        if let (Some(c), Some(mount)) = (imu, k.imu) {
            // Specific force and rate in base_link, into the IMU's frame.
            let inv = conj(mount);
            let mut w = CdrWriter::new();
            w.header(ns, "imu_link");
            let world = from_rpy(0.0, 0.0, yaw + k.heading_bias);
            for c in mul(world, mount) {
                w.f64(c);
            }
            for _ in 0..9 {
                w.f64(0.0);
            }
            vec3(&mut w, rotate(inv, [0.0, 0.0, wz]));
            for _ in 0..9 {
                w.f64(0.0);
            }
            vec3(&mut w, rotate(inv, [dv, v * wz, 9.81]));
            for _ in 0..9 {
                w.f64(0.0);
            }
            m.write(c, ns, &w.finish()).unwrap();
        }
        if let Some(c) = fix.filter(|_| i % (HZ / 2) == 0) {
            let mut w = CdrWriter::new();
            w.header(ns, "gps");
            w.u8(0).u8(0).u8(1).u8(0);
            let lat = 45.0 + n / 111_132.0;
            let lon = 7.0 + e / (111_319.5 * 45f64.to_radians().cos());
            w.f64(lat).f64(lon).f64(100.0);
            for c in [0.25, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 1.0] {
                w.f64(c);
            }
            w.u8(2);
            m.write(c, ns, &w.finish()).unwrap();
        }
    }
    m.finish().unwrap();
}

fn imported(k: Kind) -> (DriveLog, ImportReport) {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("b.mcap");
    write_bag(&p, k);
    import(&p, &TopicsConfig::default(), None).unwrap()
}

const PLAIN: Kind = Kind {
    urdf: false,
    imu: None,
    heading_bias: 0.0,
    gnss: false,
};

/// Husky-like: y axis up, x to the right.
fn y_up() -> Quat {
    from_rpy(90f64.to_radians(), 0.0, -90f64.to_radians())
}

#[test]
fn an_odometry_twist_with_no_separation_runs_at_a_stated_nominal_one() {
    // No URDF, no track width, no pose: the default, said so.
    let (log, report) = imported(PLAIN);
    assert_eq!(log.meta.separation, Some(DEFAULT_SEPARATION));
    assert_eq!(log.meta.separation_source.as_deref(), Some("default"));
    assert!(!log.meta.separation_is_absolute());
    let text = report.to_text();
    assert!(
        text.contains("decided: separation S = 1 m") && text.contains("a default"),
        "{text}"
    );
    // v ∓ ω·S/2 with that S, on a turn.
    let w = log.wheels.iter().find(|w| w.t > 11.0).unwrap();
    let (v, _, wz) = motion(w.t);
    assert!((w.v_right - w.v_left - wz * DEFAULT_SEPARATION).abs() < 1e-9);
    assert!((0.5 * (w.v_right + w.v_left) - v).abs() < 1e-9);
    // No pose at all: no pose rows, no heading.
    assert!(log.pose.is_empty());
    assert!(report.streams.iter().all(|s| !s.file.starts_with("pose")));

    // The URDF's wheel joints, when the bag carries /robot_description.
    let (log, report) = imported(Kind {
        urdf: true,
        ..PLAIN
    });
    assert_eq!(log.meta.separation, Some(0.6));
    assert_eq!(log.meta.separation_source.as_deref(), Some("urdf"));
    assert!(report.to_text().contains("/robot_description"));
}

#[test]
fn an_imu_mounted_y_up_with_no_mounting_given_is_found_from_the_data() {
    let (log, report) = imported(Kind {
        imu: Some(y_up()),
        ..PLAIN
    });
    let text = report.to_text();
    assert!(
        text.contains("mounted roll 90.0°, pitch 0.0°, yaw -90.0° in base_link, from the data"),
        "{text}"
    );
    assert!(!report.warnings.iter().any(|w| w.contains("not along +z")));
    // In base_link: gravity up, the yaw rate on z, the forward acceleration on x.
    for s in &log.imu {
        let (v, dv, wz) = motion(s.t);
        assert!((s.accel_z - 9.81).abs() < 1e-6, "{}", s.accel_z);
        assert!((s.gyro_z.unwrap() - wz).abs() < 1e-6);
        assert!((s.accel_x.unwrap() - dv).abs() < 1e-6);
        assert!((s.accel_y.unwrap() - v * wz).abs() < 1e-6);
    }
    // An IMU mounted upside down and yawed 180°: the same from the data.
    let (log, report) = imported(Kind {
        imu: Some(from_rpy(PI, 0.0, PI)),
        ..PLAIN
    });
    assert!(report.to_text().contains("from the data"));
    let s = &log.imu[777];
    let (_, dv, wz) = motion(s.t);
    assert!((s.accel_z - 9.81).abs() < 1e-6 && (s.gyro_z.unwrap() - wz).abs() < 1e-6);
    assert!((s.accel_x.unwrap() - dv).abs() < 1e-6);
}

#[test]
fn a_heading_that_disagrees_with_the_gnss_course_is_left_out() {
    let kind = Kind {
        imu: Some(y_up()),
        gnss: true,
        ..PLAIN
    };
    // Mounted y-up and found from the data: its heading agrees with the
    // course and is used.
    let (log, report) = imported(kind);
    let yaws = log.pose.iter().filter(|p| p.yaw.is_some()).count();
    assert_eq!(yaws, (SECONDS * HZ) as usize);
    assert!(
        report.decisions.iter().any(|d| d.contains("heading used")),
        "{:?}",
        report.decisions
    );
    let p = log
        .pose
        .iter()
        .find(|p| p.yaw.is_some() && p.t > 5.0)
        .unwrap();
    assert!((p.yaw.unwrap() - 0.3).abs() < 1e-6, "{:?}", p);
    // 40° off (a wrong declination): left out, with a warning.
    let (log, report) = imported(Kind {
        heading_bias: 40f64.to_radians(),
        ..kind
    });
    assert!(log.pose.iter().all(|p| p.yaw.is_none() && p.east.is_some()));
    let w = report.warnings.join("\n");
    assert!(
        w.contains("/imu/data: heading left out") && w.contains("40.0° from the GNSS course"),
        "{w}"
    );
}
