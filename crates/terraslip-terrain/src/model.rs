//! The serialisable terrain model: what it reads (source and features),
//! how it scales them, the trained classifier and the filter settings; and
//! the call the estimator pipeline makes, [`TerrainModel::classify_log`].
use serde::{Deserialize, Serialize};
use terraslip_io::DriveLog;

use crate::classify::{argmax, Classifier, ClassifierParams, Standardizer};
use crate::confidence::ClassDistance;
use crate::envelope::{lower_confidence, Envelope};
use crate::error::{Result, TerrainError};
pub use crate::features::Features;
pub use crate::samples::extract;
use crate::speed_norm::SpeedNormalisation;
pub use crate::timeline::{BeliefSettings, FilteredFrame, TerrainTimeline};
pub use crate::train_options::TrainOptions;
use crate::vibration::{ChannelSet, VibrationFeatureSet};

/// Version of the model file format; a file of another version is refused.
/// 2: the `full` vibration set gained the steering-efficiency (slip) and
/// manoeuvre features. 3: the vibration settings gained the spatial bands
/// (`spatial_bands`, grid, scaling). 4: the learnt speed normalisation
/// (`speed_norm` settings, `speed_normalisation` slopes). 5: the vibration
/// settings record the motor-current channels (`currents`); the spatial
/// bands are gone. 6: the manoeuvre envelope (`envelope`). 7: the current
/// in excess of the robot's baseline at the window's speed and turn
/// (`current_excess`, `speed_normalisation.current_baseline`). 8: no
/// `calibration` (the probabilities are the classifier's own).
pub const MODEL_FORMAT_VERSION: u32 = 8;

/// The sensor a model reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// `imu.csv` (+ tread speeds from `wheels.csv`).
    Imu,
    /// `images.csv` ground-camera frames.
    Camera,
}

impl Source {
    pub fn name(self) -> &'static str {
        match self {
            Source::Imu => "imu",
            Source::Camera => "camera",
        }
    }
}

/// What the model was trained on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainingInfo {
    pub logs: Vec<String>,
    /// Training windows (frames) per class, in the order of `classes`.
    pub samples_per_class: Vec<usize>,
    /// Speed factors of the training copies ([`crate::augment`]); empty: none.
    #[serde(default)]
    pub speed_copies: Vec<f64>,
    /// Windows of the speed copies trained on, per class (beside
    /// `samples_per_class`); empty without copies.
    #[serde(default)]
    pub speed_copy_samples_per_class: Vec<usize>,
}

/// A trained terrain classifier, saved as JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TerrainModel {
    pub format_version: u32,
    pub source: Source,
    /// Terrain names; class `i` of every probability vector is `classes[i]`.
    pub classes: Vec<String>,
    pub features: Features,
    pub feature_names: Vec<String>,
    /// Learnt speed slopes applied before `normalisation` (vibration
    /// models trained with `speed_norm`; `null` otherwise).
    #[serde(default)]
    pub speed_normalisation: Option<SpeedNormalisation>,
    pub normalisation: Standardizer,
    /// Tread speeds and differences of the training windows per class
    /// (vibration models of the `full` set; `null` otherwise).
    #[serde(default)]
    pub envelope: Option<Envelope>,
    pub classifier_settings: ClassifierParams,
    pub classifier: Classifier,
    /// Per-class spread of the training windows in standardised feature
    /// space, for the novelty of a window (`null` in older files).
    #[serde(default)]
    pub class_distance: Option<ClassDistance>,
    pub belief: BeliefSettings,
    pub training: TrainingInfo,
}

/// Below this mean tread speed (m/s) over a vibration window the robot is
/// standing or spinning slowly in place: the terrain hardly shakes it, and
/// the classifier's verdict is a guess (on the simulated drives, every
/// wrongly declared terrain came from such windows). Such windows carry no
/// evidence for the estimator.
pub const MIN_INFORMATIVE_SPEED: f64 = 0.2;

