//! Samples of a log for a model's features: IMU windows or camera frames,
//! and the labelled ones for training.

use terraslip_core::IcrParams;
use terraslip_io::DriveLog;

use crate::error::{Result, TerrainError};
use crate::features::Features;
use crate::vibration;
use crate::vision::{self, VisionConfig};

/// Per-frame features of a log for `features`: `(t, feature vector)`, and
/// the lv2019 similarity change `φ_t` of each frame (0 for IMU windows).
pub fn extract(log: &DriveLog, features: &Features) -> Result<Vec<(f64, Vec<f64>, f64)>> {
    match features {
        Features::Vibration { config, rate_hz } => {
            let (rate, windows) = vibration::log_windows(log, config)?;
            if *rate_hz > 0.0 && (rate / rate_hz - 1.0).abs() > 0.1 {
                return Err(TerrainError::MissingSource {
                    log: log.name(),
                    sensor: "imu",
                    reason: format!("imu.csv is sampled at {rate:.1} Hz but the model was trained at {rate_hz:.1} Hz"),
                });
            }
            Ok(windows.into_iter().map(|(t, f)| (t, f, 0.0)).collect())
        }
        Features::Vision { config, .. } => camera_frames(log, config),
    }
}

fn camera_frames(log: &DriveLog, cfg: &VisionConfig) -> Result<Vec<(f64, Vec<f64>, f64)>> {
    if log.images.is_empty() {
        return Err(TerrainError::MissingSource {
            log: log.name(),
            sensor: "camera",
            reason: "images.csv is missing or empty".into(),
        });
    }
    let icr = IcrParams::no_slip(
        log.meta
            .track_width
            .or(cfg.roi.as_ref().map(|r| r.width))
            .unwrap_or(0.5),
    );
    let mut out = Vec::with_capacity(log.images.len());
    let mut prev: Option<Vec<f64>> = None;
    for im in &log.images {
        let path = log.image_path(im);
        let img = vision::load_frame(&path)?;
        let roi = cfg.roi.as_ref().and_then(|r| {
            let i = log.wheels.partition_point(|w| w.t <= im.t);
            let w = log.wheels.get(i.saturating_sub(1))?;
            r.region(&icr.twist(w.v_left, w.v_right))
        });
        let mut f = Vec::new();
        vision::frame_features(&img, cfg, roi, &mut f).map_err(|e| match e {
            TerrainError::Data(reason) => TerrainError::Image { path, reason },
            e => e,
        })?;
        let sim = vision::similarity_vector(&img, cfg.hist_bins);
        let phi = vision::similarity_change(prev.as_deref(), &sim);
        prev = Some(sim);
        out.push((im.t, f, phi));
    }
    Ok(out)
}

/// A training sample: features and the label index.
pub(crate) struct Labelled {
    pub x: Vec<f64>,
    pub y: usize,
    pub phi: f64,
    pub same_as_prev: Option<bool>,
}

/// Labelled samples of a log; IMU windows straddling a label change are
/// dropped (they belong to neither terrain).
pub(crate) fn labelled(
    log: &DriveLog,
    features: &Features,
    classes: &[String],
) -> Result<Vec<Labelled>> {
    if log.terrain.is_empty() {
        return Err(TerrainError::MissingLabels { log: log.name() });
    }
    let window = match features {
        Features::Vibration { config, .. } => config.window_s,
        Features::Vision { .. } => 0.0,
    };
    let mut out = Vec::new();
    let mut prev_label: Option<usize> = None;
    for (t, x, phi) in extract(log, features)? {
        let (Some(a), Some(b)) = (log.terrain_at(t - window), log.terrain_at(t)) else {
            continue;
        };
        if a != b {
            prev_label = None;
            continue;
        }
        let Some(y) = classes.iter().position(|c| c == b) else {
            continue;
        };
        out.push(Labelled {
            x,
            y,
            phi,
            same_as_prev: prev_label.map(|p| p == y),
        });
        prev_label = Some(y);
    }
    Ok(out)
}
