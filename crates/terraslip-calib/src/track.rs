//! Position-only references (GNSS fixes without a heading): the model's path
//! over a window of fixes, compared with the fixes up to a rigid motion.
//!
//! A fix carries no heading, so the increment between two fixes cannot be
//! put in the frame of the segment start, and over one second a fix's
//! metre-level noise swamps the motion. A [`Window`] instead takes every
//! fix over [`TrackConfig::window`] s (20 s by default). The model's path,
//! integrated from the tread speeds, is fitted onto the fixes by the rigid
//! motion (rotation and translation) that brings it closest: the unknown
//! start heading and the noisy start position are nuisance parameters,
//! profiled out in closed form (2D Procrustes: the rotation angle is the
//! argument of the summed dot and cross products of the centred point sets).
//! What remains to compare is the path's shape: its length (the speed
//! factors), its curvature against the tread speed difference (the spread)
//! and its sideways drift in turns (`x_c`). Only windows that turn tell the
//! spread; a straight window tells the speed factors.
//!
//! Frames: fixes east/north (ENU, m); the model's path in the frame of the
//! window start (REP-103: x forward, y left). Times on the pose clock, s.

use std::ops::Range;

use terraslip_core::IcrParams;
use terraslip_io::{DriveLog, WheelSample};

use crate::model::{trajectory_rate, RateSlopes};
use crate::segment::{wheel_at, Step};

/// How a drive with a position-only reference is cut into windows.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackConfig {
    /// Length of a window, s. Long enough that the path (metres) stands
    /// out of the fixes' noise (about 1 m) and bends in turns.
    pub window: f64,
    /// Time between window starts, s (half a window: each fix is in two).
    pub stride: f64,
    /// Fewest fixes in a window.
    pub min_fixes: usize,
    /// Largest gap between fixes inside a window, s.
    pub max_fix_gap: f64,
    /// Largest gap between wheel samples inside a window, s.
    pub max_wheel_gap: f64,
    /// A window whose treads travel less than this (m) is stationary.
    pub min_travel: f64,
    /// Only fixes with `t_min <= t <= t_max` (pose clock, s) are used.
    pub t_min: f64,
    pub t_max: f64,
}

impl Default for TrackConfig {
    fn default() -> Self {
        Self {
            window: 20.0,
            stride: 10.0,
            min_fixes: 8,
            max_fix_gap: 2.0,
            max_wheel_gap: 0.5,
            min_travel: 2.0,
            t_min: f64::NEG_INFINITY,
            t_max: f64::INFINITY,
        }
    }
}

/// The fixes of one window and the wheel steps between them.
#[derive(Debug, Clone, PartialEq)]
pub struct Window {
    /// Index of the log (order given to [`Tracks::build`]).
    pub log: usize,
    /// First and last fix, s (pose clock).
    pub t0: f64,
    pub t1: f64,
    /// Terrain label in force over the whole window, if the log has labels.
    pub terrain: Option<String>,
    /// This window's steps in [`Tracks::steps`].
    pub steps: Range<usize>,
    /// Each fix: the number of steps from the window start to it, and its
    /// east and north (m) relative to the first fix.
    pub fixes: Vec<(usize, f64, f64)>,
    /// `int (v_r - v_l) dt` over the window, m: the no-slip turn times the
    /// spread.
    pub int_diff: f64,
}

/// Why fixes or windows were not used, counted.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TrackStats {
    /// Fixes that repeat the previous one exactly (a held fix).
    pub held_fixes: usize,
    /// Windows with too few fixes, a gap in the fixes or the wheels, or
    /// outside the wheels' time span.
    pub gaps: usize,
    /// Windows with (almost) no tread motion.
    pub stationary: usize,
    /// Windows during which the terrain label changes.
    pub terrain_change: usize,
}

/// All usable windows of one or more logs, their steps in one buffer.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tracks {
    pub windows: Vec<Window>,
    pub steps: Vec<Step>,
    pub stats: TrackStats,
}

/// Whether a log's reference is position-only: it has positions and no
/// heading on any row.
pub fn position_only(log: &DriveLog) -> bool {
    log.pose.iter().all(|p| p.yaw.is_none())
        && log
            .pose
            .iter()
            .any(|p| p.east.is_some() && p.north.is_some())
}

