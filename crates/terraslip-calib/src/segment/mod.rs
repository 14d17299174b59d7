//! Segments: the motion between two pose observations, with the wheel
//! samples recorded meanwhile.
//!
//! A segment starts at a pose observation and ends at the first later one at
//! least [`SegmentConfig::min_duration`] away; the next segment starts where
//! the previous one ended (Mandow et al. 2007, sec. III: "training paths can be
//! broken into a number N of short segments according to the external sensor
//! rate"). The reference increment is expressed in the body frame of the
//! segment start (REP-103: x forward, y left), so it does not depend on the
//! absolute heading.

use terraslip_core::angle;
use terraslip_io::{DriveLog, WheelSample};

mod gates;
pub mod reference;

pub use gates::{clean_poses, drop_mistimed, plausible};

/// A pose increment in the body frame of the segment start: `dx` forward m,
/// `dy` left m, `dyaw` counter-clockwise rad.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Increment {
    pub dx: f64,
    pub dy: f64,
    pub dyaw: f64,
}

/// One wheel interval of constant measured tread speeds (m/s) lasting `dt` s.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Step {
    pub dt: f64,
    pub v_left: f64,
    pub v_right: f64,
    /// Acceleration of the mean tread speed `(v_l + v_r)/2` at mid-step,
    /// m/s^2, made positive when speeding up in the driving direction
    /// (`d|v|/dt`): a central difference over [`ACC_HALF_WINDOW`] each side,
    /// because the Warthog's encoders hold each tread speed for 0.25 s.
    /// Only the traction term of [`crate::model::RateSlopes`] reads it.
    pub acc: f64,
}

/// Half width (s) of the central difference that gives [`Step::acc`]:
/// one hold period of the Warthog's tread speeds (0.25 s), so a speed step
/// shows as one acceleration pulse instead of a spike.
pub const ACC_HALF_WINDOW: f64 = 0.25;

/// The tread acceleration of each wheels row as `calibrate` reads it
/// (central difference over [`ACC_HALF_WINDOW`], signed by the direction
/// of travel), m/s^2.
pub fn accelerations(w: &[WheelSample]) -> Vec<f64> {
    let at = |t: f64| {
        let k = w.partition_point(|s| s.t <= t).clamp(1, w.len()) - 1;
        0.5 * (w[k].v_left + w[k].v_right)
    };
    w.iter()
        .map(|s| {
            (at(s.t + ACC_HALF_WINDOW) - at(s.t - ACC_HALF_WINDOW)) / (2.0 * ACC_HALF_WINDOW)
                * (s.v_left + s.v_right).signum()
        })
        .collect()
}

/// The motion between two pose observations.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// Index of the log this segment comes from (order given to the builder).
    pub log: usize,
    /// Start and end, s, on the pose clock.
    pub t0: f64,
    pub t1: f64,
    /// Reference increment from the pose stream.
    pub reference: Increment,
    /// Terrain label in force over the whole segment, if the log has labels.
    pub terrain: Option<String>,
    /// Range of this segment's steps in [`Segments::steps`] (a run of its
    /// log's timeline, shared with overlapping segments).
    pub steps: std::ops::Range<usize>,
    /// `int |v_l| + |v_r| dt`, m: how much the treads moved.
    pub tread_travel: f64,
    /// `int (v_r - v_l) dt`, m, and `int (v_r + v_l)/2 dt`, m (quick calibration).
    pub int_diff: f64,
    pub int_mean: f64,
}

/// Segmentation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentConfig {
    /// Shortest segment, s (the contract's 1 s).
    pub min_duration: f64,
    /// Segments longer than this (a pose dropout) are discarded, s.
    pub max_duration: f64,
    /// Largest gap between wheel samples inside a segment, s.
    pub max_wheel_gap: f64,
    /// A segment whose treads travel less than this (m) is stationary.
    pub stationary_travel: f64,
    /// Only poses with `t_min <= t <= t_max` (pose clock, s) are used.
    pub t_min: f64,
    pub t_max: f64,
    /// Drop segments whose reference cannot be a motion the treads made
    /// (see [`plausible`]): a localiser that stalls and then catches up, or
    /// relocalises, yields pose increments no wheel model can match.
    pub reference_gate: bool,
    /// Drop single poses whose timestamp is off (see [`drop_mistimed`]).
    pub drop_mistimed: bool,
    /// Track width (m) used by the gate's yaw bound; 1 m if unknown.
    pub gate_track_width: Option<f64>,
    /// `None`: chained segments, each starting where the previous one ended
    /// (the contract's, what `validate` scores). `Some(stride)`: chains of
    /// segments interleaved: a segment starts at every pose where an earlier
    /// one ended, and a new chain at the first pose at least `stride` s
    /// after the previous start (0: every pose starts a segment). Every
    /// start is then also an end, so each pose's noise enters the fit from
    /// both sides and largely cancels. The segments overlap, so their
    /// residuals are correlated (see [`crate::sandwich`]).
    pub overlap: Option<f64>,
}

