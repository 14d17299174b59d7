//! What a pose fix should read at a state: the motion over the fix's lag,
//! the predicted fix `h(x)` and its Jacobian.

use nalgebra::Vector3;

use super::ekf::Mat3xN;
use super::Filter;
use crate::model::{
    BIAS_E, BIAS_N, CLOCK, EAST, K_SPREAD_SPEED, K_X_SPEED, LAW, NORTH, SLIP, SPEED_LAW, YAW,
};

impl Filter {
    /// The motion over the fix's lag at state `x`.
    pub(super) fn motion(&self, x: &crate::model::State, lag: f64) -> super::history::Motion {
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
    pub(super) fn measure(
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
}
