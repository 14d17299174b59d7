//! `terraslip-lab`: the estimator's quality benchmarks. Every change to the
//! default estimator is judged on both:
//!
//!     cargo run -p terraslip-lab --release -- family --worlds 50
//!     cargo run -p terraslip-lab --release -- family --worlds 50 --subset gnss2m
//!     cargo run -p terraslip-lab --release -- family --worlds 50 --subset papers
//!     cargo run -p terraslip-lab --release -- family --worlds 50 --gyro [--gyro-scale 0.03]
//!     cargo run -p terraslip-lab --release -- drives
//!     cargo run -p terraslip-lab --release -- odometry-nees
//!     cargo run -p terraslip-lab --release -- follow --seeds 20
//!     cargo run -p terraslip-lab --release -- terrain-trust [--borealtc DIR] [--evidence-cache DIR]
//!
//! Estimators are named presets (`terraslip`, `ekf-qmin`, `no-slip`, ...)
//! or `config:FILE.toml` (the default overridden by that file's keys).
//! docs/benchmarks.md has the figures.

use clap::{Parser, Subcommand};

mod blr;
mod borealtc_trust;
mod drive_protocol;
mod drive_readings;
mod drives;
mod estimators;
mod family;
mod family_outages;
mod family_run;
mod family_target;
mod follow;
mod heldout;
mod hindsight;
mod misread;
mod odometry_nees;
mod outage_table;
mod prediction_table;
mod scored_model;
mod seeds;
mod silent_changes;
mod smoothing_spline;
mod stats;
mod terrain_trust;
mod verdict_confidence;

/// The estimator's quality benchmarks.
#[derive(Parser)]
#[command(name = "terraslip-lab")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The family of simulated worlds: distributions of each estimator's
    /// figures (median, 90th percentile, worst).
    Family(family::Args),
    /// The real drives: the 2 s prediction error of each estimator, against
    /// the no-slip model and a calibration of the same drive.
    Drives(drives::Args),
    /// DRIVE's learned slip model against the online default and
    /// `calibrate`, each trained on data the score does not see: first half
    /// -> second half of every drive, and drive -> drive (`--across`).
    Heldout(heldout::Args),
    /// Whether the odometry's published twist and pose covariances are
    /// honest: their NEES against a pose reference, with the 95 % band.
    OdometryNees(odometry_nees::Args),
    /// A regulated pure pursuit follower over grounds of different slip,
    /// steering on the online estimate in the closed-loop simulator:
    /// without compensation, through a static wheel separation multiplier
    /// tuned on the first ground, and through live compensation; cross-track
    /// RMS, heading error at the end of turns, time to finish and recovery
    /// after a ground change, median and worst over the seeds.
    Follow(follow::Args),
    /// The estimator given terrain labels, a classifier or nothing: on
    /// simulated worlds whose classifier misreads a ground (confidently or
    /// unsure), and on BorealTC with models trained without each run.
    TerrainTrust(terrain_trust::Args),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::Family(a) => family::run(a),
        Command::Drives(a) => drives::run(a),
        Command::Heldout(a) => heldout::run(a),
        Command::OdometryNees(a) => odometry_nees::run(a),
        Command::Follow(a) => follow::run(a),
        Command::TerrainTrust(a) => terrain_trust::run(a),
    }
}
