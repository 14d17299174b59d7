//! The `calibrate` and `calibrate validate` command-line contract
//! (shared/spec/cli.md): exit codes, one JSON object on stdout, one-line errors.

use assert_cmd::Command;
use terraslip_calib::synthetic::{drive, mandow_table1, Manoeuvres, SynthConfig};
use terraslip_core::IcrParams;

fn terraslip() -> Command {
    Command::cargo_bin("terraslip").expect("binary built")
}

fn write_log(
    dir: &std::path::Path,
    name: &str,
    labelled: bool,
    cfg: &SynthConfig,
) -> std::path::PathBuf {
    let mut log = drive(&[("asphalt", mandow_table1())], cfg);
    if !labelled {
        log.terrain.clear();
    }
    let p = dir.join(name);
    log.write(&p).expect("write log");
    p
}

fn json_of(out: &[u8]) -> serde_json::Value {
    let s = String::from_utf8(out.to_vec()).expect("utf8");
    assert_eq!(s.trim().lines().count(), 1, "exactly one JSON line: {s}");
    serde_json::from_str(s.trim()).expect("stdout is JSON")
}

#[test]
fn calibrate_json_and_validate_json_follow_the_contract() {
    let d = tempfile::tempdir().expect("tempdir");
    let log = write_log(d.path(), "drive", false, &SynthConfig::p3at(150.0, 21));
    let params = d.path().join("params.json");
    let out = terraslip()
        .args(["calibrate"])
        .arg(&log)
        .arg("--out")
        .arg(&params)
        .args(["--method", "lm", "--json"])
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j = json_of(&out.stdout);
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
    let out = terraslip()
        .args(["calibrate", "validate"])
        .arg(&log)
        .arg("--params")
        .arg(&params)
        .arg("--json")
        .arg("--plot")
        .arg(&svg)
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = json_of(&out.stdout);
    assert!(v["segments"].as_u64().is_some_and(|n| n > 50));
    for m in ["mse", "nominal_mse"] {
        for k in ["dx", "dy", "dyaw"] {
            assert!(v[m][k].as_f64().is_some_and(|x| x >= 0.0), "{m}.{k}");
        }
    }
    assert!(v["mse"]["dyaw"].as_f64() < v["nominal_mse"]["dyaw"].as_f64());
    let svg_text = std::fs::read_to_string(&svg).expect("plot written");
    assert!(svg_text.contains("<svg"));
}

#[test]
fn labelled_logs_give_one_set_per_terrain() {
    let d = tempfile::tempdir().expect("tempdir");
    let log = write_log(d.path(), "drive", true, &SynthConfig::p3at(100.0, 22));
    let params = d.path().join("p.json");
    let out = terraslip()
        .arg("calibrate")
        .arg(&log)
        .arg("--out")
        .arg(&params)
        .args([
            "--method",
            "ga",
            "--generations",
            "20",
            "--population",
            "24",
            "--json",
        ])
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j = json_of(&out.stdout);
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
    let out = terraslip()
        .arg("calibrate")
        .arg(&log)
        .arg("--out")
        .arg(&params)
        .output()
        .expect("runs");
    assert!(!out.status.success());
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
    let mut log = drive(
        &[(
            "a",
            IcrParams {
                alpha_r: 0.95,
                ..IcrParams::new(0.3, -0.3, 0.0)
            },
        )],
        &cfg,
    );
    log.wheels.iter_mut().for_each(|w| w.v_right = w.v_left);
    log.terrain.clear();
    let dir = d.path().join("straight");
    log.write(&dir).expect("write");
    let params = d.path().join("p.json");
    let out = terraslip()
        .arg("calibrate")
        .arg(&dir)
        .arg("--out")
        .arg(&params)
        .args(["--method", "lm"])
        .output()
        .expect("runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("y_l") && err.contains("never turns"), "{err}");
    let out = terraslip()
        .arg("calibrate")
        .arg(&dir)
        .arg("--out")
        .arg(&params)
        .args(["--method", "lm", "--allow-partial", "--json"])
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j = json_of(&out.stdout);
    assert_eq!(j["unidentified"], serde_json::json!(["y_l", "y_r", "x_c"]));
}

#[test]
fn bad_flags_are_reported() {
    let d = tempfile::tempdir().expect("tempdir");
    let log = write_log(d.path(), "drive", false, &SynthConfig::p3at(20.0, 25));
    let out = terraslip()
        .arg("calibrate")
        .arg(&log)
        .args(["--out", "/dev/null", "--bound", "y_q=0:1"])
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown parameter"));
    let out = terraslip()
        .args(["calibrate", "validate"])
        .arg(&log)
        .args(["--params"])
        .arg(d.path().join("missing.json"))
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.json"));
}
