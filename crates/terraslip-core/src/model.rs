//! Discrete process model of a skid-steering robot with unknown ICRs
//! (lv2019 eqs. 4-6, rewritten in REP-103, extended with the tread speed
//! factors of Mandow eq. 6-7) and its analytic Jacobian.
//!
//! State `s = [east, north, yaw, y_l, y_r, x_c, alpha_l, alpha_r]`: world
//! ENU position (m), yaw (rad, counter-clockwise from east), the ICR
//! coordinates of [`IcrParams`] in the body frame (m) and the factors that
//! scale the measured tread speeds (1 = nominal). The factors matter: a
//! 0.4 % difference between `alpha_l` and `alpha_r` turns a robot whose
//! encoders say "straight" by a few tenths of a degree per second, which no
//! choice of ICRs can explain. The filter can hold them fixed (the papers'
//! six-state model) or learn them.
//!
//! One Euler step of length `dt` with body twist `(v_x, v_y, omega)` from
//! [`IcrParams::twist`] of the measured speeds `(V_l, V_r)`:
//!
//! ```text
//! east'  = east  + dt*(v_x*cos(yaw) - v_y*sin(yaw))
//! north' = north + dt*(v_x*sin(yaw) + v_y*cos(yaw))
//! yaw'   = yaw   + dt*omega
//! icr'   = icr,  alpha' = alpha
//! ```
//!
//! (lv2019 writes the same with a heading measured from north.)

use nalgebra::{SMatrix, SVector};

use crate::angle;
use crate::kinematics::{IcrParams, MIN_SPREAD};

/// Dimension of the state.
pub const N: usize = 8;
/// Number of slip parameters (`y_l, y_r, x_c, alpha_l, alpha_r`).
pub const K: usize = 5;
/// State vector `[east, north, yaw, y_l, y_r, x_c, alpha_l, alpha_r]`.
pub type State = SVector<f64, N>;
/// NxN matrix (covariance, Jacobian).
pub type MatN = SMatrix<f64, N, N>;
/// Covariance of the slip parameters, on `(y_l, y_r, x_c, alpha_l, alpha_r)`.
pub type SlipCov = SMatrix<f64, K, K>;

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
/// Index of the left tread speed factor.
pub const ALPHA_L: usize = 6;
/// Index of the right tread speed factor.
pub const ALPHA_R: usize = 7;
/// First index of the slip parameters.
pub const SLIP: usize = Y_L;

/// Builds a state from a pose and slip parameters.
pub fn state(east: f64, north: f64, yaw: f64, icr: &IcrParams) -> State {
    State::from([
        east,
        north,
        yaw,
        icr.y_l,
        icr.y_r,
        icr.x_c,
        icr.alpha_l,
        icr.alpha_r,
    ])
}

/// The slip parameters held in a state.
pub fn icr_of(s: &State) -> IcrParams {
    IcrParams {
        y_l: s[Y_L],
        y_r: s[Y_R],
        x_c: s[X_C],
        alpha_l: s[ALPHA_L],
        alpha_r: s[ALPHA_R],
    }
}

/// Measured tread speeds of one prediction step, m/s (before the factors).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TreadInput {
    /// Left tread speed from the encoders, m/s.
    pub v_left: f64,
    /// Right tread speed from the encoders, m/s.
    pub v_right: f64,
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
    let (v_l, v_r) = (s[ALPHA_L] * u.v_left, s[ALPHA_R] * u.v_right);
    let v_x = (v_r * y_l - v_l * y_r) / d;
    let v_y = x_c * (v_l - v_r) / d;
    let omega = (v_r - v_l) / d;
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
pub fn jacobian(s: &State, u: TreadInput, dt: f64) -> MatN {
    predict_with_jacobian(s, u, u, dt).1
}

