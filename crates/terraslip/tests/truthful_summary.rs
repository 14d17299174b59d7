//! summary.json reports what the drive taught: a factor it did not teach
//! is `null` (held), and the controller's recommendation is the whole
//! drive's, with its 1-sigma, apart from the estimator's last state.

use terraslip::estimate::{estimate, Inputs};
use terraslip::testkit::{drive, SynthSpec};
use terraslip_core::IcrParams;
use terraslip_io::DriveLog;

fn summary(log: &DriveLog) -> serde_json::Value {
    let cfg = terraslip::config::EstimatorConfig::default();
    estimate(log, cfg, &Inputs::default(), &mut |_, _| {})
        .unwrap()
        .summary
}

/// Tread speeds from a controller's odometry made with a nominal S = 1 m.
fn nominal(mut log: DriveLog) -> DriveLog {
    log.meta.separation = Some(1.0);
    log.meta.separation_source = Some("default".into());
    log
}

#[test]
fn odometry_alone_gives_no_factor() {
    let mut log = drive(&SynthSpec {
        duration: 60.0,
        ..Default::default()
    });
    log.pose.clear();
    log.meta.track_width = None;
    let s = summary(&nominal(log));
    let c = &s["controller"];
    for k in ["separation_factor", "turn_factor", "wheel_separation_m"] {
        assert!(c[k].is_null(), "{k}: {c}");
    }
    assert!(c["final_state"]["separation_factor"].is_null(), "{c}");
    assert!(c["learning"]["turn_factor"]
        .as_str()
        .unwrap()
        .starts_with("held"));
    for k in ["spread_m", "alpha_l", "alpha_r", "turn_spread_m"] {
        assert!(
            s["recommendation"][k].is_null(),
            "{k}: {}",
            s["recommendation"]
        );
    }
}

#[test]
fn the_recommendation_is_the_whole_drive_not_its_last_seconds() {
    let main = IcrParams {
        y_l: 0.52,
        y_r: -0.50,
        x_c: 0.03,
        alpha_l: 0.9,
        alpha_r: 0.9,
    };
    // The last 25 s on a ground that turns the robot far worse.
    let end = IcrParams {
        y_l: 0.75,
        y_r: -0.73,
        alpha_l: 0.75,
        alpha_r: 0.75,
        ..main
    };
    let log = drive(&SynthSpec {
        duration: 300.0,
        pose_hz: 5.0,
        std_xy: 0.03,
        std_yaw: 0.005,
        terrains: vec![(0.0, "a".into(), main), (275.0, "b".into(), end)],
        ..Default::default()
    });
    let s = summary(&nominal(log));
    let c = &s["controller"];
    let (f, sd) = (
        c["separation_factor"].as_f64().unwrap(),
        c["separation_factor_std"].as_f64().unwrap(),
    );
    let truth = main.y_l - main.y_r;
    assert!(sd > 0.0 && sd < 0.1, "{c}");
    assert!(
        (f - truth).abs() < 0.1 * truth,
        "{f} +- {sd} against {truth}: {c}"
    );
    let last = c["final_state"]["separation_factor"].as_f64().unwrap();
    assert!((last - truth).abs() > (f - truth).abs(), "{c}");
    let a = &s["recommendation"]["alpha_l"];
    assert!((a["value"].as_f64().unwrap() - 0.9).abs() < 0.05, "{a}");
    assert!(s["icr_is"].as_str().unwrap().starts_with("final state"));
}
