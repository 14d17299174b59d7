//! Where the pose reference sits on the robot: fixes of a point off the
//! wheel axle (a GNSS antenna, a tag; meta.toml's `[pose]`) are moved onto
//! the axle's centre before a fit, so that the fit's `x_c` (and ICR
//! centre) do not take the mount's offset as slip. Each fix is turned
//! with its own heading, or the nearest heading within
//! [`MAX_HEADING_GAP`] s.
//!
//! Frames: the lever arm in the body frame (REP-103: x forward, y left),
//! m; fixes ENU, m; headings counter-clockwise from east, rad.

use terraslip_io::DriveLog;

/// Largest time between a position fix and the heading it is turned
/// with, s.
pub const MAX_HEADING_GAP: f64 = 0.5;

/// Moves `log`'s position fixes from the pose reference's point to the
/// axle's centre: `p = z - R(yaw) l`. Returns a warning when some fixes
/// have no heading near enough (they are left as they are); nothing when
/// the log states no lever arm.
pub fn move_fixes_to_axle(log: &mut DriveLog) -> Option<String> {
    let m = log.meta.pose?;
    let (lx, ly) = (m.lever_arm_x, m.lever_arm_y);
    if lx == 0.0 && ly == 0.0 {
        return None;
    }
    let headings: Vec<(f64, f64)> = log
        .pose
        .iter()
        .filter_map(|p| p.yaw.map(|y| (p.t, y)))
        .collect();
    let nearest = |t: f64| {
        let k = headings.partition_point(|h| h.0 < t);
        [k.checked_sub(1), Some(k)]
            .into_iter()
            .flatten()
            .filter_map(|i| headings.get(i))
            .filter(|h| (h.0 - t).abs() <= MAX_HEADING_GAP)
            .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
            .map(|h| h.1)
    };
    let mut unmoved = 0usize;
    for p in &mut log.pose {
        let (Some(e), Some(n)) = (p.east, p.north) else {
            continue;
        };
        let Some(yaw) = p.yaw.or_else(|| nearest(p.t)) else {
            unmoved += 1;
            continue;
        };
        let (s, c) = yaw.sin_cos();
        p.east = Some(e - (c * lx - s * ly));
        p.north = Some(n - (s * lx + c * ly));
    }
    (unmoved > 0).then(|| {
        format!(
            "{}: {unmoved} position fix(es) have no heading within {MAX_HEADING_GAP} s to place meta.toml's [pose] lever arm ({lx}, {ly}) m with; they are taken as the axle centre's",
            log.dir.display()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use terraslip_io::{PoseMount, PoseObs};

    fn fix(t: f64, yaw: Option<f64>) -> PoseObs {
        PoseObs {
            t,
            east: Some(10.0),
            north: Some(5.0),
            yaw,
            std_xy: None,
            std_yaw: None,
        }
    }

    #[test]
    fn fixes_of_an_antenna_ahead_of_the_axle_move_behind_it() {
        let mut log = DriveLog::default();
        log.meta.pose = Some(PoseMount {
            lever_arm_x: 0.3,
            lever_arm_y: 0.0,
        });
        let north = std::f64::consts::FRAC_PI_2;
        log.pose = vec![
            fix(0.0, Some(0.0)),
            fix(0.2, None),
            fix(1.0, Some(north)),
            fix(5.0, None),
        ];
        let w = move_fixes_to_axle(&mut log).expect("one fix without a heading");
        assert!(w.contains("1 position fix"), "{w}");
        let at = |i: usize| (log.pose[i].east.unwrap(), log.pose[i].north.unwrap());
        let close = |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() + (a.1 - b.1).abs() < 1e-12;
        // Facing east, the axle is 0.3 m west of the antenna.
        assert!(close(at(0), (9.7, 5.0)), "{:?}", at(0));
        // The nearest heading, 0.2 s before.
        assert!(close(at(1), (9.7, 5.0)), "{:?}", at(1));
        // Facing north, 0.3 m south.
        assert!(close(at(2), (10.0, 4.7)), "{:?}", at(2));
        // No heading near: left.
        assert_eq!(at(3), (10.0, 5.0));
        // A log stating none is left alone.
        let mut plain = DriveLog {
            pose: vec![fix(0.0, Some(0.0))],
            ..Default::default()
        };
        assert_eq!(move_fixes_to_axle(&mut plain), None);
        assert_eq!(plain.pose[0].east, Some(10.0));
    }
}
