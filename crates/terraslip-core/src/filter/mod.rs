//! Extended Kalman filter over [`crate::model`]: pose, slip parameters,
//! the pose stream's clock offset and the slow part of the position fixes'
//! error, from tread speeds and absolute pose fixes.
//!
//! * [`predict`](Filter::predict) (`predict.rs`): one model step and
//!   `P = F P F' + Q`.
//! * [`update`](Filter::update) (`update.rs`): a pose fix (position, heading
//!   or both) compared with where the robot was when the fix was taken,
//!   chi-square gates per part, the Kalman gain (or the papers'
//!   innovation-adaptive one) and the Joseph-form update.
//! * [`add_gyro`](Filter::add_gyro) (`gyro.rs`): the gyro's heading change
//!   over a short window against the model's, its bias and noise learned.
//! * `detector.rs`: a slip-change detector on the normalised innovations
//!   that resets the slip uncertainty when the ground changes.
//! * `noise.rs`: the measurement noise scale learned from the residuals.
//! * `reset.rs`: covariance resets and recalls (the terrain schedule's).
//!
//! Frames: REP-103 body frame, ENU world frame, yaw counter-clockwise from
//! east. Units SI.

mod adaptive;
mod config;
pub(crate) mod detector;
mod gyro;
mod history;
mod noise;
mod predict;
mod reset;
mod update;

pub use config::{
    FilterConfig, IcrBand, MeasurementConfig, SlipHold, SlipStd, Variant, MAX_WINDOW,
};
pub use gyro::{GyroNoise, GYRO_WINDOW};

use nalgebra::SMatrix;

use crate::kinematics::{CentripetalSlopes, IcrParams, Twist};
use crate::model::{
    self, MatN, State, BIAS_E, BIAS_N, CLOCK, EAST, GYRO_BIAS, GYRO_SCALE, K_SPREAD_SPEED,
    K_X_SPEED, LAW, N, NORTH, SLIP, SPEED_LAW, YAW,
};
use crate::slip::{Slip, SlipMat, TreadInput};

use detector::Detector;
use history::History;
use noise::NoiseFit;

/// Why a filter step could not be taken. The filter is unchanged then.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FilterError {
    /// An input (speed, time step, measurement, std) is NaN/inf or out of range.
    BadInput(&'static str),
    /// A setting is out of range (the message names the key).
    BadConfig(&'static str),
    /// The innovation covariance (or the innovation-adaptive gain's window)
    /// is not positive-definite.
    SingularInnovation,
    /// The step would produce a non-finite state or covariance.
    NonFinite,
    /// The papers' innovation-adaptive update would leave a negative
    /// variance; the update is refused.
    LostDefiniteness,
}

impl core::fmt::Display for FilterError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::BadInput(what) => write!(f, "bad filter input: {what}"),
            Self::BadConfig(what) => write!(f, "invalid configuration: {what}"),
            Self::SingularInnovation => {
                write!(f, "innovation covariance is not positive-definite")
            }
            Self::NonFinite => write!(f, "filter step would produce non-finite values"),
            Self::LostDefiniteness => write!(f, "update would leave a negative variance"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FilterError {}

/// One absolute pose observation. `None` = not measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseFix {
    /// `(east, north)`, m, world ENU.
    pub position: Option<(f64, f64)>,
    /// Yaw, rad, counter-clockwise from east (any branch).
    pub yaw: Option<f64>,
    /// Stated standard deviation of each position coordinate, m.
    pub std_xy: f64,
    /// Stated standard deviation of yaw, rad.
    pub std_yaw: f64,
    /// Whether the sensor stated these stds (false: they are a configured
    /// guess, which the noise learning replaces after a few fixes).
    pub stated: bool,
}

/// What happened to one part of a fix.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fate {
    /// Not in the fix.
    Absent,
    /// Fused.
    Fused,
    /// Rejected by the chi-square gate.
    Gated,
    /// Taken as the pose without the gate: the first fix of its kind, or
    /// after too many rejections.
    Anchored,
}

/// Result of one update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateReport {
    /// Fate of the position part.
    pub position: Fate,
    /// Fate of the heading part.
    pub yaw: Fate,
    /// Normalised innovation squared of the position part (2 dof; 0 if absent).
    pub nis_position: f64,
    /// Normalised innovation squared of the heading part (1 dof; 0 if absent).
    pub nis_yaw: f64,
    /// The slip-change detector fired on this fix (the slip uncertainty was
    /// raised before fusing it).
    pub change: bool,
    /// The slip parameters had to be projected into the physical band.
    pub at_band: bool,
}

