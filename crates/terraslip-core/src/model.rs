//! Discrete process model of a skid-steering robot with unknown ICRs
//! (lv2019 eqs. 4-6, rewritten in REP-103, extended with the tread speed
//! factors of Mandow eq. 6-7) and its analytic Jacobian.
//!
//! State `s = [east, north, yaw, y_l, y_r, x_c, alpha_l, alpha_r, k_spread]`:
//! world ENU position (m), yaw (rad, counter-clockwise from east), the ICR
//! coordinates of [`IcrParams`] in the body frame (m), the factors that
//! scale the measured tread speeds (1 = nominal), and the turn-rate slope of
//! the spread (s/m, [`TurnRateSlopes::k_spread`]; the ICRs and factors are
//! then the straight-line values). [`predict`] and [`jacobian`] are the
//! constant-ICR model and ignore the slope; the filter's step is
//! [`predict_with_jacobian_rate_in`]. The factors matter: a
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
use crate::kinematics::{IcrParams, TurnRateSlopes, MIN_SPREAD};

/// Dimension of the state.
pub const N: usize = 9;
/// Number of slip parameters (`y_l, y_r, x_c, alpha_l, alpha_r`).
pub const K: usize = 5;
/// State vector `[east, north, yaw, y_l, y_r, x_c, alpha_l, alpha_r, k_spread]`.
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
/// Index of the turn-rate slope of the spread, s/m (a robot property: the
/// terrain schedule's resets and recalls leave it alone).
pub const RATE_K: usize = 8;

/// Builds a state from a pose and slip parameters (turn-rate slope 0).
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
        0.0,
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
    let (out, rows) = predict_with_pose_rows(s, u, u_slip, dt);
    (out, with_pose_rows(&rows))
}

/// The Jacobian whose rows east, north, yaw are `rows` and whose other rows
/// are the identity's.
fn with_pose_rows(rows: &PoseRows) -> MatN {
    let mut f = MatN::identity();
    f.fixed_rows_mut::<3>(0).copy_from(rows);
    f
}

/// Rows east, north, yaw of a prediction Jacobian (the others are the
/// identity's: the slip parameters are random walks).
pub type PoseRows = SMatrix<f64, 3, N>;

/// [`predict_with_jacobian`] returning only the Jacobian's pose rows (the
/// filter's hot path: it never forms the identity part).
#[inline]
pub fn predict_with_pose_rows(
    s: &State,
    u: TreadInput,
    u_slip: TreadInput,
    dt: f64,
) -> (State, PoseRows) {
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
    let mut f = PoseRows::zeros();
    f[(EAST, EAST)] = 1.0;
    f[(NORTH, NORTH)] = 1.0;
    f[(YAW, YAW)] = 1.0;
    f[(EAST, YAW)] = dt * (-v_x * sn - v_y * cs);
    f[(NORTH, YAW)] = dt * (v_x * cs - v_y * sn);
    for (j, dvx, dvy, dw) in cols {
        f[(EAST, j)] = dt * (dvx * cs - dvy * sn);
        f[(NORTH, j)] = dt * (dvx * sn + dvy * cs);
        f[(YAW, j)] = dt * dw;
    }
    (out, f)
}

/// How the filter carries the two tread speed factors internally (its own
/// state: `[east, north, yaw, y_l, y_r, x_c, a, z]` with the common factor
/// `a = (alpha_l + alpha_r)/2` in slot 6 and `z` in slot 7). The public
/// [`State`] always holds `alpha_l, alpha_r`; [`to_filter`] and
/// [`from_filter`] convert.
///
/// The heading rate is `omega = a (V_r - V_l)/d - (alpha_l - alpha_r) V / d`
/// (`V` the mean tread speed). On a straight (`V_r = V_l`) it sees only the
/// ratio `(alpha_l - alpha_r)/d`; carried as two states, a heading update
/// there moves both along that ratio, so `d` drifts on straights with no
/// information about it. [`FactorCoords::PerSpread`] carries the ratio
/// itself, and a straight teaches it alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FactorCoords {
    /// `z = alpha_l - alpha_r` (dimensionless): a linear change of the
    /// tread-factor coordinates, so the filter behaves exactly as on
    /// `(alpha_l, alpha_r)` (branch `est2` before the per-spread form).
    Difference,
    /// `z = (alpha_l - alpha_r) / d` (1/m): minus the heading change per
    /// metre of straight driving. On a straight `d` has no partial at all.
    #[default]
    PerSpread,
}

