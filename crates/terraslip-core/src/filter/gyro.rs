//! The yaw-rate gyro: the heading change it integrates over a short window
//! against the model's.
//!
//! ```text
//! z = integral of gyro_z over the window = g (Psi(x) + E) + b_g T + n,   g = 1 + k_g
//! ```
//!
//! `Psi` is the heading change the ICR model makes of the window's tread
//! speeds (`history.rs`, with its slip Jacobian), `k_g` the gyro's scale
//! error and `b_g` its bias (states), `T` the window's length, `n` the
//! gyro's white noise integrated, and `E` the model's own heading error
//! over the window: the very error the predictions added to the yaw's
//! variance. The measurement noise and the state therefore share `E`; the
//! filter carries that cross-covariance `C = cov(x, E)` through the
//! window's predictions and fixes, and the update uses it
//! (`K = (P H' + g C) / S`), so the yaw follows the gyro through a turn the
//! model gets wrong while the slip parameters learn only what persists.
//!
//! The scale error is learned only where positions or headings show the
//! true turn ([`super::FilterConfig::hold_gyro_scale`]): against the gyro
//! alone, `g` and the spread make the same turn.
//!
//! A window rather than each wheels step: over one step, encoder
//! quantisation makes the tread speed difference jump by a tick per step,
//! which a per-step comparison would read as a wrong turning gain; over a
//! window the ticks add up to the motion.
//!
//! The gyro's noise is learned from the windows' residuals (`noise.rs`,
//! its sensor part; the model's yaw-rate noise is the heading fixes' fit,
//! which learning it from the gyro's residuals too made worse:
//! docs/benchmarks.md).

use nalgebra::SVector;

use super::ekf::finite_mat;
use super::gyro_window::GyroWindow;
use super::history::CAPACITY;
use super::{Filter, FilterError};
use crate::model::{
    centripetal_of, slip_of, GYRO_BIAS, GYRO_SCALE, K_SPREAD_SPEED, K_X_SPEED, N, SLIP, YAW,
};

/// Length of a gyro window, s.
pub const GYRO_WINDOW: f64 = 0.5;
/// Smallest gyro noise trusted, rad/s per sample.
const MIN_STD_GYRO: f64 = 1e-4;
/// Windows behind the noise belief before the gate applies.
const GATE_WARMUP: f64 = 20.0;
/// Heading change of the model over a window (rad) above which the
/// window's residual says whether the model turns too little or too much.
const MIN_DETECTOR_TURN: f64 = 0.05;

/// What the filter has learned about its gyro.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GyroNoise {
    /// White noise of one sample, as learned, rad/s.
    pub std: f64,
    /// The bias, rad/s.
    pub bias: f64,
    /// Its std, rad/s.
    pub bias_std: f64,
    /// The scale: the gyro reads `scale` times the true yaw rate (1 + the
    /// scale error `k_g`).
    pub scale: f64,
    /// Its std.
    pub scale_std: f64,
    /// Whether the scale was learned (false: held at its starting value,
    /// [`super::FilterConfig::hold_gyro_scale`]).
    pub scale_learned: bool,
    /// Windows fused.
    pub fused: u64,
    /// Of those, windows whose turn the model missed by more than the gate
    /// allows, fused with the model's heading error widened to fit.
    pub widened: u64,
}

impl Filter {
    /// Adds the gyro's heading change `angle` (rad, counter-clockwise about
    /// body z; the integral of its rate) over the last prediction step, from
    /// `samples` samples (fractional when a step holds part of them); fuses
    /// the window once it spans [`GYRO_WINDOW`]. Returns the normalised
    /// innovation squared of the window fused (before any widening), if
    /// one was.
    pub fn add_gyro(&mut self, angle: f64, samples: f64) -> Result<Option<f64>, FilterError> {
        if !angle.is_finite() {
            return Err(FilterError::BadInput("gyro rate not finite"));
        }
        let (dt, q_model, q_yaw) = self.last_step;
        if !(dt > 0.0 && samples >= 0.0 && samples.is_finite()) || self.meas.std_gyro == 0.0 {
            self.gyro_win.close();
            return Ok(None);
        }
        let w = &mut self.gyro_win;
        if !w.open {
            // Opened on this step: its model noise is the window's first.
            *w = GyroWindow::new();
            w.open = true;
            w.add_model_noise(q_model, q_yaw);
        }
        w.angle += angle;
        w.samples += samples;
        w.span += dt;
        w.steps += 1;
        if w.span + 1e-9 < GYRO_WINDOW {
            return Ok(None);
        }
        let w = *w;
        self.gyro_win.close();
        if w.steps >= CAPACITY {
            return Ok(None);
        }
        self.fuse_gyro_window(&w)
    }

