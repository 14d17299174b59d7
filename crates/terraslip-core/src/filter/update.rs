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

use nalgebra::{Vector2, Vector3};

use super::ekf::{finite_mat, isolate, Chord, GUESS_WEIGHT};
use super::gain::{blind_clock_gain, innovation, normalised, MatNx3};
use super::{Fate, Filter, FilterError, PoseFix, UpdateReport, Variant};
use crate::angle;
use crate::model::{MatN, CLOCK, N, YAW};

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
            unexplained: [0.0; 2],
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
                    self.noise[k].set_sensor_weight(GUESS_WEIGHT);
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
            if fate == Fate::Gated {
                report.unexplained[k] = if k == 0 {
                    0.5 * (nu[0] * nu[0] + nu[1] * nu[1] - S[(0, 0)] - S[(1, 1)])
                } else {
                    nu[2] * nu[2] - S[(2, 2)]
                }
                .max(0.0);
            }
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

    /// Recomputes the slip random walk in the chart at the current state
    /// (the walk is set in ICR terms; the chart's coordinates move).
    fn refresh_walk(&mut self) {
        if let Some(q) = self.cfg.slip_walk_cov(&self.icr()) {
            self.q_slip = q;
        }
    }
}
