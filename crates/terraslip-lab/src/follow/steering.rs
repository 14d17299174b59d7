//! What stands between the path follower and the drive controller.

use terraslip::belief::Belief;
use terraslip::pipeline::EstimateRow;
use terraslip_core::compensate::{CompensateConfig, Compensator, IcrModel};
use terraslip_core::estimator::Estimator;
use terraslip_core::kinematics::Twist;

/// How the follower's twist reaches the drive controller.
#[derive(Debug, Clone)]
pub enum Steering {
    /// Unchanged.
    None,
    /// Through a drive controller whose `wheel_separation_multiplier` is
    /// this: its tread speeds are those of the yaw rate times it.
    Multiplier(f64),
    /// Through the compensator, under the estimator's model now, to a
    /// drive controller whose `wheel_separation_multiplier` is `multiplier`
    /// (the compensator expresses its commands in that controller's model,
    /// so a command passed through is driven as [`Steering::Multiplier`]).
    Live {
        compensator: Box<Compensator>,
        belief: Belief,
        multiplier: f64,
    },
}

impl Steering {
    /// Live compensation with the compensator's settings `cfg` (whose
    /// `separation` is the controller's: the robot's times `multiplier`),
    /// the estimate judged by `belief`, to a controller of wheel
    /// separation multiplier `multiplier`.
    pub fn live(cfg: CompensateConfig, belief: Belief, multiplier: f64) -> anyhow::Result<Self> {
        let c = Compensator::new(cfg).map_err(|e| anyhow::anyhow!("compensator: {e}"))?;
        Ok(Steering::Live {
            compensator: Box::new(c),
            belief,
            multiplier,
        })
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
            Steering::Multiplier(m) => multiplied(desired, *m),
            Steering::Live {
                compensator,
                belief,
                multiplier,
            } => {
                let model = IcrModel::of_filter(estimator.filter());
                belief.row(row, &[]);
                let confident = belief.verdict.is_ok();
                let cmd = compensator.command(t, desired, Some((model, confident)));
                multiplied(cmd.twist, *multiplier)
            }
        }
    }
}

/// The twist whose tread speeds a controller of wheel separation
/// multiplier `m` makes of `cmd`: its yaw rate times `m`.
fn multiplied(cmd: Twist, m: f64) -> Twist {
    Twist {
        omega: cmd.omega * m,
        ..cmd
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
