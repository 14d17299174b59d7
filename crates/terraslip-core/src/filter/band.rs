//! Where the ICRs may physically be: the band the slip parameters are kept in.

use super::FilterError;
use crate::kinematics::IcrParams;

/// Where the ICRs may physically be. The state is projected into this band
/// after every update (and a run reports how long it sat on an edge).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IcrBand {
    /// Smallest spread `y_l - y_r`, m (> 0).
    pub min_spread: f64,
    /// Largest spread, m.
    pub max_spread: f64,
    /// Largest `|y_l + y_r| / 2`, m.
    pub max_centre: f64,
    /// Largest `|x_c|`, m.
    pub max_x_c: f64,
    /// Smallest and largest tread speed factor.
    pub alpha_range: (f64, f64),
}

impl IcrBand {
    /// Projects `p` into the band; returns the projected parameters and
    /// whether anything moved.
    pub fn project(&self, p: &IcrParams) -> (IcrParams, bool) {
        let d = p.y_l - p.y_r;
        let c = 0.5 * (p.y_l + p.y_r);
        let dc = d.clamp(self.min_spread, self.max_spread);
        let cc = c.clamp(-self.max_centre, self.max_centre);
        let xc = p.x_c.clamp(-self.max_x_c, self.max_x_c);
        let (lo, hi) = self.alpha_range;
        let al = p.alpha_l.clamp(lo, hi);
        let ar = p.alpha_r.clamp(lo, hi);
        let moved = dc != d || cc != c || xc != p.x_c || al != p.alpha_l || ar != p.alpha_r;
        (
            IcrParams {
                y_l: cc + 0.5 * dc,
                y_r: cc - 0.5 * dc,
                x_c: xc,
                alpha_l: al,
                alpha_r: ar,
            },
            moved,
        )
    }

    fn is_valid(&self) -> bool {
        let (lo, hi) = self.alpha_range;
        [
            self.min_spread,
            self.max_spread,
            self.max_centre,
            self.max_x_c,
            lo,
            hi,
        ]
        .iter()
        .all(|v| v.is_finite())
            && self.min_spread > 0.0
            && self.max_spread > self.min_spread
            && self.max_centre >= 0.0
            && self.max_x_c >= 0.0
            && lo > 0.0
            && hi > lo
    }
}

pub(super) fn validate_band(band: &IcrBand) -> Result<(), FilterError> {
    if band.is_valid() {
        Ok(())
    } else {
        Err(FilterError::BadConfig(
            "band: spreads, centre, x_c and alpha limits must be finite, positive and ordered",
        ))
    }
}
