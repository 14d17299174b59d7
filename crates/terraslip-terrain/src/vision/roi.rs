//! chen2023 §3.2.2: the region of interest, the footprint the kinematic
//! model predicts the robot will cover `t_s` seconds ahead, projected into
//! the image by a pinhole camera model.

use serde::{Deserialize, Serialize};
use terraslip_core::kinematics::Twist;

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

#[cfg(test)]
mod tests {
    use super::*;

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
}
