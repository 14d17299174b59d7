//! Ground-camera features.
//!
//! - lv2019 §III-2: `D`-bin histograms of R, G and B plus a histogram of
//!   uniform LBP codes, and the frame-to-frame similarity `φ_t = ‖c_t − c_{t−1}‖₂`
//!   whose jumps signal a terrain change.
//! - chen2023 §3.2.1: SFTA. The grey image (eq. 18) is split by `n_t`
//!   multi-level Otsu thresholds into `2·n_t` binary images (eq. 19-20);
//!   each gives the box-counting dimension of its border map (eq. 21), its
//!   pixel share and its mean grey level.
//! - chen2023 §3.2.2: the region of interest, the footprint the kinematic
//!   model predicts the robot will cover `t_s` seconds ahead, projected into
//!   the image by a pinhole camera model.
//!
//! Image rows go down, columns right; pixel (0, 0) is the top-left corner.

use image::RgbImage;
use serde::{Deserialize, Serialize};
use terraslip_core::kinematics::Twist;

use crate::error::{Result, TerrainError};

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

/// Bins of the rotation-invariant uniform LBP histogram (P = 8: codes 0..=8
/// count the ones of uniform patterns, 9 collects the non-uniform ones).
pub const LBP_BINS: usize = 10;

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

/// Appends `bins` normalised histogram bins for each of R, G, B.
pub fn rgb_histograms(img: &RgbImage, bins: usize, out: &mut Vec<f64>) {
    let bins = bins.clamp(1, 256);
    let mut bin_of = [0u16; 256];
    for (v, b) in bin_of.iter_mut().enumerate() {
        *b = (v * bins / 256) as u16;
    }
    // Two interleaved copies per channel: neighbouring pixels often fall in
    // the same bin, and back-to-back increments of one counter stall.
    let mut h2 = vec![0u32; 6 * bins];
    let (h_a, h_b) = h2.split_at_mut(3 * bins);
    let raw = img.as_raw();
    let mut pairs = raw.chunks_exact(6);
    for p in &mut pairs {
        h_a[bin_of[p[0] as usize] as usize] += 1;
        h_a[bins + bin_of[p[1] as usize] as usize] += 1;
        h_a[2 * bins + bin_of[p[2] as usize] as usize] += 1;
        h_b[bin_of[p[3] as usize] as usize] += 1;
        h_b[bins + bin_of[p[4] as usize] as usize] += 1;
        h_b[2 * bins + bin_of[p[5] as usize] as usize] += 1;
    }
    for p in pairs.remainder().chunks_exact(3) {
        for c in 0..3 {
            h_a[c * bins + bin_of[p[c] as usize] as usize] += 1;
        }
    }
    let h: Vec<u32> = h_a.iter().zip(h_b.iter()).map(|(a, b)| a + b).collect();
    let n = (img.width() as f64 * img.height() as f64).max(1.0);
    out.extend(h.iter().map(|&c| c as f64 / n));
}

/// Bin of each 8-bit LBP code: the number of ones for uniform patterns
/// (at most two 0/1 transitions around the circle), 9 otherwise.
const fn lbp_table() -> [u8; 256] {
    let mut t = [0u8; 256];
    let mut code: usize = 0;
    while code < 256 {
        let rotated = ((code << 1) | (code >> 7)) & 0xff;
        let transitions = (code ^ rotated).count_ones();
        t[code] = if transitions <= 2 {
            (code as u32).count_ones() as u8
        } else {
            9
        };
        code += 1;
    }
    t
}
static LBP_TABLE: [u8; 256] = lbp_table();

/// Appends the normalised riu2 LBP histogram (P = 8, R = 1) of a grey image.
///
/// Ojala's convention: bit `p` is set when neighbour `g_p >= g_c`, with
/// `p = 0` the right neighbour and `p` increasing counter-clockwise
/// (right, up-right, up, up-left, left, down-left, down, down-right).
/// Border pixels, lacking a full neighbourhood, are skipped.
pub fn lbp_histogram(grey: &[u8], width: usize, height: usize, out: &mut Vec<f64>) {
    let mut h = [0u32; LBP_BINS];
    if width >= 3 && height >= 3 && grey.len() >= width * height {
        // One pass per neighbour over a whole row: simple zips that the
        // compiler vectorises, then one table lookup per pixel.
        let inner = width - 2;
        let mut code = vec![0u8; inner];
        for y in 1..height - 1 {
            let up = &grey[(y - 1) * width..y * width];
            let mid = &grey[y * width..(y + 1) * width];
            let down = &grey[(y + 1) * width..(y + 2) * width];
            let centre = &mid[1..width - 1];
            code.iter_mut().for_each(|c| *c = 0);
            // (row, column offset) of neighbour p, p = 0 right, counter-clockwise.
            let neighbours: [(&[u8], usize); 8] = [
                (mid, 2),
                (up, 2),
                (up, 1),
                (up, 0),
                (mid, 0),
                (down, 0),
                (down, 1),
                (down, 2),
            ];
            for (p, (row, dx)) in neighbours.iter().enumerate() {
                let nb = &row[*dx..*dx + inner];
                for ((c, &n), &g) in code.iter_mut().zip(nb).zip(centre) {
                    *c |= ((n >= g) as u8) << p;
                }
            }
            for &c in &code {
                h[LBP_TABLE[c as usize] as usize] += 1;
            }
        }
    }
    let n = h.iter().sum::<u32>().max(1) as f64;
    out.extend(h.iter().map(|&c| c as f64 / n));
}