impl Default for SegmentConfig {
    fn default() -> Self {
        Self {
            min_duration: 1.0,
            max_duration: 3.0,
            max_wheel_gap: 0.5,
            stationary_travel: 0.02,
            t_min: f64::NEG_INFINITY,
            t_max: f64::INFINITY,
            reference_gate: true,
            drop_mistimed: true,
            gate_track_width: None,
            overlap: None,
        }
    }
}

impl SegmentConfig {
    /// This configuration with the gate's track width taken from the first
    /// log's `meta.toml` when not set.
    pub fn for_logs(&self, logs: &[DriveLog]) -> Self {
        let mut c = self.clone();
        c.gate_track_width = c
            .gate_track_width
            .or_else(|| logs.iter().find_map(|l| l.meta.track_width));
        c
    }
}

/// Why pose rows or segments were not used, counted.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SegmentStats {
    /// Pose rows lacking east, north or yaw.
    pub incomplete_poses: usize,
    /// Pose rows that repeat the previous pose exactly (a held, stale pose).
    pub stale_poses: usize,
    /// Poses dropped as mistimed (see [`drop_mistimed`]).
    pub mistimed_poses: usize,
    /// Segments with (almost) no tread motion.
    pub stationary: usize,
    /// Segments longer than `max_duration` or not covered by wheel samples.
    pub gaps: usize,
    /// Segments during which the terrain label changes.
    pub terrain_change: usize,
    /// Segments whose reference the treads cannot have produced (stalled
    /// or jumping poses), see [`plausible`].
    pub implausible: usize,
}

impl SegmentStats {
    /// What to look at when too few segments are usable: pose rows with no
    /// heading (a position-only reference), else whether the robot moves
    /// while the reference is valid.
    pub fn hint(&self, segments: usize) -> String {
        if segments == 0 && self.incomplete_poses > 0 {
            format!(
                "{} pose rows have no position or no heading: segments need both; a position-only reference (GNSS without a heading) is calibrated on windows of fixes only when no log has a heading: calibrate such logs on their own, or add a heading (an IMU orientation that agrees with the GNSS course, `[heading]` of the topics file for a bag)",
                self.incomplete_poses
            )
        } else {
            "is the robot moving while the pose reference is valid?".into()
        }
    }

    pub fn add(&mut self, o: &SegmentStats) {
        self.incomplete_poses += o.incomplete_poses;
        self.stale_poses += o.stale_poses;
        self.mistimed_poses += o.mistimed_poses;
        self.stationary += o.stationary;
        self.gaps += o.gaps;
        self.terrain_change += o.terrain_change;
        self.implausible += o.implausible;
    }
}

/// All moving segments of one or more logs, their wheel steps in one buffer.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Segments {
    pub segments: Vec<Segment>,
    /// Each log's timeline, one after the other: a step between every two
    /// consecutive wheel samples or pose times (wheel clock).
    pub steps: Vec<Step>,
    /// Totals over all logs.
    pub stats: SegmentStats,
    /// The same, per log (index as given to [`Segments::push_log`]).
    pub per_log: Vec<SegmentStats>,
}

/// The union of two ascending sequences, ascending (a linear merge: the
/// offset search builds segments dozens of times per log). Falls back to a
/// sort if either is out of order.
fn merge_sorted(a: impl Iterator<Item = f64>, b: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(b.len() + a.size_hint().0);
    let mut b = b.iter().copied().peekable();
    for x in a {
        while let Some(y) = b.next_if(|&y| y < x) {
            out.push(y);
        }
        out.push(x);
    }
    out.extend(b);
    if !out.windows(2).all(|p| p[0] <= p[1]) {
        out.sort_by(f64::total_cmp);
    }
    out
}

