//! A motion-capture reference stamped when its fixes arrive, in bunches,
//! rather than when they were measured: the AgileX Scout 2.0 recording of
//! Politecnico di Milano's robotics course (docs/figures/robots.md) has its
//! `/gt_pose` so, fixes delivered every few tenths of a second. Run
//! as a new user runs a log directory, `estimate`, `report` and
//! `calibrate` succeed, leave the log as it was and say what is wrong with
//! the stamps; the same drive stamped at measurement draws no such warning.

use std::path::Path;

use terraslip::testkit::{drive, SynthSpec};
use terraslip_core::IcrParams;

mod cli;
use cli::terraslip as run;

const WARNING: &str = "stamped when they arrived";

/// A Scout-like skid-steer (0.583 m track, an effective spread of about
/// 1 m) for 40 s with a 50 Hz motion-capture pose, its stamps bunched
/// into deliveries every `bunch` s (0: stamped when measured).
fn scout(dir: &Path, bunch: f64) {
    let mut log = drive(&SynthSpec {
        duration: 40.0,
        pose_hz: 50.0,
        std_xy: 0.002,
        std_yaw: 0.002,
        track_width: 0.583,
        stated_std: false,
        terrains: vec![(0.0, "lab".into(), IcrParams::new(0.5, -0.52, 0.01))],
        ..Default::default()
    });
    log.truth.clear();
    log.terrain.clear();
    if bunch > 0.0 {
        // Each delivery's fixes stamped 0.1 ms apart from its arrival.
        let (mut last, mut k) = (f64::NAN, 0);
        for p in &mut log.pose {
            let delivered = (p.t / bunch).ceil() * bunch;
            k = if delivered == last { k + 1 } else { 0 };
            last = delivered;
            p.t = delivered + k as f64 * 1e-4;
        }
    }
    log.write(dir).unwrap();
}

fn listing(dir: &Path) -> Vec<(String, u64)> {
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                e.metadata().unwrap().len(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn a_motion_capture_pose_stamped_on_arrival_is_named_by_every_command() {
    let d = tempfile::tempdir().unwrap();
    let log = d.path().join("scout");
    scout(&log, 0.3);
    let before = listing(&log);
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let est = d.path().join("est");
    let said = run(&["estimate", &s(&log), "--out", &s(&est)]);
    assert!(said.contains(WARNING), "{said}");
    let summary = std::fs::read_to_string(est.join("summary.json")).unwrap();
    assert!(summary.contains(WARNING), "{summary}");
    run(&["report", &s(&est)]);
    let report = std::fs::read_to_string(est.join("report.html")).unwrap();
    assert!(report.contains(WARNING), "the report shows the warning");
    let said = run(&[
        "calibrate",
        &s(&log),
        "--out",
        &s(&d.path().join("params.json")),
        "--ros2-params",
        &s(&d.path().join("ddc.yaml")),
    ]);
    assert!(said.contains(WARNING), "{said}");
    assert_eq!(listing(&log), before, "the log is left as it was");
}

#[test]
fn the_same_pose_stamped_when_measured_draws_no_such_warning() {
    let d = tempfile::tempdir().unwrap();
    let log = d.path().join("scout");
    scout(&log, 0.0);
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let said = run(&["estimate", &s(&log), "--out", &s(&d.path().join("est"))]);
    assert!(!said.contains(WARNING), "{said}");
}
