//! A gated heading fix that says the heading has drifted: what its
//! innovation leaves unexplained goes into the heading's variance.
//!
//! A yaw slip held for seconds turns the heading away faster than the
//! model's noise allows; its fixes then fail the gate, and without more
//! the filter keeps claiming a heading it has lost until `max_rejections`
//! re-anchors it. Adding `nu^2 - S` (rad^2) to the yaw's variance makes the
//! stated heading cover the error the fix shows, and lets the next heading
//! fix in if the drift is real (a lone outlier costs only covariance).

use super::Filter;
use crate::model::YAW;

impl Filter {
    /// Takes a gated heading innovation of square `nu2` (rad^2) against its
    /// predicted variance `s` (rad^2) into the yaw's variance, as model
    /// heading noise (the gyro window shares it).
    pub(super) fn inflate_gated_heading(&mut self, nu2: f64, s: f64) {
        let extra = nu2 - s;
        if !(extra.is_finite() && extra > 0.0 && self.anchored[1]) {
            return;
        }
        self.P[(YAW, YAW)] += extra;
        if self.gyro_win.is_open() {
            self.gyro_win.add_model_noise(extra, extra);
        }
    }
}
