//! The ICR model in effect on the ground now, with its laws, and its
//! inverse: the tread speeds that give a desired twist (what slip
//! compensation sends the drive controller).
//!
//! Frames and units: body frame (REP-103: x forward, y left, yaw
//! counter-clockwise); tread speeds and forward speed m/s, yaw rate rad/s.

use crate::kinematics::{CentripetalSlopes, IcrParams, KinematicsError, Twist};
use crate::slip::law_factor;

/// The ICR model in effect on the ground now: the filter's straight-line
/// ICRs at rest and the laws that move them with the treads' speeds (the
/// process model of [`crate::model`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IcrModel {
    /// Straight-line ICRs and speed factors at rest (body frame, m).
    pub icr: IcrParams,
    /// Slope of the spread's turn law, s/m: the spread in effect is
    /// `1 + spread_law |V_r - V_l|` times `icr`'s, about the ICR centre
    /// (the factor clamped as [`law_factor`]).
    pub spread_law: f64,
    /// Slope of the speed factors' turn law, s/m: both speed factors in
    /// effect are `1 + speed_law |V_r - V_l|` times `icr`'s (clamped).
    pub speed_law: f64,
    /// The centripetal terms (`x_c` and the spread with the mean tread
    /// speed).
    pub centripetal: CentripetalSlopes,
}

impl IcrModel {
    /// A sandy ground, for examples, tests and benchmarks: a wide spread
    /// (0.88 m), slow treads (speed factors 0.88 and 0.93), turn laws of
    /// both signs and both centripetal terms.
    pub const EXAMPLE_SAND: Self = Self {
        icr: IcrParams {
            y_l: 0.47,
            y_r: -0.41,
            x_c: 0.03,
            alpha_l: 0.88,
            alpha_r: 0.93,
        },
        spread_law: 0.15,
        speed_law: -0.05,
        centripetal: CentripetalSlopes {
            k_x_speed: 0.04,
            k_spread_speed: 0.1,
        },
    };
}

/// Most steps [`IcrModel::tread_speeds`] takes.
const MAX_ITERATIONS: usize = 40;
/// Times a Newton step is halved before a plain fixed-point step is taken.
const NEWTON_HALVINGS: usize = 8;
/// Steps from standstill to a command the direct search missed.
const CONTINUATION_STEPS: usize = 16;
/// Relative residual (m/s per m/s) below which the fixed point is found.
const CONVERGED: f64 = 1e-12;

impl IcrModel {
    /// The model with constant ICRs `icr` (no laws).
    pub const fn constant(icr: IcrParams) -> Self {
        Self {
            icr,
            spread_law: 0.0,
            speed_law: 0.0,
            centripetal: CentripetalSlopes::NONE,
        }
    }

    /// The model a drive controller of wheel separation `separation` (m)
    /// holds: the no-slip differential drive.
    pub const fn nominal(separation: f64) -> Self {
        Self::constant(IcrParams::no_slip(separation))
    }

    /// The filter's model now: its straight-line ICRs, turn laws and
    /// centripetal terms.
    pub fn of_filter(f: &crate::Filter) -> Self {
        Self {
            icr: f.icr(),
            spread_law: f.turn_law().0,
            speed_law: f.speed_law().0,
            centripetal: f.centripetal().0,
        }
    }

    /// Checks that the ICRs are usable and every slope finite.
    pub fn validate(&self) -> Result<(), KinematicsError> {
        self.icr.validate()?;
        let c = self.centripetal;
        if [
            self.spread_law,
            self.speed_law,
            c.k_x_speed,
            c.k_spread_speed,
        ]
        .iter()
        .all(|k| k.is_finite())
        {
            Ok(())
        } else {
            Err(KinematicsError::NonFinite)
        }
    }

    /// The constant ICRs in effect at tread speeds `v_left`, `v_right`
    /// (m/s): the spread scaled about the ICR centre by the turn law and
    /// the centripetal factor, `x_c` moved by the centripetal shift, the
    /// speed factors scaled by their turn law, as the filter's process
    /// model has them.
    pub fn at(&self, v_left: f64, v_right: f64) -> IcrParams {
        let dv = libm::fabs(v_right - v_left);
        let v = 0.5 * (v_left + v_right);
        let c = self.centripetal;
        let f = law_factor(self.spread_law, dv).0 * law_factor(c.k_spread_speed, libm::fabs(v)).0;
        let a = law_factor(self.speed_law, dv).0;
        let p = self.icr;
        let (centre, half) = (0.5 * (p.y_l + p.y_r), 0.5 * f * (p.y_l - p.y_r));
        IcrParams {
            y_l: centre + half,
            y_r: centre - half,
            x_c: p.x_c + c.k_x_speed * v,
            alpha_l: a * p.alpha_l,
            alpha_r: a * p.alpha_r,
        }
    }

