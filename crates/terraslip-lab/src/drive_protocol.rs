//! DRIVE's own protocol for training its learned slip model
//! ([`crate::blr`]) on a windowed log (repository norlab-ulaval/DRIVE,
//! `model_training/data_utils/dataset_parser.py`,
//! `data_utils/slip_dataset_parser.py`, `model_trainers/blr_slip_trainer.py`):
//!
//! * the log is DRIVE's 2 s windows (20 Hz, [`WINDOW_ROWS`] rows each)
//!   chained; each command is held 6 s, three windows, the first
//!   transitory and the second and third **steady**: every row of a
//!   steady window trains the model, no other;
//! * each window's pose (the lidar pose held at each 20 Hz row) is put in
//!   the window's frame (origin the first pose, orientation the mean
//!   heading of its first [`FRAME_SAMPLES`] poses, headings relative to the
//!   first), each of x, y and heading smoothed by a cubic smoothing spline
//!   ([`SPLINE_LAMBDA`], sample times `linspace(0, 2, 40)` as DRIVE's),
//!   and the body velocity of row `j` is the step from `j` to `j + 1`
//!   rotated into the body frame at `j`, over 0.05 s (the last row repeats
//!   the one before).
//!
//! Where this departs from the repository: the ideal velocities come from
//! the measured tread speeds (the logs hold no commands; DRIVE takes the
//! commands, clipped, in steady windows), and the yaw rate from the
//! heading's spline (DRIVE: the IMU's gyro; these logs have none).
//!
//! The 6 s commands are not stamped in the logs: they are read from the
//! windows where the tread speeds step ([`Windows::of`]).

use crate::blr::{Blr, Row};
use crate::smoothing_spline::Smoother;
use terraslip_io::{DriveLog, WheelSample};

/// DRIVE's sampling period, s (20 Hz).
pub const PERIOD: f64 = 0.05;
/// Rows of one 2 s window.
pub const WINDOW_ROWS: usize = 40;
/// Windows of one command (6 s): the first transitory, the rest steady.
pub const WINDOWS_PER_COMMAND: usize = 3;
/// DRIVE's roughness weight of the pose splines (scipy's `lam`).
pub const SPLINE_LAMBDA: f64 = 0.8;
/// Poses whose mean heading orients DRIVE's window frame.
pub const FRAME_SAMPLES: usize = 5;
/// A window whose tread speeds move by more than this (m/s) from its
/// first 0.25 s to its last 0.5 s holds a command's start.
const COMMAND_STEP: f64 = 0.3;
/// Windows holding a command's start, fewest, for a log to be windowed.
const MIN_STARTS: usize = 10;

/// Where a windowed log's commands start.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Windows {
    /// The first window (from the log's first row) that starts a command.
    pub phase: usize,
    /// Whole windows in the log.
    pub count: usize,
}

impl Windows {
    /// The command windows of a log of DRIVE's windows: rows every
    /// [`PERIOD`] s, and the windows where the tread speeds step falling
    /// every third window (at least 3 times as often at one phase as at
    /// either other); `None` for any other log (a continuous recording).
    pub fn of(wheels: &[WheelSample]) -> Option<Self> {
        let on_grid = wheels
            .windows(2)
            .all(|w| ((w[1].t - w[0].t) - PERIOD).abs() < 1e-6);
        if !on_grid {
            return None;
        }
        let count = wheels.len() / WINDOW_ROWS;
        let mut starts = [0usize; WINDOWS_PER_COMMAND];
        for k in 0..count {
            let w = &wheels[k * WINDOW_ROWS..(k + 1) * WINDOW_ROWS];
            let mean = |rows: &[WheelSample], f: fn(&WheelSample) -> f64| {
                rows.iter().map(f).sum::<f64>() / rows.len() as f64
            };
            let (head, tail) = (&w[..5], &w[WINDOW_ROWS - 10..]);
            let step = (mean(tail, |s| s.v_left) - mean(head, |s| s.v_left))
                .abs()
                .max((mean(tail, |s| s.v_right) - mean(head, |s| s.v_right)).abs());
            if step > COMMAND_STEP {
                starts[k % WINDOWS_PER_COMMAND] += 1;
            }
        }
        let phase = (0..WINDOWS_PER_COMMAND).max_by_key(|&p| starts[p])?;
        let others = (0..WINDOWS_PER_COMMAND)
            .filter(|&p| p != phase)
            .map(|p| starts[p])
            .max()
            .unwrap_or(0);
        (starts[phase] >= MIN_STARTS && starts[phase] >= 3 * others)
            .then_some(Self { phase, count })
    }

