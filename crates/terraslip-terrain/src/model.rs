//! The serialisable terrain model: what it reads (source and features),
//! how it scales them, the trained classifier and the filter settings; and
//! the call the estimator pipeline makes, [`TerrainModel::classify_log`].

use serde::{Deserialize, Serialize};
use terraslip_core::terrain_belief::{BeliefConfig, TerrainBelief, MAX_TERRAINS};
use terraslip_io::DriveLog;

use crate::augment::{SpeedAugmentation, SpeedLaw};
use crate::classify::{Classifier, ClassifierParams, Standardizer};
use crate::confidence::{Calibration, ClassDistance, ScoredWindow};
use crate::envelope::{lower_confidence, Envelope};
use crate::error::{Result, TerrainError};
pub use crate::samples::extract;
use crate::samples::labelled;
use crate::speed_norm::SpeedNormalisation;
use crate::vibration::{self, ChannelSet, VibrationConfig, VibrationFeatureSet};
use crate::vision::VisionConfig;

/// Version of the model file format; a file of another version is refused.
/// 2: the `full` vibration set gained the steering-efficiency (slip) and
/// manoeuvre features. 3: the vibration settings gained the spatial bands
/// (`spatial_bands`, grid, scaling). 4: the learnt speed normalisation
/// (`speed_norm` settings, `speed_normalisation` slopes). 5: the vibration
/// settings record the motor-current channels (`currents`); the spatial
/// bands are gone. 6: the manoeuvre envelope (`envelope`). 7: the current
/// in excess of the robot's baseline at the window's speed and turn
/// (`current_excess`, `speed_normalisation.current_baseline`).
pub const MODEL_FORMAT_VERSION: u32 = 7;

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

/// How classifier outputs are smoothed (wang2018's Bayesian filter + λ-vote).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeliefSettings {
    pub stay_prob: f64,
    pub stay_prob_on_jump: f64,
    pub vote_lambda: u32,
    /// Class probabilities are mixed with this share of a uniform
    /// distribution before the Bayes update, so that one confident
    /// mistake cannot zero out the true terrain.
    pub prob_floor: f64,
}

impl Default for BeliefSettings {
    fn default() -> Self {
        let b = BeliefConfig::default();
        Self {
            stay_prob: b.stay_prob,
            stay_prob_on_jump: b.stay_prob_on_jump,
            vote_lambda: b.vote_lambda,
            prob_floor: 0.1,
        }
    }
}

impl BeliefSettings {
    pub fn belief_config(&self) -> BeliefConfig {
        BeliefConfig {
            stay_prob: self.stay_prob,
            stay_prob_on_jump: self.stay_prob_on_jump,
            vote_lambda: self.vote_lambda,
        }
    }
}

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
    /// Grouped inner folds (whole training runs out) on which the class
    /// probabilities are calibrated and the unknown threshold chosen
    /// ([`crate::confidence`]); below 2: no calibration.
    pub calibration_folds: usize,
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
            calibration_folds: 0,
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
    /// Temperature and unknown threshold fitted on inner folds of the
    /// training runs (`null`: raw probabilities, never "unknown").
    #[serde(default)]
    pub calibration: Option<Calibration>,
    /// Per-class spread of the training windows in standardised feature
    /// space, for the novelty of a window (`null` in older files).
    #[serde(default)]
    pub class_distance: Option<ClassDistance>,
    pub belief: BeliefSettings,
    pub training: TrainingInfo,
}

/// Class probabilities over time, causal: frame `t` uses data up to `t` only.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TerrainTimeline {
    pub classes: Vec<String>,
    /// `(t, probabilities)`: `t` in s (end of the window, or frame time).
    pub frames: Vec<(f64, Vec<f64>)>,
    /// Times (s) at which the camera change detector fired (lv2019); empty for IMU models.
    pub changes: Vec<f64>,
    /// Per frame: driven outside the model's envelope for the terrain it
    /// is read as (its probabilities were mixed with a uniform
    /// distribution). Empty when the model has no envelope.
    pub outside_envelope: Vec<bool>,
    /// Per frame: distance from the training windows of the terrain it is
    /// read as ([`ClassDistance::novelty`]). Empty when the model has none.
    pub novelty: Vec<f64>,
    /// Confidence below which a frame's verdict is "unknown" (the model's
    /// calibration; 0 without one).
    pub unknown_below: f64,
}

/// One frame after the Bayesian filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilteredFrame {
    pub t: f64,
    /// argmax of the classifier output.
    pub raw: usize,
    /// argmax of the filtered belief.
    pub filtered: usize,
    /// Terrain declared by the λ-vote (what the noise schedule would use).
    pub voted: Option<usize>,
}

