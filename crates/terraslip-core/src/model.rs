//! The filter's state and its process model.
//!
//! State `x = [east, north, yaw, s0..s4, law, clock, bias_e, bias_n, gyro_bias, gyro_scale,
//! k_x_speed, k_spread_speed, speed_law]`:
//!
//! * world ENU position (m) and yaw (rad, counter-clockwise from east) of
//!   the body frame, on the wheels' clock;
//! * five slip parameters in a [`Chart`]'s coordinates (the straight-line
//!   values);
//! * `law` (s/m): the turn law's slope, the spread in effect being
//!   `1 + law |V_r - V_l|` times the straight-line one
//!   ([`Chart::twist_with_terms`]): the treads' grip saturates in a turn;
//! * `clock` (s): how late the pose stream is stamped against the wheels
//!   (a pose stamped `t` describes the robot at wheel time `t - clock`);
//! * `bias_e`, `bias_n` (m): the slowly wandering part of the position
//!   fixes' error (first-order Gauss-Markov), so that GNSS errors
//!   correlated over tens of seconds are not read as motion;
//! * `gyro_bias` (rad/s): the yaw-rate gyro's bias (a random walk), where
//!   the log has a gyro;
//! * `gyro_scale` (dimensionless): the gyro's scale error `k_g`, the gyro
//!   reading `1 + k_g` times the true yaw rate (a slow random walk);
//! * `k_x_speed` (s) and `k_spread_speed` (s/m): the centripetal terms
//!   ([`crate::kinematics::CentripetalSlopes`]): with `v = (V_l + V_r) / 2`
//!   the mean measured tread speed, `x_c` moves by `k_x_speed v` (a lateral
//!   slip `-k_x_speed v omega`, outward in a turn when positive) and the
//!   spread scales by `1 + k_spread_speed |v|` about the ICR centre (a yaw
//!   slip growing with `v omega`), on top of the turn law;
//! * `speed_law` (s/m): the speed factors' turn law, both speed factors in
//!   effect being `1 + speed_law |V_r - V_l|` times the straight-line ones
//!   (clamped as the turn law; the treads lose speed in a turn). The whole
//!   twist scales by that factor ([`twist_at`]).
//!
//! One Euler step of length `dt` with the body twist `(v_x, v_y, omega)` of
//! [`Chart::twist_with_terms`]:
//!
//! ```text
//! east'  = east  + dt (v_x cos(yaw) - v_y sin(yaw))
//! north' = north + dt (v_x sin(yaw) + v_y cos(yaw))
//! yaw'   = yaw   + dt omega
//! ```
//!
//! The slip parameters, the law, the clock offset, the gyro bias and the
//! gyro scale are random walks, the centripetal terms constants, the position bias decays
//! ([`crate::filter`] adds the noise). [`step`] returns the new state and the rows of the Jacobian that
//! differ from the identity's.

use nalgebra::{SMatrix, SVector};

use crate::angle;
use crate::kinematics::{CentripetalSlopes, Twist};
use crate::slip::{Chart, Slip, TreadInput};

/// Dimension of the state.
pub const N: usize = SPEED_LAW + 1;
/// Index of east, m.
pub const EAST: usize = 0;
/// Index of north, m.
pub const NORTH: usize = 1;
/// Index of yaw, rad.
pub const YAW: usize = 2;
/// First of the five slip parameters.
pub const SLIP: usize = 3;
/// Index of the turn law's slope, s/m.
pub const LAW: usize = 8;
/// Index of the pose stream's clock offset, s.
pub const CLOCK: usize = 9;
/// Index of the east bias of the position fixes, m.
pub const BIAS_E: usize = 10;
/// Index of the north bias of the position fixes, m.
pub const BIAS_N: usize = 11;
/// Index of the yaw-rate gyro's bias, rad/s.
pub const GYRO_BIAS: usize = 12;
/// Index of the yaw-rate gyro's scale error `k_g` (it reads `1 + k_g`
/// times the true yaw rate).
pub const GYRO_SCALE: usize = GYRO_BIAS + 1;
/// Index of the centripetal term `k_x_speed`, s: `x_c` moves by
/// `k_x_speed` m per m/s of mean tread speed.
pub const K_X_SPEED: usize = GYRO_SCALE + 1;
/// Index of the centripetal term `k_spread_speed`, s/m: the spread scales
/// by `1 + k_spread_speed |v|` at mean tread speed `v`.
pub const K_SPREAD_SPEED: usize = K_X_SPEED + 1;
/// Index of the speed factors' turn law, s/m: both speed factors in effect
/// are `1 + speed_law dv` times the straight-line ones, `dv` its input
/// ([`LawInputs::speed`]; the treads lose speed in a turn).
pub const SPEED_LAW: usize = K_SPREAD_SPEED + 1;

