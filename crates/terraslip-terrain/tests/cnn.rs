//! The 1D CNN classifier (feature `cnn`): it learns two synthetic grounds
//! from their vibration spectra, and a model file with corrupt weights is
//! refused with a reason.
#![cfg(feature = "cnn")]

use terraslip_terrain::synth::vibration_log;
use terraslip_terrain::*;

const NAMES: [&str; 2] = ["asphalt", "grass"];

fn cnn_opts() -> TrainOptions {
    let mut o = TrainOptions::default();
    o.vibration.window_s = 1.0;
    o.classifier.kind = ClassifierKind::Cnn;
    o.classifier.cnn.epochs = 30;
    o.speed_floor = Some(0.1);
    o
}

fn trained() -> TerrainModel {
    let runs: Vec<_> = (0..2)
        .map(|k| vibration_log(&NAMES, &[(k, 40.0)], 11 + k as u64, 0.0))
        .collect();
    TerrainModel::train(&runs, &cnn_opts()).unwrap()
}

#[test]
fn cnn_separates_two_synthetic_grounds_on_unseen_runs() {
    let model = trained();
    let test = vibration_log(&NAMES, &[(1, 20.0), (0, 20.0)], 99, 0.0);
    let s = score_log(&model, &test).unwrap();
    assert!(s.raw.total() > 60, "windows {}", s.raw.total());
    assert!(s.raw.accuracy() > 0.9, "raw {}", s.raw.accuracy());
}

#[test]
fn cnn_model_round_trips_and_corrupt_weights_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let model = trained();
    let path = dir.path().join("m.json");
    model.save(&path).unwrap();
    assert_eq!(TerrainModel::load(&path).unwrap(), model);
    let mut j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let cases: [(&str, fn(&mut serde_json::Value)); 3] = [
        ("a weight dropped", |c| {
            c["w3"].as_array_mut().unwrap().pop();
        }),
        ("an index past the features", |c| {
            c["rest"][0] = 100_000.into();
        }),
        ("a class too many", |c| {
            c["classes"] = 3.into();
        }),
    ];
    for (what, corrupt) in cases {
        let mut bad = j.clone();
        corrupt(&mut bad["classifier"]);
        let p = dir.path().join("bad.json");
        std::fs::write(&p, serde_json::to_string(&bad).unwrap()).unwrap();
        let e = TerrainModel::load(&p).unwrap_err().to_string();
        assert!(e.contains("cnn") && e.contains("bad.json"), "{what}: {e}");
    }
    // Not a number where a weight belongs: refused by the parser, named.
    j["classifier"]["w1"][0] = "x".into();
    let p = dir.path().join("bad.json");
    std::fs::write(&p, serde_json::to_string(&j).unwrap()).unwrap();
    assert!(TerrainModel::load(&p).is_err());
}
