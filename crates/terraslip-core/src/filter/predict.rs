//! The prediction step: `x = f(x, u, dt)`, `P = F P F' + Q`.

use nalgebra::SMatrix;

use super::ekf::finite_mat;
use super::{Filter, FilterError, SlipHold};
use crate::model::{
    self, State, BIAS_E, BIAS_N, CLOCK, EAST, GYRO_BIAS, GYRO_SCALE, LAW, N, NORTH, SLIP, YAW,
};
use crate::slip::{Chart, TreadInput};

/// The filter's model carried on from its state at one time with every
/// parameter held (the turn laws' lagged input moving on): where an
/// estimator given no fixes puts the robot. World frame, m and rad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeadReckoning {
    x: State,
    chart: Chart,
    /// The turn laws' lag, s, and their lagged input, m/s.
    lag: f64,
    lagged: f64,
    /// The speed factors' law reads the lagged input (else the step's).
    speed_lagged: bool,
}

impl DeadReckoning {
    /// Tread speeds `v_left`, `v_right` (m/s) held over `dt` s; a step
    /// that is not finite is not taken.
    pub fn step(&mut self, v_left: f64, v_right: f64, dt: f64) {
        self.step_with_gain(v_left, v_right, dt, lag_gain(dt, self.lag));
    }

    /// [`Self::step`] with the turn laws' low-pass gain over `dt` given:
    /// `gain` is [`Self::lag_gain`]`(dt)`, computed once for reckonings
    /// stepped together.
    pub fn step_with_gain(&mut self, v_left: f64, v_right: f64, dt: f64, gain: f64) {
        if !(dt > 0.0 && dt.is_finite() && v_left.is_finite() && v_right.is_finite()) {
            return;
        }
        let dv = (v_right - v_left).abs();
        self.lagged = low_pass(self.lagged, dv, gain);
        let law = model::LawInputs {
            spread: self.lagged,
            speed: if self.speed_lagged { self.lagged } else { dv },
        };
        let u = TreadInput { v_left, v_right };
        self.x = model::step(&self.x, self.chart, u, law, dt).0;
    }

    /// The turn laws' low-pass gain over a step of `dt` s (1).
    pub fn lag_gain(&self, dt: f64) -> f64 {
        lag_gain(dt, self.lag)
    }

    /// The turn laws' time constant, s.
    pub fn lag(&self) -> f64 {
        self.lag
    }

    /// Pose `(east, north, yaw)`: m, m, rad.
    pub fn pose(&self) -> (f64, f64, f64) {
        (self.x[EAST], self.x[NORTH], self.x[YAW])
    }
}

/// The gain by which the turn laws' input moves towards the step's tread
/// speed difference over `dt` s with time constant `lag` s.
fn lag_gain(dt: f64, lag: f64) -> f64 {
    if lag > 0.0 {
        1.0 - libm::exp(-dt / lag)
    } else {
        1.0
    }
}

/// The turn laws' input `prev` (m/s) low-passed towards the step's tread
/// speed difference `dv` over `dt` s with time constant `lag` s.
fn lag_input(prev: f64, dv: f64, dt: f64, lag: f64) -> f64 {
    low_pass(prev, dv, lag_gain(dt, lag))
}

/// `prev` moved towards `dv` by `gain` (0 to 1).
fn low_pass(prev: f64, dv: f64, gain: f64) -> f64 {
    prev + gain * (dv - prev)
}

impl Filter {
    /// Propagates over `dt` seconds with measured tread speeds `v_left`,
    /// `v_right` (m/s, held over the step).
    pub fn predict(&mut self, v_left: f64, v_right: f64, dt: f64) -> Result<(), FilterError> {
        if !(v_left.is_finite() && v_right.is_finite()) {
            return Err(FilterError::BadInput("tread speed not finite"));
        }
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(FilterError::BadInput("time step negative or not finite"));
        }
        let cfg = self.cfg;
        self.still = v_left.abs() < cfg.still_speed && v_right.abs() < cfg.still_speed;
        if dt == 0.0 {
            self.last_step = (0.0, 0.0, 0.0);
            return Ok(());
        }
        self.elapsed += dt;
        let u = TreadInput { v_left, v_right };
        // The ground takes a new turn up with a lag: the law reads the
        // tread speed difference low-passed.
        let dv = (v_right - v_left).abs();
        let lagged = lag_input(self.law_input.spread, dv, dt, cfg.turn_law_lag);
        self.law_input = self.law_inputs(dv, lagged);
        let (x, twist, rows) = model::step(&self.x, cfg.chart, u, self.law_input, dt);

        // F = I except the pose rows (`rows`) and the bias decay `phi` on
        // the bias diagonal: F P F' in two products of 3 rows / 3 columns.
        let phi = if self.bias_std > 0.0 {
            libm::exp(-dt / self.meas.correlation_time)
        } else {
            1.0
        };
        let fp: SMatrix<f64, 3, N> = rows * self.P;
        let mut A = self.P;
        A.fixed_rows_mut::<3>(0).copy_from(&fp);
        for b in [BIAS_E, BIAS_N] {
            for j in 0..N {
                A[(b, j)] *= phi;
            }
        }
        let afp: SMatrix<f64, N, 3> = A * rows.transpose();
        let mut P = A;
        P.fixed_columns_mut::<3>(0).copy_from(&afp);
        for b in [BIAS_E, BIAS_N] {
            for i in 0..N {
                P[(i, b)] *= phi;
            }
        }