/// The fixes `(t, east, north)` (s, m) of `log`'s pose rows with a finite
/// position and `t_min <= t <= t_max`, in the log's order.
pub fn fixes(log: &DriveLog, t_min: f64, t_max: f64) -> Vec<(f64, f64, f64)> {
    log.pose
        .iter()
        .filter_map(|p| Some((p.t, p.east?, p.north?)))
        .filter(|f| f.0.is_finite() && f.1.is_finite() && f.2.is_finite())
        .filter(|f| f.0 >= t_min && f.0 <= t_max)
        .collect()
}

impl Tracks {
    /// The windows of `logs`, each log's wheel clock shifted by its offset
    /// (s): the wheel sample stamped `t` describes pose-clock time
    /// `t + offset`.
    pub fn build(logs: &[&DriveLog], offsets: &[f64], cfg: &TrackConfig) -> Self {
        let mut out = Tracks::default();
        for (i, log) in logs.iter().enumerate() {
            out.push_log(i, log, offsets.get(i).copied().unwrap_or(0.0), cfg);
        }
        out
    }

    fn push_log(&mut self, li: usize, log: &DriveLog, offset: f64, cfg: &TrackConfig) {
        let mut fixes: Vec<(f64, f64, f64)> = Vec::with_capacity(log.pose.len());
        for p in &log.pose {
            let (Some(e), Some(n)) = (p.east, p.north) else {
                continue;
            };
            if !(p.t.is_finite() && e.is_finite() && n.is_finite()) {
                continue;
            }
            if fixes.last().is_some_and(|f| f.1 == e && f.2 == n) {
                self.stats.held_fixes += 1;
                continue;
            }
            fixes.push((p.t, e, n));
        }
        fixes.sort_by(|a, b| a.0.total_cmp(&b.0));
        let w = &log.wheels;
        if w.len() < 2 || fixes.len() < 2 {
            return;
        }
        let mut i0 = fixes.partition_point(|f| f.0 < cfg.t_min);
        while i0 < fixes.len() {
            let t0 = fixes[i0].0;
            let end = (t0 + cfg.window).min(cfg.t_max);
            let i1 = fixes.partition_point(|f| f.0 <= end);
            let last_window = i1 >= fixes.len() || fixes[i1].0 > cfg.t_max;
            self.push_window(li, log, &fixes[i0..i1], offset, cfg);
            if last_window {
                break;
            }
            let next = fixes.partition_point(|f| f.0 < t0 + cfg.stride);
            i0 = next.max(i0 + 1);
        }
    }

    fn push_window(
        &mut self,
        li: usize,
        log: &DriveLog,
        fixes: &[(f64, f64, f64)],
        offset: f64,
        cfg: &TrackConfig,
    ) {
        let w = &log.wheels;
        if fixes.len() < cfg.min_fixes.max(2) || gap_in(fixes.iter().map(|f| f.0), cfg.max_fix_gap)
        {
            self.stats.gaps += 1;
            return;
        }
        let (t0, t1) = (fixes[0].0, fixes[fixes.len() - 1].0);
        let (wa, wb) = (t0 - offset, t1 - offset);
        if wa < w[0].t || wb > w[w.len() - 1].t {
            self.stats.gaps += 1;
            return;
        }
        let k0 = w.partition_point(|s| s.t <= wa);
        let k1 = w.partition_point(|s| s.t < wb);
        let inner = || w[k0..k1.max(k0)].iter().map(|s| s.t);
        let span = std::iter::once(wa)
            .chain(inner())
            .chain(std::iter::once(wb));
        if gap_in(span, cfg.max_wheel_gap) {
            self.stats.gaps += 1;
            return;
        }
        let terrain = if log.terrain.is_empty() {
            None
        } else {
            let la = log.terrain_at(t0);
            if la != log.terrain_at(t1) || log.terrain.iter().any(|l| l.t > t0 && l.t < t1) {
                self.stats.terrain_change += 1;
                return;
            }
            la.map(str::to_string)
        };
        // Knots on the wheel clock: every fix and every wheel sample between.
        let mut knots: Vec<f64> = fixes.iter().map(|f| f.0 - offset).chain(inner()).collect();
        knots.sort_by(f64::total_cmp);
        knots.dedup();
        let base = self.steps.len();
        let (travel, int_diff) = push_steps(w, &knots, &mut self.steps);
        if travel < cfg.min_travel {
            self.steps.truncate(base);
            self.stats.stationary += 1;
            return;
        }
        let (e0, n0) = (fixes[0].1, fixes[0].2);
        let fixes = fixes
            .iter()
            .map(|f| {
                let k = knots.partition_point(|&x| x < f.0 - offset);
                (k, f.1 - e0, f.2 - n0)
            })
            .collect();
        self.windows.push(Window {
            log: li,
            t0,
            t1,
            terrain,
            steps: base..self.steps.len(),
            fixes,
            int_diff,
        });
    }

