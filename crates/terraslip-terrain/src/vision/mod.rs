//! Ground-camera features.
//!
//! - `histogram`: lv2019 §III-2, `D`-bin histograms of R, G and B plus a
//!   histogram of uniform LBP codes.
//! - `change`: lv2019's frame-to-frame similarity `φ_t = ‖c_t − c_{t−1}‖₂`,
//!   whose jumps signal a terrain change.
//! - `sfta`: chen2023 §3.2.1, SFTA. The grey image (eq. 18) is split by
//!   `n_t` multi-level Otsu thresholds into `2·n_t` binary images (eq.
//!   19-20); each gives the box-counting dimension of its border map (eq.
//!   21), its pixel share and its mean grey level.
//! - `roi`: chen2023 §3.2.2, the region of interest, the footprint the
//!   kinematic model predicts the robot will cover `t_s` seconds ahead,
//!   projected into the image by a pinhole camera model.
//!
//! This module holds the settings a model records, the grey image every
//! feature starts from, and the features of one frame.
//!
//! Image rows go down, columns right; pixel (0, 0) is the top-left corner.

mod change;
mod histogram;
mod roi;
mod sfta;

use image::RgbImage;
use serde::{Deserialize, Serialize};

use crate::error::{Result, TerrainError};

pub use change::{similarity_change, similarity_vector};
pub use histogram::{lbp_histogram, rgb_histograms, LBP_BINS};
pub use roi::{CameraModel, Rect, RoiConfig, MIN_ROI_PIXELS};
pub use sfta::{multi_otsu, sfta};

/// Which image features a model uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VisionFeatureSet {
    /// lv2019: RGB histograms + uniform LBP histogram.
    HistLbp,
    /// chen2023: SFTA (3·2·n_t features).
    Sfta,
    /// Both, concatenated.
    Both,
}

/// Image feature settings, recorded in the model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VisionConfig {
    pub features: VisionFeatureSet,
    /// Bins per colour histogram (lv2019's `D`).
    pub hist_bins: usize,
    /// Otsu thresholds `n_t` of SFTA (chen2023 uses 4), 1..=8.
    pub sfta_thresholds: usize,
    /// Classify only the predicted footprint (chen2023); whole frame when `None`.
    #[serde(default)]
    pub roi: Option<RoiConfig>,
}

impl Default for VisionConfig {
    fn default() -> Self {
        Self {
            features: VisionFeatureSet::Both,
            hist_bins: 16,
            sfta_thresholds: 4,
            roi: None,
        }
    }
}

impl VisionConfig {
    pub fn feature_names(&self) -> Vec<String> {
        let mut names = Vec::new();
        if matches!(
            self.features,
            VisionFeatureSet::HistLbp | VisionFeatureSet::Both
        ) {
            for ch in ["r", "g", "b"] {
                for b in 0..self.hist_bins {
                    names.push(format!("hist_{ch}{b}"));
                }
            }
            for b in 0..LBP_BINS {
                names.push(format!("lbp{b}"));
            }
        }
        if matches!(
            self.features,
            VisionFeatureSet::Sfta | VisionFeatureSet::Both
        ) {
            for i in 0..2 * self.sfta_thresholds {
                for f in ["dim", "share", "grey"] {
                    names.push(format!("sfta{i}_{f}"));
                }
            }
        }
        names
    }

    fn check(&self) -> Result<()> {
        if self.hist_bins == 0 || self.hist_bins > 256 {
            return Err(TerrainError::Config(format!(
                "hist_bins {} not in 1..=256",
                self.hist_bins
            )));
        }
        if !(1..=8).contains(&self.sfta_thresholds) {
            return Err(TerrainError::Config(format!(
                "sfta_thresholds {} not in 1..=8",
                self.sfta_thresholds
            )));
        }
        Ok(())
    }
}

/// Grey level of chen2023 eq. 18 (0.30 R + 0.59 G + 0.11 B), row-major.
pub fn grey(img: &RgbImage) -> Vec<u8> {
    img.as_raw()
        .chunks_exact(3)
        .map(|p| {
            let (r, g, b) = (p[0], p[1], p[2]);
            // 0.30, 0.59, 0.11 in 8.8 fixed point (77 + 151 + 28 = 256).
            ((77 * r as u32 + 151 * g as u32 + 28 * b as u32 + 128) >> 8) as u8
        })
        .collect()
}

/// Features of one frame (or of its region of interest), appended to `out`.
pub fn frame_features(
    img: &RgbImage,
    cfg: &VisionConfig,
    roi: Option<Rect>,
    out: &mut Vec<f64>,
) -> Result<()> {
    cfg.check()?;
    let cropped;
    let img = match roi {
        Some(r) if r.x1 <= img.width() && r.y1 <= img.height() && r.x1 > r.x0 && r.y1 > r.y0 => {
            cropped =
                image::imageops::crop_imm(img, r.x0, r.y0, r.x1 - r.x0, r.y1 - r.y0).to_image();
            &cropped
        }
        _ => img,
    };
    let (w, h) = (img.width() as usize, img.height() as usize);
    if w < 3 || h < 3 {
        return Err(TerrainError::Data(format!(
            "image of {w}x{h} pixels is too small; frames need at least 3x3 pixels"
        )));
    }
    let g = grey(img);
    if matches!(
        cfg.features,
        VisionFeatureSet::HistLbp | VisionFeatureSet::Both
    ) {
        rgb_histograms(img, cfg.hist_bins, out);
        lbp_histogram(&g, w, h, out);
    }
    if matches!(
        cfg.features,
        VisionFeatureSet::Sfta | VisionFeatureSet::Both
    ) {
        sfta(&g, w, h, cfg.sfta_thresholds, out);
    }
    Ok(())
}

/// Opens a frame as RGB8; unreadable or corrupt files are a typed error.
pub fn load_frame(path: &std::path::Path) -> Result<RgbImage> {
    let unreadable = |e: &dyn std::fmt::Display| TerrainError::Image {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    let img = image::ImageReader::open(path)
        .map_err(|e| unreadable(&e))?
        .with_guessed_format()
        .map_err(|e| unreadable(&e))?
        .decode()
        .map_err(|e| unreadable(&e))?;
    Ok(img.to_rgb8())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corrupt_image_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.png");
        std::fs::write(&p, b"\x89PNG\r\n\x1a\nnot really").unwrap();
        let e = load_frame(&p).unwrap_err();
        assert!(
            matches!(e, TerrainError::Image { .. }) && e.to_string().contains("bad.png"),
            "{e}"
        );
        let e = load_frame(&dir.path().join("missing.jpg")).unwrap_err();
        assert!(e.to_string().contains("missing.jpg"));
    }
}
