//! What stands between the path follower and the drive controller.

use terraslip::pipeline::EstimateRow;
use terraslip_core::compensate::{CompensateConfig, Compensator, IcrModel};
use terraslip_core::estimator::Estimator;
use terraslip_core::kinematics::Twist;

/// Believed when the spread's std is at most this fraction of the spread
/// ...
pub const CONFIDENT_SPREAD: f64 = 0.05;
/// ... and no slip change was detected in the last this many seconds (the
/// defaults of `terraslip node --compensate`'s `confident_spread_std` and
/// `hold_after_change`, judged as the node judges them).
pub const HOLD_AFTER_CHANGE: f64 = 3.0;

/// Whether the estimate is believed, row by row.
#[derive(Debug, Clone, Default)]
pub struct Belief {
    last_change: Option<f64>,
}

impl Belief {
    /// Takes the newest row; true when its model may be applied.
    pub fn confident(&mut self, row: &EstimateRow) -> bool {
        self.judge(row.t, row.y_l - row.y_r, row.std_spread, row.change)
    }

    /// A row at `t` s of spread `spread` with std `std_spread` (m), a
    /// change detected since the previous row (`change`).
    fn judge(&mut self, t: f64, spread: f64, std_spread: f64, change: bool) -> bool {
        if change {
            self.last_change = Some(t);
        }
        let rel = if spread > 0.0 {
            std_spread / spread
        } else {
            f64::INFINITY
        };
        rel <= CONFIDENT_SPREAD && !self.last_change.is_some_and(|c| t - c < HOLD_AFTER_CHANGE)
    }
}

/// How the follower's twist reaches the drive controller.
#[derive(Debug, Clone)]
pub enum Steering {
    /// Unchanged.
    None,
    /// Through a drive controller whose `wheel_separation_multiplier` is
    /// this: its tread speeds are those of the yaw rate times it.
    Multiplier(f64),
    /// Through the compensator, under the estimator's model now.
    Live(Box<Compensator>, Belief),
}

impl Steering {
    /// Live compensation with the compensator's settings `cfg`.
    pub fn live(cfg: CompensateConfig) -> anyhow::Result<Self> {
        let c = Compensator::new(cfg).map_err(|e| anyhow::anyhow!("compensator: {e}"))?;
        Ok(Steering::Live(Box::new(c), Belief::default()))
    }

    /// The twist the drive controller receives for the follower's
    /// `desired` one at `t` s, with the estimator and its newest `row`.
    pub fn command(
        &mut self,
        t: f64,
        desired: Twist,
        row: &EstimateRow,
        estimator: &Estimator,
    ) -> Twist {
        match self {
            Steering::None => desired,
            Steering::Multiplier(m) => Twist {
                omega: desired.omega * *m,
                ..desired
            },
            Steering::Live(c, belief) => {
                let model = IcrModel::of_filter(estimator.filter());
                let confident = belief.confident(row);
                c.command(t, desired, Some((model, confident))).twist
            }
        }
    }
}

/// How the follower's twist reaches the drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// As it is.
    None,
    /// Through a static multiplier from a turn test on the first ground.
    Static,
    /// Through live compensation under the estimator's model.
    Live,
}

impl Variant {
    pub const ALL: [Variant; 3] = [Variant::None, Variant::Static, Variant::Live];

    pub fn name(self) -> &'static str {
        match self {
            Variant::None => "none",
            Variant::Static => "static",
            Variant::Live => "live",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn belief_needs_a_narrow_spread_and_no_change_for_the_hold() {
        let mut b = Belief::default();
        // (t s, spread m, its std m, change)
        assert!(b.judge(0.0, 0.4, 0.01, false));
        assert!(!b.judge(0.1, 0.4, 0.03, false));
        assert!(!b.judge(1.0, 0.4, 0.01, true));
        assert!(!b.judge(3.9, 0.4, 0.01, false));
        assert!(b.judge(4.0, 0.4, 0.01, false));
        assert!(!b.judge(5.0, -0.1, 0.0, false));
    }
}
