//! The course check: how far the tread speeds turn the robot against the
//! course of a position-only reference (GNSS fixes), over long baselines.
//!
//! A fix carries no heading, but a straight stretch of fixes does: the
//! direction the robot moved along it (its course). Between two straight
//! stretches far apart in turning, the course change is the true heading
//! change, whatever the antenna's lever arm (a constant offset in the body
//! frame moves a straight line sideways, it does not turn it) and nearly
//! whatever the wheel/pose clock offset (the baseline starts and ends where
//! the robot does not turn). The heading change the tread speeds give under
//! the odometry of separation `S`, `int (a_r v_r - a_l v_l) dt / S` with
//! the speed factors' ratios `a = alpha / mean alpha` (1 and 1 when the
//! two treads roll alike, as `scripts/ros2-course-check.py` assumes), divided
//! by it is the **turn factor**: `spread / (mean speed factor * S)` for the
//! ICR model, what a `diff_drive_controller` of separation `S` with its
//! radius multipliers in the ratio of the speed factors gets wrong (0.98:
//! the odometry turns 2 % less than the robot, the separation should be
//! 0.98 S). The ratio matters: treads rolling 2 % apart drive straight with
//! `v_r != v_l`, and over a long baseline that difference reads as a turn.
//!
//! Straight stretches are found from the treads (their odometry turn under
//! [`CourseConfig::max_turn`] over [`CourseConfig::stretch`] s), their
//! course is the direction of the least-squares velocity of their fixes,
//! and the factor is the least-squares gain over every pair of stretches at
//! least [`CourseConfig::min_baseline`] rad of turning apart. Pairs share
//! stretches, so the 1-sigma is the jackknife over stretches (each left out
//! with all its pairs), not the pairs' count.
//!
//! Frames: fixes east/north (ENU, m), course counter-clockwise from east
//! (rad). Times on the pose clock, s.

use std::f64::consts::PI;

use terraslip_io::DriveLog;

/// The treads' asymmetry is fitted when it is at least this many 1-sigma
/// from 0, else held at 0.
pub const ASYMMETRY_SIGMAS: f64 = 2.0;

/// How straight stretches and their pairs are chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct CourseConfig {
    /// Length of a straight stretch, s.
    pub stretch: f64,
    /// Largest odometry turn over a stretch, rad.
    pub max_turn: f64,
    /// Shortest distance between a stretch's first and last fix, m.
    pub min_chord: f64,
    /// Fewest fixes in a stretch.
    pub min_fixes: usize,
    /// Smallest odometry turn between the midpoints of a pair, rad.
    pub min_baseline: f64,
    /// Only fixes with `t_min <= t <= t_max` (pose clock, s).
    pub t_min: f64,
    pub t_max: f64,
}

impl Default for CourseConfig {
    fn default() -> Self {
        Self {
            stretch: 10.0,
            max_turn: 0.06,
            min_chord: 7.0,
            min_fixes: 8,
            min_baseline: 2.5,
            t_min: f64::NEG_INFINITY,
            t_max: f64::INFINITY,
        }
    }
}

/// A straight stretch of fixes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stretch {
    /// Index of the log.
    pub log: usize,
    /// Midpoint, s (pose clock).
    pub t_mid: f64,
    /// Direction of travel, rad counter-clockwise from east.
    pub course: f64,
}

/// One pair of stretches: the course change, wrapped to (-pi, pi] (rad),
/// the no-slip turn `int (v_r - v_l) dt / S` and the travel
/// `int (v_r + v_l) dt / S` between the midpoints (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pair {
    pub a: usize,
    pub b: usize,
    pub course: f64,
    pub treads: f64,
    pub travel: f64,
}

impl Pair {
    /// The course change unwrapped to the one nearest `turn` (rad).
    pub fn course_near(&self, turn: f64) -> f64 {
        self.course - 2.0 * PI * ((self.course - turn) / (2.0 * PI)).round()
    }
}

