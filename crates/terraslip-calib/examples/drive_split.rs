//! Time-split evaluation on real drives (one drive per terrain): calibrate
//! on one half of each drive and validate on the other half, both ways,
//! then cross-terrain (calibrated on the first half of row, scored on the
//! second half of column).
//!
//! Each split is scored with the constant ICRs (Mandow's model) and with
//! the turn-rate dependent model where calibration selected it; both with
//! the same segments, gate and time offset as the no-slip model.
//!
//! `cargo run --release -p terraslip-calib --example drive_split -- DATA_DIR [lm|ga|symmetric|all] [--yaw-weight W] [--no-offset] [--no-gate] [--plain] [--cauchy C] [--rate off|auto|on] [--validation-offset params|auto] [--chained | --stride S] [--traction off|auto|on [--signed]]`
//!
//! `--validation-offset auto` estimates the wheel-to-pose offset of the
//! validation half on that half itself (model-free, the same for every
//! model scored) instead of taking the training half's.

use terraslip_calib::*;
use terraslip_io::DriveLog;

mod common;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = common::data_dir(&args);
    let flag = |n: &str| args.iter().any(|a| a == n);
    let value = |n: &str| {
        args.iter()
            .position(|a| a == n)
            .and_then(|i| args.get(i + 1))
            .and_then(|v| v.parse::<f64>().ok())
    };
    let method = match args.get(1).map(String::as_str) {
        Some("ga") => Some(Method::Ga),
        Some("symmetric") => Some(Method::Symmetric),
        Some("all") => None,
        _ => Some(Method::Lm),
    };
    let mut cfg = CalibConfig {
        method,
        ..Default::default()
    };
    if let Some(w) = value("--yaw-weight") {
        cfg.yaw_weight = w;
    }
    if let Some(c) = value("--cauchy") {
        cfg.lm.cauchy_c = c;
    }
    if flag("--plain") {
        // Plain least squares: no reweighting, no outlier dropping.
        cfg.lm.irls_rounds = 1;
    }
    if flag("--no-offset") {
        cfg.time_offset = TimeOffset::Fixed(0.0);
    }
    let word = |n: &str| {
        args.iter()
            .position(|a| a == n)
            .and_then(|i| args.get(i + 1))
            .map(String::as_str)
    };
    cfg.rate_model = match word("--rate") {
        Some("off") => RateModel::Off,
        Some("on") => RateModel::On,
        _ => RateModel::Auto,
    };
    cfg.traction = match word("--traction") {
        Some("auto") => RateModel::Auto,
        Some("on") => RateModel::On,
        Some("off") => RateModel::Off,
        _ => cfg.traction,
    };
    cfg.traction_signed = flag("--signed");
    let validation_offset = if flag("--no-offset") {
        OffsetChoice::Fixed(0.0)
    } else if word("--validation-offset") == Some("auto") {
        OffsetChoice::Auto {
            max: 0.5,
            step: 0.01,
        }
    } else {
        OffsetChoice::FromParams
    };
    cfg.segment.reference_gate = !flag("--no-gate");
    cfg.segment.drop_mistimed = !flag("--no-gate");
    if flag("--chained") {
        cfg.segment.overlap = None;
    }
    if let Some(stride) = value("--stride") {
        cfg.segment.overlap = Some(stride);
    }
    let logs = common::drives(&dir, "");
    let halves = |log: &DriveLog| {
        let (a, b) = (log.pose[0].t, log.pose[log.pose.len() - 1].t);
        ((a, 0.5 * (a + b)), (0.5 * (a + b), b))
    };
    println!("| drive | train -> test | method | y_l | y_r | x_c | alpha_l | alpha_r | offset s (train/test) | used/dropped | N test | MSE pos no-slip | MSE pos constant | ratio constant | rate model k_spread, k_alpha (s/m) | MSE pos rate | ratio rate |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut first_half = Vec::new();
    for log in &logs {
        let (h1, h2) = halves(log);
        for (name, train, test) in [("1st -> 2nd", h1, h2), ("2nd -> 1st", h2, h1)] {
            // `--in-sample`: score on the training half itself (how far the
            // model family can reach there, not a held-out figure).
            let test = if flag("--in-sample") { train } else { test };
            let mut c = cfg.clone();
            (c.segment.t_min, c.segment.t_max) = train;
            let cal = match calibrate(std::slice::from_ref(log), &c, &|_| {}) {
                Ok(x) => x,
                Err(e) => {
                    println!("| {} | {name} | error: {e} |", log.name());
                    continue;
                }
            };
            let pf = cal.params_file();
            let mut v = ValidateConfig::default();
            v.segment.reference_gate = cfg.segment.reference_gate;
            v.segment.drop_mistimed = cfg.segment.drop_mistimed;
            (v.segment.t_min, v.segment.t_max) = test;
            v.time_offset = validation_offset;
            assert!(v.segment.overlap.is_none());
            let s = &cal.sets[0];
            let p = s.best.params;
            let constant = validate(
                std::slice::from_ref(log),
                &pf,
                &ValidateConfig {
                    model: ModelChoice::Constant,
                    ..v.clone()
                },
            );
            let rate = validate(std::slice::from_ref(log), &pf, &v);
            match (constant, rate) {
                (Ok(c), Ok(r)) => {
                    let traction = match s
                        .rate
                        .as_ref()
                        .and_then(|x| x.traction.as_ref().map(|t| (x, t)))
                    {
                        Some((x, (t, b))) => format!(
                            "; traction {}: k_acc {:.3}±{:.3}{}, BIC {:+.1} vs rate {:+.1}",
                            if x.traction_selected {
                                "selected"
                            } else {
                                "not selected"
                            },
                            t.slopes.k_acc,
                            t.std[7],
                            // k_dir is fitted only with --traction-signed.
                            if t.std[8].is_finite() {
                                format!(", k_dir {:.3}±{:.3}", t.slopes.k_dir, t.std[8])
                            } else {
                                String::new()
                            },
                            b - x.bic_constant,
                            x.bic_rate - x.bic_constant
                        ),
                        None => String::new(),
                    };
                    let rate_cols = match &s.rate {
                        Some(x) if x.selected => format!(
                            "{:.3}, {:.3}{traction} | {:.3} | **{:.3}**",
                            x.written().slopes.k_spread,
                            x.written().slopes.k_alpha,
                            r.mse.position(),
                            r.nominal_mse.position() / r.mse.position()
                        ),
                        Some(x) => format!(
                            "not selected: {} ({:.3}±{:.3}, {:.3}±{:.3}; BIC {:+.1}){traction} | - | -",
                            x.reason.as_deref().unwrap_or(""),
                            x.fit.slopes.k_spread,
                            x.fit.std[5],
                            x.fit.slopes.k_alpha,
                            x.fit.std[6],
                            x.bic_rate - x.bic_constant
                        ),
                        None => "off | - | -".into(),
                    };
                    println!(
                        "| {} | {name} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2}/{:.2} | {}/{} | {} | {:.3} | {:.3} | **{:.3}** | {rate_cols} |",
                        log.name(),
                        s.best.method.name(),
                        p.y_l,
                        p.y_r,
                        p.x_c,
                        p.alpha_l,
                        p.alpha_r,
                        s.time_offsets[0].1,
                        c.offsets[0],
                        s.segments_used,
                        s.dropped.len(),
                        c.segments.len(),
                        c.nominal_mse.position(),
                        c.mse.position(),
                        c.nominal_mse.position() / c.mse.position()
                    )
                }
                (Err(e), _) | (_, Err(e)) => {
                    println!("| {} | {name} | validation error: {e} |", log.name())
                }
            }
            if name.starts_with("1st") {
                first_half.push((log.name(), pf, s.time_offsets[0].1));
            }
        }
    }
    println!("\ncross-terrain: no-slip MSE / calibrated MSE of positions on the 2nd half of the column drive, parameters (the turn-rate model where selected) from the 1st half of the row drive\n");
    let mut head = "| calibrated on |".to_string();
    for l in &logs {
        head += &format!(" {} |", l.name());
    }
    println!("{head}");
    println!("|---|{}", "---|".repeat(logs.len()));
    for (name, pf, _) in &first_half {
        let mut row = format!("| {name} |");
        // Use the set whatever the terrain is called on the other drive.
        let mut any = pf.clone();
        if let Some(e) = pf.terrains.values().next() {
            any.params = Some(e.params);
            any.extra = e.extra.clone();
        }
        any.terrains.clear();
        for log in &logs {
            let mut v = ValidateConfig::default();
            v.segment.reference_gate = cfg.segment.reference_gate;
            v.segment.drop_mistimed = cfg.segment.drop_mistimed;
            (v.segment.t_min, v.segment.t_max) = halves(log).1;
            // The latency belongs to the drive, not to the parameters.
            v.time_offset = if flag("--no-offset") {
                OffsetChoice::Fixed(0.0)
            } else {
                OffsetChoice::Auto {
                    max: 0.5,
                    step: 0.01,
                }
            };
            row += &match validate(std::slice::from_ref(log), &any, &v) {
                Ok(r) => format!(" {:.2} |", r.nominal_mse.position() / r.mse.position()),
                Err(_) => " - |".into(),
            };
        }
        println!("{row}");
    }
}