/// The state vector.
pub type State = SVector<f64, N>;
/// An NxN matrix (covariance, Jacobian).
pub type MatN = SMatrix<f64, N, N>;
/// Rows east, north, yaw of a step's Jacobian.
pub type PoseRows = SMatrix<f64, 3, N>;

/// The slip parameters held in `x`.
#[inline]
pub fn slip_of(x: &State) -> Slip {
    x.fixed_rows::<5>(SLIP).into_owned()
}

/// The centripetal terms held in `x`.
#[inline]
pub fn centripetal_of(x: &State) -> CentripetalSlopes {
    CentripetalSlopes {
        k_x_speed: x[K_X_SPEED],
        k_spread_speed: x[K_SPREAD_SPEED],
    }
}

/// The turn laws' inputs, m/s: the tread speed difference `|V_r - V_l|` as
/// each law reads it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LawInputs {
    /// The spread's turn law (`law`).
    pub spread: f64,
    /// The speed factors' turn law (`speed_law`).
    pub speed: f64,
}

impl LawInputs {
    /// Both laws reading `dv` (m/s).
    pub const fn both(dv: f64) -> Self {
        Self {
            spread: dv,
            speed: dv,
        }
    }
}

/// The twist of `x` at tread speeds `u` and turn-law inputs `dv`, with
/// its derivatives by the slip parameters, by the turn law and by the
/// terms `(k_x_speed, k_spread_speed, speed_law)` (columns): the ICR twist
/// is linear in the two tread speeds as the ground takes them up, so the
/// speed law's factor scales all of it.
#[inline]
pub fn twist_at(
    x: &State,
    chart: Chart,
    u: TreadInput,
    dv: LawInputs,
) -> (Twist, crate::slip::TwistJac, [f64; 3], SMatrix<f64, 3, 3>) {
    let parts = chart.twist_with_terms(&slip_of(x), x[LAW], dv.spread, &centripetal_of(x), u);
    with_speed_law(parts, x[SPEED_LAW], dv.speed)
}

/// The twist of [`Chart::twist_with_terms`] and its derivatives (`parts`)
/// under the speed factors' turn law of slope `k` (s/m) at input `dv`
/// (m/s): [`twist_at`]'s.
#[inline]
pub fn with_speed_law(
    parts: (Twist, crate::slip::TwistJac, [f64; 3], SMatrix<f64, 3, 2>),
    k: f64,
    dv: f64,
) -> (Twist, crate::slip::TwistJac, [f64; 3], SMatrix<f64, 3, 3>) {
    let (t, j, dk, dc) = parts;
    let (f, d_f) = crate::slip::law_factor(k, dv);
    let mut d_terms = SMatrix::<f64, 3, 3>::zeros();
    d_terms.fixed_view_mut::<3, 2>(0, 0).copy_from(&(dc * f));
    d_terms[(0, 2)] = d_f * t.v_x;
    d_terms[(1, 2)] = d_f * t.v_y;
    d_terms[(2, 2)] = d_f * t.omega;
    (
        t.scaled(f),
        j * f,
        [f * dk[0], f * dk[1], f * dk[2]],
        d_terms,
    )
}

/// One Euler step of `dt` seconds with tread speeds `u` and turn-law
/// inputs `dv`: the new state (yaw wrapped to `(-pi, pi]`), the twist
/// used, and the pose rows of `F = df/dx` at `x` (the other rows are the
/// identity's; the bias decay is the filter's).
#[inline]
pub fn step(
    x: &State,
    chart: Chart,
    u: TreadInput,
    dv: LawInputs,
    dt: f64,
) -> (State, Twist, PoseRows) {
    let (t, j, dk, dc) = twist_at(x, chart, u, dv);
    // One argument reduction for both (the same bits as `sin`, `cos`).
    let (sn, cs) = libm::sincos(x[YAW]);
    let mut out = *x;
    out[EAST] += dt * (t.v_x * cs - t.v_y * sn);
    out[NORTH] += dt * (t.v_x * sn + t.v_y * cs);
    out[YAW] = angle::wrap(x[YAW] + dt * t.omega);

    let mut rows = PoseRows::zeros();
    for i in 0..3 {
        rows[(i, i)] = 1.0;
    }
    rows[(EAST, YAW)] = -dt * (t.v_x * sn + t.v_y * cs);
    rows[(NORTH, YAW)] = dt * (t.v_x * cs - t.v_y * sn);
    for k in 0..6 {
        let (dvx, dvy, dw) = if k < 5 {
            (j[(0, k)], j[(1, k)], j[(2, k)])
        } else {
            (dk[0], dk[1], dk[2])
        };
        rows[(EAST, SLIP + k)] = dt * (dvx * cs - dvy * sn);
        rows[(NORTH, SLIP + k)] = dt * (dvx * sn + dvy * cs);
        rows[(YAW, SLIP + k)] = dt * dw;
    }
    for (c, i) in [K_X_SPEED, K_SPREAD_SPEED, SPEED_LAW]
        .into_iter()
        .enumerate()
    {
        let (dvx, dvy, dw) = (dc[(0, c)], dc[(1, c)], dc[(2, c)]);
        rows[(EAST, i)] = dt * (dvx * cs - dvy * sn);
        rows[(NORTH, i)] = dt * (dvx * sn + dvy * cs);
        rows[(YAW, i)] = dt * dw;
    }
    (out, t, rows)
}

