//! The update step: a pose fix against where the robot was when it was
//! taken.
//!
//! A fix stamped `lag` seconds before the filter's time, on a clock that
//! runs `clock` seconds late, describes the robot `L = lag + clock` seconds
//! ago: the prediction is the current pose minus the motion of those
//! seconds (`history.rs`), plus the slow error of the position fixes:
//!
//! ```text
//! h_pos = p - D(L) + R(yaw - Psi(L)) l + b        h_yaw = yaw - Psi(L)
//! ```
//!
//! with `dh/dclock = -(velocity then)` and `l` the lever arm of the pose
//! reference on the robot (body frame; once the heading is known). Each part (position, heading) is
//! gated on its own chi-square with the noise as learned; the slip-change
//! detector may first raise the slip uncertainty; the gain is the Kalman
//! gain (or the papers' innovation-adaptive one) with the rows of whatever
//! must not learn from this fix zeroed, and the covariance update is the
//! Joseph form, so `P` stays symmetric positive-definite for any gain.

use nalgebra::{Matrix2, Matrix3, SMatrix, Vector2, Vector3};

use super::{
    finite_mat, isolate, Chord, Fate, Filter, FilterError, Mat3xN, PoseFix, SlipHold, UpdateReport,
    Variant,
};
use crate::angle;
use crate::model::{
    MatN, BIAS_E, BIAS_N, CLOCK, EAST, GYRO_SCALE, K_SPREAD_SPEED, K_X_SPEED, LAW, N, NORTH, SLIP,
    SPEED_LAW, YAW,
};

type MatNx3 = SMatrix<f64, N, 3>;

/// Position fixes teach the heading once the robot is this many position
/// stds (and at least `MIN_CHORD` m) away from the first fix.
const CHORD_STDS: f64 = 8.0;
const MIN_CHORD: f64 = 2.0;

/// Smallest position std (m) and heading std (rad) a fix is trusted with.
const MIN_STD_XY: f64 = 0.005;
const MIN_STD_YAW: f64 = 0.001;

/// Measured dimensions behind the noise belief before the gates apply.
const GATE_WARMUP: f64 = 2.0;
/// Heading 1-sigma (rad, about 11°) below which the iterated fix update holds the
/// heading at its prior and iterates the clock offset alone.
const HEADING_KNOWN_RAD: f64 = 0.2;

/// Fixes of each kind before the slip-change detector trusts the learned
/// noise enough to test (the noise scale must have settled first).
pub(super) const DETECTOR_WARMUP: f64 = 20.0;

