//! The covariance of the body twist the ICR model gives, for an odometry
//! message another filter fuses (robot_localization, Nav2).
//!
//! Two parts add up:
//!
//! * **parameter uncertainty**: the covariance of the ICRs and speed
//!   factors `(y_l, y_r, x_c, alpha_l, alpha_r)` carried through the
//!   kinematics ([`twist_jacobian`]) at the current tread speeds. It does
//!   not average out over time (a wrong spread is wrong at every step);
//! * **slip noise** ([`TwistNoise`]): the variance of the model's twist
//!   error averaged over [`TWIST_WINDOW_S`], per body component a quadratic
//!   form of the motion, learned from the pose fixes at that horizon
//!   ([`crate::twist_noise`]); before any is learned, the filter's process
//!   noise on the pose (a random walk of diffusion `q`) averaged over the
//!   window, `q / window`.
//!
//! Frames: body REP-103 (x forward, y left); the twist is `(v_x, v_y, ω)`
//! in m/s, m/s, rad/s.

use nalgebra::{Matrix3, SMatrix};

use crate::kinematics::IcrParams;
use crate::slip::SlipMat;

/// Averaging window the model-noise share of the twist covariance is
/// stated for, s: the twist's error averaged over one second.
pub const TWIST_WINDOW_S: f64 = 1.0;

/// Smallest variance of each twist component, (m/s)² and (rad/s)²: a
/// twist covariance is never zero (a fusing filter would take the twist as
/// exact), even at standstill with no configured noise floor.
pub const TWIST_VARIANCE_FLOOR: f64 = 1e-6;

/// The filter's model noise at a step: diffusion of the position per axis
/// (m²/s) and of the yaw (rad²/s), as its prediction adds them.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ModelNoise {
    /// `q_pos`, m²/s.
    pub q_pos: f64,
    /// `q_speed`, m²/s per (m/s)² of mean tread speed.
    pub q_speed: f64,
    /// `q_yaw`, rad²/s.
    pub q_yaw: f64,
    /// `q_turn`, rad²/s per (rad/s)² of yaw rate.
    pub q_turn: f64,
}

impl ModelNoise {
    /// The model noise filter `f` adds at a step: its learned factors on
    /// speed and turn, its configured floors.
    pub fn of(f: &crate::filter::Filter) -> Self {
        let (q_speed, q_turn) = f.model_noise();
        Self {
            q_pos: f.config().q_pos,
            q_speed,
            q_yaw: f.config().q_yaw,
            q_turn,
        }
    }

    /// Diffusion `(q_xy, q_yaw)` at mean tread speed `v` (m/s) and yaw rate
    /// `omega` (rad/s), as the filter's prediction adds it.
    pub fn diffusion(&self, v: f64, omega: f64) -> (f64, f64) {
        (
            self.q_pos + self.q_speed * v * v,
            self.q_yaw + self.q_turn * omega * omega,
        )
    }
}

/// Variance of the model's twist error averaged over [`TWIST_WINDOW_S`],
/// per body component `k` (`v_x` in (m/s)², `v_y` in (m/s)², `ω` in
/// (rad/s)²): `coef[k][0] + coef[k][1] v² + coef[k][2] ω²` at mean tread
/// speed `v` (m/s) and yaw rate `ω` (rad/s). The components are taken as
/// uncorrelated.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TwistNoise {
    /// Per component: the constant part, the part per (m/s)² of speed and
    /// the part per (rad/s)² of yaw rate.
    pub coef: [[f64; 3]; 3],
}

impl TwistNoise {
    /// The filter's model noise `n` as the twist's error averaged over
    /// [`TWIST_WINDOW_S`] (its diffusion over the window, `q / window`).
    pub fn from_model_noise(n: &ModelNoise) -> Self {
        let w = TWIST_WINDOW_S;
        let xy = [n.q_pos / w, n.q_speed / w, 0.0];
        Self {
            coef: [xy, xy, [n.q_yaw / w, 0.0, n.q_turn / w]],
        }
    }

    /// Variances of `(v_x, v_y, ω)` at mean tread speed `v` (m/s) and yaw
    /// rate `omega` (rad/s); non-finite or negative parts count as 0.
    pub fn variance(&self, v: f64, omega: f64) -> [f64; 3] {
        core::array::from_fn(|k| {
            let c = self.coef[k];
            let q = c[0] + c[1] * v * v + c[2] * omega * omega;
            if q.is_finite() && q > 0.0 {
                q
            } else {
                0.0
            }
        })
    }
}

