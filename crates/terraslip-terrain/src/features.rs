//! What a model reads from a log: the feature extraction settings of its
//! source (IMU vibration windows or ground-camera frames).

use serde::{Deserialize, Serialize};

use crate::vibration::VibrationConfig;
use crate::vision::VisionConfig;

/// Feature extraction settings of either source.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Features {
    Vibration {
        config: VibrationConfig,
        /// IMU rate the model was trained at, Hz (a log at another rate is refused).
        rate_hz: f64,
    },
    Vision {
        config: VisionConfig,
        /// lv2019 change detector: a terrain change when `φ_t` exceeds this.
        change_threshold: f64,
    },
}
