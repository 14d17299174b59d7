//! Dead-reckoning drift on real drives, scored against their own pose
//! reference: for each 30 s window starting every 60 s, the run drops the
//! pose fixes (position and heading) in the window and the drift is the
//! end-point error of the estimate's motion over it against the reference's,
//! in % of the distance driven (`metrics::outage_drift`, the simulated
//! figures' definition, with the reference pose as truth).
//!
//! ```text
//! cargo run -p terraslip --release --example estimator_real_drift -- LOG=PARAMS...
//! ```
//!
//! `PARAMS` is `terraslip calibrate LOG --out PARAMS`' file (`--init`, and
//! its wheel-to-pose offset as the pose latency, as `terraslip estimate`
//! takes it); `LOG` alone runs without. `TUNE=file.toml` overrides the
//! default's keys. Calibrating on the same drive that is scored flatters
//! the `--init` rows; compare variants on the same `PARAMS`.

use terraslip::config::EstimatorConfig;
use terraslip::metrics;
use terraslip::pipeline::{self, RunOptions, TerrainEvidence};
use terraslip_io::{DriveLog, ParamsFile, TruthSample};

fn main() -> anyhow::Result<()> {
    let mut cfg0 = EstimatorConfig::default();
    if let Ok(path) = std::env::var("TUNE") {
        cfg0 = EstimatorConfig::from_toml(&std::fs::read_to_string(&path)?)?;
    }
    println!("| drive | windows | drift % mean (max) | along RMS % | across RMS % | heading change error RMS (deg) |");
    println!("|---|---|---|---|---|---|");
    for arg in std::env::args().skip(1) {
        let (dir, params) = match arg.split_once('=') {
            Some((d, p)) => (d.to_string(), Some(ParamsFile::read(p.as_ref())?)),
            None => (arg.clone(), None),
        };
        let log = DriveLog::read(&dir)?;
        let mut cfg = cfg0.clone();
        if cfg.measurement.pose_latency == 0.0 {
            let get = |e: &std::collections::BTreeMap<String, serde_json::Value>| {
                e.get("time_offset_s").and_then(|v| v.as_f64())
            };
            if let Some(lat) = params.as_ref().and_then(|p| {
                get(&p.extra).or_else(|| p.terrains.values().find_map(|e| get(&e.extra)))
            }) {
                cfg.measurement.pose_latency = lat;
            }
        }
        let lat = cfg.measurement.pose_latency;
        // The reference on the wheels' clock.
        let truth: Vec<TruthSample> = log
            .pose
            .iter()
            .filter_map(|p| {
                Some(TruthSample {
                    t: p.t - lat,
                    east: p.east?,
                    north: p.north?,
                    yaw: p.yaw?,
                    y_l: 0.0,
                    y_r: 0.0,
                    x_c: 0.0,
                })
            })
            .collect();
        let (Some(first), Some(last)) = (log.wheels.first(), log.wheels.last()) else {
            continue;
        };
        let (mut pct, mut along, mut across, mut dyaw) = (Vec::new(), 0.0, 0.0, 0.0);
        let mut t0 = first.t + 30.0;
        while t0 + 30.0 < last.t - 5.0 {
            let opts = RunOptions {
                outage: Some((t0, t0 + 30.0)),
            };
            let run = pipeline::run_with(
                &log,
                &cfg,
                &TerrainEvidence::None,
                params.as_ref(),
                opts,
                &mut |_, _| {},
            )?;
            if let Some(d) = metrics::outage_drift(&run, &truth, t0 - lat, t0 + 30.0 - lat) {
                if d.distance > 5.0 {
                    pct.push(d.percent);
                    along += (100.0 * d.along / d.distance).powi(2);
                    across += (100.0 * d.cross / d.distance).powi(2);
                    dyaw += d.yaw_error.to_degrees().powi(2);
                }
            }
            t0 += 60.0;
        }
        if pct.is_empty() {
            println!("| {dir} | 0 | - | - | - | - |");
            continue;
        }
        let n = pct.len() as f64;
        let max = pct.iter().fold(0.0f64, |a, b| a.max(*b));
        println!(
            "| {} | {} | {:.2} ({:.2}) | {:.2} | {:.2} | {:.2} |",
            std::path::Path::new(&dir)
                .file_name()
                .map_or(dir.clone(), |s| s.to_string_lossy().into()),
            pct.len(),
            pct.iter().sum::<f64>() / n,
            max,
            (along / n).sqrt(),
            (across / n).sqrt(),
            (dyaw / n).sqrt()
        );
    }
    Ok(())
}