/// The turn factor the fixes' course supports.
#[derive(Debug, Clone, PartialEq)]
pub struct CourseCheck {
    /// Tread turn over course turn (`spread / (mean speed factor * S)`).
    pub turn_factor: f64,
    /// Its 1-sigma (jackknife over stretches).
    pub std: f64,
    /// The treads' speed factor asymmetry
    /// `(alpha_r - alpha_l) / (alpha_r + alpha_l)` with its 1-sigma, when
    /// the pairs tell it from 0 (at least [`ASYMMETRY_SIGMAS`] sigma);
    /// `None`: held at 0 (equal treads).
    pub asymmetry: Option<(f64, f64)>,
    /// The asymmetry and its 1-sigma as fitted, held or not.
    pub asymmetry_free: (f64, f64),
    pub stretches: Vec<Stretch>,
    pub pairs: Vec<Pair>,
}

/// The odometry a course is compared with: separation `s` (m) and the
/// speed factors `(alpha_l, alpha_r)` whose ratio weighs the treads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Odometry {
    pub separation: f64,
    pub alpha: (f64, f64),
}

impl Odometry {
    /// Weights of (v_left, v_right) in the turn: the speed factors over
    /// their mean.
    fn weights(&self) -> (f64, f64) {
        let m = 0.5 * (self.alpha.0 + self.alpha.1);
        if m.is_finite() && self.alpha.0.is_finite() && self.alpha.1.is_finite() && m != 0.0 {
            (self.alpha.0 / m, self.alpha.1 / m)
        } else {
            (1.0, 1.0)
        }
    }
}

/// Straight stretches of one log (index `li`; driven forwards or
/// backwards: the course is taken as the heading), the wheel clock shifted by
/// `offset` s (the wheel sample stamped `t` describes pose-clock time
/// `t + offset`), turns measured by `odo`.
pub fn stretches(
    li: usize,
    log: &DriveLog,
    offset: f64,
    odo: &Odometry,
    cfg: &CourseConfig,
) -> Vec<Stretch> {
    let fixes = crate::track::fixes(log, cfg.t_min, cfg.t_max);
    let mut out = Vec::new();
    let (Some(first), Some(last)) = (fixes.first(), fixes.last()) else {
        return out;
    };
    let (t_end, mut t) = (last.0, first.0);
    while t + cfg.stretch <= t_end {
        let i0 = fixes.partition_point(|f| f.0 < t);
        let i1 = fixes.partition_point(|f| f.0 <= t + cfg.stretch);
        let run = &fixes[i0..i1];
        let ok = run.len() >= cfg.min_fixes.max(2) && {
            let (a, b) = (run[0], run[run.len() - 1]);
            let turn = odometry_turn(log, a.0 - offset, b.0 - offset, odo);
            (b.1 - a.1).hypot(b.2 - a.2) >= cfg.min_chord
                && turn.is_some_and(|x| x.abs() < cfg.max_turn)
        };
        // Driving backwards, the course is the heading plus pi.
        let reverse = || mean_speed(log, run[0].0 - offset, run[run.len() - 1].0 - offset) < 0.0;
        match ok.then(|| velocity_direction(run)).flatten() {
            Some(course) => {
                let course = match reverse() {
                    true => terraslip_core::angle::wrap(course + PI),
                    false => course,
                };
                out.push(Stretch {
                    log: li,
                    t_mid: t + 0.5 * cfg.stretch,
                    course,
                });
                t += cfg.stretch;
            }
            None => t += 1.0,
        }
    }
    out
}

/// The direction of the least-squares velocity of `fixes` (t, e, n), rad.
fn velocity_direction(fixes: &[(f64, f64, f64)]) -> Option<f64> {
    let n = fixes.len() as f64;
    let tm = fixes.iter().map(|f| f.0).sum::<f64>() / n;
    let (mut stt, mut ste, mut stn) = (0.0, 0.0, 0.0);
    for f in fixes {
        let dt = f.0 - tm;
        stt += dt * dt;
        ste += dt * f.1;
        stn += dt * f.2;
    }
    (stt > 0.0).then(|| stn.atan2(ste))
}

/// The mean of `(v_left + v_right) / 2` over the wheel samples in `[a, b]`
/// (wheel clock), m/s; 0 without samples.
fn mean_speed(log: &DriveLog, a: f64, b: f64) -> f64 {
    let w = &log.wheels;
    let run = &w[w.partition_point(|x| x.t < a)..w.partition_point(|x| x.t <= b)];
    let sum: f64 = run.iter().map(|x| 0.5 * (x.v_left + x.v_right)).sum();
    sum / run.len().max(1) as f64
}