    /// Keeps only the windows for which `keep` is true (steps stay).
    pub fn retain(&mut self, keep: impl FnMut(&Window) -> bool) {
        self.windows.retain(keep);
    }

    /// How many windows cover an instant on average (2 with the default
    /// half-window stride): the count of independent windows is the count
    /// over this.
    pub fn coverage(&self) -> f64 {
        crate::segment::coverage(self.windows.iter().map(|w| (w.log, w.t0, w.t1)))
    }
}

/// One step per interval between `knots` (wheel clock, sorted), the tread
/// speeds the trapezoid means of the wheels interpolated at its ends,
/// appended to `steps`. Returns the treads' travel `int (|v_l| + |v_r|)/2 dt`
/// and `int (v_r - v_l) dt`, m.
pub fn push_steps(w: &[WheelSample], knots: &[f64], steps: &mut Vec<Step>) -> (f64, f64) {
    let (mut hint, mut travel, mut int_diff) = (0usize, 0.0, 0.0);
    let Some(&first) = knots.first() else {
        return (0.0, 0.0);
    };
    let mut prev = wheel_at(w, first, &mut hint);
    for p in knots.windows(2) {
        let next = wheel_at(w, p[1], &mut hint);
        let dt = p[1] - p[0];
        let (v_left, v_right) = (0.5 * (prev.0 + next.0), 0.5 * (prev.1 + next.1));
        travel += 0.5 * (v_left.abs() + v_right.abs()) * dt;
        int_diff += (v_right - v_left) * dt;
        steps.push(Step {
            dt,
            v_left,
            v_right,
            acc: 0.0,
        });
        prev = next;
    }
    (travel, int_diff)
}

/// Whether consecutive times of `t` are ever more than `max` apart.
pub fn gap_in(t: impl Iterator<Item = f64>, max: f64) -> bool {
    let mut prev: Option<f64> = None;
    for x in t {
        if prev.is_some_and(|p| x - p > max) {
            return true;
        }
        prev = Some(x);
    }
    false
}

/// The residuals of one window (fix minus the fitted path, east and north
/// alternating, m) appended to `out`, the path of `p` placed on the fixes
/// by the best rigid motion. Returns the rotation (rad): the start heading
/// the fixes imply.
pub fn window_residuals(p: &IcrParams, tracks: &Tracks, win: &Window, out: &mut Vec<f64>) -> f64 {
    let path = trajectory_rate(p, &RateSlopes::NONE, &tracks.steps[win.steps.clone()]);
    let q: Vec<(f64, f64)> = win
        .fixes
        .iter()
        .map(|&(k, ..)| path.get(k).map_or((f64::NAN, f64::NAN), |s| (s.x, s.y)))
        .collect();
    let fixes: Vec<(f64, f64)> = win.fixes.iter().map(|f| (f.1, f.2)).collect();
    let place = Placement::fit(&q, &fixes);
    for (s, f) in q.iter().zip(&fixes) {
        let (x, y) = place.apply(*s);
        out.push(f.0 - x);
        out.push(f.1 - y);
    }
    place.angle
}

/// The rotation and translation that bring a path's points closest to
/// fixes (2D Procrustes, no scale): `fix ≈ R(angle) (point - from) + to`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// rad
    pub angle: f64,
    /// Centroid of the path's points, m (path frame).
    pub from: (f64, f64),
    /// Centroid of the fixes, m (east, north).
    pub to: (f64, f64),
}

impl Placement {
    /// The best placement of `points` on `fixes` (paired, same length):
    /// the angle is the argument of the summed dot and cross products of
    /// the centred sets.
    pub fn fit(points: &[(f64, f64)], fixes: &[(f64, f64)]) -> Self {
        let n = points.len().max(1) as f64;
        let centroid = |v: &[(f64, f64)]| {
            v.iter()
                .fold((0.0, 0.0), |a, s| (a.0 + s.0 / n, a.1 + s.1 / n))
        };
        let (from, to) = (centroid(points), centroid(fixes));
        let (mut dot, mut cross) = (0.0, 0.0);
        for (s, f) in points.iter().zip(fixes) {
            let (ax, ay) = (s.0 - from.0, s.1 - from.1);
            let (bx, by) = (f.0 - to.0, f.1 - to.1);
            dot += ax * bx + ay * by;
            cross += ax * by - ay * bx;
        }
        Self {
            angle: cross.atan2(dot),
            from,
            to,
        }
    }

