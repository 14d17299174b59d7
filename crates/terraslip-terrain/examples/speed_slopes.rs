//! The slopes the learnt speed normalisation fits on a directory of
//! labelled runs (all of them: the crossval example fits them per fold),
//! for each amplitude-like feature, at one or more `v_min` (m/s).
//!
//! `cargo run -p terraslip-terrain --release --example speed_slopes -- DIR [v_min...]`

use terraslip_terrain::vibration::log_windows;
use terraslip_terrain::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let dir = args.get(1).ok_or("usage: speed_slopes DIR [v_min...]")?;
    let v_mins: Vec<f64> = if args.len() > 2 {
        args[2..]
            .iter()
            .map(|s| s.parse())
            .collect::<Result<_, _>>()?
    } else {
        vec![0.1]
    };
    let cfg = VibrationConfig::default();
    let names = cfg.feature_names();
    let mut entries: Vec<_> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .collect();
    entries.sort();
    let mut classes: Vec<String> = Vec::new();
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for p in entries {
        let log = terraslip_io::DriveLog::read(&p)?;
        let (_, windows) = log_windows(&log, &cfg)?;
        for (t, f) in windows {
            let Some(label) = log.terrain_at(t) else {
                continue;
            };
            let c = match classes.iter().position(|c| c == label) {
                Some(c) => c,
                None => {
                    classes.push(label.to_string());
                    classes.len() - 1
                }
            };
            x.push(f);
            y.push(c);
        }
    }
    let fits: Vec<SpeedNormalisation> = v_mins
        .iter()
        .map(|&m| SpeedNormalisation::fit(&x, &y, classes.len(), &names, 0.5, m))
        .collect::<Result<_, _>>()?;
    print!("{:28}", "feature \\ v_min (m/s)");
    for m in &v_mins {
        print!(" {m:>7}");
    }
    println!();
    for (j, name) in names.iter().enumerate() {
        if fits[0].slopes[j] == 0.0 && fits.iter().all(|f| f.slopes[j] == 0.0) {
            continue;
        }
        print!("{name:28}");
        for f in &fits {
            print!(" {:+7.2}", f.slopes[j]);
        }
        println!();
    }
    Ok(())
}
