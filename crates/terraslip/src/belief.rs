//! Whether the live slip estimate is believed enough to drive on: what
//! `terraslip node --compensate` (and the closed-loop follower of
//! `terraslip-lab follow`) asks before applying the learned model to a
//! command, row by row of the estimate.

use crate::pipeline::EstimateRow;

/// Default largest std of the spread `y_l - y_r`, as a fraction of the
/// spread, at which the estimate is believed.
pub const CONFIDENT_SPREAD_STD: f64 = 0.05;

/// Default time after a detected slip change during which the estimate is
/// not believed, s (stamp time): none. The detector resets the spread's
/// uncertainty (to at least a tenth of the spread), so the estimate is not
/// believed until the data have brought its std back within
/// [`CONFIDENT_SPREAD_STD`]: the re-learned estimate is taken as soon as
/// it is known, where a fixed hold kept the model of the old ground
/// through the first turn on the new one.
pub const HOLD_AFTER_CHANGE: f64 = 0.0;

/// Whether the live estimate is believed, row by row: the spread known to
/// within a fraction of itself, no slip change detected for a while, the
/// terrain known (when the run tells terrains apart).
#[derive(Debug, Clone)]
pub struct Belief {
    max_spread_std: f64,
    hold: f64,
    last_change: Option<f64>,
    /// The last row's verdict: believed, or why not.
    pub verdict: Result<(), String>,
}

impl Belief {
    /// Believed when the spread's std is at most `max_spread_std` of the
    /// spread and no change was detected in the last `hold` s.
    pub fn new(max_spread_std: f64, hold: f64) -> Self {
        Self {
            max_spread_std,
            hold,
            last_change: None,
            verdict: Err("no estimate yet".into()),
        }
    }

    /// Believed from now on when the spread's std is at most
    /// `max_spread_std` of the spread and no change was detected in the
    /// last `hold` s (the last change detected is kept).
    pub fn retune(&mut self, max_spread_std: f64, hold: f64) {
        self.max_spread_std = max_spread_std;
        self.hold = hold;
    }

    /// Takes one estimate row (`terrains`: the run's terrain names).
    pub fn row(&mut self, r: &EstimateRow, terrains: &[String]) {
        let unknown_terrain = !terrains.is_empty() && r.terrain.is_none();
        self.judge(r.t, r.y_l - r.y_r, r.std_spread, r.change, unknown_terrain);
    }

    /// Takes a row at `t` (s) of spread `spread` with std `std_spread` (m),
    /// a change detected since the last (`change`), on an unknown terrain.
    pub fn judge(
        &mut self,
        t: f64,
        spread: f64,
        std_spread: f64,
        change: bool,
        unknown_terrain: bool,
    ) {
        if change {
            self.last_change = Some(t);
        }
        let rel = if spread > 0.0 {
            std_spread / spread
        } else {
            f64::INFINITY
        };
        // NaN is not believed.
        let known = rel <= self.max_spread_std;
        self.verdict = if !known {
            Err(format!(
                "spread std {:.1} % of the spread (believed from {:.1} %)",
                100.0 * rel,
                100.0 * self.max_spread_std
            ))
        } else if let Some(ago) = self
            .last_change
            .map(|c| t - c)
            .filter(|ago| *ago < self.hold)
        {
            Err(format!("slip change detected {ago:.1} s ago"))
        } else if unknown_terrain {
            Err("terrain unknown".into())
        } else {
            Ok(())
        };
    }
}

impl Default for Belief {
    /// [`CONFIDENT_SPREAD_STD`] and [`HOLD_AFTER_CHANGE`].
    fn default() -> Self {
        Self::new(CONFIDENT_SPREAD_STD, HOLD_AFTER_CHANGE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn belief_needs_a_known_spread_no_recent_change_and_a_known_terrain() {
        let mut b = Belief::new(0.05, 3.0);
        assert!(b.verdict.is_err());
        b.judge(1.0, 1.0, 0.08, false, false);
        assert!(
            b.verdict.as_ref().unwrap_err().contains("8.0 %"),
            "{:?}",
            b.verdict
        );
        b.judge(2.0, 1.0, 0.04, false, false);
        assert_eq!(b.verdict, Ok(()));
        b.judge(3.0, 1.0, 0.04, true, false);
        assert!(b.verdict.as_ref().unwrap_err().contains("change"));
        b.judge(5.9, 1.0, 0.04, false, false);
        assert!(b.verdict.is_err());
        b.judge(6.1, 1.0, 0.04, false, false);
        assert_eq!(b.verdict, Ok(()));
        b.judge(7.0, 1.0, 0.04, false, true);
        assert_eq!(b.verdict, Err("terrain unknown".into()));
        // A NaN std or a singular spread is not believed.
        b.judge(8.0, 1.0, f64::NAN, false, false);
        assert!(b.verdict.is_err());
        b.judge(8.1, 0.0, 0.01, false, false);
        assert!(b.verdict.is_err());
    }

    #[test]
    fn retuned_belief_judges_the_next_row_by_the_new_bounds() {
        let mut b = Belief::new(0.05, 3.0);
        b.judge(1.0, 1.0, 0.08, true, false);
        assert!(b.verdict.is_err());
        b.retune(0.1, 0.5);
        b.judge(2.0, 1.0, 0.08, false, false);
        assert_eq!(b.verdict, Ok(()));
    }

    #[test]
    fn by_default_a_detected_change_is_believed_once_the_spread_is_known_again() {
        let mut b = Belief::default();
        b.judge(1.0, 1.0, 0.04, false, false);
        assert_eq!(b.verdict, Ok(()));
        // The detector's reset leaves the spread unknown ...
        b.judge(2.0, 1.0, 0.12, true, false);
        assert!(b.verdict.is_err());
        // ... until the new ground has taught it again, half a second later.
        b.judge(2.5, 1.0, 0.04, false, false);
        assert_eq!(b.verdict, Ok(()));
    }
}
