//! `terraslip terrain train|eval|crossval` on small synthetic logs: the
//! contract's JSON fields, the plots, and one-line errors on bad input.

use std::path::Path;

use assert_cmd::Command;
use terraslip_terrain::synth::vibration_log;

const NAMES: [&str; 3] = ["asphalt", "grass", "soil"];

fn write_runs(dir: &Path) -> Vec<String> {
    let mut paths = Vec::new();
    for (i, seed) in [1u64, 2].iter().enumerate() {
        for k in 0..3 {
            let p = dir.join(format!("run_{i}_{k}"));
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

/// Runs `cmd`, which must succeed, and parses its stdout as JSON; with its stderr.
fn run_json(cmd: &mut Command) -> (serde_json::Value, String) {
    let out = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    (serde_json::from_slice(&out.stdout).unwrap(), stderr)
}

/// A synthetic run of terrain `k` whose treads read twice the usual 0.5 m/s.
fn write_fast_run(path: &Path, k: usize, seed: u64) {
    let mut log = vibration_log(&NAMES, &[(k, 25.0)], seed, 0.0);
    for w in &mut log.wheels {
        w.v_left *= 2.0;
        w.v_right *= 2.0;
    }
    log.write(path).unwrap();
}

/// Trains a small model on `runs` (1 s windows) into `model`.
fn train_model(runs: &[String], model: &Path, rounds: &str) {
    terraslip()
        .args(["terrain", "train"])
        .args(runs)
        .args([
            "--out",
            model.to_str().unwrap(),
            "--window",
            "1",
            "--rounds",
            rounds,
        ])
        .assert()
        .success();
    assert!(model.exists());
}

#[test]
fn train_then_eval_json_has_the_contract_fields_and_draws_plots() {
    let dir = tempfile::tempdir().unwrap();
    let runs = write_runs(dir.path());
    let model = dir.path().join("model.json");
    train_model(&runs[..3], &model, "40");
    // A spliced test log: asphalt -> soil -> grass.
    let test = dir.path().join("test");
    vibration_log(&NAMES, &[(0, 20.0), (2, 20.0), (1, 20.0)], 99, 0.0)
        .write(&test)
        .unwrap();
    let plots = dir.path().join("plots");
    let out = terraslip()
        .args(["terrain", "eval", test.to_str().unwrap(), &runs[4]])
        .args(["--model", model.to_str().unwrap(), "--json"])
        .args(["--plots", plots.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("exactly one JSON object");
    let windows = v["windows"].as_u64().unwrap();
    assert!(windows > 100, "{v}");
    let acc = v["accuracy"].as_f64().unwrap();
    let filt = v["accuracy_filtered"].as_f64().unwrap();
    assert!(acc > 0.85 && acc <= 1.0, "{acc}");
    assert!(filt > 0.85 && filt <= 1.0, "{filt}");
    assert_eq!(
        v["classes"],
        serde_json::json!(["asphalt", "grass", "soil"])
    );
    let conf = v["confusion"].as_array().unwrap();
    assert_eq!(conf.len(), 3);
    let total: u64 = conf
        .iter()
        .flat_map(|r| r.as_array().unwrap())
        .map(|c| c.as_u64().unwrap())
        .sum();
    assert_eq!(total, windows);
    for f in ["confusion.svg", "confusion_filtered.svg"] {
        let svg = std::fs::read_to_string(plots.join(f)).unwrap();
        assert!(svg.contains("<svg") && svg.contains("asphalt"), "{f}");
    }
    let timelines = std::fs::read_dir(&plots)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with("timeline_")
        })
        .count();
    assert_eq!(timelines, 2);
    // Human-readable output: the confusion table with per-class percentages.
    let text = terraslip()
        .args(["terrain", "eval", test.to_str().unwrap()])
        .args([
            "--model",
            model.to_str().unwrap(),
            "--plots",
            plots.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let s = String::from_utf8_lossy(&text.stdout);
    assert!(
        s.contains("recall") && s.contains("%") && s.contains("Bayesian filter"),
        "{s}"
    );
}

#[test]
fn crossval_reports_leave_runs_out_accuracy() {
    let dir = tempfile::tempdir().unwrap();
    let runs = write_runs(dir.path());
    let (v, _) = run_json(
        terraslip()
            .args(["terrain", "crossval"])
            .args(&runs)
            .args(["--folds", "2", "--window", "1", "--rounds", "40", "--json"]),
    );
    assert_eq!(v["folds"], 2);
    let per_fold = v["fold_accuracy"].as_array().unwrap();
    assert_eq!(per_fold.len(), 2);
    assert!(per_fold.iter().all(|a| a.as_f64().unwrap() > 0.8), "{v}");
    assert!(v["accuracy"].as_f64().unwrap() > 0.85, "{v}");
    assert!(
        v["spliced_accuracy_filtered"].as_f64().unwrap() > 0.85,
        "{v}"
    );
    assert!(
        v["chained_accuracy_filtered"].as_f64().unwrap() > 0.85,
        "{v}"
    );
    assert!(v["chained_changes"].as_u64().unwrap() > 0, "{v}");
    // One entry per run, each named after its log directory.
    let per_run = v["runs"].as_array().unwrap();
    assert_eq!(per_run.len(), runs.len());
    assert!(per_run
        .iter()
        .all(|r| r["frames"].as_u64().unwrap() > 0 && r["log"].is_string()));
}

fn fails_with(cmd: &mut Command, needle: &str) {
    let out = cmd.output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(needle), "expected `{needle}` in: {err}");
}

/// `terrain eval LOG --model MODEL` must fail with one line containing `needle`.
fn eval_fails(log: &Path, model: &Path, plots: &Path, needle: &str) {
    fails_with(
        terraslip()
            .args(["terrain", "eval"])
            .arg(log)
            .arg("--model")
            .arg(model)
            .arg("--plots")
            .arg(plots),
        needle,
    );
}

#[test]
fn bad_input_is_one_line_and_non_zero() {
    let dir = tempfile::tempdir().unwrap();
    let runs = write_runs(dir.path());
    let model = dir.path().join("model.json");
    train_model(&runs[..3], &model, "40");
    let plots = dir.path().join("plots");

    // Model of another format version.
    let old = dir.path().join("old.json");
    let text = std::fs::read_to_string(&model).unwrap();
    std::fs::write(
        &old,
        text.replacen(
            &format!(
                "\"format_version\": {}",
                terraslip_terrain::MODEL_FORMAT_VERSION
            ),
            "\"format_version\": 99",
            1,
        ),
    )
    .unwrap();
    eval_fails(Path::new(&runs[0]), &old, &plots, "version 99");
    // A log with a terrain the model does not know.
    let other = dir.path().join("other");
    vibration_log(&["ice"], &[(0, 10.0)], 5, 0.0)
        .write(&other)
        .unwrap();
    eval_fails(&other, &model, &plots, "ice");
    // A log without an IMU for an IMU model.
    let no_imu = dir.path().join("no_imu");
    let mut log = vibration_log(&NAMES, &[(0, 10.0)], 6, 0.0);
    log.imu.clear();
    log.write(&no_imu).unwrap();
    eval_fails(&no_imu, &model, &plots, "no imu data");
    // Training on two runs with `extra` settings must fail naming `needle`.
    let train_fails = |extra: &[&str], needle: &str| {
        let out = dir.path().join("refused.json");
        fails_with(
            terraslip()
                .args(["terrain", "train", &runs[0], &runs[1]])
                .args(extra)
                .arg("--out")
                .arg(&out),
            needle,
        )
    };
    // A speed copy factor that is not a positive number.
    train_fails(
        &["--speed-copies", "1.2,0"],
        "--speed-copies takes positive speed factors, got 0",
    );
    // Training a camera model from logs without images.
    train_fails(&["--source", "camera"], "camera");
    // A class with too few windows.
    let tiny = dir.path().join("tiny");
    vibration_log(&NAMES, &[(2, 1.2)], 7, 0.0)
        .write(&tiny)
        .unwrap();
    fails_with(
        terraslip()
            .args([
                "terrain",
                "train",
                &runs[0],
                &runs[1],
                tiny.to_str().unwrap(),
            ])
            .args([
                "--window",
                "1",
                "--out",
                dir.path().join("t.json").to_str().unwrap(),
            ]),
        "soil",
    );
    // Nonsense settings.
    fails_with(
        terraslip()
            .args(["terrain", "train", &runs[0], "--window", "0"])
            .args(["--out", dir.path().join("t.json").to_str().unwrap()]),
        "--window",
    );
    // A corrupt imu.csv names file and line.
    let bad = dir.path().join("bad");
    std::fs::create_dir_all(&bad).unwrap();
    std::fs::copy(
        Path::new(&runs[0]).join("wheels.csv"),
        bad.join("wheels.csv"),
    )
    .unwrap();
    std::fs::write(bad.join("imu.csv"), "t,accel_z\n0,9.8\n0.01,oops\n").unwrap();
    eval_fails(&bad, &model, &plots, "imu.csv:3");
    // A region-of-interest file with a wrong type: file, line, reason.
    let roi = dir.path().join("roi.toml");
    std::fs::write(&roi, "length = 0.5\nhorizon_s = \"soon\"\n").unwrap();
    fails_with(
        terraslip()
            .args([
                "terrain",
                "train",
                &runs[0],
                "--source",
                "camera",
                "--roi",
                roi.to_str().unwrap(),
            ])
            .args(["--out", dir.path().join("t.json").to_str().unwrap()]),
        "roi.toml:2",
    );
    // Nothing was written for the failed trainings.
    assert!(!dir.path().join("t.json").exists());
    assert!(!dir.path().join("c.json").exists());
}

#[test]
fn eval_that_scores_no_window_fails_and_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let runs = write_runs(dir.path());
    let model = dir.path().join("model.json");
    train_model(&runs[..3], &model, "40");
    // Half a second of data for a model of 1 s windows.
    let short = dir.path().join("short");
    vibration_log(&NAMES, &[(0, 0.5)], 3, 0.0)
        .write(&short)
        .unwrap();
    eval_fails(
        &short,
        &model,
        &dir.path().join("plots"),
        "scored 0 windows: short: imu.csv covers 0.5 s, shorter than the model's 1 s window",
    );
}

#[test]
fn crossval_refuses_a_run_given_twice_and_fewer_than_two_folds() {
    let dir = tempfile::tempdir().unwrap();
    let runs = write_runs(dir.path());
    let again = format!("{}/", runs[0]);
    fails_with(
        terraslip()
            .args(["terrain", "crossval", &runs[0], &runs[1], &runs[2], &again])
            .args(["--window", "1", "--rounds", "40"]),
        "given twice",
    );
    for folds in ["0", "1"] {
        let out = terraslip()
            .args(["terrain", "crossval"])
            .args(&runs)
            .args(["--folds", folds, "--window", "1"])
            .output()
            .unwrap();
        assert!(!out.status.success(), "--folds {folds} accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("--folds") && err.contains("at least 2"),
            "{err}"
        );
    }
}

#[test]
fn crossval_prints_progress_lines_when_stderr_is_not_a_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let runs = write_runs(dir.path());
    let out = terraslip()
        .env("TERRASLIP_PROGRESS_SECS", "0")
        .args(["terrain", "crossval"])
        .args(&runs)
        .args(["--folds", "2", "--window", "1", "--rounds", "40"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cross-validating (folds done): 2/2"), "{err}");
    assert!(err.contains("reading logs: 6/6"), "{err}");
    // The per-run table and the time to follow a terrain change.
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("a change to a correct filtered label: median"),
        "{text}"
    );
    assert!(text.contains("run_1_2"), "{text}");
}

/// Trains a small model on `runs` into `model`, which must succeed; its stderr.
fn train_stderr(runs: &[String], model: &Path) -> String {
    let out = terraslip()
        .args(["terrain", "train"])
        .args(runs)
        .arg("--out")
        .arg(model)
        .args(["--window", "1", "--rounds", "40"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{err}");
    err
}

#[test]
fn train_reads_the_channels_every_log_has_and_names_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    // Logs with accel_z only and no motor currents (all the format requires).
    let mut bare = Vec::new();
    for k in 0..3 {
        let mut log = vibration_log(&NAMES, &[(k, 20.0)], 40 + k as u64, 0.0);
        log.currents.clear();
        for s in &mut log.imu {
            (s.accel_x, s.accel_y, s.gyro_x, s.gyro_y, s.gyro_z) = (None, None, None, None, None);
        }
        let p = dir.path().join(format!("bare_{k}"));
        log.write(&p).unwrap();
        bare.push(p.to_string_lossy().into_owned());
    }
    let err = train_stderr(&bare, &dir.path().join("bare.json"));
    assert!(
        err.contains("on 3 logs:") && err.contains("reads imu.csv (accel_z)"),
        "{err}"
    );
    assert!(!err.contains("motor currents"), "{err}");
    // One log alone: singular.
    let full = write_runs(dir.path());
    let p = dir.path().join("three_terrains");
    vibration_log(&NAMES, &[(0, 15.0), (1, 15.0), (2, 15.0)], 9, 0.0)
        .write(&p)
        .unwrap();
    let err = train_stderr(
        &[p.to_string_lossy().into_owned()],
        &dir.path().join("one.json"),
    );
    assert!(
        err.contains("on 1 log:") && err.contains("motor currents"),
        "{err}"
    );
    // Logs that differ: the error names the option that makes them alike.
    fails_with(
        terraslip()
            .args(["terrain", "train", &full[0], &bare[1]])
            .args([
                "--out",
                dir.path().join("x.json").to_str().unwrap(),
                "--window",
                "1",
            ]),
        "--channels accel-z",
    );
    fails_with(
        terraslip()
            .args([
                "terrain",
                "train",
                &full[0],
                &bare[1],
                "--channels",
                "accel-z",
            ])
            .args([
                "--out",
                dir.path().join("x.json").to_str().unwrap(),
                "--window",
                "1",
            ]),
        "--no-currents",
    );
    // With both, they train together.
    terraslip()
        .args(["terrain", "train", &full[0], &full[1], &full[2], &bare[0]])
        .args([
            "--channels",
            "accel-z",
            "--no-currents",
            "--window",
            "1",
            "--rounds",
            "5",
        ])
        .args(["--out", dir.path().join("x.json").to_str().unwrap()])
        .assert()
        .success();
}

#[test]
fn crossval_by_manoeuvre_holds_out_the_run_driven_faster_than_its_terrain_was_trained() {
    let dir = tempfile::tempdir().unwrap();
    let runs = write_runs(dir.path());
    // Every run at 0.5 m/s: no run is outside its terrain's speeds.
    fails_with(
        terraslip()
            .args(["terrain", "crossval", "--split", "manoeuvre"])
            .args(&runs)
            .args(["--window", "1", "--rounds", "40"]),
        "no run lies outside the speeds and turn rates",
    );
    // A third grass run, its treads reading twice as fast.
    let fast = dir.path().join("run_fast_grass");
    write_fast_run(&fast, 1, 77);
    let (v, stderr) = run_json(
        terraslip()
            .args(["terrain", "crossval", "--split", "manoeuvre"])
            .args(&runs)
            .arg(&fast)
            .args(["--window", "1", "--rounds", "40", "--json"]),
    );
    assert_eq!(v["split"], "manoeuvre");
    let held = v["held_out"].as_array().unwrap();
    assert_eq!(held.len(), 1, "{v}");
    assert_eq!(held[0]["log"], "run_fast_grass");
    assert!((held[0]["mean_tread_speed"].as_f64().unwrap() - 1.0).abs() < 0.05);
    assert!(held[0]["why"]
        .as_str()
        .unwrap()
        .contains("fastest drive of grass"));
    // Only the held-out run is scored, and it is driven where no training run was.
    assert_eq!(v["runs"].as_array().unwrap().len(), 1);
    assert_eq!(v["outside_envelope_share"].as_f64(), Some(1.0), "{v}");
    assert_eq!(v["runs"][0]["outside_envelope_share"].as_f64(), Some(1.0));
    assert!(
        stderr.contains("split by manoeuvre: 1 runs held out"),
        "{stderr}"
    );
}

#[test]
fn eval_reports_the_share_of_windows_driven_outside_the_training_envelope() {
    let dir = tempfile::tempdir().unwrap();
    let runs = write_runs(dir.path());
    let model = dir.path().join("model.json");
    train_model(&runs[..3], &model, "40");
    let eval = |log: &Path| {
        run_json(
            terraslip()
                .args(["terrain", "eval"])
                .arg(log)
                .arg("--model")
                .arg(&model)
                .arg("--plots")
                .arg(dir.path().join("plots"))
                .arg("--json"),
        )
    };
    // Driven like the training runs: no window outside.
    let (v, _) = eval(Path::new(&runs[4]));
    assert_eq!(v["outside_envelope_share"].as_f64(), Some(0.0), "{v}");
    // The treads at twice the speed: every window outside, said in the text.
    let fast = dir.path().join("fast");
    write_fast_run(&fast, 1, 55);
    let (v, text) = eval(&fast);
    assert_eq!(v["outside_envelope_share"].as_f64(), Some(1.0), "{v}");
    assert_eq!(v["logs"][0]["outside_envelope_share"].as_f64(), Some(1.0));
    assert!(
        text.contains("driven outside the training envelope: 100.0 %"),
        "{text}"
    );
}

#[test]
fn estimate_warns_when_a_slow_drive_gives_the_vibration_model_no_window() {
    let dir = tempfile::tempdir().unwrap();
    let runs = write_runs(dir.path());
    let model = dir.path().join("model.json");
    train_model(&runs[..3], &model, "40");
    // The same run driven at 0.05 m/s: `terrain eval` still scores its
    // windows, the estimator takes none (vibration says little that slowly).
    let mut slow = terraslip_io::DriveLog::read(&runs[3]).unwrap();
    for w in &mut slow.wheels {
        (w.v_left, w.v_right) = (0.05, 0.05);
    }
    let slow_dir = dir.path().join("slow");
    slow.write(&slow_dir).unwrap();
    for (log, warned) in [(Path::new(&runs[3]), false), (slow_dir.as_path(), true)] {
        let est = dir.path().join(format!("est-{warned}"));
        let out = terraslip()
            .args(["estimate", log.to_str().unwrap(), "--terrain-model"])
            .args([model.to_str().unwrap(), "--out", est.to_str().unwrap()])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        let says = err.contains("no window was used, the terrain stays unknown")
            && err.contains("this drive's is 0.05 m/s");
        assert_eq!(says, warned, "{err}");
        let summary: serde_json::Value =
            serde_json::from_slice(&std::fs::read(est.join("summary.json")).unwrap()).unwrap();
        let in_summary = summary["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w.as_str().unwrap().contains("no window was used"));
        assert_eq!(in_summary, warned);
    }
}
