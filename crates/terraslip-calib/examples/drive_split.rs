//! Time-split evaluation on the real Warthog drives: calibrate on one half
//! of each drive, validate on the other half, and the reverse; then
//! cross-terrain. Usage:
//! `cargo run --release -p terraslip-calib --example drive_split -- DATA_DIR [lm|ga|symmetric|all] [offset=auto|0]`

use terraslip_calib::*;
use terraslip_io::DriveLog;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .get(1)
        .cloned()
        .unwrap_or("/work/shared/data/drive".into());
    let method = match args.get(2).map(String::as_str) {
        Some("ga") => Some(Method::Ga),
        Some("symmetric") => Some(Method::Symmetric),
        Some("all") => None,
        _ => Some(Method::Lm),
    };
    let fixed0 = args.get(3).map(String::as_str) == Some("0");
    let plain = args.get(4).map(String::as_str) == Some("plain");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .expect("data dir")
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .collect();
    names.sort();
    let mut cal = Vec::new();
    for p in &names {
        let log = DriveLog::read(p).expect("log");
        let (t0, t1) = (log.pose[0].t, log.pose[log.pose.len() - 1].t);
        let mid = 0.5 * (t0 + t1);
        for (half, (a, b), (va, vb)) in [
            ("1st->2nd", (t0, mid), (mid, t1)),
            ("2nd->1st", (mid, t1), (t0, mid)),
        ] {
            let mut cfg = CalibConfig::default();
            cfg.method = method;
            let oracle = std::env::var("ORACLE").is_ok();
            cfg.segment.t_min = if oracle { va } else { a };
            cfg.segment.t_max = if oracle { vb } else { b };
            if let Ok(m) = std::env::var("MAXOFF") {
                cfg.time_offset = TimeOffset::Auto {
                    max: m.parse().unwrap_or(0.5),
                    step: 0.01,
                };
            }
            if fixed0 {
                cfg.time_offset = TimeOffset::Fixed(0.0);
            }
            if plain {
                cfg.lm.irls_rounds = 1;
            }
            let smooth: f64 = std::env::var("SMOOTH")
                .ok()
                .and_then(|x| x.parse().ok())
                .unwrap_or(0.0);
            cfg.segment.pose_smoothing = smooth;
            let t = std::time::Instant::now();
            let c = match calibrate(std::slice::from_ref(&log), &cfg, &|_| {}) {
                Ok(c) => c,
                Err(e) => {
                    println!("{} {half}: {e}", log.name());
                    continue;
                }
            };
            let el = t.elapsed().as_secs_f64();
            let pf = c.params_file();
            let mut vcfg = ValidateConfig::default();
            vcfg.segment.t_min = va;
            vcfg.segment.t_max = vb;
            vcfg.segment.pose_smoothing = smooth;
            let v = validate(std::slice::from_ref(&log), &pf, &vcfg).expect("validate");
            let s = &c.sets[0];
            let p = s.best.params;
            println!(
                "{:22} {half} {:9} y_l {:6.3} y_r {:6.3} x_c {:6.3} a_l {:5.3} a_r {:5.3} off {:5.3} used {:4} drop {:3} | N {:4} mse_pos {:.4} nominal {:.4} ratio {:5.2} | yaw {:.4} vs {:.4} ({el:.2}s)",
                log.name(),
                s.best.method.name(),
                p.y_l, p.y_r, p.x_c, p.alpha_l, p.alpha_r,
                s.time_offsets[0].1, s.segments_used, s.dropped.len(),
                v.segments.len(),
                v.mse.position(),
                v.nominal_mse.position(),
                v.nominal_mse.position() / v.mse.position(),
                v.mse.dyaw, v.nominal_mse.dyaw,
            );
            if half == "1st->2nd" {
                cal.push((log.name(), pf));
            }
        }
    }
    // Cross-terrain: params from terrain A (first half) on the second half of B.
    println!(
        "cross-terrain ratio (nominal/calibrated position MSE, 2nd halves), rows = calibrated on"
    );
    let logs: Vec<DriveLog> = names
        .iter()
        .map(|p| DriveLog::read(p).expect("log"))
        .collect();
    for (name, pf) in &cal {
        let mut row = format!("{name:22}");
        for log in &logs {
            let (t0, t1) = (log.pose[0].t, log.pose[log.pose.len() - 1].t);
            let mut vcfg = ValidateConfig::default();
            vcfg.segment.t_min = 0.5 * (t0 + t1);
            // the terrain names differ, so use the set as pooled
            let mut any = pf.clone();
            any.params = pf.terrains.values().next().map(|e| e.params);
            any.terrains.clear();
            let v = validate(std::slice::from_ref(log), &any, &vcfg).expect("validate");
            row += &format!(" {:6.2}", v.nominal_mse.position() / v.mse.position());
        }
        println!("{row}");
    }
}