impl Filter {
    /// Fuses a pose fix stamped `t` (s, the pose stream's clock) that is
    /// `lag` seconds older than the filter's state (0 when the filter has
    /// been predicted to the stamp). Parts failing their gate are not fused.
    pub fn update(&mut self, t: f64, lag: f64, fix: &PoseFix) -> Result<UpdateReport, FilterError> {
        if !(fix.std_xy.is_finite()
            && fix.std_xy > 0.0
            && fix.std_yaw.is_finite()
            && fix.std_yaw > 0.0)
        {
            return Err(FilterError::BadInput(
                "measurement std must be finite and > 0",
            ));
        }
        if !lag.is_finite() {
            return Err(FilterError::BadInput("fix lag not finite"));
        }
        let pos = match fix.position {
            Some((e, n)) if e.is_finite() && n.is_finite() => Some(Vector2::new(e, n)),
            Some(_) => return Err(FilterError::BadInput("position not finite")),
            None => None,
        };
        let yaw = match fix.yaw {
            Some(y) if y.is_finite() => Some(y),
            Some(_) => return Err(FilterError::BadInput("yaw not finite")),
            None => None,
        };
        let mut report = UpdateReport {
            position: if pos.is_some() {
                Fate::Fused
            } else {
                Fate::Absent
            },
            yaw: if yaw.is_some() {
                Fate::Fused
            } else {
                Fate::Absent
            },
            nis_position: 0.0,
            nis_yaw: 0.0,
            change: false,
            at_band: false,
        };
        let keep = match self.last_fix_t {
            Some(t0) if t > t0 && self.cfg.noise_memory > 0.0 => {
                libm::exp(-(t - t0) / self.cfg.noise_memory)
            }
            _ => 1.0,
        };
        self.last_fix_t = Some(t);
        for (k, present) in [(0, pos.is_some()), (1, yaw.is_some())] {
            if present && !self.noise_started[k] {
                self.noise_started[k] = true;
                if self.noise[k].learns() && !fix.stated {
                    self.noise[k].set_sensor_weight(super::GUESS_WEIGHT);
                }
            }
            if present {
                self.noise[k].forget(keep);
            }
        }
        let r_nom = [
            fix.std_xy * fix.std_xy,
            fix.std_xy * fix.std_xy,
            fix.std_yaw * fix.std_yaw,
        ];
        // No sensor is better than a floor (a localiser standing still
        // repeats its pose exactly; moving, it does not).
        let floor = [MIN_STD_XY * MIN_STD_XY, MIN_STD_YAW * MIN_STD_YAW];
        let r = [
            (r_nom[0] * self.noise[0].sensor()).max(floor[0]),
            (r_nom[1] * self.noise[0].sensor()).max(floor[0]),
            (r_nom[2] * self.noise[1].sensor()).max(floor[1]),
        ];
        if pos.is_some() {
            // A stated GNSS std describes the whole error, most of it slow;
            // a learned one only what moves between fixes.
            let std = if fix.stated {
                fix.std_xy
            } else {
                libm::sqrt(r[0])
            };
            self.set_bias_std(std);
        }
        let z = Vector3::new(
            pos.map_or(0.0, |p| p[0]),
            pos.map_or(0.0, |p| p[1]),
            yaw.unwrap_or(0.0),
        );

        // First fix of a kind: take it as the pose.
        let mut use_pos = pos.is_some();
        let mut use_yaw = yaw.is_some();
        self.heading_seen |= yaw.is_some();
        if yaw.is_some() && !self.anchored[1] {
            let m = self.motion(&self.x, lag);
            self.anchor(YAW, angle::wrap(z[2] + m.d_yaw), &[(CLOCK, m.omega)], r[2]);
            self.anchored[1] = true;
            self.chord = None;
            report.yaw = Fate::Anchored;
            use_yaw = false;
        }
        if pos.is_some() && !self.anchored[0] {
            self.anchor_position(&z, lag, r[0]);
            self.anchored[0] = true;
            report.position = Fate::Anchored;
            use_pos = false;
            if !self.anchored[1] {
                self.chord = Some(Chord {
                    start: (z[0], z[1]),
                    odo: (0.0, 0.0),
                    turned: 0.0,
                });
            }
        }
        if !use_pos && !use_yaw {
            return Ok(report);
        }

        // The prior's innovation: gates and the slip-change detector, per part.
        let yaw_known = self.anchored[1];
        let parts = [use_pos, use_pos, use_yaw];
        let (h, H) = self.measure(&self.x, lag, parts);
        let nu = innovation(&z, &h, parts);
        let (_, S) = self.innovation_cov(&H, &r, parts);
        let mut nis = [0.0; 2];
        let mut z_norm = [[0.0; 2]; 2];
        for (k, used) in [(0usize, use_pos), (1, use_yaw)] {
            if used {
                (nis[k], z_norm[k]) = normalised(&S, &nu, k)?;
            }
        }
        let moving = !self.still && yaw_known;
        let mut fired = false;
        for (k, used) in [(0usize, use_pos), (1, use_yaw)] {
            if used && moving && self.noise[k].count() >= DETECTOR_WARMUP {
                let dims = if k == 0 { 2 } else { 1 };
                if let Some(stat) =
                    self.detector[k].push(t, z_norm[k], dims, self.cfg.change_window)
                {
                    let threshold =
                        self.cfg.change_threshold * if k == 0 { 13.8 / 10.8 } else { 1.0 };
                    fired |= stat > threshold;
                }
            }
        }
        if fired && self.cfg.learn_icr {
            self.raise_slip_uncertainty()?;
            let (_, S) = self.innovation_cov(&H, &r, parts);
            for (k, used) in [(0usize, use_pos), (1, use_yaw)] {
                if used {
                    (nis[k], _) = normalised(&S, &nu, k)?;
                }
            }
            report.change = true;
        }
        report.change |= core::mem::take(&mut self.gyro_change);
        report.nis_position = nis[0];
        report.nis_yaw = nis[1];

        let mut reanchor = [false; 2];
        for (k, used, gate) in [
            (0usize, use_pos, self.cfg.gate_position),
            (1, use_yaw, self.cfg.gate_yaw),
        ] {
            if !used {
                continue;
            }
            // A guessed noise is not a gate until residuals have set it.
            let gate = if self.noise[k].count() >= GATE_WARMUP {
                gate
            } else {
                0.0
            };
            let fate = if gate > 0.0 && nis[k] > gate {
                self.rejected[k] += 1;
                if self.rejected[k] > self.cfg.max_rejections {
                    reanchor[k] = true;
                    Fate::Anchored
                } else {
                    Fate::Gated
                }
            } else {
                self.rejected[k] = 0;
                Fate::Fused
            };
            if k == 0 {
                report.position = fate;
                use_pos = fate == Fate::Fused;
            } else {
                report.yaw = fate;
                use_yaw = fate == Fate::Fused;
            }
        }
        // What this fix's innovation says about the noise (fused or gated;
        // `noise.rs`): the sensor's and the model's since the last fix.
        for (k, fate, dims) in [(0usize, report.position, 0..2), (1, report.yaw, 2..3)] {
            if !matches!(fate, Fate::Fused | Fate::Gated) {
                continue;
            }
            let gate = if k == 0 {
                self.cfg.gate_position / 2.0
            } else {
                self.cfg.gate_yaw
            };
            for i in dims {
                let (nu2, s) = ((nu[i] * nu[i]).min(gate * S[(i, i)]), S[(i, i)]);
                self.noise[k].add(nu2, s, r_nom[i], self.basis[k]);
            }
            self.basis[k] = 0.0;
        }
        if reanchor[1] {
            let m = self.motion(&self.x, lag);
            self.anchor(YAW, angle::wrap(z[2] + m.d_yaw), &[(CLOCK, m.omega)], r[2]);
            self.rejected[1] = 0;
        }
        if reanchor[0] {
            self.anchor_position(&z, lag, r[0]);
            self.rejected[0] = 0;
            if !self.heading_seen && !self.gyro_seen {
                // Without heading fixes, a run of rejected positions means
                // the heading found from them is lost: find it again, and
                // let the slip parameters learn again too.
                self.anchored[1] = false;
                isolate(&mut self.P, YAW, 0.0);
                self.gyro_win.close();
                self.chord = Some(Chord {
                    start: (z[0], z[1]),
                    odo: (0.0, 0.0),
                    turned: 0.0,
                });
                self.raise_slip_uncertainty()?;
            }
        }
        if report.position == Fate::Gated && !self.anchored[1] {
            // The chord is made of every fix, gated or not: the prediction
            // a fix failed rests on the heading the chord is to find.
            self.find_heading(Vector2::new(z[0], z[1]), libm::sqrt(r[0]));
        }
        if !use_pos && !use_yaw {
            return Ok(report);
        }

        // Iterated over the clock offset: x_{i+1} = x + K_i (z - h(x_i) -
        // H_i (x - x_i)), with x_i the prior but for the iterate's clock.
        // The motion of the lag is re-evaluated at the offset found (its
        // turns, its speed changes) and everything else stays linear about
        // the prior: re-evaluated at the iterate's heading too, the product
        // (heading step) x (clock step) would explain part of each
        // cross-track residual, and as the heading step follows that
        // residual, the product has one sign and the offset drifts negative
        // fix after fix.
        let used = [use_pos, use_pos, use_yaw];
        let iterations = match self.cfg.variant {
            Variant::Ekf => self.cfg.update_iterations,
            // The papers' gain is not a Gauss-Newton step.
            Variant::InnovationAdaptive => 1,
        };
        // Until the heading is known to a few degrees its linearisation is
        // poor and every state is iterated; after, the heading stays at the
        // prior and only the clock is.
        let heading_known = self.P[(YAW, YAW)] <= HEADING_KNOWN_RAD * HEADING_KNOWN_RAD;
        let mut xi = self.x;
        let mut last = None;
        for it in 0..iterations {
            let at = if heading_known {
                let mut at = self.x;
                at[CLOCK] = xi[CLOCK];
                at
            } else {
                xi
            };
            let (hi, Hi) = self.measure(&at, lag, used);
            let (HPi, Si) = self.innovation_cov(&Hi, &r, used);
            let mut dx = self.x - at;
            dx[YAW] = angle::wrap(dx[YAW]);
            let ri = innovation(&z, &hi, used) - Hi * dx;
            let gain_S = match self.cfg.variant {
                Variant::InnovationAdaptive => {
                    self.window.push(&ri, &used);
                    self.window
                        .covariance(self.cfg.innovation_window, &used)
                        .unwrap_or(Si)
                }
                Variant::Ekf => Si,
            };
            let chol = gain_S.cholesky().ok_or(FilterError::SingularInnovation)?;
            // K = P H' S^-1  <=>  S K' = H P
            let mut K: MatNx3 = chol.solve(&HPi).transpose();
            self.zero_gains(&mut K, yaw_known);
            blind_clock_gain(&mut K, &Hi);
            let mut x = self.x + K * ri;
            x[YAW] = angle::wrap(x[YAW]);
            let mut step = x - xi;
            step[YAW] = angle::wrap(step[YAW]);
            xi = x;
            last = Some((K, Hi, HPi, Si));
            // Converged: the step is far below the state's uncertainty.
            if it + 1 < iterations
                && (0..N).all(|k| step[k] * step[k] <= 1e-6 * self.P[(k, k)].max(1e-30))
            {
                break;
            }
        }
        let Some((K, Hl, HP, S)) = last else {
            return Ok(report);
        };
        self.gyro_win.after_update(&K, &Hl);
        let x = xi;
        let P = match self.cfg.variant {
            // lv2019 eq. 15, as written.
            Variant::InnovationAdaptive => self.P - K * HP,
            Variant::Ekf => {
                // Joseph form (I - K H) P (I - K H)' + K R K', expanded to
                // P - K HP - (K HP)' + K S K': exact for any gain.
                let KHP: MatN = K * HP;
                let P = self.P - KHP - KHP.transpose() + (K * S) * K.transpose();
                0.5 * (P + P.transpose())
            }
        };
        if !finite_mat(&x) || (0..N).any(|i| !P[(i, i)].is_finite()) {
            return Err(FilterError::NonFinite);
        }
        if (0..N).any(|i| P[(i, i)] < 0.0) {
            return Err(FilterError::LostDefiniteness);
        }
        let mut x = x;
        report.at_band = self.project(&mut x);
        self.x = x;
        self.P = P;

        if use_pos && !self.anchored[1] {
            self.find_heading(Vector2::new(z[0], z[1]), libm::sqrt(r[0]));
        }
        self.refresh_walk();
        Ok(report)
    }