    /// A path point placed on the fixes, m (east, north).
    pub fn apply(&self, p: (f64, f64)) -> (f64, f64) {
        let (sn, cs) = self.angle.sin_cos();
        let (ax, ay) = (p.0 - self.from.0, p.1 - self.from.1);
        (self.to.0 + cs * ax - sn * ay, self.to.1 + sn * ax + cs * ay)
    }
}

/// Residuals of the windows with `active[i]`, in order, and where each
/// window's run of them starts (one more entry: the end).
pub(crate) fn residuals(p: &IcrParams, tracks: &Tracks, active: &[bool]) -> (Vec<f64>, Vec<usize>) {
    let mut r = Vec::new();
    let mut at = Vec::with_capacity(tracks.windows.len() + 1);
    for (w, _) in tracks.windows.iter().zip(active).filter(|(_, &a)| a) {
        at.push(r.len());
        window_residuals(p, tracks, w, &mut r);
    }
    at.push(r.len());
    (r, at)
}

/// Sum of squared residuals (m^2) of the windows with `active[i]`.
pub fn cost(p: &IcrParams, tracks: &Tracks, active: &[bool]) -> f64 {
    residuals(p, tracks, active).0.iter().map(|x| x * x).sum()
}

/// Root mean square residual per axis of each window (m).
pub fn window_rms(p: &IcrParams, tracks: &Tracks) -> Vec<f64> {
    let mut r = Vec::new();
    tracks
        .windows
        .iter()
        .map(|w| {
            r.clear();
            window_residuals(p, tracks, w, &mut r);
            (r.iter().map(|x| x * x).sum::<f64>() / r.len().max(1) as f64).sqrt()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::track_fit::{fit, DIFF_DRIVE};

    /// A window of 20 fixes along the path of `p` over a left turn, the
    /// path rotated by `th` and moved by `(e, n)`.
    fn window_on(p: &IcrParams, th: f64, e: f64, n: f64) -> Tracks {
        let steps: Vec<Step> = (0..200)
            .map(|k| Step {
                dt: 0.1,
                v_left: 0.8,
                v_right: if k < 100 { 0.8 } else { 1.2 },
                acc: 0.0,
            })
            .collect();
        let path = trajectory_rate(p, &RateSlopes::NONE, &steps);
        let (s, c) = th.sin_cos();
        let fixes: Vec<(usize, f64, f64)> = (0..=200)
            .step_by(10)
            .map(|k| {
                let (x, y) = (path[k].x, path[k].y);
                (k, c * x - s * y + e, s * x + c * y + n)
            })
            .collect();
        let (e0, n0) = (fixes[0].1, fixes[0].2);
        Tracks {
            windows: vec![Window {
                log: 0,
                t0: 0.0,
                t1: 20.0,
                terrain: None,
                steps: 0..steps.len(),
                fixes: fixes.iter().map(|f| (f.0, f.1 - e0, f.2 - n0)).collect(),
                int_diff: 4.0,
            }],
            steps,
            stats: TrackStats::default(),
        }
    }

    #[test]
    fn the_start_heading_and_position_are_profiled_out() {
        let p = IcrParams::no_slip(0.6);
        let t = window_on(&p, 0.7, 3.0, -2.0);
        let mut r = Vec::new();
        let th = window_residuals(&p, &t, &t.windows[0], &mut r);
        assert!((th - 0.7).abs() < 1e-9, "{th}");
        assert!(r.iter().all(|x| x.abs() < 1e-9), "{r:?}");
        // Another spread bends the path otherwise: no rigid motion fits.
        let q = IcrParams::no_slip(0.5);
        r.clear();
        window_residuals(&q, &t, &t.windows[0], &mut r);
        assert!(r.iter().map(|x| x * x).sum::<f64>().sqrt() > 0.1, "{r:?}");
    }

    #[test]
    fn the_fit_finds_the_spread_of_a_turning_window() {
        let truth = IcrParams {
            y_l: 0.35,
            y_r: -0.35,
            x_c: 0.0,
            alpha_l: 0.9,
            alpha_r: 0.9,
        };
        let t = window_on(&truth, -1.2, 10.0, 5.0);
        let f = fit(&t, &IcrParams::no_slip(0.555), &DIFF_DRIVE, &[true]).unwrap();
        assert!((f.params.spread() - 0.7).abs() < 1e-4, "{:?}", f.params);
        assert!((f.params.alpha_l - 0.9).abs() < 1e-4, "{:?}", f.params);
    }
}
