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
