//! Discrete process model of a skid-steering robot with unknown ICRs
//! (lv2019 eqs. 4-6, rewritten in REP-103) and its analytic Jacobian.
//!
//! State `s = [east, north, yaw, y_l, y_r, x_c]`: world ENU position (m),
//! yaw (rad, counter-clockwise from east), and the ICR coordinates of
//! [`IcrParams`] in the body frame (m). The tread speed factors `alpha_l`,
//! `alpha_r` are known constants of the model (from calibration), not states:
//! with GNSS-grade position they are not observable online.
//!
//! One Euler step of length `dt` with body twist `(v_x, v_y, omega)` from
//! [`IcrParams::twist`]:
//!
//! ```text
//! east'  = east  + dt*(v_x*cos(yaw) - v_y*sin(yaw))
//! north' = north + dt*(v_x*sin(yaw) + v_y*cos(yaw))
//! yaw'   = yaw   + dt*omega
//! icr'   = icr
//! ```
//!
//! (lv2019 writes the same with a heading measured from north.)

use nalgebra::{SMatrix, SVector};

use crate::angle;
use crate::kinematics::{IcrParams, MIN_SPREAD};

/// Dimension of the state.
pub const N: usize = 6;
/// State vector `[east, north, yaw, y_l, y_r, x_c]` (m, m, rad, m, m, m).
pub type State = SVector<f64, N>;
/// 6x6 matrix (covariance, Jacobian).
pub type Mat6 = SMatrix<f64, N, N>;

/// Index of east in the state.
pub const EAST: usize = 0;
/// Index of north in the state.
pub const NORTH: usize = 1;
/// Index of yaw in the state.
pub const YAW: usize = 2;
/// Index of the left tread ICR `y_l`.
pub const Y_L: usize = 3;
/// Index of the right tread ICR `y_r`.
pub const Y_R: usize = 4;
/// Index of the longitudinal ICR `x_c`.
pub const X_C: usize = 5;

/// Builds a state from a pose and ICRs.
pub fn state(east: f64, north: f64, yaw: f64, icr: &IcrParams) -> State {
    State::from([east, north, yaw, icr.y_l, icr.y_r, icr.x_c])
}

/// The ICRs held in a state, with the given speed factors.
pub fn icr_of(s: &State, alpha_l: f64, alpha_r: f64) -> IcrParams {
    IcrParams {
        y_l: s[Y_L],
        y_r: s[Y_R],
        x_c: s[X_C],
        alpha_l,
        alpha_r,
    }
}

/// Tread inputs of one prediction step: measured tread speeds (m/s) already
/// scaled by the speed factors `alpha`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TreadInput {
    /// Left tread speed `alpha_l * V_l`, m/s.
    pub v_l: f64,
    /// Right tread speed `alpha_r * V_r`, m/s.
    pub v_r: f64,
}

impl TreadInput {
    /// Scales measured tread speeds by the speed factors.
    pub fn new(v_left: f64, v_right: f64, alpha_l: f64, alpha_r: f64) -> Self {
        Self {
            v_l: alpha_l * v_left,
            v_r: alpha_r * v_right,
        }
    }
}

/// Spread `y_l - y_r` of a state, floored at [`MIN_SPREAD`] so nothing
/// divides by ~0 (the filter keeps it far above by its sanity band).
#[inline]
fn spread(s: &State) -> f64 {
    let d = s[Y_L] - s[Y_R];
    if d > MIN_SPREAD {
        d
    } else {
        MIN_SPREAD
    }
}

/// `f(s, u, dt)`: the state after `dt` seconds (yaw wrapped to `(-pi, pi]`).
pub fn predict(s: &State, u: TreadInput, dt: f64) -> State {
    let d = spread(s);
    let (y_l, y_r, x_c) = (s[Y_L], s[Y_R], s[X_C]);
    let v_x = (u.v_r * y_l - u.v_l * y_r) / d;
    let v_y = x_c * (u.v_l - u.v_r) / d;
    let omega = (u.v_r - u.v_l) / d;
    let (sn, cs) = (libm::sin(s[YAW]), libm::cos(s[YAW]));
    let mut out = *s;
    out[EAST] += dt * (v_x * cs - v_y * sn);
    out[NORTH] += dt * (v_x * sn + v_y * cs);
    out[YAW] = angle::wrap(s[YAW] + dt * omega);
    out
}