/// Derivative of the twist `(v_x, v_y, ω)` of [`IcrParams::twist`] with
/// respect to `(y_l, y_r, x_c, alpha_l, alpha_r)` at tread speeds
/// `v_left`, `v_right` (m/s).
pub fn twist_jacobian(p: &IcrParams, v_left: f64, v_right: f64) -> SMatrix<f64, 3, 5> {
    let d = p.guarded_spread();
    let d2 = d * d;
    let v_l = p.alpha_l * v_left;
    let v_r = p.alpha_r * v_right;
    // The guard holds the spread: no derivative through it there.
    let live = if p.spread() == d { 1.0 } else { 0.0 };
    let mut j = SMatrix::<f64, 3, 5>::zeros();
    // v_x = (v_r y_l - v_l y_r) / d
    j[(0, 0)] = live * p.y_r * (v_l - v_r) / d2;
    j[(0, 1)] = live * p.y_l * (v_r - v_l) / d2;
    j[(0, 3)] = -v_left * p.y_r / d;
    j[(0, 4)] = v_right * p.y_l / d;
    // v_y = x_c (v_l - v_r) / d
    j[(1, 0)] = -live * p.x_c * (v_l - v_r) / d2;
    j[(1, 1)] = live * p.x_c * (v_l - v_r) / d2;
    j[(1, 2)] = (v_l - v_r) / d;
    j[(1, 3)] = p.x_c * v_left / d;
    j[(1, 4)] = -p.x_c * v_right / d;
    // ω = (v_r - v_l) / d
    j[(2, 0)] = -live * (v_r - v_l) / d2;
    j[(2, 1)] = live * (v_r - v_l) / d2;
    j[(2, 3)] = -v_left / d;
    j[(2, 4)] = v_right / d;
    j
}

/// Covariance of the body twist `(v_x, v_y, ω)` at tread speeds `v_left`,
/// `v_right` (m/s): parameters `p` with covariance `icr_cov` carried
/// through the kinematics, plus the slip noise `noise` (the error of the
/// twist averaged over [`TWIST_WINDOW_S`]), plus
/// [`TWIST_VARIANCE_FLOOR`] on the diagonal. Symmetric positive definite
/// and finite for finite inputs; non-finite parts are dropped.
pub fn twist_covariance(
    p: &IcrParams,
    icr_cov: &SlipMat,
    noise: &TwistNoise,
    v_left: f64,
    v_right: f64,
) -> Matrix3<f64> {
    let j = twist_jacobian(p, v_left, v_right);
    let sym = 0.5 * (icr_cov + icr_cov.transpose());
    let mut c = j * sym * j.transpose();
    if !c.iter().all(|v| v.is_finite()) {
        c = Matrix3::zeros();
    }
    let omega = p.twist(v_left, v_right).omega;
    let q = noise.variance(0.5 * (v_left + v_right), omega);
    for k in 0..3 {
        c[(k, k)] += q[k] + TWIST_VARIANCE_FLOOR;
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> IcrParams {
        IcrParams {
            y_l: 0.62,
            y_r: -0.55,
            x_c: 0.08,
            alpha_l: 0.97,
            alpha_r: 1.03,
        }
    }

    #[test]
    fn the_jacobian_matches_finite_differences() {
        let (vl, vr) = (0.7, 1.3);
        let j = twist_jacobian(&p(), vl, vr);
        let h = 1e-7;
        for k in 0..5 {
            let mut a = [p().y_l, p().y_r, p().x_c, p().alpha_l, p().alpha_r];
            let mut b = a;
            a[k] += h;
            b[k] -= h;
            let q = |v: [f64; 5]| IcrParams {
                y_l: v[0],
                y_r: v[1],
                x_c: v[2],
                alpha_l: v[3],
                alpha_r: v[4],
            };
            let (ta, tb) = (q(a).twist(vl, vr), q(b).twist(vl, vr));
            let num = [
                (ta.v_x - tb.v_x) / (2.0 * h),
                (ta.v_y - tb.v_y) / (2.0 * h),
                (ta.omega - tb.omega) / (2.0 * h),
            ];
            for r in 0..3 {
                assert!(
                    (j[(r, k)] - num[r]).abs() < 1e-6,
                    "d twist[{r}] / d param[{k}]: {} vs {}",
                    j[(r, k)],
                    num[r]
                );
            }
        }
    }

    #[test]
    fn the_covariance_grows_with_the_turn_and_is_never_zero() {
        let mut cov = SlipMat::zeros();
        for k in 0..5 {
            cov[(k, k)] = 0.01f64.powi(2);
        }
        cov[(0, 1)] = -5e-5;
        cov[(1, 0)] = -5e-5;
        let noise = ModelNoise {
            q_pos: 1e-4,
            q_speed: 1e-3,
            q_yaw: 1e-6,
            q_turn: 1e-3,
        };
        let noise = TwistNoise::from_model_noise(&noise);
        let still = twist_covariance(&p(), &SlipMat::zeros(), &TwistNoise::default(), 0.0, 0.0);
        assert!(still.cholesky().is_some(), "{still}");
        let straight = twist_covariance(&p(), &cov, &noise, 1.0, 1.0);
        let turning = twist_covariance(&p(), &cov, &noise, 0.0, 2.0);
        assert!(turning[(2, 2)] > straight[(2, 2)]);
        assert!(
            turning[(1, 1)] > straight[(1, 1)],
            "x_c makes v_y uncertain in turns"
        );
        for c in [still, straight, turning] {
            assert!(c.cholesky().is_some(), "{c}");
            assert!((c - c.transpose()).norm() < 1e-15);
        }
        let bad = twist_covariance(&p(), &(cov * f64::NAN), &noise, 1.0, 1.0);
        assert!(bad.iter().all(|v| v.is_finite()));
    }
}
