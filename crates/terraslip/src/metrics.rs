//! Scores of an [`EstimateRun`] against a log's ground truth (`truth.csv`)
//! and terrain labels (`terrain.csv`). Definitions in `docs/estimator.md`.

use serde::Serialize;
use terraslip_core::angle;
use terraslip_io::{TerrainLabel, TruthSample};

use crate::pipeline::EstimateRun;

/// Truth interpolated linearly at time `t` (yaw by its wrapped difference);
/// `None` outside the truth's time span or with no truth.
pub fn truth_at(truth: &[TruthSample], t: f64) -> Option<TruthSample> {
    let first = truth.first()?;
    let last = truth.last()?;
    if t < first.t || t > last.t {
        return None;
    }
    let i = truth.partition_point(|s| s.t <= t);
    if i == 0 {
        return Some(*first);
    }
    if i >= truth.len() {
        return Some(*last);
    }
    let (a, b) = (&truth[i - 1], &truth[i]);
    let span = b.t - a.t;
    let f = if span > 0.0 { (t - a.t) / span } else { 0.0 };
    let lerp = |x: f64, y: f64| x + f * (y - x);
    Some(TruthSample {
        t,
        east: lerp(a.east, b.east),
        north: lerp(a.north, b.north),
        yaw: angle::wrap(a.yaw + f * angle::wrap(b.yaw - a.yaw)),
        y_l: lerp(a.y_l, b.y_l),
        y_r: lerp(a.y_r, b.y_r),
        x_c: lerp(a.x_c, b.x_c),
    })
}

/// Re-convergence after one terrain change.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Reconvergence {
    /// Time of the change (from the labels), s.
    pub t_change: f64,
    /// Terrain entered.
    pub terrain: String,
    /// The terrain was visited before in this drive.
    pub revisit: bool,
    /// Seconds until the spread error is within tolerance for good; `None`
    /// if it never settles before the next change.
    pub seconds: Option<f64>,
    /// Seconds until the next change (the most `seconds` can be).
    pub segment: f64,
    /// Seconds after the change at which the true heading had turned by
    /// [`ReconvergenceSpec::turn_angle`] in all (the first informative
    /// turn: on a straight `d` has no effect on any measurement); `None` if
    /// it never did before the next change.
    pub first_turn: Option<f64>,
    /// `seconds` counted from the first informative turn (0 if it settled
    /// before the turn); `None` if it never settled or never turned.
    pub from_turn: Option<f64>,
}

/// Settings of [`reconvergence`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReconvergenceSpec {
    /// Tolerance on the averaged spread error, m (the target: 0.02).
    pub tolerance: f64,
    /// Averaging window, s (the target's: 5).
    pub window: f64,
    /// Total heading change (rad) that makes the first informative turn.
    pub turn_angle: f64,
    /// Seconds after the change before turning is counted (the simulated
    /// ICRs blend over the border until then).
    pub turn_delay: f64,
}

impl Default for ReconvergenceSpec {
    fn default() -> Self {
        Self {
            tolerance: 0.02,
            window: 5.0,
            turn_angle: 0.3,
            turn_delay: 2.0,
        }
    }
}

/// Seconds after `t0` at which the truth's heading has turned by `angle`
/// (rad, sum of absolute changes) counted from `t0 + delay`, before `t1`.
pub fn first_turn(truth: &[TruthSample], t0: f64, t1: f64, angle: f64, delay: f64) -> Option<f64> {
    let start = truth.partition_point(|s| s.t < t0 + delay);
    let mut turned = 0.0;
    for w in truth[start..].windows(2).take_while(|w| w[1].t < t1) {
        turned += angle::wrap(w[1].yaw - w[0].yaw).abs();
        if turned >= angle {
            return Some(w[1].t - t0);
        }
    }
    None
}

/// Spread errors `d_est - d_true` at the run's rows within `[t0, t1)`.
fn spread_errors(run: &EstimateRun, truth: &[TruthSample], t0: f64, t1: f64) -> Vec<(f64, f64)> {
    let start = run.rows.partition_point(|r| r.t < t0);
    run.rows[start..]
        .iter()
        .take_while(|r| r.t < t1)
        .filter_map(|r| truth_at(truth, r.t).map(|s| (r.t, (r.y_l - r.y_r) - (s.y_l - s.y_r))))
        .collect()
}

