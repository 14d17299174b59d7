//! The speed factors' turn law, held: a calibration's selected turn-rate
//! model (`terraslip calibrate`, `TurnRateSlopes::k_alpha`) scales both
//! speed factors by `1 + k_alpha |V_r - V_l|` (clamped as the calibration
//! clamps it). The filter does not learn it; started from such a model
//! (`estimate --init`) it holds the calibration's slope, so its model is
//! the one the calibration predicts with.

use super::{Filter, FilterError};
use crate::kinematics::{IcrParams, RATE_GAIN_MAX, RATE_GAIN_MIN};
use crate::slip::TreadInput;

/// Largest slope of the speed factors' turn law, s/m (as the spread's).
pub const MAX_SPEED_LAW: f64 = 2.0;

impl Filter {
    /// Holds the speed factors' turn law at slope `k_alpha` (s/m per m/s
    /// of tread speed difference; 0 = none).
    pub fn hold_speed_law(&mut self, k_alpha: f64) -> Result<(), FilterError> {
        if k_alpha.is_nan() || k_alpha.abs() > MAX_SPEED_LAW {
            return Err(FilterError::BadInput(
                "speed factors' turn law slope must be within +-2 s/m",
            ));
        }
        self.speed_law = k_alpha;
        Ok(())
    }

    /// The speed factors' turn law slope held, s/m.
    pub fn speed_law(&self) -> f64 {
        self.speed_law
    }

    /// The factor both speed factors take at measured tread speeds `u`.
    pub(super) fn speed_gain(&self, u: TreadInput) -> f64 {
        let dv = libm::fabs(u.v_right - u.v_left);
        (1.0 + self.speed_law * dv).clamp(RATE_GAIN_MIN, RATE_GAIN_MAX)
    }

    /// Measured tread speeds `u` as the model reads them: both speed
    /// factors scaled by the law is both tread speeds scaled (the ICR
    /// model's twist depends on `alpha_l V_l` and `alpha_r V_r` alone).
    pub(super) fn tread_in_effect(&self, u: TreadInput) -> TreadInput {
        let g = self.speed_gain(u);
        TreadInput {
            v_left: g * u.v_left,
            v_right: g * u.v_right,
        }
    }

    /// `p` with its speed factors scaled by the law at tread speeds `u`.
    pub(super) fn with_speed_law(&self, mut p: IcrParams, u: TreadInput) -> IcrParams {
        let g = self.speed_gain(u);
        p.alpha_l *= g;
        p.alpha_r *= g;
        p
    }
}
