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
    // The law is held at the calibration's slope, with no uncertainty.
    assert_eq!(r.speed_law, (k_alpha, 0.0));
    // The speed factors in effect are the law's at the turn the law reads
    // (the tread speed difference low-passed over `turn_law_lag`): on rows
    // where the difference has held within 0.05 m/s for 4 lags, at the
    // row's own difference (the law moves them 6 % at 1 m/s).
    let lag = cfg.filter.turn_law_lag;
    let mut turning = 0;
    for row in &r.rows {
        let k = log.wheels.partition_point(|w| w.t < row.t);
        if k == 0 || k >= log.wheels.len() || log.wheels[k].t != row.t {
            continue;
        }
        let dv = |w: &terraslip_io::WheelSample| (w.v_right - w.v_left).abs();
        let here = dv(&log.wheels[k]);
        let steady = log.wheels[..=k]
            .iter()
            .rev()
            .take_while(|w| row.t - w.t <= 4.0 * lag)
            .all(|w| (dv(w) - here).abs() < 0.05);
        let held_long = log.wheels[k].t - log.wheels[0].t > 4.0 * lag;
        if !(steady && held_long) {
            continue;
        }
        let gain = 1.0 + k_alpha * here;
        assert!(
            (row.alpha_l - law.alpha_l * gain).abs() < 8e-3
                && (row.alpha_r - law.alpha_r * gain).abs() < 8e-3,
            "t = {:.2} s, |V_r - V_l| = {here:.2} m/s: alpha {:.4} / {:.4}, the law gives {:.4} / {:.4}",
            row.t,
            row.alpha_l,
            row.alpha_r,
            law.alpha_l * gain,
            law.alpha_r * gain
        );
        if here > 0.5 {
            turning += 1;
        }
    }
    assert!(turning > 10, "{turning} steady rows in a turn");
}
