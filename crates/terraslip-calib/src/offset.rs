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

use terraslip_io::DriveLog;

use crate::segment::{SegmentConfig, Segments};

/// Normalised residual of the two linear regressions at one offset, or
/// `None` with fewer than 10 moving segments.
pub fn alignment_score(log: &DriveLog, offset: f64, cfg: &SegmentConfig) -> Option<f64> {
    let segs = Segments::build(&[log], &[offset], cfg);
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

/// Offset (s) in `[-max_offset, max_offset]` that best aligns the streams:
/// a coarse grid of 5 `step`s, then a `step` grid around its best point,
/// refined by a parabola; with the scores evaluated, for reporting.
pub fn estimate_offset(
    log: &DriveLog,
    cfg: &SegmentConfig,
    max_offset: f64,
    step: f64,
) -> Option<(f64, Vec<(f64, f64)>)> {
    let step = step.max(1e-3);
    let coarse = 5.0 * step;
    let n = (max_offset / coarse).round() as i64;
    let mut curve: Vec<(f64, f64)> = (-n..=n)
        .filter_map(|k| {
            let t = k as f64 * coarse;
            alignment_score(log, t, cfg).map(|s| (t, s))
        })
        .collect();
    let centre = curve.iter().min_by(|a, b| a.1.total_cmp(&b.1))?.0;
    let fine: Vec<(f64, f64)> = (-5..=5)
        .map(|k| centre + k as f64 * step)
        .filter(|t| t.abs() <= max_offset + 1e-9)
        .filter_map(|t| alignment_score(log, t, cfg).map(|s| (t, s)))
        .collect();
    let best = (0..fine.len()).min_by(|&a, &b| fine[a].1.total_cmp(&fine[b].1))?;
    let mut off = fine[best].0;
    if best > 0 && best + 1 < fine.len() {
        let (a, b, c) = (fine[best - 1].1, fine[best].1, fine[best + 1].1);
        let den = a - 2.0 * b + c;
        if den > 0.0 {
            off += 0.5 * step * (a - c) / den;
        }
    }
    curve.extend(fine);
    curve.sort_by(|a, b| a.0.total_cmp(&b.0));
    Some((off, curve))
}
