//! `estimate --init` from a calibration whose selected turn-rate model
//! scales the speed factors with the turn (`k_alpha`): the filter holds
//! that law, so started there and learning nothing it is the
//! calibration's model (DRIVE's Warthog on sand, `../shared/data/drive`).

use terraslip::pipeline::{self, TerrainEvidence};
use terraslip::EstimatorConfig;
use terraslip_core::IcrParams;
use terraslip_io::DriveLog;

fn sand() -> DriveLog {
    terraslip::testkit::shared_drive("warthog_sand_b")
}

#[test]
fn init_holds_the_speed_factors_turn_law_of_the_calibration() {
    let log = sand();
    // sand_b's whole-drive calibration, rounded.
    let law = IcrParams {
        y_l: 0.94,
        y_r: -0.95,
        x_c: -0.03,
        alpha_l: 0.89,
        alpha_r: 0.94,
    };
    let k_alpha = -0.063;
    let mut entry = terraslip_io::ParamEntry::new(IcrParams {
        y_l: 1.16,
        y_r: -1.19,
        x_c: -0.01,
        alpha_l: 0.81,
        alpha_r: 0.83,
    });
    entry.extra.insert(
        "rate_model".into(),
        serde_json::json!({
            "selected": true, "k_spread": -0.054, "k_alpha": k_alpha,
            "params": {"y_l": law.y_l, "y_r": law.y_r, "x_c": law.x_c,
                       "alpha_l": law.alpha_l, "alpha_r": law.alpha_r},
        }),
    );
    entry
        .extra
        .insert("time_offset_s".into(), serde_json::json!(0.35));
    let mut pf = terraslip_io::ParamsFile::default();
    pf.terrains.insert("sand".into(), entry);
    // Nothing learned: the run is the calibration's model.
    let mut cfg = EstimatorConfig::default();
    cfg.filter.learn_icr = false;
    cfg.filter.learn_alpha = false;
    cfg.filter.turn_law_walk = 0.0;
    cfg.init.std_k_x_speed = 0.0;
    let r = pipeline::run(&log, &cfg, &TerrainEvidence::None, Some(&pf)).unwrap();
    let mut turning = 0;
    for row in &r.rows {
        assert_eq!(row.prediction_model.slopes.k_alpha, k_alpha);
        // A row's ICRs are those at its own tread speeds (the first row
        // comes before any step).
        let k = log.wheels.partition_point(|w| w.t < row.t);
        let Some(w) = log.wheels.get(k).filter(|w| k > 0 && w.t == row.t) else {
            continue;
        };
        let dv = (w.v_right - w.v_left).abs();
        let gain = 1.0 + k_alpha * dv;
        // The speed factors in effect are the law's at the row's treads.
        assert!(
            (row.alpha_l - law.alpha_l * gain).abs() < 1e-6
                && (row.alpha_r - law.alpha_r * gain).abs() < 1e-6,
            "t = {:.2} s, |V_r - V_l| = {dv:.2} m/s: alpha {:.4} / {:.4}, the law gives {:.4} / {:.4}",
            row.t,
            row.alpha_l,
            row.alpha_r,
            law.alpha_l * gain,
            law.alpha_r * gain
        );
        if dv > 0.5 {
            turning += 1;
        }
    }
    assert!(turning > 1000, "{turning} rows in a turn");
}