/// The run's largest spread error `d_est - d_true` (m) within `[t0, t1)`
/// and its time, s: what a 5 s mean of [`reconvergence`] can hide.
pub fn largest_spread_error(
    run: &EstimateRun,
    truth: &[TruthSample],
    t0: f64,
    t1: f64,
) -> Option<(f64, f64)> {
    spread_errors(run, truth, t0, t1)
        .into_iter()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
}

/// For every terrain change in `labels` (not the first label): the time
/// after the change from which every `window`-second average of the spread
/// error `d = y_l - y_r` (estimate minus truth), up to the next change, is
/// within `tolerance`. Zero when it never leaves the tolerance.
pub fn reconvergence(
    run: &EstimateRun,
    truth: &[TruthSample],
    labels: &[TerrainLabel],
    spec: ReconvergenceSpec,
) -> Vec<Reconvergence> {
    let end = run.rows.last().map_or(0.0, |r| r.t);
    let mut out = Vec::new();
    for (k, lab) in labels.iter().enumerate().skip(1) {
        if lab.terrain == labels[k - 1].terrain {
            continue;
        }
        let t_next = labels[k + 1..]
            .iter()
            .find(|l| l.terrain != lab.terrain)
            .map_or(end, |l| l.t);
        let revisit = labels[..k].iter().any(|l| l.terrain == lab.terrain);
        let errs = spread_errors(run, truth, lab.t, t_next);
        let seconds = settle_time(&errs, lab.t, spec);
        let turn = first_turn(truth, lab.t, t_next, spec.turn_angle, spec.turn_delay);
        out.push(Reconvergence {
            t_change: lab.t,
            terrain: lab.terrain.clone(),
            revisit,
            seconds,
            segment: t_next - lab.t,
            first_turn: turn,
            from_turn: seconds.zip(turn).map(|(s, t)| (s - t).max(0.0)),
        });
    }
    out
}

/// Earliest time (relative to `t0`) from which all trailing-window means of
/// the errors stay within tolerance. Windows are anchored at each sample.
fn settle_time(errs: &[(f64, f64)], t0: f64, spec: ReconvergenceSpec) -> Option<f64> {
    if errs.is_empty() {
        return None;
    }
    // Prefix sums for O(n) window means.
    let mut pre = Vec::with_capacity(errs.len() + 1);
    pre.push(0.0);
    for (_, e) in errs {
        pre.push(pre.last().copied().unwrap_or(0.0) + e);
    }
    let t_last = errs[errs.len() - 1].0;
    let mut settled_from: Option<f64> = None;
    let mut j = 0usize;
    // Window [t_i, t_i + window) for every start with a full window.
    let mut bad_after: Option<f64> = None;
    for i in 0..errs.len() {
        let ti = errs[i].0;
        if ti + spec.window > t_last + 1e-9 {
            break;
        }
        while j < errs.len() && errs[j].0 < ti + spec.window {
            j += 1;
        }
        let n = (j - i) as f64;
        let mean = (pre[j] - pre[i]) / n;
        if mean.abs() > spec.tolerance {
            bad_after = Some(ti);
        }
    }
    if errs[0].0 + spec.window > t_last + 1e-9 {
        // Segment shorter than a window: judge the plain mean.
        let mean = pre[errs.len()] / errs.len() as f64;
        return (mean.abs() <= spec.tolerance).then_some(0.0);
    }
    match bad_after {
        None => settled_from = Some(t0),
        Some(tb) => {
            // Settled from the first window start after the last bad one.
            if let Some(k) = errs.iter().position(|(t, _)| *t > tb) {
                if errs[k].0 + spec.window <= t_last + 1e-9 {
                    settled_from = Some(errs[k].0);
                }
            }
        }
    }
    settled_from.map(|t| (t - t0).max(0.0))
}

/// Root-mean-square ICR errors, m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IcrRms {
    /// Spread `y_l - y_r`.
    pub d: f64,
    pub y_l: f64,
    pub y_r: f64,
    pub x_c: f64,
    /// Number of rows scored.
    pub samples: usize,
}

