//! `terraslip terrain eval` and `crossval` on small synthetic logs: the
//! confidence (risk–coverage, 80 % coverage, ECE), the per-window
//! CSV, and the outer-fold headline beside the plain baseline.

use std::path::Path;

use assert_cmd::Command;
use terraslip_terrain::synth::vibration_log;

const NAMES: [&str; 3] = ["asphalt", "grass", "soil"];

fn write_runs(dir: &Path) -> Vec<String> {
    let mut paths = Vec::new();
    for seed in [1u64, 2] {
        for k in 0..3 {
            let p = dir.join(format!("run_{seed}_{k}"));
            vibration_log(&NAMES, &[(k, 25.0)], seed * 10 + k as u64, 0.0)
                .write(&p)
                .unwrap();
            paths.push(p.to_string_lossy().into_owned());
        }
    }
    paths
}

fn terraslip() -> Command {
    Command::cargo_bin("terraslip").unwrap()
}

const SMALL: [&str; 5] = ["--window", "1", "--rounds", "30", "--no-speed-copies"];

#[test]
fn eval_windows_writes_one_row_per_window_and_reports_the_unknown_threshold() {
    let dir = tempfile::tempdir().unwrap();
    let runs = write_runs(dir.path());
    let model = dir.path().join("model.json");
    terraslip()
        .args(["terrain", "train"])
        .args(&runs)
        .args(["--out", model.to_str().unwrap()])
        .args(SMALL)
        .assert()
        .success();
    let test = dir.path().join("test");
    vibration_log(&NAMES, &[(0, 15.0), (2, 15.0)], 99, 0.0)
        .write(&test)
        .unwrap();
    let csv = dir.path().join("windows.csv");
    let out = terraslip()
        .args(["terrain", "eval", test.to_str().unwrap(), "--json"])
        .args(["--model", model.to_str().unwrap()])
        .args(["--plots", dir.path().join("plots").to_str().unwrap()])
        .args(["--windows", csv.to_str().unwrap()])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let c = &v["confidence"];
    let ece = c["ece"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&ece), "{v}");
    assert!(c["accuracy_at_80"].as_f64().unwrap() > 0.8, "{v}");
    assert_eq!(c["risk_coverage"].as_array().unwrap().len(), 10, "{v}");
    assert_eq!(v["unknown_below"].as_f64(), Some(0.5), "{v}");
    assert!(stderr.contains("expected calibration error"), "{stderr}");

    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("log,t,truth,predicted,confidence"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len() as u64, v["windows"].as_u64().unwrap());
    for r in &rows {
        assert_eq!(r.len(), 5, "{r:?}");
        assert_eq!(r[0], "test");
        assert!(r[1].parse::<f64>().unwrap() > 0.0);
        assert!(NAMES.contains(&r[2]));
        let conf = r[4].parse::<f64>().unwrap();
        assert!((0.0..=1.0).contains(&conf));
        assert_eq!(r[3] == "unknown", conf < 0.5, "{r:?}");
        assert!(NAMES.contains(&r[3]) || r[3] == "unknown", "{r:?}");
    }
    // Never written over an input.
    let out = terraslip()
        .args(["terrain", "eval", test.to_str().unwrap()])
        .args(["--model", model.to_str().unwrap()])
        .args(["--plots", dir.path().join("plots").to_str().unwrap()])
        .args(["--windows", model.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(std::fs::read_to_string(&model)
        .unwrap()
        .contains("format_version"));
}

#[test]
fn crossval_headline_is_the_outer_fold_figure_beside_the_plain_baseline() {
    let dir = tempfile::tempdir().unwrap();
    let runs = write_runs(dir.path());
    let out = terraslip()
        .args(["terrain", "crossval"])
        .args(&runs)
        .args(["--folds", "2", "--json"])
        .args(SMALL)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let b = v["baseline"]["accuracy"].as_f64().unwrap();
    assert!(b > 0.5 && b <= 1.0, "{v}");
    assert!(v["confidence"]["ece"].as_f64().is_some(), "{v}");
    assert!(
        stderr.contains("outer folds") && stderr.contains("plain baseline"),
        "{stderr}"
    );
    // The headline comes before the details.
    assert!(
        stderr.find("plain baseline") < stderr.find("single windows"),
        "{stderr}"
    );
}
