//! The prediction score computed as the drive streams by: starts opened
//! and scored with only the rows still needed kept.

use std::collections::VecDeque;

use terraslip_core::IcrParams;
use terraslip_io::{PoseObs, WheelSample};

use crate::model::RateSlopes;
use crate::prediction::{
    gap_free, heading_at, interpolate_position, predict, predict_with, warmup_for, Position,
    PredictionScore, PredictionSegment, PredictionSpec, Timed,
};
use crate::segment::accelerations;

/// [`score`] computed as the drive streams by: give the pose rows and the
/// wheels rows in time order, each pose row before the wheels rows stamped
/// after it (as the estimator merges them). Only the wheels and reference
/// poses of the starts still open (about `horizon + max_gap` s) are kept,
/// so memory does not grow with the drive beyond one segment per `stride`.
#[derive(Debug, Clone)]
pub struct PredictionStream {
    spec: PredictionSpec,
    no_slip: IcrParams,
    /// Reference positions from the last one before the oldest open start.
    refs: VecDeque<Position>,
    /// Reference headings (unwrapped) likewise.
    headings: VecDeque<(f64, f64)>,
    /// The estimate's heading at the latest wheels row, rad.
    estimate_heading: Option<f64>,
    estimate_headings: usize,
    /// Time of the first and of the latest reference pose.
    r_first: Option<f64>,
    r_max: f64,
    /// Wheels rows after the oldest open start, and the latest row's time.
    wheels: VecDeque<WheelSample>,
    w_max: f64,
    /// The next start to open (from the first wheels row on).
    next_start: Option<f64>,
    /// The first wheels row's time.
    first: Option<f64>,
    /// Starts before `spec.warmup` still to open, kept for a drive too
    /// short for it ([`warmup_for`]).
    early: VecDeque<f64>,
    /// Open starts, the parameters (and clock offset) in effect at each,
    /// the estimate's heading then, and whether it is an early start.
    open: VecDeque<(f64, Option<Timed>, Option<f64>, bool)>,
    segments: Vec<PredictionSegment>,
    /// Scored early starts, each with whether its start heading was the
    /// estimate's.
    early_segments: Vec<(PredictionSegment, bool)>,
}

impl PredictionStream {
    /// Wheels rows, reference poses and open starts held in memory.
    #[cfg(test)]
    pub(crate) fn held(&self) -> usize {
        self.wheels.len() + self.refs.len() + self.open.len()
    }

    /// Scores against the no-slip model of `track_width` (m).
    pub fn new(track_width: f64, spec: PredictionSpec) -> Self {
        Self {
            spec,
            no_slip: IcrParams::no_slip(track_width),
            refs: VecDeque::new(),
            headings: VecDeque::new(),
            estimate_heading: None,
            estimate_headings: 0,
            r_first: None,
            r_max: f64::NEG_INFINITY,
            wheels: VecDeque::new(),
            w_max: f64::NEG_INFINITY,
            next_start: None,
            first: None,
            early: VecDeque::new(),
            open: VecDeque::new(),
            segments: Vec::new(),
            early_segments: Vec::new(),
        }
    }

    fn valid(&self) -> bool {
        self.spec.horizon > 0.0 && self.spec.stride > 0.0
    }

    /// The next pose row: its position and its heading, each when present.
    pub fn pose(&mut self, p: &PoseObs) {
        if let Some(y) = p.yaw.filter(|y| y.is_finite()) {
            let y = match self.headings.back() {
                Some(&(_, prev)) => prev + terraslip_core::angle::wrap(y - prev),
                None => y,
            };
            self.headings.push_back((p.t, y));
        }
        if let (Some(e), Some(n)) = (p.east, p.north) {
            self.refs.push_back((p.t, e, n));
            self.r_first.get_or_insert(p.t);
            self.r_max = p.t;
        }
    }

    /// The estimate's heading (rad, ENU) after the latest wheels row: the
    /// start heading of the starts opened at the next row when the
    /// reference has none there.
    pub fn estimate_heading(&mut self, yaw: f64) {
        self.estimate_heading = yaw.is_finite().then_some(yaw);
    }

    /// The next wheels row; `params_at(t)` gives the parameters and clock
    /// offset in effect at a start `t` earlier than this row (called once
    /// per start).
    pub fn wheels(&mut self, w: WheelSample, params_at: &mut dyn FnMut(f64) -> Option<Timed>) {
        if !self.valid() {
            return;
        }
        if self.first.is_none() {
            self.first = Some(w.t);
            // The grid of starts continued back to one stride after the
            // first row.
            let (warmup, stride) = (self.spec.warmup, self.spec.stride);
            let k = ((warmup - stride) / stride).floor().max(0.0) as usize;
            self.early = (1..=k)
                .rev()
                .map(|j| w.t + warmup - j as f64 * stride)
                .collect();
        }
        while let Some(t) = self.early.front().copied().filter(|&t| t < w.t) {
            self.early.pop_front();
            self.open
                .push_back((t, params_at(t), self.estimate_heading, true));
        }
        let mut next = self.next_start.unwrap_or(w.t + self.spec.warmup);
        while next < w.t {
            self.open
                .push_back((next, params_at(next), self.estimate_heading, false));
            next += self.spec.stride;
        }
        self.next_start = Some(next);
        self.wheels.push_back(w);
        self.w_max = w.t;
        self.close(false);
    }

