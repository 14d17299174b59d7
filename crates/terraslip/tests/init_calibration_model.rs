//! `estimate --init` from a calibration whose selected turn-rate model
//! scales the speed factors with the turn (`k_alpha`): the filter holds
//! that law and reads it as `calibrate` does, at each instant's tread
//! speeds, so started there and learning nothing it is the calibration's
//! model (DRIVE's Warthog on sand, `data/warthog_sand_b`).

use terraslip::pipeline::{self, EstimateRun, TerrainEvidence};
use terraslip::EstimatorConfig;
use terraslip_core::IcrParams;
use terraslip_io::{DriveLog, ParamsFile};

fn sand() -> DriveLog {
    terraslip::testkit::repo_drive("warthog_sand_b")
}

/// sand_b's whole-drive calibration, rounded: the selected model's
/// straight-line parameters.
const LAW: IcrParams = IcrParams {
    y_l: 0.94,
    y_r: -0.95,
    x_c: -0.03,
    alpha_l: 0.89,
    alpha_r: 0.94,
};
/// Its speed factors' turn law, s/m.
const K_ALPHA: f64 = -0.063;

/// A parameters file holding sand_b's calibration with the spread's turn
/// law `k_spread` (s/m) and [`K_ALPHA`], stamped 0.35 s late.
fn calibration(k_spread: f64) -> ParamsFile {
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
            "selected": true, "k_spread": k_spread, "k_alpha": K_ALPHA,
            "params": {"y_l": LAW.y_l, "y_r": LAW.y_r, "x_c": LAW.x_c,
                       "alpha_l": LAW.alpha_l, "alpha_r": LAW.alpha_r},
        }),
    );
    entry
        .extra
        .insert("time_offset_s".into(), serde_json::json!(0.35));
    let mut pf = ParamsFile::default();
    pf.terrains.insert("sand".into(), entry);
    pf
}

/// `log` run from `pf` learning nothing: the run is the calibration's
/// model.
fn frozen(log: &DriveLog, pf: &ParamsFile) -> EstimateRun {
    let mut cfg = EstimatorConfig::default();
    cfg.filter.learn_icr = false;
    cfg.filter.learn_alpha = false;
    cfg.filter.turn_law_walk = 0.0;
    cfg.init.std_k_x_speed = 0.0;
    pipeline::run(log, &cfg, &TerrainEvidence::None, Some(pf)).unwrap()
}

/// The speed factors in effect on every row are the law's at that row's
/// own tread speed difference, also right after the difference steps
/// (read through the spread's lagged input they trailed it).
#[test]
fn init_holds_the_speed_factors_turn_law_at_each_instants_tread_speeds() {
    let log = sand();
    let r = frozen(&log, &calibration(-0.054));
    // The law is held at the calibration's slope, with no uncertainty.
    assert_eq!(r.speed_law, (K_ALPHA, 0.0));
    let dv = |w: &terraslip_io::WheelSample| (w.v_right - w.v_left).abs();
    let (mut rows, mut steps, mut worst) = (0, 0, 0.0f64);
    for row in &r.rows {
        let k = log.wheels.partition_point(|w| w.t < row.t);
        if k == 0 || k >= log.wheels.len() || log.wheels[k].t != row.t {
            continue;
        }
        let here = dv(&log.wheels[k]);
        let gain = 1.0 + K_ALPHA * here;
        let off = (row.alpha_l - LAW.alpha_l * gain)
            .abs()
            .max((row.alpha_r - LAW.alpha_r * gain).abs());
        assert!(
            off < 1e-6,
            "t = {:.2} s, |V_r - V_l| = {here:.3} m/s (before {:.3}): alpha {:.5} / {:.5}, \
             the law gives {:.5} / {:.5}",
            row.t,
            dv(&log.wheels[k - 1]),
            row.alpha_l,
            row.alpha_r,
            LAW.alpha_l * gain,
            LAW.alpha_r * gain
        );
        worst = worst.max(off);
        rows += 1;
        steps += usize::from((here - dv(&log.wheels[k - 1])).abs() > 0.1);
    }
    assert!(rows > 5000, "{rows} rows compared");
    assert!(steps > 20, "{steps} rows right after a step in the turn");
    eprintln!("{rows} rows ({steps} after a step): worst {worst:.2e}");
}

/// The run's 2 s prediction (`summary.json`'s `prediction`) applies the
/// held law row by row over each segment, as `calibrate validate` does:
/// frozen at the calibration (whose spread does not change with the
/// turn) the two score the same segments alike.
#[test]
fn init_s_prediction_with_the_held_speed_law_is_calibrate_validate_s() {
    let log = sand();
    let pf = calibration(0.0);
    let r = frozen(&log, &pf);
    let online = r.prediction.expect("sand_b has a pose reference");
    let calib = terraslip::validation::prediction(std::slice::from_ref(&log), &pf).expect("scored");
    let mut same = 0;
    let mut worst = 0.0f64;
    for s in &online.segments {
        let Some(c) = calib.segments.iter().find(|c| c.t == s.t) else {
            continue;
        };
        same += 1;
        worst = worst.max((s.error - c.error).abs());
        assert!(
            (s.error - c.error).abs() < 1e-4,
            "segment at t = {:.1} s: online {:.4} m, calibrate validate {:.4} m",
            s.t,
            s.error,
            c.error
        );
    }
    assert!(
        same > online.segments.len() * 9 / 10 && same > 200,
        "{same} of {} segments shared with calibrate validate's {}",
        online.segments.len(),
        calib.segments.len()
    );
    eprintln!(
        "{same} segments: worst difference {worst:.2e} m; means {:.4} / {:.4} m",
        online.stats.mean_m, calib.stats.mean_m
    );
}