/// The odometry's turn `int (a_r v_r - a_l v_l) dt / S` over `[a, b]` on
/// the wheel clock (trapezoids, the speeds interpolated at the ends), rad;
/// `None` outside the wheels' span or across a gap over 0.5 s.
pub fn odometry_turn(log: &DriveLog, a: f64, b: f64, odo: &Odometry) -> Option<f64> {
    let (wl, wr) = odo.weights();
    Some(tread_integral(log, a, b, (wl, wr))? / odo.separation)
}

/// `int (w_r v_r - w_l v_l) dt` over `[a, b]` (wheel clock), m.
fn tread_integral(log: &DriveLog, a: f64, b: f64, (wl, wr): (f64, f64)) -> Option<f64> {
    let w = &log.wheels;
    let d = |x: &terraslip_io::WheelSample| wr * x.v_right - wl * x.v_left;
    if w.len() < 2 || a < w[0].t || b > w[w.len() - 1].t || b < a {
        return None;
    }
    let diff_at = |t: f64| {
        let k = w.partition_point(|x| x.t <= t).clamp(1, w.len() - 1);
        let (p, q) = (&w[k - 1], &w[k]);
        let u = if q.t > p.t {
            ((t - p.t) / (q.t - p.t)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        d(p) + u * (d(q) - d(p))
    };
    let k0 = w.partition_point(|x| x.t <= a);
    let k1 = w.partition_point(|x| x.t < b);
    let mut knots = vec![(a, diff_at(a))];
    knots.extend(w[k0..k1.max(k0)].iter().map(|x| (x.t, d(x))));
    knots.push((b, diff_at(b)));
    let mut sum = 0.0;
    for p in knots.windows(2) {
        if p[1].0 - p[0].0 > 0.5 {
            return None;
        }
        sum += 0.5 * (p[0].1 + p[1].1) * (p[1].0 - p[0].0);
    }
    Some(sum)
}

/// Pairs of `stretches` of the same log at least `min_baseline` rad of
/// odometry turning apart.
pub fn pairs(
    logs: &[&DriveLog],
    offsets: &[f64],
    stretches: &[Stretch],
    odo: &Odometry,
    min_baseline: f64,
) -> Vec<Pair> {
    let mut out = Vec::new();
    for (a, x) in stretches.iter().enumerate() {
        for (b, y) in stretches.iter().enumerate().skip(a + 1) {
            if x.log != y.log {
                continue;
            }
            let o = offsets.get(x.log).copied().unwrap_or(0.0);
            let (t0, t1) = (x.t_mid - o, y.t_mid - o);
            let (Some(diff), Some(sum)) = (
                tread_integral(logs[x.log], t0, t1, (1.0, 1.0)),
                tread_integral(logs[x.log], t0, t1, (-1.0, 1.0)),
            ) else {
                continue;
            };
            let (treads, travel) = (diff / odo.separation, sum / odo.separation);
            if treads.abs() < min_baseline {
                continue;
            }
            out.push(Pair {
                a,
                b,
                course: terraslip_core::angle::wrap(y.course - x.course),
                treads,
                travel,
            });
        }
    }
    out
}

/// The turn factor from `pairs`: the course change regressed on the
/// no-slip turn `x` and the travel `y` (least squares, `c = a x + b y`,
/// `k = 1 / a`, `b / a` the treads' speed factor asymmetry
/// `(alpha_r - alpha_l) / (alpha_r + alpha_l)`, which over a long baseline
/// turns the robot as `b y`). The course change is known modulo a full
/// turn: it is taken nearest the prediction. A first pass uses the pairs
/// within one no-slip turn (2 pi) and the shorter half of their travels
/// (at least 50 rad) at `a = 1, b = 0`,
/// unambiguous for factors within [0.67, 2]; the next ones unwrap longer
/// baselines with the fit so far. With `free` false the asymmetry is held
/// at 0 (`b = 0`). Returns the factor and the asymmetry.
fn turn_factor(pairs: &[&Pair], free: bool) -> Option<(f64, f64)> {
    let pass = |a: f64, b: f64, max: f64, max_travel: f64| {
        let (mut xx, mut xy, mut yy, mut xc, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let near = |p: &&&Pair| p.treads.abs() <= max && p.travel.abs() <= max_travel;
        for p in pairs.iter().filter(near) {
            let c = p.course_near(a * p.treads + b * p.travel);
            xx += p.treads * p.treads;
            xy += p.treads * p.travel;
            yy += p.travel * p.travel;
            xc += p.treads * c;
            yc += p.travel * c;
        }
        if !free {
            return (xx > 0.0)
                .then(|| (xc / xx, 0.0))
                .filter(|(a, _)| a.is_finite() && *a > 0.0);
        }
        let det = xx * yy - xy * xy;
        (det > 1e-12 * xx * yy && xx > 0.0)
            .then(|| ((xc * yy - yc * xy) / det, (yc * xx - xc * xy) / det))
            .filter(|(a, b)| a.is_finite() && *a > 0.0 && b.is_finite())
    };
    // Baselines lengthen as the fit firms up: an asymmetry of 2 % turns
    // the robot by a radian over 50 rad of travel.
    let mut short: Vec<f64> = pairs
        .iter()
        .filter(|p| p.treads.abs() <= 2.0 * PI)
        .map(|p| p.travel.abs())
        .collect();
    short.sort_by(f64::total_cmp);
    let first = short.get(short.len() / 2).map_or(50.0, |m| m.max(50.0));
    let (mut a, mut b) = pass(1.0, 0.0, 2.0 * PI, first)?;
    for max_travel in [4.0 * first, 20.0 * first, f64::INFINITY, f64::INFINITY] {
        (a, b) = pass(a, b, f64::INFINITY, max_travel).unwrap_or((a, b));
    }
    Some((1.0 / a, b / a))
}

/// The course check of `logs` (each log's wheel clock shifted by its
/// offset, s) against the odometry `odo`. `None` when fewer than 3
/// stretches pair up.
pub fn check(
    logs: &[&DriveLog],
    offsets: &[f64],
    odo: &Odometry,
    cfg: &CourseConfig,
) -> Option<CourseCheck> {
    let st: Vec<Stretch> = logs
        .iter()
        .enumerate()
        .flat_map(|(i, l)| stretches(i, l, offsets.get(i).copied().unwrap_or(0.0), odo, cfg))
        .collect();
    let pr = pairs(logs, offsets, &st, odo, cfg.min_baseline);
    let used: Vec<usize> = (0..st.len())
        .filter(|&i| pr.iter().any(|p| p.a == i || p.b == i))
        .collect();
    if used.len() < 3 {
        return None;
    }
    // The fit on all pairs and its jackknife over stretches.
    let fit = |free: bool| -> Option<((f64, f64), (f64, f64))> {
        let all = turn_factor(&pr.iter().collect::<Vec<_>>(), free)?;
        let loo: Vec<(f64, f64)> = used
            .iter()
            .filter_map(|&i| {
                let rest: Vec<&Pair> = pr.iter().filter(|p| p.a != i && p.b != i).collect();
                turn_factor(&rest, free)
            })
            .collect();
        let n = loo.len() as f64;
        let sd = |f: fn(&(f64, f64)) -> f64| {
            let m = loo.iter().map(f).sum::<f64>() / n;
            ((n - 1.0) / n * loo.iter().map(|x| (f(x) - m).powi(2)).sum::<f64>()).sqrt()
        };
        Some((all, (sd(|x| x.0), sd(|x| x.1))))
    };
    let ((k, asym), (sk, sa)) = fit(true)?;
    // An asymmetry the pairs do not tell apart from 0 is held there: it
    // trades off against the factor (loops drive and turn together).
    let (k, std, asymmetry) = if asym.abs() >= ASYMMETRY_SIGMAS * sa {
        (k, sk, Some((asym, sa)))
    } else {
        let ((k0, _), (sk0, _)) = fit(false)?;
        (k0, sk0, None)
    };
    Some(CourseCheck {
        turn_factor: k,
        std,
        asymmetry,
        asymmetry_free: (asym, sa),
        stretches: st,
        pairs: pr,
    })
}
