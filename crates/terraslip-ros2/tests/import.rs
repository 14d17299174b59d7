//! Import on synthetic bags: topic choice, JointState, NavSatFix to ENU,
//! IMU heading with offset and declination, header stamps vs receive time.

use std::path::Path;

use terraslip_ros2::defs::definition_of;
use terraslip_ros2::msg::CdrWriter;
use terraslip_ros2::out::EstimateMcap;
use terraslip_ros2::{import, TopicsConfig};

const T0: u64 = 1_700_000_000_000_000_000;

fn joint_state(w: &mut CdrWriter, ns: u64, vl: f64, vr: f64) {
    w.header(ns, "base_link");
    w.u32(2)
        .string("front_left_wheel_joint")
        .string("front_right_wheel_joint");
    w.u32(0); // position
    w.u32(2).f64(vl).f64(vr);
    w.u32(0); // effort
}

fn fix(w: &mut CdrWriter, ns: u64, status: i8, lat: f64, lon: f64) {
    w.header(ns, "gps");
    w.u8(status as u8);
    // uint16 service (aligned to 2)
    w.u8(0).u8(1).u8(0);
    w.f64(lat).f64(lon).f64(100.0);
    for c in [4.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 9.0] {
        w.f64(c);
    }
    w.u8(2);
}

fn imu(w: &mut CdrWriter, ns: u64, yaw: f64) {
    w.header(ns, "imu");
    let (s, c) = (yaw / 2.0).sin_cos();
    w.f64(0.0).f64(0.0).f64(s).f64(c);
    for _ in 0..9 {
        w.f64(0.0);
    }
    for v in [0.0, 0.0, 0.1] {
        w.f64(v);
    }
    for _ in 0..9 {
        w.f64(0.0);
    }
    for v in [0.0, 0.0, 9.81] {
        w.f64(v);
    }
    for _ in 0..9 {
        w.f64(0.0);
    }
}

/// Two JointState topics, one NavSatFix, one Imu; 20 samples 0.1 s apart.
/// The joint states' header stamps are 0 on `/js_b` (receive time is used).
fn write_bag(p: &Path) {
    let mut m = EstimateMcap::create(p).unwrap();
    let js = "sensor_msgs/msg/JointState";
    let a = m.channel("/js_a", js, &definition_of(js).unwrap()).unwrap();
    let b = m.channel("/js_b", js, &definition_of(js).unwrap()).unwrap();
    let f = m
        .channel(
            "/fix",
            "sensor_msgs/msg/NavSatFix",
            &definition_of("sensor_msgs/msg/NavSatFix").unwrap(),
        )
        .unwrap();
    let i = m
        .channel(
            "/imu",
            "sensor_msgs/msg/Imu",
            &definition_of("sensor_msgs/msg/Imu").unwrap(),
        )
        .unwrap();
    for k in 0..20u64 {
        let ns = T0 + k * 100_000_000;
        let mut w = CdrWriter::new();
        joint_state(&mut w, ns, 2.0, 4.0);
        m.write(a, ns + 5_000_000, &w.finish()).unwrap();
        let mut w = CdrWriter::new();
        joint_state(&mut w, 0, 1.0, 1.0);
        m.write(b, ns + 5_000_000, &w.finish()).unwrap();
        let mut w = CdrWriter::new();
        // 0.001 degree of latitude per sample; the first fix has no fix.
        fix(
            &mut w,
            ns,
            if k == 0 { -1 } else { 0 },
            45.0 + 0.001 * k as f64,
            7.0,
        );
        m.write(f, ns, &w.finish()).unwrap();
        let mut w = CdrWriter::new();
        imu(&mut w, ns, 0.3);
        m.write(i, ns, &w.finish()).unwrap();
    }
    m.finish().unwrap();
}

#[test]
fn ambiguous_wheel_topics_fail_listing_candidates_and_the_lines_to_pick() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("b.mcap");
    write_bag(&p);
    let e = import(&p, &TopicsConfig::default(), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("/js_a") && e.contains("/js_b"), "{e}");
    assert!(e.contains("[wheels] topic = \"/js_a\""), "{e}");
    assert!(!e.contains('\n'), "one line: {e}");
}