/// Spread `y_l - y_r` with the division guard of [`spread`].
#[inline]
fn raw_spread(y_l: f64, y_r: f64) -> f64 {
    let d = y_l - y_r;
    if d > MIN_SPREAD {
        d
    } else {
        MIN_SPREAD
    }
}

/// Slot of the common factor in the filter's state.
pub const FACTOR_MEAN: usize = ALPHA_L;
/// Slot of the factor difference (in [`FactorCoords`]) in the filter's state.
pub const FACTOR_DIFF: usize = ALPHA_R;

/// A public state (`alpha_l, alpha_r`) in the filter's coordinates.
pub fn to_filter(s: &State, c: FactorCoords) -> State {
    let mut out = *s;
    let e = s[ALPHA_L] - s[ALPHA_R];
    out[FACTOR_MEAN] = 0.5 * (s[ALPHA_L] + s[ALPHA_R]);
    out[FACTOR_DIFF] = match c {
        FactorCoords::Difference => e,
        FactorCoords::PerSpread => e / raw_spread(s[Y_L], s[Y_R]),
    };
    out
}

/// A filter state back in the public coordinates (`alpha_l, alpha_r`).
#[inline]
pub fn from_filter(s: &State, c: FactorCoords) -> State {
    let mut out = *s;
    let e = match c {
        FactorCoords::Difference => s[FACTOR_DIFF],
        FactorCoords::PerSpread => s[FACTOR_DIFF] * raw_spread(s[Y_L], s[Y_R]),
    };
    out[ALPHA_L] = s[FACTOR_MEAN] + 0.5 * e;
    out[ALPHA_R] = s[FACTOR_MEAN] - 0.5 * e;
    out
}

/// Rows `alpha_l, alpha_r` of `d from_filter / d s` at the filter state `s`
/// (the other rows are the identity's).
#[inline]
pub fn from_filter_rows(s: &State, c: FactorCoords) -> SMatrix<f64, 2, N> {
    let mut r = SMatrix::<f64, 2, N>::zeros();
    let (half_z, half_s) = match c {
        FactorCoords::Difference => (0.0, 0.5),
        FactorCoords::PerSpread => (0.5 * s[FACTOR_DIFF], 0.5 * raw_spread(s[Y_L], s[Y_R])),
    };
    // alpha_l = a + e/2, alpha_r = a - e/2, e = z (or z d with d = y_l - y_r)
    r[(0, Y_L)] = half_z;
    r[(0, Y_R)] = -half_z;
    r[(0, FACTOR_MEAN)] = 1.0;
    r[(0, FACTOR_DIFF)] = half_s;
    r[(1, Y_L)] = -half_z;
    r[(1, Y_R)] = half_z;
    r[(1, FACTOR_MEAN)] = 1.0;
    r[(1, FACTOR_DIFF)] = -half_s;
    r
}

/// Rows `a, z` of `d to_filter / d s` at the public state `s`.
pub fn to_filter_rows(s: &State, c: FactorCoords) -> SMatrix<f64, 2, N> {
    let mut r = SMatrix::<f64, 2, N>::zeros();
    r[(0, ALPHA_L)] = 0.5;
    r[(0, ALPHA_R)] = 0.5;
    match c {
        FactorCoords::Difference => {
            r[(1, ALPHA_L)] = 1.0;
            r[(1, ALPHA_R)] = -1.0;
        }
        FactorCoords::PerSpread => {
            let inv_d = 1.0 / raw_spread(s[Y_L], s[Y_R]);
            let e_d2 = (s[ALPHA_L] - s[ALPHA_R]) * inv_d * inv_d;
            r[(1, Y_L)] = -e_d2;
            r[(1, Y_R)] = e_d2;
            r[(1, ALPHA_L)] = inv_d;
            r[(1, ALPHA_R)] = -inv_d;
        }
    }
    r
}

