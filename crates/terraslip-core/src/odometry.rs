//! Dead reckoning with given ICRs: integrates tread speeds into a pose,
//! used between pose fixes and through GNSS outages.

use crate::kinematics::IcrParams;
use crate::model::{self, State, TreadInput, EAST, NORTH, YAW};

/// Pose integrated from tread speeds with fixed ICRs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Odometry {
    s: State,
    alpha_l: f64,
    alpha_r: f64,
}

impl Odometry {
    /// Starts at `(east, north)` (m, ENU) and `yaw` (rad, CCW from east).
    pub fn new(east: f64, north: f64, yaw: f64, icr: &IcrParams) -> Self {
        Self {
            s: model::state(east, north, yaw, icr),
            alpha_l: icr.alpha_l,
            alpha_r: icr.alpha_r,
        }
    }

    /// Advances by `dt` s with measured tread speeds (m/s). Non-finite or
    /// negative steps are ignored (the pose stays finite).
    pub fn step(&mut self, v_left: f64, v_right: f64, dt: f64) {
        if !(v_left.is_finite() && v_right.is_finite() && dt.is_finite() && dt > 0.0) {
            return;
        }
        let u = TreadInput::new(v_left, v_right, self.alpha_l, self.alpha_r);
        self.s = model::predict(&self.s, u, dt);
    }

    /// `(east, north, yaw)`: m, m, rad.
    pub fn pose(&self) -> (f64, f64, f64) {
        (self.s[EAST], self.s[NORTH], self.s[YAW])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_circle_returns_home() {
        // Spin on an arc: omega = 0.4/0.5 = 0.8 rad/s, radius v/omega.
        let icr = IcrParams::new(0.25, -0.25, 0.0);
        let mut o = Odometry::new(0.0, 0.0, 0.0, &icr);
        let period = 2.0 * core::f64::consts::PI / 0.8;
        let n = 100_000;
        for _ in 0..n {
            o.step(0.3, 0.7, period / n as f64);
        }
        let (e, nn, y) = o.pose();
        assert!(
            e.abs() < 1e-3 && nn.abs() < 1e-3 && y.abs() < 1e-6,
            "{e} {nn} {y}"
        );
        o.step(f64::NAN, 0.0, 0.1);
        assert!(o.pose().0.is_finite());
    }
}
