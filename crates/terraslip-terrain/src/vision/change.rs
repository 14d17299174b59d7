//! lv2019's terrain-change detector: the distance `φ_t` between the
//! colour+texture vectors of consecutive frames.

use image::RgbImage;

use super::{grey, lbp_histogram};

/// lv2019's colour+texture vector of a frame (RGB histograms + LBP), used
/// by the change detector whatever features the classifier reads. The
/// colours are first divided by the frame's mean grey level: lighting
/// changes between frames (sun, cloud, shadow) otherwise move the
/// histograms more than a change of terrain does. LBP is already
/// invariant to monotone grey-level changes.
pub fn similarity_vector(img: &RgbImage, bins: usize) -> Vec<f64> {
    let bins = bins.clamp(1, 256);
    let g = grey(img);
    let mean = g.iter().map(|&v| v as f64).sum::<f64>() / g.len().max(1) as f64;
    let gain = 128.0 / mean.max(1.0);
    let mut h = vec![0u32; 3 * bins];
    for p in img.pixels() {
        for (c, &v) in p.0.iter().enumerate() {
            let v = ((v as f64 * gain) as usize).min(255);
            h[c * bins + v * bins / 256] += 1;
        }
    }
    let n = g.len().max(1) as f64;
    let mut v: Vec<f64> = h.iter().map(|&c| c as f64 / n).collect();
    lbp_histogram(&g, img.width() as usize, img.height() as usize, &mut v);
    v
}

/// `φ_t = ‖c_t − c_{t−1}‖₂` (lv2019); 0 for the first frame.
pub fn similarity_change(prev: Option<&[f64]>, cur: &[f64]) -> f64 {
    prev.map_or(0.0, |p| {
        p.iter()
            .zip(cur)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt()
    })
}
