//! `terraslip estimate` as a user runs it: outputs, flags, and bad input
//! (clear one-line error naming file and line, non-zero exit, no NaN, no
//! partial files).

use std::fs;
use std::path::Path;

use assert_cmd::Command;
use terraslip::config::EstimatorConfig;
use terraslip::testkit::{drive, SynthSpec};

fn write_log(dir: &Path, spec: &SynthSpec) {
    let log = drive(spec);
    log.write(dir).unwrap();
}

fn short() -> SynthSpec {
    SynthSpec {
        duration: 120.0,
        terrains: SynthSpec::default().terrains[..2]
            .iter()
            .map(|(t, n, p)| (t * 0.6, n.clone(), *p))
            .collect(),
        ..Default::default()
    }
}

/// A temporary directory holding the short log at `log/` and the output
/// path `out/` (not created).
fn short_log() -> (tempfile::TempDir, std::path::PathBuf, std::path::PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let (log, out) = (tmp.path().join("log"), tmp.path().join("out"));
    write_log(&log, &short());
    (tmp, log, out)
}

/// [`fails`] on `LOG --out OUT` with no other flag.
fn fails_plain(log: &Path, out: &Path) -> String {
    fails(
        &[log.to_str().unwrap(), "--out", out.to_str().unwrap()],
        out,
    )
}

fn estimate() -> Command {
    Command::cargo_bin("terraslip").unwrap()
}

/// Runs a failing estimate and returns its stderr; checks exit status,
/// one line, and that no output file (or temporary) was left behind.
fn fails(args: &[&str], out: &Path) -> String {
    let o = estimate().arg("estimate").args(args).output().unwrap();
    assert!(!o.status.success(), "should fail: {args:?}");
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    if out.exists() {
        let left: Vec<_> = fs::read_dir(out).unwrap().collect();
        assert!(left.is_empty(), "left behind: {left:?}");
    }
    err
}

