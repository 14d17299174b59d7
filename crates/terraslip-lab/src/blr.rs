//! DRIVE's learned slip model (Baril et al., "DRIVE: Data-driven Robot
//! Input Vector Exploration", 2024; repository norlab-ulaval/DRIVE,
//! `model_training/models/learning/blr_slip.py`,
//! `model_trainers/blr_slip_trainer.py`,
//! `data_utils/slip_dataset_parser.py`), as a baseline for the online
//! estimator and `calibrate`.
//!
//! The ideal differential drive of the track width `b` gives the body
//! velocities `v = (v_l + v_r) / 2`, `omega = (v_r - v_l) / b` (REP-103
//! body frame, m/s and rad/s). The body-frame slip (ideal minus measured
//! velocity) is regressed, each part on its own, by Bayesian linear
//! regression without intercept:
//!
//! ```text
//! slip_x   = w_x   * v
//! slip_y   = w_y   * v * omega                      (centripetal)
//! slip_yaw = w_yaw . [v * omega, v, omega]
//! ```
//!
//! trained on the steady part of each command window; the prediction
//! integrates `(v - slip_x, -slip_y, omega - slip_yaw)`.
//!
//! Where this departs from the repository:
//!
//! * the inputs are the measured tread speeds (the logs here hold no
//!   commands, and DRIVE's powertrain model only maps commands to them);
//! * "steady" is read from the tread speeds (held within
//!   [`STEADY_TOLERANCE`] for [`STEADY_FOR`] s before the row and through
//!   its velocity window), not from DRIVE's window
//!   bookkeeping (the first 2 s window of each command is transitory), and
//!   rows standing still ([`MOVING`]) are left out (DRIVE's windows are
//!   all commanded motion; a continuous recording stands for minutes);
//! * the measured body velocity is a central difference of the pose over
//!   ±[`VELOCITY_HALF_WINDOW`] s (DRIVE: a smoothing spline of each 2 s
//!   window, then one-step differences), and the yaw rate comes from the
//!   pose's heading (DRIVE: the IMU's gyro);
//! * the prediction integrates the mean slip (DRIVE propagates sigma
//!   points of the slip's predictive distribution; the mean differs only
//!   by second-order terms of the slip's variance);
//! * DRIVE's model has no clock: it is given the offset between wheels and
//!   pose stamps that predicts its own training data best
//!   ([`Blr::fit_timed`]).
//!
//! [`crate::drive_protocol`] trains the same model by the repository's own
//! protocol (its steady windows and smoothing splines), a second reading.

use nalgebra::{Matrix3, Vector3};
use terraslip_calib::prediction::{interpolate, segment_error, PredictionSpec, Reference};
use terraslip_core::Twist;
use terraslip_io::{DriveLog, WheelSample};

/// DRIVE's prior precision of the weights relative to the noise
/// (`variance_init / param_variance_init` = 1e9 / 1e21): all but
/// uninformative, so the weights are the least-squares ones.
const PRIOR_PRECISION: f64 = 1e-12;

/// Tread speeds held within this (m/s) ...
pub const STEADY_TOLERANCE: f64 = 0.1;
/// ... for this long (s) are a steady command.
pub const STEADY_FOR: f64 = 1.0;
/// Rows whose tread speeds add up (in magnitude) to less than this (m/s)
/// stand still: the pose's noise is all they hold.
pub const MOVING: f64 = 0.2;
/// Half width (s) of the central difference of the pose that measures the
/// body velocity.
pub const VELOCITY_HALF_WINDOW: f64 = 0.25;

/// Longest gap (s) of the pose stream a velocity may be measured across
/// (a lidar localiser drops scans for up to a second while driving).
const MAX_GAP: f64 = 1.0;

/// Clock offsets (s) tried for the model, a pose stamped `t + c`
/// describing wheel time `t`.
pub const OFFSETS: [f64; 13] = [
    0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6,
];

/// The trained model: weights of the three regressions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blr {
    /// Track width of the ideal differential drive, m.
    pub track_width: f64,
    pub w_x: f64,
    pub w_y: f64,
    /// On `[v * omega, v, omega]`.
    pub w_yaw: [f64; 3],
    /// Clock offset of the pose stream the model was trained with, s.
    pub clock_offset: f64,
}

/// One training row: ideal `(v, omega)` (m/s, rad/s) and the slip
/// `(x, y, yaw)` (m/s, m/s, rad/s).
pub type Row = ((f64, f64), [f64; 3]);

/// The training rows of a drive read at a clock offset (s): the model
/// (for its ideal velocities) and the offset.
pub type RowSource<'a> = dyn Fn(&Blr, f64) -> Vec<Row> + 'a;