/// Starting slip parameters and their uncertainty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prior {
    /// Starting ICR parameters (straight-line values).
    pub icr: IcrParams,
    /// Their standard deviations.
    pub std: SlipStd,
    /// Starting slope of the turn law, s/m (0 = constant ICRs).
    pub turn_law: f64,
    /// Its standard deviation, s/m (0 = held at `turn_law`).
    pub turn_law_std: f64,
    /// Starting centripetal terms (zero = the constant model).
    pub centripetal: CentripetalSlopes,
    /// Their standard deviations, s and s/m (both 0 = held at
    /// `centripetal`).
    pub centripetal_std: CentripetalSlopes,
    /// Starting slope of the speed factors' turn law, s/m: both speed
    /// factors in effect are `1 + speed_law |V_r - V_l|` times the
    /// straight-line ones (0 = constant).
    pub speed_law: f64,
    /// Its standard deviation, s/m (0 = held at `speed_law`). Learned
    /// where the speed factor is: with a position reference.
    pub speed_law_std: f64,
}

/// Chord of the first position fix to now, for finding the heading when no
/// fix carries one.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Chord {
    /// The first position fix, m.
    start: (f64, f64),
    /// Dead-reckoned displacement since, in the filter's (unanchored) frame, m.
    odo: (f64, f64),
    /// Heading the model turned through since, rad (its sum of `|omega dt|`).
    turned: f64,
}

/// The estimator's filter: state, covariance and what it has learned about
/// its sensors.
#[derive(Debug, Clone)]
pub struct Filter {
    x: State,
    P: MatN,
    cfg: FilterConfig,
    meas: MeasurementConfig,
    band: IcrBand,
    /// Slip random walk per second, chart coordinates (at the last reset).
    q_slip: SlipMat,
    /// Factor the terrain schedule applies to the slip random walk.
    schedule_scale: f64,
    /// Twist of the last step (body frame).
    twist: Twist,
    /// Tread speeds of the last step.
    tread: TreadInput,
    /// The turn laws' inputs at the last step ([`Filter::law_inputs`]).
    law_input: model::LawInputs,
    still: bool,
    history: History,
    /// Noise of the position and heading fixes (a scale of the stated
    /// variance) and of the model's speed (m^2/s per (m/s)^2) and yaw rate
    /// (rad^2/s per (rad/s)^2).
    noise: [NoiseFit; 2],
    /// Their bases accumulated since the last position / heading fix:
    /// `sum(v^2 dt)`, `sum(omega^2 dt)`.
    basis: [f64; 2],
    /// Whether a fix of each kind has set the sensor noise's prior yet.
    noise_started: [bool; 2],
    /// Std of the correlated part of the position error in effect, m.
    bias_std: f64,
    /// Slip-change detectors on the position fixes, the heading fixes and
    /// the gyro windows.
    detector: [Detector; 3],
    /// Time driven through by the predictions, s (the gyro detector's
    /// clock).
    elapsed: f64,
    /// The gyro's detector fired since the last fix's report.
    gyro_change: bool,
    /// Pose parts taken from a fix yet (position, heading).
    anchored: [bool; 2],
    chord: Option<Chord>,
    /// Whether any fix has carried a heading.
    heading_seen: bool,
    rejected: [u32; 2],
    last_fix_t: Option<f64>,
    /// Innovation window of [`Variant::InnovationAdaptive`].
    window: adaptive::InnovationWindow,
    /// The gyro's noise (a scale of `std_gyro^2`).
    gyro_noise: NoiseFit,
    /// Whether a gyro window has been fused.
    gyro_seen: bool,
    gyro_win: gyro::GyroWindow,
    /// Length (s) of the last prediction step, the variance of the model's
    /// heading error over it and the part the yaw took (rad^2): what a
    /// gyro's heading change over that step shares with the state.
    last_step: (f64, f64, f64),
    /// Gyro windows fused, and of those widened.
    gyro_counts: [u64; 2],
    /// Whether each centripetal term (`k_x_speed`, `k_spread_speed`) is
    /// learned: a position reference shows them and the prior gives it
    /// room; otherwise it is held at its starting value with no
    /// uncertainty.
    learn_centripetal: [bool; 2],
    /// Whether the speed factors' turn law is learned.
    learn_speed_law: bool,
}

type Mat3xN = SMatrix<f64, 3, N>;

/// Largest clock offset of the pose stream the filter accepts, s.
pub const MAX_CLOCK_OFFSET: f64 = 1.0;
/// Largest turn law slope, s/m.
pub const MAX_TURN_LAW: f64 = 1.0;
/// Largest gyro scale error `|k_g|` the filter accepts.
pub const MAX_GYRO_SCALE: f64 = 0.2;
/// Largest centripetal term `|k_x_speed|`, s (`x_c` moves by at most a
/// metre per m/s).
pub const MAX_K_X_SPEED: f64 = 1.0;
/// Largest centripetal term `|k_spread_speed|`, s/m.
pub const MAX_K_SPREAD_SPEED: f64 = 1.0;

