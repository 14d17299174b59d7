//! Topic choice from evidence and wheels from whatever the robot
//! publishes: a drive controller's odometry beside a filter's, JointState
//! positions with no velocities (wrapped, repeated and jittered stamps),
//! and a JointState that gives nothing falling back to the bag's odometry.

use std::f64::consts::PI;
use std::path::Path;

use terraslip_ros2::defs::definition_of;
use terraslip_ros2::msg::{build, CdrWriter};
use terraslip_ros2::out::EstimateMcap;
use terraslip_ros2::{import, ImportReport, TopicsConfig};

const T0: u64 = 1_700_000_000_000_000_000;
const HZ: u64 = 20;
const R: f64 = 0.033;
const SEP: f64 = 0.3;

/// Forward speed (m/s) and yaw rate (rad/s) at `t`.
fn motion(t: f64) -> (f64, f64) {
    (
        0.5 + 0.2 * (t / 3.0).sin(),
        if t % 10.0 > 6.0 { 0.5 } else { 0.0 },
    )
}

/// An odometry topic: name, frame, lateral velocity per yaw rate, and
/// whether it behaves as a filter fusing fixes (every 2 s its pose
/// covariance shrinks and its pose jumps by a correction).
type Odom = (&'static str, &'static str, f64, bool);