    /// The score of the whole drive; `None` as for [`score`].
    pub fn finish(mut self) -> Option<PredictionScore> {
        self.close(true);
        let first = self.first?;
        let warmup = warmup_for(&self.spec, self.w_max - first);
        let kept: Vec<(PredictionSegment, bool)> = self
            .early_segments
            .into_iter()
            .filter(|s| s.0.t - first >= warmup - 1e-9 * warmup.abs().max(1.0))
            .collect();
        let estimate_headings = kept.iter().filter(|s| s.1).count();
        let mut segments: Vec<PredictionSegment> = kept.into_iter().map(|s| s.0).collect();
        segments.append(&mut self.segments);
        if segments.is_empty() {
            return None;
        }
        let mut score = PredictionScore::from_segments(self.spec, segments);
        score.warmup_s = warmup;
        score.estimate_headings = self.estimate_headings + estimate_headings;
        Some(score)
    }

    /// Scores or drops the open starts that can be decided (all of them at
    /// the `end`), oldest first, and forgets what no open start needs.
    fn close(&mut self, end: bool) {
        let (h, gap) = (self.spec.horizon, self.spec.max_gap);
        while let Some(&(t, timed, heading, early)) = self.open.front() {
            // The start and end on the pose stream's clock.
            let c = timed.map_or(0.0, |p| p.clock_offset);
            let (r0, r1) = (t + c, t + h + c);
            let decidable = r0 <= self.r_max - h && t <= self.w_max - h;
            let covered = self.r_max >= r1 && self.w_max >= t + h;
            if end || covered && decidable {
                self.open.pop_front();
                if decidable {
                    self.score_start(t, timed, heading, early);
                }
                continue;
            }
            // Every later pose is stamped after the latest wheels row: a
            // start with no reference at or before it cannot be
            // interpolated, and one still waiting for its end across a gap
            // longer than `max_gap` cannot be gap-free.
            let unanchored = self.r_first.is_none_or(|r| r > r0) && self.w_max >= r0;
            let broken = self.r_max < r1 && self.w_max - self.r_max > gap;
            if !(unanchored || broken) {
                break;
            }
            self.open.pop_front();
        }
        let earliest = self
            .open
            .iter()
            .map(|o| o.1.map_or(0.0, |p| p.clock_offset))
            .fold(0.0f64, f64::min);
        let oldest = match (self.open.front(), self.next_start) {
            (Some(&(t, _, _, _)), _) | (None, Some(t)) => t,
            (None, None) => return,
        };
        while self.refs.len() >= 2 && self.refs[1].0 < oldest + earliest {
            self.refs.pop_front();
        }
        while self.headings.len() >= 2 && self.headings[1].0 < oldest + earliest {
            self.headings.pop_front();
        }
        while self.wheels.front().is_some_and(|w| w.t <= oldest) {
            self.wheels.pop_front();
        }
    }

    /// One start, as [`score`] defines it, on the kept poses and wheels
    /// (which hold everything it reads).
    fn score_start(&mut self, t: f64, timed: Option<Timed>, estimate: Option<f64>, early: bool) {
        let Some(Timed {
            params: p,
            clock_offset: c,
            slopes,
        }) = timed
        else {
            return;
        };
        let (r0, r1) = (t + c, t + self.spec.horizon + c);
        let r = self.refs.make_contiguous();
        if !gap_free(r, |p| p.0, r0, r1, self.spec.max_gap) {
            return;
        }
        let reference = heading_at(self.headings.make_contiguous(), r0, self.spec.max_gap);
        let Some(yaw) = reference.or(estimate) else {
            return;
        };
        let (Some(a), Some(b)) = (interpolate_position(r, r0), interpolate_position(r, r1)) else {
            return;
        };
        let a = (a.0, a.1, yaw);
        let wheels = self.wheels.make_contiguous();
        let t1 = t + self.spec.horizon;
        let (e, n) = if slopes == RateSlopes::NONE {
            predict(wheels, &p, t, t1, a)
        } else {
            // The tread accelerations of the kept rows (those near the
            // window's ends from the rows kept on each side).
            let acc = accelerations(wheels);
            let at = |w: &WheelSample| {
                let i = wheels.partition_point(|s| s.t < w.t).min(acc.len() - 1);
                slopes.twist(&p, w.v_left, w.v_right, acc[i])
            };
            predict_with(wheels, &at, t, t1, a)
        };
        let (en, nn) = predict(wheels, &self.no_slip, t, t1, a);
        let segment = PredictionSegment {
            t,
            error: (e - b.0).hypot(n - b.1),
            no_slip: (en - b.0).hypot(nn - b.1),
        };
        if early {
            self.early_segments.push((segment, reference.is_none()));
        } else {
            self.estimate_headings += usize::from(reference.is_none());
            self.segments.push(segment);
        }
    }
}

/// Scores the parameters `params_at(t)` (those in effect at `t`) on the
/// drive, the pose stamps read as they are; `None` without a pose
/// reference with positions (and headings, or the estimate's) or wheels, or when no segment qualifies.
pub fn score(
    wheels: &[WheelSample],
    pose: &[PoseObs],
    track_width: f64,
    params_at: &dyn Fn(f64) -> Option<IcrParams>,
    spec: PredictionSpec,
) -> Option<PredictionScore> {
    score_timed(
        wheels,
        pose,
        track_width,
        &|t| params_at(t).map(Timed::on_time),
        spec,
    )
}

/// [`score`] with each start's own clock offset of the pose stream.
pub fn score_timed(
    wheels: &[WheelSample],
    pose: &[PoseObs],
    track_width: f64,
    params_at: &dyn Fn(f64) -> Option<Timed>,
    spec: PredictionSpec,
) -> Option<PredictionScore> {
    let mut stream = PredictionStream::new(track_width, spec);
    let mut k = 0;
    for w in wheels {
        while let Some(p) = pose.get(k).filter(|p| p.t <= w.t) {
            stream.pose(p);
            k += 1;
        }
        stream.wheels(*w, &mut |t| params_at(t));
    }
    for p in &pose[k..] {
        stream.pose(p);
    }
    stream.finish()
}
