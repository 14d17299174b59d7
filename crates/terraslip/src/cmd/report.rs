//! `terraslip report EST_DIR`: plots and an HTML page of an estimate.

use std::path::PathBuf;

use anyhow::{Context, Result};
use terraslip::bag::Topics;

/// Draw an estimate: its track against the pose reference, the ICRs and
/// speed factors with 2σ bands, the 2 s prediction error.
///
/// Reads EST_DIR/estimate.csv, EST_DIR/summary.json and
/// EST_DIR/prediction.csv (all written by `terraslip estimate`; the
/// prediction error is summary.json's, start by start), reads the log or
/// bag named in summary.json (or --log; a bag with the topics the estimate
/// used, unless --topics is given) for the pose reference (truth.csv, when
/// the log is simulated), and writes report.html with track.svg, slip.svg,
/// prediction.svg and outage.svg (the dead reckoning through pose outages,
/// summary.json's outage) into --out (default EST_DIR).
///
/// Examples:
///   terraslip estimate data/warthog_gravel --out est
///   terraslip report est                  # est/report.html
///   terraslip report est --log drive/ --out figures/
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Directory written by `terraslip estimate`.
    pub estimate: PathBuf,
    #[arg(
        long,
        value_name = "LOG",
        help = concat!("The log or bag the estimate was run on (default: the \"log\" recorded in summary.json; give it when that moved). ", log_help!())
    )]
    pub log: Option<PathBuf>,
    /// Where to write report.html and the SVG plots (default: ESTIMATE).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

/// The files `report` writes into its output directory.
const OUTPUTS: [&str; 5] = [
    "report.html",
    "track.svg",
    "slip.svg",
    "prediction.svg",
    "outage.svg",
];

pub fn run(a: Args) -> Result<()> {
    let csv = a.estimate.join("estimate.csv");
    let prediction_path = a.estimate.join("prediction.csv");
    let summary_path = a.estimate.join("summary.json");
    if !csv.exists() {
        anyhow::bail!(
            "{}: not an estimate directory: it has no estimate.csv (write one with `terraslip estimate LOG --out {}`)",
            a.estimate.display(),
            a.estimate.display()
        );
    }
    let summary: Option<serde_json::Value> = match std::fs::read_to_string(&summary_path) {
        Ok(text) => Some(
            serde_json::from_str(&text)
                .with_context(|| format!("{}: not valid JSON", summary_path.display()))?,
        ),
        Err(_) => None,
    };
    let field = |k: &str| summary.as_ref().and_then(|s| s.get(k).cloned());
    let given = a.log.is_some();
    let log_dir = a
        .log
        .or_else(|| field("log").and_then(|v| v.as_str().map(PathBuf::from)));
    let out = a.out.unwrap_or_else(|| a.estimate.clone());
    let mut inputs = super::inputs();
    inputs
        .add(&csv, "the estimate")
        .add(&summary_path, "the estimate's summary")
        .add(&prediction_path, "the estimate's prediction errors");
    if let Some(d) = &log_dir {
        inputs.add(d, "the log");
    }
    inputs.check_dir("--out", &out, &OUTPUTS)?;
    let rows = terraslip_io::read_estimate(&csv)?;
    let prediction = if prediction_path.exists() {
        Some(terraslip_io::read_prediction(&prediction_path)?)
    } else {
        eprintln!(
            "warning: {} is missing; drawing without the 2 s prediction error (run `terraslip estimate` again to write it)",
            prediction_path.display()
        );
        None
    };
    // A bag is read again with the topics the estimate used, unless
    // --topics says otherwise.
    let topics = match (super::bag::topics(), field("bag_topics")) {
        (Topics::ByType, Some(record)) => super::bag::topics_from_record(&record),
        (given, _) => given.clone(),
    };
    let log = match &log_dir {
        Some(dir) if dir.exists() => {
            let mut log = super::bag::read_using(dir, &topics, super::read_log)?;
            let truth = dir.join("truth.csv");
            if truth.exists() {
                log.truth = terraslip_io::read_truth(&truth)?;
            }
            Some(log)
        }
        Some(dir) if given => {
            eprintln!(
                "warning: --log {} does not exist; drawing without the pose reference",
                dir.display()
            );
            None
        }
        Some(dir) => {
            eprintln!(
                "warning: log {} (recorded in {}) no longer exists (moved or renamed?); drawing without the pose reference; give its new place with --log PATH",
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
    let title = match &log_dir {
        Some(d) => format!("terraslip estimate of {}", d.display()),
        None => format!("terraslip estimate {}", a.estimate.display()),
    };
    let written = terraslip::report::write(
        &rows,
        log.as_ref(),
        prediction.as_deref(),
        summary.as_ref(),
        &out,
        &title,
    )?;
    println!("wrote {}", written.page.display());
    for p in &written.plots {
        println!("wrote {}", p.display());
    }
    Ok(())
}