/// Total duration of time spans `(log, start, end)` (s) over the length of
/// their union per log, at least 1: how many of them cover an instant on
/// average.
pub(crate) fn coverage(spans: impl Iterator<Item = (usize, f64, f64)>) -> f64 {
    let mut spans: Vec<(usize, f64, f64)> = spans.collect();
    spans.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let total: f64 = spans.iter().map(|s| s.2 - s.1).sum();
    let mut union = 0.0;
    let mut cur: Option<(usize, f64, f64)> = None;
    for (log, a, b) in spans {
        cur = match cur {
            Some((l, ca, cb)) if l == log && a <= cb => Some((l, ca, cb.max(b))),
            Some((_, ca, cb)) => {
                union += cb - ca;
                Some((log, a, b))
            }
            None => Some((log, a, b)),
        };
    }
    if let Some((_, a, b)) = cur {
        union += b - a;
    }
    if union > 0.0 {
        (total / union).max(1.0)
    } else {
        1.0
    }
}

/// Linear interpolation of wheel speeds at `t` (clamped at the ends).
/// `hint` is an index at or before `t`, advanced as the caller walks forward.
pub(crate) fn wheel_at(w: &[WheelSample], t: f64, hint: &mut usize) -> (f64, f64) {
    while *hint + 1 < w.len() && w[*hint + 1].t <= t {
        *hint += 1;
    }
    let a = &w[*hint];
    match w.get(*hint + 1) {
        Some(b) if b.t > a.t && t > a.t => {
            let s = ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0);
            (
                a.v_left + s * (b.v_left - a.v_left),
                a.v_right + s * (b.v_right - a.v_right),
            )
        }
        _ => (a.v_left, a.v_right),
    }
}

/// Reference increment from pose `a` to pose `b`, in the frame of `a`.
pub fn relative(a: (f64, f64, f64), b: (f64, f64, f64)) -> Increment {
    let (s, c) = a.2.sin_cos();
    let (de, dn) = (b.0 - a.0, b.1 - a.1);
    Increment {
        dx: c * de + s * dn,
        dy: -s * de + c * dn,
        dyaw: angle::wrap(b.2 - a.2),
    }
}

