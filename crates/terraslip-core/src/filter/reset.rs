//! Covariance resets of the slip parameters: at a change the slip-change
//! detector finds, and at the terrain schedule's changes and recalls
//! (chen2023's covariance reset, the terrain memory).

use super::{Filter, FilterError, SlipStd};
use crate::kinematics::IcrParams;
use crate::model::{N, SLIP};
use crate::slip::SlipMat;

impl Filter {
    /// Adds [`super::FilterConfig::change_reset`] to the slip uncertainty
    /// (its correlations with the pose kept: the pose has not changed).
    pub(super) fn raise_slip_uncertainty(&mut self) -> Result<(), FilterError> {
        let icr = self.icr();
        let mut std = self.cfg.change_reset;
        std.spread *= icr.spread();
        let add = std
            .chart_cov(self.cfg.chart, &icr)
            .map(|c| self.cfg.unheld(c))
            .ok_or(FilterError::NonFinite)?;
        let mut blk = self.P.fixed_view_mut::<5, 5>(SLIP, SLIP);
        blk += add;
        for d in &mut self.detector {
            d.clear();
        }
        Ok(())
    }

    /// Resets the slip parameters to `icr` (or keeps the current values if
    /// `None`) with standard deviations `std`, uncorrelated with the rest of
    /// the state.
    pub fn reset_slip(
        &mut self,
        icr: Option<&IcrParams>,
        std: &SlipStd,
    ) -> Result<(), FilterError> {
        let target = icr.copied().unwrap_or_else(|| self.icr());
        self.set_slip(&target, &std.icr_cov())
    }

    /// Sets the slip parameters to `icr` with covariance `icr_cov` on
    /// `(y_l, y_r, x_c, alpha_l, alpha_r)`, uncorrelated with the rest.
    pub fn set_slip(&mut self, icr: &IcrParams, icr_cov: &SlipMat) -> Result<(), FilterError> {
        icr.validate()
            .map_err(|_| FilterError::BadInput("reset ICR parameters are not usable"))?;
        if !icr_cov.iter().all(|v| v.is_finite()) {
            return Err(FilterError::BadInput("reset covariance not finite"));
        }
        let chart = self.cfg.chart;
        let (icr, _) = self.band.project(icr);
        let s = chart.from_icr(&icr);
        let c = chart
            .cov_from_icr(&s, icr_cov)
            .ok_or(FilterError::BadInput("reset ICR parameters are singular"))?;
        self.x.fixed_rows_mut::<5>(SLIP).copy_from(&s);
        for i in SLIP..SLIP + 5 {
            for j in 0..N {
                if !(SLIP..SLIP + 5).contains(&j) {
                    self.P[(i, j)] = 0.0;
                    self.P[(j, i)] = 0.0;
                }
            }
        }
        self.P.fixed_view_mut::<5, 5>(SLIP, SLIP).copy_from(&c);
        self.gyro_win.close();
        if let Some(q) = self.cfg.slip_walk_cov(&icr) {
            self.q_slip = q;
        }
        for d in &mut self.detector {
            d.clear();
        }
        Ok(())
    }
}
