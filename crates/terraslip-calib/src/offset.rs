//! Time offset between the wheel and pose streams.
//!
//! A lidar localiser publishes a pose some tens of milliseconds after the
//! scan it describes, and stamps may be taken on arrival. Over 1 s segments
//! with 2.5 rad/s spins, 0.1 s of latency is a 0.25 rad error that no ICR
//! parameter can explain. The offset is found without any kinematic
//! parameter: for each candidate, the reference yaw change of every segment
//! is regressed on `int (v_r - v_l) dt` and the forward displacement on
//! `int (v_r + v_l)/2 dt` (both relations are linear whatever the ICRs are,
//! for symmetric ICRs); the offset with the smallest normalised residual
//! wins (coarse-to-fine grid), refined by a parabola through its neighbours.
//!
//! Every candidate of one grid is scored on the same segments: the pose
//! pairs that give a usable segment at all of them. The mistimed-pose filter
//! and the reference gate look at the wheels, so which segments survive
//! depends on the offset; scoring each candidate on its own survivors made
//! the curve jump by whole segments and gave wrong minima (the second half
//! of the sand drive found -0.03 s where every other half finds 0.35-0.6 s).

use std::collections::HashSet;

use terraslip_io::DriveLog;

use crate::segment::{Segment, SegmentConfig, Segments};

/// Identity of a segment across offsets: its log and pose times (the wheel
/// offset moves the wheel samples, never the pose times).
type Key = (usize, u64, u64);

fn key(s: &Segment) -> Key {
    (s.log, s.t0.to_bits(), s.t1.to_bits())
}

/// The pose pairs that give a usable segment of `log` at every offset of
/// `offsets`. Each offset's segments are built and dropped in turn, so
/// only one offset's steps are in memory at a time.
pub fn common_keys(log: &DriveLog, offsets: &[f64], cfg: &SegmentConfig) -> HashSet<Key> {
    let mut common: Option<HashSet<Key>> = None;
    for &o in offsets {
        let here = Segments::build(&[log], &[o], cfg);
        common = Some(match common {
            None => here.segments.iter().map(key).collect(),
            Some(mut c) => {
                let here: HashSet<Key> = here.segments.iter().map(key).collect();
                c.retain(|k| here.contains(k));
                c
            }
        });
    }
    common.unwrap_or_default()
}

/// The segments of `log` at `offset` among `keys` ([`common_keys`]).
pub fn segments_among(
    log: &DriveLog,
    offset: f64,
    cfg: &SegmentConfig,
    keys: &HashSet<Key>,
) -> Segments {
    let mut s = Segments::build(&[log], &[offset], cfg);
    s.retain(|g| keys.contains(&key(g)));
    s
}

/// Segments of `log` at each offset of `offsets`, each restricted to the
/// pose pairs usable at every one of them, so that scores at different
/// offsets compare the same motion.
pub fn common_segments(log: &DriveLog, offsets: &[f64], cfg: &SegmentConfig) -> Vec<Segments> {
    let keys = common_keys(log, offsets, cfg);
    offsets
        .iter()
        .map(|&o| segments_among(log, o, cfg, &keys))
        .collect()
}

/// What [`regression_score`] reads of a segment: `int (v_r - v_l) dt`
/// with the reference yaw change, `int (v_r + v_l)/2 dt` with the forward
/// displacement.
type Sums = (f64, f64, f64, f64);

fn sums(s: &Segment) -> Sums {
    (s.int_diff, s.reference.dyaw, s.int_mean, s.reference.dx)
}

/// Normalised residual of the two linear regressions over `segs`, or `None`
/// with fewer than 10 segments.
pub fn regression_score(segs: &Segments) -> Option<f64> {
    regression(&segs.segments.iter().map(sums).collect::<Vec<_>>())
}

fn regression(segs: &[Sums]) -> Option<f64> {
    if segs.len() < 10 {
        return None;
    }
    let fit = |pairs: &mut dyn Iterator<Item = (f64, f64)>| {
        let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
        let v: Vec<(f64, f64)> = pairs.collect();
        for &(x, y) in &v {
            sxy += x * y;
            sxx += x * x;
            syy += y * y;
        }
        if sxx <= 0.0 || syy <= 0.0 {
            return 0.0;
        }
        let a = sxy / sxx;
        v.iter().map(|&(x, y)| (y - a * x).powi(2)).sum::<f64>() / syy
    };
    let yaw = fit(&mut segs.iter().map(|s| (s.0, s.1)));
    let fwd = fit(&mut segs.iter().map(|s| (s.2, s.3)));
    Some(yaw + fwd)
}

