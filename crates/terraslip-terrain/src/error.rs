use std::path::PathBuf;

/// Everything that can go wrong between sensor data and a terrain verdict.
/// Each variant says what was wrong with which input.
#[derive(Debug, thiserror::Error)]
pub enum TerrainError {
    /// A log lacks the sensor stream the model or the command needs.
    #[error("{log}: no {sensor} data ({reason})")]
    MissingSource {
        log: String,
        sensor: &'static str,
        reason: String,
    },
    /// A log has no `terrain.csv` labels but they are needed (training, scoring).
    #[error("{log}: no terrain labels (terrain.csv) to train or score against")]
    MissingLabels { log: String },
    /// An image could not be opened or decoded.
    #[error("{path}: cannot read image: {reason}")]
    Image { path: PathBuf, reason: String },
    /// A model file could not be read, parsed or written.
    #[error("{path}: {reason}")]
    ModelFile { path: PathBuf, reason: String },
    /// A model from another format version.
    #[error("{path}: model format version {found}, this terraslip reads version {expected}; retrain the model")]
    ModelVersion {
        path: PathBuf,
        found: u32,
        expected: u32,
    },
    /// The model's classes differ from the ones asked for.
    #[error("model classes {model:?} differ from expected classes {expected:?}")]
    ClassMismatch {
        model: Vec<String>,
        expected: Vec<String>,
    },
    /// Training data that cannot give a usable classifier.
    #[error("cannot train: {0}")]
    Training(String),
    /// Settings that make no sense (window shorter than a sample, k = 0...).
    #[error("invalid setting: {0}")]
    Config(String),
    /// Input data that is unusable (non-finite values, empty windows...).
    #[error("{0}")]
    Data(String),
}

pub type Result<T, E = TerrainError> = std::result::Result<T, E>;
