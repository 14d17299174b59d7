//! How far a `diff_drive_controller` parameter file, applied as written,
//! makes the controller's odometry turn against the course of a
//! position-only reference (GNSS fixes).
//!
//! **Applied as written.** The log's tread speeds were made from the
//! recording's controller odometry with its effective separation
//! `S = wheel_separation x wheel_separation_multiplier` (`meta.toml`'s
//! `separation`) and, as the parameter file's header assumes, radius
//! multipliers of 1. A file's block replaces the values it sets and leaves
//! the controller's own for the rest (a commented line sets nothing), as
//! ros2_controllers' `diff_drive_controller` (`odometry.cpp`) takes them:
//! each tread speed is multiplied by its radius multiplier (and by the ratio
//! of a stated `wheel_radius` to the recording's, when both are known), and
//! the turn rate is `(m_r v_r - m_l v_l) / S'` with `S'` the new
//! `wheel_separation x wheel_separation_multiplier`.
//!
//! **Against the course.** The straight stretches of fixes and their pairs
//! at least [`CourseConfig::min_baseline`] rad of turning apart are those of
//! `calibrate`'s course check ([`terraslip_calib::course`]), found with the
//! recording's own odometry, so every file is judged on the same pairs. For
//! each pair the course change between the stretches' midpoints (the true
//! heading change, unwrapped nearest the recording's odometry turn) is
//! compared with the applied odometry's heading change over the same
//! interval. The **turn gain** is the least-squares gain of the latter on
//! the former through the origin: 1 when the odometry turns as the robot
//! did; its distance from 1 is the turn error. Unequal radius multipliers
//! make the odometry drift in heading along straight travel, and that drift
//! counts here as it does on the robot.
//!
//! Frames: fixes east/north (ENU, m), headings counter-clockwise (rad).

use terraslip_calib::course::{self, CourseConfig, Odometry};
use terraslip_io::{DriveLog, Meta};
use terraslip_ros2::controller_yaml::WrittenParams;

/// What the recording's controller ran with, as far as the log tells.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordedController {
    /// Effective separation the tread speeds were made with, m.
    pub separation: f64,
    /// Its `wheel_separation` (m) and `wheel_separation_multiplier`, when
    /// the log states them apart (`separation` given with a `track_width`).
    pub wheel_separation: Option<f64>,
    pub wheel_separation_multiplier: Option<f64>,
    /// Its wheel radius, m, when stated.
    pub wheel_radius: Option<f64>,
}

impl RecordedController {
    /// From a log's `meta.toml`; `None` when its tread speeds were not made
    /// from a twist with a separation.
    pub fn of(meta: &Meta) -> Option<Self> {
        let s = meta.separation.filter(|s| s.is_finite() && *s > 0.0)?;
        let given = meta
            .separation_source
            .as_deref()
            .is_none_or(|x| x == "given");
        let track = meta
            .track_width
            .filter(|w| given && w.is_finite() && *w > 0.0);
        Some(Self {
            separation: s,
            wheel_separation: track,
            wheel_separation_multiplier: track.map(|w| s / w),
            wheel_radius: meta.wheel_radius.filter(|r| *r > 0.0),
        })
    }
}

/// The controller's odometry under a parameter file: its effective
/// separation (m) and the factors on the recorded tread speeds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AppliedOdometry {
    pub separation: f64,
    pub left: f64,
    pub right: f64,
}

/// `written` applied over `recorded`; an error when the file sets one
/// factor of the separation and the log does not tell the controller's
/// other one.
pub fn apply(
    recorded: &RecordedController,
    written: &WrittenParams,
) -> Result<AppliedOdometry, String> {
    let separation = match (
        written.wheel_separation,
        written.wheel_separation_multiplier,
    ) {
        (None, None) => recorded.separation,
        (w, m) => {
            let w = w.or(recorded.wheel_separation).ok_or(
                "the file sets wheel_separation_multiplier and the recording does not state its wheel_separation",
            )?;
            let m = m.or(recorded.wheel_separation_multiplier).ok_or(
                "the file sets wheel_separation and the recording does not state its wheel_separation_multiplier",
            )?;
            w * m
        }
    };
    let radius = match (written.wheel_radius, recorded.wheel_radius) {
        (Some(new), Some(old)) => new / old,
        _ => 1.0,
    };
    let out = AppliedOdometry {
        separation,
        left: radius * written.left_wheel_radius_multiplier.unwrap_or(1.0),
        right: radius * written.right_wheel_radius_multiplier.unwrap_or(1.0),
    };
    let ok = [out.separation, out.left, out.right]
        .iter()
        .all(|v| v.is_finite() && *v > 0.0);
    ok.then_some(out)
        .ok_or_else(|| format!("not a positive separation and radius multipliers: {out:?}"))
}