/// `F = df/ds` at `s` (the state before the step).
///
/// Where the spread is floored (`y_l - y_r <= MIN_SPREAD`) this is the
/// Jacobian of the unfloored formula: the filter never operates there.
pub fn jacobian(s: &State, u: TreadInput, dt: f64) -> Mat6 {
    let d = spread(s);
    let d2 = d * d;
    let (y_l, y_r, x_c) = (s[Y_L], s[Y_R], s[X_C]);
    let dv = u.v_l - u.v_r;
    let v_x = (u.v_r * y_l - u.v_l * y_r) / d;
    let v_y = x_c * dv / d;
    // Partial derivatives of the twist by (y_l, y_r, x_c).
    let vx_l = y_r * dv / d2;
    let vx_r = -y_l * dv / d2;
    let vy_l = -x_c * dv / d2;
    let vy_r = x_c * dv / d2;
    let vy_c = dv / d;
    let w_l = dv / d2;
    let w_r = -dv / d2;
    let (sn, cs) = (libm::sin(s[YAW]), libm::cos(s[YAW]));

    let mut f = Mat6::identity();
    f[(EAST, YAW)] = dt * (-v_x * sn - v_y * cs);
    f[(NORTH, YAW)] = dt * (v_x * cs - v_y * sn);
    f[(EAST, Y_L)] = dt * (vx_l * cs - vy_l * sn);
    f[(EAST, Y_R)] = dt * (vx_r * cs - vy_r * sn);
    f[(EAST, X_C)] = dt * (-vy_c * sn);
    f[(NORTH, Y_L)] = dt * (vx_l * sn + vy_l * cs);
    f[(NORTH, Y_R)] = dt * (vx_r * sn + vy_r * cs);
    f[(NORTH, X_C)] = dt * (vy_c * cs);
    f[(YAW, Y_L)] = dt * w_l;
    f[(YAW, Y_R)] = dt * w_r;
    f
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn central_difference(s: &State, u: TreadInput, dt: f64) -> Mat6 {
        let mut f = Mat6::zeros();
        for j in 0..N {
            let h = 1e-6;
            let mut sp = *s;
            let mut sm = *s;
            sp[j] += h;
            sm[j] -= h;
            let mut col = predict(&sp, u, dt) - predict(&sm, u, dt);
            col[YAW] = angle::wrap(col[YAW]);
            f.set_column(j, &(col / (2.0 * h)));
        }
        f
    }

    #[test]
    fn straight_line_moves_along_heading() {
        let s = state(
            1.0,
            2.0,
            core::f64::consts::FRAC_PI_2,
            &IcrParams::no_slip(0.5),
        );
        let s2 = predict(&s, TreadInput::new(1.0, 1.0, 1.0, 1.0), 0.5);
        assert!((s2[EAST] - 1.0).abs() < 1e-12);
        assert!((s2[NORTH] - 2.5).abs() < 1e-12);
        assert!((s2[YAW] - s[YAW]).abs() < 1e-12);
    }

    #[test]
    fn turning_left_increases_yaw_and_x_c_drifts_sideways() {
        let icr = IcrParams::new(0.3, -0.3, 0.1);
        let s = state(0.0, 0.0, 0.0, &icr);
        let s2 = predict(&s, TreadInput::new(-0.6, 0.6, 1.0, 1.0), 0.1);
        // omega = 1.2/0.6 = 2 rad/s; v_y = -x_c*omega = -0.2 m/s
        assert!((s2[YAW] - 0.2).abs() < 1e-12);
        assert!((s2[NORTH] + 0.02).abs() < 1e-12);
    }

    proptest! {
        #[test]
        fn jacobian_matches_central_differences(
            e in -100.0f64..100.0, n in -100.0f64..100.0, yaw in -3.1f64..3.1,
            y_l in 0.1f64..1.2, y_r in -1.2f64..-0.1, x_c in -0.3f64..0.3,
            vl in -2.0f64..2.0, vr in -2.0f64..2.0, dt in 0.001f64..0.5,
        ) {
            let s = State::from([e, n, yaw, y_l, y_r, x_c]);
            let u = TreadInput { v_l: vl, v_r: vr };
            let fa = jacobian(&s, u, dt);
            let fd = central_difference(&s, u, dt);
            for i in 0..N {
                for j in 0..N {
                    let tol = 1e-6 * (1.0 + fa[(i, j)].abs());
                    prop_assert!((fa[(i, j)] - fd[(i, j)]).abs() < tol,
                        "F[{},{}] analytic {} numeric {}", i, j, fa[(i, j)], fd[(i, j)]);
                }
            }
        }
    }
}
