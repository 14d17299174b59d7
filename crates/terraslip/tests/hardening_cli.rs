//! Broken, hostile and extreme input through the commands, as a new user
//! meets it: never a panic, one line naming the file and the line or field
//! and what to do, a non-zero exit, and no output written over an input or
//! left half-written.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Output;

use assert_cmd::Command;

fn terraslip(args: &[&str]) -> Output {
    Command::cargo_bin("terraslip")
        .unwrap()
        .args(args)
        .output()
        .unwrap()
}

/// Runs a command that must fail cleanly; returns its stderr.
fn fails(args: &[&str]) -> String {
    let o = terraslip(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(
        o.status.code(),
        Some(1),
        "{args:?} must fail cleanly: {err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    err
}

/// A copy of the shipped Warthog drive in a temporary directory.
fn gravel(tmp: &Path) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/warthog_gravel");
    let dst = tmp.join("gravel");
    fs::create_dir_all(&dst).unwrap();
    for e in fs::read_dir(&src).unwrap() {
        let e = e.unwrap();
        fs::copy(e.path(), dst.join(e.file_name())).unwrap();
    }
    dst
}

/// Replaces line `n` (1-based) of `file` with `f(old line)`.
fn edit_line(file: &Path, n: usize, f: impl Fn(&str) -> String) {
    let text = fs::read_to_string(file).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[n - 1] = f(&lines[n - 1]);
    fs::write(file, lines.join("\n") + "\n").unwrap();
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn calibrate_with_an_extreme_wheel_speed_does_not_panic() {
    let tmp = tempfile::tempdir().unwrap();
    let log = gravel(tmp.path());
    edit_line(&log.join("wheels.csv"), 2000, |l| {
        let t = l.split(',').next().unwrap();
        format!("{t},1e308,1e308")
    });
    let out = tmp.path().join("p.json");
    let e = fails(&["calibrate", s(&log), "--out", s(&out)]);
    assert!(
        e.contains("wheels.csv:2000:") && e.contains("`v_left`"),
        "{e}"
    );
    assert!(!out.exists());
}

#[test]
fn outputs_never_overwrite_inputs() {
    let tmp = tempfile::tempdir().unwrap();
    let log = gravel(tmp.path());
    let before = fs::read(log.join("wheels.csv")).unwrap();
    let e = fails(&["calibrate", s(&log), "--out", s(&log.join("wheels.csv"))]);
    assert!(e.contains("which the command reads"), "{e}");
    assert_eq!(fs::read(log.join("wheels.csv")).unwrap(), before);
    // The same file reached through another spelling of the path.
    let other = log.join(".").join("pose.csv");
    let e = fails(&["calibrate", s(&log), "--out", s(&other)]);
    assert!(e.contains("which the command reads"), "{e}");
    // estimate: its --init is one of its inputs.
    let init = tmp.path().join("summary.json");
    fs::write(
        &init,
        r#"{"params": {"y_l": 0.6, "y_r": -0.6, "x_c": 0.0, "alpha_l": 1.0, "alpha_r": 1.0}}"#,
    )
    .unwrap();
    let e = fails(&[
        "estimate",
        s(&log),
        "--out",
        s(tmp.path()),
        "--init",
        s(&init),
    ]);
    assert!(e.contains("which the command reads"), "{e}");
}

#[test]
fn a_held_output_directory_is_reported_and_stale_temporaries_are_removed() {
    let tmp = tempfile::tempdir().unwrap();
    let log = gravel(tmp.path());
    let out = tmp.path().join("est");
    fs::create_dir_all(&out).unwrap();
    // This test's own process holds the directory.
    fs::write(out.join(".terraslip.lock"), std::process::id().to_string()).unwrap();
    let e = fails(&["estimate", s(&log), "--out", s(&out)]);
    assert!(e.contains("another run (process"), "{e}");
    assert!(!out.join("estimate.csv").exists());
    // A run killed earlier left its lock and temporaries behind.
    fs::write(out.join(".terraslip.lock"), "4294967295").unwrap();
    fs::write(out.join(".estimate.csv.4294967295.tmp"), "half").unwrap();
    fs::write(out.join(".summary.json.4294967295.tmp"), "{").unwrap();
    fs::write(out.join(".prediction.csv.4294967295.tmp"), "t,").unwrap();
    let o = terraslip(&["estimate", s(&log), "--out", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut left: Vec<String> = fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["estimate.csv", "prediction.csv", "summary.json"]);
}

/// Two different logs estimated into one directory at the same time: each
/// run either writes its files or is told the directory is held, and the
/// summary always describes the estimate.csv and prediction.csv beside it.
#[test]
fn concurrent_runs_never_leave_a_mismatched_pair() {
    let tmp = tempfile::tempdir().unwrap();
    let long = gravel(tmp.path());
    let short = tmp.path().join("short");
    fs::create_dir_all(&short).unwrap();
    for f in ["pose.csv", "meta.toml", "terrain.csv"] {
        fs::copy(long.join(f), short.join(f)).unwrap();
    }
    let wheels = fs::read_to_string(long.join("wheels.csv")).unwrap();
    let half: Vec<&str> = wheels.lines().take(6000).collect();
    fs::write(short.join("wheels.csv"), half.join("\n") + "\n").unwrap();
    let out = tmp.path().join("est");
    let bin = assert_cmd::cargo::cargo_bin("terraslip");
    for _ in 0..4 {
        let kids: Vec<_> = [&long, &short]
            .iter()
            .map(|l| {
                std::process::Command::new(&bin)
                    .args(["estimate", s(l), "--out", s(&out)])
                    .stderr(std::process::Stdio::piped())
                    .spawn()
                    .unwrap()
            })
            .collect();
        for k in kids {
            let o = k.wait_with_output().unwrap();
            let err = String::from_utf8_lossy(&o.stderr);
            assert!(o.status.success() || err.contains("another run"), "{err}");
        }
        let summary: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
        let rows = fs::read_to_string(out.join("estimate.csv"))
            .unwrap()
            .lines()
            .count()
            - 1;
        assert_eq!(summary["rows"].as_u64(), Some(rows as u64));
        let starts = fs::read_to_string(out.join("prediction.csv"))
            .unwrap()
            .lines()
            .count()
            - 1;
        assert_eq!(
            summary["prediction"]["segments"].as_u64(),
            Some(starts as u64)
        );
    }
}

#[test]
fn an_absurd_track_width_blames_meta_toml() {
    let tmp = tempfile::tempdir().unwrap();
    let log = gravel(tmp.path());
    fs::write(log.join("meta.toml"), "track_width = 1e300\n").unwrap();
    let e = fails(&["estimate", s(&log), "--out", s(&tmp.path().join("o"))]);
    assert!(
        e.contains("meta.toml") && e.contains("`track_width`"),
        "{e}"
    );
    assert!(!e.contains("wheels.csv"), "{e}");
}

#[test]
fn os_errors_are_said_once() {
    let tmp = tempfile::tempdir().unwrap();
    let log = gravel(tmp.path());
    let missing = tmp.path().join("missing.json");
    let e = fails(&[
        "estimate",
        s(&log),
        "--out",
        s(&tmp.path().join("o")),
        "--init",
        s(&missing),
    ]);
    assert_eq!(e.matches("os error").count(), 1, "{e}");
    assert!(e.contains("missing.json"), "{e}");
}

/// A drive whose pose clock runs 0.8 s behind the wheels: the offset search
/// stops at its +-0.5 s bound, which is a warning, not a quiet result.
#[test]
fn a_time_offset_at_the_search_bound_is_a_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let log = gravel(tmp.path());
    let pose = fs::read_to_string(log.join("pose.csv")).unwrap();
    let mut out = String::new();
    for (i, l) in pose.lines().enumerate() {
        if i == 0 {
            out.push_str(l);
        } else {
            let (t, rest) = l.split_once(',').unwrap();
            let t: f64 = t.parse().unwrap();
            out.push_str(&format!("{},{rest}", t + 0.8));
        }
        out.push('\n');
    }
    fs::write(log.join("pose.csv"), out).unwrap();
    let params = tmp.path().join("p.json");
    let o = terraslip(&["calibrate", s(&log), "--out", s(&params), "--method", "lm"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.lines()
            .any(|l| l.starts_with("warning:") && l.contains("edge of its search range")),
        "{err}"
    );
}

/// The message catalogue: every error from bad input names the file and
/// the line or field, and says what to do (after a `;`).
#[test]
fn every_error_names_the_file_and_says_what_to_do() {
    let tmp = tempfile::tempdir().unwrap();
    let base = gravel(tmp.path());
    let out = tmp.path().join("o");
    let case = |name: &str, file: &str, text: &str| {
        let log = tmp.path().join(name);
        fs::create_dir_all(&log).unwrap();
        for f in ["wheels.csv", "pose.csv", "meta.toml"] {
            fs::copy(base.join(f), log.join(f)).unwrap();
        }
        fs::write(log.join(file), text).unwrap();
        (log, file.to_string())
    };
    let cases = [
        case("dup", "wheels.csv", "t,v_left,v_left\n0,1,1\n"),
        case("nan", "wheels.csv", "t,v_left,v_right\n0,x,1\n"),
        case("inf", "wheels.csv", "t,v_left,v_right\n0,inf,1\n"),
        case("empty", "wheels.csv", "t,v_left,v_right\n0,,1\n"),
        case("back", "wheels.csv", "t,v_left,v_right\n1,0,0\n0,0,0\n"),
        case("cols", "wheels.csv", "t,v_left\n0,1\n"),
        case("ragged", "wheels.csv", "t,v_left,v_right\n0,1\n"),
        case(
            "binary",
            "wheels.csv",
            "t,v_left,v_right\n0,\u{0}\u{fffd},1\n",
        ),
        case("nohead", "wheels.csv", ""),
        case("norows", "wheels.csv", "t,v_left,v_right\n"),
        case("std", "pose.csv", "t,east,north,yaw,std_xy\n0,0,0,0,-1\n"),
        case("huge", "pose.csv", "t,east,north,yaw\n0,1e300,0,0\n"),
        case("key", "meta.toml", "wheel_separation = 1\n"),
        case("toml", "meta.toml", "track_width = \n"),
        case("width", "meta.toml", "track_width = -1\n"),
    ];
    for (log, file) in &cases {
        let e = fails(&["estimate", s(log), "--out", s(&out)]);
        assert!(e.contains(file.as_str()), "names {file}: {e}");
        assert!(e.contains("; "), "says what to do: {e}");
    }
    let missing = tmp.path().join("nolog");
    fs::create_dir_all(&missing).unwrap();
    let e = fails(&["estimate", s(&missing), "--out", s(&out)]);
    assert!(e.contains("wheels.csv") && e.contains("; "), "{e}");
    let bad_params = tmp.path().join("bad.json");
    fs::write(&bad_params, "{\"params\": 3}").unwrap();
    let e = fails(&[
        "estimate",
        s(&base),
        "--out",
        s(&out),
        "--init",
        s(&bad_params),
    ]);
    assert!(e.contains("bad.json:1"), "{e}");
}

#[test]
fn a_frame_too_small_to_classify_is_named() {
    use terraslip_terrain::{synth::camera_log, Source, TerrainModel, TrainOptions};
    let tmp = tempfile::tempdir().unwrap();
    let logs: Vec<_> = (0..2)
        .map(|k| {
            camera_log(
                &tmp.path().join(format!("run{k}")),
                &["a", "b"],
                &[(k, 2)],
                3,
                1,
                1,
            )
            .unwrap()
        })
        .collect();
    let opts = TrainOptions {
        source: Source::Camera,
        ..TrainOptions::default()
    };
    let e = TerrainModel::train(&logs, &opts).unwrap_err().to_string();
    assert!(e.contains("00000.png") && e.contains("1x1"), "{e}");
}