    /// The motion over the fix's lag at state `x`.
    fn motion(&self, x: &crate::model::State, lag: f64) -> super::history::Motion {
        self.history.over(
            lag + x[CLOCK],
            self.cfg.chart,
            &crate::model::slip_of(x),
            x[LAW],
            &crate::model::centripetal_of(x),
            x[SPEED_LAW],
            x[YAW],
        )
    }

    /// Predicted fix `h(x)` and its Jacobian for the parts in `used`
    /// (rows east, north, yaw; unused rows zero).
    fn measure(
        &self,
        x: &crate::model::State,
        lag: f64,
        used: [bool; 3],
    ) -> (Vector3<f64>, Mat3xN) {
        let m = self.motion(x, lag);
        let mut h = Vector3::zeros();
        let mut H = Mat3xN::zeros();
        let yaw_known = self.anchored[1];
        if used[0] {
            h[0] = x[EAST] - m.d_east + x[BIAS_E];
            h[1] = x[NORTH] - m.d_north + x[BIAS_N];
            H[(0, EAST)] = 1.0;
            H[(1, NORTH)] = 1.0;
            H[(0, BIAS_E)] = 1.0;
            H[(1, BIAS_N)] = 1.0;
            H[(0, CLOCK)] = -m.v_east;
            H[(1, CLOCK)] = -m.v_north;
            if yaw_known {
                // The reference's point on the robot, turned with the
                // heading then.
                let (s, c) = libm::sincos(x[YAW] - m.d_yaw);
                let (lx, ly) = self.lever_arm();
                let (oe, on) = (c * lx - s * ly, s * lx + c * ly);
                h[0] += oe;
                h[1] += on;
                // d(offset)/d(heading then) = (-on, oe); the heading then
                // is yaw - Psi(L), Psi moving with the clock, slip and
                // centripetal terms as the heading row below.
                H[(0, YAW)] += -on;
                H[(1, YAW)] += oe;
                H[(0, CLOCK)] += on * m.omega;
                H[(1, CLOCK)] += -oe * m.omega;
                for k in 0..5 {
                    H[(0, SLIP + k)] += on * m.d_slip[(2, k)];
                    H[(1, SLIP + k)] += -oe * m.d_slip[(2, k)];
                }
                for (k, i) in [K_X_SPEED, K_SPREAD_SPEED, SPEED_LAW]
                    .into_iter()
                    .enumerate()
                {
                    H[(0, i)] += on * m.d_centripetal[(2, k)];
                    H[(1, i)] += -oe * m.d_centripetal[(2, k)];
                }
                // The motion of the lag turns with the heading and scales
                // with the slip parameters.
                H[(0, YAW)] += m.d_north;
                H[(1, YAW)] += -m.d_east;
                for k in 0..5 {
                    H[(0, SLIP + k)] += -m.d_slip[(0, k)];
                    H[(1, SLIP + k)] += -m.d_slip[(1, k)];
                }
                for (k, i) in [K_X_SPEED, K_SPREAD_SPEED, SPEED_LAW]
                    .into_iter()
                    .enumerate()
                {
                    H[(0, i)] += -m.d_centripetal[(0, k)];
                    H[(1, i)] += -m.d_centripetal[(1, k)];
                }
            }
        }
        if used[2] {
            h[2] = x[YAW] - m.d_yaw;
            H[(2, YAW)] = 1.0;
            H[(2, CLOCK)] = -m.omega;
            for k in 0..5 {
                H[(2, SLIP + k)] = -m.d_slip[(2, k)];
            }
            for (k, i) in [K_X_SPEED, K_SPREAD_SPEED, SPEED_LAW]
                .into_iter()
                .enumerate()
            {
                H[(2, i)] = -m.d_centripetal[(2, k)];
            }
        }
        (h, H)
    }

