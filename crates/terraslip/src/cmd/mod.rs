use std::path::{Path, PathBuf};

/// The help of every LOG argument: what it takes.
#[cfg(feature = "ros2")]
macro_rules! log_help {
    () => {
        "A log directory (wheels.csv, pose.csv, meta.toml: docs/log-format.md) or a rosbag2 \
         recording: a bag directory or one .mcap or .db3 file (MCAP or sqlite3 storage). A \
         bag's topics are chosen by their types, each choice printed as a `decided:` line; \
         --topics FILE.toml chooses them (see `terraslip import --help`)."
    };
}
#[cfg(not(feature = "ros2"))]
macro_rules! log_help {
    () => {
        "A log directory (wheels.csv, pose.csv, meta.toml: docs/log-format.md); ROS 2 bags \
         need a build with the `ros2` feature."
    };
}

pub mod bag;
pub mod calibrate;
pub mod demo;
pub mod estimate;
#[cfg(feature = "ros2")]
pub mod import;
#[cfg(any(feature = "node", feature = "node-humble"))]
pub mod node;
#[cfg(any(feature = "node", feature = "node-humble"))]
pub mod node_args;
#[cfg(any(feature = "node", feature = "node-humble"))]
mod node_compensate;
#[cfg(any(feature = "node", feature = "node-humble"))]
mod node_outputs;
#[cfg(any(feature = "node", feature = "node-humble"))]
mod node_params;
#[cfg(any(feature = "node", feature = "node-humble"))]
mod node_state;
#[cfg(any(feature = "node", feature = "node-humble"))]
mod realtime;
pub mod report;
#[cfg(feature = "ros2")]
pub mod ros2out;
pub mod simulate;
pub mod terrain;

pub use terraslip::estimate::read_log;

/// The paths a command reads, to check its outputs against (one rule for
/// every command: an output is never an input nor inside one): the global
/// `--topics` when given; the command adds its own.
pub fn inputs() -> terraslip_io::Inputs {
    let mut inputs = terraslip_io::Inputs::new();
    if let terraslip::bag::Topics::File(p) = bag::topics() {
        inputs.add(p, "--topics");
    }
    inputs
}

/// [`inputs`] with `logs` (log directories or bags) and `files`, each
/// named by its flag.
pub fn inputs_with(logs: &[PathBuf], files: &[(&str, Option<&Path>)]) -> terraslip_io::Inputs {
    let mut inputs = inputs();
    for l in logs {
        inputs.add(l, "an input log");
    }
    for (flag, f) in files {
        if let Some(f) = f {
            inputs.add(f, flag);
        }
    }
    inputs
}