impl Blr {
    /// Ideal body velocities `(v, omega)` of tread speeds (m/s).
    pub fn ideal(&self, v_l: f64, v_r: f64) -> (f64, f64) {
        (0.5 * (v_l + v_r), (v_r - v_l) / self.track_width)
    }

    /// Predicted body twist of a wheels row.
    pub fn twist(&self, w: &WheelSample) -> Twist {
        let (v, om) = self.ideal(w.v_left, w.v_right);
        let y = &self.w_yaw;
        Twist {
            v_x: v - self.w_x * v,
            v_y: -self.w_y * v * om,
            omega: om - (y[0] * v * om + y[1] * v + y[2] * om),
        }
    }

    /// The model with no slip, before training.
    pub fn untrained(track_width: f64, clock_offset: f64) -> Self {
        Self {
            track_width,
            w_x: 0.0,
            w_y: 0.0,
            w_yaw: [0.0; 3],
            clock_offset,
        }
    }

    /// DRIVE's three regressions on `rows`; `None` with fewer than 10.
    pub fn trained(self, rows: &[Row]) -> Option<Self> {
        let mut m = self;
        if rows.len() < 10 {
            return None;
        }
        let (mut xx, mut xy) = ([PRIOR_PRECISION; 2], [0.0; 2]);
        let mut a = Matrix3::identity() * PRIOR_PRECISION;
        let mut b = Vector3::zeros();
        for &((v, om), s) in rows {
            xx[0] += v * v;
            xy[0] += v * s[0];
            xx[1] += (v * om) * (v * om);
            xy[1] += v * om * s[1];
            let x = Vector3::new(v * om, v, om);
            a += x * x.transpose();
            b += x * s[2];
        }
        m.w_x = xy[0] / xx[0];
        m.w_y = xy[1] / xx[1];
        let w = a.try_inverse()? * b;
        m.w_yaw = [w[0], w[1], w[2]];
        Some(m)
    }

    /// Trained on the steady rows of `[t0, t1)` whose pose window lies in
    /// the same span, at each offset of [`OFFSETS`], keeping the one whose
    /// 2 s prediction of its own training span (starts every second) is
    /// best; `None` with fewer than 10 steady rows.
    pub fn fit_timed(log: &DriveLog, track_width: f64, t0: f64, t1: f64) -> Option<Self> {
        let rows = |m: &Blr, c: f64| m.training_rows(log, c, t0, t1);
        Self::fit_timed_by(log, track_width, t0, t1, &OFFSETS, &rows)
    }

    /// Trained on `rows` at each of `offsets` (s), keeping the one whose
    /// 2 s prediction of `[t0, t1)` (starts every second) is best.
    pub fn fit_timed_by(
        log: &DriveLog,
        track_width: f64,
        t0: f64,
        t1: f64,
        offsets: &[f64],
        rows: &RowSource,
    ) -> Option<Self> {
        let refs = terraslip_calib::prediction::references(&log.pose);
        let spec = PredictionSpec::default();
        let mut best: Option<(f64, Self)> = None;
        for &c in offsets {
            let m = Self::untrained(track_width, c);
            let Some(m) = m.trained(&rows(&m, c)) else {
                continue;
            };
            let (mut sum, mut n) = (0.0, 0usize);
            let mut t = t0;
            while t + spec.horizon + c <= t1 {
                if let Some(e) = segment_error(&refs, &log.wheels, &|w| m.twist(w), t, c, &spec) {
                    sum += e;
                    n += 1;
                }
                t += spec.stride;
            }
            if n == 0 {
                continue;
            }
            let score = sum / n as f64;
            if best.as_ref().is_none_or(|b| score < b.0) {
                best = Some((score, m));
            }
        }
        best.map(|b| b.1)
    }