impl Segments {
    /// Builds the moving segments of `log` and appends them. The wheel clock
    /// is shifted by `time_offset` s: the wheel sample stamped `t` is taken
    /// to describe the motion at pose-clock time `t + time_offset` (a pose
    /// stream that lags the wheels by 0.1 s needs `time_offset = 0.1`).
    pub fn push_log(
        &mut self,
        log_index: usize,
        log: &DriveLog,
        time_offset: f64,
        cfg: &SegmentConfig,
    ) {
        let mut stats = SegmentStats::default();
        // Positions and headings on rows of their own (what a GNSS bag
        // carries): completed as `reference` describes.
        let split = log
            .pose
            .iter()
            .any(|p| p.yaw.is_some() && (p.east.is_none() || p.north.is_none()));
        let completed = split.then(|| reference::complete(&log.pose)).flatten();
        let pose = completed.as_deref().unwrap_or(&log.pose);
        let mut poses = clean_poses(pose, &mut stats);
        let w = &log.wheels;
        if cfg.drop_mistimed {
            let n0 = poses.len();
            // A stall over several poses needs several passes.
            for _ in 0..4 {
                let n = poses.len();
                poses = drop_mistimed(&poses, w, time_offset);
                if poses.len() == n {
                    break;
                }
            }
            stats.mistimed_poses += n0 - poses.len();
        }
        if w.len() < 2 || poses.len() < 2 {
            self.record(log_index, &stats);
            return;
        }
        let (w_first, w_last) = (w[0].t + time_offset, w[w.len() - 1].t + time_offset);
        // The log's timeline: one step between consecutive knots, the knots
        // being every wheel sample and every pose time on the wheel clock.
        // Each segment is a contiguous run of it, so the whole drive can be
        // integrated once per parameter vector and every segment's increment
        // read off that trajectory (`model::residuals_rate`), however much
        // the segments overlap.
        let base = self.steps.len();
        let pose_knots: Vec<f64> = poses
            .iter()
            .map(|p| p.0 - time_offset)
            .filter(|&t| t >= w[0].t && t <= w[w.len() - 1].t)
            .collect();
        let mut knots = merge_sorted(w.iter().map(|s| s.t), &pose_knots);
        knots.dedup();
        let mut hint = 0usize;
        let (mut lo, mut hi) = (0usize, 0usize);
        let mut prev = wheel_at(w, knots[0], &mut hint);
        for p in knots.windows(2) {
            let next = wheel_at(w, p[1], &mut hint);
            let mid = 0.5 * (p[0] + p[1]);
            let (a, b) = (
                wheel_at(w, mid - ACC_HALF_WINDOW, &mut lo),
                wheel_at(w, mid + ACC_HALF_WINDOW, &mut hi),
            );
            // Trapezoid: the mean speed over the interval.
            let (v_left, v_right) = (0.5 * (prev.0 + next.0), 0.5 * (prev.1 + next.1));
            self.steps.push(Step {
                dt: p[1] - p[0],
                v_left,
                v_right,
                acc: (0.5 * (b.0 + b.1) - 0.5 * (a.0 + a.1)) / (2.0 * ACC_HALF_WINDOW)
                    * (v_left + v_right).signum(),
            });
            prev = next;
        }
        let knot_index = |t: f64| {
            let k = knots.partition_point(|&x| x < t);
            (k < knots.len() && knots[k] == t).then_some(base + k)
        };
        // A pose starts a segment if an earlier segment ended there (so
        // chains of segments run on), or, for overlapping segments, if it is
        // at least `stride` after the previous start (a new chain). Every
        // start is then also an end once the chains run: the noise of such
        // a pose enters the fit as `(J_before - J_after) n` and mostly
        // cancels, while a pose that only starts or only ends segments adds
        // its noise `J n` whole (see docs/calibration.md, fit segments).
        let stride = cfg.overlap.unwrap_or(f64::INFINITY);
        let mut ends = vec![false; poses.len()];
        let mut last_start: Option<f64> = None;
        for i in 0..poses.len() {
            let (ta, ..) = poses[i];
            if ta < cfg.t_min || !(ends[i] || last_start.is_none_or(|t| ta - t >= stride)) {
                continue;
            }
            last_start = Some(ta);
            // First pose at least min_duration later.
            let mut j = i + 1;
            while j < poses.len() && poses[j].0 - ta < cfg.min_duration {
                j += 1;
            }
            if j >= poses.len() || poses[j].0 > cfg.t_max {
                break;
            }
            ends[j] = true;
            let tb = poses[j].0;
            let start = i;
            if tb - ta > cfg.max_duration || ta < w_first || tb > w_last {
                stats.gaps += 1;
                continue;
            }
            let terrain = if log.terrain.is_empty() {
                None
            } else {
                let la = log.terrain_at(ta);
                if la != log.terrain_at(tb) || log.terrain.iter().any(|l| l.t > ta && l.t < tb) {
                    stats.terrain_change += 1;
                    continue;
                }
                la.map(str::to_string)
            };
            // Wheel samples between ta and tb on the wheel clock: a gap
            // between them (not between timeline knots, which include the
            // pose times) means the treads were not observed.
            let (wa, wb) = (ta - time_offset, tb - time_offset);
            let k0 = w.partition_point(|s| s.t <= wa);
            let k1 = w.partition_point(|s| s.t < wb);
            let gap = std::iter::once(wa)
                .chain(w[k0..k1.max(k0)].iter().map(|s| s.t))
                .chain(std::iter::once(wb))
                .collect::<Vec<_>>()
                .windows(2)
                .any(|p| p[1] - p[0] > cfg.max_wheel_gap);
            let (Some(sa), Some(sb)) = (knot_index(wa), knot_index(wb)) else {
                stats.gaps += 1;
                continue;
            };
            if gap || sb <= sa {
                stats.gaps += 1;
                continue;
            }
            let mut seg = Segment {
                log: log_index,
                t0: ta,
                t1: tb,
                reference: relative(
                    (poses[start].1, poses[start].2, poses[start].3),
                    (poses[j].1, poses[j].2, poses[j].3),
                ),
                terrain,
                steps: sa..sb,
                tread_travel: 0.0,
                int_diff: 0.0,
                int_mean: 0.0,
            };
            for st in &self.steps[sa..sb] {
                seg.tread_travel += (st.v_left.abs() + st.v_right.abs()) * st.dt;
                seg.int_diff += (st.v_right - st.v_left) * st.dt;
                seg.int_mean += 0.5 * (st.v_right + st.v_left) * st.dt;
            }
            if seg.tread_travel < cfg.stationary_travel {
                stats.stationary += 1;
                continue;
            }
            if cfg.reference_gate && !plausible(&seg, &self.steps[sa..sb], cfg) {
                stats.implausible += 1;
                continue;
            }
            self.segments.push(seg);
        }
        self.record(log_index, &stats);
    }

