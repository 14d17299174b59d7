//! The 2 s motion-prediction error: how a user judges whether learned slip
//! parameters are worth using (the yardstick DRIVE, Baril et al. 2024, uses
//! for slip models).
//!
//! Every `stride` seconds after a `warmup`, from the reference pose at `t`
//! (linear interpolation of `pose.csv`'s positions, and of its headings,
//! unwrapped, which may sit on rows of their own), the tread
//! speeds of `wheels.csv` are integrated over `[t, t + horizon]` with the
//! ICR model and the parameters in effect at `t`, held for the whole
//! horizon; the error is the distance to the reference position at
//! `t + horizon`. Starts where the pose stream has a gap longer than
//! `max_gap` inside the horizon are skipped. The same segments are scored
//! with the no-slip model of the track width, for comparison.
//!
//! A position-only reference (GNSS without a heading) has no start
//! heading of its own: [`PredictionStream`] then takes the estimate's
//! heading at `t` when it is given one (the heading the robot itself
//! would predict from), and counts the starts that did
//! (`start_heading` of the score).
//!
//! A pose stream stamped late against the wheels (a lidar localiser's
//! pose, stamped when the scan was matched) is read with the model's own
//! clock offset `c` (s): the start `t` and the end `t + horizon` on the
//! wheels' clock are the reference poses stamped `t + c` and
//! `t + horizon + c`. A model that knows the pose is late predicts with
//! that knowledge; an offset of 0 reads the stamps as they are.

use terraslip_core::IcrParams;
use terraslip_io::{PoseObs, WheelSample};

use crate::model::RateSlopes;

pub use crate::prediction_stream::{score, score_timed, PredictionStream};

/// Settings of the score.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictionSpec {
    /// Prediction horizon, s.
    pub horizon: f64,
    /// Time from the first wheels row before the first start, s, on a
    /// drive long enough for it ([`warmup_for`]: a shorter drive's is
    /// shorter).
    pub warmup: f64,
    /// Time between starts, s.
    pub stride: f64,
    /// Longest gap in the pose stream a segment may contain, s.
    pub max_gap: f64,
}

impl Default for PredictionSpec {
    fn default() -> Self {
        Self {
            horizon: 2.0,
            warmup: 60.0,
            stride: 1.0,
            max_gap: 0.5,
        }
    }
}

/// Seconds of scored starts a drive keeps before its warm-up is shortened.
pub const MIN_SCORED_S: f64 = 20.0;

/// The warm-up (s) used on a drive of `duration` s: `spec.warmup`, or on a
/// drive too short to leave [`MIN_SCORED_S`] of starts after it and the
/// horizon, the longer of what leaves them and half the drive (never
/// longer than `spec.warmup`), rounded up to whole strides.
pub fn warmup_for(spec: &PredictionSpec, duration: f64) -> f64 {
    let w = spec.warmup;
    let wanted = (duration - spec.horizon - MIN_SCORED_S).max(0.5 * duration);
    if wanted >= w || spec.stride <= 0.0 {
        return w;
    }
    // On the grid of starts w - k stride.
    let k = ((w - wanted) / spec.stride).floor();
    w - k * spec.stride
}

/// One scored start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictionSegment {
    /// Start time, s.
    pub t: f64,
    /// Position error of the parameters' prediction, m.
    pub error: f64,
    /// Position error of the no-slip model's prediction, m.
    pub no_slip: f64,
}

/// Summary statistics of errors, m.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct ErrorStats {
    pub mean_m: f64,
    pub rmse_m: f64,
    pub p90_m: f64,
}

