//! terraslip on a live ROS 2 graph, with no ROS install: one static binary
//! joins the graph through RustDDS (`ros2-client`), interoperable with the
//! DDS implementations ROS 2 ships (Fast DDS, Cyclone DDS).
//!
//! - [`env`]: `ROS_DOMAIN_ID` and the discovery range
//!   (`ROS_AUTOMATIC_DISCOVERY_RANGE`, `ROS_LOCALHOST_ONLY`);
//! - [`args`]: `--ros-args` (remaps, parameters, parameter files);
//! - [`graph`]: the node, discovery, raw CDR readers and writers with
//!   ROS QoS;
//! - [`params`]: the node's parameters on the ROS 2 parameter services;
//! - [`signals`]: SIGINT and SIGTERM as a flag, for a clean shutdown.
//!
//! What the node computes lives in `terraslip::pipeline::live` and
//! `terraslip_ros2::import::LiveImport`; this crate only moves bytes.

pub mod args;
pub mod env;
pub mod graph;
pub mod params;

pub use args::RosArgs;
pub use env::{DiscoveryRange, RosEnv};
pub use graph::{Graph, GraphTopic, Reader, TopicQos, Wait, Writer};
pub use params::{Change, Changes, Parameters};

use std::path::PathBuf;

/// The ROS 2 distribution the node was built for (its node GID layout).
pub const DISTRO: &str = if cfg!(feature = "jazzy") {
    "jazzy"
} else {
    "humble"
};

/// Errors joining or using the graph.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    #[error("environment variable {name}={value}: {reason}")]
    Env {
        name: String,
        value: String,
        reason: String,
    },
    #[error("--ros-args `{arg}`: {reason}")]
    Args { arg: String, reason: String },
    #[error("--params-file {path}: {reason}")]
    ParamsFile { path: PathBuf, reason: String },
    #[error("DDS: {0}")]
    Dds(String),
}

/// SIGINT and SIGTERM as a flag the node's loop polls.
pub mod signals {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    /// Set once SIGINT or SIGTERM arrived.
    #[derive(Clone)]
    pub struct Stop(Arc<AtomicBool>);

    impl Stop {
        /// Installs the handlers.
        pub fn install() -> std::io::Result<Self> {
            let flag = Arc::new(AtomicBool::new(false));
            for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
                signal_hook::flag::register(sig, Arc::clone(&flag))?;
            }
            Ok(Self(flag))
        }
        /// Whether a stop was asked for.
        pub fn asked(&self) -> bool {
            self.0.load(Ordering::Relaxed)
        }
    }
}