    fn record(&mut self, log_index: usize, stats: &SegmentStats) {
        self.stats.add(stats);
        if self.per_log.len() <= log_index {
            self.per_log.resize(log_index + 1, SegmentStats::default());
        }
        self.per_log[log_index].add(stats);
    }

    /// Builds segments from several logs, each with its own time offset.
    pub fn build(logs: &[&DriveLog], offsets: &[f64], cfg: &SegmentConfig) -> Self {
        let mut s = Segments::default();
        for (i, log) in logs.iter().enumerate() {
            s.push_log(i, log, offsets.get(i).copied().unwrap_or(0.0), cfg);
        }
        s
    }

    /// How many segments cover an instant on average: their total duration
    /// over the length of the union of their time spans (per log). 1 for
    /// chained segments; about poses-per-`min_duration` with
    /// [`SegmentConfig::overlap`] = `Some(0)`. Overlapping segments share
    /// pose noise, so counts of them overstate the evidence by about this
    /// (the uncertainties model the sharing itself, [`crate::sandwich`]).
    pub fn coverage(&self) -> f64 {
        coverage(self.segments.iter().map(|s| (s.log, s.t0, s.t1)))
    }

    /// A chained subset of (possibly overlapping) segments: in time order per
    /// log, each kept segment starts at or after the end of the previous one
    /// kept. All of them for chained segments.
    pub fn chained_mask(&self) -> Vec<bool> {
        let mut order: Vec<usize> = (0..self.segments.len()).collect();
        order.sort_by(|&a, &b| {
            let (x, y) = (&self.segments[a], &self.segments[b]);
            x.log.cmp(&y.log).then(x.t0.total_cmp(&y.t0))
        });
        let mut keep = vec![false; self.segments.len()];
        let mut last: Option<(usize, f64)> = None;
        for i in order {
            let s = &self.segments[i];
            if last.is_none_or(|(log, t1)| log != s.log || s.t0 >= t1) {
                keep[i] = true;
                last = Some((s.log, s.t1));
            }
        }
        keep
    }

    /// At most `bound` of the segments `mask` selects, evenly spread over
    /// them in their order (every selected one when there are no more
    /// than `bound`): a long drive's evidence at a bounded cost.
    pub fn evenly_spread(mask: &[bool], bound: usize) -> Vec<bool> {
        let chosen: Vec<usize> = (0..mask.len()).filter(|&i| mask[i]).collect();
        if chosen.len() <= bound {
            return mask.to_vec();
        }
        let mut keep = vec![false; mask.len()];
        for k in 0..bound {
            // The k-th of `bound` equal shares of the selected ones.
            keep[chosen[k * chosen.len() / bound]] = true;
        }
        keep
    }

    /// The segments `keep` selects, each with a copy of its own steps, so
    /// that integrating the result walks only their steps, not the whole
    /// drive's. Their residuals are those of the originals.
    pub fn subset(&self, keep: &[bool]) -> Segments {
        let mut out = Segments {
            stats: self.stats,
            per_log: self.per_log.clone(),
            ..Default::default()
        };
        for (seg, _) in self.segments.iter().zip(keep).filter(|(_, &k)| k) {
            let start = out.steps.len();
            out.steps.extend_from_slice(self.steps_of(seg));
            out.segments.push(Segment {
                steps: start..out.steps.len(),
                ..seg.clone()
            });
        }
        out
    }

    /// The steps of one segment.
    pub fn steps_of(&self, seg: &Segment) -> &[Step] {
        &self.steps[seg.steps.clone()]
    }

    /// Keeps only the segments for which `keep` is true (steps stay shared).
    pub fn retain(&mut self, mut keep: impl FnMut(&Segment) -> bool) {
        self.segments.retain(|s| keep(s));
    }

    pub fn len(&self) -> usize {
        self.segments.len()
    }

    pub fn is_empty(&self) -> bool {
        self.segments.is_empty()
    }
}

#[cfg(test)]
mod tests;