/// World-frame velocity (m/s, east and north) of a body twist at `yaw`.
#[inline]
pub fn world_velocity(t: &Twist, yaw: f64) -> (f64, f64) {
    let (sn, cs) = libm::sincos(yaw);
    (t.v_x * cs - t.v_y * sn, t.v_x * sn + t.v_y * cs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::IcrParams;
    use proptest::prelude::*;

    #[test]
    fn sincos_is_sin_and_cos_to_the_last_bit() {
        // Headings of every size and the small angles where the two take
        // different branches (|x| near 2^-27 and 2^-26).
        let mut rng = crate::rng::SplitMix64::new(5);
        let mut xs: std::vec::Vec<f64> = (0..200_000)
            .map(|_| (rng.uniform() - 0.5) * 2.0 * libm::exp(12.0 * rng.normal()))
            .collect();
        xs.extend((0..20_000).map(|k| 0.9e-8 + k as f64 * 1e-12));
        xs.extend([0.0, -0.0, core::f64::consts::FRAC_PI_4, 1e300, f64::NAN]);
        for x in xs {
            let (s, c) = libm::sincos(x);
            assert_eq!(s.to_bits(), libm::sin(x).to_bits(), "sin {x:e}");
            assert_eq!(c.to_bits(), libm::cos(x).to_bits(), "cos {x:e}");
        }
    }

    proptest! {
        #[test]
        fn step_jacobian_matches_central_differences(
            yaw in -3.1f64..3.1, d in 0.3f64..2.0, c in -0.1f64..0.1, xc in -0.2f64..0.2,
            al in 0.6f64..1.2, ar in 0.6f64..1.2, vl in -2.0f64..2.0, vr in -2.0f64..2.0,
            dt in 0.001f64..0.2,
        ) {
            let p = IcrParams { y_l: c + d / 2.0, y_r: c - d / 2.0, x_c: xc, alpha_l: al, alpha_r: ar };
            let u = TreadInput { v_left: vl, v_right: vr };
            for chart in [Chart::Tread, Chart::Gain] {
                let mut x = State::zeros();
                x[EAST] = 3.0;
                x[NORTH] = -2.0;
                x[YAW] = yaw;
                x[LAW] = 0.1;
                x[K_X_SPEED] = 0.07;
                x[K_SPREAD_SPEED] = -0.05;
                x[SPEED_LAW] = -0.04;
                x.fixed_rows_mut::<5>(SLIP).copy_from(&chart.from_icr(&p));
                // The speed law reading another input than the spread's.
                let dv = LawInputs { spread: (vr - vl).abs(), speed: 0.8 * (vr - vl).abs() + 0.1 };
                let (_, _, rows) = step(&x, chart, u, dv, dt);
                for k in 0..N {
                    let h = 1e-6 * (1.0 + x[k].abs());
                    let (mut xp, mut xm) = (x, x);
                    xp[k] += h;
                    xm[k] -= h;
                    let (fp, _, _) = step(&xp, chart, u, dv, dt);
                    let (fm, _, _) = step(&xm, chart, u, dv, dt);
                    for r in 0..3 {
                        let diff = if r == YAW { angle::wrap(fp[r] - fm[r]) } else { fp[r] - fm[r] };
                        prop_assert!((diff / (2.0 * h) - rows[(r, k)]).abs() < 1e-5,
                            "{chart:?} d{r}/d{k}");
                    }
                }
            }
        }
    }
}
