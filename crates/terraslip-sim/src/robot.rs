//! The simulated robot's geometry.

use serde::{Deserialize, Serialize};

/// The robot's geometry (nominal, what `meta.toml` says).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Robot {
    pub name: String,
    /// Distance between tread centre lines, m.
    pub track_width: f64,
    /// Nominal wheel radius, m (encoder ticks -> tread speed).
    pub wheel_radius: f64,
    /// Body length, m (scales the default x_c of the catalogue).
    pub length: f64,
    /// Top tread speed, m/s: commands are clipped to it.
    pub max_tread_speed: f64,
}

impl Default for Robot {
    /// The four-wheeled robot of lv2019 §IV: 400 x 320 mm, 130 mm wheels 60 mm
    /// wide, so about 0.26 m between the wheel centre lines.
    fn default() -> Self {
        Self {
            name: "lv2019-4wd".into(),
            track_width: 0.26,
            wheel_radius: 0.065,
            length: 0.40,
            max_tread_speed: 1.6,
        }
    }
}
