//! Other robots' recordings, as a new user runs them: no topics file.
//! Each kind is a small synthetic twin with that robot's topic layout
//! (docs/figures/robots.md lists them with their sources): `import`,
//! `estimate --mcap` and `report` succeed, `calibrate --ros2-params` where
//! a pose reference exists, and nothing is written beside the bag.
#![cfg(feature = "ros2")]

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use assert_cmd::Command;
use terraslip_ros2::defs::definition_of;
use terraslip_ros2::msg::CdrWriter;
use terraslip_ros2::out::EstimateMcap;

const T0: u64 = 1_700_000_000_000_000_000;
const HZ: u64 = 20;
const SECONDS: u64 = 90;

/// The true motion at `t` s: forward speed (m/s), yaw rate (rad/s). Legs
/// of 8 s, each followed by a turn of 4 s; a spin in place at 40-44 s.
fn motion(t: f64) -> (f64, f64) {
    let v = 0.5 + 0.2 * (2.0 * PI * t / 7.0).sin();
    match t % 12.0 {
        _ if (40.0..44.0).contains(&t) => (0.0, 0.8),
        x if x >= 8.0 => (v, 0.4),
        _ => (v, 0.0),
    }
}

/// An odometry topic of the twin: its name, `header.frame_id`, and how it
/// is made (`lateral`: a lateral velocity, as a filter fusing an IMU has;
/// `yaw_scale`: its turn against the true one).
#[derive(Clone, Copy)]
struct Odom {
    topic: &'static str,
    frame: &'static str,
    lateral: f64,
    yaw_scale: f64,
}

/// JointState wheels: joint names and what is filled in.
#[derive(Clone, Copy)]
struct Joints {
    left: &'static str,
    right: &'static str,
    velocity: bool,
    position: bool,
    /// Positions wrapped into (-π, π].
    wrapped: bool,
    /// Stamps jittered by up to ± this many s; every 7th stamp repeated.
    jitter: f64,
}

#[derive(Clone, Default)]
struct Twin {
    odoms: Vec<Odom>,
    joints: Option<Joints>,
    imu: Option<&'static str>,
    /// The gyro's turn against the true one (a tracked vehicle's treads
    /// turn it less than their speed difference says).
    gyro_scale: f64,
    urdf: Option<&'static str>,
}

const WHEEL_R: f64 = 0.033;

fn odom_msg(w: &mut CdrWriter, ns: u64, o: &Odom, pose: (f64, f64, f64), v: f64, wz: f64) {
    w.header(ns, o.frame).string("base_link");
    let (sz, cz) = (pose.2 / 2.0).sin_cos();
    for c in [pose.0, pose.1, 0.0, 0.0, 0.0, sz, cz] {
        w.f64(c);
    }
    for k in 0..36 {
        w.f64(if k % 7 == 0 { 0.01 } else { 0.0 });
    }
    for c in [v, o.lateral * wz, 0.0, 0.0, 0.0, wz * o.yaw_scale] {
        w.f64(c);
    }
    for k in 0..36 {
        w.f64(if k % 7 == 0 { 0.01 } else { 0.0 });
    }
}

fn write_twin(p: &Path, k: &Twin) {
    let mut m = EstimateMcap::create(p).unwrap();
    let ch = |m: &mut EstimateMcap, topic: &str, ty: &str| {
        m.channel(topic, ty, &definition_of(ty).unwrap()).unwrap()
    };
    let odoms: Vec<_> = k
        .odoms
        .iter()
        .map(|o| ch(&mut m, o.topic, "nav_msgs/msg/Odometry"))
        .collect();
    let js = k
        .joints
        .map(|_| ch(&mut m, "/joint_states", "sensor_msgs/msg/JointState"));
    let imu = k.imu.map(|t| ch(&mut m, t, "sensor_msgs/msg/Imu"));
    if let Some(u) = k.urdf {
        let c = ch(&mut m, "/robot_description", "std_msgs/msg/String");
        let mut w = CdrWriter::new();
        w.string(u);
        m.write(c, T0, &w.finish()).unwrap();
    }
    let sep = 0.3;
    let (mut x, mut y, mut yaw) = (0.0f64, 0.0f64, 0.0f64);
    let (mut ql, mut qr) = (1.0f64, -2.0f64);
    let dt = 1.0 / HZ as f64;
    let mut last_js = 0u64;
    for i in 0..SECONDS * HZ {
        let t = i as f64 * dt;
        let ns = T0 + i * (1_000_000_000 / HZ);
        let (v, wz) = motion(t);
        x += dt * v * yaw.cos();
        y += dt * v * yaw.sin();
        yaw += dt * wz;
        ql += dt * (v - wz * sep / 2.0) / WHEEL_R;
        qr += dt * (v + wz * sep / 2.0) / WHEEL_R;
        for (o, &c) in k.odoms.iter().zip(&odoms) {
            let mut w = CdrWriter::new();
            odom_msg(&mut w, ns, o, (x, y, yaw), v, wz);
            m.write(c, ns, &w.finish()).unwrap();
        }
        if let (Some(c), Some(j)) = (js, k.joints) {
            let jit = (j.jitter * 1e9 * ((i * 7919 % 13) as f64 / 6.0 - 1.0)) as i64;
            let stamp = if i % 7 == 3 {
                last_js
            } else {
                (ns as i64 + jit) as u64
            };
            last_js = stamp;
            let wrap = |a: f64| {
                if j.wrapped {
                    (a + PI).rem_euclid(2.0 * PI) - PI
                } else {
                    a
                }
            };
            let mut w = CdrWriter::new();
            w.header(stamp, "");
            w.u32(2).string(j.left).string(j.right);
            if j.position {
                w.u32(2).f64(wrap(ql)).f64(wrap(qr));
            } else {
                w.u32(0);
            }
            if j.velocity {
                w.u32(2)
                    .f64((v - wz * sep / 2.0) / WHEEL_R)
                    .f64((v + wz * sep / 2.0) / WHEEL_R);
            } else {
                w.u32(0);
            }
            w.u32(0);
            m.write(c, ns, &w.finish()).unwrap();
        }
        if let Some(c) = imu {
            let mut w = CdrWriter::new();
            w.header(ns, "imu_link");
            let (sz, cz) = (yaw / 2.0).sin_cos();
            for c in [0.0, 0.0, sz, cz] {
                w.f64(c);
            }
            for _ in 0..9 {
                w.f64(0.0);
            }
            for c in [0.0, 0.0, wz * k.gyro_scale] {
                w.f64(c);
            }
            for _ in 0..9 {
                w.f64(0.0);
            }
            for c in [0.0, v * wz, 9.81] {
                w.f64(c);
            }
            for _ in 0..9 {
                w.f64(0.0);
            }
            m.write(c, ns, &w.finish()).unwrap();
        }
    }
    m.finish().unwrap();
}

