//! `terraslip report EST_DIR`: plots and an HTML page of an estimate.

use std::path::PathBuf;

use anyhow::{Context, Result};

/// Draw an estimate: its track against the pose reference, the ICRs and
/// speed factors with 2σ bands, the 2 s prediction error.
///
/// Reads EST_DIR/estimate.csv and EST_DIR/summary.json (both written by
/// `terraslip estimate`), reads the log named in summary.json (or --log)
/// for the pose reference (truth.csv, when the log is simulated) and the
/// wheels, and writes report.html with
/// track.svg, slip.svg and prediction.svg into --out (default EST_DIR).
///
/// Examples:
///   terraslip estimate data/warthog_gravel --out est
///   terraslip report est                  # est/report.html
///   terraslip report est --log drive/ --out figures/
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Directory written by `terraslip estimate`.
    pub estimate: PathBuf,
    /// The log the estimate was run on (default: the "log" in summary.json).
    #[arg(long, value_name = "LOG")]
    pub log: Option<PathBuf>,
    /// Where to write report.html and the SVG plots (default: ESTIMATE).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<()> {
    let csv = a.estimate.join("estimate.csv");
    let rows = terraslip_io::read_estimate(&csv)?;
    let summary_path = a.estimate.join("summary.json");
    let summary: Option<serde_json::Value> = match std::fs::read_to_string(&summary_path) {
        Ok(text) => Some(
            serde_json::from_str(&text)
                .with_context(|| format!("{}: not valid JSON", summary_path.display()))?,
        ),
        Err(_) => None,
    };
    let field = |k: &str| summary.as_ref().and_then(|s| s.get(k).cloned());
    let log_dir = a
        .log
        .or_else(|| field("log").and_then(|v| v.as_str().map(PathBuf::from)));
    let log = match &log_dir {
        Some(dir) if dir.exists() => {
            let mut log = super::read_log(dir)?;
            let truth = dir.join("truth.csv");
            if truth.exists() {
                log.truth = terraslip_io::read_truth(&truth)?;
            }
            Some(log)
        }
        Some(dir) => {
            eprintln!(
                "warning: log {} (from {}) not found; drawing without the pose reference (pass --log)",
                dir.display(),
                summary_path.display()
            );
            None
        }
        None => {
            eprintln!("warning: no log named; drawing without the pose reference (pass --log)");
            None
        }
    };
    let track_width = field("track_width").and_then(|v| v.as_f64());
    let out = a.out.unwrap_or_else(|| a.estimate.clone());
    let title = match &log_dir {
        Some(d) => format!("terraslip estimate of {}", d.display()),
        None => format!("terraslip estimate {}", a.estimate.display()),
    };
    let written = terraslip::report::write(&rows, log.as_ref(), track_width, &out, &title)?;
    println!("wrote {}", written.page.display());
    for p in &written.plots {
        println!("wrote {}", p.display());
    }
    Ok(())
}
