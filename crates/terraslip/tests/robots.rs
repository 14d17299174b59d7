//! Other robots' recordings, as a new user runs them: no topics file.
//! Each kind is a small synthetic twin with that robot's topic layout
//! (docs/figures/robots.md lists them with their sources): `import`,
//! `estimate --mcap` and `report` succeed, `calibrate --ros2-params` where
//! a pose reference exists, and nothing is written beside the bag.
#![cfg(feature = "ros2")]

use std::path::{Path, PathBuf};

use assert_cmd::Command;

mod twin;
use twin::{filter_odom, wheel_odom, write_twin, Joints, Twin, TB4_URDF, WHEEL_R};

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
    // No URDF: the wheel radius and separation are the base driver's, read
    // off its `/odom` twist against the joints' rates (a default 0.1 m,
    // three times the TurtleBot 3's, left the filter starting far off: on
    // fuse's turtlebot3.bag its spread ended 0.39 m against calibrate's
    // 0.285 m, docs/figures/robots.md).
    let radius = r
        .said
        .split("decided: wheel radius ")
        .nth(1)
        .and_then(|l| l.split(" m (the base driver's").next())
        .and_then(|x| x.parse::<f64>().ok())
        .unwrap_or_else(|| panic!("no radius from the odometry in\n{}", r.said));
    assert!((radius / WHEEL_R - 1.0).abs() < 0.02, "{radius}");
    let rec = &r.summary["recommendation"];
    let spread = rec["spread_m"]["value"].as_f64().unwrap();
    assert!((spread - 0.3).abs() < 0.015, "spread {spread}: {}", r.said);
    for side in ["alpha_l", "alpha_r"] {
        let a = rec[side]["value"].as_f64().unwrap();
        assert!((a - 1.0).abs() < 0.02, "{side} {a}");
    }
    // The controller file names the radius its multipliers are relative
    // to, so that applied as written the wheels' radius is their product
    // (the 0.033 m of the recording).
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
    let r = runs(
        &Twin {
            odoms: vec![wheel_odom("/odom")],
            imu: Some("/imu"),
            gyro_scale: 1.0,
            urdf: Some(TB4_URDF),
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
    // An Odometry as the pose reference: its kind is not told by its type,
    // and the line says how to state it.
    assert!(
        r.said.contains("of a kind not stated")
            && r.said.contains("[meta] pose_reference = \"localiser\""),
        "{}",
        r.said
    );
    assert!(r.summary["pose_noise"]["reference"].is_null());
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