impl TerrainModel {
    /// What the online estimator should fuse: [`Self::classify_log`]'s
    /// class probabilities floored by the model's `prob_floor`, without the
    /// vibration windows in which the robot was nearly still (mean tread
    /// speed below [`MIN_INFORMATIVE_SPEED`]) and without the frames whose
    /// verdict is unsure (confidence below
    /// [`crate::confidence::EVIDENCE_BELOW`]): an unsure terrain is no evidence, the
    /// belief keeps what it had and the estimator's own innovation-driven
    /// change detection decides. Camera frames are kept at any speed.
    /// Each frame is stamped at the middle of its window
    /// ([`TerrainTimeline::stamped_at_window_middle`]): the estimator
    /// declares a ground where it began, not half a window later.
    pub fn estimator_evidence(&self, log: &DriveLog) -> Result<TerrainTimeline> {
        let mut timeline = self.classify_log(log)?;
        let mut keep = vec![true; timeline.frames.len()];
        if let Features::Vibration { config, .. } = &self.features {
            let w = &log.wheels;
            for ((t, _), k) in timeline.frames.iter().zip(keep.iter_mut()) {
                let lo = w.partition_point(|s| s.t < t - config.window_s);
                let hi = w.partition_point(|s| s.t <= *t);
                let n = hi.saturating_sub(lo);
                let sum: f64 = w[lo..hi.max(lo)]
                    .iter()
                    .map(|s| 0.5 * (s.v_left.abs() + s.v_right.abs()))
                    .sum();
                *k &= n > 0 && sum / n.max(1) as f64 >= MIN_INFORMATIVE_SPEED;
            }
        }
        timeline.retain_frames(&keep);
        Ok(timeline
            .sure_evidence(self.belief.prob_floor)
            .stamped_at_window_middle(self.window_s()))
    }
    /// What the model reads from a log, for messages: e.g. `imu.csv (all
    /// six channels), wheels.csv tread speeds and motor currents`.
    pub fn channels_description(&self) -> String {
        match &self.features {
            Features::Vision { .. } => "images.csv frames".into(),
            Features::Vibration { config, .. } => {
                match (config.feature_set, config.channels, config.currents) {
                    (VibrationFeatureSet::Paper, ..) => "imu.csv accel_z".into(),
                    (_, c, cur) => format!(
                        "imu.csv ({}), wheels.csv tread speeds{}",
                        match c {
                            ChannelSet::All => "all six channels",
                            ChannelSet::AccelZ => "accel_z",
                        },
                        if cur { " and motor currents" } else { "" }
                    ),
                }
            }
        }
    }

    /// Length of the span of data behind one output, s: the IMU window, 0
    /// for camera frames.
    pub fn window_s(&self) -> f64 {
        match &self.features {
            Features::Vibration { config, .. } => config.window_s,
            Features::Vision { .. } => 0.0,
        }
    }

    /// Class probabilities of every window (IMU) or frame (camera) of a log.
    pub fn classify_log(&self, log: &DriveLog) -> Result<TerrainTimeline> {
        let samples = extract(log, &self.features)?;
        let k = self.classes.len();
        let threshold = match &self.features {
            Features::Vision {
                change_threshold, ..
            } => *change_threshold,
            Features::Vibration { .. } => f64::INFINITY,
        };
        let mut tl = TerrainTimeline {
            classes: self.classes.clone(),
            frames: Vec::with_capacity(samples.len()),
            changes: Vec::new(),
            outside_envelope: Vec::new(),
            novelty: Vec::new(),
        };
        let manoeuvre = manoeuvre_indices(&self.features);
        for (t, mut x, phi) in samples {
            if x.len() != self.normalisation.mean.len() {
                return Err(TerrainError::Data(format!(
                    "{}: {} features per window, the model expects {}",
                    log.name(),
                    x.len(),
                    self.normalisation.mean.len()
                )));
            }
            let driven = manoeuvre.map(|(iv, id)| (x[iv], x[id]));
            if let Some(sn) = &self.speed_normalisation {
                sn.apply(&mut x);
            }
            let mut p = vec![0.0; k];
            let xs = self.normalisation.apply(&x);
            self.classifier.predict_proba(&xs, &mut p);
            if let (Some(e), Some((v, d))) = (&self.envelope, driven) {
                let outside = !e.covers(argmax(&p), v, d);
                if outside {
                    lower_confidence(&mut p);
                }
                tl.outside_envelope.push(outside);
            }
            if let Some(cd) = &self.class_distance {
                tl.novelty.push(cd.novelty(&xs, argmax(&p)));
            }
            if phi > threshold {
                tl.changes.push(t);
            }
            tl.frames.push((t, p));
        }
        Ok(tl)
    }
}

/// Indices of the tread speed and tread speed difference features (the
/// `full` vibration set), which the envelope reads.
pub(crate) fn manoeuvre_indices(f: &Features) -> Option<(usize, usize)> {
    let Features::Vibration { config, .. } = f else {
        return None;
    };
    let names = config.feature_names();
    let at = |n: &str| names.iter().position(|m| m == n);
    Some((at("tread_speed")?, at("tread_speed_diff")?))
}