/// [`predict`] and [`jacobian`] together, sharing the trigonometry (the
/// filter's hot path). The slip-parameter columns of the Jacobian are
/// evaluated at `u_slip` (the filter passes smoothed tread speeds there:
/// see [`crate::filter::FilterConfig::slip_input_time_constant`]); with
/// `u_slip == u` this is exactly [`jacobian`].
pub fn predict_with_jacobian(
    s: &State,
    u: TreadInput,
    u_slip: TreadInput,
    dt: f64,
) -> (State, MatN) {
    let d = spread(s);
    let inv_d = 1.0 / d;
    let inv_d2 = inv_d * inv_d;
    let (y_l, y_r, x_c) = (s[Y_L], s[Y_R], s[X_C]);
    let (v_l, v_r) = (s[ALPHA_L] * u.v_left, s[ALPHA_R] * u.v_right);
    let dv = v_l - v_r;
    let v_x = (v_r * y_l - v_l * y_r) * inv_d;
    let v_y = x_c * dv * inv_d;
    let omega = -dv * inv_d;
    let (sn, cs) = (libm::sin(s[YAW]), libm::cos(s[YAW]));

    let mut out = *s;
    out[EAST] += dt * (v_x * cs - v_y * sn);
    out[NORTH] += dt * (v_x * sn + v_y * cs);
    out[YAW] = angle::wrap(s[YAW] + dt * omega);

    // Partial derivatives of the twist (v_x, v_y, omega) by each slip
    // parameter; (alpha_l, alpha_r) act through v_l = alpha_l V_l, v_r = alpha_r V_r.
    let u = u_slip;
    let dv = s[ALPHA_L] * u.v_left - s[ALPHA_R] * u.v_right;
    let cols = [
        (Y_L, y_r * dv * inv_d2, -x_c * dv * inv_d2, dv * inv_d2),
        (Y_R, -y_l * dv * inv_d2, x_c * dv * inv_d2, -dv * inv_d2),
        (X_C, 0.0, dv * inv_d, 0.0),
        (
            ALPHA_L,
            -y_r * inv_d * u.v_left,
            x_c * inv_d * u.v_left,
            -u.v_left * inv_d,
        ),
        (
            ALPHA_R,
            y_l * inv_d * u.v_right,
            -x_c * inv_d * u.v_right,
            u.v_right * inv_d,
        ),
    ];
    let mut f = MatN::identity();
    f[(EAST, YAW)] = dt * (-v_x * sn - v_y * cs);
    f[(NORTH, YAW)] = dt * (v_x * cs - v_y * sn);
    for (j, dvx, dvy, dw) in cols {
        f[(EAST, j)] = dt * (dvx * cs - dvy * sn);
        f[(NORTH, j)] = dt * (dvx * sn + dvy * cs);
        f[(YAW, j)] = dt * dw;
    }
    (out, f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn central_difference(s: &State, u: TreadInput, dt: f64) -> MatN {
        let mut f = MatN::zeros();
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
        let s2 = predict(
            &s,
            TreadInput {
                v_left: 1.0,
                v_right: 1.0,
            },
            0.5,
        );
        assert!((s2[EAST] - 1.0).abs() < 1e-12);
        assert!((s2[NORTH] - 2.5).abs() < 1e-12);
        assert!((s2[YAW] - s[YAW]).abs() < 1e-12);
    }

    #[test]
    fn unequal_alphas_turn_a_straight_command() {
        let mut icr = IcrParams::no_slip(0.5);
        icr.alpha_l = 0.98;
        let s = predict(
            &state(0.0, 0.0, 0.0, &icr),
            TreadInput {
                v_left: 1.0,
                v_right: 1.0,
            },
            1.0,
        );
        assert!((s[YAW] - 0.02 / 0.5).abs() < 1e-12);
        assert!((s[EAST] - 0.99).abs() < 1e-12);
    }

    #[test]
    fn turning_left_increases_yaw_and_x_c_drifts_sideways() {
        let icr = IcrParams::new(0.3, -0.3, 0.1);
        let s = state(0.0, 0.0, 0.0, &icr);
        let s2 = predict(
            &s,
            TreadInput {
                v_left: -0.6,
                v_right: 0.6,
            },
            0.1,
        );
        // omega = 1.2/0.6 = 2 rad/s; v_y = -x_c*omega = -0.2 m/s
        assert!((s2[YAW] - 0.2).abs() < 1e-12);
        assert!((s2[NORTH] + 0.02).abs() < 1e-12);
    }

    proptest! {
        #[test]
        fn jacobian_matches_central_differences(
            e in -100.0f64..100.0, n in -100.0f64..100.0, yaw in -3.1f64..3.1,
            y_l in 0.1f64..1.2, y_r in -1.2f64..-0.1, x_c in -0.3f64..0.3,
            a_l in 0.8f64..1.2, a_r in 0.8f64..1.2,
            vl in -2.0f64..2.0, vr in -2.0f64..2.0, dt in 0.001f64..0.5,
        ) {
            let s = State::from([e, n, yaw, y_l, y_r, x_c, a_l, a_r]);
            let u = TreadInput { v_left: vl, v_right: vr };
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
