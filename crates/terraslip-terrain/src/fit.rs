//! A model fitted to labelled logs: the features read (channels and speed
//! floor chosen from the logs), the labelled windows with their speed
//! copies, the speed normalisation and scaling, the manoeuvre envelope,
//! the classifier and the spread of each class.

use terraslip_core::terrain_belief::MAX_TERRAINS;
use terraslip_io::DriveLog;

use crate::augment::SpeedLaw;
use crate::classify::{Classifier, Standardizer};
use crate::confidence::ClassDistance;
use crate::envelope::Envelope;
use crate::error::{Result, TerrainError};
use crate::features::Features;
use crate::model::{manoeuvre_indices, Source, TerrainModel, TrainingInfo, MODEL_FORMAT_VERSION};
use crate::samples::labelled;
use crate::speed_norm::SpeedNormalisation;
use crate::train_options::TrainOptions;
use crate::vibration::{self, VibrationFeatureSet};

impl TerrainModel {
    /// Fits a model for the given classes (labels outside them are
    /// ignored).
    pub(crate) fn fit(logs: &[DriveLog], classes: &[String], opts: &TrainOptions) -> Result<Self> {
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
