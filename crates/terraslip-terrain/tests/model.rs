//! TerrainModel end to end on synthetic logs: training, held-out accuracy,
//! the Bayesian filter on spliced logs, the camera path with the change
//! detector, and every bad-input case of the issue.

use terraslip_io::DriveLog;
use terraslip_terrain::synth::{camera_log, vibration_log};
use terraslip_terrain::*;

const NAMES: [&str; 3] = ["asphalt", "grass", "soil"];

fn imu_runs(seed: u64) -> Vec<DriveLog> {
    (0..3)
        .map(|k| vibration_log(&NAMES, &[(k, 40.0)], seed + k as u64, 0.0))
        .collect()
}

fn fast_opts() -> TrainOptions {
    let mut o = TrainOptions::default();
    o.vibration.window_s = 1.0;
    o.classifier.boost.rounds = 40;
    o
}

#[test]
fn imu_model_classifies_unseen_runs_and_filters_a_spliced_log() {
    let model = TerrainModel::train(&imu_runs(1), &fast_opts()).unwrap();
    assert_eq!(model.classes, ["asphalt", "grass", "soil"]);
    // Unseen runs, spliced: grass -> soil -> asphalt -> grass.
    let test = vibration_log(
        &NAMES,
        &[(1, 30.0), (2, 30.0), (0, 30.0), (1, 30.0)],
        99,
        5.0,
    );
    let s = score_log(&model, &test).unwrap();
    assert!(s.raw.total() > 150, "windows {}", s.raw.total());
    assert!(s.raw.accuracy() > 0.9, "raw {}", s.raw.accuracy());
    assert!(
        s.filtered.accuracy() > 0.95,
        "filtered {}",
        s.filtered.accuracy()
    );
    // The timeline is causal and the probabilities are distributions.
    let tl = model.classify_log(&test).unwrap();
    assert!(tl.frames.windows(2).all(|w| w[0].0 < w[1].0));
    assert!(tl
        .frames
        .iter()
        .all(|(_, p)| (p.iter().sum::<f64>() - 1.0).abs() < 1e-9));
    assert!(
        tl.frames[0].0 >= 5.0 + 1.0 - 0.02,
        "first window ends after one window"
    );
}

#[test]
fn every_classifier_kind_trains_and_round_trips_through_json() {
    let dir = tempfile::tempdir().unwrap();
    let runs = imu_runs(3);
    let test = vibration_log(&NAMES, &[(0, 10.0), (1, 10.0), (2, 10.0)], 77, 0.0);
    for kind in [
        ClassifierKind::Tree,
        ClassifierKind::Knn,
        ClassifierKind::Boost,
    ] {
        let mut o = fast_opts();
        o.classifier.kind = kind;
        let m = TerrainModel::train(&runs, &o).unwrap();
        let path = dir.path().join("m.json");
        m.save(&path).unwrap();
        let back = TerrainModel::load(&path).unwrap();
        assert_eq!(back, m);
        let s = score_log(&back, &test).unwrap();
        assert!(s.raw.accuracy() > 0.85, "{kind:?}: {}", s.raw.accuracy());
    }
    // The paper's feature set trains too (three features).
    let mut o = fast_opts();
    o.vibration = VibrationConfig::paper();
    o.classifier.kind = ClassifierKind::Tree;
    let m = TerrainModel::train(&runs, &o).unwrap();
    assert_eq!(m.feature_names.len(), 3);
}