#[derive(Clone, Copy, Default)]
struct Js {
    names: [&'static str; 2],
    velocity: bool,
    position: bool,
    wrapped: bool,
    jitter_s: f64,
}

fn write(p: &Path, odoms: &[Odom], js: Option<Js>, poses: &[(&str, u64)]) {
    let mut m = EstimateMcap::create(p).unwrap();
    let mut ch = |topic: &str, ty: &str| m_channel(&mut m, topic, ty);
    let oc: Vec<u16> = odoms
        .iter()
        .map(|o| ch(o.0, "nav_msgs/msg/Odometry"))
        .collect();
    let jc = js.map(|_| ch("/joint_states", "sensor_msgs/msg/JointState"));
    let pc: Vec<u16> = poses
        .iter()
        .map(|p| ch(p.0, "geometry_msgs/msg/PoseStamped"))
        .collect();
    let (mut ql, mut qr, mut last) = (3.0f64, -1.0f64, 0u64);
    // The wheels' integral (x, y, yaw) and a filter's correction of it.
    let (mut x, mut y, mut yaw, mut fix) = (0.0f64, 0.0f64, 0.0f64, [0.0f64; 2]);
    let dt = 1.0 / HZ as f64;
    for i in 0..60 * HZ {
        let t = i as f64 * dt;
        let ns = T0 + i * (1_000_000_000 / HZ);
        let (v, wz) = motion(t);
        ql += dt * (v - wz * SEP / 2.0) / R;
        qr += dt * (v + wz * SEP / 2.0) / R;
        x += dt * v * yaw.cos();
        y += dt * v * yaw.sin();
        yaw += dt * wz;
        if i % (2 * HZ) == 0 && i > 0 {
            fix = [0.3 * (t * 1.7).sin(), 0.3 * (t * 2.3).cos()];
        }
        for (o, &c) in odoms.iter().zip(&oc) {
            let (px, py, var) = if o.3 {
                (x + fix[0], y + fix[1], 0.01 + 0.005 * (t % 2.0))
            } else {
                (x, y, 0.01 + 0.005 * t)
            };
            let twist = [v, o.2 * wz, 0.0, 0.0, 0.0, wz];
            let msg = build::odometry(ns, o.1, [px, py, yaw], var, twist, 0.0);
            m.write(c, ns, &msg).unwrap();
        }
        if let (Some(j), Some(c)) = (js, jc) {
            let jit = (j.jitter_s * 1e9 * (((i * 7919) % 13) as f64 / 6.0 - 1.0)) as i64;
            let stamp = if i % 7 == 3 {
                last
            } else {
                (ns as i64 + jit) as u64
            };
            last = stamp;
            let wrap = |a: f64| {
                if j.wrapped {
                    (a + PI).rem_euclid(2.0 * PI) - PI
                } else {
                    a
                }
            };
            let position = [wrap(ql), wrap(qr)];
            let velocity = [(v - wz * SEP / 2.0) / R, (v + wz * SEP / 2.0) / R];
            let msg = build::joint_state(
                stamp,
                &j.names,
                if j.position { &position } else { &[] },
                if j.velocity { &velocity } else { &[] },
            );
            m.write(c, ns, &msg).unwrap();
        }
        for (p, &c) in poses.iter().zip(&pc) {
            if i % p.1 == 0 {
                let mut w = CdrWriter::new();
                w.header(ns, "map");
                for c in [t, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
                    w.f64(c);
                }
                m.write(c, ns, &w.finish()).unwrap();
            }
        }
    }
    m.finish().unwrap();
}

fn m_channel(m: &mut EstimateMcap, topic: &str, ty: &str) -> u16 {
    m.channel(topic, ty, &definition_of(ty).unwrap()).unwrap()
}

fn imported(
    odoms: &[Odom],
    js: Option<Js>,
    poses: &[(&str, u64)],
) -> Result<(terraslip_io::DriveLog, ImportReport), String> {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("b.mcap");
    write(&p, odoms, js, poses);
    import(&p, &TopicsConfig::default(), None).map_err(|e| e.to_string())
}

/// The tread speeds of the log against the true ones, |error| of each row
/// (the worse side), m/s, after the first second.
fn speed_errors(log: &terraslip_io::DriveLog) -> Vec<f64> {
    log.wheels
        .iter()
        .filter(|w| w.t > 1.0)
        .map(|w| {
            let (v, wz) = motion(w.t);
            let e = |a: f64, b: f64| (a - b).abs();
            e(w.v_left, v - wz * SEP / 2.0).max(e(w.v_right, v + wz * SEP / 2.0))
        })
        .collect()
}

fn worst_speed_error(log: &terraslip_io::DriveLog) -> f64 {
    speed_errors(log).into_iter().fold(0.0, f64::max)
}

#[test]
fn a_drive_controllers_odometry_is_chosen_over_a_filters() {
    for (filter, why) in [
        (
            ("/combined_odom", "combined_odom", 0.0, false),
            "combined_odom",
        ),
        (("/odometry/filtered", "odom", 0.0, false), "filtered"),
        (("/fused", "odom", 0.3, false), "lateral"),
    ] {
        let (log, report) = imported(&[("/odom", "odom", 0.0, false), filter], None, &[]).unwrap();
        let text = report.to_text();
        assert!(
            text.contains("/odom (nav_msgs/Odometry) -> wheels.csv"),
            "{text}"
        );
        let line = text
            .lines()
            .find(|l| l.starts_with("decided: wheels from /odom"))
            .unwrap_or_else(|| panic!("{text}"));
        assert!(line.contains(filter.0) && line.contains(why), "{line}");
        assert!(
            line.contains(&format!("`[wheels] topic = \"{}\"`", filter.0)),
            "{line}"
        );
        assert!(!log.wheels.is_empty());
    }
}

#[test]
fn streams_the_evidence_cannot_settle_are_all_listed_at_once() {
    let e = imported(
        &[
            ("/odom_a", "odom", 0.0, false),
            ("/odom_b", "odom", 0.0, false),
        ],
        None,
        &[("/ref_a", 1), ("/ref_b", 1)],
    )
    .unwrap_err();
    for line in [
        "`[wheels] topic = \"/odom_a\"`",
        "`[wheels] topic = \"/odom_b\"`",
        "`[pose] topic = \"/ref_a\"`",
        "`[pose] topic = \"/ref_b\"`",
    ] {
        assert!(e.contains(line), "{e}");
    }
    // A pose topic with a handful of messages (a goal) is not a reference.
    let (_, report) = imported(
        &[("/odom", "odom", 0.0, false)],
        None,
        &[("/ref", 1), ("/goal_pose", 400)],
    )
    .unwrap();
    let text = report.to_text();
    assert!(
        text.contains("/ref (geometry_msgs/PoseStamped) -> pose.csv"),
        "{text}"
    );
    assert!(text.contains("decided: pose from /ref"), "{text}");
}

#[test]
fn a_filters_odometry_is_not_the_pose_reference_when_another_is_there() {
    let js = Js {
        names: ["left_wheel_joint", "right_wheel_joint"],
        velocity: true,
        ..Default::default()
    };
    let filtered = ("/odometry/filtered", "odom", 0.0, false);
    let truth = ("/ground_truth/odom", "world", 0.0, false);
    for (odoms, wheels) in [
        (vec![filtered, truth], Some(js)),
        (vec![("/odom", "odom", 0.0, false), filtered, truth], None),
    ] {
        let (log, report) = imported(&odoms, wheels, &[]).unwrap();
        let text = report.to_text();
        assert!(
            text.contains("/ground_truth/odom (nav_msgs/Odometry) -> pose.csv"),
            "{text}"
        );
        let line = text
            .lines()
            .find(|l| l.starts_with("decided: pose from /ground_truth/odom"))
            .unwrap_or_else(|| panic!("{text}"));
        assert!(
            line.contains("/odometry/filtered") && line.contains("filtered"),
            "{line}"
        );
        assert!(
            line.contains("`[pose] topic = \"/odometry/filtered\"`"),
            "{line}"
        );
        assert!(!log.pose.is_empty());
    }
}

#[test]
fn joint_positions_are_differentiated_when_there_are_no_velocities() {
    for js in [
        Js {
            names: ["wheel_left_joint", "wheel_right_joint"],
            position: true,
            ..Default::default()
        },
        Js {
            names: ["wheel_left_joint", "wheel_right_joint"],
            position: true,
            wrapped: true,
            ..Default::default()
        },
        Js {
            names: ["wheel_left_joint", "wheel_right_joint"],
            position: true,
            jitter_s: 0.004,
            ..Default::default()
        },
    ] {
        let (log, report) = imported(&[], Some(js), &[]).unwrap();
        let text = report.to_text();
        assert!(log.wheels.len() > 900, "{text}");
        // The default wheel radius 0.1 m against the true 0.033 m.
        let mut scaled = log.clone();
        for w in &mut scaled.wheels {
            w.v_left *= R / 0.1;
            w.v_right *= R / 0.1;
        }
        // Within the span's lag but at the steps into and out of a turn.
        let mut errs = speed_errors(&scaled);
        errs.sort_by(f64::total_cmp);
        let p90 = errs[errs.len() * 9 / 10];
        assert!(p90 < 0.015, "tread speed error p90 {p90} m/s: {text}");
        assert!(errs[errs.len() - 1] < 0.1, "{text}");
        assert!(text.contains("positions"), "{text}");
    }
}

#[test]
fn a_joint_state_that_gives_no_tread_speeds_falls_back_to_the_odometry() {
    for js in [
        // Neither velocities nor positions.
        Js {
            names: ["wheel_left_joint", "wheel_right_joint"],
            ..Default::default()
        },
        // No joint a wheel.
        Js {
            names: ["arm_1", "arm_2"],
            velocity: true,
            ..Default::default()
        },
    ] {
        let (log, report) = imported(&[("/odom", "odom", 0.0, false)], Some(js), &[]).unwrap();
        let text = report.to_text();
        assert!(
            text.contains("/odom (nav_msgs/Odometry) -> wheels.csv"),
            "{text}"
        );
        let line = text
            .lines()
            .find(|l| l.starts_with("decided: wheels from /odom"))
            .unwrap_or_else(|| panic!("{text}"));
        assert!(line.contains("/joint_states"), "{line}");
        assert!(worst_speed_error(&log) < 0.3, "{text}");
    }
}

/// A filter's odometry with an innocent name and frame (`/odom2`, `odom`,
/// or even `/odom`) told apart by its data: its pose covariance shrinks and
/// its pose jumps at the fixes, where the wheels' grows and stays smooth.
#[test]
fn a_filters_odometry_is_told_by_its_covariance_and_its_jumps() {
    for (wheels, filter) in [("/odom", "/odom2"), ("/odom2", "/odom")] {
        let (log, report) = imported(
            &[(filter, "odom", 0.0, true), (wheels, "odom", 0.0, false)],
            None,
            &[],
        )
        .unwrap();
        let text = report.to_text();
        assert!(
            text.contains(&format!("{wheels} (nav_msgs/Odometry) -> wheels.csv")),
            "{text}"
        );
        let line = text
            .lines()
            .find(|l| l.starts_with(&format!("decided: wheels from {wheels} ")))
            .unwrap_or_else(|| panic!("{text}"));
        assert!(
            line.contains(filter) && line.contains("covariance") && line.contains("jump"),
            "{line}"
        );
        assert!(worst_speed_error(&log) < 0.3, "{text}");
        assert!(
            report.warnings.iter().all(|w| !w.contains("filter")),
            "{text}"
        );
    }
}

/// The only wheel-source candidate, behaving as a filter, is taken with a
/// warning that names the evidence; a wheel odometry alone gets none.
#[test]
fn a_filters_odometry_taken_as_the_only_wheel_source_is_warned_about() {
    // Alone, or the next source after a JointState that gives nothing.
    let empty = Js {
        names: ["wheel_left_joint", "wheel_right_joint"],
        ..Default::default()
    };
    for js in [None, Some(empty)] {
        let (log, report) = imported(&[("/odom2", "odom", 0.0, true)], js, &[]).unwrap();
        let text = report.to_text();
        assert!(!log.wheels.is_empty(), "{text}");
        let w = report
            .warnings
            .iter()
            .find(|w| w.contains("/odom2") && w.contains("filter"))
            .unwrap_or_else(|| panic!("{text}"));
        assert!(w.contains("covariance") && w.contains("jump"), "{w}");
    }
    let (_, report) = imported(&[("/odom2", "odom", 0.0, false)], None, &[]).unwrap();
    assert!(
        report.warnings.iter().all(|w| !w.contains("filter")),
        "{}",
        report.to_text()
    );
}
