//! The 2 s prediction error on a position-only reference (GNSS fixes
//! without a heading).
//!
//! [`crate::prediction`] starts each 2 s prediction from the reference
//! pose, and a fix has no heading. Here each model (the parameters and the
//! no-slip model alike) finds its own start heading from the fixes: its
//! path, integrated from the tread speeds over the
//! [`PositionOnlySpec::window`] s before the start, is placed on the fixes
//! of that span by the rotation and translation that fit best
//! ([`Placement`]: the start heading profiled out). From the reference
//! position at the start (fixes interpolated), the model's motion over
//! [`PredictionSpec::horizon`] s, turned by that placement, lands at a
//! point; the error is its distance to the reference position then. It is
//! what a robot that knows only its past fixes and this model would
//! predict. A model that turns wrong bends its past path wrong, so it is
//! placed at a wrong heading and lands off.
//!
//! Frames: fixes east/north (ENU, m); times on the pose clock, s (the
//! wheel sample stamped `t` describes pose-clock time `t + offset`).

use terraslip_core::IcrParams;
use terraslip_io::DriveLog;

use crate::model::{trajectory_rate, RateSlopes};
use crate::prediction::{PredictionScore, PredictionSegment, PredictionSpec};
use crate::track::{gap_in, push_steps, Placement};

/// How starts are placed on a position-only reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionOnlySpec {
    /// Horizon, stride and the largest gap between wheel samples.
    pub prediction: PredictionSpec,
    /// Span of fixes before a start that places each model's path, s.
    pub window: f64,
    /// Fewest fixes in that span.
    pub min_fixes: usize,
    /// Largest gap between fixes (in the span and around the end), s.
    pub max_fix_gap: f64,
}

impl Default for PositionOnlySpec {
    fn default() -> Self {
        Self {
            prediction: PredictionSpec::default(),
            window: 20.0,
            min_fixes: 8,
            max_fix_gap: 2.0,
        }
    }
}

/// The 2 s prediction score of `params` on a position-only `log` against
/// the no-slip model of separation `width` (m), the wheels `offset` s
/// behind the pose clock. `None` when no start has its span of fixes.
pub fn score(
    log: &DriveLog,
    params: &IcrParams,
    width: f64,
    offset: f64,
    spec: &PositionOnlySpec,
) -> Option<PredictionScore> {
    let fixes = crate::track::fixes(log, f64::NEG_INFINITY, f64::INFINITY);
    let w = &log.wheels;
    let (first, last) = (fixes.first()?.0, fixes.last()?.0);
    if w.len() < 2 {
        return None;
    }
    let h = spec.prediction.horizon;
    let nominal = IcrParams::no_slip(width);
    let mut segments = Vec::new();
    let mut t = first + spec.window;
    while t + h <= last {
        if let Some((e, n)) = one_start(&fixes, log, params, &nominal, t, offset, spec) {
            segments.push(PredictionSegment {
                t,
                error: e,
                no_slip: n,
            });
        }
        t += spec.prediction.stride;
    }
    (!segments.is_empty()).then(|| {
        let mut s = PredictionScore::from_segments(spec.prediction, segments);
        s.profiled_window_s = Some(spec.window);
        s
    })
}

/// The reference position at `t`, m: fixes interpolated between
/// neighbours no further apart than `max_gap` s.
fn reference_at(fixes: &[(f64, f64, f64)], t: f64, max_gap: f64) -> Option<(f64, f64)> {
    let k = fixes.partition_point(|f| f.0 < t);
    let (a, b) = (fixes.get(k.checked_sub(1)?)?, fixes.get(k)?);
    if b.0 - a.0 > max_gap {
        return None;
    }
    let u = if b.0 > a.0 {
        (t - a.0) / (b.0 - a.0)
    } else {
        0.0
    };
    Some((a.1 + u * (b.1 - a.1), a.2 + u * (b.2 - a.2)))
}

/// The errors (m) of `params` and `nominal` from the start `t`.
fn one_start(
    fixes: &[(f64, f64, f64)],
    log: &DriveLog,
    params: &IcrParams,
    nominal: &IcrParams,
    t: f64,
    offset: f64,
    spec: &PositionOnlySpec,
) -> Option<(f64, f64)> {
    let h = spec.prediction.horizon;
    let past = &fixes
        [fixes.partition_point(|f| f.0 < t - spec.window)..fixes.partition_point(|f| f.0 <= t)];
    let times = || past.iter().map(|f| f.0).chain(std::iter::once(t));
    if past.len() < spec.min_fixes.max(2) || gap_in(times(), spec.max_fix_gap) {
        return None;
    }
    let start = reference_at(fixes, t, spec.max_fix_gap)?;
    let end = reference_at(fixes, t + h, spec.max_fix_gap)?;
    // Knots on the wheel clock: the past fixes, the end and every wheel
    // sample between.
    let w = &log.wheels;
    let (wa, wb) = (past[0].0 - offset, t + h - offset);
    if wa < w[0].t || wb > w[w.len() - 1].t {
        return None;
    }
    let inner = &w[w.partition_point(|s| s.t <= wa)..w.partition_point(|s| s.t < wb)];
    let span = std::iter::once(wa)
        .chain(inner.iter().map(|s| s.t))
        .chain(std::iter::once(wb));
    if gap_in(span, spec.prediction.max_gap) {
        return None;
    }
    let mut knots: Vec<f64> = past
        .iter()
        .map(|f| f.0 - offset)
        .chain(inner.iter().map(|s| s.t))
        .chain([t - offset, wb])
        .collect();
    knots.sort_by(f64::total_cmp);
    knots.dedup();
    let mut steps = Vec::with_capacity(knots.len());
    push_steps(w, &knots, &mut steps);
    let at: Vec<usize> = past
        .iter()
        .map(|f| knots.partition_point(|&x| x < f.0 - offset))
        .collect();
    let fix_xy: Vec<(f64, f64)> = past.iter().map(|f| (f.1, f.2)).collect();
    let k_start = knots.partition_point(|&x| x < t - offset);
    let error = |p: &IcrParams| {
        let path = trajectory_rate(p, &RateSlopes::NONE, &steps);
        let pts: Vec<(f64, f64)> = at.iter().map(|&k| (path[k].x, path[k].y)).collect();
        let (s, last) = (path.get(k_start)?, path.last()?);
        // The motion over the horizon, turned by the placement's angle,
        // from the reference position at the start.
        let (sn, cs) = Placement::fit(&pts, &fix_xy).angle.sin_cos();
        let (dx, dy) = (last.x - s.x, last.y - s.y);
        let (x, y) = (start.0 + cs * dx - sn * dy, start.1 + sn * dx + cs * dy);
        Some((x - end.0).hypot(y - end.1))
    };
    Some((error(params)?, error(nominal)?))
}