    /// The steady rows of `[t0, t1)` and their measured slip.
    fn training_rows(&self, log: &DriveLog, c: f64, t0: f64, t1: f64) -> Vec<Row> {
        let refs = terraslip_calib::prediction::references(&log.pose);
        let w = &log.wheels;
        let h = VELOCITY_HALF_WINDOW;
        let mut out = Vec::new();
        let mut since = 0usize; // first row of the current steady run
        for (k, s) in w.iter().enumerate() {
            let held = |q: &WheelSample| {
                (q.v_left - s.v_left).abs() <= STEADY_TOLERANCE
                    && (q.v_right - s.v_right).abs() <= STEADY_TOLERANCE
            };
            while since < k && !w[since..k].iter().all(held) {
                since += 1;
            }
            let (ta, tb) = (s.t + c - h, s.t + c + h);
            let moving = s.v_left.abs() + s.v_right.abs() >= MOVING;
            if s.t < t0 || tb >= t1 || s.t - w[since].t < STEADY_FOR || !moving {
                continue;
            }
            // The velocity window must not reach into the next command.
            if !w[k..].iter().take_while(|q| q.t <= s.t + h).all(held) {
                continue;
            }
            if !gap_free(&refs, ta, tb) {
                continue;
            }
            let (Some(a), Some(b)) = (interpolate(&refs, ta), interpolate(&refs, tb)) else {
                continue;
            };
            // The chord of an arc turning `turn` is `sinc(turn / 2)` of its
            // length, along the heading halfway.
            let (yaw, turn) = (0.5 * (a.2 + b.2), b.2 - a.2);
            let half = 0.5 * turn;
            let sinc = if half.abs() < 1e-6 {
                1.0
            } else {
                half.sin() / half
            };
            let (de, dn) = (b.0 - a.0, b.1 - a.1);
            let vx = (de * yaw.cos() + dn * yaw.sin()) / (2.0 * h * sinc);
            let vy = (-de * yaw.sin() + dn * yaw.cos()) / (2.0 * h * sinc);
            let om = turn / (2.0 * h);
            let (v, o) = self.ideal(s.v_left, s.v_right);
            out.push(((v, o), [v - vx, -vy, o - om]));
        }
        out
    }
}

/// Whether the references around `[ta, tb]` have no gap over
/// [`MAX_GAP`].
fn gap_free(refs: &[Reference], ta: f64, tb: f64) -> bool {
    let i = refs.partition_point(|p| p.0 <= ta).saturating_sub(1);
    let j = refs.partition_point(|p| p.0 < tb);
    j < refs.len() && refs[i..=j].windows(2).all(|w| w[1].0 - w[0].0 <= MAX_GAP)
}

/// A 600 s drive at 20 Hz whose slip is exactly `truth`'s: commands held
/// 6 s from `command_start` (s), random-looking, followed by the tread
/// speeds with a 0.2 s time constant; the pose every `pose_every` rows,
/// stamped `lag` s late.
#[cfg(test)]
pub fn simulated_drive(truth: &Blr, lag: f64, pose_every: usize, command_start: f64) -> DriveLog {
    use terraslip_io::PoseObs;
    let (mut e, mut n, mut y) = (0.0f64, 0.0f64, 0.0f64);
    let mut log = DriveLog::default();
    let (mut v_left, mut v_right) = (0.0, 0.0);
    let follow = 1.0 - (-0.05f64 / 0.2).exp();
    for k in 0..12000 {
        let t = k as f64 * 0.05;
        let step = ((t - command_start) / 6.0).floor();
        v_left += follow * (1.5 * (step * 1.7).sin() - v_left);
        v_right += follow * (1.5 * (step * 2.9 + 1.0).cos() - v_right);
        let s = WheelSample { t, v_left, v_right };
        if k > 0 {
            let tw = truth.twist(&s);
            e += 0.05 * (tw.v_x * y.cos() - tw.v_y * y.sin());
            n += 0.05 * (tw.v_x * y.sin() + tw.v_y * y.cos());
            y += 0.05 * tw.omega;
        }
        log.wheels.push(s);
        if k % pose_every == 0 {
            log.pose.push(PoseObs {
                t: t + lag,
                east: Some(e),
                north: Some(n),
                yaw: Some(terraslip_core::angle::wrap(y)),
                std_xy: None,
                std_yaw: None,
            });
        }
    }
    log
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drive whose slip is exactly DRIVE's model: the fit recovers the
    /// weights, and the clock offset of a late pose stream.
    #[test]
    fn recovers_the_slip_weights_and_the_clock_offset() {
        let truth = Blr {
            track_width: 1.1,
            w_x: 0.15,
            w_y: 0.05,
            w_yaw: [0.02, 0.03, 0.3],
            clock_offset: 0.0,
        };
        let log = simulated_drive(&truth, 0.3, 2, 0.0);
        let m = Blr::fit_timed(&log, 1.1, 0.0, 600.0).unwrap();
        assert!((m.clock_offset - 0.3).abs() < 1e-9, "{m:?}");
        assert!((m.w_x - truth.w_x).abs() < 0.01, "{m:?}");
        assert!((m.w_yaw[2] - truth.w_yaw[2]).abs() < 0.02, "{m:?}");
        // The drive is integrated with the heading at the start of each
        // 0.05 s step (as the prediction is): a sideways drift of about
        // `v omega dt / 2` that the lateral slip takes up.
        assert!((m.w_y - truth.w_y).abs() < 0.025, "{m:?}");
        for (a, b) in m.w_yaw.iter().zip(truth.w_yaw) {
            assert!((a - b).abs() < 0.01, "{m:?}");
        }
    }
}
