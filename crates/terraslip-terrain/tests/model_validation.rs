//! A terrain model file that is not what training writes is refused on
//! load, naming the file and what is wrong with it.

use serde_json::{json, Value};
use terraslip_terrain::synth::vibration_log;
use terraslip_terrain::{TerrainModel, TrainOptions};

fn model() -> Value {
    let names = ["asphalt", "grass"];
    let runs: Vec<_> = (0..2)
        .map(|k| vibration_log(&names, &[(k, 12.0)], 5 + k as u64, 0.0))
        .collect();
    let mut o = TrainOptions::default();
    o.vibration.window_s = 1.0;
    o.classifier.forest.n_trees = 2;
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
    let good = model();
    let trees = |v: &Value| -> Value { v["classifier"]["trees"].clone() };

    let mut v = good.clone();
    v["classifier"]["trees"][0]["nodes"] = json!([]);
    assert!(load_err(&v).contains("tree 0 has no nodes"));

    let mut v = good.clone();
    v["classifier"]["trees"] = json!([]);
    assert!(load_err(&v).contains("no trees"));

    let mut v = good.clone();
    let mut t = trees(&v);
    t[0]["nodes"][0]["probs"] = json!([-0.5, 1.5]);
    v["classifier"]["trees"] = t;
    assert!(load_err(&v).contains("outside [0, 1]"));

    let mut v = good.clone();
    v["classes"] = json!(["asphalt", "asphalt"]);
    assert!(load_err(&v).contains("both `asphalt`"));

    let mut v = good.clone();
    let mut t = trees(&v);
    t[0]["nodes"][0]["left"] = json!(0xffff);
    v["classifier"]["trees"] = t;
    assert!(load_err(&v).contains("child links"));
}