/// [`regression_score`] of the segments usable at `offset` alone.
pub fn alignment_score(log: &DriveLog, offset: f64, cfg: &SegmentConfig) -> Option<f64> {
    regression_score(&Segments::build(&[log], &[offset], cfg))
}

/// Most pose rows the offset search reads of one log.
pub const OFFSET_POSES: usize = 6000;

/// Pose rows in each window of a thinned log ([`thinned`]).
const WINDOW_POSES: usize = 200;

/// `log` as the offset search reads it: a log of more than `max_poses`
/// pose rows is cut to evenly spread windows of [`WINDOW_POSES`]
/// consecutive rows (at most `max_poses` rows in all) with the wheel rows
/// around them, so that a long drive's dozens of candidate builds stay
/// cheap; a shorter log is used whole. Segments across the cut between two
/// windows are too long and are not used.
pub fn thinned(log: &DriveLog, max_poses: usize) -> std::borrow::Cow<'_, DriveLog> {
    let n = log.pose.len();
    if n <= max_poses.max(WINDOW_POSES) {
        return std::borrow::Cow::Borrowed(log);
    }
    let windows = (max_poses / WINDOW_POSES).max(1);
    // Window k starts at pose k (n - W) / (windows - 1): the first at the
    // start, the last at the end.
    let span = windows.saturating_sub(1).max(1);
    let mut out = DriveLog {
        dir: log.dir.clone(),
        terrain: log.terrain.clone(),
        meta: log.meta.clone(),
        ..Default::default()
    };
    // Room for the largest offset and the acceleration's half window.
    const MARGIN: f64 = 2.0;
    for k in 0..windows {
        let first = (k * (n - WINDOW_POSES) / span).min(n - WINDOW_POSES);
        let poses = &log.pose[first..first + WINDOW_POSES];
        let (t0, t1) = (poses[0].t - MARGIN, poses[WINDOW_POSES - 1].t + MARGIN);
        let from = log.wheels.partition_point(|w| w.t < t0);
        let to = log.wheels.partition_point(|w| w.t <= t1);
        // Windows never overlap: each starts after the last one kept.
        let last_pose = out.pose.last().map_or(f64::NEG_INFINITY, |p| p.t);
        let last_wheel = out.wheels.last().map_or(f64::NEG_INFINITY, |w| w.t);
        out.pose
            .extend(poses.iter().filter(|p| p.t > last_pose).cloned());
        out.wheels.extend(
            log.wheels[from..to.max(from)]
                .iter()
                .filter(|w| w.t > last_wheel)
                .copied(),
        );
    }
    std::borrow::Cow::Owned(out)
}

/// Minimum of sampled `(t, score)` points, refined by a parabola through the
/// best point and its neighbours when they are `step` apart.
pub fn parabolic_minimum(curve: &[(f64, f64)], step: f64) -> Option<f64> {
    let best = (0..curve.len())
        .filter(|&i| curve[i].1.is_finite())
        .min_by(|&a, &b| curve[a].1.total_cmp(&curve[b].1))?;
    let mut t = curve[best].0;
    if best > 0 && best + 1 < curve.len() {
        let (a, b, c) = (curve[best - 1].1, curve[best].1, curve[best + 1].1);
        let den = a - 2.0 * b + c;
        let spaced = (curve[best + 1].0 - curve[best - 1].0 - 2.0 * step).abs() < 1e-9;
        if den > 0.0 && spaced {
            t += (0.5 * step * (a - c) / den).clamp(-step, step);
        }
    }
    Some(t)
}

/// [`regression_score`] at every offset of `grid`, all on the same
/// segments (as [`common_segments`]); `(t, score)` for the offsets where
/// it is defined. Of each offset's segments only their keys and sums are
/// kept, not their steps, so memory holds one offset's steps at a time.
pub fn scan(log: &DriveLog, grid: &[f64], cfg: &SegmentConfig) -> Vec<(f64, f64)> {
    let all: Vec<Vec<(Key, Sums)>> = grid
        .iter()
        .map(|&o| {
            let segs = Segments::build(&[log], &[o], cfg);
            segs.segments.iter().map(|s| (key(s), sums(s))).collect()
        })
        .collect();
    let Some(first) = all.first() else {
        return Vec::new();
    };
    let mut common: HashSet<Key> = first.iter().map(|s| s.0).collect();
    for s in &all[1..] {
        let here: HashSet<Key> = s.iter().map(|s| s.0).collect();
        common.retain(|k| here.contains(k));
    }
    all.iter()
        .zip(grid)
        .filter_map(|(s, &t)| {
            let kept: Vec<Sums> = s
                .iter()
                .filter(|s| common.contains(&s.0))
                .map(|s| s.1)
                .collect();
            regression(&kept).map(|v| (t, v))
        })
        .collect()
}