/// Prior weight (fixes' dimensions) of a stated fix std.
const STATED_WEIGHT: f64 = 2.0;
/// Prior weight of a configured guess of the fix std: the first residuals
/// replace it.
const GUESS_WEIGHT: f64 = 1e-3;
/// Prior weight (fixes) of the model noise's starting value.
const MODEL_WEIGHT: f64 = 2.0;

fn finite_mat<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> bool {
    m.iter().all(|v| v.is_finite())
}

impl Filter {
    /// A filter starting from `prior`, its pose not yet anchored: the first
    /// position fix sets the position, the first heading fix the heading
    /// (without any, the heading is found from the first stretch of
    /// position fixes).
    pub fn new(
        prior: &Prior,
        cfg: FilterConfig,
        meas: MeasurementConfig,
        band: IcrBand,
    ) -> Result<Self, FilterError> {
        cfg.validate()?;
        meas.validate()?;
        config::validate_band(&band)?;
        prior
            .icr
            .validate()
            .map_err(|_| FilterError::BadInput("prior ICR parameters are not usable"))?;
        if !prior.std.is_valid() {
            return Err(FilterError::BadInput("prior std not finite or negative"));
        }
        if !(prior.turn_law.abs() <= 2.0
            && prior.turn_law_std.is_finite()
            && prior.turn_law_std >= 0.0
            && prior.speed_law.abs() <= MAX_TURN_LAW
            && prior.speed_law_std.is_finite()
            && prior.speed_law_std >= 0.0)
        {
            return Err(FilterError::BadInput(
                "turn law slopes must be within +-2 s/m (the speed factors' +-1 s/m) \
                 with finite stds",
            ));
        }
        let (c, c_std) = (prior.centripetal, prior.centripetal_std);
        if !(c.k_x_speed.abs() <= MAX_K_X_SPEED
            && c.k_spread_speed.abs() <= MAX_K_SPREAD_SPEED
            && c_std.k_x_speed.is_finite()
            && c_std.k_x_speed >= 0.0
            && c_std.k_spread_speed.is_finite()
            && c_std.k_spread_speed >= 0.0)
        {
            return Err(FilterError::BadInput(
                "centripetal terms must be within +-1 s (k_x_speed) and +-1 s/m \
                 (k_spread_speed) with finite stds",
            ));
        }
        let chart = cfg.chart;
        let (icr0, _) = band.project(&prior.icr);
        let mut x = State::zeros();
        x.fixed_rows_mut::<5>(SLIP)
            .copy_from(&chart.from_icr(&icr0));
        x[CLOCK] = meas.clock_offset;
        x[LAW] = prior.turn_law;
        let mut P = MatN::zeros();
        let slip_cov = prior
            .std
            .chart_cov(chart, &icr0)
            .ok_or(FilterError::BadInput("prior ICR parameters are singular"))?;
        P.fixed_view_mut::<5, 5>(SLIP, SLIP).copy_from(&slip_cov);
        if cfg.learn_clock {
            P[(CLOCK, CLOCK)] = meas.clock_offset_std * meas.clock_offset_std;
        }
        P[(LAW, LAW)] = prior.turn_law_std * prior.turn_law_std;
        P[(GYRO_BIAS, GYRO_BIAS)] = meas.gyro_bias_std * meas.gyro_bias_std;
        x[GYRO_SCALE] = meas.gyro_scale;
        if !cfg.hold_gyro_scale {
            P[(GYRO_SCALE, GYRO_SCALE)] = meas.gyro_scale_std * meas.gyro_scale_std;
        }
        x[K_X_SPEED] = c.k_x_speed;
        x[K_SPREAD_SPEED] = c.k_spread_speed;
        let shown = cfg.learn_icr && cfg.hold == SlipHold::Nothing;
        let learn_centripetal = [
            c_std.k_x_speed > 0.0 && shown,
            c_std.k_spread_speed > 0.0 && shown,
        ];
        for ((i, sd), learn) in [
            (K_X_SPEED, c_std.k_x_speed),
            (K_SPREAD_SPEED, c_std.k_spread_speed),
        ]
        .into_iter()
        .zip(learn_centripetal)
        {
            if learn {
                P[(i, i)] = sd * sd;
            }
        }
        x[SPEED_LAW] = prior.speed_law;
        // Learned where the speed factor is shown: a position reference.
        let learn_speed_law = prior.speed_law_std > 0.0 && shown && cfg.learn_alpha;
        if learn_speed_law {
            P[(SPEED_LAW, SPEED_LAW)] = prior.speed_law_std * prior.speed_law_std;
        }
        let q_slip = cfg
            .slip_walk_cov(&icr0)
            .ok_or(FilterError::BadInput("prior ICR parameters are singular"))?;
        let learn = cfg.noise_memory > 0.0;
        let fit = |model: f64| {
            if learn {
                NoiseFit::new(1.0, STATED_WEIGHT, model, MODEL_WEIGHT)
            } else {
                NoiseFit::fixed(1.0, model)
            }
        };
        Ok(Self {
            x,
            P,
            cfg,
            meas,
            band,
            q_slip,
            schedule_scale: 1.0,
            twist: Twist::default(),
            tread: TreadInput::default(),
            law_input: model::LawInputs::default(),
            still: true,
            history: History::new(),
            noise: [fit(cfg.q_pos_per_speed2), fit(cfg.q_yaw_per_rate2)],
            basis: [0.0; 2],
            noise_started: [false; 2],
            bias_std: 0.0,
            detector: [Detector::new(), Detector::new(), Detector::new()],
            elapsed: 0.0,
            gyro_change: false,
            anchored: [false; 2],
            chord: None,
            heading_seen: false,
            rejected: [0; 2],
            last_fix_t: None,
            window: adaptive::InnovationWindow::new(),
            gyro_noise: fit(cfg.q_yaw_per_rate2),
            gyro_seen: false,
            gyro_win: gyro::GyroWindow::new(),
            last_step: (0.0, 0.0, 0.0),
            gyro_counts: [0; 2],
            learn_centripetal,
            learn_speed_law,
        })
    }

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
    fn with_speed_law(&self, p: IcrParams) -> IcrParams {
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
    fn terms_now(&self) -> crate::slip::WithTerms {
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
    pub fn measurement(&self) -> &MeasurementConfig {
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

    fn slip(&self) -> Slip {
        model::slip_of(&self.x)
    }

    /// Full state and covariance, in the filter's own coordinates (the slip
    /// parameters in [`FilterConfig::chart`]'s): for tests and diagnostics.
    pub fn raw(&self) -> (&State, &MatN) {
        (&self.x, &self.P)
    }

    /// Keeps the slip part of `x` in the band; returns whether it moved.
    fn project(&self, x: &mut State) -> bool {
        let chart = self.cfg.chart;
        let icr = chart.to_icr(&model::slip_of(x));
        let (p, moved) = self.band.project(&icr);
        if moved {
            x.fixed_rows_mut::<5>(SLIP).copy_from(&chart.from_icr(&p));
        }
        // Outside the slip band: the turn law and the clock offset have
        // physical limits too.
        x[LAW] = x[LAW].clamp(-MAX_TURN_LAW, MAX_TURN_LAW);
        x[CLOCK] = x[CLOCK].clamp(-MAX_CLOCK_OFFSET, MAX_CLOCK_OFFSET);
        x[GYRO_SCALE] = x[GYRO_SCALE].clamp(-MAX_GYRO_SCALE, MAX_GYRO_SCALE);
        x[K_X_SPEED] = x[K_X_SPEED].clamp(-MAX_K_X_SPEED, MAX_K_X_SPEED);
        x[K_SPREAD_SPEED] = x[K_SPREAD_SPEED].clamp(-MAX_K_SPREAD_SPEED, MAX_K_SPREAD_SPEED);
        x[SPEED_LAW] = x[SPEED_LAW].clamp(-MAX_TURN_LAW, MAX_TURN_LAW);
        moved
    }

    /// Sets the std of the correlated position error for fixes of
    /// (learned) std `std_xy`, and keeps the bias variance within it.
    fn set_bias_std(&mut self, std_xy: f64) {
        let b = self.meas.correlated_std(std_xy);
        self.bias_std = b;
        let target = b * b;
        for i in [BIAS_E, BIAS_N] {
            let v = self.P[(i, i)];
            if v > target {
                // Scale the row and column: a congruence, so P stays PSD.
                let k = if v > 0.0 { libm::sqrt(target / v) } else { 0.0 };
                for j in 0..N {
                    self.P[(i, j)] *= k;
                    self.P[(j, i)] *= k;
                }
                self.x[i] *= k;
            }
        }
    }
}

/// Zeroes row and column `i` of `P` and sets its variance.
fn isolate(P: &mut MatN, i: usize, var: f64) {
    for j in 0..N {
        P[(i, j)] = 0.0;
        P[(j, i)] = 0.0;
    }
    P[(i, i)] = var;
}

#[cfg(test)]
mod tests;