/// `n_t` thresholds maximising the between-class variance of a 256-bin
/// grey histogram (multi-level Otsu, exact, by dynamic programming over
/// the grey levels: O(n_t·256²) instead of Liao's O(256^n_t) search).
/// Class `j` holds levels `(T_j, T_{j+1}]`, with `T_0 = -1`, `T_{n_t+1} = 255`.
pub fn multi_otsu(hist: &[u64; 256], n_t: usize) -> Vec<u8> {
    const L: usize = 256;
    let n_t = n_t.clamp(1, 8);
    let mut p = [0.0f64; L + 1];
    let mut s = [0.0f64; L + 1];
    for i in 0..L {
        p[i + 1] = p[i] + hist[i] as f64;
        s[i + 1] = s[i] + i as f64 * hist[i] as f64;
    }
    // Between-class variance is Σ_j S_j²/P_j up to constants.
    let cost = |a: usize, b: usize| -> f64 {
        let w = p[b] - p[a];
        if w > 0.0 {
            let m = s[b] - s[a];
            m * m / w
        } else {
            0.0
        }
    };
    let classes = n_t + 1;
    // best[c][e]: best value splitting levels [0, e) into c+1 classes.
    let mut best = vec![[f64::NEG_INFINITY; L + 1]; classes];
    let mut arg = vec![[0usize; L + 1]; classes];
    for (e, b) in best[0].iter_mut().enumerate().skip(1) {
        *b = cost(0, e);
    }
    for c in 1..classes {
        for e in (c + 1)..=L {
            for b in c..e {
                let v = best[c - 1][b] + cost(b, e);
                if v > best[c][e] {
                    best[c][e] = v;
                    arg[c][e] = b;
                }
            }
        }
    }
    let mut cuts = vec![0usize; n_t];
    let mut e = L;
    for c in (1..classes).rev() {
        let b = arg[c][e];
        cuts[c - 1] = b;
        e = b;
    }
    // A cut at b means class boundary between levels b-1 and b: T = b-1.
    cuts.iter().map(|&b| b.saturating_sub(1) as u8).collect()
}

