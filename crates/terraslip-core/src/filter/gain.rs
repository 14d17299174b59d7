//! The innovation of a fix and which states may learn from it: the
//! reduced innovation covariance, the frozen gain rows, the normalised
//! innovations.

use nalgebra::{Matrix2, Matrix3, SMatrix, Vector2, Vector3};

use super::ekf::Mat3xN;
use super::{Filter, FilterError, SlipHold};
use crate::angle;
use crate::model::{
    BIAS_E, BIAS_N, CLOCK, EAST, GYRO_SCALE, K_SPREAD_SPEED, K_X_SPEED, LAW, N, NORTH, SLIP,
    SPEED_LAW,
};

pub(super) type MatNx3 = SMatrix<f64, N, 3>;

impl Filter {
    /// `H P` and `S = H P H' + R` with the rows not in `used` replaced by
    /// unit, uncorrelated ones (the reduced update in 3x3).
    pub(super) fn innovation_cov(
        &self,
        H: &Mat3xN,
        r: &[f64; 3],
        used: [bool; 3],
    ) -> (Mat3xN, Matrix3<f64>) {
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
    pub(super) fn zero_gains(&self, K: &mut MatNx3, yaw_known: bool) {
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
}

/// `z - h` on the parts in `used` (heading wrapped), zero elsewhere.
pub(super) fn innovation(z: &Vector3<f64>, h: &Vector3<f64>, used: [bool; 3]) -> Vector3<f64> {
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
pub(super) fn normalised(
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
pub(super) fn blind_clock_gain(K: &mut MatNx3, H: &SMatrix<f64, 3, N>) {
    if (0..3).all(|j| H[(j, CLOCK)] == 0.0) {
        K.row_mut(CLOCK).fill(0.0);
    }
}