impl ErrorStats {
    fn of(v: impl Iterator<Item = f64>) -> Self {
        let mut v: Vec<f64> = v.collect();
        if v.is_empty() {
            return Self::default();
        }
        let n = v.len() as f64;
        let mean_m = v.iter().sum::<f64>() / n;
        let rmse_m = (v.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
        v.sort_by(|a, b| a.total_cmp(b));
        let p90_m = v[((v.len() - 1) as f64 * 0.9).round() as usize];
        Self {
            mean_m,
            rmse_m,
            p90_m,
        }
    }
}

/// The score of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct PredictionScore {
    pub spec: PredictionSpec,
    pub segments: Vec<PredictionSegment>,
    /// Segments whose start heading was the estimate's (the reference had
    /// none at their start); the others took the reference's.
    pub estimate_headings: usize,
    /// Of the parameters.
    pub stats: ErrorStats,
    /// Of the no-slip model on the same segments.
    pub no_slip: ErrorStats,
    /// A position-only reference: each model's start heading and position
    /// profiled out over the span of fixes (s) before each start
    /// ([`crate::position_prediction`]).
    pub profiled_window_s: Option<f64>,
    /// The warm-up used (s from the first wheels row to the first start):
    /// `spec.warmup`, or a short drive's ([`warmup_for`]).
    pub warmup_s: f64,
}

impl PredictionScore {
    /// The score of given segments.
    pub fn from_segments(spec: PredictionSpec, segments: Vec<PredictionSegment>) -> Self {
        Self {
            spec,
            estimate_headings: 0,
            profiled_window_s: None,
            warmup_s: spec.warmup,
            stats: ErrorStats::of(segments.iter().map(|s| s.error)),
            no_slip: ErrorStats::of(segments.iter().map(|s| s.no_slip)),
            segments,
        }
    }

    /// The `prediction` object of `summary.json` and `calibrate validate --json`.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "horizon_s": self.spec.horizon,
            "warmup_s": self.warmup_s,
            "segments": self.segments.len(),
            "mean_m": self.stats.mean_m,
            "rmse_m": self.stats.rmse_m,
            "p90_m": self.stats.p90_m,
            "no_slip": self.no_slip,
            "start_heading": match (self.estimate_headings, self.profiled_window_s) {
                (_, Some(w)) => format!(
                    "profiled: each model's path over the {w} s of fixes before the start, \
                     placed on them by the best rotation and translation"
                ),
                (0, _) => "reference".to_string(),
                (n, _) if n == self.segments.len() => "estimate".to_string(),
                (n, _) => format!("reference, the estimate's on {n} segments"),
            },
        })
    }
}

/// The reference pose at `t` (linear interpolation; `None` outside them).
pub fn interpolate(r: &[Reference], t: f64) -> Option<(f64, f64, f64)> {
    lerp(r, t, |p| p.0, |p| [p.1, p.2, p.3]).map(|[e, n, y]| (e, n, y))
}

/// Linear interpolation at `t` of the samples `r` (their times `time`,
/// their values `value`); `None` outside them.
pub(crate) fn lerp<T, const N: usize>(
    r: &[T],
    t: f64,
    time: impl Fn(&T) -> f64,
    value: impl Fn(&T) -> [f64; N],
) -> Option<[f64; N]> {
    let i = r.partition_point(|p| time(p) < t);
    if let Some(p) = r.get(i).filter(|p| time(p) == t) {
        return Some(value(p));
    }
    if i == 0 || i >= r.len() {
        return None;
    }
    let (a, b) = (&r[i - 1], &r[i]);
    let (ta, tb) = (time(a), time(b));
    let f = if tb > ta { (t - ta) / (tb - ta) } else { 0.0 };
    let (va, vb) = (value(a), value(b));
    Some(std::array::from_fn(|k| va[k] + f * (vb[k] - va[k])))
}

/// Parameters in effect at a start and the pose stream's clock offset
/// then (s: a pose stamped `t + clock_offset` describes wheel time `t`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timed {
    pub params: IcrParams,
    pub clock_offset: f64,
    /// How the ICRs move with turn rate, acceleration and speed over the
    /// 2 s (a calibration's selected model; [`RateSlopes::NONE`] holds
    /// `params` constant).
    pub slopes: RateSlopes,
}

impl Timed {
    /// Constant `params`, the pose read `clock_offset` s later.
    pub fn new(params: IcrParams, clock_offset: f64) -> Self {
        Self {
            params,
            clock_offset,
            slopes: RateSlopes::NONE,
        }
    }

    /// `params` read against the pose stamps as they are.
    pub fn on_time(params: IcrParams) -> Self {
        Self::new(params, 0.0)
    }
}

