//! A terrain model file that is not what training writes is refused on
//! load, naming the file and what is wrong with it.

use serde_json::{json, Value};
use terraslip_terrain::classify::ClassifierKind;
use terraslip_terrain::synth::vibration_log;
use terraslip_terrain::{TerrainModel, TrainOptions};

fn model(kind: ClassifierKind) -> Value {
    let names = ["asphalt", "grass"];
    let runs: Vec<_> = (0..2)
        .map(|k| vibration_log(&names, &[(k, 12.0)], 5 + k as u64, 0.0))
        .collect();
    let mut o = TrainOptions::default();
    o.vibration.window_s = 1.0;
    o.classifier.kind = kind;
    o.classifier.boost.rounds = 3;
    serde_json::to_value(TerrainModel::train(&runs, &o).unwrap()).unwrap()
}

fn load_err(v: &Value) -> String {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("model.json");
    std::fs::write(&p, serde_json::to_vec(v).unwrap()).unwrap();
    let e = TerrainModel::load(&p)
        .expect_err("must be refused")
        .to_string();
    assert!(e.contains("model.json") && e.contains("retrain"), "{e}");
    e
}

#[test]
fn broken_models_are_refused_naming_the_fault() {
    let good = model(ClassifierKind::Tree);

    let mut v = good.clone();
    v["classifier"]["nodes"] = json!([]);
    assert!(load_err(&v).contains("tree has no nodes"));

    let mut v = good.clone();
    v["classifier"]["nodes"][0]["probs"] = json!([-0.5, 1.5]);
    assert!(load_err(&v).contains("outside [0, 1]"));

    let mut v = good.clone();
    v["classes"] = json!(["asphalt", "asphalt"]);
    assert!(load_err(&v).contains("both `asphalt`"));

    let mut v = good.clone();
    v["classifier"]["nodes"][0]["left"] = json!(0xffff);
    assert!(load_err(&v).contains("child links"));

    let boost = model(ClassifierKind::Boost);
    let mut v = boost.clone();
    v["classifier"]["trees"] = json!([]);
    assert!(load_err(&v).contains("empty tree"));

    // A node pointing back at itself would walk forever.
    let mut v = boost.clone();
    let t = &mut v["classifier"]["trees"][0];
    t[0]["left"] = json!(1);
    t[0]["right"] = json!(0);
    t[0]["feature"] = json!(0);
    assert!(load_err(&v).contains("boosted trees"));
}
