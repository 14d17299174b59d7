//! Confidence on synthetic logs: a verdict below [`UNKNOWN_BELOW`] is
//! "unknown", and one below [`EVIDENCE_BELOW`] no evidence for the
//! estimator; a model file keeps the
//! spread of each class for the novelty, and one without it still loads.

use terraslip_io::DriveLog;
use terraslip_terrain::confidence::{confidence, EVIDENCE_BELOW, UNKNOWN_BELOW};
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
    let at_least = |c: f64| -> Vec<f64> {
        tl.frames
            .iter()
            .filter(|(_, p)| confidence(p) >= c)
            .map(|(t, _)| *t)
            .collect()
    };
    let (sure, evidence) = (at_least(UNKNOWN_BELOW), at_least(EVIDENCE_BELOW));
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
    // The robot drives at 0.5 m/s throughout: only the windows less sure
    // than the evidence floor go (the unknown ones among them), and each
    // verdict kept is stamped at the middle of its window (the ground it
    // reads).
    let ev = model.estimator_evidence(&test).unwrap();
    let kept: Vec<f64> = ev.frames.iter().map(|(t, _)| *t).collect();
    let half = 0.5 * model.window_s();
    assert!(half > 0.0);
    let middles: Vec<f64> = evidence.iter().map(|t| t - half).collect();
    assert_eq!(kept, middles);
    assert_eq!(ev.novelty.len(), evidence.len());
}

/// A verdict that is not "unknown" but not sure either (0.6: wrong two
/// times in five on calibrated probabilities) is no evidence for the
/// estimator: a run of them would convince the belief all the same, and
/// the estimator would recall the wrong ground's slip. A sure verdict is
/// kept, floored.
#[test]
fn a_verdict_less_sure_than_the_evidence_floor_is_no_evidence() {
    let tl = TerrainTimeline {
        classes: vec!["asphalt".into(), "grass".into()],
        frames: vec![
            (1.0, vec![0.6, 0.4]),
            (1.5, vec![0.45, 0.55]),
            (2.0, vec![0.1, 0.9]),
            (2.5, vec![0.4, 0.6]),
        ],
        ..Default::default()
    };
    let ev = tl.sure_evidence(0.1);
    assert_eq!(ev.frames.len(), 1, "{:?}", ev.frames);
    assert_eq!(ev.frames[0].0, 2.0);
    assert!((ev.frames[0].1[1] - (0.9 * 0.9 + 0.05)).abs() < 1e-12);
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
