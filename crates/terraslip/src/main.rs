//! `terraslip`: a thin command-line shell over the terraslip libraries.
//! Each subcommand lives in `cmd/`; this file only parses and dispatches.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cmd;
mod progress;

/// How a skid-steering robot really moves: online ICR slip estimation,
/// terrain awareness and offline calibration.
///
/// Frames: ROS REP-103 (body x forward, y left; world ENU, yaw counter-clockwise
/// from east). Units: SI. Log directories follow docs/log-format.md.
#[derive(Parser)]
#[command(
    name = "terraslip",
    version,
    propagate_version = true,
    after_help = "Start here:
  terraslip demo                                      # simulate, compare every estimator, write demo-out/report.html
  terraslip simulate papers-rtk --out out/log --no-camera   # the papers' drive with an RTK-grade reference and ground truth
  terraslip calibrate out/log --out out/params.json   # ICR parameters per terrain (needs a precise pose reference)
  terraslip estimate out/log --out out/est --init out/params.json --terrain-labels
  terraslip report out/est                            # out/est/report.html: track, ICRs, prediction error, outages
Each command's --help has more examples; docs/ has the method and the figures."
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    command: Command,
    /// ROS 2 bags given as LOG: which topic feeds which stream (see `import --help`).
    #[arg(long, global = true, value_name = "FILE.toml")]
    topics: Option<std::path::PathBuf>,
    /// ROS 2 bags: refuse a bag with a message that cannot be physical (not
    /// finite, out of range, a stamp out of order or repeated), naming its
    /// topic, index and stamp; such messages are skipped with a warning otherwise.
    #[arg(long, global = true)]
    strict: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate the papers' drive, compare every estimator variant, write a report.
    Demo(cmd::demo::Args),
    /// Write a simulated drive log with ground truth.
    Simulate(cmd::simulate::Args),
    /// Run the online ICR estimator over a drive log.
    Estimate(cmd::estimate::Args),
    /// Draw an estimate: track, ICRs with 2σ bands, prediction error, dead reckoning through outages (report.html).
    Report(cmd::report::Args),
    /// Train and evaluate terrain classifiers.
    Terrain(cmd::terrain::Args),
    /// Identify ICR kinematic parameters offline from drives with a pose reference.
    // Boxed: its many flags make it much larger than the other variants.
    Calibrate(Box<cmd::calibrate::Args>),
    /// Convert a ROS 2 bag (MCAP or sqlite3) into a drive log.
    #[cfg(feature = "ros2")]
    Import(cmd::import::Args),
    /// Run the estimator live as a ROS 2 node (no ROS install needed).
    #[cfg(any(feature = "node", feature = "node-humble"))]
    Node(cmd::node_args::Args),
    /// Run the estimator live as a ROS 2 node: not in this build (install it
    /// with `--features node`, docs/user-guide.md §8).
    #[cfg(not(any(feature = "node", feature = "node-humble")))]
    #[command(disable_help_flag = true)]
    Node {
        /// Whatever was given: this build has no node to take it.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true, hide = true)]
        args: Vec<String>,
    },
}

/// What `terraslip node` says in a build without the node.
#[cfg(not(any(feature = "node", feature = "node-humble")))]
const NO_NODE: &str = "this terraslip is built without the ROS 2 node (it brings the DDS stack in): \
install it with `cargo install --path crates/terraslip --features node` for a Jazzy, Iron or Kilted graph, \
or `--features node-humble` for Humble (docs/user-guide.md §8)";

/// Splits a command line at `--ros-args`: the arguments before it (and
/// after a closing `--`), and those of the ROS section.
fn split_ros_args(args: &[String]) -> (Vec<String>, Vec<String>) {
    let mut own = Vec::new();
    let mut ros = Vec::new();
    let mut in_ros = false;
    for a in args {
        match a.as_str() {
            "--ros-args" => in_ros = true,
            "--" if in_ros => in_ros = false,
            _ if in_ros => ros.push(a.clone()),
            _ => own.push(a.clone()),
        }
    }
    (own, ros)
}

fn main() -> ExitCode {
    // ROS 2 arguments (`--ros-args ...`) are the node's, not clap's.
    let args: Vec<String> = std::env::args().collect();
    let (own, ros_args) = split_ros_args(&args);
    let cli = Cli::parse_from(own);
    #[cfg(not(any(feature = "node", feature = "node-humble")))]
    if !ros_args.is_empty() && !matches!(cli.command, Command::Node { .. }) {
        eprintln!("error: --ros-args is for `terraslip node` (build with --features node)");
        return ExitCode::FAILURE;
    }
    cmd::bag::set_topics(cli.topics, cli.strict);
    let result = match cli.command {
        Command::Demo(a) => cmd::demo::run(a),
        Command::Simulate(a) => cmd::simulate::run(a),
        Command::Estimate(a) => cmd::estimate::run(a),
        Command::Report(a) => cmd::report::run(a),
        Command::Terrain(a) => cmd::terrain::run(a),
        Command::Calibrate(a) => cmd::calibrate::run(*a),
        #[cfg(feature = "ros2")]
        Command::Import(a) => cmd::import::run(a),
        #[cfg(any(feature = "node", feature = "node-humble"))]
        Command::Node(a) => cmd::node::run(a, &ros_args),
        #[cfg(not(any(feature = "node", feature = "node-humble")))]
        Command::Node { .. } => Err(anyhow::anyhow!(NO_NODE)),
    };

    cmd::bag::cleanup();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", terraslip::one_line(&e));
            ExitCode::FAILURE
        }
    }
}
