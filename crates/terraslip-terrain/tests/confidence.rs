//! Calibrated confidence on synthetic logs: the model stores a temperature
//! and an unknown threshold fitted on inner folds, an unsure window is no
//! evidence for the estimator, and a model file without them still loads.

use terraslip_io::DriveLog;
use terraslip_terrain::synth::vibration_log;
use terraslip_terrain::*;

const NAMES: [&str; 3] = ["asphalt", "grass", "soil"];

fn runs() -> Vec<DriveLog> {
    [1u64, 5]
        .iter()
        .flat_map(|s| {
            (0..3).map(move |k| vibration_log(&NAMES, &[(k, 30.0)], s * 10 + k as u64, 0.0))
        })
        .collect()
}

fn calibrated_opts() -> TrainOptions {
    let mut o = TrainOptions::default();
    o.vibration.window_s = 1.0;
    o.classifier.boost.rounds = 30;
    o.speed_augmentation = None;
    o.calibration_folds = 3;
    o
}

#[test]
fn calibrated_model_answers_unknown_below_its_threshold_and_gives_the_estimator_no_evidence() {
    let logs = runs();
    let mut model = TerrainModel::train(&logs, &calibrated_opts()).unwrap();
    let cal = model
        .calibration
        .clone()
        .expect("calibrated on inner folds");
    assert!(
        cal.temperature > 0.0 && cal.folds == 3 && cal.windows > 100,
        "{cal:?}"
    );
    assert!((0.0..=1.0).contains(&cal.unknown_below));
    assert!(model.class_distance.is_some());
    // Round trip through the file keeps the calibration.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.json");
    model.save(&path).unwrap();
    assert_eq!(
        TerrainModel::load(&path).unwrap().calibration,
        Some(cal.clone())
    );

    let test = vibration_log(&NAMES, &[(0, 15.0), (2, 15.0)], 99, 0.0);
    let all = model.classify_log(&test).unwrap().frames.len();
    assert!(all > 10);
    // Nothing is sure enough (a temperature that flattens every output
    // below the threshold): every verdict is unknown, no evidence at all.
    let c = model.calibration.as_mut().unwrap();
    c.temperature = 1e3;
    c.unknown_below = 0.9;
    let tl = model.classify_log(&test).unwrap();
    let truth: Vec<Option<usize>> = tl
        .frames
        .iter()
        .map(|(t, _)| {
            test.terrain_at(*t)
                .and_then(|n| NAMES.iter().position(|c| *c == n))
        })
        .collect();
    assert!(tl.scored_windows(&truth).iter().all(|w| w.unknown));
    assert_eq!(model.estimator_evidence(&test).unwrap().frames.len(), 0);
    // Everything is sure enough: every window is evidence again.
    model.calibration.as_mut().unwrap().unknown_below = 0.0;
    let ev = model.estimator_evidence(&test).unwrap();
    assert_eq!(ev.frames.len(), all);
    assert_eq!(ev.novelty.len(), all);
}

#[test]
fn a_model_file_without_calibration_still_loads_and_is_never_unknown() {
    let mut o = calibrated_opts();
    o.calibration_folds = 0;
    let model = TerrainModel::train(&runs()[..3], &o).unwrap();
    assert!(model.calibration.is_none());
    let mut v = serde_json::to_value(&model).unwrap();
    let obj = v.as_object_mut().unwrap();
    obj.remove("calibration");
    obj.remove("class_distance");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("old.json");
    std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
    let old = TerrainModel::load(&path).unwrap();
    assert!(old.calibration.is_none() && old.class_distance.is_none());
    let tl = old.classify_log(&runs()[3]).unwrap();
    assert_eq!(tl.unknown_below, 0.0);
    assert!(tl.novelty.is_empty());
}
