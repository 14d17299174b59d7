//! What the filter tells: pose, slip parameters, turn laws, centripetal
//! terms, sensor noise and their uncertainty.

use nalgebra::SMatrix;

use super::{Filter, FilterConfig};
use crate::kinematics::{CentripetalSlopes, IcrParams, Twist};
use crate::model::{
    self, MatN, State, BIAS_E, BIAS_N, CLOCK, EAST, K_SPREAD_SPEED, K_X_SPEED, LAW, NORTH, SLIP,
    SPEED_LAW, YAW,
};
use crate::slip::{Slip, SlipMat};

impl Filter {
    /// The settings in use.
    pub fn config(&self) -> &FilterConfig {
        &self.cfg
    }

    /// Pose `(east, north, yaw)`: m, m, rad (wheels' clock).
    pub fn pose(&self) -> (f64, f64, f64) {
        (self.x[EAST], self.x[NORTH], self.x[YAW])
    }

    /// Covariance of `(east, north, yaw)`.
    pub fn pose_covariance(&self) -> nalgebra::Matrix3<f64> {
        self.P.fixed_view::<3, 3>(EAST, EAST).into_owned()
    }

    /// The straight-line slip parameters as ICRs (body frame, m) and tread
    /// speed factors (what the terrain memory keeps).
    pub fn icr(&self) -> IcrParams {
        self.cfg.chart.to_icr(&self.slip())
    }

    /// The ICRs in effect at the last step's tread speeds (the turn law
    /// and the centripetal terms applied): what the plain ICR model needs
    /// to give the filter's twist.
    pub fn icr_now(&self) -> IcrParams {
        let chart = self.cfg.chart;
        self.with_speed_law(chart.to_icr(&self.terms_now().slip))
    }

    /// `p` with both speed factors scaled by the speed factors' turn law at
    /// the last step's turn.
    pub(super) fn with_speed_law(&self, p: IcrParams) -> IcrParams {
        let (f, _) = crate::slip::law_factor(self.x[SPEED_LAW], self.law_input.speed);
        crate::kinematics::scaled(&p, 1.0, f)
    }

    /// Slope of the speed factors' turn law and its std, s/m: both speed
    /// factors in effect are `1 + slope |V_r - V_l|` times the
    /// straight-line ones.
    pub fn speed_law(&self) -> (f64, f64) {
        (
            self.x[SPEED_LAW],
            libm::sqrt(self.P[(SPEED_LAW, SPEED_LAW)].max(0.0)),
        )
    }

    /// The slip parameters in effect at the last step's tread speeds.
    pub(super) fn terms_now(&self) -> crate::slip::WithTerms {
        self.cfg.chart.with_terms(
            &self.slip(),
            self.x[LAW],
            self.law_input.spread,
            &self.centripetal().0,
            self.tread,
        )
    }

    /// What a prediction from the last step takes of the model: the ICRs
    /// at that step's turn, at rest (the turn law applied, not the
    /// centripetal terms: [`CentripetalSlopes::at`] applies those at a
    /// speed), and the slope (s/m) of the speed factors' turn law still to
    /// apply at each tread speed row of the prediction. A learned law reads
    /// the lagged turn and is applied here at the last step's (slope 0
    /// returned); a held law reads each instant's tread speeds
    /// ([`Filter::law_inputs`]): its slope is returned and the ICRs are
    /// without it.
    pub fn icr_turn(&self) -> (IcrParams, f64) {
        let icr = self
            .cfg
            .chart
            .to_icr_at(&self.slip(), self.x[LAW], self.law_input.spread);
        if self.learn_speed_law {
            (self.with_speed_law(icr), 0.0)
        } else {
            (icr, self.x[SPEED_LAW])
        }
    }

    /// The centripetal terms (s, s/m) and their stds.
    pub fn centripetal(&self) -> (CentripetalSlopes, CentripetalSlopes) {
        let sd = |i: usize| libm::sqrt(self.P[(i, i)].max(0.0));
        (
            model::centripetal_of(&self.x),
            CentripetalSlopes {
                k_x_speed: sd(K_X_SPEED),
                k_spread_speed: sd(K_SPREAD_SPEED),
            },
        )
    }

    /// Whether the centripetal terms are learned (a position reference and
    /// a prior with room for one of them), not held at their starting
    /// values.
    pub fn learns_centripetal(&self) -> bool {
        self.learn_centripetal.contains(&true)
    }

    /// Covariance of [`Self::icr_now`]: the slip parameters' and the
    /// centripetal terms' (the law's slope taken as known).
    pub fn icr_now_covariance(&self) -> SlipMat {
        let chart = self.cfg.chart;
        let a = self.terms_now();
        // d(parameters in effect) / d(slip parameters, k_x_speed, k_spread_speed).
        let mut j = SMatrix::<f64, 5, 7>::zeros();
        j.fixed_view_mut::<5, 5>(0, 0).copy_from(&a.d_slip);
        j[(chart.x_c_slot(), 5)] = a.speed;
        j.fixed_view_mut::<5, 1>(0, 6)
            .copy_from(&(a.d_factor * (a.law * a.d_centripetal)));
        let idx = [
            SLIP,
            SLIP + 1,
            SLIP + 2,
            SLIP + 3,
            SLIP + 4,
            K_X_SPEED,
            K_SPREAD_SPEED,
        ];
        let c = SMatrix::<f64, 7, 7>::from_fn(|r, k| self.P[(idx[r], idx[k])]);
        chart.cov_to_icr(&a.slip, &(j * c * j.transpose()))
    }

