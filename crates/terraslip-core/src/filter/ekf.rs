//! The filter itself: its state, covariance and what it has learned
//! about its sensors, started from a prior and kept in the physical band.

use nalgebra::SMatrix;

use super::adaptive::InnovationWindow;
use super::band::validate_band;
use super::detector::Detector;
use super::gyro_window::GyroWindow;
use super::history::History;
use super::noise::NoiseFit;
use super::{
    FilterConfig, FilterError, IcrBand, MeasurementConfig, Prior, SlipHold, MAX_CLOCK_OFFSET,
    MAX_GYRO_SCALE, MAX_K_SPREAD_SPEED, MAX_K_X_SPEED, MAX_TURN_LAW,
};
use crate::kinematics::Twist;
use crate::model::{
    self, MatN, State, BIAS_E, BIAS_N, CLOCK, GYRO_BIAS, GYRO_SCALE, K_SPREAD_SPEED, K_X_SPEED,
    LAW, N, SLIP, SPEED_LAW,
};
use crate::slip::{SlipMat, TreadInput};

/// Chord of the first position fix to now, for finding the heading when no
/// fix carries one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Chord {
    /// The first position fix, m.
    pub(super) start: (f64, f64),
    /// Dead-reckoned displacement since, in the filter's (unanchored) frame, m.
    pub(super) odo: (f64, f64),
    /// Heading the model turned through since, rad (its sum of `|omega dt|`).
    pub(super) turned: f64,
}

/// The estimator's filter: state, covariance and what it has learned about
/// its sensors.
#[derive(Debug, Clone)]
pub struct Filter {
    pub(super) x: State,
    pub(super) P: MatN,
    pub(super) cfg: FilterConfig,
    pub(super) meas: MeasurementConfig,
    pub(super) band: IcrBand,
    /// Slip random walk per second, chart coordinates (at the last reset).
    pub(super) q_slip: SlipMat,
    /// Factor the terrain schedule applies to the slip random walk.
    pub(super) schedule_scale: f64,
    /// Twist of the last step (body frame).
    pub(super) twist: Twist,
    /// Tread speeds of the last step.
    pub(super) tread: TreadInput,
    /// The turn laws' inputs at the last step ([`Filter::law_inputs`]).
    pub(super) law_input: model::LawInputs,
    pub(super) still: bool,
    pub(super) history: History,
    /// Noise of the position and heading fixes (a scale of the stated
    /// variance) and of the model's speed (m^2/s per (m/s)^2) and yaw rate
    /// (rad^2/s per (rad/s)^2).
    pub(super) noise: [NoiseFit; 2],
    /// Their bases accumulated since the last position / heading fix:
    /// `sum(v^2 dt)`, `sum(omega^2 dt)`.
    pub(super) basis: [f64; 2],
    /// Whether a fix of each kind has set the sensor noise's prior yet.
    pub(super) noise_started: [bool; 2],
    /// Std of the correlated part of the position error in effect, m.
    pub(super) bias_std: f64,
    /// Slip-change detectors on the position fixes, the heading fixes and
    /// the gyro windows.
    pub(super) detector: [Detector; 3],
    /// Time driven through by the predictions, s (the gyro detector's
    /// clock).
    pub(super) elapsed: f64,
    /// The gyro's detector fired since the last fix's report.
    pub(super) gyro_change: bool,
    /// Pose parts taken from a fix yet (position, heading).
    pub(super) anchored: [bool; 2],
    pub(super) chord: Option<Chord>,
    /// Whether any fix has carried a heading.
    pub(super) heading_seen: bool,
    pub(super) rejected: [u32; 2],
    pub(super) last_fix_t: Option<f64>,
    /// Innovation window of [`Variant::InnovationAdaptive`].
    pub(super) window: InnovationWindow,
    /// The gyro's noise (a scale of `std_gyro^2`).
    pub(super) gyro_noise: NoiseFit,
    /// Whether a gyro window has been fused.
    pub(super) gyro_seen: bool,
    pub(super) gyro_win: GyroWindow,
    /// Length (s) of the last prediction step, the variance of the model's
    /// heading error over it and the part the yaw took (rad^2): what a
    /// gyro's heading change over that step shares with the state.
    pub(super) last_step: (f64, f64, f64),
    /// Gyro windows fused, and of those widened.
    pub(super) gyro_counts: [u64; 2],
    /// Whether each centripetal term (`k_x_speed`, `k_spread_speed`) is
    /// learned: a position reference shows them and the prior gives it
    /// room; otherwise it is held at its starting value with no
    /// uncertainty.
    pub(super) learn_centripetal: [bool; 2],
    /// Whether the speed factors' turn law is learned.
    pub(super) learn_speed_law: bool,
}

pub(super) type Mat3xN = SMatrix<f64, 3, N>;

/// Prior weight (fixes' dimensions) of a stated fix std.
pub(super) const STATED_WEIGHT: f64 = 2.0;
/// Prior weight of a configured guess of the fix std: the first residuals
/// replace it.
pub(super) const GUESS_WEIGHT: f64 = 1e-3;
/// Prior weight (fixes) of the model noise's starting value.
pub(super) const MODEL_WEIGHT: f64 = 2.0;

pub(super) fn finite_mat<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> bool {
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
        validate_band(&band)?;
        prior.validate()?;
        let (c, c_std) = (prior.centripetal, prior.centripetal_std);
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
            window: InnovationWindow::new(),
            gyro_noise: fit(cfg.q_yaw_per_rate2),
            gyro_seen: false,
            gyro_win: GyroWindow::new(),
            last_step: (0.0, 0.0, 0.0),
            gyro_counts: [0; 2],
            learn_centripetal,
            learn_speed_law,
        })
    }

    /// Keeps the slip part of `x` in the band; returns whether it moved.
    pub(super) fn project(&self, x: &mut State) -> bool {
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
    pub(super) fn set_bias_std(&mut self, std_xy: f64) {
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
pub(super) fn isolate(P: &mut MatN, i: usize, var: f64) {
    for j in 0..N {
        P[(i, j)] = 0.0;
        P[(j, i)] = 0.0;
    }
    P[(i, i)] = var;
}
