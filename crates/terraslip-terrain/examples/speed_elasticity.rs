//! How much each band feature moves with speed within a terrain: the slope
//! d feature / d ln v (for log powers: the elasticity d ln P / d ln v),
//! pooled over the terrains of a directory of labelled runs, over the
//! windows faster than 0.1 m/s. Used to check whether spatial bands
//! depend less on speed than temporal ones (docs/research-log.md).
//!
//! `cargo run -p terraslip-terrain --release --example speed_elasticity -- DIR [jacobian|profile]`

use std::collections::BTreeMap;

use terraslip_terrain::vibration::log_windows;
use terraslip_terrain::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .get(1)
        .ok_or("usage: speed_elasticity DIR [jacobian|profile]")?;
    let mut cfg = VibrationConfig {
        spatial_bands: 6,
        ..Default::default()
    };
    if args.get(2).map(String::as_str) == Some("profile") {
        cfg.spatial_scaling = SpatialScaling::Profile;
    }
    let names = cfg.feature_names();
    let speed_ix = names
        .iter()
        .position(|n| n == "tread_speed")
        .ok_or("no tread_speed feature")?;
    let mut entries: Vec<_> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .collect();
    entries.sort();
    // Per terrain: (ln v, features) of every window above 0.1 m/s.
    let mut by_terrain: BTreeMap<String, Vec<(f64, Vec<f64>)>> = BTreeMap::new();
    for p in entries {
        let log = terraslip_io::DriveLog::read(&p)?;
        let (_, windows) = log_windows(&log, &cfg)?;
        for (t, f) in windows {
            let (Some(label), v) = (log.terrain_at(t), f[speed_ix]) else {
                continue;
            };
            if v > 0.1 {
                by_terrain
                    .entry(label.to_string())
                    .or_default()
                    .push((v.ln(), f));
            }
        }
    }
    for (j, name) in names.iter().enumerate() {
        if !name.contains("band") || name.ends_with("_share") {
            continue;
        }
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for rows in by_terrain.values() {
            let n = rows.len() as f64;
            let mx = rows.iter().map(|r| r.0).sum::<f64>() / n;
            let my = rows.iter().map(|r| r.1[j]).sum::<f64>() / n;
            for (x, f) in rows {
                sxy += (x - mx) * (f[j] - my);
                sxx += (x - mx) * (x - mx);
            }
        }
        println!("{name:24} {:+.2}", sxy / sxx.max(1e-12));
    }
    Ok(())
}
