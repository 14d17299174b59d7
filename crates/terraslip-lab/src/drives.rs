//! `terraslip-lab drives`: each estimator over the real drives with a pose
//! reference (`../shared/data/drive` by default): the 2 s prediction error
//! (as `estimate` reports it in summary.json, read with the clock offset
//! the run had learned), against the no-slip model and an LM calibration
//! fitted on the same drive (the offline reference: it has seen the whole
//! drive; read with its `time_offset_s`).

use std::path::PathBuf;

use anyhow::Context;
use terraslip::pipeline::{self, TerrainEvidence};
use terraslip_calib::{calibrate, CalibConfig, Method};
use terraslip_io::DriveLog;

use crate::estimators;

/// Run every estimator over the real drives.
#[derive(clap::Args)]
pub struct Args {
    /// Log directories with a pose reference (default: every one under
    /// ../shared/data/drive).
    logs: Vec<PathBuf>,
    /// Estimators to compare (repeatable): a preset or `config:FILE.toml`.
    #[arg(long = "estimator", default_values_t = ["terraslip".to_string(), "ekf-qmin".to_string(), "no-slip".to_string()])]
    estimators: Vec<String>,
    /// Skip the calibration of each drive (slow on long drives).
    #[arg(long)]
    no_calibrate: bool,
}

/// `logs`, or every drive with a pose reference under ../shared/data/drive.
pub fn logs_or_default(logs: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    if !logs.is_empty() {
        return Ok(logs.to_vec());
    }
    let root = PathBuf::from("../shared/data/drive");
    let mut found: Vec<PathBuf> = std::fs::read_dir(&root)
        .with_context(|| format!("{}: no drives given and none found there", root.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("pose.csv").exists())
        .collect();
    found.sort();
    Ok(found)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let logs = logs_or_default(&a.logs)?;
    let cfgs = estimators::resolve(&a.estimators)?;
    println!("2 s prediction error, mean (p90), m; final spread d (m) and speed factor; warnings");
    for dir in &logs {
        let log = DriveLog::read(dir).with_context(|| format!("reading {}", dir.display()))?;
        let name = dir
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into());
        println!("{name}");
        let mut no_slip = None;
        for (est, cfg) in &cfgs {
            let run = pipeline::run(&log, cfg, &TerrainEvidence::None, None)?;
            let Some(p) = terraslip::prediction_score(&log, &run) else {
                println!("  {est:14} no pose reference to score against");
                continue;
            };
            no_slip = Some(p.no_slip);
            let f = run.final_icr;
            println!(
                "  {est:14} {:6.3} ({:6.3})   d {:5.2} alpha {:.3} {:.3}   clock {:+.3} s   {}",
                p.stats.mean_m,
                p.stats.p90_m,
                f.spread(),
                f.alpha_l,
                f.alpha_r,
                run.clock_offset.0,
                run.warnings.len()
            );
        }
        if let Some(n) = no_slip {
            println!("  {:14} {:6.3} ({:6.3})", "(no-slip)", n.mean_m, n.p90_m);
        }
        if !a.no_calibrate {
            let cc = CalibConfig {
                method: Some(Method::Lm),
                ..Default::default()
            };
            match calibrate(std::slice::from_ref(&log), &cc, &|_| {}) {
                Ok(cal) => {
                    let pf = cal.params_file();
                    let w = log.meta.track_width.unwrap_or(0.5);
                    // The selected model, read with the calibration's own
                    // clock offset.
                    let clock_offset = terraslip_calib::validate::stored_offset(&pf).unwrap_or(0.0);
                    let timed_at = |t: f64| {
                        let k = log.terrain.partition_point(|l| l.t <= t);
                        let name = k.checked_sub(1).map(|k| log.terrain[k].terrain.as_str());
                        terraslip::validation::timed(&pf, name, clock_offset)
                    };
                    if let Some(p) = terraslip_calib::prediction::score_timed(
                        &log.wheels,
                        &log.pose,
                        w,
                        &timed_at,
                        Default::default(),
                    ) {
                        println!(
                            "  {:14} {:6.3} ({:6.3})",
                            "calibrate (LM)", p.stats.mean_m, p.stats.p90_m
                        );
                    }
                }
                Err(e) => println!("  calibrate failed: {e}"),
            }
        }
    }
    Ok(())
}