/// `J P J'` where `J` is the identity except rows 6 and 7, which are
/// `rows` (from [`from_filter_rows`] or [`to_filter_rows`]): the
/// covariance in the other coordinates, to first order. Symmetric.
pub fn transform_cov(p: &MatN, rows: &SMatrix<f64, 2, N>) -> MatN {
    let rp: SMatrix<f64, 2, N> = rows * p;
    let corner = rp * rows.transpose();
    let mut out = *p;
    for k in 0..2 {
        for i in (0..N).filter(|&i| i != ALPHA_L && i != ALPHA_R) {
            out[(ALPHA_L + k, i)] = rp[(k, i)];
            out[(i, ALPHA_L + k)] = rp[(k, i)];
        }
    }
    out[(ALPHA_L, ALPHA_L)] = corner[(0, 0)];
    out[(ALPHA_R, ALPHA_R)] = corner[(1, 1)];
    let off = 0.5 * (corner[(0, 1)] + corner[(1, 0)]);
    out[(ALPHA_L, ALPHA_R)] = off;
    out[(ALPHA_R, ALPHA_L)] = off;
    out
}

/// The filter's step on its own state (see [`FactorCoords`]) with the
/// turn-rate law of the state's slope `s[RATE_K]` and no speed-factor
/// slope: [`predict_with_jacobian_rate_in`] with `k_alpha = 0`.
pub fn predict_with_jacobian_in(
    s: &State,
    u: TreadInput,
    u_slip: TreadInput,
    dt: f64,
    c: FactorCoords,
) -> (State, MatN) {
    predict_with_jacobian_rate_in(s, u, u_slip, u, dt, c, 0.0)
}

/// The filter's step and its Jacobian by the filter state, with the
/// turn-rate law ([`TurnRateSlopes`]) of slopes `k_spread = s[RATE_K]` and
/// `k_alpha` (s/m): the state's ICRs and factors are the straight-line
/// values, the step uses those in effect at the speeds `u_rate`
/// ([`TurnRateSlopes::at`]; `u` itself for the calibration's law as
/// written, the filter passes low-passed speeds: the ICRs follow the motion
/// with a lag). The law's factors depend on `u_rate` and the slope
/// only, so the Jacobian is the constant model's at the scaled parameters
/// with the `y` columns times the spread factor, the factor columns times
/// the speed factor, and a slope column `dv (y_l d/dy_l' + y_r d/dy_r')`
/// (zero where the spread factor is clamped).
pub fn predict_with_jacobian_rate_in(
    s: &State,
    u: TreadInput,
    u_slip: TreadInput,
    u_rate: TreadInput,
    dt: f64,
    c: FactorCoords,
    k_alpha: f64,
) -> (State, MatN) {
    let (out, rows) = predict_with_pose_rows_rate_in(s, u, u_slip, u_rate, dt, c, k_alpha);
    (out, with_pose_rows(&rows))
}

/// [`predict_with_jacobian_rate_in`] returning only the Jacobian's pose
/// rows (the filter's hot path).
#[inline]
pub fn predict_with_pose_rows_rate_in(
    s: &State,
    u: TreadInput,
    u_slip: TreadInput,
    u_rate: TreadInput,
    dt: f64,
    c: FactorCoords,
    k_alpha: f64,
) -> (State, PoseRows) {
    let mut ext = from_filter(s, c);
    let rate = TurnRateSlopes {
        k_spread: s[RATE_K],
        k_alpha,
    };
    let (gs, ga) = rate.gains(u_rate.v_left, u_rate.v_right);
    let dv = (u_rate.v_right - u_rate.v_left).abs();
    let dgs = if 1.0 + rate.k_spread * dv == gs {
        dv
    } else {
        0.0
    };
    let (y_l, y_r) = (ext[Y_L], ext[Y_R]);
    scale_slip(&mut ext, gs, ga);
    let (next, mut fe) = predict_with_pose_rows(&ext, u, u_slip, dt);
    let mut out = *s;
    out[EAST] = next[EAST];
    out[NORTH] = next[NORTH];
    out[YAW] = next[YAW];
    for i in 0..3 {
        fe[(i, RATE_K)] = dgs * (y_l * fe[(i, Y_L)] + y_r * fe[(i, Y_R)]);
        fe[(i, Y_L)] *= gs;
        fe[(i, Y_R)] *= gs;
        fe[(i, ALPHA_L)] *= ga;
        fe[(i, ALPHA_R)] *= ga;
    }
    // Chain rule: only the pose rows differ from the identity, and
    // d ext / d s only in rows alpha_l, alpha_r.
    let r = from_filter_rows(s, c);
    let mut f = fe;
    for i in 0..3 {
        let (gl, gr) = (fe[(i, ALPHA_L)], fe[(i, ALPHA_R)]);
        for j in [Y_L, Y_R, FACTOR_MEAN, FACTOR_DIFF] {
            let base = if j == FACTOR_MEAN || j == FACTOR_DIFF {
                0.0
            } else {
                fe[(i, j)]
            };
            f[(i, j)] = base + gl * r[(0, j)] + gr * r[(1, j)];
        }
    }
    (out, f)
}

