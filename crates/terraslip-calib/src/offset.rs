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
fn key(s: &Segment) -> (usize, u64, u64) {
    (s.log, s.t0.to_bits(), s.t1.to_bits())
}

/// Segments of `log` at each offset of `offsets`, each restricted to the
/// pose pairs usable at every one of them, so that scores at different
/// offsets compare the same motion.
pub fn common_segments(log: &DriveLog, offsets: &[f64], cfg: &SegmentConfig) -> Vec<Segments> {
    let mut all: Vec<Segments> = offsets
        .iter()
        .map(|&o| Segments::build(&[log], &[o], cfg))
        .collect();
    let Some(first) = all.first() else {
        return all;
    };
    let mut common: HashSet<(usize, u64, u64)> = first.segments.iter().map(key).collect();
    for s in &all[1..] {
        let here: HashSet<_> = s.segments.iter().map(key).collect();
        common.retain(|k| here.contains(k));
    }
    for s in &mut all {
        s.retain(|g| common.contains(&key(g)));
    }
    all
}

/// Normalised residual of the two linear regressions over `segs`, or `None`
/// with fewer than 10 segments.
pub fn regression_score(segs: &Segments) -> Option<f64> {
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
    let yaw = fit(&mut segs.segments.iter().map(|s| (s.int_diff, s.reference.dyaw)));
    let fwd = fit(&mut segs.segments.iter().map(|s| (s.int_mean, s.reference.dx)));
    Some(yaw + fwd)
}

/// [`regression_score`] of the segments usable at `offset` alone.
pub fn alignment_score(log: &DriveLog, offset: f64, cfg: &SegmentConfig) -> Option<f64> {
    regression_score(&Segments::build(&[log], &[offset], cfg))
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

/// Scores `score` at every offset of `grid` over [`common_segments`];
/// `(t, score)` for the offsets where it is defined.
pub fn scan(
    log: &DriveLog,
    grid: &[f64],
    cfg: &SegmentConfig,
    score: &dyn Fn(&Segments) -> Option<f64>,
) -> Vec<(f64, f64)> {
    common_segments(log, grid, cfg)
        .iter()
        .zip(grid)
        .filter_map(|(s, &t)| score(s).map(|v| (t, v)))
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
    let mut curve = scan(log, &grid, cfg, &regression_score);
    let centre = curve.iter().min_by(|a, b| a.1.total_cmp(&b.1))?.0;
    let grid: Vec<f64> = (-5..=5)
        .map(|k| centre + k as f64 * step)
        .filter(|t| t.abs() <= max_offset + 1e-9)
        .collect();
    let fine = scan(log, &grid, cfg, &regression_score);
    let off = parabolic_minimum(&fine, step)?;
    curve.extend(fine);
    curve.sort_by(|a, b| a.0.total_cmp(&b.0));
    Some((off, curve))
}

#[cfg(test)]
mod tests {
    use super::*;

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