    /// Whether window `k` is steady (the second or third of its command).
    pub fn steady(&self, k: usize) -> bool {
        !(k + WINDOWS_PER_COMMAND - self.phase).is_multiple_of(WINDOWS_PER_COMMAND)
    }
}

/// DRIVE's training rows of `log` in `[t0, t1)`: every row of each steady
/// window whose rows lie in the span and whose pose, read `c` s later,
/// does too; `model` gives the ideal velocities.
pub fn training_rows(
    log: &DriveLog,
    windows: &Windows,
    model: &Blr,
    c: f64,
    t0: f64,
    t1: f64,
) -> Vec<Row> {
    let poses: Vec<(f64, [f64; 3])> = log
        .pose
        .iter()
        .filter_map(|p| Some((p.t, [p.east?, p.north?, p.yaw?])))
        .collect();
    let times: Vec<f64> = (0..WINDOW_ROWS)
        .map(|j| 2.0 * j as f64 / (WINDOW_ROWS - 1) as f64)
        .collect();
    let Some(smoother) = Smoother::new(&times, SPLINE_LAMBDA) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for k in (0..windows.count).filter(|&k| windows.steady(k)) {
        let rows = &log.wheels[k * WINDOW_ROWS..(k + 1) * WINDOW_ROWS];
        if rows[0].t < t0 || rows[WINDOW_ROWS - 1].t + c >= t1 {
            continue;
        }
        // The pose held at each row (the last one stamped by then).
        let held: Option<Vec<[f64; 3]>> = rows
            .iter()
            .map(|r| {
                let i = poses.partition_point(|p| p.0 <= r.t + c);
                i.checked_sub(1).map(|i| poses[i].1)
            })
            .collect();
        let Some(held) = held else {
            continue;
        };
        let Some(vel) = window_velocities(&held, &smoother) else {
            continue;
        };
        for (r, (vx, vy, om)) in rows.iter().zip(vel) {
            let (v, o) = model.ideal(r.v_left, r.v_right);
            out.push(((v, o), [v - vx, -vy, o - om]));
        }
    }
    out
}

/// The body velocities `(v_x, v_y, omega)` (m/s, rad/s; REP-103 body
/// frame) at each row of a window, from the pose `[east, north, yaw]`
/// held at each row, by DRIVE's splines.
fn window_velocities(held: &[[f64; 3]], smoother: &Smoother) -> Option<Vec<(f64, f64, f64)>> {
    let first = held.first()?;
    let rel = |p: &[f64; 3]| terraslip_core::angle::wrap(p[2] - first[2]);
    let n = FRAME_SAMPLES.min(held.len());
    let frame = first[2] + held[..n].iter().map(rel).sum::<f64>() / n as f64;
    let (s, c) = frame.sin_cos();
    let x: Vec<f64> = held
        .iter()
        .map(|p| c * (p[0] - first[0]) + s * (p[1] - first[1]))
        .collect();
    let y: Vec<f64> = held
        .iter()
        .map(|p| -s * (p[0] - first[0]) + c * (p[1] - first[1]))
        .collect();
    // Headings relative to the first, unwrapped.
    let mut yaw = vec![0.0; held.len()];
    for j in 1..held.len() {
        yaw[j] = yaw[j - 1] + terraslip_core::angle::wrap(held[j][2] - held[j - 1][2]);
    }
    let (x, y, yaw) = (
        smoother.apply(&x)?,
        smoother.apply(&y)?,
        smoother.apply(&yaw)?,
    );
    let mut out: Vec<(f64, f64, f64)> = (0..held.len() - 1)
        .map(|j| {
            let (dx, dy) = (x[j + 1] - x[j], y[j + 1] - y[j]);
            let (s, c) = yaw[j].sin_cos();
            (
                (c * dx + s * dy) / PERIOD,
                (-s * dx + c * dy) / PERIOD,
                (yaw[j + 1] - yaw[j]) / PERIOD,
            )
        })
        .collect();
    out.push(*out.last()?);
    Some(out)
}