/// Offset (s) in `[-max_offset, max_offset]` that best aligns the streams:
/// a coarse grid of 5 `step`s, then a `step` grid around its best point,
/// refined by a parabola; with the scores evaluated, for reporting. Each
/// grid scores all its candidates on the same segments ([`common_segments`]).
pub fn estimate_offset(
    log: &DriveLog,
    cfg: &SegmentConfig,
    max_offset: f64,
    step: f64,
) -> Option<(f64, Vec<(f64, f64)>)> {
    let step = step.max(1e-3);
    let coarse = 5.0 * step;
    let n = (max_offset / coarse).round() as i64;
    let grid: Vec<f64> = (-n..=n).map(|k| k as f64 * coarse).collect();
    let mut curve = scan(log, &grid, cfg);
    let centre = curve.iter().min_by(|a, b| a.1.total_cmp(&b.1))?.0;
    let grid: Vec<f64> = (-5..=5)
        .map(|k| centre + k as f64 * step)
        .filter(|t| t.abs() <= max_offset + 1e-9)
        .collect();
    let fine = scan(log, &grid, cfg);
    let off = parabolic_minimum(&fine, step)?;
    curve.extend(fine);
    curve.sort_by(|a, b| a.0.total_cmp(&b.0));
    Some((off, curve))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_log_is_thinned_to_spread_windows_and_a_short_one_kept() {
        use terraslip_io::{PoseObs, WheelSample};
        let mut log = DriveLog::default();
        for k in 0..200_000 {
            let t = k as f64 * 0.05;
            log.wheels.push(WheelSample {
                t,
                v_left: 1.0,
                v_right: 1.0,
            });
            if k % 4 == 0 {
                log.pose.push(PoseObs {
                    t,
                    east: Some(t),
                    north: Some(0.0),
                    yaw: Some(0.0),
                    ..Default::default()
                });
            }
        }
        assert!(matches!(
            thinned(&log, 50_000),
            std::borrow::Cow::Borrowed(_)
        ));
        let thin = thinned(&log, 2000);
        assert_eq!(thin.pose.len(), 2000);
        // Ten windows of 200 rows, the first at the start and the last at
        // the end, evenly apart; each with its wheels and no more.
        let starts: Vec<f64> = thin.pose.chunks(200).map(|w| w[0].t).collect();
        assert_eq!(starts.len(), 10);
        assert_eq!(starts[0], 0.0);
        assert_eq!(thin.pose.last().map(|p| p.t), log.pose.last().map(|p| p.t));
        let gaps: Vec<f64> = starts.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(gaps.iter().all(|g| (g - gaps[0]).abs() <= 0.21), "{gaps:?}");
        assert!(thin.wheels.windows(2).all(|w| w[0].t < w[1].t));
        assert!(thin.wheels.len() < 10 * (200 * 4 + 100));
        // Each window's poses lie within its wheels.
        for w in thin.pose.chunks(200) {
            let inside = thin
                .wheels
                .iter()
                .filter(|s| s.t >= w[0].t && s.t <= w[199].t)
                .count();
            assert_eq!(inside, 199 * 4 + 1);
        }
    }

    #[test]
    fn parabola_finds_the_vertex_between_grid_points() {
        let curve: Vec<(f64, f64)> = (0..7)
            .map(|k| {
                let t = 0.1 * k as f64;
                (t, (t - 0.33).powi(2))
            })
            .collect();
        let t = parabolic_minimum(&curve, 0.1).expect("minimum");
        assert!((t - 0.33).abs() < 1e-9, "{t}");
        // At the edge of the grid there is no parabola: the grid point.
        let edge: Vec<(f64, f64)> = curve.iter().map(|&(t, _)| (t, -t)).collect();
        assert_eq!(parabolic_minimum(&edge, 0.1), Some(0.6000000000000001));
        assert_eq!(parabolic_minimum(&[], 0.1), None);
    }
}
