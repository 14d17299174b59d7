//! Temporary: the CNN's inference cost per window.
use terraslip_terrain::synth::vibration_log;
use terraslip_terrain::*;
fn main() {
    let names = ["asphalt", "grass"];
    let runs: Vec<_> = (0..2)
        .map(|k| vibration_log(&names, &[(k, 40.0)], 11 + k as u64, 0.0))
        .collect();
    let mut o = TrainOptions::default();
    o.vibration.window_s = 1.0;
    o.speed_floor = Some(0.1);
    for kind in [ClassifierKind::Boost, ClassifierKind::Cnn] {
        o.classifier.kind = kind;
        let m = TerrainModel::train(&runs, &o).unwrap();
        let d = m.feature_names.len();
        let row: Vec<f64> = (0..d).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut out = vec![0.0; 2];
        let n = 20000;
        let t = std::time::Instant::now();
        for _ in 0..n {
            m.classifier
                .predict_proba(std::hint::black_box(&row), &mut out);
        }
        println!(
            "{kind:?}: {} features, {:.1} us per window",
            d,
            t.elapsed().as_secs_f64() * 1e6 / n as f64
        );
    }
}
