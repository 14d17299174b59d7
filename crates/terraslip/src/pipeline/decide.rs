//! What a run decides before its first row, from the drive's start: how
//! late the wheels are stamped against the gyro (and whether the gyro is
//! the body's yaw rate at all), which slip parameters the sensors can
//! teach (positions, headings, a gyro), and, from what the log states its
//! pose reference is, whether the fixes' error wanders. `estimate` decides from the log's
//! first [`super::gyro_delay::SPAN`] s, `node` from the same span of live
//! samples held back as its warm-up, both with this code.

use terraslip_core::filter::SlipHold;
use terraslip_io::PoseReference;

use super::GyroClock;
use crate::config::EstimatorConfig;

/// What the drive's start shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Seen {
    /// The gyro's clock against the wheels' ([`super::gyro_delay`]).
    pub gyro_clock: GyroClock,
    /// Pose rows with a position came.
    pub positions: bool,
    /// Pose rows with a heading came.
    pub headings: bool,
    /// Gyro samples came.
    pub gyro: bool,
    /// What the log states its pose reference is (meta.toml's
    /// `pose_reference`; a bag's topics file `[meta]`).
    pub pose_reference: Option<PoseReference>,
}

/// The run's decisions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decisions {
    /// What the start showed of the gyro's clock.
    pub gyro_clock: GyroClock,
    /// The gyro is fused.
    pub fuse_gyro: bool,
    /// How late the wheels are stamped against the gyro, s (0 when the
    /// gyro is not fused): its samples are moved this much later.
    pub gyro_delay: f64,
    /// The slip parameters held at their starting values.
    pub hold: SlipHold,
    /// The gyro's scale is held (nothing shows the true turn: no
    /// positions, no headings).
    pub hold_gyro_scale: bool,
    /// The pose reference as stated: a localiser's fixes carry no
    /// wandering error (`measurement.correlated_fraction` 0).
    pub pose_reference: Option<PoseReference>,
}

impl Decisions {
    /// Decides from what the start showed; `dir` names the source in the
    /// warning returned when the gyro is not the body's yaw rate.
    pub fn new(dir: &str, cfg: &EstimatorConfig, seen: Seen) -> (Self, Option<String>) {
        let configured = cfg.measurement.std_gyro > 0.0;
        let mut warning = None;
        let (fuse_gyro, gyro_delay) = match seen.gyro_clock {
            _ if !configured => (false, 0.0),
            GyroClock::NotYaw(c) => {
                warning = Some(format!(
                    "{dir}: the gyro (imu gyro_z) does not follow the tread speed difference at any delay within 1 s (best correlation {c:.2}), so it is not fused; it is not the body's yaw rate: check the IMU's mounting (for a bag, `[imu] mount_rpy_deg` in the topics file)"
                ));
                (false, 0.0)
            }
            GyroClock::Faulty {
                wheels,
                gyro_ref,
                wheels_ref,
            } => {
                warning = Some(format!(
                    "{dir}: the gyro (imu gyro_z) follows neither the tread speed difference (best correlation {wheels:.2}) nor the pose reference's yaw rate ({gyro_ref:.2}), which follows the wheels ({wheels_ref:.2}): the gyro is faulty or mounted wrongly and is not fused; check the IMU's mounting (for a bag, `[imu] mount_rpy_deg` in the topics file)"
                ));
                (false, 0.0)
            }
            GyroClock::Slipping {
                wheels,
                gyro_ref,
                wheels_ref,
            } => {
                warning = Some(format!(
                    "{dir}: the treads slip heavily: the gyro (imu gyro_z) follows the pose reference's yaw rate (correlation {gyro_ref:.2}) and the tread speed difference does not ({wheels_ref:.2}; against the gyro {wheels:.2}), so the gyro is fused as the body's yaw rate (its clock taken as the wheels') and the wheels' turn is read as slip"
                ));
                (seen.gyro, 0.0)
            }
            GyroClock::Delay { wheels_late_by, .. } => (seen.gyro, wheels_late_by),
            GyroClock::Unknown => (seen.gyro, 0.0),
        };
        let hold = if seen.positions {
            SlipHold::Nothing
        } else if seen.headings || fuse_gyro {
            SlipHold::PositionTaught
        } else {
            SlipHold::All
        };
        let d = Self {
            gyro_clock: seen.gyro_clock,
            fuse_gyro,
            gyro_delay: if fuse_gyro { gyro_delay } else { 0.0 },
            hold,
            // Only positions or headings show the true turn the gyro's
            // scale is measured against.
            hold_gyro_scale: !(seen.positions || seen.headings),
            pose_reference: seen.pose_reference,
        };
        (d, warning)
    }

    /// The configuration the filter is built with: `cfg` with the slip
    /// parameters and gyro scale held as decided, and no wandering error
    /// in a localiser's fixes.
    pub fn filter_config(&self, cfg: &EstimatorConfig) -> EstimatorConfig {
        let mut held = for_pose_reference(cfg, self.pose_reference);
        held.filter.hold = self.hold;
        held.filter.hold_gyro_scale = self.hold_gyro_scale;
        held
    }

