//! Recordings played message by message through the node's live path
//! (candidate topics held over the warm-up, the choice, the live import,
//! the warm-up and the live estimator; no DDS) with no topics file and no
//! other setting give the odometry `estimate` gives of the same recording
//! with no topics file: the node decides the topics, the scale, the IMU's
//! mounting and the heading as `import` does, with its code.
#![cfg(feature = "ros2")]

use std::path::Path;

use terraslip::bag::{import_deciding, Topics};
use terraslip::config::EstimatorConfig;
use terraslip::live_streams::{start_width, LiveStreams};
use terraslip::pipeline::warmup::WarmUp;
use terraslip::pipeline::{run, EstimateRow, TerrainEvidence, DECISION_SPAN};
use terraslip_ros2::import::revisit::Revision;
use terraslip_ros2::import::LiveRow;
use terraslip_ros2::{Bag, TopicsConfig};

mod twin;
use twin::{motion, wheel_odom, write_twin, Joints, Odom, Twin, HZ, TB4_URDF};

/// The reorder lag the node waits by default, s.
const LAG: f64 = 0.3;

/// What the live path said it decided, and its odometry's distance from
/// the offline estimate's, row for row: median and p99, m.
struct Compared {
    decided: Vec<String>,
    median: f64,
    p99: f64,
    /// Decisions made again: live (as the node made them) and offline (the
    /// import's `decided:` lines).
    revised_live: Vec<Revision>,
    revised_offline: Vec<String>,
    /// The offline rows.
    offline: Vec<EstimateRow>,
}

/// Hands the estimator the rows `made`, building it once the choice is
/// made, as the node does.
fn feed<'a>(
    made: Vec<LiveRow>,
    cfg: &'a EstimatorConfig,
    streams: &mut LiveStreams,
    node: &mut Option<WarmUp<'a>>,
    rows: &mut Vec<EstimateRow>,
    decided: &mut Vec<String>,
) {
    if let Some(s) = streams.take_settled() {
        decided.extend(s.report.decisions.iter().cloned());
        decided.extend(s.report.streams.iter().map(|r| r.topic.clone()));
        let width = start_width(None, &s.topics, cfg.init.default_track_width);
        *node =
            Some(WarmUp::new("graph", cfg, width, None, LAG, DECISION_SPAN, None, None).unwrap());
    }
    if made.is_empty() {
        return;
    }
    let node = node.as_mut().expect("rows come once the choice is made");
    for r in made {
        node.push(r.into(), rows).unwrap();
    }
}

fn live_against_offline(path: &Path) -> Compared {
    let topics = TopicsConfig::default();
    let cfg = EstimatorConfig::default();
    // As `estimate` imports a bag given no topics file.
    let out = tempfile::tempdir().unwrap();
    let (log, report) = import_deciding(path, &Topics::ByType, &topics, out.path()).unwrap();
    let offline = run(&log, &cfg, &TerrainEvidence::None, None).unwrap();

    let mut bag = Bag::open(path).unwrap();
    let mut messages = Vec::new();
    bag.for_each(&|_| true, &mut |_, m| {
        messages.push((m.topic, m.recv_ns, m.data.to_vec()));
        Ok(())
    })
    .unwrap();
    let window = WarmUp::window(DECISION_SPAN, LAG);
    let mut streams = LiveStreams::new("graph", bag.topics.clone(), &topics, true, window).unwrap();
    let mut rows: Vec<EstimateRow> = Vec::new();
    let mut node: Option<WarmUp> = None;
    let mut decided = Vec::new();
    let mut revised_live = Vec::new();
    for (topic, recv_ns, data) in messages {
        let mut made = streams.message(topic, recv_ns, &data).unwrap();
        if streams.due() {
            made = streams.decide().unwrap();
        }
        feed(made, &cfg, &mut streams, &mut node, &mut rows, &mut decided);
        revised_live.extend(streams.take_revisions());
    }
    let made = streams.decide().unwrap();
    feed(made, &cfg, &mut streams, &mut node, &mut rows, &mut decided);
    revised_live.extend(streams.take_revisions());
    node.as_mut().expect("decided").flush(&mut rows).unwrap();

    // Row for row on the import's clock (the two origins differ by whole
    // seconds).
    let shift = (streams.origin_ns().unwrap() as f64 - report.time_origin_ns as f64) * 1e-9;
    assert_eq!(rows.len(), offline.rows.len(), "{decided:?}");
    let (median, p99) = terraslip::testkit::live_against_offline(&rows, &offline.rows, shift);
    Compared {
        decided,
        median,
        p99,
        revised_live,
        revised_offline: report.revisited,
        offline: offline.rows,
    }
}

