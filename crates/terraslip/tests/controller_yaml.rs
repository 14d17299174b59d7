//! The Husky recording the repository ships (`data/husky_test1`: the
//! controller's odometry, an IMU, GNSS fixes): the controller file
//! `calibrate --ros2-params` writes, applied as written, against the
//! fixes' course (`terraslip::controller_turn`), and `estimate` and
//! `calibrate` recommending the same factors.
#![cfg(feature = "ros2")]

use std::path::{Path, PathBuf};

use assert_cmd::Command;
use serde_json::Value;
use terraslip::controller_turn::{apply, turn_against_course, AppliedOdometry, RecordedController};
use terraslip_io::DriveLog;
use terraslip_ros2::controller_yaml::{read_block, WrittenParams};

/// The user guide's topics file: the controller's separation (a
/// multiplier of 1.875 on a 0.555 m track) stated.
const HUSKY_TOML: &str = "[wheels]\nseparation = 1.040625\n[imu]\nmount_rpy_deg = [90, 0, -90]\n\
                          [heading]\ntopic = \"\"\n[meta]\ntrack_width = 0.555\n";

fn terraslip(args: &[&std::ffi::OsStr]) -> std::process::Output {
    let o = Command::cargo_bin("terraslip")
        .unwrap()
        .args(args)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

/// `import`, `calibrate --ros2-params` and `estimate` of the Husky bag into
/// `dir`, with `topics` when given: the log, the YAML, `params.json` and
/// `summary.json`.
struct Runs {
    log: DriveLog,
    yaml: String,
    params: Value,
    summary: Value,
}

fn runs(dir: &Path, topics: Option<&Path>) -> Runs {
    let bag = terraslip_io::shared::repo_data("husky_test1");
    let with = |args: Vec<PathBuf>| -> Vec<std::ffi::OsString> {
        let mut a: Vec<std::ffi::OsString> = args.into_iter().map(Into::into).collect();
        if let Some(t) = topics {
            a.push("--topics".into());
            a.push(t.into());
        }
        a
    };
    let run = |args: Vec<PathBuf>| {
        let a = with(args);
        terraslip(&a.iter().map(|s| s.as_os_str()).collect::<Vec<_>>());
    };
    let p = |s: &str| PathBuf::from(s);
    run(vec![p("import"), bag.clone(), p("--out"), dir.join("log")]);
    run(vec![
        p("calibrate"),
        bag.clone(),
        p("--ros2-params"),
        dir.join("dd.yaml"),
        p("--out"),
        dir.join("params.json"),
    ]);
    run(vec![p("estimate"), bag, p("--out"), dir.join("est")]);
    let json = |f: PathBuf| -> Value {
        serde_json::from_str(&std::fs::read_to_string(f).unwrap()).unwrap()
    };
    Runs {
        log: DriveLog::read(dir.join("log")).unwrap(),
        yaml: std::fs::read_to_string(dir.join("dd.yaml")).unwrap(),
        params: json(dir.join("params.json")),
        summary: json(dir.join("est/summary.json")),
    }
}

fn topics_file(dir: &Path) -> PathBuf {
    let t = dir.join("husky.toml");
    std::fs::write(&t, HUSKY_TOML).unwrap();
    t
}

/// The turn error (%) of the log's odometry under `written` as written.
fn turn_error(r: &Runs, written: &WrittenParams) -> f64 {
    let rec = RecordedController::of(&r.log.meta).expect("tread speeds from a twist");
    applied_turn_error(r, &apply(&rec, written).unwrap())
}

fn applied_turn_error(r: &Runs, applied: &AppliedOdometry) -> f64 {
    let rec = RecordedController::of(&r.log.meta).unwrap();
    turn_against_course(&r.log, rec.separation, applied)
        .expect("pairs of straight stretches")
        .error_percent()
}

/// `estimate`'s whole-drive factors applied to the recording's controller
/// (it writes no file): its separation times the separation factor, the
/// speed factors as radius multipliers.
fn estimate_applied(r: &Runs) -> AppliedOdometry {
    let f = r.summary["controller"]["separation_factor"]
        .as_f64()
        .unwrap();
    let rec = &r.summary["recommendation"];
    AppliedOdometry {
        separation: RecordedController::of(&r.log.meta).unwrap().separation * f,
        left: rec["alpha_l"]["value"].as_f64().unwrap(),
        right: rec["alpha_r"]["value"].as_f64().unwrap(),
    }
}

#[test]
fn the_controller_file_applied_as_written_turns_within_2_percent_of_the_course() {
    let dir = tempfile::tempdir().unwrap();
    let topics = topics_file(dir.path());
    for (name, t) in [
        ("no settings", None),
        ("husky.toml", Some(topics.as_path())),
    ] {
        let d = dir.path().join(name.replace([' ', '.'], "_"));
        std::fs::create_dir_all(&d).unwrap();
        let r = runs(&d, t);
        let written = read_block(&r.yaml, "husky_velocity_controller").unwrap();
        let nominal = turn_error(&r, &WrittenParams::default());
        let calibrated = turn_error(&r, &written);
        let estimated = applied_turn_error(&r, &estimate_applied(&r));
        eprintln!(
            "{name}: turn error against the GNSS course: recording's odometry {nominal:+.2} %, \
             calibrate's file as written {calibrated:+.2} %, estimate's factors applied {estimated:+.2} %"
        );
        assert!(
            calibrated.abs() < 2.0,
            "{name}: {calibrated:+.2} %\n{}",
            r.yaml
        );
        // With the controller's separation stated the file is complete:
        // it sets the separation and the radius multipliers.
        if t.is_some() {
            assert!(
                written.wheel_separation_multiplier.is_some()
                    && written.left_wheel_radius_multiplier.is_some(),
                "{}",
                r.yaml
            );
        }
    }
}

/// `value ± std` of a `{value, std}` object or of two keys.
fn figure(v: &Value, key: &str, std: &str) -> (f64, f64) {
    (v[key].as_f64().unwrap(), v[std].as_f64().unwrap())
}

#[test]
fn estimate_and_calibrate_recommend_the_same_factors_within_their_uncertainty() {
    let dir = tempfile::tempdir().unwrap();
    let r = runs(dir.path(), None);
    let c = &r.summary["controller"];
    let tf = &r.params["turn_factor"];
    let s = r.params["separation"]["separation_m"].as_f64().unwrap();
    let p = &r.params["params"];
    let sd = &r.params["std"];
    let spread = p["y_l"].as_f64().unwrap() - p["y_r"].as_f64().unwrap();
    let rec = &r.summary["recommendation"];
    let pairs = [
        (
            "turn factor",
            figure(c, "turn_factor", "turn_factor_std"),
            figure(tf, "combined", "combined_std"),
        ),
        (
            "separation factor",
            figure(c, "separation_factor", "separation_factor_std"),
            (spread / s, 2.0 * sd["y_l"].as_f64().unwrap() / s),
        ),
        (
            "left speed factor",
            figure(&rec["alpha_l"], "value", "std"),
            (
                p["alpha_l"].as_f64().unwrap(),
                sd["alpha_l"].as_f64().unwrap(),
            ),
        ),
        (
            "right speed factor",
            figure(&rec["alpha_r"], "value", "std"),
            (
                p["alpha_r"].as_f64().unwrap(),
                sd["alpha_r"].as_f64().unwrap(),
            ),
        ),
    ];
    // `estimate`'s turn factor on the course's (the fixes' course over
    // long baselines, which `calibrate` checks against): within 2 %.
    let course = tf["course_check"].as_f64().unwrap();
    let (e, _) = pairs[0].1;
    eprintln!("turn factor: estimate {e:.4}, course check {course:.4}");
    assert!(
        (e / course - 1.0).abs() < 0.02,
        "estimate's turn factor {e:.4} against the course's {course:.4}"
    );
    for (name, (e, se), (k, sk)) in pairs {
        eprintln!("{name}: estimate {e:.4} ± {se:.4}, calibrate {k:.4} ± {sk:.4}");
        assert!(se > 0.0 && sk > 0.0, "{name}");
        // Within their joint 1-sigma.
        assert!(
            (e - k).abs() <= se.hypot(sk),
            "{name}: estimate {e:.4} ± {se:.4} against calibrate {k:.4} ± {sk:.4}"
        );
    }
}
