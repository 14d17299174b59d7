//! The gyro window being integrated: its heading change, length and the
//! model heading error it shares with the state.

use crate::model::{State, N, YAW};

/// The gyro window being integrated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct GyroWindow {
    pub(super) open: bool,
    /// Integral of the gyro's rate, rad.
    pub(super) angle: f64,
    /// Gyro samples in it.
    pub(super) samples: f64,
    /// Length, s, and prediction steps.
    pub(super) span: f64,
    pub(super) steps: usize,
    /// Yaw variance the model's noise added over the window, rad^2.
    pub(super) model_var: f64,
    /// Covariance of the state with the model's heading error `E`.
    pub(super) cross: State,
}

impl GyroWindow {
    pub(super) fn new() -> Self {
        Self {
            open: false,
            angle: 0.0,
            samples: 0.0,
            span: 0.0,
            steps: 0,
            model_var: 0.0,
            cross: State::zeros(),
        }
    }

    pub(super) fn is_open(&self) -> bool {
        self.open
    }

    /// `cov(x, E)`, for a prediction step to propagate.
    pub(super) fn cross_mut(&mut self) -> &mut State {
        &mut self.cross
    }

    /// A prediction step's model heading error of variance `q_model`
    /// (rad^2), of which the yaw took `q_yaw`.
    pub(super) fn add_model_noise(&mut self, q_model: f64, q_yaw: f64) {
        self.cross[YAW] += q_yaw;
        self.model_var += q_model;
    }

    /// A fix's update `x += K nu` changes the cross-covariance to
    /// `C - K (H C)`.
    pub(super) fn after_update<const M: usize>(
        &mut self,
        K: &nalgebra::SMatrix<f64, N, M>,
        H: &nalgebra::SMatrix<f64, M, N>,
    ) {
        if self.open {
            let hc = H * self.cross;
            self.cross -= K * hc;
        }
    }

    /// The window is abandoned (a gap in the gyro, a re-anchored pose).
    pub(super) fn close(&mut self) {
        self.open = false;
    }
}