    fn fuse_gyro_window(&mut self, w: &GyroWindow) -> Result<Option<f64>, FilterError> {
        if self.cfg.noise_memory > 0.0 {
            self.gyro_noise
                .forget(libm::exp(-w.span / self.cfg.noise_memory));
        }
        let m = self.history.over(
            w.span,
            self.cfg.chart,
            &slip_of(&self.x),
            self.x[crate::model::LAW],
            &centripetal_of(&self.x),
            self.x[crate::model::SPEED_LAW],
            self.x[YAW],
        );
        // The gyro reads g times the true turn.
        let g = 1.0 + self.x[GYRO_SCALE];
        let mut H = SVector::<f64, N>::zeros();
        for k in 0..5 {
            H[SLIP + k] = g * m.d_slip[(2, k)];
        }
        H[crate::model::LAW] = g * m.d_yaw_law;
        H[K_X_SPEED] = g * m.d_centripetal[(2, 0)];
        H[K_SPREAD_SPEED] = g * m.d_centripetal[(2, 1)];
        H[crate::model::SPEED_LAW] = g * m.d_centripetal[(2, 2)];
        H[GYRO_BIAS] = w.span;
        H[GYRO_SCALE] = m.d_yaw;
        let nu = w.angle - (g * m.d_yaw + self.x[GYRO_BIAS] * w.span);

        // The gyro's white noise integrated, the model's heading error
        // (shared with the state: `C`), the encoder's quantisation.
        let std0 = self.meas.std_gyro.max(MIN_STD_GYRO);
        let r_nom = std0 * std0 * w.span * w.span / w.samples.max(1.0);
        let tick = self.meas.encoder_tick;
        let d = self.icr().guarded_spread();
        let r_tick = tick * tick / (3.0 * d * d);
        let r = r_nom * self.gyro_noise.sensor() + g * g * w.model_var + r_tick;
        let mut C = g * w.cross;
        let ph = self.P * H;
        let mut s = H.dot(&ph) + r + 2.0 * H.dot(&C);
        if !(s > 0.0 && s.is_finite()) {
            return Err(FilterError::SingularInnovation);
        }
        self.detect_change(nu / libm::sqrt(s), m.d_yaw)?;
        let nis = nu * nu / s;
        let beyond = nis > self.cfg.gate_yaw && self.gyro_noise.count() >= GATE_WARMUP;
        if !beyond {
            // (Capped: before the gate applies, one window counts a gate's
            // worth at most.)
            self.gyro_noise
                .add((nu * nu).min(self.cfg.gate_yaw * s), s, r_nom, 0.0);
        } else {
            // The model missed the window's turn by more than its assumed
            // heading error allows (new ground, a spin): that error was
            // larger. Widen it, in the measurement, in the yaw and in their
            // covariance alike, until the window sits on the gate; the yaw
            // then follows the gyro and the slip parameters learn little
            // from the window. (`H` has no yaw entry: `P H'` is unchanged.)
            let extra = nu * nu / self.cfg.gate_yaw - s;
            s += extra;
            if self.anchored[1] {
                self.P[(YAW, YAW)] += extra;
                C[YAW] += extra;
            }
            self.gyro_counts[1] += 1;
        }

        // K = (P H' + C) / S with the rows of what must not learn zeroed;
        // P - K (H P + C') - (P H' + C) K' + K S K' holds for any such gain.
        let a = ph + C;
        let mut k = a / s;
        let frozen = self.frozen(true);
        for (i, f) in frozen.iter().enumerate() {
            if *f || ((i == YAW || i == GYRO_SCALE) && !self.anchored[1]) {
                k[i] = 0.0;
            }
        }
        let mut x = self.x + k * nu;
        x[YAW] = crate::angle::wrap(x[YAW]);
        let ka = k * a.transpose();
        let P = self.P - ka - ka.transpose() + k * k.transpose() * s;
        let P = 0.5 * (P + P.transpose());
        if !finite_mat(&x) || (0..N).any(|i| !(P[(i, i)] >= 0.0 && P[(i, i)].is_finite())) {
            return Err(FilterError::NonFinite);
        }
        self.project(&mut x);
        self.x = x;
        self.P = P;
        self.gyro_seen = true;
        self.gyro_counts[0] += 1;
        Ok(Some(nis))
    }

    /// The slip-change detector on the gyro windows. A wrong spread makes
    /// the model turn too little or too much whichever way the robot
    /// turns, so the normalised residual `z` of a turning window is signed
    /// by the model's turn `d_yaw` (rad): new ground shows as a run of one
    /// sign, a bias error (the same sign whichever way) averages out.
    fn detect_change(&mut self, z: f64, d_yaw: f64) -> Result<(), FilterError> {
        let turning = libm::fabs(d_yaw) > MIN_DETECTOR_TURN;
        if !(turning && self.cfg.learn_icr && !self.still && self.anchored[1])
            || self.gyro_noise.count() < super::update::DETECTOR_WARMUP
        {
            return Ok(());
        }
        let z = if d_yaw > 0.0 { z } else { -z };
        let stat = self.detector[2].push(self.elapsed, [z, 0.0], 1, self.cfg.change_window);
        if stat.is_some_and(|s| s > self.cfg.change_threshold) {
            self.raise_slip_uncertainty()?;
            self.gyro_change = true;
        }
        Ok(())
    }

    /// The gyro as learned (all zero before the first gyro window).
    pub fn gyro_noise(&self) -> GyroNoise {
        if !self.gyro_seen {
            return GyroNoise::default();
        }
        let std0 = self.meas.std_gyro.max(MIN_STD_GYRO);
        GyroNoise {
            std: std0 * libm::sqrt(self.gyro_noise.sensor()),
            bias: self.x[GYRO_BIAS],
            bias_std: libm::sqrt(self.P[(GYRO_BIAS, GYRO_BIAS)].max(0.0)),
            scale: 1.0 + self.x[GYRO_SCALE],
            scale_std: libm::sqrt(self.P[(GYRO_SCALE, GYRO_SCALE)].max(0.0)),
            scale_learned: !self.cfg.hold_gyro_scale && self.meas.gyro_scale_std > 0.0,
            fused: self.gyro_counts[0],
            widened: self.gyro_counts[1],
        }
    }

    /// Abandons the gyro window being integrated (a gap in the gyro).
    pub fn break_gyro(&mut self) {
        self.gyro_win.close();
    }
}