fn assert_close(c: &Compared) {
    eprintln!(
        "live against offline: median {:.6} m, p99 {:.6} m; decided {:?}",
        c.median, c.p99, c.decided
    );
    assert!(
        c.median <= 0.01 && c.p99 <= 0.10,
        "median {} m, p99 {} m",
        c.median,
        c.p99
    );
}

/// The Husky recording (395 s: the warm-up ends before it does), played
/// with no flags: its IMU is mounted on its side (found from gravity) and
/// its heading disagrees with the GNSS course (left out), as `estimate`
/// decides.
#[test]
fn the_husky_recording_played_with_no_flags_gives_its_estimate() {
    let c = live_against_offline(&terraslip_io::shared::repo_data("husky_test1"));
    assert!(
        c.decided
            .iter()
            .any(|d| d.contains("mounting from the data")),
        "{:?}",
        c.decided
    );
    assert!(
        c.decided.iter().any(|d| d.contains("heading left out")),
        "{:?}",
        c.decided
    );
    assert_close(&c);
}

/// Two odometries whose names tell nothing (neither a filter's nor a
/// drive controller's): only the data says which is the wheels' (the
/// other reports a lateral velocity a wheeled base's odometry never does).
#[test]
fn a_twin_whose_odometries_only_the_data_tells_apart() {
    let c = twin(&Twin {
        odoms: vec![
            Odom {
                lateral: 0.4,
                ..wheel_odom("/robot/odom_local")
            },
            wheel_odom("/robot/odom"),
        ],
        imu: Some("/imu/data"),
        gyro_scale: 1.0,
        ..Default::default()
    });
    assert!(
        c.decided
            .iter()
            .any(|d| d.starts_with("wheels from /robot/odom (")),
        "{:?}",
        c.decided
    );
    assert_close(&c);
}

/// The twin `k` played with no flags, against its estimate.
fn twin(k: &Twin) -> Compared {
    let d = tempfile::tempdir().unwrap();
    let bag = d.path().join("drive.mcap");
    write_twin(&bag, k);
    live_against_offline(&bag)
}

/// A TurtleBot 4: the scale comes from the URDF on `/robot_description`.
#[test]
fn a_twin_whose_scale_is_in_its_urdf() {
    let c = twin(&Twin {
        odoms: vec![wheel_odom("/odom")],
        imu: Some("/imu"),
        gyro_scale: 1.0,
        urdf: Some(TB4_URDF),
        ..Default::default()
    });
    assert!(
        c.decided
            .iter()
            .any(|d| d.starts_with("separation S = 0.233 m")),
        "{:?}",
        c.decided
    );
    assert_close(&c);
}

/// Joint states that carry neither rates nor positions: the wheels come
/// from the odometry, as `import` falls back.
#[test]
fn a_twin_whose_joint_states_carry_no_tread_speeds() {
    let c = twin(&Twin {
        odoms: vec![wheel_odom("/odom")],
        joints: Some(Joints {
            left: "wheel_left_joint",
            right: "wheel_right_joint",
            velocity: false,
            position: false,
            wrapped: false,
            jitter: 0.0,
        }),
        imu: Some("/imu"),
        gyro_scale: 1.0,
        ..Default::default()
    });
    assert!(
        c.decided
            .iter()
            .any(|d| d.starts_with("wheels from /odom (") && d.contains("no tread speeds")),
        "{:?}",
        c.decided
    );
    assert_close(&c);
}

