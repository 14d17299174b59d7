//! Time-split evaluation on real drives (one drive per terrain): calibrate
//! on one half of each drive and validate on the other half, both ways,
//! then cross-terrain (calibrated on the first half of row, scored on the
//! second half of column).
//!
//! `cargo run --release -p terraslip-calib --example drive_split -- DATA_DIR [lm|ga|symmetric|all] [--yaw-weight W] [--no-offset] [--no-gate] [--plain] [--cauchy C]`

use terraslip_calib::*;
use terraslip_io::DriveLog;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = args
        .first()
        .cloned()
        .unwrap_or("../shared/data/drive".into());
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
    cfg.segment.reference_gate = !flag("--no-gate");
    cfg.segment.drop_mistimed = !flag("--no-gate");
    let mut paths: Vec<_> = match std::fs::read_dir(&dir) {
        Ok(d) => d.filter_map(|e| e.ok()).map(|e| e.path()).collect(),
        Err(e) => {
            eprintln!("{dir}: {e}");
            std::process::exit(1);
        }
    };
    paths.sort();
    let logs: Vec<DriveLog> = paths
        .iter()
        .filter_map(|p| DriveLog::read(p).ok())
        .collect();
    let halves = |log: &DriveLog| {
        let (a, b) = (log.pose[0].t, log.pose[log.pose.len() - 1].t);
        ((a, 0.5 * (a + b)), (0.5 * (a + b), b))
    };
    println!("| drive | train -> test | method | y_l | y_r | x_c | alpha_l | alpha_r | offset s | used/dropped | N test | MSE pos calibrated | MSE pos no-slip | ratio |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut first_half = Vec::new();
    for log in &logs {
        let (h1, h2) = halves(log);
        for (name, train, test) in [("1st -> 2nd", h1, h2), ("2nd -> 1st", h2, h1)] {
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
            if flag("--no-offset") {
                v.time_offset = OffsetChoice::Fixed(0.0);
            }
            let s = &cal.sets[0];
            let p = s.best.params;
            match validate(std::slice::from_ref(log), &pf, &v) {
                Ok(r) => println!(
                    "| {} | {name} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {}/{} | {} | {:.3} | {:.3} | **{:.2}** |",
                    log.name(),
                    s.best.method.name(),
                    p.y_l,
                    p.y_r,
                    p.x_c,
                    p.alpha_l,
                    p.alpha_r,
                    s.time_offsets[0].1,
                    s.segments_used,
                    s.dropped.len(),
                    r.segments.len(),
                    r.mse.position(),
                    r.nominal_mse.position(),
                    r.nominal_mse.position() / r.mse.position()
                ),
                Err(e) => println!("| {} | {name} | validation error: {e} |", log.name()),
            }
            if name.starts_with("1st") {
                first_half.push((log.name(), pf, s.time_offsets[0].1));
            }
        }
    }
    println!("\ncross-terrain: no-slip MSE / calibrated MSE of positions on the 2nd half of the column drive, parameters from the 1st half of the row drive\n");
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
        any.params = pf.terrains.values().next().map(|e| e.params).or(pf.params);
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