/// DRIVE's model trained by DRIVE's protocol on `[t0, t1)`, at the one of
/// `offsets` (s) whose 2 s prediction of the training span is best.
pub fn fit_timed(
    log: &DriveLog,
    windows: &Windows,
    track_width: f64,
    t0: f64,
    t1: f64,
    offsets: &[f64],
) -> Option<Blr> {
    let rows = |m: &Blr, c: f64| training_rows(log, windows, m, c, t0, t1);
    Blr::fit_timed_by(log, track_width, t0, t1, offsets, &rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::blr::simulated_drive;

    fn truth() -> Blr {
        Blr {
            track_width: 1.1,
            w_x: 0.15,
            w_y: 0.05,
            w_yaw: [0.02, 0.03, 0.3],
            clock_offset: 0.0,
        }
    }

    #[test]
    fn the_commands_are_found_from_where_the_tread_speeds_step() {
        for phase in 0..3 {
            // Commands start 2 s x phase into the log.
            let log = simulated_drive(&truth(), 0.0, 4, 2.0 * phase as f64);
            let w = Windows::of(&log.wheels).unwrap();
            assert_eq!(w, Windows { phase, count: 300 });
            assert!(!w.steady(phase) && w.steady(phase + 1) && w.steady(phase + 2));
            assert!(!w.steady(phase + 3));
        }
        // A continuous recording: no grid of 2 s windows.
        let mut log = simulated_drive(&truth(), 0.0, 4, 0.0);
        for (k, w) in log.wheels.iter_mut().enumerate() {
            w.t = k as f64 * 0.0499;
        }
        assert!(Windows::of(&log.wheels).is_none());
    }

    #[test]
    fn drive_s_protocol_recovers_the_slip_of_a_drive_of_its_model() {
        // A pose at every row.
        let log = simulated_drive(&truth(), 0.0, 1, 0.0);
        let w = Windows::of(&log.wheels).unwrap();
        let rows = training_rows(&log, &w, &truth(), 0.0, 0.0, 600.0);
        assert_eq!(rows.len(), 200 * WINDOW_ROWS);
        let m = truth().trained(&rows).unwrap();
        for (a, b) in m.w_yaw.iter().zip(truth().w_yaw) {
            assert!((a - b).abs() < 0.001, "{m:?}");
        }
        // The splines shorten this drive's tight arcs (up to 2.7 rad/s):
        // about 2.5 % of the speed read as slip.
        assert!((m.w_x - 0.15).abs() < 0.03, "{m:?}");
        // DRIVE's window frame is turned by the mean heading of its first
        // five poses, the body's by the first: on a turn, a sideways
        // velocity the lateral slip takes up.
        assert!(m.w_y > 0.05 && m.w_y < 0.11, "{m:?}");
    }

    #[test]
    fn the_transitory_window_does_not_train_the_model() {
        // Every first window of a command shows twice the longitudinal
        // slip: the model trained by DRIVE's protocol does not see it.
        let mut log = simulated_drive(&truth(), 0.0, 4, 0.0);
        let bad = Blr {
            w_x: 0.5,
            ..truth()
        };
        let skid = simulated_drive(&bad, 0.0, 4, 0.0);
        let w = Windows::of(&log.wheels).unwrap();
        // Splice the skidding windows' own poses into the transitory
        // windows (each window is read in its own frame).
        for (i, (p, q)) in log.pose.iter_mut().zip(&skid.pose).enumerate() {
            // Pose `i` is held from row `4 i` on.
            if !w.steady(4 * i / WINDOW_ROWS) {
                *p = *q;
            }
        }
        let rows = training_rows(&log, &w, &truth(), 0.0, 0.0, 600.0);
        let m = truth().trained(&rows).unwrap();
        assert!((m.w_x - 0.15).abs() < 0.04, "{m:?}");
        assert!((m.w_yaw[2] - 0.3).abs() < 0.01, "{m:?}");
    }
}
