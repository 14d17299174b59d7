//! The `calibrate` and `calibrate validate` command-line contract
//! (docs/cli.md): exit codes, one JSON object on stdout, one-line errors.

use std::ffi::OsStr;
use std::path::Path;
use std::process::Output;

use assert_cmd::Command;
use terraslip_calib::synthetic::{drive, mandow_table1, Manoeuvres, SynthConfig};
use terraslip_core::IcrParams;

/// Runs `terraslip` with `args`; with `expect_ok`, fails the test on a
/// non-zero exit, showing stderr.
fn terraslip(args: &[&OsStr], expect_ok: bool) -> Output {
    let out = Command::cargo_bin("terraslip")
        .expect("binary built")
        .args(args)
        .output()
        .expect("runs");
    if expect_ok {
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    } else {
        assert!(!out.status.success(), "expected a failure");
    }
    out
}

fn s(x: &str) -> &OsStr {
    OsStr::new(x)
}

fn write_log(dir: &Path, name: &str, labelled: bool, cfg: &SynthConfig) -> std::path::PathBuf {
    let mut log = drive(&[("asphalt", mandow_table1())], cfg);
    if !labelled {
        log.terrain.clear();
    }
    let p = dir.join(name);
    log.write(&p).expect("write log");
    p
}

/// `calibrate LOG --out PARAMS --method lm` and `extra`, which must succeed.
fn calibrate_lm(log: &Path, params: &Path, extra: &[&OsStr]) -> Output {
    let mut args = vec![
        s("calibrate"),
        log.as_os_str(),
        s("--out"),
        params.as_os_str(),
        s("--method"),
        s("lm"),
    ];
    args.extend_from_slice(extra);
    terraslip(&args, true)
}

/// `calibrate validate LOG --params PARAMS` and `extra`, which must succeed.
fn validate(log: &Path, params: &Path, extra: &[&OsStr]) -> Output {
    let mut args = vec![
        s("calibrate"),
        s("validate"),
        log.as_os_str(),
        s("--params"),
        params.as_os_str(),
    ];
    args.extend_from_slice(extra);
    terraslip(&args, true)
}

fn json_of(out: &[u8]) -> serde_json::Value {
    let text = String::from_utf8(out.to_vec()).expect("utf8");
    assert_eq!(
        text.trim().lines().count(),
        1,
        "exactly one JSON line: {text}"
    );
    serde_json::from_str(text.trim()).expect("stdout is JSON")
}

#[test]
fn calibrate_json_and_validate_json_follow_the_contract() {
    let d = tempfile::tempdir().expect("tempdir");
    let log = write_log(d.path(), "drive", false, &SynthConfig::p3at(150.0, 21));
    let params = d.path().join("params.json");
    let out = calibrate_lm(&log, &params, &[s("--json")]);
    let j = json_of(&out.stdout);
    // stderr is a pipe here: progress comes as plain lines, one per stage.
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.lines().any(|l| l == "calibrate: levenberg-marquardt"),
        "{err}"
    );
    let truth = mandow_table1();
    for (k, v) in [("y_l", truth.y_l), ("y_r", truth.y_r), ("x_c", truth.x_c)] {
        let got = j["params"][k].as_f64().expect("param present");
        assert!((got - v).abs() < 0.02, "{k}: {got} vs {v}");
    }
    for k in ["alpha_l", "alpha_r"] {
        assert!(j["params"][k].as_f64().is_some());
    }
    assert!(j["cost"].as_f64().is_some_and(|c| c >= 0.0));
    // The written file is the same object.
    let file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&params).expect("file written"))
            .expect("json");
    assert_eq!(file["params"], j["params"]);

    let svg = d.path().join("v.svg");
    let out = validate(&log, &params, &[s("--json"), s("--plot"), svg.as_os_str()]);
    let v = json_of(&out.stdout);
    assert!(v["segments"].as_u64().is_some_and(|n| n > 50));
    for m in ["mse", "nominal_mse"] {
        for k in ["dx", "dy", "dyaw"] {
            assert!(v[m][k].as_f64().is_some_and(|x| x >= 0.0), "{m}.{k}");
        }
    }
    assert!(v["mse"]["dyaw"].as_f64() < v["nominal_mse"]["dyaw"].as_f64());
    // A constant robot: the turn-rate model is fitted, not selected, and
    // the constant scores are the calibrated ones.
    assert_eq!(file["rate_model"]["selected"], serde_json::json!(false));
    assert_eq!(v["rate_model_segments"], serde_json::json!(0));
    assert_eq!(v["constant_mse"], v["mse"]);
    let svg_text = std::fs::read_to_string(&svg).expect("plot written");
    assert!(svg_text.contains("<svg"));
}

