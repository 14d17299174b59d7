//! The features of every window of labelled runs, as CSV on stdout: one
//! row per window with the run, the label at the window's end and the raw
//! features (before any speed normalisation: `current_excess` is still the
//! ln mean current, the robot's baseline is fitted in training), for
//! looking at what tells two terrains apart.
//!
//! `cargo run -p terraslip-terrain --release --example window_features -- DIR... > windows.csv`
//!
//! Default settings of `train` (six IMU channels, motor currents when the
//! log has them).

use terraslip_terrain::vibration::log_windows;
use terraslip_terrain::VibrationConfig;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dirs: Vec<String> = std::env::args().skip(1).collect();
    if dirs.is_empty() {
        return Err("usage: window_features DIR...".into());
    }
    let mut header = false;
    for d in &dirs {
        let log = terraslip_io::DriveLog::read(d)?;
        let cfg = VibrationConfig {
            currents: !log.currents.is_empty(),
            ..Default::default()
        };
        if !header {
            println!("run,label,t,{}", cfg.feature_names().join(","));
            header = true;
        }
        let (_, windows) = log_windows(&log, &cfg)?;
        for (t, f) in windows {
            let label = log.terrain_at(t).unwrap_or("");
            let row: Vec<String> = f.iter().map(|x| format!("{x:.6}")).collect();
            println!("{},{label},{t:.3},{}", log.name(), row.join(","));
        }
    }
    Ok(())
}