/// Appends SFTA features of a grey image (chen2023): for each of the
/// `2·n_t` binary images, [box-counting dimension of its border, share of
/// pixels in it, their mean grey level].
pub fn sfta(grey: &[u8], width: usize, height: usize, n_t: usize, out: &mut Vec<f64>) {
    let n_t = n_t.clamp(1, 8);
    let n_img = 2 * n_t;
    let n_px = width * height;
    if n_px == 0 || grey.len() < n_px {
        out.resize(out.len() + 3 * n_img, 0.0);
        return;
    }
    let grey = &grey[..n_px];
    let mut hist = [0u64; 256];
    for &g in grey {
        hist[g as usize] += 1;
    }
    let thr = multi_otsu(&hist, n_t);
    // label(g) = number of thresholds below g: 0..=n_t.
    let mut label_of = [0u8; 256];
    for (g, l) in label_of.iter_mut().enumerate() {
        *l = thr.iter().filter(|&&t| g > t as usize).count() as u8;
    }
    let labels: Vec<u8> = grey.iter().map(|&g| label_of[g as usize]).collect();
    // 3x3 min and max of labels (edge pixels see only existing neighbours).
    let (mn, mx) = min_max_3x3(&labels, width, height);
    // Membership and border bitmasks of the 2·n_t binary images:
    // bit i < n_t: levels [0, T_{i+1}] (label <= i);
    // bit n_t + j: levels (T_{j+1}, T_{j+2}] (label == j + 1).
    let mut member_mask = [0u16; 9];
    for (l, m) in member_mask.iter_mut().enumerate().take(n_t + 1) {
        for i in 0..n_t {
            if l <= i {
                *m |= 1 << i;
            }
        }
        if l >= 1 {
            *m |= 1 << (n_t + l - 1);
        }
    }
    // Border mask of every binary image as a function of (label, 3x3 min,
    // 3x3 max): a table of at most 9³ entries, one lookup per pixel.
    let nl = n_t + 1;
    let mut border_of = vec![0u16; nl * nl * nl];
    for l in 0..nl {
        for lo in 0..nl {
            for hi in 0..nl {
                let mut b = 0u16;
                for i in 0..n_t {
                    // Cumulative set {label <= i}: border if a neighbour is above i.
                    if l <= i && hi > i {
                        b |= 1 << i;
                    }
                }
                if l >= 1 && (lo < l || hi > l) {
                    b |= 1 << (n_t + l - 1);
                }
                border_of[(l * nl + lo) * nl + hi] = b;
            }
        }
    }
    let border: Vec<u16> = labels
        .iter()
        .zip(mn.iter().zip(&mx))
        .map(|(&l, (&lo, &hi))| border_of[(l as usize * nl + lo as usize) * nl + hi as usize])
        .collect();
    // Pixel counts and grey sums per label, then per binary image.
    let mut label_count = [0u64; 9];
    let mut label_grey = [0u64; 9];
    for (&l, &g) in labels.iter().zip(grey) {
        label_count[l as usize] += 1;
        label_grey[l as usize] += g as u64;
    }
    let mut count = [0u64; 16];
    let mut grey_sum = [0u64; 16];
    for (l, m) in member_mask.iter().enumerate().take(nl) {
        for i in 0..n_img {
            if m & (1 << i) != 0 {
                count[i] += label_count[l];
                grey_sum[i] += label_grey[l];
            }
        }
    }
    let dims = box_counting(border, width, height, n_img);
    for i in 0..n_img {
        out.push(dims[i]);
        out.push(count[i] as f64 / n_px as f64);
        out.push(if count[i] > 0 {
            grey_sum[i] as f64 / count[i] as f64
        } else {
            0.0
        });
    }
}

fn min_max_3x3(v: &[u8], w: usize, h: usize) -> (Vec<u8>, Vec<u8>) {
    // Separable: 1x3 along rows, then 3x1 along columns; edges see only
    // the neighbours that exist.
    let mut rmin = vec![0u8; v.len()];
    let mut rmax = vec![0u8; v.len()];
    for y in 0..h {
        let row = &v[y * w..(y + 1) * w];
        let (omin, omax) = (&mut rmin[y * w..(y + 1) * w], &mut rmax[y * w..(y + 1) * w]);
        for x in 0..w {
            let a = row[x.saturating_sub(1)];
            let b = row[x];
            let c = row[(x + 1).min(w - 1)];
            omin[x] = a.min(b).min(c);
            omax[x] = a.max(b).max(c);
        }
    }
    let mut mn = vec![0u8; v.len()];
    let mut mx = vec![0u8; v.len()];
    for y in 0..h {
        let (ya, yb) = (y.saturating_sub(1), (y + 1).min(h - 1));
        let (a0, b0, c0) = (
            &rmin[ya * w..ya * w + w],
            &rmin[y * w..y * w + w],
            &rmin[yb * w..yb * w + w],
        );
        let (a1, b1, c1) = (
            &rmax[ya * w..ya * w + w],
            &rmax[y * w..y * w + w],
            &rmax[yb * w..yb * w + w],
        );
        let (omin, omax) = (&mut mn[y * w..(y + 1) * w], &mut mx[y * w..(y + 1) * w]);
        for x in 0..w {
            omin[x] = a0[x].min(b0[x]).min(c0[x]);
            omax[x] = a1[x].max(b1[x]).max(c1[x]);
        }
    }
    (mn, mx)
}

