//! Confidence on synthetic logs: a verdict below [`UNKNOWN_BELOW`] is
//! "unknown" and no evidence for the estimator; a model file keeps the
//! spread of each class for the novelty, and one without it still loads.

use terraslip_io::DriveLog;
use terraslip_terrain::confidence::{confidence, UNKNOWN_BELOW};
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

fn opts() -> TrainOptions {
    let mut o = TrainOptions::default();
    o.vibration.window_s = 1.0;
    o.classifier.boost.rounds = 30;
    o.speed_augmentation = None;
    o
}

#[test]
fn an_unsure_window_is_unknown_and_no_evidence_for_the_estimator() {
    // Few boosting rounds: the probabilities have moved only part of the
    // way from the prior, sure on some windows, unsure on others.
    let mut o = opts();
    o.classifier.boost.rounds = 8;
    let model = TerrainModel::train(&runs(), &o).unwrap();
    // Terrain changes every 1.2 s: most 1 s windows straddle two grounds.
    let segments: Vec<(usize, f64)> = (0..30).map(|i| (i % 3, 1.2)).collect();
    let test = vibration_log(&NAMES, &segments, 99, 0.0);
    let tl = model.classify_log(&test).unwrap();
    let sure: Vec<f64> = tl
        .frames
        .iter()
        .filter(|(_, p)| confidence(p) >= UNKNOWN_BELOW)
        .map(|(t, _)| *t)
        .collect();
    let unsure = tl.frames.len() - sure.len();
    assert!(
        unsure > 0 && !sure.is_empty(),
        "{unsure} of {}",
        tl.frames.len()
    );
    let truth: Vec<Option<usize>> = tl
        .frames
        .iter()
        .map(|(t, _)| {
            test.terrain_at(*t)
                .and_then(|n| NAMES.iter().position(|c| *c == n))
        })
        .collect();
    let scored = tl.scored_windows(&truth);
    assert_eq!(scored.iter().filter(|w| w.unknown).count(), unsure);
    // The robot drives at 0.5 m/s throughout: only the unsure windows go,
    // and each verdict kept is stamped at the middle of its window (the
    // ground it reads).
    let ev = model.estimator_evidence(&test).unwrap();
    let kept: Vec<f64> = ev.frames.iter().map(|(t, _)| *t).collect();
    let half = 0.5 * model.window_s();
    assert!(half > 0.0);
    let middles: Vec<f64> = sure.iter().map(|t| t - half).collect();
    assert_eq!(kept, middles);
    assert_eq!(ev.novelty.len(), sure.len());
}

#[test]
fn a_model_file_without_the_class_spread_still_loads() {
    let model = TerrainModel::train(&runs()[..3], &opts()).unwrap();
    assert!(model.class_distance.is_some());
    let mut v = serde_json::to_value(&model).unwrap();
    v.as_object_mut().unwrap().remove("class_distance");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("old.json");
    std::fs::write(&path, serde_json::to_vec(&v).unwrap()).unwrap();
    let old = TerrainModel::load(&path).unwrap();
    assert!(old.class_distance.is_none());
    let tl = old.classify_log(&runs()[3]).unwrap();
    assert!(tl.novelty.is_empty());
}