fn read_rows(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

#[test]
fn writes_estimate_and_summary() {
    let (_tmp, log, out) = short_log();
    let o = estimate()
        .args([
            "estimate",
            log.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args(["--terrain-labels", "--json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let js: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let wheels = fs::read_to_string(log.join("wheels.csv"))
        .unwrap()
        .lines()
        .count()
        - 1;
    assert_eq!(js["rows"].as_u64().unwrap() as usize, wheels);
    assert!((js["duration_s"].as_f64().unwrap() - 120.0).abs() < 1e-6);
    let d = js["icr"]["y_l"].as_f64().unwrap() - js["icr"]["y_r"].as_f64().unwrap();
    assert!((d - 0.73).abs() < 0.03, "final spread {d}");
    let file: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(file["rows"], js["rows"]);

    let (header, rows) = read_rows(&out.join("estimate.csv"));
    let spec_cols =
        "t,east,north,yaw,y_l,y_r,x_c,std_east,std_north,std_yaw,std_y_l,std_y_r,std_x_c,terrain";
    assert_eq!(header[..14].join(","), spec_cols);
    assert_eq!(rows.len(), wheels);
    let ti = header.iter().position(|h| h == "terrain").unwrap();
    assert_eq!(rows[0][ti], "asphalt");
    assert_eq!(rows[rows.len() - 1][ti], "grass");
    for r in &rows {
        for (i, c) in r.iter().enumerate() {
            if i != ti {
                let v: f64 = c.parse().unwrap();
                assert!(v.is_finite());
            }
        }
    }
}

#[test]
fn print_config_is_loadable_toml() {
    let o = estimate()
        .args(["estimate", "--print-config"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).unwrap();
    assert_eq!(
        EstimatorConfig::from_toml(&text).unwrap(),
        EstimatorConfig::default()
    );
    let o = estimate()
        .args(["estimate", "--print-config", "--preset", "ta-iekf"])
        .output()
        .unwrap();
    let c = EstimatorConfig::from_toml(&String::from_utf8(o.stdout).unwrap()).unwrap();
    assert_eq!(
        c.filter.variant,
        terraslip_core::Variant::InnovationAdaptive
    );
    assert_eq!(c.schedule.boost_updates, 5);
}

#[test]
fn missing_wheels_file_is_named() {
    let (_tmp, log, out) = short_log();
    fs::remove_file(log.join("wheels.csv")).unwrap();
    let err = fails_plain(&log, &out);
    assert!(
        err.contains("wheels.csv") && err.contains("missing"),
        "{err}"
    );
}

#[test]
fn missing_column_is_named() {
    let (_tmp, log, out) = short_log();
    fs::write(log.join("wheels.csv"), "t,v_left\n0,0.1\n0.02,0.1\n").unwrap();
    let err = fails_plain(&log, &out);
    assert!(
        err.contains("wheels.csv") && err.contains("v_right"),
        "{err}"
    );
}

/// Replaces line `line` (1-based, header = 1) of a CSV file.
fn corrupt(path: &Path, line: usize, f: impl Fn(&str) -> String) {
    let text = fs::read_to_string(path).unwrap();
    let out: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| if i + 1 == line { f(l) } else { l.to_string() })
        .collect();
    fs::write(path, out.join("\n") + "\n").unwrap();
}

#[test]
fn nan_and_text_cells_name_file_and_line() {
    for (cell, why) in [("NaN", "not finite"), ("fast", "not a number")] {
        let (_tmp, log, out) = short_log();
        corrupt(&log.join("pose.csv"), 7, |l| {
            let mut c: Vec<&str> = l.split(',').collect();
            c[1] = cell;
            c.join(",")
        });
        let err = fails_plain(&log, &out);
        assert!(err.contains("pose.csv:7") && err.contains(why), "{err}");
    }
}

#[test]
fn time_going_backwards_names_line() {
    let (_tmp, log, out) = short_log();
    corrupt(&log.join("wheels.csv"), 50, |l| {
        let mut c: Vec<String> = l.split(',').map(String::from).collect();
        c[0] = "0.5".into();
        c.join(",")
    });
    let err = fails_plain(&log, &out);
    assert!(
        err.contains("wheels.csv:50") && err.contains("backwards"),
        "{err}"
    );
}

#[test]
fn duplicate_timestamps_and_empty_pose_rows_warn_and_run() {
    let (_tmp, log, out) = short_log();
    // Duplicate the 100th wheels row; blank every field of the 5th pose row.
    let wheels = log.join("wheels.csv");
    let text = fs::read_to_string(&wheels).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    let dup = lines[100];
    lines.insert(100, dup);
    fs::write(&wheels, lines.join("\n") + "\n").unwrap();
    corrupt(&log.join("pose.csv"), 6, |l| {
        let t = l.split(',').next().unwrap().to_string();
        format!("{t},,,,,")
    });
    let o = estimate()
        .args([
            "estimate",
            log.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--json",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("repeat the previous timestamp"), "{err}");
    assert!(err.contains("no east/north/yaw were skipped"), "{err}");
    let js: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(js["rows"].as_u64().unwrap() as usize, lines.len() - 2);
}

#[test]
fn no_motion_warns_and_stays_finite() {
    let tmp = tempfile::tempdir().unwrap();
    let (log, out) = (tmp.path().join("log"), tmp.path().join("out"));
    let mut l = drive(&SynthSpec {
        duration: 20.0,
        ..Default::default()
    });
    for w in &mut l.wheels {
        (w.v_left, w.v_right) = (0.0, 0.0);
    }
    l.write(&log).unwrap();
    let o = estimate()
        .args([
            "estimate",
            log.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("never moves"), "{err}");
    let text = fs::read_to_string(out.join("estimate.csv")).unwrap();
    assert!(!text.to_lowercase().contains("nan") && !text.contains("inf"));
}

#[test]
fn bad_flags_and_files_fail_cleanly() {
    let (tmp, log, out) = short_log();
    let (l, o) = (log.to_str().unwrap(), out.to_str().unwrap());

    let err = fails(&[l, "--out", o, "--terrain-model", "m.json"], &out);
    assert!(
        err.contains("--terrain-model") && err.contains("m.json"),
        "{err}"
    );

    let cfg = tmp.path().join("c.toml");
    fs::write(&cfg, "[filter]\nq_spred = 1e-5\n").unwrap();
    let err = fails(&[l, "--out", o, "--config", cfg.to_str().unwrap()], &out);
    assert!(err.contains("c.toml") && err.contains("q_spred"), "{err}");

    let params = tmp.path().join("p.json");
    fs::write(
        &params,
        r#"{"params": {"y_l": 0.1, "y_r": 0.1, "x_c": 0.0}}"#,
    )
    .unwrap();
    let err = fails(&[l, "--out", o, "--init", params.to_str().unwrap()], &out);
    assert!(err.contains("p.json") && err.contains("spread"), "{err}");

    let err = fails(&[l, "--out", o, "--preset", "nope"], &out);
    assert!(err.contains("nope") && err.contains("terraslip"), "{err}");

    fs::remove_file(log.join("terrain.csv")).unwrap();
    let err = fails(&[l, "--out", o, "--terrain-labels"], &out);
    assert!(err.contains("terrain.csv"), "{err}");

    let err = fails(
        &[tmp.path().join("nolog").to_str().unwrap(), "--out", o],
        &out,
    );
    assert!(err.contains("nolog"), "{err}");
}

#[test]
fn init_per_terrain_sets_are_recalled() {
    let tmp = tempfile::tempdir().unwrap();
    let (log, out) = (tmp.path().join("log"), tmp.path().join("out"));
    let spec = short();
    write_log(&log, &spec);
    // Calibrated sets for both terrains, grass deliberately 1 cm off.
    let (a, g) = (spec.terrains[0].2, spec.terrains[1].2);
    let params = tmp.path().join("p.json");
    fs::write(
        &params,
        format!(
            r#"{{"terrains": {{"asphalt": {{"params": {{"y_l": {}, "y_r": {}, "x_c": {}}}}},
                               "grass": {{"params": {{"y_l": {}, "y_r": {}, "x_c": {}}}}}}}}}"#,
            a.y_l,
            a.y_r,
            a.x_c,
            g.y_l + 0.01,
            g.y_r,
            g.x_c
        ),
    )
    .unwrap();
    let o = estimate()
        .args([
            "estimate",
            log.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args([
            "--terrain-labels",
            "--json",
            "--init",
            params.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let js: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let actions: Vec<&str> = js["terrain_changes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["action"].as_str().unwrap())
        .collect();
    assert_eq!(actions, ["recalled", "recalled"], "{js}");
    // Right after entering grass the spread is already the calibrated one.
    let (header, rows) = read_rows(&out.join("estimate.csv"));
    let col = |n: &str| header.iter().position(|h| h == n).unwrap();
    let t_change = spec.terrains[1].0;
    let r = rows
        .iter()
        .find(|r| r[col("t")].parse::<f64>().unwrap() >= t_change + 0.5)
        .unwrap();
    let d: f64 = r[col("y_l")].parse::<f64>().unwrap() - r[col("y_r")].parse::<f64>().unwrap();
    assert!(
        (d - (g.y_l - g.y_r)).abs() < 0.02,
        "spread right after recall {d}"
    );
}

/// Runs `terraslip ARGS`, which must succeed; returns its stderr.
fn succeeds(args: &[&str]) -> String {
    let o = estimate().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{args:?}: {err}");
    err
}

/// `terraslip estimate LOG --out OUT`, then `terraslip report OUT`.
fn estimate_and_report(log: &Path, out: &Path) {
    let (log, out) = (log.to_str().unwrap(), out.to_str().unwrap());
    succeeds(&["estimate", log, "--out", out]);
    succeeds(&["report", out]);
}

/// `terraslip report` draws an estimate against the log named in its
/// summary; a directory without estimate.csv fails naming the file.
#[test]
fn report_draws_an_estimate() {
    let tmp = tempfile::tempdir().unwrap();
    let (log, out) = (tmp.path().join("log"), tmp.path().join("out"));
    // A dense pose reference, as a lidar gives: the 2 s prediction needs one.
    write_log(
        &log,
        &SynthSpec {
            pose_hz: 10.0,
            ..short()
        },
    );
    estimate_and_report(&log, &out);
    let html = fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("2 s prediction error against the pose reference (summary.json's prediction"),
        "{html}"
    );
    assert!(html.contains("Dead reckoning through a pose outage (summary.json"));
    for svg in ["track.svg", "slip.svg", "prediction.svg", "outage.svg"] {
        let text = fs::read_to_string(out.join(svg)).unwrap();
        assert!(text.contains("<svg") && text.contains("polyline"), "{svg}");
    }

    // A damaged prediction.csv is named with its line.
    fs::write(
        out.join("prediction.csv"),
        "t,error_m,no_slip_m\n60,abc,1\n",
    )
    .unwrap();
    let o = estimate()
        .args(["report", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("prediction.csv:2") && err.contains("error_m"),
        "{err}"
    );
    // Without prediction.csv the report says so and draws the rest.
    fs::remove_file(out.join("prediction.csv")).unwrap();
    fs::remove_file(out.join("prediction.svg")).unwrap();
    let err = succeeds(&["report", out.to_str().unwrap()]);
    assert!(err.contains("prediction.csv is missing"), "{err}");
    let html = fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("has no prediction.csv"), "{html}");
    assert!(!out.join("prediction.svg").exists());

    let empty = tmp.path().join("empty");
    fs::create_dir(&empty).unwrap();
    let o = estimate()
        .args(["report", empty.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(err.contains("estimate.csv"), "{err}");
    assert!(
        fs::read_dir(&empty).unwrap().next().is_none(),
        "wrote into {empty:?}"
    );
}

/// report.html's 2 s prediction is summary.json's: the same segments and
/// figures, on the shipped Warthog drive, where the filter's laws (the turn law, the
/// centripetal terms, read at each instant's tread speeds over the 2 s)
/// and its clock offset matter.
#[test]
fn report_shows_the_summarys_prediction() {
    let log = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/warthog_gravel");
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("est");
    estimate_and_report(&log, &out);
    let summary: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let p = &summary["prediction"];
    let m = |v: &serde_json::Value| v.as_f64().unwrap();
    let html = fs::read_to_string(out.join("report.html")).unwrap();
    let figures = format!(
        "over {} segments: mean {:.3} m, p90 {:.3} m with the learned ICRs; mean {:.3} m, p90 {:.3} m with the no-slip model",
        p["segments"],
        m(&p["mean_m"]),
        m(&p["p90_m"]),
        m(&p["no_slip"]["mean_m"]),
        m(&p["no_slip"]["p90_m"]),
    );
    assert!(
        html.contains(&figures),
        "summary.json: {p}\nreport.html: {html}"
    );
    // The series prediction.svg plots: the summary's segments, to the bit.
    let segments = terraslip_io::read_prediction(&out.join("prediction.csv")).unwrap();
    assert_eq!(segments.len() as u64, p["segments"].as_u64().unwrap());
    let scored = terraslip::report::prediction_score(&segments).unwrap();
    assert_eq!(scored.stats.mean_m, m(&p["mean_m"]));
    assert_eq!(scored.stats.rmse_m, m(&p["rmse_m"]));
    assert_eq!(scored.stats.p90_m, m(&p["p90_m"]));
    assert_eq!(scored.no_slip.mean_m, m(&p["no_slip"]["mean_m"]));
}

/// `std_y_l` of `estimate.csv` at the first row of each terrain's stay,
/// run with `--terrain-labels --init` on a file holding a set per terrain,
/// each stating `std` (a JSON object, or nothing when empty).
fn std_y_l_at_terrain_starts(std: &str) -> Vec<f64> {
    let tmp = tempfile::tempdir().unwrap();
    let (log, out) = (tmp.path().join("log"), tmp.path().join("out"));
    let spec = short();
    write_log(&log, &spec);
    let set = |p: &terraslip_core::IcrParams| {
        let std = if std.is_empty() {
            String::new()
        } else {
            format!(r#", "std": {std}"#)
        };
        format!(
            r#"{{"params": {{"y_l": {}, "y_r": {}, "x_c": {}}}{std}}}"#,
            p.y_l, p.y_r, p.x_c
        )
    };
    let params = tmp.path().join("p.json");
    fs::write(
        &params,
        format!(
            r#"{{"terrains": {{"asphalt": {}, "grass": {}}}}}"#,
            set(&spec.terrains[0].2),
            set(&spec.terrains[1].2)
        ),
    )
    .unwrap();
    let (l, o) = (log.to_str().unwrap(), out.to_str().unwrap());
    succeeds(&[
        "estimate",
        l,
        "--out",
        o,
        "--terrain-labels",
        "--init",
        params.to_str().unwrap(),
    ]);
    let (header, rows) = read_rows(&out.join("estimate.csv"));
    let col = |n: &str| header.iter().position(|h| h == n).unwrap();
    let at = |t0: f64| {
        let r = rows
            .iter()
            .find(|r| r[col("t")].parse::<f64>().unwrap() >= t0)
            .unwrap();
        r[col("std_y_l")].parse::<f64>().unwrap()
    };
    spec.terrains.iter().map(|(t, _, _)| at(*t)).collect()
}

#[test]
fn init_per_terrain_sets_start_with_their_stated_std() {
    // Each set states 0.25 m on y_l: the filter starts every terrain that
    // wide, not at the floor `init.calibrated_std` a set stating nothing
    // gets.
    let floor = std_y_l_at_terrain_starts("");
    let full = std_y_l_at_terrain_starts(
        r#"{"y_l": 0.25, "y_r": 0.01, "x_c": 0.01, "alpha_l": 0.01, "alpha_r": 0.01}"#,
    );
    let partial = std_y_l_at_terrain_starts(r#"{"y_l": 0.25}"#);
    for s in &floor {
        assert!(*s < 0.02, "no stated std: the floor, not {s}");
    }
    for s in full.iter().chain(&partial) {
        assert!(
            *s > 0.15,
            "stated 0.25 m on y_l, started at {s}: {full:?} {partial:?}"
        );
    }
}