/// The public state's ICRs scaled by a turn-rate law's factors
/// ([`crate::kinematics::scaled`]).
#[inline]
fn scale_slip(s: &mut State, gs: f64, ga: f64) {
    s[Y_L] *= gs;
    s[Y_R] *= gs;
    s[ALPHA_L] *= ga;
    s[ALPHA_R] *= ga;
}

/// `f` on the filter's state (no Jacobian): [`predict_rate_in`] with `k_alpha = 0`.
pub fn predict_in(s: &State, u: TreadInput, dt: f64, c: FactorCoords) -> State {
    predict_rate_in(s, u, u, dt, c, 0.0)
}

/// The step of [`predict_with_jacobian_rate_in`] without the Jacobian.
pub fn predict_rate_in(
    s: &State,
    u: TreadInput,
    u_rate: TreadInput,
    dt: f64,
    c: FactorCoords,
    k_alpha: f64,
) -> State {
    let mut ext = from_filter(s, c);
    let rate = TurnRateSlopes {
        k_spread: s[RATE_K],
        k_alpha,
    };
    let (gs, ga) = rate.gains(u_rate.v_left, u_rate.v_right);
    scale_slip(&mut ext, gs, ga);
    let next = predict(&ext, u, dt);
    let mut out = *s;
    out[EAST] = next[EAST];
    out[NORTH] = next[NORTH];
    out[YAW] = next[YAW];
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Central differences of `step` at `s` (yaw differences wrapped).
    fn central_difference_of(s: &State, step: impl Fn(&State) -> State) -> MatN {
        let mut f = MatN::zeros();
        for j in 0..N {
            let h = 1e-6;
            let mut sp = *s;
            let mut sm = *s;
            sp[j] += h;
            sm[j] -= h;
            let mut col = step(&sp) - step(&sm);
            col[YAW] = angle::wrap(col[YAW]);
            f.set_column(j, &(col / (2.0 * h)));
        }
        f
    }

    fn central_difference(s: &State, u: TreadInput, dt: f64) -> MatN {
        central_difference_of(s, |x| predict(x, u, dt))
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

    fn central_difference_in(s: &State, u: TreadInput, dt: f64, c: FactorCoords) -> MatN {
        central_difference_of(s, |x| predict_in(x, u, dt, c))
    }

    #[test]
    fn per_spread_straight_leaves_spread_without_partial() {
        // On a straight the heading sees z = (alpha_l - alpha_r)/d alone.
        let icr = IcrParams {
            y_l: 0.3,
            y_r: -0.35,
            x_c: 0.0,
            alpha_l: 0.98,
            alpha_r: 0.975,
        };
        let s = to_filter(&state(0.0, 0.0, 0.4, &icr), FactorCoords::PerSpread);
        let u = TreadInput {
            v_left: 0.8,
            v_right: 0.8,
        };
        let (_, f) = predict_with_jacobian_in(&s, u, u, 0.1, FactorCoords::PerSpread);
        assert!(f[(YAW, Y_L)].abs() < 1e-15 && f[(YAW, Y_R)].abs() < 1e-15);
        assert!((f[(YAW, FACTOR_DIFF)] + 0.1 * 0.8).abs() < 1e-12);
        // ... which the difference coordinates do not give.
        let s = to_filter(&state(0.0, 0.0, 0.4, &icr), FactorCoords::Difference);
        let (_, f) = predict_with_jacobian_in(&s, u, u, 0.1, FactorCoords::Difference);
        assert!(f[(YAW, Y_L)].abs() > 1e-4);
    }

    proptest! {
        #[test]
        fn jacobians_match_central_differences_in_both_coordinates(
            e in -100.0f64..100.0, n in -100.0f64..100.0, yaw in -3.1f64..3.1,
            y_l in 0.1f64..1.2, y_r in -1.2f64..-0.1, x_c in -0.3f64..0.3,
            a_l in 0.8f64..1.2, a_r in 0.8f64..1.2,
            vl in -2.0f64..2.0, vr in -2.0f64..2.0, dt in 0.001f64..0.5,
            per_spread in any::<bool>(),
            k_spread in -0.15f64..0.15, k_alpha in -0.15f64..0.15,
            rl in -2.0f64..2.0, rr in -2.0f64..2.0,
        ) {
            // The law's speeds may differ from the step's (low-passed).
            let u_rate = TreadInput { v_left: rl, v_right: rr };
            let c = if per_spread { FactorCoords::PerSpread } else { FactorCoords::Difference };
            let ext = State::from([e, n, yaw, y_l, y_r, x_c, a_l, a_r, k_spread]);
            let s = to_filter(&ext, c);
            let back = from_filter(&s, c);
            prop_assert!((back - ext).amax() < 1e-12);
            // The filter's step is the public step.
            let u = TreadInput { v_left: vl, v_right: vr };
            let a = from_filter(&predict_in(&s, u, dt, c), c);
            let now = TurnRateSlopes { k_spread, k_alpha: 0.0 }.at(&icr_of(&ext), vl, vr);
            let mut b = predict(&state(e, n, yaw, &now), u, dt);
            b.fixed_rows_mut::<6>(SLIP).copy_from(&ext.fixed_rows::<6>(SLIP));
            prop_assert!((a - b).amax() < 1e-9);
            // With a turn-rate law: the step is the constant model's at the
            // ICRs in effect at this turn.
            let rate = TurnRateSlopes { k_spread, k_alpha };
            let now = rate.at(&icr_of(&ext), vl, vr);
            let want = predict(&state(e, n, yaw, &now), u, dt);
            let got = predict_rate_in(&s, u, u, dt, c, k_alpha);
            prop_assert!((got.fixed_rows::<3>(0) - want.fixed_rows::<3>(0)).amax() < 1e-9);
            prop_assert!((predict_with_jacobian_rate_in(&s, u, u, u, dt, c, k_alpha).0 - got).amax() < 1e-12);
            // Public Jacobian, and the filter's (chain rule) in `c`, without
            // and with the law.
            for (fa, fd) in [
                (jacobian(&ext, u, dt), central_difference(&ext, u, dt)),
                (predict_with_jacobian_in(&s, u, u, dt, c).1, central_difference_in(&s, u, dt, c)),
                (
                    predict_with_jacobian_rate_in(&s, u, u, u_rate, dt, c, k_alpha).1,
                    central_difference_of(&s, |x| predict_rate_in(x, u, u_rate, dt, c, k_alpha)),
                ),
            ] {
                for i in 0..N {
                    for j in 0..N {
                        let tol = 1e-6 * (1.0 + fa[(i, j)].abs());
                        prop_assert!((fa[(i, j)] - fd[(i, j)]).abs() < tol,
                            "{:?} F[{},{}] analytic {} numeric {}", c, i, j, fa[(i, j)], fd[(i, j)]);
                    }
                }
            }
            // The conversion Jacobians are each other's inverse (rows 6, 7).
            let mut jf = MatN::identity();
            jf.fixed_rows_mut::<2>(ALPHA_L).copy_from(&from_filter_rows(&s, c));
            let mut jt = MatN::identity();
            jt.fixed_rows_mut::<2>(ALPHA_L).copy_from(&to_filter_rows(&ext, c));
            prop_assert!((jf * jt - MatN::identity()).amax() < 1e-9);
            // And transform_cov is J P J'.
            let p = MatN::from_fn(|i, j| 0.01 / (1.0 + (i as f64 - j as f64).abs()));
            let want = jf * p * jf.transpose();
            prop_assert!((transform_cov(&p, &from_filter_rows(&s, c)) - want).amax() < 1e-12);
        }
    }
}