    /// Recomputes the slip random walk in the chart at the current state
    /// (the walk is set in ICR terms; the chart's coordinates move).
    fn refresh_walk(&mut self) {
        if let Some(q) = self.cfg.slip_walk_cov(&self.icr()) {
            self.q_slip = q;
        }
    }

    /// Sets state `i` to `value`, a fix of variance `r` plus `sum dep_k x_k`
    /// of other states: its covariance follows from theirs, so the fix's
    /// dependence on the clock offset (and bias, heading) stays known.
    fn anchor(&mut self, i: usize, value: f64, dep: &[(usize, f64)], r: f64) {
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
    fn anchor_position(&mut self, z: &Vector3<f64>, lag: f64, r: f64) {
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

    /// `H P` and `S = H P H' + R` with the rows not in `used` replaced by
    /// unit, uncorrelated ones (the reduced update in 3x3).
    fn innovation_cov(&self, H: &Mat3xN, r: &[f64; 3], used: [bool; 3]) -> (Mat3xN, Matrix3<f64>) {
        let mut HP: Mat3xN = H * self.P;
        let mut S: Matrix3<f64> = HP * H.transpose() + Matrix3::from_diagonal(&Vector3::from(*r));
        for i in 0..3 {
            if !used[i] {
                HP.row_mut(i).fill(0.0);
                for j in 0..3 {
                    S[(i, j)] = 0.0;
                    S[(j, i)] = 0.0;
                }
                S[(i, i)] = 1.0;
            }
        }
        (HP, 0.5 * (S + S.transpose()))
    }

    /// Zeroes the gain rows of what must not learn from this fix.
    fn zero_gains(&self, K: &mut MatNx3, yaw_known: bool) {
        for (i, f) in self.frozen(yaw_known).iter().enumerate() {
            if *f {
                K.row_mut(i).fill(0.0);
            }
        }
    }

    /// The states that must not learn from a measurement now: the slip
    /// parameters at standstill, when not learned or held
    /// ([`super::FilterConfig::hold`]), the speed factors when not learned, the clock likewise, and everything but the position
    /// and its bias from a position fix while the heading is unknown.
    pub(super) fn frozen(&self, yaw_known: bool) -> [bool; N] {
        let cfg = &self.cfg;
        let mut frozen = [false; N];
        if !yaw_known {
            // Position fixes move the position only until the heading is found.
            for (i, f) in frozen.iter_mut().enumerate() {
                *f = !matches!(i, EAST | NORTH | BIAS_E | BIAS_N);
            }
        }
        let hold_all = cfg.hold == SlipHold::All;
        for f in &mut frozen[SLIP..=LAW] {
            *f |= self.still || !cfg.learn_icr || hold_all;
        }
        // The speed factors' turn law, as the speed factors it scales.
        frozen[SPEED_LAW] |= self.still || !self.learn_speed_law || hold_all;
        for (k, held) in cfg.held_slots().iter().enumerate() {
            frozen[SLIP + k] |= *held;
        }
        if !cfg.learn_alpha {
            for k in cfg.chart.factor_slots() {
                frozen[SLIP + k] = true;
            }
        }
        frozen[CLOCK] |= self.still || !cfg.learn_clock;
        frozen[GYRO_SCALE] |= cfg.hold_gyro_scale;
        for (f, learn) in frozen[K_X_SPEED..=K_SPREAD_SPEED]
            .iter_mut()
            .zip(self.learn_centripetal)
        {
            *f |= self.still || !learn || hold_all;
        }
        frozen
    }

    /// Without heading fixes: once the robot is far enough from the first
    /// position fix, the heading is the angle between that chord and the
    /// same chord dead-reckoned in the filter's frame.
    fn find_heading(&mut self, z: Vector2<f64>, std_xy: f64) {
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

/// `z - h` on the parts in `used` (heading wrapped), zero elsewhere.
fn innovation(z: &Vector3<f64>, h: &Vector3<f64>, used: [bool; 3]) -> Vector3<f64> {
    let mut nu = Vector3::zeros();
    for i in 0..2 {
        if used[i] {
            nu[i] = z[i] - h[i];
        }
    }
    if used[2] {
        nu[2] = angle::wrap(z[2] - h[2]);
    }
    nu
}

/// NIS and normalised innovation (`L^-1 nu`) of part `k` (0 position,
/// 1 heading).
fn normalised(
    S: &Matrix3<f64>,
    nu: &Vector3<f64>,
    k: usize,
) -> Result<(f64, [f64; 2]), FilterError> {
    if k == 0 {
        let Spp: Matrix2<f64> = S.fixed_view::<2, 2>(0, 0).into_owned();
        let chol = Spp.cholesky().ok_or(FilterError::SingularInnovation)?;
        let v = Vector2::new(nu[0], nu[1]);
        let z = chol
            .l()
            .solve_lower_triangular(&v)
            .ok_or(FilterError::SingularInnovation)?;
        Ok((z.norm_squared(), [z[0], z[1]]))
    } else {
        if !(S[(2, 2)] > 0.0) {
            return Err(FilterError::SingularInnovation);
        }
        let z = nu[2] / libm::sqrt(S[(2, 2)]);
        Ok((z * z, [z, 0.0]))
    }
}

/// A fix taken while the robot stood still at the pose's time (the
/// measurement's clock column `H[.., CLOCK]` is zero: no motion for the
/// offset to shift) says nothing of the clock offset. The clock then keeps
/// its value (its gain row is zeroed, a consider update; the Joseph form
/// keeps `P` honest) instead of following the pose through their
/// correlation, which at stops and starts carries the slip model's errors.
#[allow(non_snake_case)]
fn blind_clock_gain(K: &mut MatNx3, H: &SMatrix<f64, 3, N>) {
    if (0..3).all(|j| H[(j, CLOCK)] == 0.0) {
        K.row_mut(CLOCK).fill(0.0);
    }
}
