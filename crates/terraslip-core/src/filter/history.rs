//! The recent tread speeds, so that a fix stamped in the past (or on a
//! clock that runs late) is compared with where the robot was then.
//!
//! Each prediction step is stored as its duration and tread speeds. The
//! motion of the last `lag` seconds is integrated backwards from the
//! current heading with the current slip parameters (so an iterated update
//! can re-evaluate it at another state): the displacement and heading
//! change from then to now, the velocity then, and their partial
//! derivatives by the slip parameters. A negative lag (a fix from the
//! future of the wheels) extrapolates with the newest speeds.

use nalgebra::SMatrix;

use crate::kinematics::CentripetalSlopes;
use crate::model::LawInputs;
use crate::slip::{Chart, Slip, TreadInput};

/// Steps kept (at 100 Hz, 2.5 s).
pub(super) const CAPACITY: usize = 256;

#[derive(Debug, Clone, Copy, Default)]
struct Step {
    dt: f64,
    u: TreadInput,
    /// The turn laws' inputs.
    dv: LawInputs,
}

/// Motion over a lag: displacement (world frame) and heading change from
/// then to now, the velocity at that time, and `d(displacement east,
/// north, heading change) / d(slip)`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Motion {
    pub d_east: f64,
    pub d_north: f64,
    pub d_yaw: f64,
    pub v_east: f64,
    pub v_north: f64,
    pub omega: f64,
    pub d_slip: SMatrix<f64, 3, 5>,
    /// `d(heading change) / d(turn law slope)`.
    pub d_yaw_law: f64,
    /// `d(displacement east, north, heading change) / d(k_x_speed,
    /// k_spread_speed, speed_law)`.
    pub d_centripetal: SMatrix<f64, 3, 3>,
}

#[derive(Debug, Clone)]
pub(super) struct History {
    steps: [Step; CAPACITY],
    len: usize,
    next: usize,
}

impl History {
    pub(super) const fn new() -> Self {
        Self {
            steps: [Step {
                dt: 0.0,
                u: TreadInput {
                    v_left: 0.0,
                    v_right: 0.0,
                },
                dv: LawInputs::both(0.0),
            }; CAPACITY],
            len: 0,
            next: 0,
        }
    }

    /// Records one prediction step of `dt` s with tread speeds `u` and
    /// turn-law inputs `dv`.
    pub(super) fn push(&mut self, dt: f64, u: TreadInput, dv: LawInputs) {
        self.steps[self.next] = Step { dt, u, dv };
        self.next = (self.next + 1) % CAPACITY;
        self.len = (self.len + 1).min(CAPACITY);
    }

    /// Forgets the motion (after the pose was re-anchored).
    pub(super) fn clear(&mut self) {
        self.len = 0;
    }