/// The applied odometry's turn against the course.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurnAgainstCourse {
    /// Least-squares gain of the odometry's heading change on the course
    /// change (1: turns as the robot did).
    pub gain: f64,
    /// RMS of (odometry heading change - gain x course change), rad.
    pub rms: f64,
    pub stretches: usize,
    pub pairs: usize,
}

impl TurnAgainstCourse {
    /// The turn error, % (positive: the odometry turns more than the robot).
    pub fn error_percent(&self) -> f64 {
        100.0 * (self.gain - 1.0)
    }
}

/// The turn of `log`'s tread speeds under `applied` against its fixes'
/// course, the recording's own odometry (separation `recorded`, m) finding
/// the straight stretches and their pairs. `None` when fewer than 3 pairs
/// (or no course change) are found.
pub fn turn_against_course(
    log: &DriveLog,
    recorded: f64,
    applied: &AppliedOdometry,
) -> Option<TurnAgainstCourse> {
    let cfg = CourseConfig::default();
    let own = Odometry {
        separation: recorded,
        alpha: (1.0, 1.0),
    };
    let stretches = course::stretches(0, log, 0.0, &own, &cfg);
    let pairs = course::pairs(&[log], &[0.0], &stretches, &own, cfg.min_baseline);
    // odometry_turn weighs the treads by the factors over their mean.
    let mean = 0.5 * (applied.left + applied.right);
    let odo = Odometry {
        separation: applied.separation / mean,
        alpha: (applied.left, applied.right),
    };
    let turns: Vec<(f64, f64)> = pairs
        .iter()
        .filter_map(|p| {
            let (a, b) = (stretches[p.a].t_mid, stretches[p.b].t_mid);
            let turn = course::odometry_turn(log, a, b, &odo)?;
            Some((turn, p.course_near(p.treads)))
        })
        .collect();
    let cc: f64 = turns.iter().map(|(_, c)| c * c).sum();
    if turns.len() < 3 || cc <= 0.0 {
        return None;
    }
    let gain = turns.iter().map(|(t, c)| t * c).sum::<f64>() / cc;
    let rms = (turns
        .iter()
        .map(|(t, c)| (t - gain * c).powi(2))
        .sum::<f64>()
        / turns.len() as f64)
        .sqrt();
    Some(TurnAgainstCourse {
        gain,
        rms,
        stretches: stretches.len(),
        pairs: turns.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recorded() -> RecordedController {
        RecordedController {
            separation: 1.040625,
            wheel_separation: Some(0.555),
            wheel_separation_multiplier: Some(1.875),
            wheel_radius: None,
        }
    }

    #[test]
    fn a_file_replaces_what_it_sets_and_keeps_the_rest() {
        let none = apply(&recorded(), &WrittenParams::default()).unwrap();
        assert_eq!(
            (none.separation, none.left, none.right),
            (1.040625, 1.0, 1.0)
        );
        let w = WrittenParams {
            wheel_separation_multiplier: Some(1.8),
            left_wheel_radius_multiplier: Some(0.96),
            ..Default::default()
        };
        let a = apply(&recorded(), &w).unwrap();
        assert!((a.separation - 0.555 * 1.8).abs() < 1e-12);
        assert_eq!((a.left, a.right), (0.96, 1.0));
        // A multiplier with no stated wheel_separation cannot be applied.
        let bare = RecordedController {
            wheel_separation: None,
            wheel_separation_multiplier: None,
            ..recorded()
        };
        assert!(apply(&bare, &w).unwrap_err().contains("wheel_separation"));
    }
}