    /// The decisions for the user, one line each (without the `decided: `
    /// prefix).
    pub fn lines(&self) -> Vec<String> {
        let gyro = match (self.fuse_gyro, self.gyro_clock) {
            (true, GyroClock::Delay { wheels_late_by, .. }) if wheels_late_by == self.gyro_delay => format!(
                "gyro fused, the wheels stamped {:.3} s late against it (the best correlation of its rate with the tread speed difference)",
                self.gyro_delay
            ),
            (true, GyroClock::Slipping { gyro_ref, .. }) => format!(
                "gyro fused on the wheels' clock: the pose reference's yaw rate follows it (correlation {gyro_ref:.2}) and not the treads, which slip"
            ),
            (true, GyroClock::Unknown) if self.gyro_delay == 0.0 => {
                "gyro fused, no delay (the start turns too little to tell)".into()
            }
            (true, _) => format!(
                "gyro fused, the wheels stamped {:.3} s late against it (given, or recalled when the warm-up turns too little to tell)",
                self.gyro_delay
            ),
            (false, GyroClock::NotYaw(c)) => format!(
                "gyro not fused: its rate does not follow the tread speed difference (best correlation {c:.2})"
            ),
            (false, GyroClock::Faulty { gyro_ref, .. }) => format!(
                "gyro not fused: the pose reference's yaw rate follows the treads, not the gyro (correlation {gyro_ref:.2})"
            ),
            (false, _) => "no gyro fused".into(),
        };
        let hold = match self.hold {
            SlipHold::Nothing => "every slip parameter learned (positions came)",
            SlipHold::PositionTaught => {
                "the common speed factor and the ICR centre held (no positions), the turning learned"
            }
            SlipHold::All => "every slip parameter held (no positions, headings or gyro)",
        };
        let scale = if self.hold_gyro_scale {
            "the gyro's scale held (no positions or headings show the true turn)"
        } else {
            "the gyro's scale learned against the positions and headings"
        };
        let mut out = vec![gyro, hold.to_string()];
        if self.fuse_gyro {
            out.push(scale.to_string());
        }
        // A GNSS receiver's is the default, said by `import` where a bag's
        // message type tells it.
        if let Some(r @ PoseReference::Localiser) = self.pose_reference {
            out.push(format!(
                "the pose reference is a {} (pose_reference in meta.toml or a topics file's [meta]): {}",
                r.noun(),
                r.error_taken()
            ));
        }
        out
    }

    /// The decisions as a parameters file keeps them (`decided`).
    pub fn to_json(&self) -> serde_json::Value {
        let gyro = match (self.fuse_gyro, self.gyro_clock) {
            (false, GyroClock::NotYaw(_)) => "not the yaw rate",
            (false, GyroClock::Faulty { .. }) => "faulty (the reference follows the treads)",
            (false, _) => "not fused",
            (true, _) => "fused",
        };
        serde_json::json!({
            "gyro": gyro,
            "gyro_delay_s": self.gyro_delay,
            "hold": format!("{:?}", self.hold),
            "hold_gyro_scale": self.hold_gyro_scale,
            "pose_reference": self.pose_reference.map(PoseReference::name),
        })
    }
}

/// `cfg` for a pose reference of kind `reference` (meta.toml's
/// `pose_reference`): a localiser's fixes carry no wandering error
/// (`measurement.correlated_fraction` 0); a GNSS's, or an unstated one's,
/// as configured.
pub fn for_pose_reference(
    cfg: &EstimatorConfig,
    reference: Option<PoseReference>,
) -> EstimatorConfig {
    let mut out = cfg.clone();
    if reference == Some(PoseReference::Localiser) {
        out.measurement.correlated_fraction = 0.0;
    }
    out
}

/// The warnings that depend on the decisions and the set-up: a gyro whose
/// turns the slip model cannot follow, and the slip parameters held.
pub fn warnings(
    dir: &str,
    cfg: &EstimatorConfig,
    d: &Decisions,
    track_width: f64,
    has_pose: bool,
    init_source: &str,
) -> Vec<String> {
    let mut out = Vec::new();
    if let (true, GyroClock::Delay { gyro_per_tread, .. }) = (d.fuse_gyro, d.gyro_clock) {
        let band = cfg.band(track_width);
        out.extend(super::gyro_delay::turn_disagreement(
            dir,
            gyro_per_tread,
            track_width,
            band.min_spread,
            band.max_spread,
        ));
    }
    out.extend(hold_warning(dir, d.hold, has_pose, init_source));
    out
}

/// The warning that says which slip parameters a log without positions
/// cannot teach and holds (`None` when positions are present).
fn hold_warning(dir: &str, hold: SlipHold, has_pose: bool, start: &str) -> Option<String> {
    let what = if has_pose {
        "the pose reference has headings but no positions"
    } else {
        "no pose observations: dead reckoning from the origin"
    };
    match hold {
        SlipHold::Nothing => None,
        SlipHold::PositionTaught => Some(format!(
            "{dir}: {what}; only positions show the common speed factor (alpha_l + alpha_r)/2 and the ICR centre offsets, so they stay at their starting values ({start}) and are not learned; the turning (spread, speed factor difference) is learned from the {}",
            if has_pose { "headings" } else { "gyro" }
        )),
        SlipHold::All => Some(format!(
            "{dir}: {what} and no yaw-rate gyro: nothing measures the motion, so every slip parameter stays at its starting value ({start}) and none is learned"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decided(gyro: bool, pose_reference: Option<PoseReference>) -> Decisions {
        let seen = Seen {
            gyro_clock: GyroClock::Unknown,
            positions: true,
            headings: true,
            gyro,
            pose_reference,
        };
        Decisions::new("log", &EstimatorConfig::default(), seen).0
    }

    #[test]
    fn the_lines_speak_of_a_gyro_only_when_one_is_fused_and_of_a_stated_localiser() {
        let scale = |d: &Decisions| d.lines().iter().any(|l| l.contains("gyro's scale"));
        assert!(scale(&decided(true, None)));
        assert!(!scale(&decided(false, None)));
        assert_eq!(decided(false, None).lines()[0], "no gyro fused");
        let localiser = decided(false, Some(PoseReference::Localiser)).lines();
        assert!(
            localiser.last().unwrap().contains("is a localiser"),
            "{localiser:?}"
        );
        assert_eq!(decided(false, Some(PoseReference::Gnss)).lines().len(), 2);
    }
}
