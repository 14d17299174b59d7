//! Settings of the filter: the one place their defaults and their
//! validation live (the command line's `[filter]` table is this struct;
//! `[measurement]` is `measurement.rs`).

use crate::kinematics::IcrParams;
use crate::slip::{Chart, Slip, SlipMat};

use super::FilterError;

/// Largest window of the innovation-adaptive gain, in fixes.
pub const MAX_WINDOW: usize = 64;

/// Standard deviations of the slip parameters in the coordinates that
/// users (and the data) tell apart: spread `d = y_l - y_r` (m), centre
/// `(y_l + y_r) / 2` (m), `x_c` (m), common speed factor
/// `(alpha_l + alpha_r) / 2` and factor difference `alpha_l - alpha_r`.
/// Used for priors (std) and random walks (std growth per square-root
/// second).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SlipStd {
    /// Spread y_l - y_r, m.
    pub spread: f64,
    /// Centre (y_l + y_r)/2, m.
    pub centre: f64,
    /// Longitudinal ICR offset x_c, m.
    pub x_c: f64,
    /// Common tread speed factor (alpha_l + alpha_r)/2.
    pub alpha: f64,
    /// Tread speed factor difference alpha_l - alpha_r.
    pub alpha_diff: f64,
}

impl SlipStd {
    /// Every entry zero.
    pub const ZERO: SlipStd = SlipStd {
        spread: 0.0,
        centre: 0.0,
        x_c: 0.0,
        alpha: 0.0,
        alpha_diff: 0.0,
    };

    /// The entries in order spread, centre, x_c, alpha, alpha_diff.
    pub fn entries(&self) -> [f64; 5] {
        [
            self.spread,
            self.centre,
            self.x_c,
            self.alpha,
            self.alpha_diff,
        ]
    }

    /// All entries finite and non-negative.
    pub fn is_valid(&self) -> bool {
        self.entries().iter().all(|v| v.is_finite() && *v >= 0.0)
    }

    /// The covariance these give on `(y_l, y_r, x_c, alpha_l, alpha_r)`
    /// (independent in spread, centre, x_c, alpha, alpha_diff).
    pub fn icr_cov(&self) -> SlipMat {
        let [s, c, x, a, e] = self.entries().map(|v| v * v);
        // y_l = c + d/2, y_r = c - d/2; alpha_l = a + e/2, alpha_r = a - e/2
        let mut m = SlipMat::zeros();
        m[(0, 0)] = 0.25 * s + c;
        m[(1, 1)] = 0.25 * s + c;
        m[(0, 1)] = -0.25 * s + c;
        m[(1, 0)] = -0.25 * s + c;
        m[(2, 2)] = x;
        m[(3, 3)] = 0.25 * e + a;
        m[(4, 4)] = 0.25 * e + a;
        m[(3, 4)] = -0.25 * e + a;
        m[(4, 3)] = -0.25 * e + a;
        m
    }

    /// The same covariance in `chart` coordinates at `icr` (first order).
    pub fn chart_cov(&self, chart: Chart, icr: &IcrParams) -> Option<SlipMat> {
        let s: Slip = chart.from_icr(icr);
        chart.cov_from_icr(&s, &self.icr_cov())
    }
}

/// Slip parameters the filter holds at their starting values because the
/// log's sensors cannot tell them. Decided from the sensors a log has (by
/// the pipeline), not a setting: no process noise is added to a held
/// parameter and no update moves it; its starting uncertainty is kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SlipHold {
    /// Everything is learned: a position reference is present.
    #[default]
    Nothing,
    /// No position reference, but a heading or a yaw-rate gyro: the
    /// parameters only positions teach ([`Chart::position_slots`]: the
    /// common speed factor and the ICR centre offsets) are held; the
    /// turning gain and the factor difference are learned from the turning.
    PositionTaught,
    /// No position, heading or gyro: every slip parameter and the turn law
    /// are held (dead reckoning with the starting values).
    All,
}