impl TerrainTimeline {
    /// Share of frames outside the model's envelope, 0..1; `None` when
    /// the model has no envelope or there are no frames.
    pub fn outside_envelope_share(&self) -> Option<f64> {
        let n = self.outside_envelope.len();
        (n > 0).then(|| self.outside_envelope.iter().filter(|&&o| o).count() as f64 / n as f64)
    }

    /// The frames with a true class (`truth[i]`, `None`: unlabelled,
    /// skipped) as [`ScoredWindow`]s: confidence, right or wrong,
    /// "unknown", envelope and novelty.
    pub fn scored_windows(&self, truth: &[Option<usize>]) -> Vec<ScoredWindow> {
        self.frames
            .iter()
            .zip(truth)
            .enumerate()
            .filter_map(|(i, ((time, p), t))| {
                let truth = (*t)?;
                let confidence = crate::confidence::confidence(p);
                Some(ScoredWindow {
                    t: *time,
                    truth,
                    predicted: argmax(p),
                    confidence,
                    correct: argmax(p) == truth,
                    unknown: confidence < self.unknown_below,
                    outside_envelope: self.outside_envelope.get(i).copied(),
                    novelty: self.novelty.get(i).copied(),
                })
            })
            .collect()
    }

    /// The frames with each probability vector mixed with `floor` of a
    /// uniform distribution (see [`BeliefSettings::prob_floor`]): what to
    /// feed `TerrainBelief::update` so one confident mistake cannot zero
    /// out the true terrain.
    pub fn floored(&self, floor: f64) -> Vec<(f64, Vec<f64>)> {
        let floor = if floor.is_finite() {
            floor.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let k = self.classes.len().max(1) as f64;
        self.frames
            .iter()
            .map(|(t, p)| {
                (
                    *t,
                    p.iter().map(|v| (1.0 - floor) * v + floor / k).collect(),
                )
            })
            .collect()
    }

    /// Runs the HMM filter and λ-vote over the frames. A camera change
    /// detection counts as an innovation jump (lower stay probability).
    pub fn filter(&self, settings: &BeliefSettings) -> Vec<FilteredFrame> {
        let k = self.classes.len();
        let mut belief = TerrainBelief::new(k, settings.belief_config());
        let mut next_change = 0;
        self.floored(settings.prob_floor)
            .iter()
            .zip(&self.frames)
            .map(|((t, lik), (_, p))| {
                let mut jump = false;
                while next_change < self.changes.len() && self.changes[next_change] <= *t {
                    jump = true;
                    next_change += 1;
                }
                belief.update(lik, jump);
                FilteredFrame {
                    t: *t,
                    raw: argmax(p),
                    filtered: belief.most_likely(),
                    voted: belief.current(),
                }
            })
            .collect()
    }
}

/// Keeps the items of `v` whose `keep` is true (all when `v` is empty:
/// an optional per-frame column).
fn retain_by<T>(v: &mut Vec<T>, keep: &[bool]) {
    let mut k = keep.iter();
    v.retain(|_| k.next().copied().unwrap_or(false));
}

pub(crate) fn argmax(p: &[f64]) -> usize {
    let mut best = 0;
    for (i, v) in p.iter().enumerate() {
        if *v > p[best] {
            best = i;
        }
    }
    best
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
    /// calibrated verdict is "unknown" (confidence below the model's
    /// `calibration.unknown_below`): an unsure terrain is no evidence, the
    /// belief keeps what it had and the estimator's own innovation-driven
    /// change detection decides. Camera frames are kept at any speed.
    pub fn estimator_evidence(&self, log: &DriveLog) -> Result<TerrainTimeline> {
        let mut timeline = self.classify_log(log)?;
        let mut keep: Vec<bool> = timeline
            .frames
            .iter()
            .map(|(_, p)| !self.calibration.as_ref().is_some_and(|c| c.is_unknown(p)))
            .collect();
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
        timeline.frames = timeline.floored(self.belief.prob_floor);
        retain_by(&mut timeline.frames, &keep);
        retain_by(&mut timeline.outside_envelope, &keep);
        retain_by(&mut timeline.novelty, &keep);
        Ok(timeline)
    }

    /// Trains on labelled logs. Classes are the sorted union of their labels.
    pub fn train(logs: &[DriveLog], opts: &TrainOptions) -> Result<Self> {
        let mut classes: Vec<String> = logs.iter().flat_map(|l| l.terrain_names()).collect();
        classes.sort();
        classes.dedup();
        Self::train_classes(logs, &classes, opts)
    }

    /// Trains for the given classes (labels outside them are ignored).
    pub fn train_classes(
        logs: &[DriveLog],
        classes: &[String],
        opts: &TrainOptions,
    ) -> Result<Self> {
        if logs.is_empty() {
            return Err(TerrainError::Training("no logs given".into()));
        }
        if let Some(r) = opts
            .speed_augmentation
            .iter()
            .flat_map(|a| &a.factors)
            .find(|r| !(r.is_finite() && **r > 0.0))
        {
            return Err(TerrainError::Config(format!(
                "speed augmentation factor {r}: must be a positive number"
            )));
        }
        if classes.len() > MAX_TERRAINS {
            return Err(TerrainError::Training(format!(
                "{} terrain classes, the belief filter holds at most {MAX_TERRAINS}",
                classes.len()
            )));
        }
        let mut features = match opts.source {
            Source::Imu => {
                let first = logs
                    .iter()
                    .find_map(|l| vibration::imu_rate(&l.imu))
                    .ok_or_else(|| TerrainError::MissingSource {
                        log: logs[0].name(),
                        sensor: "imu",
                        reason: "no training log has IMU data".into(),
                    })?;
                let mut config = opts.vibration.clone();
                if config.feature_set == VibrationFeatureSet::Full {
                    crate::select::channels_from_logs(
                        logs,
                        &mut config,
                        opts.imu_channels,
                        opts.currents,
                    )?;
                }
                if let Some(v) = opts.speed_floor {
                    config.speed_norm_min = v;
                }
                Features::Vibration {
                    config,
                    rate_hz: first,
                }
            }
            Source::Camera => Features::Vision {
                config: opts.vision.clone(),
                change_threshold: f64::INFINITY,
            },
        };
        let mut x = Vec::new();
        let mut y = Vec::new();
        let mut run = Vec::new();
        let mut run_class = Vec::new();
        let mut phi_same = Vec::new();
        let mut phi_change = Vec::new();
        for (r, log) in logs.iter().enumerate() {
            let samples = labelled(log, &features, classes)?;
            run_class.push(
                log.terrain
                    .first()
                    .and_then(|l| classes.iter().position(|c| *c == l.terrain))
                    .unwrap_or(0),
            );
            // A label change at frame i may show in the image only at frame
            // i + 1 (the camera looks ahead, the label is where the body
            // is): score a change by the larger φ of the two, and keep
            // frame i + 1 out of the same-terrain statistics.
            let mut skip_next = false;
            for (i, s) in samples.iter().enumerate() {
                match s.same_as_prev {
                    Some(false) => {
                        let next = samples.get(i + 1).filter(|n| n.same_as_prev == Some(true));
                        phi_change.push(next.map_or(s.phi, |n| n.phi.max(s.phi)));
                        skip_next = true;
                        continue;
                    }
                    Some(true) if !skip_next => phi_same.push(s.phi),
                    _ => {}
                }
                skip_next = false;
            }
            for s in samples {
                x.push(s.x);
                y.push(s.y);
                run.push(r);
            }
        }
        if x.is_empty() {
            return Err(TerrainError::Training(
                "no labelled windows in the training logs".into(),
            ));
        }
        let mut samples_per_class = vec![0usize; classes.len()];
        for &c in &y {
            samples_per_class[c] += 1;
        }
        if let Some((c, n)) = samples_per_class
            .iter()
            .enumerate()
            .find(|(_, &n)| n < crate::classify::MIN_SAMPLES_PER_CLASS)
        {
            return Err(TerrainError::Training(format!(
                "terrain `{}` has {n} training samples, fewer than {}",
                classes[c],
                crate::classify::MIN_SAMPLES_PER_CLASS
            )));
        }
        if let Features::Vision {
            change_threshold, ..
        } = &mut features
        {
            *change_threshold = change_threshold_from(&phi_same, &phi_change);
        }
        if let Features::Vibration { config, .. } = &mut features {
            if config.speed_norm && opts.speed_floor.is_none() {
                if let Some(v) = crate::select::choose_speed_floor(
                    &x,
                    &y,
                    &run,
                    &run_class,
                    classes.len(),
                    config,
                    &opts.classifier,
                ) {
                    config.speed_norm_min = v;
                }
            }
        }
        let speed_normalisation = match &features {
            Features::Vibration { config, .. } if config.speed_norm => {
                let sn = SpeedNormalisation::fit(
                    &x,
                    &y,
                    classes.len(),
                    &config.feature_names(),
                    config.speed_norm_ref,
                    config.speed_norm_min,
                )?;
                Some(sn)
            }
            _ => None,
        };
        // The envelope holds the recorded windows only: what was driven.
        let manoeuvre = manoeuvre_indices(&features);
        let envelope = manoeuvre.map(|(iv, id)| {
            Envelope::fit(
                x.iter().zip(&y).map(|(r, &c)| (c, r[iv], r[id])),
                classes.len(),
            )
        });
        let mut speed_copies = Vec::new();
        let mut speed_copy_samples_per_class = Vec::new();
        if let (Some(aug), Some(sn), Features::Vibration { config, .. }) =
            (&opts.speed_augmentation, &speed_normalisation, &features)
        {
            speed_copies.clone_from(&aug.factors);
            speed_copy_samples_per_class = vec![0usize; classes.len()];
            let law = SpeedLaw::from_speed_normalisation(sn, &config.feature_names());
            let driven = |s: &crate::samples::Labelled| match (&envelope, manoeuvre) {
                (Some(e), Some((iv, id))) => e.covers(s.y, s.x[iv], s.x[id]),
                _ => false,
            };
            for log in logs {
                for &r in &aug.factors {
                    let copy = crate::augment::speed_copy(log, r, &law);
                    for s in labelled(&copy, &features, classes)? {
                        if driven(&s) {
                            continue;
                        }
                        speed_copy_samples_per_class[s.y] += 1;
                        x.push(s.x);
                        y.push(s.y);
                    }
                }
            }
        }
        if let Some(sn) = &speed_normalisation {
            x.iter_mut().for_each(|r| sn.apply(r));
        }
        let normalisation = Standardizer::fit(&x);
        let xs: Vec<Vec<f64>> = x.iter().map(|r| normalisation.apply(r)).collect();
        let classifier = Classifier::fit(&xs, &y, classes.len(), &opts.classifier)?;
        let class_distance = Some(ClassDistance::fit(&xs, &y, classes.len()));
        drop(xs);
        let calibration = if opts.calibration_folds >= 2 {
            let mut inner = opts.clone();
            inner.calibration_folds = 0;
            if let Features::Vibration { config, .. } = &features {
                inner.speed_floor = Some(config.speed_norm_min);
            }
            crate::calibrate::inner_calibration(logs, classes, &inner, opts.calibration_folds)?
        } else {
            None
        };
        let feature_names = match &features {
            Features::Vibration { config, .. } => config.feature_names(),
            Features::Vision { config, .. } => config.feature_names(),
        };
        Ok(Self {
            format_version: MODEL_FORMAT_VERSION,
            source: opts.source,
            classes: classes.to_vec(),
            features,
            feature_names,
            speed_normalisation,
            normalisation,
            envelope,
            classifier_settings: opts.classifier.clone(),
            classifier,
            calibration,
            class_distance,
            belief: opts.belief,
            training: TrainingInfo {
                logs: logs.iter().map(|l| l.name()).collect(),
                samples_per_class,
                speed_copies,
                speed_copy_samples_per_class,
            },
        })
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
            unknown_below: self.calibration.as_ref().map_or(0.0, |c| c.unknown_below),
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
            if let Some(c) = &self.calibration {
                c.apply(&mut p);
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

/// Threshold on `φ_t` between same-terrain and changing consecutive frames:
/// halfway (geometrically) between the 99th percentile of the former and
/// the smallest of the latter; 2x that percentile when no change was seen.
fn change_threshold_from(same: &[f64], change: &[f64]) -> f64 {
    if same.is_empty() {
        return change.iter().copied().fold(f64::INFINITY, f64::min) * 0.5;
    }
    let mut s = same.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let p99 = s[((s.len() - 1) as f64 * 0.99).round() as usize].max(1e-6);
    let lo_change = change.iter().copied().fold(f64::INFINITY, f64::min);
    if lo_change.is_finite() && lo_change > p99 {
        (p99 * lo_change).sqrt()
    } else {
        2.0 * p99
    }
}

/// Indices of the tread speed and tread speed difference features (the
/// `full` vibration set), which the envelope reads.
fn manoeuvre_indices(f: &Features) -> Option<(usize, usize)> {
    let Features::Vibration { config, .. } = f else {
        return None;
    };
    let names = config.feature_names();
    let at = |n: &str| names.iter().position(|m| m == n);
    Some((at("tread_speed")?, at("tread_speed_diff")?))
}