#[test]
fn a_configured_bag_imports_with_enu_heading_and_stamps() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("b.mcap");
    write_bag(&p);
    let cfg: TopicsConfig = toml::from_str(
        "[wheels]\ntopic = \"/js_a\"\nwheel_radius = 0.5\n[heading]\nyaw_offset_deg = 10\ndeclination_deg = 4\nstd_deg = 2\n",
    )
    .unwrap();
    let (log, report) = import(&p, &cfg, None).unwrap();
    assert_eq!(report.time_origin_ns, T0);
    assert_eq!(log.wheels.len(), 20);
    // rad/s x radius; header stamps (not the receive time 5 ms later).
    assert_eq!(log.wheels[3].v_left, 1.0);
    assert_eq!(log.wheels[3].v_right, 2.0);
    assert!((log.wheels[3].t - 0.3).abs() < 1e-9, "{}", log.wheels[3].t);
    let fixes: Vec<_> = log.pose.iter().filter(|p| p.east.is_some()).collect();
    assert_eq!(fixes.len(), 19, "the no-fix status is dropped");
    // Origin is the first good fix (k = 1); 0.018 degrees north at 45 N is
    // 2000.41 m north on WGS-84 (ECEF to ENU, computed independently), no east.
    let last = fixes.last().unwrap();
    assert!(last.east.unwrap().abs() < 0.01, "{:?}", last.east);
    assert!(
        (last.north.unwrap() - 2000.407).abs() < 0.01,
        "{:?}",
        last.north
    );
    assert_eq!(last.std_xy, Some(2.0));
    // yaw = 0.3 rad + 10 deg - 4 deg
    let h = log.pose.iter().find(|p| p.yaw.is_some()).unwrap();
    assert!((h.yaw.unwrap() - (0.3 + 6f64.to_radians())).abs() < 1e-9);
    assert!((h.std_yaw.unwrap() - 2f64.to_radians()).abs() < 1e-12);
    assert_eq!(log.imu.len(), 20);
    assert_eq!(log.imu[0].gyro_z, Some(0.1));

    // Zero header stamps fall back to the receive time.
    let cfg: TopicsConfig =
        toml::from_str("[wheels]\ntopic = \"/js_b\"\nwheel_radius = 0.5\n").unwrap();
    let (log, _) = import(&p, &cfg, None).unwrap();
    assert!(
        (log.wheels[3].t - 0.305).abs() < 1e-9,
        "{}",
        log.wheels[3].t
    );
}

#[test]
fn a_topic_of_the_wrong_type_is_named() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("b.mcap");
    write_bag(&p);
    let cfg: TopicsConfig = toml::from_str("[wheels]\ntopic = \"/imu\"\n").unwrap();
    let e = import(&p, &cfg, None).unwrap_err().to_string();
    assert!(
        e.contains("/imu") && e.contains("sensor_msgs/msg/Imu"),
        "{e}"
    );
}

#[test]
fn an_lz4_compressed_mcap_file_reads_the_same() {
    use std::io::Write;
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("b.mcap");
    write_bag(&p);
    let lz = d.path().join("c.mcap.lz4");
    let mut enc = lz4::EncoderBuilder::new()
        .build(std::fs::File::create(&lz).unwrap())
        .unwrap();
    enc.write_all(&std::fs::read(&p).unwrap()).unwrap();
    let (_, r) = enc.finish();
    r.unwrap();
    let cfg: TopicsConfig =
        toml::from_str("[wheels]\ntopic = \"/js_a\"\nwheel_radius = 0.5\n").unwrap();
    let (a, _) = import(&p, &cfg, None).unwrap();
    let (b, _) = import(&lz, &cfg, None).unwrap();
    assert_eq!(a.wheels, b.wheels);
    assert_eq!(a.pose, b.pose);
    assert_eq!(a.imu, b.imu);
}