fn run(args: &[&str]) -> std::process::Output {
    Command::cargo_bin("terraslip")
        .unwrap()
        .args(args)
        .output()
        .unwrap()
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// What the commands said and wrote.
struct Ran {
    /// `import`'s and `estimate`'s terminal output.
    said: String,
    summary: serde_json::Value,
    _dir: tempfile::TempDir,
}

/// Runs `import`, `estimate --mcap`, `report` (and `calibrate
/// --ros2-params` when `pose`) on the twin with no topics file; each must
/// succeed and leave the bag's directory as it was.
fn runs(k: &Twin, pose: bool) -> Ran {
    let d = tempfile::tempdir().unwrap();
    let bagdir = d.path().join("bag");
    std::fs::create_dir(&bagdir).unwrap();
    let bag = bagdir.join("drive.mcap");
    write_twin(&bag, k);
    let before = listing(&bagdir);
    let s = |p: PathBuf| p.to_str().unwrap().to_string();
    let b = s(bag.clone());
    let mut said = String::new();
    let mut check = |args: &[&str]| {
        let out = run(args);
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{args:?}: {err}");
        said.push_str(&err);
    };
    check(&["import", &b, "--out", &s(d.path().join("log"))]);
    let est = s(d.path().join("est"));
    check(&[
        "estimate",
        &b,
        "--out",
        &est,
        "--mcap",
        &s(d.path().join("est.mcap")),
    ]);
    check(&["report", &est]);
    if pose {
        check(&[
            "calibrate",
            &b,
            "--out",
            &s(d.path().join("params.json")),
            "--ros2-params",
            &s(d.path().join("ddc.yaml")),
        ]);
    }
    assert_eq!(listing(&bagdir), before, "nothing written beside the bag");
    let summary =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("est/summary.json")).unwrap())
            .unwrap();
    Ran {
        said,
        summary,
        _dir: d,
    }
}

/// A base driver's or drive controller's wheel odometry.
const fn wheel_odom(topic: &'static str) -> Odom {
    Odom {
        topic,
        frame: "odom",
        lateral: 0.0,
        yaw_scale: 1.0,
    }
}

/// An AgileX Scout-like skid-steer: the base driver's `/odom`, nothing
/// else. Nothing can be learned, so nothing shows as a correction.
#[test]
fn a_skid_steer_with_odometry_only() {
    let r = runs(
        &Twin {
            odoms: vec![wheel_odom("/odom")],
            ..Default::default()
        },
        false,
    );
    let c = &r.summary["controller"];
    for key in ["separation_factor", "turn_factor"] {
        let f = &c[key];
        assert!(
            f.is_null() || f.as_f64().is_some_and(|f| (f - 1.0).abs() < 0.02),
            "{key} = {f} where nothing was learned: {}",
            r.said
        );
    }
}

/// A filter's fused odometry (robot_localization, a vendor's fusion node).
const fn filter_odom(topic: &'static str, frame: &'static str) -> Odom {
    Odom {
        topic,
        frame,
        lateral: 0.05,
        yaw_scale: 1.0,
    }
}

