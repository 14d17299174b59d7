//! Why a simulation could not be run or written.

use std::path::PathBuf;
use terraslip_io::LogError;

/// Errors of the simulator.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A scenario file that does not parse or validate; `line` 0 = whole file.
    #[error("{}{}: {reason}", path.display(), if *line > 0 { format!(":{line}") } else { String::new() })]
    Scenario {
        path: PathBuf,
        line: usize,
        reason: String,
    },
    #[error("unknown scenario `{name}` (built-in: {known}; or give a .toml file)")]
    UnknownScenario { name: String, known: String },
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Log(#[from] LogError),
    #[error("{}: cannot encode image: {reason}", path.display())]
    Image { path: PathBuf, reason: String },
}