/// The stamp (s since the epoch, as written) a `decided:` line of a
/// decision made again names.
fn stamp_of(line: &str) -> &str {
    let rest = line.split("at stamp ").nth(1).expect(line);
    rest.split(' ').next().unwrap_or_default()
}

/// The true heading's change (rad) between `a` and `b` s of the twin's
/// clock, as the twin integrates it.
fn true_turn(a: f64, b: f64) -> f64 {
    let dt = 1.0 / HZ as f64;
    (0..)
        .map(|i| i as f64 * dt)
        .skip_while(|t| *t < a)
        .take_while(|t| *t < b)
        .map(|t| motion(t).1 * dt)
        .sum()
}

/// The estimate's heading change (rad, unwrapped) between `a` and `b` s.
fn estimated_turn(rows: &[EstimateRow], a: f64, b: f64) -> f64 {
    let inside: Vec<_> = rows.iter().filter(|r| r.t >= a && r.t < b).collect();
    inside
        .windows(2)
        .map(|w| {
            let d = w[1].yaw - w[0].yaw;
            (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
        })
        .sum()
}

/// A recording longer than the warm-up whose IMU is remounted (laid on its
/// side) after it: over the first window gravity is upright, so both the
/// node and `estimate` decide an upright mounting from it; the later
/// windows contradict it (gravity along the IMU's y), and both make the
/// mounting again from the same window, from the same stamp on, and
/// estimate the turns that follow as the twin drove them.
#[test]
fn a_twin_whose_imu_is_remounted_after_the_window() {
    let window = WarmUp::window(DECISION_SPAN, LAG);
    let d = tempfile::tempdir().unwrap();
    let bag = d.path().join("drive.mcap");
    write_twin(
        &bag,
        &Twin {
            odoms: vec![wheel_odom("/odom")],
            imu: Some("/imu"),
            gyro_scale: 1.0,
            seconds: 1000,
            remounted_at: Some(window + 20.0),
            ..Default::default()
        },
    );
    let c = live_against_offline(&bag);
    assert!(
        c.decided
            .iter()
            .any(|d| d.contains("mounting from the data") && d.contains("0.4° off")),
        "{:?}",
        c.decided
    );
    assert_close(&c);
    eprintln!("revised live: {:?}", c.revised_live);
    eprintln!("revised offline: {:?}", c.revised_offline);
    assert_eq!(c.revised_live.len(), 1, "{:?}", c.revised_live);
    assert_eq!(c.revised_offline.len(), 1, "{:?}", c.revised_offline);
    let (live, offline) = (&c.revised_live[0].line, &c.revised_offline[0]);
    assert!(
        live.contains("/imu mounting revisited") && live.contains("roll 90.0°"),
        "{live}"
    );
    assert_eq!(stamp_of(live), stamp_of(offline), "{live}\n{offline}");
    // Caught within three windows of the remounting.
    let at = c.revised_live[0].stamp_ns as f64 * 1e-9 - twin::T0 as f64 * 1e-9;
    assert!(
        at > window + 20.0 && at < window + 20.0 + 3.0 * 60.0 + 2.0,
        "{at}"
    );
    // After it, the estimate turns as the twin turned (the twin's clock is
    // the log's: its first stamp is T0).
    let (a, b) = (at + 60.0, 1000.0);
    let (truth, est) = (true_turn(a, b), estimated_turn(&c.offline, a, b));
    eprintln!("turned {est:.3} rad over {a:.0}-{b:.0} s, truly {truth:.3} rad");
    assert!((est - truth).abs() < 0.05 * truth.abs(), "{est} {truth}");
    // `estimate` says it and records it in summary.json.
    let out = d.path().join("out");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_terraslip"))
        .args([
            "estimate".as_ref(),
            bag.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ])
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{said}");
    assert!(said.contains(&format!("decided: {offline}")), "{said}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["revisited"], serde_json::json!([offline]));
}
