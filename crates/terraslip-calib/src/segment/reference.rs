//! Reference poses from what ROS 2 bags carry: a GNSS position and an IMU
//! heading on rows of their own.
//!
//! Segments need a position and a heading at both ends. Positions without
//! a heading take the heading rows' (interpolated, when one lies within
//! [`HEADING_GAP_S`] on each side). A position-only reference (no heading
//! anywhere) is not completed here: it is fitted on windows of fixes
//! ([`crate::track`]).

use terraslip_io::PoseObs;

/// Longest distance in time to a heading row a position row takes its
/// heading from, s.
pub const HEADING_GAP_S: f64 = 0.5;

fn heading_at(h: &[(f64, f64)], t: f64) -> Option<f64> {
    let i = h.partition_point(|p| p.0 < t);
    if let Some(p) = h.get(i).filter(|p| p.0 == t) {
        return Some(p.1);
    }
    let (a, b) = (h.get(i.checked_sub(1)?)?, h.get(i)?);
    if t - a.0 > HEADING_GAP_S || b.0 - t > HEADING_GAP_S {
        return None;
    }
    let d = terraslip_core::angle::wrap(b.1 - a.1);
    Some(terraslip_core::angle::wrap(
        a.1 + (t - a.0) / (b.0 - a.0) * d,
    ))
}

/// The pose rows with a position, each with its own heading or the
/// heading rows' beside it (rows that get none are left out); `None` when
/// no row ends up with both.
pub fn complete(pose: &[PoseObs]) -> Option<Vec<PoseObs>> {
    let mut headings: Vec<(f64, f64)> = pose
        .iter()
        .filter(|p| p.east.is_none() || p.north.is_none())
        .filter_map(|p| Some((p.t, p.yaw.filter(|y| y.is_finite())?)))
        .collect();
    headings.sort_by(|a, b| a.0.total_cmp(&b.0));
    let rows: Vec<PoseObs> = pose
        .iter()
        .filter(|p| p.east.is_some() && p.north.is_some())
        .filter_map(|p| {
            let yaw = p.yaw.or_else(|| heading_at(&headings, p.t))?;
            Some(PoseObs {
                yaw: Some(yaw),
                ..*p
            })
        })
        .collect();
    (!rows.is_empty()).then_some(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t: f64, en: Option<(f64, f64)>, yaw: Option<f64>) -> PoseObs {
        PoseObs {
            t,
            east: en.map(|p| p.0),
            north: en.map(|p| p.1),
            yaw,
            std_xy: None,
            std_yaw: None,
        }
    }

    #[test]
    fn positions_take_the_heading_rows_beside_them() {
        let pose = vec![
            row(0.0, Some((0.0, 0.0)), None),
            row(0.01, None, Some(0.2)),
            row(0.5, None, Some(0.4)),
            row(0.3, Some((1.0, 0.0)), None),
            row(5.0, Some((2.0, 0.0)), None),
        ];
        let mut pose = pose;
        pose.sort_by(|a, b| a.t.total_cmp(&b.t));
        let rows = complete(&pose).unwrap();
        // 0.0 lies before the first heading; 5.0 is 4.5 s from the last.
        assert_eq!(rows.len(), 1);
        assert!((rows[0].yaw.unwrap() - (0.2 + 0.29 / 0.49 * 0.2)).abs() < 1e-12);
    }
}
