//! The streaming pieces other front ends (the Python package) drive the
//! estimator with, `pipeline::estimator`, `pose_fix`, `seed_terrain` and
//! `row`, give exactly the rows of `pipeline::run`.

use terraslip::config::EstimatorConfig;
use terraslip::pipeline::{self, TerrainEvidence};
use terraslip::testkit::{drive, SynthSpec};

#[test]
fn streaming_equals_the_run_with_terrain_labels() {
    let log = drive(&SynthSpec {
        duration: 150.0,
        ..Default::default()
    });
    let cfg = EstimatorConfig::default();
    let evidence = TerrainEvidence::Labels(log.terrain.clone());
    let run = pipeline::run(&log, &cfg, &evidence, None).unwrap();

    let track_width = log.meta.track_width.unwrap();
    let (mut est, source, _) = pipeline::estimator(&cfg, track_width, None).unwrap();
    assert_eq!(source, run.init_source);
    let (mut names, mut current): (Vec<String>, Option<usize>) = (Vec::new(), None);
    let (mut pi, mut li) = (0, 0);
    let mut changes = 0;
    for (w, want) in log.wheels.iter().zip(&run.rows) {
        while li < log.terrain.len() && log.terrain[li].t <= w.t {
            let name = &log.terrain[li].terrain;
            li += 1;
            let k = names.iter().position(|n| n == name).unwrap_or_else(|| {
                names.push(name.clone());
                names.len() - 1
            });
            if current != Some(k) {
                est.on_terrain(k).unwrap();
                current = Some(k);
                changes += 1;
            }
        }
        while pi < log.pose.len() && log.pose[pi].t <= w.t {
            let p = &log.pose[pi];
            est.on_pose(p.t, pipeline::pose_fix(&cfg, p)).unwrap();
            pi += 1;
        }
        est.on_wheels(w.t, w.v_left, w.v_right).unwrap();
        let summary = est.take_fix_summary();
        let got = pipeline::row(&est, w.t, current, &summary);
        assert_eq!(got, *want, "t = {}", w.t);
    }
    assert_eq!(changes, run.changes.len());
    assert!(run.rows.iter().any(|r| r.fused));
}

/// `estimate_streamed` (rows handed over as they are made, the log read
/// row by row) gives the rows and the summary of `estimate` on a real
/// drive, with a terrain label and an outage, warnings included.
#[test]
fn the_streamed_estimate_equals_the_estimate_from_memory() {
    use terraslip::estimate::{estimate, estimate_streamed, read_log, Inputs, OpenLog};
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/warthog_gravel");
    let tmp = tempfile::tempdir().unwrap();
    // Repeated timestamps, a pose row with half a position and pose rows
    // after the last wheels row: each stream's warnings and the reference.
    let wheels = std::fs::read_to_string(dir.join("wheels.csv")).unwrap();
    let mut lines: Vec<&str> = wheels.lines().take(9000).collect();
    let repeat = lines[300];
    lines.insert(300, repeat);
    std::fs::write(tmp.path().join("wheels.csv"), lines.join("\n") + "\n").unwrap();
    let pose = std::fs::read_to_string(dir.join("pose.csv")).unwrap();
    let pose = pose.replacen("\n0.3,-0.0110682,", "\n0.3,,", 1);
    std::fs::write(tmp.path().join("pose.csv"), pose).unwrap();
    std::fs::copy(dir.join("meta.toml"), tmp.path().join("meta.toml")).unwrap();
    std::fs::copy(dir.join("terrain.csv"), tmp.path().join("terrain.csv")).unwrap();

    let inputs = Inputs {
        terrain_labels: true,
        outage: Some((200.0, 230.0)),
        ..Default::default()
    };
    let cfg = EstimatorConfig::default();
    let log = read_log(tmp.path()).unwrap();
    let whole = estimate(&log, cfg.clone(), &inputs, &mut |_, _| {}).unwrap();
    let mut rows = Vec::new();
    let (read, streamed) = estimate_streamed(
        OpenLog::open(tmp.path()).unwrap(),
        cfg,
        &inputs,
        &mut rows,
        &mut |_, _| {},
    )
    .unwrap();
    assert!(streamed.run.rows.is_empty());
    assert_eq!(rows, whole.run.rows);
    assert_eq!(streamed.summary, whole.summary);
    assert_eq!(read.warnings, log.warnings);
    assert_eq!(log.warnings.len(), 2, "{:?}", log.warnings);
    let segments = whole.summary["prediction"]["segments"].as_u64().unwrap();
    assert!(segments > 100, "{segments}");
    // What the summary reports equals the prediction computed from the rows.
    assert_eq!(
        streamed.run.prediction,
        terraslip::prediction_score(&log, &whole.run)
    );
}