/// A TurtleBot 3: `/joint_states` with positions only, `/odom`, `/imu`.
#[test]
fn a_turtlebot3_with_joint_positions_only() {
    let r = runs(
        &Twin {
            odoms: vec![wheel_odom("/odom")],
            joints: Some(Joints {
                left: "wheel_left_joint",
                right: "wheel_right_joint",
                velocity: false,
                position: true,
                wrapped: false,
                jitter: 0.002,
            }),
            imu: Some("/imu"),
            gyro_scale: 1.0,
            ..Default::default()
        },
        true,
    );
    assert!(
        r.said
            .contains("/joint_states (sensor_msgs/JointState) -> wheels.csv"),
        "{}",
        r.said
    );
    assert!(r.said.contains("from its joint positions"), "{}", r.said);
    // No URDF: the tread speeds are made with an assumed wheel radius
    // (0.1 m, three times the TurtleBot 3's), so the radius multipliers are
    // relative to it. The controller file names that radius, so that
    // applied as written the wheels' radius is their product (the 0.033 m
    // of the recording: fuse's turtlebot3.bag, docs/figures/robots.md).
    let yaml = std::fs::read_to_string(r._dir.path().join("ddc.yaml")).unwrap();
    let value = |key: &str| -> f64 {
        let line = yaml
            .lines()
            .find(|l| l.trim_start().starts_with(key))
            .unwrap_or_else(|| panic!("no {key} in\n{yaml}"));
        line.split(':').nth(1).unwrap().trim().parse().unwrap()
    };
    let radius = value("wheel_radius:") * value("left_wheel_radius_multiplier:");
    assert!((radius - WHEEL_R).abs() < 0.002, "{radius}\n{yaml}");
    assert!(yaml.contains("assumed"), "{yaml}");
}

/// A TurtleBot 4 (Create 3 base): the URDF's wheels on prismatic
/// wheel-drop joints, `/odom`, `/imu`.
#[test]
fn a_turtlebot4_with_wheel_drops_in_its_urdf() {
    const URDF: &str = r#"<robot name="tb4">
  <link name="base_footprint"/><link name="base_link"/><link name="wheel_drop_left"/><link name="wheel_drop_right"/>
  <link name="left_wheel"/><link name="right_wheel"/>
  <joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/><origin xyz="0 0 0.0061"/></joint>
  <joint name="wheel_drop_left_joint" type="prismatic"><parent link="base_link"/><child link="wheel_drop_left"/><origin xyz="0 0.1165 0.0402"/></joint>
  <joint name="wheel_drop_right_joint" type="prismatic"><parent link="base_link"/><child link="wheel_drop_right"/><origin xyz="0 -0.1165 0.0402"/></joint>
  <joint name="left_wheel_joint" type="continuous"><parent link="wheel_drop_left"/><child link="left_wheel"/><origin xyz="0 0 0" rpy="-1.5708 0 0"/></joint>
  <joint name="right_wheel_joint" type="continuous"><parent link="wheel_drop_right"/><child link="right_wheel"/><origin xyz="0 0 0" rpy="-1.5708 0 0"/></joint>
</robot>"#;
    let r = runs(
        &Twin {
            odoms: vec![wheel_odom("/odom")],
            imu: Some("/imu"),
            gyro_scale: 1.0,
            urdf: Some(URDF),
            ..Default::default()
        },
        false,
    );
    assert!(
        r.said.contains("decided: separation S = 0.233 m"),
        "{}",
        r.said
    );
    assert_eq!(r.summary["controller"]["separation_source"], "urdf");
}

/// A Clearpath Jackal: the drive controller's odometry beside
/// robot_localization's `/odometry/filtered`, `/imu/data`.
#[test]
fn a_jackal_with_a_filtered_odometry_beside_the_controllers() {
    let r = runs(
        &Twin {
            odoms: vec![
                wheel_odom("/jackal_velocity_controller/odom"),
                filter_odom("/odometry/filtered", "odom"),
            ],
            imu: Some("/imu/data"),
            gyro_scale: 1.0,
            ..Default::default()
        },
        true,
    );
    assert!(
        r.said
            .contains("decided: wheels from /jackal_velocity_controller/odom"),
        "{}",
        r.said
    );
}

/// A two-wheel base whose driver's `/odom` sits beside another node's
/// fused `/combined_odom` (frame `combined_odom`).
#[test]
fn a_two_wheel_base_with_a_combined_odometry() {
    let r = runs(
        &Twin {
            odoms: vec![
                wheel_odom("/odom"),
                filter_odom("/combined_odom", "combined_odom"),
            ],
            imu: Some("/imu"),
            gyro_scale: 1.0,
            ..Default::default()
        },
        true,
    );
    assert!(r.said.contains("decided: wheels from /odom"), "{}", r.said);
}

/// A tracked vehicle: the treads' odometry turns it more than the gyro
/// sees (the tracks slip), `/odom` and `/imu/data`.
#[test]
fn a_tracked_vehicle_whose_gyro_turns_less_than_its_treads() {
    runs(
        &Twin {
            odoms: vec![wheel_odom("/odom")],
            imu: Some("/imu/data"),
            gyro_scale: 0.7,
            ..Default::default()
        },
        false,
    );
}
