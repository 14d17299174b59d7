//! Taking a fix as the pose: the first position and heading fixes, and
//! the heading found from the chord of the first position fixes.

use nalgebra::{Vector2, Vector3};

use super::ekf::isolate;
use super::Filter;
use crate::angle;
use crate::model::{BIAS_E, BIAS_N, CLOCK, EAST, N, NORTH, YAW};

/// Position fixes teach the heading once the robot is this many position
/// stds (and at least `MIN_CHORD` m) away from the first fix.
const CHORD_STDS: f64 = 8.0;
const MIN_CHORD: f64 = 2.0;

impl Filter {
    /// Sets state `i` to `value`, a fix of variance `r` plus `sum dep_k x_k`
    /// of other states: its covariance follows from theirs, so the fix's
    /// dependence on the clock offset (and bias, heading) stays known.
    pub(super) fn anchor(&mut self, i: usize, value: f64, dep: &[(usize, f64)], r: f64) {
        self.gyro_win.close();
        let mut row = [0.0; N];
        for (k, v) in row.iter_mut().enumerate() {
            *v = dep.iter().map(|&(m, c)| c * self.P[(m, k)]).sum();
        }
        let var = r + dep.iter().map(|&(m, c)| c * row[m]).sum::<f64>();
        for (k, v) in row.iter().enumerate() {
            self.P[(i, k)] = *v;
            self.P[(k, i)] = *v;
        }
        self.P[(i, i)] = var.max(r);
        self.x[i] = value;
    }

    /// Takes a position fix `z` as the position: `p = z - b + D(lag) -
    /// R(yaw then) l` (the lever arm once the heading is known).
    pub(super) fn anchor_position(&mut self, z: &Vector3<f64>, lag: f64, r: f64) {
        let m = self.motion(&self.x, lag);
        let turn = if self.anchored[1] { 1.0 } else { 0.0 };
        let (s, c) = libm::sincos(self.x[YAW] - m.d_yaw);
        let (lx, ly) = self.lever_arm();
        let (lx, ly) = (turn * lx, turn * ly);
        let (oe, on) = (c * lx - s * ly, s * lx + c * ly);
        let e = z[0] - self.x[BIAS_E] + m.d_east - oe;
        let n = z[1] - self.x[BIAS_N] + m.d_north - on;
        self.anchor(
            EAST,
            e,
            &[
                (BIAS_E, -1.0),
                (CLOCK, m.v_east),
                (YAW, -turn * m.d_north + on),
            ],
            r,
        );
        self.anchor(
            NORTH,
            n,
            &[
                (BIAS_N, -1.0),
                (CLOCK, m.v_north),
                (YAW, turn * m.d_east - oe),
            ],
            r,
        );
        self.history.clear();
    }

    /// Without heading fixes: once the robot is far enough from the first
    /// position fix, the heading is the angle between that chord and the
    /// same chord dead-reckoned in the filter's frame.
    pub(super) fn find_heading(&mut self, z: Vector2<f64>, std_xy: f64) {
        let Some(c) = self.chord else { return };
        let g = (z[0] - c.start.0, z[1] - c.start.1);
        let lg = libm::hypot(g.0, g.1);
        let lo = libm::hypot(c.odo.0, c.odo.1);
        let need = (CHORD_STDS * std_xy).max(MIN_CHORD);
        if lg < need || lo < need {
            return;
        }
        let turn = libm::atan2(g.1, g.0) - libm::atan2(c.odo.1, c.odo.0);
        self.x[YAW] = angle::wrap(self.x[YAW] + turn);
        // The fixes' noise across the chord, and the model's turning over
        // it: a turning gain wrong by its relative uncertainty turns the
        // dead-reckoned chord by up to that much of the heading turned.
        let gain = self.spread_std() / self.icr().guarded_spread();
        let sd = libm::hypot(2.0 * std_xy / lg, gain * c.turned);

        isolate(&mut self.P, YAW, sd * sd);
        self.gyro_win.close();
        self.anchored[1] = true;
        self.chord = None;
        self.history.clear();
    }
}
