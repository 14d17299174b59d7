//! A bag is read as a log by every command: messages that cannot be
//! physical are skipped and named (or refused with `--strict`), the import
//! writes only logs its own reader accepts, and `report` draws an estimate
//! made from a bag with no extra options.
#![cfg(feature = "ros2")]

use std::path::{Path, PathBuf};
use std::process::Output;

use assert_cmd::Command;
use terraslip_ros2::defs::definition_of;
use terraslip_ros2::msg::CdrWriter;
use terraslip_ros2::out::EstimateMcap;

const T0: u64 = 1_700_000_000_000_000_000;

/// The bad messages of [`write_bag`]: (odometry message number, what is wrong).
const BAD: [(u64, &str); 4] = [
    (100, "linear.x = NaN"),
    (150, "angular.z = +inf"),
    (200, "linear.x = 1e308 m/s"),
    (250, "stamp 1 s back"),
];

/// 20 s on a circle: 400 nav_msgs/Odometry messages at 20 Hz (1 m/s,
/// 0.2 rad/s) with the four bad ones of [`BAD`], and a PoseStamped
/// reference at 5 Hz. Returns the bag index of each bad message.
fn write_bag(p: &Path) -> Vec<u64> {
    let mut m = EstimateMcap::create(p).unwrap();
    let odom_ty = "nav_msgs/msg/Odometry";
    let odom = m
        .channel("/odom", odom_ty, &definition_of(odom_ty).unwrap())
        .unwrap();
    let pose_ty = "geometry_msgs/msg/PoseStamped";
    let pose = m
        .channel("/ref", pose_ty, &definition_of(pose_ty).unwrap())
        .unwrap();
    let mut index = 0;
    let mut bad_index = Vec::new();
    for k in 0..400u64 {
        let t = k as f64 * 0.05;
        let ns = T0 + k * 50_000_000;
        let yaw = 0.2 * t;
        let (x, y) = (5.0 * yaw.sin(), 5.0 * (1.0 - yaw.cos()));
        let (sz, cz) = (yaw / 2.0).sin_cos();
        let (mut vx, mut wz, mut stamp) = (1.0, 0.2, ns);
        match k {
            100 => vx = f64::NAN,
            150 => wz = f64::INFINITY,
            200 => vx = 1e308,
            250 => stamp = ns - 1_000_000_000,
            _ => {}
        }
        if BAD.iter().any(|(b, _)| *b == k) {
            bad_index.push(index);
        }
        let mut w = CdrWriter::new();
        w.header(stamp, "odom");
        w.string("base_link");
        for v in [x, y, 0.0, 0.0, 0.0, sz, cz] {
            w.f64(v);
        }
        for _ in 0..36 {
            w.f64(0.0);
        }
        for v in [vx, 0.0, 0.0, 0.0, 0.0, wz] {
            w.f64(v);
        }
        for _ in 0..36 {
            w.f64(0.0);
        }
        m.write(odom, ns, &w.finish()).unwrap();
        index += 1;
        if k % 4 == 0 {
            let mut w = CdrWriter::new();
            w.header(ns, "map");
            for v in [x, y, 0.0, 0.0, 0.0, sz, cz] {
                w.f64(v);
            }
            m.write(pose, ns, &w.finish()).unwrap();
            index += 1;
        }
    }
    m.finish().unwrap();
    bad_index
}

fn run(args: &[&str]) -> Output {
    Command::cargo_bin("terraslip")
        .unwrap()
        .args(args)
        .output()
        .unwrap()
}