/// Integrates the wheels over `[t0, t1]` from pose `start` (east, north,
/// yaw) with `p` (a row's speeds hold over the interval that ends at its
/// time): the position at `t1`.
pub fn predict(
    wheels: &[WheelSample],
    p: &IcrParams,
    t0: f64,
    t1: f64,
    start: (f64, f64, f64),
) -> (f64, f64) {
    predict_with(wheels, &|w| p.twist(w.v_left, w.v_right), t0, t1, start)
}

/// [`predict`] with any body twist of a wheels row: `twist(row)` gives
/// `v_x`, `v_y` (m/s, body frame) and `omega` (rad/s).
pub fn predict_with(
    wheels: &[WheelSample],
    twist: &dyn Fn(&WheelSample) -> terraslip_core::Twist,
    t0: f64,
    t1: f64,
    start: (f64, f64, f64),
) -> (f64, f64) {
    let mut pose = start;
    let mut i = wheels.partition_point(|w| w.t <= t0);
    let mut t = t0;
    while t < t1 && i < wheels.len() {
        let tn = wheels[i].t.min(t1);
        advance(&mut pose, tn - t, twist(&wheels[i]));
        t = tn;
        if tn >= wheels[i].t {
            i += 1;
        }
    }
    (pose.0, pose.1)
}

/// Moves `pose` (east, north, yaw; m, m, rad) on by body twist `tw` held
/// for `dt` s (Euler step, the heading at the step's start).
pub fn advance(pose: &mut (f64, f64, f64), dt: f64, tw: terraslip_core::Twist) {
    let (e, n, y) = pose;
    *e += dt * (tw.v_x * y.cos() - tw.v_y * y.sin());
    *n += dt * (tw.v_x * y.sin() + tw.v_y * y.cos());
    *y += dt * tw.omega;
}

/// A reference position: time, east, north.
pub(crate) type Position = (f64, f64, f64);

pub(crate) fn interpolate_position(r: &[Position], t: f64) -> Option<(f64, f64)> {
    lerp(r, t, |p| p.0, |p| [p.1, p.2]).map(|[e, n]| (e, n))
}

/// The heading at `t` from headings `(t, yaw unwrapped)` no further apart
/// than `max_gap` around it.
pub(crate) fn heading_at(h: &[(f64, f64)], t: f64, max_gap: f64) -> Option<f64> {
    let i = h.partition_point(|p| p.0 < t);
    if let Some(p) = h.get(i).filter(|p| p.0 == t) {
        return Some(p.1);
    }
    let (a, b) = (h.get(i.checked_sub(1)?)?, h.get(i)?);
    if b.0 - a.0 > max_gap {
        return None;
    }
    Some(a.1 + (t - a.0) / (b.0 - a.0) * (b.1 - a.1))
}

/// A reference pose: time, east, north and the yaw unwrapped.
pub type Reference = (f64, f64, f64, f64);

/// The reference poses of a pose stream: its rows with all of east, north
/// and yaw, the yaw unwrapped.
pub fn references(pose: &[PoseObs]) -> Vec<Reference> {
    let mut r: Vec<Reference> = Vec::new();
    for p in pose {
        if let Some(q) = reference(r.last(), p) {
            r.push(q);
        }
    }
    r
}

/// The reference pose of a pose row with all of east, north and yaw, its
/// yaw unwrapped against the previous reference's.
fn reference(prev: Option<&Reference>, p: &PoseObs) -> Option<Reference> {
    let (Some(e), Some(n), Some(y)) = (p.east, p.north, p.yaw) else {
        return None;
    };
    let y = match prev {
        Some(&(_, _, _, prev)) => prev + terraslip_core::angle::wrap(y - prev),
        None => y,
    };
    Some((p.t, e, n, y))
}

/// The position error (m) of the prediction of `twist` from start `t` (s,
/// wheels' clock) over `spec.horizon`, the references read `clock_offset`
/// s later; `None` where the references around `[t, t + horizon]` (on
/// their clock) have a gap longer than `spec.max_gap` or do not cover it.
pub fn segment_error(
    refs: &[Reference],
    wheels: &[WheelSample],
    twist: &dyn Fn(&WheelSample) -> terraslip_core::Twist,
    t: f64,
    clock_offset: f64,
    spec: &PredictionSpec,
) -> Option<f64> {
    let (r0, r1) = (t + clock_offset, t + spec.horizon + clock_offset);
    if !gap_free(refs, |p| p.0, r0, r1, spec.max_gap) {
        return None;
    }
    let (a, b) = (interpolate(refs, r0)?, interpolate(refs, r1)?);
    let (e, n) = predict_with(wheels, twist, t, t + spec.horizon, a);
    Some((e - b.0).hypot(n - b.1))
}