#[test]
fn validate_repeats_the_warnings_of_the_calibration() {
    let d = tempfile::tempdir().expect("tempdir");
    let log = write_log(d.path(), "drive", false, &SynthConfig::p3at(150.0, 21));
    let params = d.path().join("params.json");
    calibrate_lm(&log, &params, &[]);
    // A fit at a limit, as calibrate records it in the file.
    let mut file: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&params).expect("read")).expect("json");
    let edge = "drive: the time offset +0.500 s is at the edge of its search range (±0.5 s)";
    file["warnings"] = serde_json::json!([edge]);
    std::fs::write(&params, file.to_string()).expect("write");
    let out = validate(&log, &params, &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.lines()
            .any(|l| l.starts_with("warning: ") && l.contains(edge) && l.contains("params.json")),
        "{err}"
    );
}

#[test]
fn labelled_logs_give_one_set_per_terrain() {
    let d = tempfile::tempdir().expect("tempdir");
    let log = write_log(d.path(), "drive", true, &SynthConfig::p3at(100.0, 22));
    let params = d.path().join("p.json");
    let mut args = vec![
        s("calibrate"),
        log.as_os_str(),
        s("--out"),
        params.as_os_str(),
    ];
    args.extend(
        [
            "--method",
            "ga",
            "--generations",
            "20",
            "--population",
            "24",
            "--json",
        ]
        .map(s),
    );
    let j = json_of(&terraslip(&args, true).stdout);
    let set = &j["terrains"]["asphalt"];
    assert!(set["params"]["y_l"].as_f64().is_some());
    assert!(set["cost"].as_f64().is_some());
    assert_eq!(set["method"], "ga");
    assert!(set["ticksmm"].as_i64().is_some(), "P3-AT settings present");
}

#[test]
fn missing_pose_reference_fails_with_one_line() {
    let d = tempfile::tempdir().expect("tempdir");
    let log = write_log(d.path(), "drive", false, &SynthConfig::p3at(30.0, 23));
    std::fs::remove_file(log.join("pose.csv")).expect("remove pose");
    let params = d.path().join("p.json");
    let out = terraslip(
        &[
            s("calibrate"),
            log.as_os_str(),
            s("--out"),
            params.as_os_str(),
        ],
        false,
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("pose"), "{err}");
    assert!(!params.exists(), "nothing written on failure");
}

#[test]
fn a_drive_that_never_turns_is_refused_unless_partial_is_allowed() {
    let d = tempfile::tempdir().expect("tempdir");
    let mut cfg = SynthConfig::p3at(100.0, 24);
    cfg.manoeuvres = Manoeuvres::StraightOnly;
    let robot = IcrParams {
        alpha_r: 0.95,
        ..IcrParams::new(0.3, -0.3, 0.0)
    };
    let mut log = drive(&[("a", robot)], &cfg);
    log.wheels.iter_mut().for_each(|w| w.v_right = w.v_left);
    log.terrain.clear();
    let dir = d.path().join("straight");
    log.write(&dir).expect("write");
    let params = d.path().join("p.json");
    let mut args = vec![
        s("calibrate"),
        dir.as_os_str(),
        s("--out"),
        params.as_os_str(),
        s("--method"),
        s("lm"),
    ];
    let out = terraslip(&args, false);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("y_l") && err.contains("never turns"), "{err}");
    args.extend([s("--allow-partial"), s("--json")]);
    let j = json_of(&terraslip(&args, true).stdout);
    assert_eq!(j["unidentified"], serde_json::json!(["y_l", "y_r", "x_c"]));
}

#[test]
fn bad_flags_are_reported() {
    let d = tempfile::tempdir().expect("tempdir");
    let log = write_log(d.path(), "drive", false, &SynthConfig::p3at(20.0, 25));
    let out = terraslip(
        &[
            s("calibrate"),
            log.as_os_str(),
            s("--out"),
            s("/dev/null"),
            s("--bound"),
            s("y_q=0:1"),
        ],
        false,
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown parameter"));
    let missing = d.path().join("missing.json");
    let out = terraslip(
        &[
            s("calibrate"),
            s("validate"),
            log.as_os_str(),
            s("--params"),
            missing.as_os_str(),
        ],
        false,
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.json"));
    let out = terraslip(
        &[
            s("calibrate"),
            log.as_os_str(),
            s("--out"),
            s("/dev/null"),
            s("--time-offset"),
            s("params"),
        ],
        false,
    );
    assert!(String::from_utf8_lossy(&out.stderr)
        .contains("--time-offset `params`: expected `auto` or seconds"));
    let out = terraslip(
        &[
            s("calibrate"),
            log.as_os_str(),
            s("--out"),
            s("/dev/null"),
            s("--stride=-1"),
        ],
        false,
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("--stride"));
}