/// Gain rule of the filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
pub enum Variant {
    /// Textbook EKF: `K = P H' S^-1`, Joseph-form covariance update.
    Ekf,
    /// The papers' innovation-adaptive EKF (lv2019 eqs. 11-15, wang2018):
    /// the gain uses the sample covariance of the last
    /// [`FilterConfig::innovation_window`] innovations in place of `S`, and
    /// `P = (I - K H) P` as written. It can lose positive-definiteness; such
    /// an update is refused ([`FilterError::LostDefiniteness`]).
    InnovationAdaptive,
}

/// Settings of the filter (`[filter]`). Noise rates are per second of
/// elapsed time.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct FilterConfig {
    /// Gain rule: `ekf` (default) or `innovation-adaptive` (the papers').
    pub variant: Variant,
    /// Innovations averaged by the innovation-adaptive gain, fixes (1..=64).
    pub innovation_window: usize,
    /// Gauss-Newton iterations of each update over the clock offset (1 =
    /// the plain EKF): an iterated update re-evaluates the motion over the
    /// fix's lag at the corrected offset; the rest of the prediction stays
    /// linear about the prior.
    pub update_iterations: usize,
    /// Coordinates of the slip parameters inside the filter: `gain`
    /// (default: turning gain a/d, heading drift per metre, speed factor,
    /// ICR centre; the heading teaches the first two, position the speed
    /// factor) or `tread` (y_l, y_r, x_c, alpha_l, alpha_r: the papers').
    pub chart: Chart,
    /// Learn the ICRs (false: they stay at their initial values, their
    /// uncertainty still counted).
    pub learn_icr: bool,
    /// Learn the tread speed factors alpha_l, alpha_r (false: the papers'
    /// six-state model, factors fixed at their initial values).
    pub learn_alpha: bool,
    /// Learn the pose stream's clock offset against the wheels (false:
    /// fixed at `measurement.clock_offset`).
    pub learn_clock: bool,
    /// Position random walk, m^2/s.
    pub q_pos: f64,
    /// Position model noise per squared speed, m^2/s per (m/s)^2: the
    /// speed the model gives is wrong by a fraction that varies with the
    /// ground. The starting value: the filter learns it from the position
    /// innovations (`noise_memory`).
    pub q_pos_per_speed2: f64,
    /// Yaw random walk, rad^2/s.
    pub q_yaw: f64,
    /// Heading model noise per squared yaw rate, rad^2/s per (rad/s)^2: the
    /// yaw rate the model gives is wrong by a fraction that varies from turn
    /// to turn (a few % on firm ground, 20 % on a large skid-steer robot
    /// on gravel). The starting value: the filter learns it from the heading
    /// innovations (`noise_memory`).
    pub q_yaw_per_rate2: f64,
    /// Random walk of the slip parameters while moving: std growth per
    /// square-root second of spread (m), centre (m), x_c (m), common speed
    /// factor and factor difference.
    pub slip_walk: SlipStd,
    /// Random walk of the clock offset, s per square-root second. The
    /// offset is learned in the first seconds, while the slip is still
    /// wrong; the walk keeps it free to move once the slip is learned
    /// (0.003: 0.05 s over 5 minutes).
    pub clock_walk: f64,
    /// Random walk of the turn law's slope, s/m per square-root second.
    pub turn_law_walk: f64,
    /// Time constant with which the ICRs follow a change of turn, s: the
    /// turn law reads `|V_r - V_l|` low-passed with it (0 = at once).
    pub turn_law_lag: f64,
    /// Chi-square gate on the 2-dof position innovation (13.8 = 99.9 %;
    /// 0 = off). The gate is applied with the noise as learned, so it keeps
    /// its meaning whatever the noise learning does.
    pub gate_position: f64,
    /// Chi-square gate on the 1-dof heading innovation (10.8 = 99.9 %; 0 = off).
    pub gate_yaw: f64,
    /// Consecutive gated fixes after which the filter re-anchors its pose
    /// on the fix (a real jump, e.g. after an outage, is taken eventually).
    pub max_rejections: u32,
    /// When a heading fix is gated, add what its innovation leaves
    /// unexplained (`nu^2 - S`, rad^2) to the heading's variance, so the
    /// stated heading covers a drift the model missed (a yaw slip held for
    /// seconds) and the next heading fix is taken if the drift is real.
    /// Off by default: it makes the pose covariance more honest (pose NEES
    /// on the drives 31/66/14 -> 21/29/11 on asphalt/ice/sand_a) but moves
    /// the estimate, not always for the better (docs/experiments/
    /// 2026-11-28-heading-gate-inflation.md).
    pub inflate_gated_heading: bool,
    /// Tread speed below which the robot stands still (nothing is learned
    /// about slip or clock), m/s.
    pub still_speed: f64,
    /// A gap between wheels rows longer than this (s) is not integrated with
    /// held speeds: the pose uncertainty grows instead.
    pub max_wheel_gap: f64,
    /// Time over which the slip-change detector averages the normalised
    /// innovations, s (0 = no detector). A change of ground shows as
    /// innovations of one sign for longer than this, sensor noise and a
    /// turn that slips more than the last as innovations of either sign.
    pub change_window: f64,
    /// Chi-square threshold on the detector's mean normalised innovation
    /// (per dof of the heading and of the position; 10.8 = 99.9 % for one).
    pub change_threshold: f64,
    /// Uncertainty added to the slip parameters when the detector fires
    /// (a covariance reset, chen2023's P_B, triggered by the data). Here
    /// `spread` is relative: a fraction of the current spread.
    pub change_reset: SlipStd,
    /// Time over which the noise learned from the innovations (the pose
    /// fixes' noise, the model's speed and heading-rate noise) is averaged,
    /// s (0 = no learning: the stated or configured noise is used).
    pub noise_memory: f64,
    /// What the log's sensors cannot teach (set by the pipeline from the
    /// log, not read from a settings file).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub hold: SlipHold,
    /// Hold the gyro's scale error at its starting value
    /// (`measurement.gyro_scale`), as a known constant: set by the pipeline
    /// when the log has neither positions nor headings, where the gyro's
    /// scale and the spread make the same turn and only one can be learned
    /// (the spread is, in the gyro's scale).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub hold_gyro_scale: bool,
}

