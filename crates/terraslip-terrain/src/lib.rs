//! Terrain evidence from sensors (issue 4).
//!
//! - [`vibration`]: IMU window features (wang2018 + spectral and speed
//!   terms); [`windows`]: a log cut into windows.
//! - [`motion`]: tread speeds and slip terms of a window; [`current`]:
//!   drive-motor current features.
//! - [`vision`]: ground-camera features: RGB histograms + uniform LBP and the
//!   frame-to-frame change detector (lv2019), SFTA and the region of
//!   interest predicted from the kinematic model (chen2023).
//! - [`classify`]: the classifiers and k-nearest neighbours; [`tree`]: the
//!   pruned decision tree; [`boost`]: gradient-boosted trees.
//! - [`select`]: channels and the speed floor chosen from the training logs.
//! - [`model`]: the serialisable [`TerrainModel`] and
//!   [`TerrainModel::classify_log`], the call the estimator pipeline makes;
//!   `features` (what a model reads), `timeline` (class probabilities over
//!   time and the belief filter's settings), `model_file` (the JSON file).
//! - Training: `train_options` ([`TrainOptions`]), `fit` (the model fitted
//!   to labelled logs), `train` ([`TerrainModel::train`]).
//! - [`eval`]: confusion matrices, scored and spliced logs;
//!   [`crossval`](mod@crossval): leave-runs-out cross-validation (parallel
//!   folds), the runs held out chosen by `folds`.
//! - [`speed_norm`]: learnt per-feature speed slopes; [`envelope`]: the
//!   speeds and turns each terrain was trained at.
//! - [`confidence`]: the "unknown" verdict, novelty, and their scores
//!   (ECE, risk–coverage, AUROC).
//! - [`augment`]: speed copies of training logs (driven faster or slower).
//! - [`synth`]: small synthetic labelled logs for tests and benchmarks.
//!
//! The Bayesian (HMM) filter and the λ-vote live in
//! `terraslip_core::terrain_belief`, allocation-free, so the robot-side
//! estimator can run them.

pub mod augment;
pub mod boost;
pub mod classify;
pub mod confidence;
pub mod crossval;
pub mod current;
pub mod envelope;
pub mod error;
pub mod eval;
mod features;
mod fit;
mod folds;
pub mod model;
mod model_file;
pub mod motion;
mod samples;
pub mod select;
pub mod speed_norm;
pub mod synth;
mod timeline;
mod train;
mod train_options;
pub mod tree;
pub mod vibration;
pub mod vision;
pub mod windows;

pub use classify::{Classifier, ClassifierKind, ClassifierParams};
pub use crossval::{
    crossval, crossval_manoeuvre, manoeuvre_split, run_folds, CrossvalReport, HeldOut, Manoeuvre,
    RunScore,
};
pub use error::{Result, TerrainError};
pub use eval::{score_log, splice, ChangeScore, Confusion, LogScore};
pub use model::{
    BeliefSettings, Features, FilteredFrame, Source, TerrainModel, TerrainTimeline, TrainOptions,
    MIN_INFORMATIVE_SPEED, MODEL_FORMAT_VERSION,
};
pub use speed_norm::SpeedNormalisation;
pub use vibration::{ChannelSet, VibrationConfig, VibrationFeatureSet};
pub use vision::{CameraModel, RoiConfig, VisionConfig, VisionFeatureSet};