    /// The motion of the last `lag` seconds with slip parameters `s` in
    /// `chart`, turn law slope `law`, centripetal terms `c` and the speed
    /// factors' turn law `speed_law` (s/m), ending at heading `yaw`
    /// (negative lag: extrapolated ahead).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn over(
        &self,
        lag: f64,
        chart: Chart,
        s: &Slip,
        law: f64,
        c: &CentripetalSlopes,
        speed_law: f64,
        yaw: f64,
    ) -> Motion {
        let twist = |dv: LawInputs, u: TreadInput| {
            let parts = chart.twist_with_terms(s, law, dv.spread, c, u);
            crate::model::with_speed_law(parts, speed_law, dv.speed)
        };
        let newest = if self.len > 0 {
            self.steps[(self.next + CAPACITY - 1) % CAPACITY]
        } else {
            Step::default()
        };
        let mut m = Motion::default();
        let lag = if lag.is_finite() { lag } else { 0.0 };
        if lag <= 0.0 {
            // Ahead of the newest step: the motion to come, negated.
            let (t, j, _, dc) = twist(newest.dv, newest.u);
            let (sn, cs) = (libm::sin(yaw), libm::cos(yaw));
            m.v_east = t.v_x * cs - t.v_y * sn;
            m.v_north = t.v_x * sn + t.v_y * cs;
            m.omega = t.omega;
            m.d_east = lag * m.v_east;
            m.d_north = lag * m.v_north;
            m.d_yaw = lag * m.omega;
            for k in 0..5 {
                m.d_slip[(0, k)] = lag * (j[(0, k)] * cs - j[(1, k)] * sn);
                m.d_slip[(1, k)] = lag * (j[(0, k)] * sn + j[(1, k)] * cs);
                m.d_slip[(2, k)] = lag * j[(2, k)];
            }
            for k in 0..3 {
                m.d_centripetal[(0, k)] = lag * (dc[(0, k)] * cs - dc[(1, k)] * sn);
                m.d_centripetal[(1, k)] = lag * (dc[(0, k)] * sn + dc[(1, k)] * cs);
                m.d_centripetal[(2, k)] = lag * dc[(2, k)];
            }
            return m;
        }
        let mut left = lag;
        let mut heading = yaw;
        let mut i = 0;
        let mut last = newest;
        while left > 0.0 {
            // Beyond what is kept: continue at the oldest speeds kept.
            let step = if i < self.len {
                self.steps[(self.next + CAPACITY - 1 - i) % CAPACITY]
            } else {
                Step { dt: left, ..last }
            };
            i += 1;
            last = step;
            let dt = step.dt.min(left);
            left -= dt;
            let (t, j, dk, dc) = twist(step.dv, step.u);
            // Integrated backwards: the heading at the start of this step.
            heading -= dt * t.omega;
            let (sn, cs) = (libm::sin(heading), libm::cos(heading));
            let (ve, vn) = (t.v_x * cs - t.v_y * sn, t.v_x * sn + t.v_y * cs);
            m.d_east += dt * ve;
            m.d_north += dt * vn;
            m.d_yaw += dt * t.omega;
            m.d_yaw_law += dt * dk[2];
            for k in 0..5 {
                m.d_slip[(0, k)] += dt * (j[(0, k)] * cs - j[(1, k)] * sn);
                m.d_slip[(1, k)] += dt * (j[(0, k)] * sn + j[(1, k)] * cs);
                m.d_slip[(2, k)] += dt * j[(2, k)];
            }
            for k in 0..3 {
                m.d_centripetal[(0, k)] += dt * (dc[(0, k)] * cs - dc[(1, k)] * sn);
                m.d_centripetal[(1, k)] += dt * (dc[(0, k)] * sn + dc[(1, k)] * cs);
                m.d_centripetal[(2, k)] += dt * dc[(2, k)];
            }
            m.v_east = ve;
            m.v_north = vn;
            m.omega = t.omega;
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::IcrParams;

    #[test]
    fn motion_over_a_lag_integrates_backwards_from_now() {
        let chart = Chart::Tread;
        let s = chart.from_icr(&IcrParams::no_slip(1.0));
        let mut h = History::new();
        // 0.1 s straight at 1 m/s, then 0.1 s spinning at 1 rad/s.
        h.push(
            0.1,
            TreadInput {
                v_left: 1.0,
                v_right: 1.0,
            },
            LawInputs::both(0.0),
        );
        h.push(
            0.1,
            TreadInput {
                v_left: -0.5,
                v_right: 0.5,
            },
            LawInputs::both(1.0),
        );
        let yaw = 0.1;
        let none = CentripetalSlopes::NONE;
        let m = h.over(0.2, chart, &s, 0.0, &none, 0.0, yaw);
        assert!((m.d_yaw - 0.1).abs() < 1e-12);
        // The straight was driven at heading 0.
        assert!((m.d_east - 0.1).abs() < 1e-12 && m.d_north.abs() < 1e-12);
        assert!((m.v_east - 1.0).abs() < 1e-12 && m.omega == 0.0);
        let half = h.over(0.05, chart, &s, 0.0, &none, 0.0, yaw);
        assert!((half.d_yaw - 0.05).abs() < 1e-12 && (half.omega - 1.0).abs() < 1e-12);
        let ahead = h.over(-0.5, chart, &s, 0.0, &none, 0.0, yaw);
        assert!((ahead.d_yaw + 0.5).abs() < 1e-12);
        let beyond = h.over(1.2, chart, &s, 0.0, &none, 0.0, yaw);
        assert!((beyond.d_east - 1.1).abs() < 1e-9);
    }

    #[test]
    fn the_heading_change_s_centripetal_derivatives_match_central_differences() {
        for chart in [Chart::Tread, Chart::Gain] {
            let s = chart.from_icr(&IcrParams::new(0.6, -0.55, 0.05));
            let mut h = History::new();
            for (k, (vl, vr)) in [(0.8, 1.2), (-0.4, 0.3), (1.1, 0.2), (-0.6, -0.9)]
                .into_iter()
                .enumerate()
            {
                for _ in 0..10 {
                    h.push(
                        0.02,
                        TreadInput {
                            v_left: vl,
                            v_right: vr,
                        },
                        LawInputs::both(0.1 * k as f64),
                    );
                }
            }
            let c = CentripetalSlopes {
                k_x_speed: 0.12,
                k_spread_speed: -0.08,
            };
            for lag in [0.7, -0.3] {
                let m = h.over(lag, chart, &s, -0.05, &c, 0.0, 0.3);
                for k in 0..2 {
                    let eps = 1e-6;
                    let (mut cp, mut cm) = (c, c);
                    if k == 0 {
                        cp.k_x_speed += eps;
                        cm.k_x_speed -= eps;
                    } else {
                        cp.k_spread_speed += eps;
                        cm.k_spread_speed -= eps;
                    }
                    let (p, q) = (
                        h.over(lag, chart, &s, -0.05, &cp, 0.0, 0.3),
                        h.over(lag, chart, &s, -0.05, &cm, 0.0, 0.3),
                    );
                    let num = (p.d_yaw - q.d_yaw) / (2.0 * eps);
                    // The heading change exactly; the displacement's rows,
                    // like `d_slip`'s, hold each step's heading (first order
                    // in the turn over the lag) and are not compared.
                    assert!(
                        (num - m.d_centripetal[(2, k)]).abs() < 1e-6 * (1.0 + num.abs()),
                        "{chart:?} lag {lag} d_yaw/dc{k}: {} vs {}",
                        num,
                        m.d_centripetal[(2, k)]
                    );
                }
            }
        }
    }
}
