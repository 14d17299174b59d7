//! `terraslip terrain train|eval|crossval`: terrain classifiers from
//! vibration (IMU) or ground-camera frames.
//!
//! - `settings`: the training flags `train` and `crossval` share, turned
//!   into the library's `TrainOptions`.
//! - `train`, `eval`, `crossval`: one module per subcommand.

mod crossval;
mod eval;
mod settings;
mod train;

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use clap::Subcommand;
use indicatif::{ProgressBar, ProgressStyle};
use terraslip_io::DriveLog;

/// Train and evaluate terrain classifiers.
///
/// A model reads one source: `imu` (vibration windows of imu.csv plus tread
/// speeds from wheels.csv) or `camera` (frames listed in images.csv). Training
/// logs need terrain.csv labels. Evaluate on runs the model was not trained
/// on; `crossval` does that for you by leaving whole runs out.
///
/// Example:
///   terraslip terrain train data/borealtc/* --out husky.json
///   terraslip terrain eval other-run/ --model husky.json --plots eval/
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Train a classifier from labelled logs and save it as a JSON model.
    Train(train::TrainArgs),
    /// Classify labelled logs with a model: confusion matrix, raw and filtered
    /// accuracy, plots of the confusion matrix and of the terrain timeline.
    Eval(eval::EvalArgs),
    /// Leave-runs-out cross-validation: train without some runs, test on
    /// them, also spliced into logs with terrain changes for the Bayesian filter.
    Crossval(crossval::CrossvalArgs),
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Train(a) => train::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Crossval(a) => crossval::run(a),
    }
}

fn read_logs(paths: &[PathBuf], quiet: bool) -> anyhow::Result<Vec<DriveLog>> {
    let mut bar = Progress::new(paths.len() as u64, "reading logs", quiet);
    let mut logs = Vec::with_capacity(paths.len());
    for p in paths {
        let log = super::bag::read_full(p)?;
        logs.push(log);
        bar.inc();
    }
    bar.finish();
    Ok(logs)
}

/// Progress on stderr: a bar on a terminal; elsewhere (logs, CI) one line
/// `what: done/total (elapsed)` at most every TERRASLIP_PROGRESS_SECS
/// seconds (10 by default) and at the end of a step that took that long;
/// nothing when `quiet`.
struct Progress {
    bar: Option<ProgressBar>,
    what: &'static str,
    n: u64,
    done: u64,
    plain: bool,
    every: Duration,
    start: Instant,
    last: Instant,
}

impl Progress {
    fn new(n: u64, what: &'static str, quiet: bool) -> Self {
        let plain = !quiet && !std::io::stderr().is_terminal();
        let bar = (!quiet && !plain).then(|| {
            let bar = ProgressBar::new(n);
            bar.set_style(
                ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_message(what);
            bar
        });
        let every = std::env::var("TERRASLIP_PROGRESS_SECS")
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite() && *v >= 0.0)
            .map_or(Duration::from_secs(10), Duration::from_secs_f64);
        let now = Instant::now();
        Self {
            bar,
            what,
            n,
            done: 0,
            plain,
            every,
            start: now,
            last: now,
        }
    }

    fn set(&mut self, done: u64) {
        self.done = done;
        if let Some(bar) = &self.bar {
            bar.set_position(done);
        } else if self.plain && self.last.elapsed() >= self.every {
            self.last = Instant::now();
            eprintln!(
                "{}: {done}/{} ({:.0} s)",
                self.what,
                self.n,
                self.start.elapsed().as_secs_f64()
            );
        }
    }

    fn inc(&mut self) {
        self.set(self.done + 1);
    }

    fn finish(self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
