//! Nothing the user gave is written over: every output flag of every
//! command is refused, before anything is read or written, when it names an
//! input or a path inside one (a log directory, a bag directory or file, a
//! parameters, topics, model or scenario file), however the path is spelt.

#![cfg(feature = "ros2")]

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

use assert_cmd::Command;

/// Every file under `dir` with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(p.clone(), fs::read(&p).unwrap());
            }
        }
    }
    out
}

struct World {
    _tmp: tempfile::TempDir,
    root: PathBuf,
    log: PathBuf,
    bag_dir: PathBuf,
    bag_file: PathBuf,
    params: PathBuf,
    topics: PathBuf,
    scenario: PathBuf,
}

/// A copy of the shipped Warthog log, a bag directory, a bag file, a
/// parameters file, a topics file and a scenario file.
fn world() -> World {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().to_path_buf();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/warthog_gravel");
    let log = root.join("gravel");
    fs::create_dir(&log).unwrap();
    for e in fs::read_dir(&src).unwrap() {
        let e = e.unwrap();
        fs::copy(e.path(), log.join(e.file_name())).unwrap();
    }
    let bag_dir = root.join("bag");
    fs::create_dir(&bag_dir).unwrap();
    fs::write(
        bag_dir.join("metadata.yaml"),
        "rosbag2_bagfile_information: {}\n",
    )
    .unwrap();
    fs::write(bag_dir.join("bag_0.mcap"), b"\x89MCAP0\r\n recorded").unwrap();
    let bag_file = root.join("drive.db3");
    fs::write(&bag_file, b"SQLite format 3\0 recorded").unwrap();
    let params = root.join("params.json");
    fs::write(
        &params,
        r#"{"params": {"y_l": 0.6, "y_r": -0.6, "x_c": 0.0, "alpha_l": 1.0, "alpha_r": 1.0}}"#,
    )
    .unwrap();
    let topics = root.join("topics.toml");
    fs::write(&topics, "[wheels]\nseparation = 1.0\n").unwrap();
    let scenario = root.join("scenario.toml");
    fs::write(&scenario, "name = \"mine\"\n").unwrap();
    World {
        _tmp: tmp,
        root,
        log,
        bag_dir,
        bag_file,
        params,
        topics,
        scenario,
    }
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

/// Runs `args`, which must be refused with a one-line reason naming
/// `flag` and "which the command reads", leaving every file as it was.
fn refused(w: &World, args: &[String], flag: &str) {
    let before = snapshot(&w.root);
    let o = Command::cargo_bin("terraslip")
        .unwrap()
        .args(args)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{args:?} must be refused: {err}");
    assert!(
        err.contains(&format!("error: {flag} ")) && err.contains("which the command reads"),
        "{args:?}: {err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(snapshot(&w.root) == before, "{args:?} changed a file");
}

fn args(v: &[&str]) -> Vec<String> {
    v.iter().map(|a| a.to_string()).collect()
}

#[test]
fn estimate_outputs_are_refused_on_or_inside_an_input() {
    let w = world();
    let (log, bag, file) = (s(&w.log), s(&w.bag_dir), s(&w.bag_file));
    let est = s(&w.root.join("est"));
    // The input directory itself, a directory inside it, another spelling.
    refused(&w, &args(&["estimate", &log, "--out", &log]), "--out");
    refused(
        &w,
        &args(&["estimate", &log, "--out", &format!("{log}/est")]),
        "--out",
    );
    let other = format!("{}/x/../gravel/.", s(&w.root));
    refused(&w, &args(&["estimate", &log, "--out", &other]), "--out");
    refused(
        &w,
        &args(&["estimate", &bag, "--out", &format!("{bag}/est")]),
        "--out",
    );
    // --mcap onto the bag, into the bag directory, onto a log's file.
    for (input, mcap) in [
        (&bag, format!("{bag}/bag_0.mcap")),
        (&bag, format!("{bag}/estimate.mcap")),
        (&file, file.clone()),
        (&log, format!("{log}/wheels.csv")),
    ] {
        refused(
            &w,
            &args(&["estimate", input, "--out", &est, "--mcap", &mcap]),
            "--mcap",
        );
    }
    // Its files: --init, --config, --terrain-model, --topics.
    let p = s(&w.params);
    refused(
        &w,
        &args(&["estimate", &log, "--out", &est, "--init", &p, "--mcap", &p]),
        "--mcap",
    );
    let t = s(&w.topics);
    refused(
        &w,
        &args(&[
            "estimate", &bag, "--out", &est, "--topics", &t, "--mcap", &t,
        ]),
        "--mcap",
    );
    refused(
        &w,
        &args(&[
            "estimate", &log, "--out", &est, "--config", &t, "--mcap", &t,
        ]),
        "--mcap",
    );
    refused(
        &w,
        &args(&[
            "estimate",
            &log,
            "--out",
            &est,
            "--terrain-model",
            &p,
            "--mcap",
            &p,
        ]),
        "--mcap",
    );
}

#[test]
fn calibrate_outputs_are_refused_on_or_inside_an_input() {
    let w = world();
    let (log, bag) = (s(&w.log), s(&w.bag_dir));
    let out = s(&w.root.join("p.json"));
    refused(
        &w,
        &args(&["calibrate", &log, "--out", &format!("{log}/pose.csv")]),
        "--out",
    );
    refused(
        &w,
        &args(&["calibrate", &bag, "--out", &format!("{bag}/p.json")]),
        "--out",
    );
    refused(
        &w,
        &args(&[
            "calibrate",
            &log,
            "--out",
            &out,
            "--ros2-params",
            &format!("{log}/pose.csv"),
        ]),
        "--ros2-params",
    );
    refused(
        &w,
        &args(&[
            "calibrate",
            &bag,
            "--out",
            &out,
            "--ros2-params",
            &format!("{bag}/dd.yaml"),
        ]),
        "--ros2-params",
    );
    let t = s(&w.topics);
    refused(
        &w,
        &args(&["calibrate", &bag, "--topics", &t, "--out", &t]),
        "--out",
    );
    let p = s(&w.params);
    refused(
        &w,
        &args(&["calibrate", "validate", &log, "--params", &p, "--plot", &p]),
        "--plot",
    );
    refused(
        &w,
        &args(&[
            "calibrate",
            "validate",
            &log,
            "--params",
            &p,
            "--plot",
            &format!("{log}/v.svg"),
        ]),
        "--plot",
    );
}

#[test]
fn import_simulate_demo_terrain_and_report_outputs_are_refused() {
    let w = world();
    let (log, bag, file) = (s(&w.log), s(&w.bag_dir), s(&w.bag_file));
    refused(&w, &args(&["import", &bag, "--out", &bag]), "--out");
    refused(
        &w,
        &args(&["import", &bag, "--out", &format!("{bag}/log")]),
        "--out",
    );
    refused(&w, &args(&["import", &file, "--out", &file]), "--out");
    let sc = s(&w.scenario);
    refused(&w, &args(&["simulate", &sc, "--out", &sc]), "--out");
    refused(&w, &args(&["simulate", &sc, "--out", &s(&w.root)]), "--out");
    refused(
        &w,
        &args(&["demo", "--scenario", &sc, "--out", &s(&w.root)]),
        "--out",
    );
    refused(
        &w,
        &args(&[
            "terrain",
            "train",
            &log,
            "--out",
            &format!("{log}/model.json"),
        ]),
        "--out",
    );
    let p = s(&w.params);
    refused(
        &w,
        &args(&["terrain", "eval", &log, "--model", &p, "--plots", &log]),
        "--plots",
    );
    // report: the log named in summary.json, and the estimate's own files.
    let est = w.root.join("est");
    fs::create_dir(&est).unwrap();
    fs::write(est.join("estimate.csv"), "t,east,north,yaw,y_l,y_r,x_c\n").unwrap();
    fs::write(
        est.join("summary.json"),
        serde_json::json!({ "log": log }).to_string(),
    )
    .unwrap();
    refused(&w, &args(&["report", &s(&est), "--out", &log]), "--out");
    refused(
        &w,
        &args(&["report", &s(&est), "--out", &format!("{log}/figures")]),
        "--out",
    );
}
