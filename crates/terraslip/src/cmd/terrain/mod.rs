//! `terraslip terrain train|eval|crossval`: terrain classifiers from
//! vibration (IMU) or ground-camera frames.
//!
//! - `settings`: the training flags `train` and `crossval` share, turned
//!   into the library's `TrainOptions`.
//! - `train`, `eval`, `crossval`: one module per subcommand.

mod crossval;
mod eval;
mod logs;
mod progress;
mod settings;
mod train;

use clap::Subcommand;

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