#[test]
fn model_from_another_version_or_other_classes_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let m = TerrainModel::train(&imu_runs(5), &fast_opts()).unwrap();
    let path = dir.path().join("m.json");
    m.save(&path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let current = format!("\"format_version\": {MODEL_FORMAT_VERSION}");
    let old = text.replacen(&current, "\"format_version\": 1", 1);
    assert_ne!(old, text);
    let p0 = dir.path().join("old.json");
    std::fs::write(&p0, old).unwrap();
    let e = TerrainModel::load(&p0).unwrap_err();
    assert!(
        matches!(
            e,
            TerrainError::ModelVersion {
                found: 1,
                expected: MODEL_FORMAT_VERSION,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("old.json"));

    let other = vec!["asphalt".to_string(), "ice".to_string()];
    let e = TerrainModel::load_for_classes(&path, &other).unwrap_err();
    assert!(matches!(e, TerrainError::ClassMismatch { .. }), "{e}");
    let same: Vec<String> = ["soil", "asphalt", "grass"].map(String::from).to_vec();
    assert!(TerrainModel::load_for_classes(&path, &same).is_ok());

    // Not JSON, JSON but not a model, a model with a broken classifier.
    let p1 = dir.path().join("garbage.json");
    std::fs::write(&p1, "{not json").unwrap();
    assert!(matches!(
        TerrainModel::load(&p1),
        Err(TerrainError::ModelFile { .. })
    ));
    std::fs::write(&p1, format!("{{{current}}}")).unwrap();
    assert!(matches!(
        TerrainModel::load(&p1),
        Err(TerrainError::ModelFile { .. })
    ));
    let broken = text.replacen("\"classes\": [", "\"classes\": [\n    \"extra\",", 1);
    std::fs::write(&p1, broken).unwrap();
    let e = TerrainModel::load(&p1).unwrap_err();
    assert!(matches!(e, TerrainError::ModelFile { .. }), "{e}");
    assert!(TerrainModel::load(dir.path().join("missing.json")).is_err());
}

#[test]
fn logs_without_the_needed_source_are_clear_errors() {
    let m = TerrainModel::train(&imu_runs(7), &fast_opts()).unwrap();
    let mut no_imu = vibration_log(&NAMES, &[(0, 10.0)], 8, 0.0);
    no_imu.imu.clear();
    let e = m.classify_log(&no_imu).unwrap_err();
    assert!(
        matches!(e, TerrainError::MissingSource { sensor: "imu", .. }),
        "{e}"
    );
    // An accel_z-only log for a six-channel model.
    let mut z_only = vibration_log(&NAMES, &[(0, 10.0)], 8, 0.0);
    for s in &mut z_only.imu {
        s.gyro_x = None;
    }
    let e = m.classify_log(&z_only).unwrap_err();
    assert!(e.to_string().contains("gyro_x"), "{e}");
    // The wrong IMU rate.
    let mut slow = vibration_log(&NAMES, &[(0, 20.0)], 8, 0.0);
    slow.imu = slow.imu.into_iter().step_by(2).collect();
    let e = m.classify_log(&slow).unwrap_err();
    assert!(e.to_string().contains("Hz"), "{e}");
    // Training on unlabelled logs.
    let mut unlabelled = imu_runs(9);
    unlabelled[1].terrain.clear();
    let e = TerrainModel::train(&unlabelled, &fast_opts()).unwrap_err();
    assert!(matches!(e, TerrainError::MissingLabels { .. }), "{e}");
    // A camera model on a log without images.
    let mut o = fast_opts();
    o.source = Source::Camera;
    let e = TerrainModel::train(&imu_runs(9), &o).unwrap_err();
    assert!(
        matches!(
            e,
            TerrainError::MissingSource {
                sensor: "camera",
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn classes_with_too_few_samples_cannot_train() {
    let mut runs = imu_runs(11);
    // 1.5 s of soil: a single 1 s window.
    runs[2] = vibration_log(&NAMES, &[(2, 1.5)], 12, 0.0);
    let e = TerrainModel::train(&runs, &fast_opts()).unwrap_err();
    assert!(
        matches!(e, TerrainError::Training(ref m) if m.contains("soil")),
        "{e}"
    );
}

#[test]
fn camera_model_reaches_95_percent_and_flags_changes_within_one_frame() {
    let dir = tempfile::tempdir().unwrap();
    let names = ["gravel", "grass", "soil", "paving"];
    let train = camera_log(
        &dir.path().join("train"),
        &names,
        &[(0, 12), (1, 12), (2, 8), (0, 6), (3, 12), (0, 4)],
        1,
        96,
        72,
    )
    .unwrap();
    let test = camera_log(
        &dir.path().join("test"),
        &names,
        &[(2, 8), (0, 8), (3, 8), (1, 8)],
        2,
        96,
        72,
    )
    .unwrap();
    for features in [
        VisionFeatureSet::HistLbp,
        VisionFeatureSet::Sfta,
        VisionFeatureSet::Both,
    ] {
        let mut o = fast_opts();
        o.source = Source::Camera;
        o.vision.features = features;
        let m = TerrainModel::train(std::slice::from_ref(&train), &o).unwrap();
        let s = score_log(&m, &test).unwrap();
        assert_eq!(s.raw.total(), 32);
        assert!(
            s.raw.accuracy() >= 0.95,
            "{features:?}: {}",
            s.raw.accuracy()
        );
        if features == VisionFeatureSet::Both {
            assert_eq!(s.change.changes, 3);
            assert_eq!(s.change.detected, 3, "{:?}", s.change);
            assert!(s.change.false_alarms <= 1, "{:?}", s.change);
        }
    }
}

#[test]
fn corrupt_frame_in_a_log_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let names = ["a", "b"];
    let log = camera_log(dir.path(), &names, &[(0, 4), (1, 4)], 3, 32, 24).unwrap();
    let mut o = fast_opts();
    o.source = Source::Camera;
    let m = TerrainModel::train(std::slice::from_ref(&log), &o).unwrap();
    std::fs::write(
        dir.path().join("images/00002.png"),
        b"\x89PNG\r\n\x1a\ntruncated",
    )
    .unwrap();
    let e = m.classify_log(&log).unwrap_err();
    assert!(matches!(e, TerrainError::Image { .. }), "{e}");
    assert!(e.to_string().contains("00002.png"), "{e}");
    std::fs::remove_file(dir.path().join("images/00003.png")).unwrap();
    let e = TerrainModel::train(&[log], &o).unwrap_err();
    assert!(e.to_string().contains("0000"), "{e}");
}

#[test]
fn crossval_leaves_whole_runs_out() {
    let mut runs = imu_runs(20);
    runs.extend(imu_runs(30));
    for (i, r) in runs.iter_mut().enumerate() {
        r.dir = format!("run{i}").into();
    }
    let folds = crossval::run_folds(&runs, 2);
    assert_eq!(folds.len(), 2);
    // Every terrain in every fold, no run in two folds.
    for f in &folds {
        let mut t: Vec<_> = f
            .iter()
            .map(|&i| runs[i].terrain[0].terrain.clone())
            .collect();
        t.sort();
        t.dedup();
        assert_eq!(t.len(), 3);
    }
    let rep = crossval(&runs, &fast_opts(), 2, |_, _| {}).unwrap();
    assert_eq!(rep.folds, 2);
    assert!(rep.raw.accuracy() > 0.9, "{}", rep.raw.accuracy());
    assert!(
        rep.spliced_filtered.accuracy() > 0.9,
        "{}",
        rep.spliced_filtered.accuracy()
    );
    assert_eq!(
        rep.raw.total() as usize,
        rep.raw.counts.iter().flatten().sum::<u64>() as usize
    );
    // One score per run, in input order, adding up to the raw confusion.
    assert_eq!(rep.runs.len(), runs.len());
    assert!(rep.runs.iter().zip(&runs).all(|(s, r)| s.log == r.name()));
    let frames: usize = rep.runs.iter().map(|s| s.frames).sum();
    assert_eq!(frames, rep.raw.total() as usize);
    assert!(rep
        .runs
        .iter()
        .all(|s| s.raw_accuracy > 0.8 && s.terrain == s.most_predicted));
    // Two folds of three terrains: two changes spliced into each fold's log;
    // the chained outputs change terrain at every seam (a b c a b c).
    assert_eq!(rep.spliced_changes, 4);
    assert_eq!(rep.chained_changes, 5);
    assert_eq!(rep.chained_filtered.total(), rep.raw.total());
    assert!(rep.chained_filtered.accuracy() > 0.9);
    assert!(rep.spliced_filtered_settled.total() < rep.spliced_filtered.total());
    assert!(rep.spliced_filtered_settled.accuracy() >= rep.spliced_filtered.accuracy());

    // Leave-one-run-out: a spliced "log" is a single run, no change to
    // test; the chained outputs still change terrain at every seam.
    let loo = crossval(&runs, &fast_opts(), runs.len(), |_, _| {}).unwrap();
    assert_eq!(loo.folds, runs.len());
    assert_eq!(loo.spliced_changes, 0);
    assert_eq!(loo.chained_changes, 5);
    assert_eq!(loo.spliced_filtered_settled, loo.spliced_filtered);
}

#[test]
fn current_model_records_its_channels_and_refuses_logs_without_currents() {
    let dir = tempfile::tempdir().unwrap();
    // Every training log has currents: the default model reads them.
    let m = TerrainModel::train(&imu_runs(11), &fast_opts()).unwrap();
    let Features::Vibration { config, .. } = &m.features else {
        panic!("imu model");
    };
    assert!(config.currents && config.channels == ChannelSet::All);
    assert!(m.feature_names.iter().any(|n| n == "current_log_mean"));
    // The current beyond the robot's baseline, whose fit the model holds.
    assert!(m.feature_names.iter().any(|n| n == "current_excess"));
    assert!(m
        .speed_normalisation
        .as_ref()
        .is_some_and(|s| s.current_baseline.is_some()));
    assert!(vibration::SPEED_FLOOR_CANDIDATES.contains(&config.speed_norm_min));
    let path = dir.path().join("currents.json");
    m.save(&path).unwrap();
    let back = TerrainModel::load(&path).unwrap();
    assert_eq!(back, m);
    let test = vibration_log(&NAMES, &[(2, 10.0), (0, 10.0), (1, 10.0)], 78, 0.0);
    assert!(score_log(&back, &test).unwrap().raw.accuracy() > 0.85);

    // A log without currents, for a model that reads them.
    let mut no_current = test.clone();
    no_current.currents.clear();
    let e = back.classify_log(&no_current).unwrap_err();
    assert!(
        matches!(
            e,
            TerrainError::MissingSource {
                sensor: "currents",
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("current_left"), "{e}");
    // The IMU-only model, when asked for, reads it.
    let mut o = fast_opts();
    o.currents = Some(false);
    let imu_only = TerrainModel::train(&imu_runs(11), &o).unwrap();
    assert!(!imu_only
        .feature_names
        .iter()
        .any(|n| n.starts_with("current")));
    assert!(imu_only.classify_log(&no_current).is_ok());

    // Training logs that differ: an error naming one with and one without.
    let mut mixed = imu_runs(11);
    mixed[1].currents.clear();
    mixed[1].dir = "soil_run".into();
    let e = TerrainModel::train(&mixed, &fast_opts()).unwrap_err();
    assert!(
        e.to_string().contains("soil_run") && e.to_string().contains("--no-currents"),
        "{e}"
    );
    // No log has currents: an IMU-only model, no error.
    let mut none = imu_runs(11);
    none.iter_mut().for_each(|l| l.currents.clear());
    let m = TerrainModel::train(&none, &fast_opts()).unwrap();
    assert!(!m.feature_names.iter().any(|n| n.starts_with("current")));

    // IMU channels: accel_z alone when the logs have only that; mixed
    // logs name the channel option.
    let mut z_only = imu_runs(11);
    z_only
        .iter_mut()
        .flat_map(|l| &mut l.imu)
        .for_each(|s| s.gyro_y = None);
    let m = TerrainModel::train(&z_only, &fast_opts()).unwrap();
    assert!(m.feature_names.iter().all(|n| !n.starts_with("gyro_y")));
    assert!(m.feature_names.iter().any(|n| n == "accel_z_log_var"));
    let mut mixed = imu_runs(11);
    mixed[2].imu.iter_mut().for_each(|s| s.gyro_y = None);
    let e = TerrainModel::train(&mixed, &fast_opts()).unwrap_err();
    assert!(e.to_string().contains("--channels accel-z"), "{e}");
    // A floor given by hand is kept.
    let mut o = fast_opts();
    o.speed_floor = Some(0.3);
    let m = TerrainModel::train(&imu_runs(11), &o).unwrap();
    assert!(
        matches!(&m.features, Features::Vibration { config, .. } if config.speed_norm_min == 0.3)
    );
}

/// `log` driven at `v` m/s instead of 0.5, its vibration scaled with the
/// speed (amplitude ∝ v, so every band power ∝ v²).
fn at_speed(mut log: DriveLog, v: f64) -> DriveLog {
    let k = v / 0.5;
    for s in &mut log.imu {
        s.accel_z = vibration::STANDARD_GRAVITY + k * (s.accel_z - vibration::STANDARD_GRAVITY);
        for c in [
            &mut s.accel_x,
            &mut s.accel_y,
            &mut s.gyro_x,
            &mut s.gyro_y,
            &mut s.gyro_z,
        ] {
            *c = c.map(|x| k * x);
        }
    }
    for w in &mut log.wheels {
        w.v_left = v;
        w.v_right = v;
    }
    log
}

#[test]
fn speed_normalised_model_learns_the_slopes_from_training_runs_only() {
    let dir = tempfile::tempdir().unwrap();
    let mut o = fast_opts();
    o.vibration.speed_norm = true;
    // Every terrain at two speeds: power ∝ v², so the log powers rise as 2 ln v.
    let runs: Vec<DriveLog> = (0..3)
        .flat_map(|k| {
            [0.3, 0.6].map(|v| at_speed(vibration_log(&NAMES, &[(k, 30.0)], 20 + k as u64, 0.0), v))
        })
        .collect();
    let m = TerrainModel::train(&runs, &o).unwrap();
    let sn = m.speed_normalisation.as_ref().expect("slopes recorded");
    for (name, b) in m.feature_names.iter().zip(&sn.slopes) {
        let want = if name.ends_with("_log_var")
            || (name.contains("_band") && !name.ends_with("_share"))
        {
            2.0
        } else {
            // log(σ_az / v) does not move when σ ∝ v; shares, moments and
            // speed terms are not normalised.
            0.0
        };
        assert!((b - want).abs() < 0.15, "{name}: slope {b}, want {want}");
    }
    // Unseen, and three times faster than any training run: the vibration
    // is 9x stronger in power, yet it reads as the same terrains.
    let fast: Vec<DriveLog> = (0..3)
        .map(|k| at_speed(vibration_log(&NAMES, &[(k, 20.0)], 90 + k as u64, 0.0), 1.8))
        .collect();
    for log in &fast {
        let s = score_log(&m, log).unwrap();
        assert!(
            s.raw.accuracy() > 0.9,
            "{}: {}",
            log.name(),
            s.raw.accuracy()
        );
    }

    let path = dir.path().join("speed.json");
    m.save(&path).unwrap();
    let back = TerrainModel::load(&path).unwrap();
    assert_eq!(back, m);
    // The flag without slopes, or slopes without the flag, is refused.
    let text = std::fs::read_to_string(&path).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut no_flag = json.clone();
    no_flag["features"]["config"]["speed_norm"] = false.into();
    let mut no_slopes = json.clone();
    no_slopes["speed_normalisation"] = serde_json::Value::Null;
    let mut no_baseline = json.clone();
    no_baseline["speed_normalisation"]["current_baseline"] = serde_json::Value::Null;
    let mut short = json;
    short["speed_normalisation"]["slopes"]
        .as_array_mut()
        .unwrap()
        .pop();
    // The runs have motor currents: `current_excess`, which only the
    // speed normalisation gives, leaves the feature list without the flag.
    for (edited, why) in [
        (no_flag, "feature list"),
        (no_slopes, "no speed slopes"),
        (no_baseline, "no current baseline"),
        (short, "feature list"),
    ] {
        let p1 = dir.path().join("edited.json");
        std::fs::write(&p1, edited.to_string()).unwrap();
        let e = TerrainModel::load(&p1).unwrap_err();
        assert!(matches!(e, TerrainError::ModelFile { .. }), "{e}");
        assert!(e.to_string().contains(why), "{e}");
    }
    // The paper's set has no tread speed to normalise by.
    let mut o = fast_opts();
    o.vibration = VibrationConfig::paper();
    o.vibration.speed_norm = true;
    let e = TerrainModel::train(&runs, &o).unwrap_err();
    assert!(e.to_string().contains("tread speed"), "{e}");
}

/// A log whose treads read `factor` times the synthetic 0.5 m/s.
fn driven_at(mut log: DriveLog, factor: f64) -> DriveLog {
    for w in &mut log.wheels {
        w.v_left *= factor;
        w.v_right *= factor;
    }
    log
}

#[test]
fn windows_driven_unlike_the_training_runs_are_flagged_and_less_confident() {
    let dir = tempfile::tempdir().unwrap();
    let model = TerrainModel::train(&imu_runs(1), &fast_opts()).unwrap();
    let env = model
        .envelope
        .as_ref()
        .expect("a full vibration model records its envelope");
    assert_eq!(env.cells.len(), 3);
    // Saved and read back with the envelope.
    let path = dir.path().join("m.json");
    model.save(&path).unwrap();
    let model = TerrainModel::load(&path).unwrap();
    let same = vibration_log(&NAMES, &[(1, 30.0)], 99, 0.0);
    let tl = model.classify_log(&same).unwrap();
    assert_eq!(tl.outside_envelope.len(), tl.frames.len());
    assert_eq!(tl.outside_envelope_share(), Some(0.0));
    // The same vibration, the treads twice as fast: every window outside,
    // and no window more confident than the uniform mix allows.
    let fast = driven_at(same.clone(), 2.0);
    let tl = model.classify_log(&fast).unwrap();
    assert_eq!(tl.outside_envelope_share(), Some(1.0));
    let cap = 1.0 - envelope::OUTSIDE_MIX + envelope::OUTSIDE_MIX / 3.0;
    assert!(tl
        .frames
        .iter()
        .all(|(_, p)| p.iter().all(|&v| v <= cap + 1e-12)
            && (p.iter().sum::<f64>() - 1.0).abs() < 1e-9));
    let s = score_log(&model, &fast).unwrap();
    assert_eq!(s.outside_envelope, Some(s.raw.total() as usize));
    // The estimator's evidence keeps the flags of the windows it keeps.
    let ev = model.estimator_evidence(&fast).unwrap();
    assert_eq!(ev.outside_envelope.len(), ev.frames.len());
    // A file of the previous format is refused with "retrain".
    let text = std::fs::read_to_string(&path).unwrap().replacen(
        &format!("\"format_version\": {MODEL_FORMAT_VERSION}"),
        "\"format_version\": 5",
        1,
    );
    std::fs::write(&path, text).unwrap();
    let e = TerrainModel::load(&path).unwrap_err().to_string();
    assert!(e.contains("retrain"), "{e}");
}