fn ok(args: &[&str]) -> String {
    let o = run(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{args:?}: {err}");
    err
}

struct Bag {
    _tmp: tempfile::TempDir,
    dir: PathBuf,
    bag: String,
    topics: String,
    bad: Vec<u64>,
}

fn bag() -> Bag {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().to_path_buf();
    let bag = dir.join("evil.mcap");
    let bad = write_bag(&bag);
    let topics = dir.join("topics.toml");
    std::fs::write(
        &topics,
        "[wheels]\ntopic = \"/odom\"\nseparation = 0.5\n[meta]\ntrack_width = 0.5\n",
    )
    .unwrap();
    Bag {
        _tmp: tmp,
        bag: bag.to_str().unwrap().into(),
        topics: topics.to_str().unwrap().into(),
        dir,
        bad,
    }
}

#[test]
fn import_skips_and_names_unphysical_messages_and_writes_a_readable_log() {
    let b = bag();
    let before = std::fs::read(&b.bag).unwrap();
    let log = b.dir.join("log");
    let out = run(&[
        "import",
        &b.bag,
        "--topics",
        &b.topics,
        "--out",
        log.to_str().unwrap(),
        "--json",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("/odom (nav_msgs/Odometry) -> wheels.csv: 396 of 400 messages"),
        "{err}"
    );
    assert!(
        err.contains("warning: /odom: 4 messages skipped as not physical"),
        "{err}"
    );
    for (index, what) in b.bad.iter().zip([
        "v_left = NaN is not finite",
        "is not finite",
        "outside the physical range",
        "its stamp goes back",
    ]) {
        let named = format!("message {index} at t = ");
        let at = err.find(&named).unwrap_or_else(|| panic!("{named}: {err}"));
        assert!(
            err[at..].split(';').next().unwrap().contains(what),
            "{what}: {err}"
        );
    }
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["skipped"].as_array().unwrap().len(), 4);
    assert_eq!(report["skipped"][3]["index"], b.bad[3]);
    // The log reads back: no value out of range, time never going back.
    let read = terraslip_io::DriveLog::read(&log).unwrap();
    assert_eq!(read.wheels.len(), 396);
    assert!(read.wheels.windows(2).all(|w| w[0].t < w[1].t));
    assert_eq!(
        std::fs::read(&b.bag).unwrap(),
        before,
        "the bag is unchanged"
    );
}

#[test]
fn strict_refuses_the_first_unphysical_message_on_every_path() {
    let b = bag();
    let (log, est, params) = (b.dir.join("log"), b.dir.join("est"), b.dir.join("p.json"));
    for args in [
        vec!["import", &b.bag, "--out", log.to_str().unwrap()],
        vec!["estimate", &b.bag, "--out", est.to_str().unwrap()],
        vec!["calibrate", &b.bag, "--out", params.to_str().unwrap()],
    ] {
        let mut args = args;
        args.extend(["--topics", &b.topics, "--strict"]);
        let o = run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains(&format!(
                "topic /odom (nav_msgs/msg/Odometry), message {}",
                b.bad[0]
            )) && err.contains("t = 5.000000 s")
                && err.contains("refused (--strict)"),
            "{args:?}: {err}"
        );
        assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    }
    assert!(!log.exists() && !est.exists() && !params.exists());
}

#[test]
fn estimate_and_report_on_a_bag_need_no_extra_options() {
    let b = bag();
    let est = b.dir.join("est");
    let err = ok(&[
        "estimate",
        &b.bag,
        "--topics",
        &b.topics,
        "--out",
        est.to_str().unwrap(),
    ]);
    assert!(err.contains("4 messages skipped as not physical"), "{err}");
    assert!(!err.contains("terraslip-bag-"), "no temporary path: {err}");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(est.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["log"], b.bag.as_str());
    assert_eq!(
        summary["icr_holds_at"],
        "straight line (tread speed difference 0)"
    );
    // report reads the bag again with the topics the estimate used.
    let o = run(&["report", est.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("warning"), "{err}");
    let page = std::fs::read_to_string(est.join("report.html")).unwrap();
    assert!(
        page.contains("Final ICRs (straight-line values of the turn law"),
        "{page}"
    );
    let track = std::fs::read_to_string(est.join("track.svg")).unwrap();
    assert!(
        track.contains("pose reference"),
        "the bag's pose was read: {track}"
    );
}

#[test]
fn calibrate_on_a_bag_without_a_pose_names_the_bag_and_its_topics() {
    let b = bag();
    let topics = b.dir.join("no-pose.toml");
    std::fs::write(
        &topics,
        "[wheels]\ntopic = \"/odom\"\nseparation = 0.5\n[pose]\ntopic = \"\"\n",
    )
    .unwrap();
    let o = run(&[
        "calibrate",
        &b.bag,
        "--topics",
        topics.to_str().unwrap(),
        "--out",
        b.dir.join("p.json").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("{}: no pose reference among its topics (", b.bag))
            && err.contains("/ref (geometry_msgs/msg/PoseStamped)")
            && !err.contains("pose.csv"),
        "{err}"
    );
}
