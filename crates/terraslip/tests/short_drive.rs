//! A recording shorter than the prediction's warm-up still gets its 2 s
//! prediction figure, after a warm-up shortened to its length and stated.

use terraslip::estimate::{estimate, Inputs};
use terraslip::testkit::{drive, SynthSpec};
use terraslip_core::IcrParams;

fn short(duration: f64) -> serde_json::Value {
    let log = drive(&SynthSpec {
        duration,
        pose_hz: 20.0,
        std_xy: 0.02,
        terrains: vec![(0.0, "ground".into(), IcrParams::new(0.3, -0.31, 0.01))],
        ..Default::default()
    });
    let cfg = terraslip::config::EstimatorConfig::default();
    estimate(&log, cfg, &Inputs::default(), &mut |_, _| {})
        .unwrap()
        .summary
}

#[test]
fn a_40_s_drive_with_a_20_hz_pose_is_scored_after_a_20_s_warmup() {
    let s = short(40.0);
    let p = &s["prediction"];
    assert!(p.is_object(), "no prediction: {}", s["warnings"]);
    assert_eq!(p["warmup_s"], 20.0);
    assert!(p["segments"].as_u64().unwrap() >= 15, "{p}");
    let warnings = s["warnings"].to_string();
    assert!(!warnings.contains("too sparse"), "{warnings}");
}

#[test]
fn a_drive_too_short_for_any_start_says_so() {
    let s = short(3.0);
    assert!(s["prediction"].is_null());
    let warnings = s["warnings"].to_string();
    assert!(warnings.contains("too short"), "{warnings}");
    assert!(!warnings.contains("too sparse"), "{warnings}");
}