    /// Body twist at tread speeds `v_left`, `v_right` (m/s).
    pub fn twist(&self, v_left: f64, v_right: f64) -> Twist {
        self.at(v_left, v_right).twist(v_left, v_right)
    }

    /// Tread speeds `(V_l, V_r)` (m/s) whose twist has forward speed `v_x`
    /// (m/s) and yaw rate `omega` (rad/s): the fixed point of
    /// [`IcrParams::tread_speeds`] under the ICRs those speeds put in
    /// effect, found by Newton steps (a plain fixed-point step where
    /// Newton's does not shrink the residual; from standstill in steps
    /// where the first search fails). `None` when it does not
    /// converge (a law steeper than the turn it answers) or is not finite.
    pub fn tread_speeds(&self, v_x: f64, omega: f64) -> Option<(f64, f64)> {
        let start = self.icr.tread_speeds(v_x, omega);
        if let Some(z) = self.solve_from(start, v_x, omega) {
            return Some(z);
        }
        // Continuation: the command reached in steps from standstill, each
        // solved from the last (the laws bend the map too far for one).
        let mut z = (0.0, 0.0);
        for k in 1..=CONTINUATION_STEPS {
            let f = k as f64 / CONTINUATION_STEPS as f64;
            z = self.solve_from(z, f * v_x, f * omega)?;
        }
        Some(z)
    }

    /// Newton's search for [`Self::tread_speeds`] from the guess `start`.
    fn solve_from(&self, start: (f64, f64), v_x: f64, omega: f64) -> Option<(f64, f64)> {
        let residual = |z: (f64, f64)| {
            let n = self.at(z.0, z.1).tread_speeds(v_x, omega);
            (n.0 - z.0, n.1 - z.1)
        };
        let size = |r: (f64, f64)| libm::fabs(r.0).max(libm::fabs(r.1));
        let mut z = start;
        let mut r = residual(z);
        for _ in 0..MAX_ITERATIONS {
            if !(size(r).is_finite() && z.0.is_finite() && z.1.is_finite()) {
                return None;
            }
            if size(r) <= CONVERGED * (1.0 + libm::fabs(z.0) + libm::fabs(z.1)) {
                return Some(z);
            }
            // Newton on the residual, its Jacobian by forward differences.
            let h = 1e-7 * (1.0 + size(z));
            let (a, b) = (residual((z.0 + h, z.1)), residual((z.0, z.1 + h)));
            let j = [
                [(a.0 - r.0) / h, (b.0 - r.0) / h],
                [(a.1 - r.1) / h, (b.1 - r.1) / h],
            ];
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            let step = (
                -(j[1][1] * r.0 - j[0][1] * r.1) / det,
                -(j[0][0] * r.1 - j[1][0] * r.0) / det,
            );
            // The Newton step, halved until it shrinks the residual.
            let mut shrunk = None;
            let mut fraction = 1.0;
            for _ in 0..NEWTON_HALVINGS {
                let candidate = (z.0 + fraction * step.0, z.1 + fraction * step.1);
                let rc = residual(candidate);
                if size(rc) < size(r) {
                    shrunk = Some((candidate, rc));
                    break;
                }
                fraction *= 0.5;
            }
            if let Some(found) = shrunk {
                (z, r) = found;
            } else {
                z = (z.0 + r.0, z.1 + r.1);
                r = residual(z);
            }
        }
        None
    }

    /// The model a fraction `s` (0..1) of the way from `self` to `to`,
    /// every parameter interpolated (valid when both ends are).
    pub fn towards(&self, to: &IcrModel, s: f64) -> IcrModel {
        let l = |a: f64, b: f64| a + s * (b - a);
        let (p, q) = (self.icr, to.icr);
        IcrModel {
            icr: IcrParams {
                y_l: l(p.y_l, q.y_l),
                y_r: l(p.y_r, q.y_r),
                x_c: l(p.x_c, q.x_c),
                alpha_l: l(p.alpha_l, q.alpha_l),
                alpha_r: l(p.alpha_r, q.alpha_r),
            },
            spread_law: l(self.spread_law, to.spread_law),
            speed_law: l(self.speed_law, to.speed_law),
            centripetal: CentripetalSlopes {
                k_x_speed: l(self.centripetal.k_x_speed, to.centripetal.k_x_speed),
                k_spread_speed: l(
                    self.centripetal.k_spread_speed,
                    to.centripetal.k_spread_speed,
                ),
            },
        }
    }
}