        // Process noise.
        let v = 0.5 * (v_left + v_right);
        let w = twist.omega;
        let (q_speed, q_turn) = self.model_noise();
        let q_xy = dt * (cfg.q_pos + q_speed * v * v);
        P[(EAST, EAST)] += q_xy;
        P[(NORTH, NORTH)] += q_xy;
        // The model's heading error over the step; the yaw takes it once
        // it is known.
        let q_model = dt * (cfg.q_yaw + q_turn * w * w);
        let q_yaw = if self.anchored[1] { q_model } else { 0.0 };
        P[(YAW, YAW)] += q_yaw;
        if self.gyro_win.is_open() {
            // cov(x, E) through the step: F C, plus the yaw's share of E.
            let c = self.gyro_win.cross_mut();
            let pose = rows * *c;
            c.fixed_rows_mut::<3>(0).copy_from(&pose);
            c[BIAS_E] *= phi;
            c[BIAS_N] *= phi;
            self.gyro_win.add_model_noise(q_model, q_yaw);
        }
        if self.gyro_seen {
            P[(GYRO_BIAS, GYRO_BIAS)] += dt * self.meas.gyro_bias_walk * self.meas.gyro_bias_walk;
            if !self.cfg.hold_gyro_scale && self.meas.gyro_scale_std > 0.0 {
                P[(GYRO_SCALE, GYRO_SCALE)] +=
                    dt * self.meas.gyro_scale_walk * self.meas.gyro_scale_walk;
            }
        }
        if self.meas.encoder_tick > 0.0 {
            // Each step's tread increments are off by up to a tick.
            let t2 = self.meas.encoder_tick * self.meas.encoder_tick;
            let d = self.icr().guarded_spread();
            if self.anchored[1] {
                P[(YAW, YAW)] += t2 / (3.0 * d * d);
            }
            P[(EAST, EAST)] += t2 / 12.0;
            P[(NORTH, NORTH)] += t2 / 12.0;
        }
        if !self.still {
            let k = dt * self.schedule_scale;
            let mut blk = P.fixed_view_mut::<5, 5>(SLIP, SLIP);
            blk += self.q_slip * k;
            if cfg.learn_clock {
                P[(CLOCK, CLOCK)] += dt * cfg.clock_walk * cfg.clock_walk;
            }
            if P[(LAW, LAW)] > 0.0 && cfg.hold != SlipHold::All {
                P[(LAW, LAW)] += dt * cfg.turn_law_walk * cfg.turn_law_walk;
            }
            if self.learn_speed_law {
                let i = crate::model::SPEED_LAW;
                P[(i, i)] += dt * cfg.turn_law_walk * cfg.turn_law_walk;
            }
        }
        let qb = self.bias_std * self.bias_std * (1.0 - phi * phi);
        P[(BIAS_E, BIAS_E)] += qb;
        P[(BIAS_N, BIAS_N)] += qb;

        if !finite_mat(&x) || (0..N).any(|i| !P[(i, i)].is_finite()) {
            return Err(FilterError::NonFinite);
        }
        let (ve, vn) = model::world_velocity(&twist, self.x[YAW]);
        if let Some(c) = self.chord.as_mut() {
            c.odo.0 += ve * dt;
            c.odo.1 += vn * dt;
            c.turned += libm::fabs(twist.omega * dt);
        }
        self.x = x;
        self.x[BIAS_E] *= phi;
        self.x[BIAS_N] *= phi;
        self.P = P;
        self.twist = twist;
        self.tread = u;
        self.last_step = (dt, q_model, q_yaw);
        self.history.push(dt, u, self.law_input);
        self.basis[0] += v * v * dt;
        self.basis[1] += w * w * dt;
        Ok(())
    }

    /// The model from the state as it is now, every parameter held.
    pub fn dead_reckoning(&self) -> DeadReckoning {
        DeadReckoning {
            x: self.x,
            chart: self.cfg.chart,
            lag: self.cfg.turn_law_lag,
            lagged: self.law_input.spread,
            speed_lagged: self.learn_speed_law,
        }
    }

    /// The turn laws' inputs at a step whose tread speed difference
    /// `|V_r - V_l|` is `dv` (m/s), `lagged` that difference low-passed
    /// over `turn_law_lag`. The spread's law reads `lagged`: the ground
    /// takes a new turn up with a lag. The speed factors' law reads
    /// `lagged` where it is learned and `dv` where it is held (a
    /// calibration's, from `estimate --init`): held, it is the
    /// calibration's model, which scales the speed factors at each
    /// instant's tread speeds.
    pub(super) fn law_inputs(&self, dv: f64, lagged: f64) -> model::LawInputs {
        model::LawInputs {
            spread: lagged,
            speed: if self.learn_speed_law { lagged } else { dv },
        }
    }
}