/// Whether the references `r` (times `time`) around `[r0, r1]` cover it
/// with no gap longer than `max_gap`.
pub(crate) fn gap_free<T>(
    r: &[T],
    time: impl Fn(&T) -> f64,
    r0: f64,
    r1: f64,
    max_gap: f64,
) -> bool {
    let i = r.partition_point(|p| time(p) <= r0).saturating_sub(1);
    let j = r.partition_point(|p| time(p) < r1);
    j < r.len()
        && r[i..=j]
            .windows(2)
            .all(|w| time(&w[1]) - time(&w[0]) <= max_gap)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drive with exact ICR-model truth as pose (10 Hz) and wheels (50 Hz).
    fn drive(
        truth: &IcrParams,
        turn: bool,
        gap: Option<(f64, f64)>,
    ) -> (Vec<WheelSample>, Vec<PoseObs>) {
        let (mut e, mut n, mut y) = (0.0f64, 0.0f64, 0.3f64);
        let mut wheels = Vec::new();
        let mut pose = Vec::new();
        for k in 0..=5000 {
            let t = k as f64 * 0.02;
            let (vl, vr) = if turn { (0.6, 1.0) } else { (0.8, 0.8) };
            if k > 0 {
                let tw = truth.twist(vl, vr);
                e += 0.02 * (tw.v_x * y.cos() - tw.v_y * y.sin());
                n += 0.02 * (tw.v_x * y.sin() + tw.v_y * y.cos());
                y += 0.02 * tw.omega;
            }
            wheels.push(WheelSample {
                t,
                v_left: vl,
                v_right: vr,
            });
            if k % 5 == 0 && !gap.is_some_and(|(a, b)| t > a && t < b) {
                pose.push(PoseObs {
                    t,
                    east: Some(e),
                    north: Some(n),
                    yaw: Some(terraslip_core::angle::wrap(y)),
                    std_xy: None,
                    std_yaw: None,
                });
            }
        }
        (wheels, pose)
    }

    #[test]
    fn exact_parameters_predict_exactly_and_no_slip_does_not() {
        let mut truth = IcrParams::new(0.4, -0.38, 0.02);
        truth.alpha_l = 0.9;
        truth.alpha_r = 0.92;
        for turn in [false, true] {
            let (w, p) = drive(&truth, turn, None);
            let s = score(&w, &p, 0.5, &|_| Some(truth), PredictionSpec::default()).unwrap();
            // Starts every second from 60 s while t + 2 s is inside.
            assert_eq!(s.segments.len(), 39, "{turn}");
            assert!(s.stats.mean_m < 1e-6, "{:?}", s.stats);
            // A 9 % slower robot: 0.15 m short over 2 s at 0.8 m/s.
            assert!(s.no_slip.mean_m > 0.1, "{:?}", s.no_slip);
            assert!(s.no_slip.p90_m >= s.no_slip.mean_m * 0.99);
        }
    }

    #[test]
    fn a_late_pose_stream_is_read_with_the_models_clock_offset() {
        let mut truth = IcrParams::new(0.4, -0.38, 0.02);
        truth.alpha_l = 0.9;
        truth.alpha_r = 0.92;
        let (w, mut p) = drive(&truth, true, None);
        // The pose stamped 0.3 s after the wheel time it describes, and
        // the wheels changing speed so that the lag shows.
        for q in &mut p {
            q.t += 0.3;
        }
        let w: Vec<WheelSample> = w
            .iter()
            .map(|s| {
                let k = 1.0 + 0.5 * (s.t * 1.3).sin();
                WheelSample {
                    v_left: s.v_left * k,
                    v_right: s.v_right * k,
                    ..*s
                }
            })
            .collect();
        // The pose recomputed from the changed speeds, stamped late.
        let (mut e, mut n, mut y) = (0.0f64, 0.0f64, 0.3f64);
        for (k, s) in w.iter().enumerate() {
            if k > 0 {
                let tw = truth.twist(s.v_left, s.v_right);
                e += 0.02 * (tw.v_x * y.cos() - tw.v_y * y.sin());
                n += 0.02 * (tw.v_x * y.sin() + tw.v_y * y.cos());
                y += 0.02 * tw.omega;
            }
            if k % 5 == 0 {
                let q = &mut p[k / 5];
                q.east = Some(e);
                q.north = Some(n);
                q.yaw = Some(terraslip_core::angle::wrap(y));
            }
        }
        let spec = PredictionSpec::default();
        let late = score_timed(&w, &p, 0.5, &|_| Some(Timed::new(truth, 0.3)), spec).unwrap();
        let as_stamped = score(&w, &p, 0.5, &|_| Some(truth), spec).unwrap();
        assert!(late.stats.mean_m < 1e-3, "{:?}", late.stats);
        assert!(as_stamped.stats.mean_m > 0.05, "{:?}", as_stamped.stats);
        // The same starts (every pose stamp moved with the clock).
        let starts = |s: &PredictionScore| s.segments.iter().map(|g| g.t).collect::<Vec<_>>();
        assert_eq!(starts(&late), starts(&as_stamped));
        assert_eq!(late.segments.len(), 39);
    }

    #[test]
    fn gaps_and_missing_parameters_are_skipped() {
        let truth = IcrParams::new(0.4, -0.38, 0.02);
        let (w, p) = drive(&truth, true, Some((70.0, 71.0)));
        let s = score(
            &w,
            &p,
            0.5,
            &|t| (t < 90.0).then_some(truth),
            PredictionSpec::default(),
        )
        .unwrap();
        // 60..=97 in steps of 1 s; starts 69 and 70 reach into the gap; 90.. have no parameters.
        assert!(s.segments.iter().all(|g| !(68.5..70.5).contains(&g.t)));
        assert!(s.segments.iter().all(|g| g.t < 90.0));
        assert_eq!(s.segments.len(), 28);
        assert!(score(&w, &[], 0.5, &|_| Some(truth), PredictionSpec::default()).is_none());
    }

    #[test]
    fn a_drive_shorter_than_the_warmup_is_scored_after_a_shorter_one() {
        let truth = IcrParams::new(0.4, -0.38, 0.02);
        let (w, p) = drive(&truth, true, None);
        let spec = PredictionSpec::default();
        // 40 s: half of it as warm-up (20 s), starts 20..=38 s.
        let (w40, p40): (Vec<_>, Vec<_>) = (
            w.iter().copied().filter(|r| r.t <= 40.0).collect(),
            p.iter().copied().filter(|r| r.t <= 40.0).collect(),
        );
        let s = score(&w40, &p40, 0.5, &|_| Some(truth), spec).unwrap();
        assert_eq!(s.warmup_s, 20.0);
        assert_eq!(s.to_json()["warmup_s"], 20.0);
        assert_eq!(s.segments.first().map(|g| g.t), Some(20.0));
        assert_eq!(s.segments.len(), 19);
        // A drive long enough keeps the whole warm-up and its starts.
        let full = score(&w, &p, 0.5, &|_| Some(truth), spec).unwrap();
        assert_eq!(full.warmup_s, 60.0);
        assert_eq!(full.segments.first().map(|g| g.t), Some(60.0));
        assert_eq!(warmup_for(&spec, 30.0), 15.0);
        assert_eq!(warmup_for(&spec, 82.0), 60.0);
        assert_eq!(warmup_for(&spec, 600.0), 60.0);
    }

    #[test]
    fn the_stream_keeps_only_the_open_starts_and_scores_like_the_whole_drive() {
        let truth = IcrParams::new(0.4, -0.38, 0.02);
        // Poses stop at 60 s and start again at 70 s; poses without a
        // heading from 80 s to 85 s.
        let (wheels, mut pose) = drive(&truth, true, Some((60.0, 70.0)));
        for p in pose.iter_mut().filter(|p| p.t > 80.0 && p.t < 85.0) {
            p.yaw = None;
        }
        let spec = PredictionSpec {
            warmup: 5.0,
            ..Default::default()
        };
        let params_at = |t: f64| (t < 90.0).then_some(truth);
        let mut stream = PredictionStream::new(0.5, spec);
        let mut k = 0;
        let mut held = 0;
        for w in &wheels {
            while let Some(p) = pose.get(k).filter(|p| p.t <= w.t) {
                stream.pose(p);
                k += 1;
            }
            stream.wheels(*w, &mut |t| params_at(t).map(Timed::on_time));
            held = held.max(stream.held());
        }
        // 2.5 s of 50 Hz wheels and 10 Hz poses at most, gaps included.
        assert!(held < 200, "{held}");
        let got = stream.finish().unwrap();
        // Starts 5..=98 s (94); left out: 59..=69 (their 2 s reach across
        // the pose gap; 58 ends at the pose at 60), 81..=84 (no heading at
        // their start: the positions go on, the headings stop after 80 s)
        // and 90..=98 (no parameters).
        assert!(got.segments.iter().all(|g| !(58.5..70.0).contains(&g.t)));
        assert!(got.segments.iter().all(|g| !(80.5..85.0).contains(&g.t)));
        assert!(got.segments.iter().all(|g| g.t < 90.0));
        assert_eq!(got.segments.len(), 94 - 11 - 4 - 9);
        assert_eq!(got.estimate_headings, 0);
        assert_eq!(score(&wheels, &pose, 0.5, &params_at, spec), Some(got));
    }

    #[test]
    fn positions_and_headings_on_rows_of_their_own_score_as_one_reference() {
        let mut truth = IcrParams::new(0.4, -0.38, 0.02);
        truth.alpha_l = 0.9;
        let (w, p) = drive(&truth, true, None);
        let joint = score(&w, &p, 0.5, &|_| Some(truth), PredictionSpec::default()).unwrap();
        // The same poses as a GNSS import writes them: a position row and a
        // heading row, 10 ms apart.
        let mut split = Vec::new();
        for r in &p {
            split.push(PoseObs { yaw: None, ..*r });
            split.push(PoseObs {
                t: r.t + 0.01,
                east: None,
                north: None,
                ..*r
            });
        }
        let s = score(&w, &split, 0.5, &|_| Some(truth), PredictionSpec::default()).unwrap();
        assert_eq!(s.segments.len(), joint.segments.len());
        // Exact up to the heading interpolated 10 ms off.
        assert!(s.stats.mean_m < 0.01, "{:?}", s.stats);
        assert_eq!(s.to_json()["start_heading"], "reference");
    }

    #[test]
    fn a_position_only_reference_starts_from_the_estimates_heading() {
        let truth = IcrParams::new(0.4, -0.38, 0.02);
        let (w, p) = drive(&truth, true, None);
        let positions: Vec<PoseObs> = p.iter().map(|r| PoseObs { yaw: None, ..*r }).collect();
        // No heading anywhere: nothing to start from.
        assert!(score(
            &w,
            &positions,
            0.5,
            &|_| Some(truth),
            PredictionSpec::default()
        )
        .is_none());
        // The true heading at every row, as a perfect estimate would give it.
        let yaw_at = |t: f64| {
            let k = p.partition_point(|r| r.t <= t) - 1;
            let (r, dt) = (&p[k], t - p[k].t);
            r.yaw.unwrap() + dt * truth.twist(0.6, 1.0).omega
        };
        // The stream fed the estimate's heading `off` rad wrong.
        let run = |off: f64| {
            let mut stream = PredictionStream::new(0.5, PredictionSpec::default());
            let mut k = 0;
            for x in &w {
                while let Some(r) = positions.get(k).filter(|r| r.t <= x.t) {
                    stream.pose(r);
                    k += 1;
                }
                stream.wheels(*x, &mut |_| Some(Timed::on_time(truth)));
                stream.estimate_heading(yaw_at(x.t) + off);
            }
            stream.finish().unwrap()
        };
        let s = run(0.0);
        assert_eq!(s.segments.len(), 39);
        assert!(s.stats.mean_m < 1e-6, "{:?}", s.stats);
        assert_eq!(s.estimate_headings, 39);
        assert_eq!(s.to_json()["start_heading"], "estimate");
        // A wrong heading shows: 0.1 rad off over ~1.6 m is ~0.16 m.
        assert!(run(0.1).stats.mean_m > 0.1);
    }
}
