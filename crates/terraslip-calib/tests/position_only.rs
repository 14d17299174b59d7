//! Calibration from a position-only reference: GNSS fixes at 1 Hz with 1 m
//! noise and no heading (what a ROS 2 bag with `/fix` and no usable
//! orientation gives).

use terraslip_calib::course;
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
    let cfg = gnss_config(duration, seed, manoeuvres);
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

/// The 1 Hz, 1 m, 1 m/s drive of [`gnss_drive_of`].
fn gnss_config(duration: f64, seed: u64, manoeuvres: Manoeuvres) -> SynthConfig {
    SynthConfig {
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
    }
}

/// A field drive of `robot` seen by an antenna at `lever` (m, base_link:
/// x forward, y left): survey lines (8-20 s holds, up to 1.5 m/s), 2.5 Hz
/// fixes with 0.6 m noise stamped `latency` s late.
fn antenna_drive_of(robot: IcrParams, seed: u64, lever: (f64, f64), latency: f64) -> DriveLog {
    let cfg = SynthConfig {
        duration: 900.0,
        pose_rate: 2.5,
        pose_noise_xy: 0.6,
        pose_latency: latency,
        max_speed: 1.5,
        hold: (8.0, 20.0),
        ..gnss_config(900.0, seed, Manoeuvres::Survey)
    };
    let mut log = drive(&[("", robot)], &cfg);
    log.terrain.clear();
    for p in &mut log.pose {
        let th = p.yaw.take().expect("synthetic heading");
        let (s, c) = th.sin_cos();
        *p.east.as_mut().unwrap() += c * lever.0 - s * lever.1;
        *p.north.as_mut().unwrap() += s * lever.0 + c * lever.1;
    }
    log
}

fn antenna_drive(seed: u64, lever: (f64, f64), latency: f64) -> DriveLog {
    antenna_drive_of(truth(), seed, lever, latency)
}

/// The turn factor `spread / (mean speed factor * S)` of the truth on the
/// 0.555 m odometry.
fn true_turn_factor() -> f64 {
    let t = truth();
    t.spread() / (0.5 * (t.alpha_l + t.alpha_r) * 0.555)
}

#[test]
fn the_course_check_finds_the_turn_factor_whatever_the_antenna_and_clock() {
    // Treads rolling 2 % apart (0.95 / 0.93): a course check that assumes
    // equal treads reads their straight-line drift as turning.
    let k_true = true_turn_factor();
    for (seed, lever, latency) in [
        (1, (0.0, 0.0), 0.0),
        (2, (0.4, 0.0), 0.2),
        (3, (0.3, 0.2), -0.3),
    ] {
        let log = antenna_drive(seed, lever, latency);
        // The stretches are chosen on the odometry with the speed factors'
        // ratio (calibrate gives the windows'); the check fits what is left.
        let odo = course::Odometry {
            separation: 0.555,
            alpha: (0.95, 0.93),
        };
        let c = course::check(&[&log], &[latency], &odo, &course::CourseConfig::default())
            .expect("straight stretches");
        eprintln!(
            "seed {seed} lever {lever:?}: {:.4} ± {:.4}, asymmetry {:?} ({} stretches, {} pairs), truth {k_true:.4}",
            c.turn_factor, c.std, c.asymmetry, c.stretches.len(), c.pairs.len()
        );
        assert!(c.stretches.len() >= 20 && c.pairs.len() >= 100, "{c:?}");
        assert!(
            (c.turn_factor / k_true - 1.0).abs() < 0.005,
            "{}",
            c.turn_factor
        );
        // (0.93 - 0.95) / (0.93 + 0.95)
        let (asym, _) = c.asymmetry.expect("unequal treads are told");
        assert!((asym + 0.0106).abs() < 0.002, "{asym}");
    }
}

#[test]
fn calibrate_carries_the_windows_and_the_course_check_combined() {
    let k_true = true_turn_factor();
    let log = antenna_drive(4, (0.3, 0.2), 0.2);
    let cal = calibrate(&[log], &CalibConfig::default(), &|_| {}).unwrap();
    let s = &cal.sets[0];
    let c = s.course.as_ref().expect("the course check is reported");
    assert!((c.course.0 / k_true - 1.0).abs() < 0.005, "{c:?}");
    // The combination leans on the more precise figure and sits between.
    assert!(c.combined.1 <= c.windows.1.min(c.course.1) + 1e-12, "{c:?}");
    let (lo, hi) = (c.windows.0.min(c.course.0), c.windows.0.max(c.course.0));
    assert!(
        c.combined.0 >= lo - 1e-12 && c.combined.0 <= hi + 1e-12,
        "{c:?}"
    );
    let p = s.best.params;
    let k = p.spread() / (0.5 * (p.alpha_l + p.alpha_r) * 0.555);
    assert!((k - c.combined.0).abs() < 1e-9, "params carry {k}, {c:?}");
    assert!((k / k_true - 1.0).abs() < 0.01, "{k}");
    let entry = s.entry();
    let tf = &entry.extra["turn_factor"];
    assert!(
        tf["course_check"].as_f64().is_some() && tf["combined"].as_f64().is_some(),
        "{tf}"
    );
}

#[test]
fn equal_treads_are_held_equal_by_the_course_check() {
    let robot = IcrParams {
        alpha_r: 0.95,
        ..truth()
    };
    let k_true = robot.spread() / (0.95 * 0.555);
    let log = antenna_drive_of(robot, 5, (0.3, -0.1), 0.1);
    let odo = course::Odometry {
        separation: 0.555,
        alpha: (1.0, 1.0),
    };
    let c = course::check(&[&log], &[0.1], &odo, &course::CourseConfig::default())
        .expect("straight stretches");
    eprintln!(
        "{:.4} ± {:.4} {:?}, truth {k_true:.4}",
        c.turn_factor, c.std, c.asymmetry_free
    );
    assert_eq!(c.asymmetry, None, "{:?}", c.asymmetry_free);
    assert!(
        (c.turn_factor / k_true - 1.0).abs() < 0.005,
        "{}",
        c.turn_factor
    );
}

#[test]
fn the_2s_prediction_on_fixes_alone_tells_the_true_model_from_the_no_slip_one() {
    use terraslip_calib::position_prediction::{score, PositionOnlySpec};
    let log = antenna_drive_of(truth(), 6, (0.0, 0.0), 0.0);
    let s = score(&log, &truth(), 0.555, 0.0, &PositionOnlySpec::default())
        .expect("starts with 20 s of fixes before them");
    eprintln!(
        "{} segments: truth {:?}, no-slip {:?}",
        s.segments.len(),
        s.stats,
        s.no_slip
    );
    assert!(s.segments.len() > 800, "{}", s.segments.len());
    // 0.6 m fixes at both ends: about 0.85 m of noise in any error.
    assert!(s.stats.mean_m < 1.1, "{:?}", s.stats);
    assert!(
        s.no_slip.mean_m > 1.2 * s.stats.mean_m,
        "{:?} vs {:?}",
        s.no_slip,
        s.stats
    );
    assert!(s.to_json()["start_heading"]
        .as_str()
        .is_some_and(|h| h.starts_with("profiled")));
}