/// RMS errors of the ICRs over the rows that are at least `settle` seconds
/// after the start and after every terrain change in `labels`.
pub fn steady_state_rms(
    run: &EstimateRun,
    truth: &[TruthSample],
    labels: &[TerrainLabel],
    settle: f64,
) -> IcrRms {
    let t_start = run.rows.first().map_or(0.0, |r| r.t);
    let mut changes: Vec<f64> = vec![t_start];
    for (k, l) in labels.iter().enumerate().skip(1) {
        if l.terrain != labels[k - 1].terrain {
            changes.push(l.t);
        }
    }
    let mut sums = [0.0f64; 4];
    let mut n = 0usize;
    for r in &run.rows {
        let last_change = changes
            .iter()
            .rev()
            .find(|&&c| c <= r.t)
            .copied()
            .unwrap_or(t_start);
        if r.t - last_change < settle {
            continue;
        }
        let Some(s) = truth_at(truth, r.t) else {
            continue;
        };
        let e = [
            (r.y_l - r.y_r) - (s.y_l - s.y_r),
            r.y_l - s.y_l,
            r.y_r - s.y_r,
            r.x_c - s.x_c,
        ];
        for (acc, v) in sums.iter_mut().zip(e) {
            *acc += v * v;
        }
        n += 1;
    }
    let rms = |s: f64| {
        if n > 0 {
            (s / n as f64).sqrt()
        } else {
            f64::NAN
        }
    };
    IcrRms {
        d: rms(sums[0]),
        y_l: rms(sums[1]),
        y_r: rms(sums[2]),
        x_c: rms(sums[3]),
        samples: n,
    }
}

/// Dead-reckoning drift over an outage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Drift {
    /// Outage start and end, s.
    pub t0: f64,
    pub t1: f64,
    /// Path length driven (truth), m.
    pub distance: f64,
    /// End-point error of the motion over the outage, m.
    pub error: f64,
    /// `100 * error / distance`.
    pub percent: f64,
    /// The error split along the true displacement over the outage (m;
    /// positive = the estimate went too far: mostly the common speed
    /// factor) and across it (m, positive to its left: mostly the heading
    /// rate, i.e. the spread and the factor difference). `along^2 +
    /// cross^2 = error^2`.
    pub along: f64,
    pub cross: f64,
    /// Estimated minus true heading change over the outage, rad.
    pub yaw_error: f64,
}

/// Drift of the estimate's own motion over `[t0, t1]` (a window in which
/// the run had no pose fixes): the displacement from `t0` to `t1` expressed
/// in the body frame at `t0`, estimate against truth. Expressing it in the
/// body frame at the start leaves out the absolute position and heading
/// error at `t0` (GNSS noise), so what remains is what dead reckoning on the
/// estimated ICRs adds. `None` without truth over the window or motion.
pub fn outage_drift(run: &EstimateRun, truth: &[TruthSample], t0: f64, t1: f64) -> Option<Drift> {
    // Start after the last fix (the row at t0 has fused it), end before the
    // first fix after the outage: the row at t1 has already been pulled
    // towards that fix, which measures the GNSS error there, not the drift.
    let a = run.rows.get(run.rows.partition_point(|r| r.t < t0))?;
    let b = run
        .rows
        .get(run.rows.partition_point(|r| r.t < t1).checked_sub(1)?)?;
    if b.t <= a.t {
        return None;
    }
    let (ta, tb) = (truth_at(truth, a.t)?, truth_at(truth, b.t)?);
    let local = |de: f64, dn: f64, yaw: f64| {
        let (s, c) = yaw.sin_cos();
        (c * de + s * dn, -s * de + c * dn)
    };
    let est = local(b.east - a.east, b.north - a.north, a.yaw);
    let tru = local(tb.east - ta.east, tb.north - ta.north, ta.yaw);
    let error = ((est.0 - tru.0).powi(2) + (est.1 - tru.1).powi(2)).sqrt();
    let (ex, ey) = (est.0 - tru.0, est.1 - tru.1);
    let norm = tru.0.hypot(tru.1);
    let (ux, uy) = if norm > 0.0 {
        (tru.0 / norm, tru.1 / norm)
    } else {
        (1.0, 0.0)
    };
    let yaw_error = angle::wrap((b.yaw - a.yaw) - (tb.yaw - ta.yaw));
    let i0 = truth.partition_point(|s| s.t < a.t);
    let i1 = truth.partition_point(|s| s.t <= b.t);
    let distance: f64 = truth[i0..i1]
        .windows(2)
        .map(|w| ((w[1].east - w[0].east).powi(2) + (w[1].north - w[0].north).powi(2)).sqrt())
        .sum();
    if distance <= 0.0 {
        return None;
    }
    Some(Drift {
        t0: a.t,
        t1: b.t,
        distance,
        error,
        percent: 100.0 * error / distance,
        along: ex * ux + ey * uy,
        cross: -ex * uy + ey * ux,
        yaw_error,
    })
}