impl Default for FilterConfig {
    fn default() -> Self {
        Self {
            variant: Variant::Ekf,
            innovation_window: 10,
            update_iterations: 3,
            chart: Chart::Gain,
            learn_icr: true,
            learn_alpha: true,
            learn_clock: true,
            q_pos: 1e-4,
            q_pos_per_speed2: 1e-3,
            q_yaw: 1e-6,
            q_yaw_per_rate2: 1e-3,
            slip_walk: SlipStd {
                spread: 2e-3,
                centre: 3e-4,
                x_c: 3e-4,
                alpha: 3e-4,
                alpha_diff: 1e-4,
            },
            clock_walk: 3e-3,
            turn_law_walk: 1e-3,
            turn_law_lag: 0.25,
            gate_position: 13.8,
            gate_yaw: 10.8,
            max_rejections: 10,
            inflate_gated_heading: false,
            still_speed: 0.02,
            max_wheel_gap: 1.0,
            change_window: 10.0,
            change_threshold: 10.8,
            change_reset: SlipStd {
                spread: 0.1,
                centre: 0.01,
                x_c: 0.02,
                alpha: 0.05,
                alpha_diff: 0.0,
            },
            noise_memory: 60.0,
            hold: SlipHold::Nothing,
            hold_gyro_scale: false,
        }
    }
}