/// Box-counting dimension of each bit-plane of `mask`: boxes of side
/// 1, 2, 4, ... pixels; `D = −slope` of `ln N(s)` against `ln s`.
fn box_counting(mut mask: Vec<u16>, mut w: usize, mut h: usize, planes: usize) -> Vec<f64> {
    let mut pts: Vec<Vec<(f64, f64)>> = vec![Vec::new(); planes];
    let mut size = 1.0f64;
    let mut by_value = vec![0u32; 1 << planes.min(16)];
    loop {
        // Count cells by mask value, then spread the values over their bits:
        // one increment per cell instead of one per set bit.
        by_value.iter_mut().for_each(|c| *c = 0);
        for &m in &mask {
            by_value[m as usize] += 1;
        }
        let mut n = [0u64; 16];
        for (v, &c) in by_value.iter().enumerate().skip(1) {
            if c > 0 {
                let mut m = v;
                while m != 0 {
                    n[m.trailing_zeros() as usize] += c as u64;
                    m &= m - 1;
                }
            }
        }
        for (i, p) in pts.iter_mut().enumerate() {
            if n[i] > 0 {
                p.push((size.ln(), (n[i] as f64).ln()));
            }
        }
        if w <= 1 && h <= 1 {
            break;
        }
        let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
        let mut next = vec![0u16; nw * nh];
        for y in 0..h {
            let row = &mask[y * w..(y + 1) * w];
            let out = &mut next[(y / 2) * nw..(y / 2 + 1) * nw];
            for (x, &m) in row.iter().enumerate() {
                out[x >> 1] |= m;
            }
        }
        mask = next;
        w = nw;
        h = nh;
        size *= 2.0;
    }
    pts.iter()
        .map(|p| {
            if p.len() < 2 {
                return 0.0;
            }
            let n = p.len() as f64;
            let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
            let my = p.iter().map(|q| q.1).sum::<f64>() / n;
            let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
            let sxx: f64 = p.iter().map(|q| (q.0 - mx) * (q.0 - mx)).sum();
            if sxx > 0.0 {
                -sxy / sxx
            } else {
                0.0
            }
        })
        .collect()
}

/// Pinhole ground camera fixed to the body. Body frame REP-103 (x forward,
/// y left, z up), metres; the camera looks forward, tilted down by `pitch`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraModel {
    /// Image size, pixels.
    pub width: u32,
    pub height: u32,
    /// Focal lengths and principal point, pixels.
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    /// Camera centre in the body frame, m (z = height above ground).
    pub x: f64,
    pub y: f64,
    pub z: f64,
    /// Tilt below the horizon, rad (π/2 looks straight down, image top = forward).
    pub pitch: f64,
}

impl CameraModel {
    /// Pixel `(u, v)` of a ground point `(x, y)` in the body frame, m;
    /// `None` when the point is behind the camera.
    pub fn project(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        let r = [x - self.x, y - self.y, -self.z];
        let (s, c) = self.pitch.sin_cos();
        let axis = [c, 0.0, -s];
        let down = [-s, 0.0, -c];
        let depth = r[0] * axis[0] + r[2] * axis[2];
        if depth <= 1e-6 {
            return None;
        }
        let right = -r[1];
        let d = r[0] * down[0] + r[2] * down[2];
        Some((
            self.cx + self.fx * right / depth,
            self.cy + self.fy * d / depth,
        ))
    }
}

/// chen2023's region of interest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoiConfig {
    pub camera: CameraModel,
    /// Look-ahead `t_s`, s.
    pub horizon_s: f64,
    /// Robot footprint, m (length along x, width along y).
    pub length: f64,
    pub width: f64,
    /// Footprint enlargement for model error (chen2023: 1.2).
    pub margin: f64,
}

/// A pixel rectangle `[x0, x1) × [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

/// Fewest pixels a region of interest may have before the whole frame is used.
pub const MIN_ROI_PIXELS: u32 = 256;

