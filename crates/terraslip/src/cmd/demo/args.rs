//! The demo command's options.

use std::path::PathBuf;

const DETAILS: &str = "\
Simulates the drive of lv2019 §IV (soil -> grass -> asphalt, 1 Hz GNSS with
2 m correlated error, 1° compass, 540-tick encoders, ICRs that vary with the
turn rate, a 30 s GNSS outage), runs every estimator variant over it with the
log's terrain labels as evidence, and compares them:

  re-convergence   seconds after each terrain change until the spread
                   d = y_l - y_r stays within 2 cm of the truth (5 s means)
  steady RMS       ICR errors after the first 20 s on each terrain
  outage drift     dead reckoning on the estimated ICRs through the outage
                   (every pose fix dropped), end-point error in % of the path

DIR gets: report.html and report.md (table + plots), table.md, summary.json,
the plots as SVG, and the simulated log in DIR/log (try
`terraslip estimate DIR/log --out est --terrain-labels`).

Examples:
  terraslip demo
  terraslip demo --out /tmp/demo --seed 7
  terraslip demo --scenario papers-rtk     # the same drive, RTK-grade reference";

/// Simulate the papers' drive, compare every estimator variant, write a report.
#[derive(clap::Args, Debug)]
#[command(after_long_help = DETAILS)]
pub struct Args {
    /// Output directory (replaced if it holds an earlier demo).
    #[arg(long, default_value = "demo-out")]
    pub out: PathBuf,
    /// Seed of the simulated drive.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Scenario to drive (built-in name or TOML file); it should have terrain
    /// changes and one GNSS outage.
    #[arg(long, default_value = "papers")]
    pub scenario: String,
}
