//! Everything training needs besides the logs: the source, the feature
//! and classifier settings, and the optional steps (channel and speed
//! floor choice, speed copies).

use crate::augment::SpeedAugmentation;
use crate::classify::ClassifierParams;
use crate::model::Source;
use crate::timeline::BeliefSettings;
use crate::vibration::{ChannelSet, VibrationConfig};
use crate::vision::VisionConfig;

/// Everything `train` needs besides the logs.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainOptions {
    pub source: Source,
    pub vibration: VibrationConfig,
    pub vision: VisionConfig,
    pub classifier: ClassifierParams,
    pub belief: BeliefSettings,
    /// IMU channels of the `full` set; `None`: all six when every training
    /// log has them, else `accel_z` (overrides `vibration.channels`).
    pub imu_channels: Option<ChannelSet>,
    /// Motor-current features of the `full` set; `None`: when every
    /// training log has currents (overrides `vibration.currents`).
    pub currents: Option<bool>,
    /// Speed floor of the speed normalisation, m/s; `None`: chosen by inner
    /// cross-validation over the training runs (overrides
    /// `vibration.speed_norm_min`).
    pub speed_floor: Option<f64>,
    /// Speed copies of the training logs ([`crate::augment`]; `full`
    /// vibration features with speed normalisation only; ignored
    /// otherwise); `None`: the recorded windows only.
    pub speed_augmentation: Option<SpeedAugmentation>,
}

impl Default for TrainOptions {
    fn default() -> Self {
        Self {
            source: Source::Imu,
            vibration: VibrationConfig::default(),
            vision: VisionConfig::default(),
            classifier: ClassifierParams::default(),
            belief: BeliefSettings::default(),
            imu_channels: None,
            currents: None,
            speed_floor: None,
            speed_augmentation: Some(SpeedAugmentation::default()),
        }
    }
}
