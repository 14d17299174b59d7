//! The Husky recording played message by message through the node's live
//! path (live import, warm-up, live estimator; no DDS), with only the user
//! guide's topics file and no `--gyro-delay`, gives the odometry `estimate`
//! gives of the same recording: the warm-up decides the gyro's delay as
//! `estimate` does.
#![cfg(feature = "ros2")]

use terraslip::config::EstimatorConfig;
use terraslip::pipeline::warmup::WarmUp;
use terraslip::pipeline::{run, EstimateRow, TerrainEvidence, DECISION_SPAN};
use terraslip_ros2::{import, TopicsConfig};

const HUSKY_TOML: &str = "[wheels]\nseparation = 1.040625\n[imu]\nmount_rpy_deg = [90, 0, -90]\n\
                          [heading]\ntopic = \"\"\n[meta]\ntrack_width = 0.555\n";

#[test]
fn the_husky_recording_played_live_gives_the_estimate_of_the_recording() {
    let Some(path) = terraslip_io::shared::shared_data("ros2/husky_test1_mcap") else {
        return;
    };
    let topics: TopicsConfig = toml::from_str(HUSKY_TOML).unwrap();
    let cfg = EstimatorConfig::default();

    let (log, report) = import(&path, &topics, None).unwrap();
    let offline = run(&log, &cfg, &TerrainEvidence::None, None).unwrap();

    let (live_import, samples) = terraslip::testkit::play_bag(&path, &topics);
    let mut node = WarmUp::new("graph", &cfg, 0.555, None, 0.3, DECISION_SPAN, None, None).unwrap();
    let mut rows: Vec<EstimateRow> = Vec::new();
    for s in samples {
        node.push(s, &mut rows).unwrap();
    }
    node.flush(&mut rows).unwrap();
    let d = *node.decisions().expect("decided");
    assert!(
        (d.gyro_delay - offline.gyro_delay).abs() < 1e-9,
        "live {} offline {}",
        d.gyro_delay,
        offline.gyro_delay
    );
    assert!(d.gyro_delay > 0.3, "the Husky's wheels are stamped late");

    // Row for row on the import's clock (the two origins differ by whole
    // seconds).
    let shift = (live_import.origin_ns().unwrap() as f64 - report.time_origin_ns as f64) * 1e-9;
    let (median, p99) = terraslip::testkit::live_against_offline(&rows, &offline.rows, shift);
    eprintln!("live against offline: median {median:.6} m, p99 {p99:.6} m");
    assert!(
        median <= 0.01 && p99 <= 0.10,
        "median {median} m, p99 {p99} m"
    );
}