    /// Slope of the turn law and its std, s/m: the spread in effect is
    /// `1 + slope |V_r - V_l|` times the straight-line one.
    pub fn turn_law(&self) -> (f64, f64) {
        (self.x[LAW], libm::sqrt(self.P[(LAW, LAW)].max(0.0)))
    }

    /// Covariance of `(y_l, y_r, x_c, alpha_l, alpha_r)` (first order).
    pub fn icr_covariance(&self) -> SlipMat {
        self.cfg.chart.cov_to_icr(
            &self.slip(),
            &self.P.fixed_view::<5, 5>(SLIP, SLIP).into_owned(),
        )
    }

    /// Standard deviation of the spread `y_l - y_r`, m.
    pub fn spread_std(&self) -> f64 {
        let c = self.icr_covariance();
        libm::sqrt((c[(0, 0)] + c[(1, 1)] - 2.0 * c[(0, 1)]).max(0.0))
    }

    /// Where the pose reference sits on the robot (`lever_arm_x`,
    /// `lever_arm_y`, m, body frame), as the fixes are compared with.
    pub fn lever_arm(&self) -> (f64, f64) {
        (self.meas.lever_arm_x, self.meas.lever_arm_y)
    }

    /// The measurement settings in use.
    pub fn measurement(&self) -> &super::MeasurementConfig {
        &self.meas
    }

    /// Clock offset of the pose stream against the wheels and its std, s.
    pub fn clock_offset(&self) -> (f64, f64) {
        (self.x[CLOCK], libm::sqrt(self.P[(CLOCK, CLOCK)].max(0.0)))
    }

    /// Estimated slow error of the position fixes `(east, north)`, m.
    pub fn position_bias(&self) -> (f64, f64) {
        (self.x[BIAS_E], self.x[BIAS_N])
    }

    /// Covariance of the position as the fixes see it, the position plus
    /// their slow error (`east + bias_e`, `north + bias_n`), m²: what a
    /// fix's position part is predicted with, less the fix's white noise.
    pub fn fix_position_covariance(&self) -> nalgebra::Matrix2<f64> {
        let p = &self.P;
        nalgebra::Matrix2::from_fn(|i, j| {
            let (a, b) = ([EAST, NORTH][i], [BIAS_E, BIAS_N][i]);
            let (c, d) = ([EAST, NORTH][j], [BIAS_E, BIAS_N][j]);
            p[(a, c)] + p[(a, d)] + p[(b, c)] + p[(b, d)]
        })
    }

    /// The measurement noise in effect: position std per axis (m) and
    /// heading std (rad) for fixes stated at `stated_xy` / `stated_yaw`,
    /// and the std of the correlated part of the position error (m).
    /// [`Self::model_noise`] gives the model's.
    pub fn noise(&self, stated_xy: f64, stated_yaw: f64) -> (f64, f64, f64) {
        (
            stated_xy * libm::sqrt(self.noise[0].sensor()),
            stated_yaw * libm::sqrt(self.noise[1].sensor()),
            self.bias_std,
        )
    }

    /// The model noise in effect: speed (m^2/s per (m/s)^2) and yaw rate
    /// (rad^2/s per (rad/s)^2); their square roots are the relative errors
    /// of the model's speed and yaw rate over one second.
    pub fn model_noise(&self) -> (f64, f64) {
        (self.noise[0].model(), self.noise[1].model())
    }

    /// Whether position and heading have been anchored on a fix yet.
    pub fn anchored(&self) -> [bool; 2] {
        self.anchored
    }

    /// Whether the last prediction was at standstill.
    pub fn is_still(&self) -> bool {
        self.still
    }

    /// Body twist of the last prediction step.
    pub fn twist(&self) -> Twist {
        self.twist
    }

    /// Sets the factor the terrain schedule applies to the slip random
    /// walk (1 = as configured; the papers' `q_max / q_min` boost).
    pub fn set_schedule_scale(&mut self, k: f64) {
        if k.is_finite() && k > 0.0 {
            self.schedule_scale = k;
        }
    }

    /// Factor on the slip random walk currently applied by the schedule.
    pub fn schedule_scale(&self) -> f64 {
        self.schedule_scale
    }

    /// Adds uncertainty to the pose: `var_xy` (m^2) to east and north,
    /// `var_yaw` (rad^2) to yaw, e.g. over a gap in the tread speeds.
    /// Non-finite or negative values are ignored.
    pub fn inflate_pose(&mut self, var_xy: f64, var_yaw: f64) {
        if var_xy.is_finite() && var_xy > 0.0 {
            self.P[(EAST, EAST)] += var_xy;
            self.P[(NORTH, NORTH)] += var_xy;
        }
        if var_yaw.is_finite() && var_yaw > 0.0 && self.anchored[1] {
            self.P[(YAW, YAW)] += var_yaw;
        }
    }

    pub(super) fn slip(&self) -> Slip {
        model::slip_of(&self.x)
    }

    /// Full state and covariance, in the filter's own coordinates (the slip
    /// parameters in [`FilterConfig::chart`]'s): for tests and diagnostics.
    pub fn raw(&self) -> (&State, &MatN) {
        (&self.x, &self.P)
    }
}
