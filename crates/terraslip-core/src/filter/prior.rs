//! Where the filter starts: slip parameters, turn laws and centripetal
//! terms, and their uncertainty.

use super::SlipStd;
use super::{FilterError, MAX_K_SPREAD_SPEED, MAX_K_X_SPEED, MAX_TURN_LAW};
use crate::kinematics::{CentripetalSlopes, IcrParams};

/// Starting slip parameters and their uncertainty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prior {
    /// Starting ICR parameters (straight-line values).
    pub icr: IcrParams,
    /// Their standard deviations.
    pub std: SlipStd,
    /// Starting slope of the turn law, s/m (0 = constant ICRs).
    pub turn_law: f64,
    /// Its standard deviation, s/m (0 = held at `turn_law`).
    pub turn_law_std: f64,
    /// Starting centripetal terms (zero = the constant model).
    pub centripetal: CentripetalSlopes,
    /// Their standard deviations, s and s/m (both 0 = held at
    /// `centripetal`).
    pub centripetal_std: CentripetalSlopes,
    /// Starting slope of the speed factors' turn law, s/m: both speed
    /// factors in effect are `1 + speed_law |V_r - V_l|` times the
    /// straight-line ones (0 = constant).
    pub speed_law: f64,
    /// Its standard deviation, s/m (0 = held at `speed_law`). Learned
    /// where the speed factor is: with a position reference.
    pub speed_law_std: f64,
}

impl Prior {
    /// Checks that the prior is usable; the error says what is not.
    pub(super) fn validate(&self) -> Result<(), FilterError> {
        self.icr
            .validate()
            .map_err(|_| FilterError::BadInput("prior ICR parameters are not usable"))?;
        if !self.std.is_valid() {
            return Err(FilterError::BadInput("prior std not finite or negative"));
        }
        if !(self.turn_law.abs() <= 2.0
            && self.turn_law_std.is_finite()
            && self.turn_law_std >= 0.0
            && self.speed_law.abs() <= MAX_TURN_LAW
            && self.speed_law_std.is_finite()
            && self.speed_law_std >= 0.0)
        {
            return Err(FilterError::BadInput(
                "turn law slopes must be within +-2 s/m (the speed factors' +-1 s/m) \
             with finite stds",
            ));
        }
        let (c, c_std) = (self.centripetal, self.centripetal_std);
        if !(c.k_x_speed.abs() <= MAX_K_X_SPEED
            && c.k_spread_speed.abs() <= MAX_K_SPREAD_SPEED
            && c_std.k_x_speed.is_finite()
            && c_std.k_x_speed >= 0.0
            && c_std.k_spread_speed.is_finite()
            && c_std.k_spread_speed >= 0.0)
        {
            return Err(FilterError::BadInput(
                "centripetal terms must be within +-1 s (k_x_speed) and +-1 s/m \
             (k_spread_speed) with finite stds",
            ));
        }
        Ok(())
    }
}