impl RoiConfig {
    /// The bounding rectangle of the footprint the robot, moving with the
    /// body twist `tw` (m/s, rad/s), will cover after `horizon_s`; `None`
    /// when it is out of view or too small to classify.
    pub fn region(&self, tw: &Twist) -> Option<Rect> {
        let t = self.horizon_s;
        let (px, py, th) = if tw.omega.abs() < 1e-9 {
            (tw.v_x * t, tw.v_y * t, 0.0)
        } else {
            // Exact arc of a constant twist.
            let th = tw.omega * t;
            let (s, c) = th.sin_cos();
            (
                (tw.v_x * s - tw.v_y * (1.0 - c)) / tw.omega,
                (tw.v_x * (1.0 - c) + tw.v_y * s) / tw.omega,
                th,
            )
        };
        if !(px.is_finite() && py.is_finite() && th.is_finite()) {
            return None;
        }
        let hl = 0.5 * self.length * self.margin;
        let hw = 0.5 * self.width * self.margin;
        let (s, c) = th.sin_cos();
        let (mut u0, mut v0, mut u1, mut v1) = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        for (dx, dy) in [(hl, hw), (hl, -hw), (-hl, hw), (-hl, -hw)] {
            let (u, v) = self
                .camera
                .project(px + c * dx - s * dy, py + s * dx + c * dy)?;
            u0 = u0.min(u);
            u1 = u1.max(u);
            v0 = v0.min(v);
            v1 = v1.max(v);
        }
        let clip = |a: f64, max: u32| a.clamp(0.0, max as f64) as u32;
        let r = Rect {
            x0: clip(u0.floor(), self.camera.width),
            x1: clip(u1.ceil(), self.camera.width),
            y0: clip(v0.floor(), self.camera.height),
            y1: clip(v1.ceil(), self.camera.height),
        };
        let area = (r.x1.saturating_sub(r.x0)) * (r.y1.saturating_sub(r.y0));
        (area >= MIN_ROI_PIXELS).then_some(r)
    }
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

/// Opens a frame as RGB8; unreadable or corrupt files are a typed error.
pub fn load_frame(path: &std::path::Path) -> Result<RgbImage> {
    let reader = image::ImageReader::open(path).map_err(|e| TerrainError::Image {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    let reader = reader
        .with_guessed_format()
        .map_err(|e| TerrainError::Image {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })?;
    let img = reader.decode().map_err(|e| TerrainError::Image {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    Ok(img.to_rgb8())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn otsu_finds_the_gaps_between_grey_clusters() {
        let mut h = [0u64; 256];
        for (c, w) in [(20usize, 100u64), (90, 80), (160, 120), (230, 90)] {
            for d in 0..5 {
                h[c + d] += w;
            }
        }
        let t = multi_otsu(&h, 3);
        assert_eq!(t.len(), 3);
        assert!((24..90).contains(&(t[0] as usize)), "{t:?}");
        assert!((94..160).contains(&(t[1] as usize)), "{t:?}");
        assert!((164..230).contains(&(t[2] as usize)), "{t:?}");
    }

    #[test]
    fn lbp_of_flat_and_striped_images() {
        // A flat image: every neighbour >= centre, code 255, bin 8.
        let flat = vec![7u8; 25];
        let mut out = Vec::new();
        lbp_histogram(&flat, 5, 5, &mut out);
        assert_eq!(out[8], 1.0);
        // A single bright pixel over a dark background: its code is 0
        // (no neighbour >= it), bin 0.
        let mut spot = vec![0u8; 9];
        spot[4] = 200;
        let mut out = Vec::new();
        lbp_histogram(&spot, 3, 3, &mut out);
        assert_eq!(out[0], 1.0);
        // A bright right neighbour only with a dark rest: Ojala's bit 0.
        let mut img = vec![100u8; 9];
        for (i, v) in img.iter_mut().enumerate() {
            if i != 4 && i != 5 {
                *v = 0;
            }
        }
        let mut out = Vec::new();
        lbp_histogram(&img, 3, 3, &mut out);
        assert_eq!(out[1], 1.0, "one bit set -> uniform, bin 1: {out:?}");
    }

    #[test]
    fn box_dimension_of_a_line_and_a_filled_square() {
        let (w, h) = (64, 64);
        let mut m = vec![0u16; w * h];
        for x in 0..w {
            m[32 * w + x] |= 1;
        }
        for v in m.iter_mut() {
            *v |= 2;
        }
        let d = box_counting(m, w, h, 2);
        assert!((d[0] - 1.0).abs() < 0.05, "line {d:?}");
        assert!((d[1] - 2.0).abs() < 0.05, "plane {d:?}");
    }

    #[test]
    fn roi_straight_ahead_is_centred_and_moves_with_turns() {
        let cam = CameraModel {
            width: 640,
            height: 480,
            fx: 400.0,
            fy: 400.0,
            cx: 320.0,
            cy: 240.0,
            x: 0.3,
            y: 0.0,
            z: 1.0,
            pitch: 0.6,
        };
        let roi = RoiConfig {
            camera: cam,
            horizon_s: 1.0,
            length: 0.5,
            width: 0.4,
            margin: 1.2,
        };
        let straight = Twist {
            v_x: 1.5,
            v_y: 0.0,
            omega: 0.0,
        };
        let r = roi.region(&straight).unwrap();
        let mid = (r.x0 + r.x1) as f64 / 2.0;
        assert!((mid - 320.0).abs() < 2.0, "{r:?}");
        let left = Twist {
            v_x: 1.5,
            v_y: 0.0,
            omega: 0.8,
        };
        let rl = roi.region(&left).unwrap();
        assert!(
            ((rl.x0 + rl.x1) as f64 / 2.0) < mid - 20.0,
            "turning left moves the ROI left: {rl:?}"
        );
        let back = Twist {
            v_x: -3.0,
            v_y: 0.0,
            omega: 0.0,
        };
        assert!(roi.region(&back).is_none());
    }

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