/// The longest stretch (at least `min_len` s) of the log's time with no
/// position fix: an outage already in the data.
pub fn find_position_outage(pose: &[terraslip_io::PoseObs], min_len: f64) -> Option<(f64, f64)> {
    let times: Vec<f64> = pose
        .iter()
        .filter(|p| p.east.is_some())
        .map(|p| p.t)
        .collect();
    times
        .windows(2)
        .map(|w| (w[0], w[1]))
        .filter(|(a, b)| b - a >= min_len)
        .max_by(|x, y| (x.1 - x.0).total_cmp(&(y.1 - y.0)))
}

/// Everything the comparison table needs for one run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scorecard {
    pub reconvergence: Vec<Reconvergence>,
    /// Worst re-convergence over first visits, s (`None` if one never settles).
    pub worst_first_visit: Option<f64>,
    /// Worst re-convergence over revisits, s.
    pub worst_revisit: Option<f64>,
    pub rms: IcrRms,
    pub drift: Option<Drift>,
}

/// Scores `run` against truth and labels; `outage` is the window of the
/// drift measurement (if any). `settle` as in [`steady_state_rms`].
pub fn scorecard(
    run: &EstimateRun,
    truth: &[TruthSample],
    labels: &[TerrainLabel],
    outage: Option<(f64, f64)>,
    settle: f64,
) -> Scorecard {
    let rec = reconvergence(run, truth, labels, ReconvergenceSpec::default());
    let worst = |revisit: bool| {
        let mut w = Some(0.0f64);
        for r in rec.iter().filter(|r| r.revisit == revisit) {
            w = match (w, r.seconds) {
                (Some(a), Some(b)) => Some(a.max(b)),
                _ => None,
            };
        }
        w
    };
    Scorecard {
        worst_first_visit: worst(false),
        worst_revisit: worst(true),
        rms: steady_state_rms(run, truth, labels, settle),
        drift: outage.and_then(|(a, b)| outage_drift(run, truth, a, b)),
        reconvergence: rec,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settle_time_finds_last_excursion() {
        let spec = ReconvergenceSpec {
            tolerance: 0.02,
            window: 1.0,
            ..Default::default()
        };
        // error 0.1 for t < 3, then 0: settled from the first window
        // starting after the last bad one.
        let errs: Vec<(f64, f64)> = (0..100)
            .map(|k| {
                let t = k as f64 * 0.1;
                (t, if t < 3.0 { 0.1 } else { 0.0 })
            })
            .collect();
        let s = settle_time(&errs, 0.0, spec).unwrap();
        assert!((s - 2.9).abs() < 0.15, "{s}");
        // Never settles: last window bad.
        let errs: Vec<(f64, f64)> = (0..100).map(|k| (k as f64 * 0.1, 0.1)).collect();
        assert_eq!(settle_time(&errs, 0.0, spec), None);
        assert_eq!(settle_time(&[], 0.0, spec), None);
    }

    #[test]
    fn first_turn_counts_heading_change_after_the_delay() {
        // Straight for 10 s, then 0.1 rad/s to the left, across +-pi.
        let tr: Vec<TruthSample> = (0..300)
            .map(|k| {
                let t = k as f64 * 0.1;
                let yaw = if t < 10.0 {
                    3.0
                } else {
                    3.0 + 0.1 * (t - 10.0)
                };
                TruthSample {
                    t,
                    yaw: angle::wrap(yaw),
                    ..Default::default()
                }
            })
            .collect();
        let t = first_turn(&tr, 0.0, 30.0, 0.3, 2.0).unwrap();
        assert!((t - 13.0).abs() < 0.15, "{t}");
        // Turning before the delay does not count; nor does anything after t1.
        let t = first_turn(&tr, 9.0, 30.0, 0.3, 5.0).unwrap();
        assert!((t - 8.0).abs() < 0.15, "{t}");
        assert_eq!(first_turn(&tr, 0.0, 12.5, 0.3, 2.0), None);
        assert_eq!(first_turn(&[], 0.0, 12.5, 0.3, 2.0), None);
    }

    #[test]
    fn truth_interpolates_and_wraps_yaw() {
        let mk = |t: f64, yaw: f64| TruthSample {
            t,
            yaw,
            y_l: t,
            ..Default::default()
        };
        let tr = [mk(0.0, 3.1), mk(1.0, -3.1)];
        let s = truth_at(&tr, 0.5).unwrap();
        assert!((s.y_l - 0.5).abs() < 1e-12);
        assert!(s.yaw.abs() > 3.1, "{}", s.yaw);
        assert!(truth_at(&tr, 2.0).is_none());
        assert!(truth_at(&[], 0.0).is_none());
    }
}