impl FilterConfig {
    /// Which of the chart's five slip parameters [`FilterConfig::hold`]
    /// keeps at their starting values.
    pub fn held_slots(&self) -> [bool; 5] {
        let mut held = [false; 5];
        match self.hold {
            SlipHold::Nothing => {}
            SlipHold::PositionTaught => {
                for k in self.chart.position_slots() {
                    held[k] = true;
                }
            }
            SlipHold::All => held = [true; 5],
        }
        held
    }

    /// `cov` with the rows and columns of the held slip parameters zeroed:
    /// what a random walk or a reset may add to the slip covariance.
    pub(super) fn unheld(&self, mut cov: SlipMat) -> SlipMat {
        for (k, held) in self.held_slots().iter().enumerate() {
            if *held {
                cov.row_mut(k).fill(0.0);
                cov.column_mut(k).fill(0.0);
            }
        }
        cov
    }

    /// The slip random walk per second in chart coordinates at `icr`, none
    /// on the held parameters.
    pub(super) fn slip_walk_cov(&self, icr: &IcrParams) -> Option<SlipMat> {
        self.slip_walk
            .chart_cov(self.chart, icr)
            .map(|q| self.unheld(q))
    }

    /// Checks every setting; the error names the key.
    pub fn validate(&self) -> Result<(), FilterError> {
        let finite_nonneg = |v: f64| v.is_finite() && v >= 0.0;
        let checks: [(&'static str, bool); 17] = [
            (
                "filter.innovation_window must be 1..=64",
                (1..=MAX_WINDOW).contains(&self.innovation_window),
            ),
            (
                "filter.update_iterations must be 1..=10",
                (1..=10).contains(&self.update_iterations),
            ),
            (
                "filter.q_pos must be finite and >= 0",
                finite_nonneg(self.q_pos),
            ),
            (
                "filter.q_pos_per_speed2 must be finite and >= 0",
                finite_nonneg(self.q_pos_per_speed2),
            ),
            (
                "filter.q_yaw must be finite and >= 0",
                finite_nonneg(self.q_yaw),
            ),
            (
                "filter.q_yaw_per_rate2 must be finite and >= 0",
                finite_nonneg(self.q_yaw_per_rate2),
            ),
            (
                "filter.slip_walk entries must be finite and >= 0",
                self.slip_walk.is_valid(),
            ),
            (
                "filter.clock_walk must be finite and >= 0",
                finite_nonneg(self.clock_walk),
            ),
            (
                "filter.turn_law_walk must be finite and >= 0",
                finite_nonneg(self.turn_law_walk),
            ),
            (
                "filter.turn_law_lag must be finite and >= 0",
                finite_nonneg(self.turn_law_lag),
            ),
            (
                "filter.gate_position must be finite and >= 0",
                finite_nonneg(self.gate_position),
            ),
            (
                "filter.gate_yaw must be finite and >= 0",
                finite_nonneg(self.gate_yaw),
            ),
            (
                "filter.still_speed must be finite and >= 0",
                finite_nonneg(self.still_speed),
            ),
            (
                "filter.max_wheel_gap must be finite and > 0",
                self.max_wheel_gap.is_finite() && self.max_wheel_gap > 0.0,
            ),
            (
                "filter.change_threshold must be finite and > 0",
                self.change_threshold.is_finite() && self.change_threshold > 0.0,
            ),
            (
                "filter.change_reset entries must be finite and >= 0",
                self.change_reset.is_valid(),
            ),
            (
                "filter.noise_memory must be finite and >= 0",
                finite_nonneg(self.noise_memory),
            ),
        ];
        for (what, ok) in checks {
            if !ok {
                return Err(FilterError::BadConfig(what));
            }
        }
        if !(self.change_window.is_finite() && self.change_window >= 0.0) {
            return Err(FilterError::BadConfig(
                "filter.change_window must be finite and >= 0",
            ));
        }
        Ok(())
    }
}
