//! Calibration from a position-only reference: GNSS fixes at 1 Hz with 1 m
//! noise and no heading (what a ROS 2 bag with `/fix` and no usable
//! orientation gives).

use terraslip_calib::synthetic::{drive, Manoeuvres, SynthConfig};
use terraslip_calib::*;
use terraslip_core::IcrParams;
use terraslip_io::DriveLog;

/// A Husky-like robot (0.555 m track, 1 m/s, 1 rad/s) on ground that
/// widens its spread to 0.70 m and slows it by 5-7 %.
fn truth() -> IcrParams {
    IcrParams {
        y_l: 0.35,
        y_r: -0.35,
        x_c: 0.0,
        alpha_l: 0.95,
        alpha_r: 0.93,
    }
}

/// `duration` s of `manoeuvres` seen by 1 Hz fixes with 1 m noise per
/// axis and no heading; no terrain labels.
fn gnss_drive_of(duration: f64, seed: u64, manoeuvres: Manoeuvres) -> DriveLog {
    let cfg = SynthConfig {
        duration,
        wheel_rate: 20.0,
        pose_rate: 1.0,
        pose_noise_xy: 1.0,
        pose_noise_yaw: 0.0,
        pose_latency: 0.0,
        max_speed: 1.0,
        max_yaw_rate: 1.0,
        hold: (3.0, 10.0),
        manoeuvres,
        track_width: 0.555,
        rate: RateSlopes::NONE,
        robot: None,
        wheel_radius: None,
        seed,
    };
    let mut log = drive(&[("", truth())], &cfg);
    log.terrain.clear();
    for p in &mut log.pose {
        p.yaw = None;
    }
    log
}

/// Mixed manoeuvres: spins, straight runs and turns.
fn gnss_drive(duration: f64, seed: u64) -> DriveLog {
    gnss_drive_of(duration, seed, Manoeuvres::Mixed)
}

#[test]
fn gnss_fixes_without_heading_give_the_spread_and_speed_factors() {
    let t = truth();
    let mut z2 = Vec::new();
    for seed in 1..=4 {
        let log = gnss_drive(1200.0, seed);
        let cal = calibrate(&[log], &CalibConfig::default(), &|_| {})
            .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let s = &cal.sets[0];
        let p = s.best.params;
        let spread_err = (p.spread() - t.spread()) / t.spread();
        eprintln!(
            "seed {seed}: spread {:.4} ({:+.2} %), alpha {:.4} {:.4}, std {:?}, offset {:?}",
            p.spread(),
            100.0 * spread_err,
            p.alpha_l,
            p.alpha_r,
            s.best.std,
            s.time_offsets
        );
        // Stated tolerance: the spread within 5 %, each speed factor
        // within 4 %, with 20 minutes of 1 Hz, 1 m fixes.
        assert!(
            spread_err.abs() < 0.05,
            "seed {seed}: spread {}",
            p.spread()
        );
        assert!(
            (p.alpha_l - t.alpha_l).abs() < 0.04,
            "alpha_l {}",
            p.alpha_l
        );
        assert!(
            (p.alpha_r - t.alpha_r).abs() < 0.04,
            "alpha_r {}",
            p.alpha_r
        );
        // The uncertainties are finite and cover the errors.
        for (k, truth_k) in [(0, t.y_l), (3, t.alpha_l), (4, t.alpha_r)] {
            let v = terraslip_calib::model::to_vec(&p)[k];
            let sd = s.best.std[k];
            assert!(sd.is_finite() && sd > 0.0, "std {:?}", s.best.std);
            z2.push(((v - truth_k) / sd).powi(2));
        }
        assert!(s.notes.iter().any(|n| n.contains("position-only")));
    }
    let rms_z = (z2.iter().sum::<f64>() / z2.len() as f64).sqrt();
    assert!(rms_z < 2.0, "RMS normalised error {rms_z}");
}

#[test]
fn fixes_that_never_bend_say_the_spread_is_unidentified() {
    let log = gnss_drive_of(600.0, 5, Manoeuvres::StraightOnly);
    match calibrate(std::slice::from_ref(&log), &CalibConfig::default(), &|_| {}) {
        Err(CalibError::Unobservable { params, reason, .. }) => {
            assert_eq!(params, vec!["y_l", "y_r", "x_c"]);
            assert!(reason.contains("windows turn"), "{reason}");
        }
        other => panic!("expected the spread unidentified, got {other:?}"),
    }
    // --allow-partial: the speed factors alone, the rest at no-slip.
    let cal = calibrate(
        &[log],
        &CalibConfig {
            allow_partial: true,
            ..Default::default()
        },
        &|_| {},
    )
    .expect("speed factors");
    let s = &cal.sets[0];
    assert_eq!(s.unidentified, vec!["y_l", "y_r", "x_c"]);
    let p = s.best.params;
    assert!(
        (p.alpha_l - 0.95).abs() < 0.04 && (p.alpha_r - 0.93).abs() < 0.04,
        "{p:?}"
    );
}
