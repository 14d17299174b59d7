//! `calibrate` on the Husky recording the repository ships
//! (`data/husky_test1`): GNSS fixes and no usable heading (a position-only
//! reference), with and without the user guide's topics file.
#![cfg(feature = "ros2")]

use std::path::Path;

use assert_cmd::Command;

/// The factor on the controller's `wheel_separation_multiplier` the YAML
/// states, and the radius multipliers it sets (or, with no controller
/// separation stated, the factors on the controller's own).
fn factors(yaml: &str) -> (f64, f64, f64) {
    let after = |key: &str| -> f64 {
        let i = yaml.find(key).unwrap_or_else(|| panic!("{key} in {yaml}")) + key.len();
        // A line the recording cannot make absolute names the factor on
        // the controller's own value.
        let rest = yaml[i..].trim_start();
        rest.strip_prefix("the controller's own x")
            .unwrap_or(rest)
            .split_whitespace()
            .next()
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("a number after {key} in {yaml}"))
    };
    (
        after("factor on the recording's wheel_separation_multiplier:"),
        after("left_wheel_radius_multiplier:"),
        after("right_wheel_radius_multiplier:"),
    )
}

fn calibrate(bag: &Path, topics: Option<&Path>, out: &Path) -> String {
    let yaml = out.join("dd.yaml");
    let mut cmd = Command::cargo_bin("terraslip").unwrap();
    cmd.arg("calibrate")
        .arg(bag)
        .arg("--ros2-params")
        .arg(&yaml)
        .arg("--out")
        .arg(out.join("params.json"));
    if let Some(t) = topics {
        cmd.arg("--topics").arg(t);
    }
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::read_to_string(yaml).unwrap()
}

#[test]
fn the_husky_bag_yields_a_controller_file_with_no_topics_file() {
    let bag = terraslip_io::shared::repo_data("husky_test1");
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    std::fs::create_dir_all(&a).unwrap();
    std::fs::create_dir_all(&b).unwrap();
    let plain = calibrate(&bag, None, &a);
    let topics = dir.path().join("husky.toml");
    std::fs::write(
        &topics,
        "[wheels]\nseparation = 1.040625\n[imu]\nmount_rpy_deg = [90, 0, -90]\n\
         [heading]\ntopic = \"\"\n[meta]\ntrack_width = 0.555\n",
    )
    .unwrap();
    let guided = calibrate(&bag, Some(&topics), &b);
    let (f, l, r) = factors(&plain);
    let (fg, lg, rg) = factors(&guided);
    // The scale S drops out: the same factors with or without the file.
    assert!((f / fg - 1.0).abs() < 0.02, "{f} vs {fg}");
    assert!((l / lg - 1.0).abs() < 0.02 && (r / rg - 1.0).abs() < 0.02);
    // The odometry's turn over the fixes' (what the course check,
    // scripts/ros2-course-check.py, measures as 0.980): spread / (mean
    // speed factor x S), within 2 % of it (the windows alone: 1.034 ± 0.10).
    let turn = f / (0.5 * (l + r));
    assert!((turn / 0.98 - 1.0).abs() < 0.02, "turn factor {turn}");
    assert!(
        plain.contains(&format!(
            "# {turn:.4} with the radius multipliers left at 1"
        )),
        "{plain}"
    );
    let pf: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("params.json")).unwrap()).unwrap();
    let notes = pf["notes"].to_string();
    assert!(notes.contains("position-only reference"), "{notes}");
    // Both figures and the combination the file carries, with 1-sigmas.
    let tf = &pf["turn_factor"];
    let (w, c) = (&tf["windows_std"], &tf["course_check_std"]);
    assert!(c.as_f64().unwrap() < w.as_f64().unwrap(), "{tf}");
    assert!(
        (tf["combined"].as_f64().unwrap() - turn).abs() < 1e-3,
        "{tf}"
    );
    // `calibrate validate` on the position-only bag: the 2 s prediction,
    // start headings profiled out, stated in the output.
    let validate = |extra: &[&str]| {
        Command::cargo_bin("terraslip")
            .unwrap()
            .args(["calibrate", "validate"])
            .arg(&bag)
            .arg("--params")
            .arg(a.join("params.json"))
            .args(extra)
            .output()
            .unwrap()
    };
    let o = validate(&["--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let p = &v["prediction"];
    assert!(p["segments"].as_u64().unwrap() > 300, "{v}");
    assert!(
        p["start_heading"].as_str().unwrap().starts_with("profiled"),
        "{v}"
    );
    let (m, n) = (
        p["mean_m"].as_f64().unwrap(),
        p["no_slip"]["mean_m"].as_f64().unwrap(),
    );
    assert!(m > 0.0 && m <= n * 1.01, "{v}");
    // What needs headings is refused with the reason, before any output.
    for (flag, value, reason) in [
        (
            "--time-offset",
            "auto".to_string(),
            "regresses heading changes",
        ),
        (
            "--plot",
            a.join("v.svg").display().to_string(),
            "draws segment scores",
        ),
    ] {
        let o = validate(&[flag, &value]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(reason), "{flag}: {err}");
        assert!(o.stdout.is_empty());
    }
    assert!(!a.join("v.svg").exists());
}
