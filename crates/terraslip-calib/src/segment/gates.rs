//! Which poses and segments to trust, decided without any calibrated
//! parameter so every model is scored on the same data: repeated poses,
//! late-stamped poses, and references the treads cannot have produced.

use terraslip_io::{PoseObs, WheelSample};

use super::{Segment, SegmentConfig, SegmentStats, Step};

/// Poses with east, north and yaw present, with exact repeats of the
/// previous pose removed: a lidar localiser republishing its last solution
/// between updates says nothing new, and the repeat's timestamp is not
/// when that pose was true.
pub fn clean_poses(pose: &[PoseObs], stats: &mut SegmentStats) -> Vec<(f64, f64, f64, f64)> {
    let mut out: Vec<(f64, f64, f64, f64)> = Vec::with_capacity(pose.len());
    for p in pose {
        let (Some(e), Some(n), Some(y)) = (p.east, p.north, p.yaw) else {
            stats.incomplete_poses += 1;
            continue;
        };
        if let Some(&(_, pe, pn, py)) = out.last() {
            if pe == e && pn == n && py == y {
                stats.stale_poses += 1;
                continue;
            }
        }
        out.push((p.t, e, n, y));
    }
    out
}

/// Removes poses whose timestamp does not match when they were true: a
/// localiser that stalls and catches up stamps an old pose late. Over
/// consecutive poses `a, b, c` with the treads driving at least 0.1 m
/// forward or back in each interval, the ratio of pose distance to tread
/// travel is compared on `a->b`, `b->c` and `a->c`; if one half is under
/// half the overall ratio and the other over 1.5 times it, `b` is suspect,
/// and dropped if it is more lopsided than its suspect neighbours.
/// The ratios are relative to the local one, so whatever the slip of the
/// terrain (alpha), no calibrated parameter enters.
pub fn drop_mistimed(
    poses: &[(f64, f64, f64, f64)],
    w: &[WheelSample],
    time_offset: f64,
) -> Vec<(f64, f64, f64, f64)> {
    if poses.len() < 3 || w.len() < 2 {
        return poses.to_vec();
    }
    // Cumulative signed forward tread travel at each wheel sample.
    let mut cum = Vec::with_capacity(w.len());
    let mut d = 0.0;
    cum.push(0.0);
    for p in w.windows(2) {
        d += 0.25 * (p[0].v_left + p[0].v_right + p[1].v_left + p[1].v_right) * (p[1].t - p[0].t);
        cum.push(d);
    }
    let travel_at = |t: f64| {
        let t = t - time_offset;
        let i = w.partition_point(|s| s.t <= t);
        if i == 0 {
            return cum[0];
        }
        if i >= w.len() {
            return cum[w.len() - 1];
        }
        let (a, b) = (&w[i - 1], &w[i]);
        let s = if b.t > a.t {
            (t - a.t) / (b.t - a.t)
        } else {
            0.0
        };
        cum[i - 1] + s * (cum[i] - cum[i - 1])
    };
    // Score of each inner pose: how lopsided the two ratios are, when they
    // are lopsided enough to call it mistimed (0 otherwise).
    let dist = |p: (f64, f64, f64, f64), q: (f64, f64, f64, f64)| (q.1 - p.1).hypot(q.2 - p.2);
    let mut score = vec![0.0f64; poses.len()];
    for i in 1..poses.len() - 1 {
        let (a, b, c) = (poses[i - 1], poses[i], poses[i + 1]);
        let (wa, wc) = (
            (travel_at(b.0) - travel_at(a.0)).abs(),
            (travel_at(c.0) - travel_at(b.0)).abs(),
        );
        if wa < 0.1 || wc < 0.1 {
            continue;
        }
        let r = dist(a, c) / (wa + wc);
        let (r1, r2) = (dist(a, b) / wa, dist(b, c) / wc);
        if (r1 < 0.5 * r && r2 > 1.5 * r) || (r1 > 1.5 * r && r2 < 0.5 * r) {
            score[i] = r1.max(r2) / r1.min(r2).max(1e-9);
        }
    }
    // A late pose also makes its neighbours look lopsided, less so: drop
    // only the most lopsided of adjacent suspects.
    poses
        .iter()
        .enumerate()
        .filter(|&(i, _)| {
            let s = score[i];
            let prev = if i > 0 { score[i - 1] } else { 0.0 };
            let next = score.get(i + 1).copied().unwrap_or(0.0);
            !(s > 0.0 && s >= prev && s >= next)
        })
        .map(|(_, p)| *p)
        .collect()
}

/// Whether a segment's reference increment is a motion its treads can have
/// produced, with margins wide enough for any terrain (ice included) and
/// without any calibrated parameter, so it treats every model alike:
///
/// * it moves at most 1.4x as far as the faster tread went, + 0.3 m;
/// * when the treads drive more than 0.5 m forward or back, it moves at
///   least 30 % of that, and not in the opposite direction (a stalled
///   localiser repeats an old pose with fresh noise);
/// * it turns at most 1.5x the no-slip yaw (skid steering only turns less), + 0.3 rad.
pub fn plausible(seg: &Segment, steps: &[Step], cfg: &SegmentConfig) -> bool {
    let r = seg.reference;
    let moved = r.dx.hypot(r.dy);
    let fast: f64 = steps
        .iter()
        .map(|s| s.v_left.abs().max(s.v_right.abs()) * s.dt)
        .sum();
    if moved > 1.4 * fast + 0.3 {
        return false;
    }
    let fwd = seg.int_mean;
    if fwd.abs() > 0.5 && (moved < 0.3 * fwd.abs() || r.dx * fwd < -0.09) {
        return false;
    }
    let w = cfg.gate_track_width.unwrap_or(1.0);
    let yaw_free = steps
        .iter()
        .map(|s| (s.v_right - s.v_left).abs() * s.dt)
        .sum::<f64>()
        / w;
    r.dyaw.abs() <= 1.5 * yaw_free + 0.3
}
