//! Named estimator configurations: the terraslip default and the papers'
//! filters to compare it with (`estimate --preset NAME`).
//!
//! | preset | what |
//! |---|---|
//! | `terraslip` | the default: gain coordinates, learned noise and clock, slip-change detector, terrain memory |
//! | `no-slip` | the ideal differential drive from the track width, nothing learned (dead reckoning + pose fixes) |
//! | `ekf-qmin`, `ekf-qmax` | lv2019's plain EKF on `(y_l, y_r, x_c)` with a small / large ICR random walk |
//! | `ta-ekf-boost` | lv2019 / wang2018: the random walk boosted from q_min to q_max for k fixes after a declared terrain change |
//! | `ta-iekf` | lv2019's terrain-adaptive innovation-based EKF: the boost plus the innovation-adaptive gain |
//! | `ekf-reset` | chen2023: the ICR covariance reset to P_B at a declared terrain change |

use terraslip_core::filter::{SlipStd, Variant};
use terraslip_core::Chart;

use super::EstimatorConfig;

/// lv2019's q_min and q_max, keeping their ratio (10^4) but scaled to
/// metres on a 1 Hz pose rate: the published 0.01 and 100 m^2/s would let
/// the ICRs swing by metres.
const Q_MIN: f64 = 1e-6;
const Q_MAX: f64 = 1e-2;

/// The papers' six-state EKF with an ICR random walk of `q` m^2/s on each
/// of `y_l, y_r, x_c`: fixed speed factors, white GNSS noise of the stated
/// (or the papers' 2 m / 1 deg) size, no clock, no gyro, no detector, no
/// memory.
fn papers(q: f64) -> EstimatorConfig {
    let mut c = EstimatorConfig::default();
    let f = &mut c.filter;
    f.variant = Variant::Ekf;
    f.chart = Chart::Tread;
    f.learn_alpha = false;
    f.learn_clock = false;
    // diag(q, q, q) on y_l, y_r, x_c is spread 2q, centre q/2, x_c q.
    f.slip_walk = SlipStd {
        spread: (2.0 * q).sqrt(),
        centre: (0.5 * q).sqrt(),
        x_c: q.sqrt(),
        alpha: 0.0,
        alpha_diff: 0.0,
    };
    f.q_yaw_per_rate2 = 1e-4;
    f.change_window = 0.0;
    f.noise_memory = 0.0;
    let m = &mut c.measurement;
    m.std_xy = 2.0;
    m.std_yaw = 1f64.to_radians();
    m.correlated_fraction = 0.0;
    m.clock_offset_std = 0.0;
    m.std_gyro = 0.0;
    let i = &mut c.init;
    i.spread_std_factor = 0.3;
    i.std_centre = 0.1;
    i.std_x_c = 0.1;
    i.std_alpha = 1e-6;
    i.std_alpha_diff = 1e-6;
    // ... and constant ICRs.
    i.std_turn_law = 0.0;
    i.std_k_x_speed = 0.0;
    i.std_k_spread_speed = 0.0;
    i.std_speed_law = 0.0;
    c.schedule.reset = false;
    c.schedule.memory = false;
    c
}

impl EstimatorConfig {
    /// Every named preset.
    pub fn presets() -> Vec<(&'static str, EstimatorConfig)> {
        let mut no_slip = papers(Q_MIN);
        no_slip.filter.learn_icr = false;

        let mut ta_ekf = papers(Q_MIN);
        ta_ekf.schedule.boost_factor = Q_MAX / Q_MIN;
        ta_ekf.schedule.boost_updates = 5;

        let mut ta_iekf = ta_ekf.clone();
        ta_iekf.filter.variant = Variant::InnovationAdaptive;

        let mut reset = papers(Q_MIN);
        reset.schedule.reset = true;
        // P_B: 0.1 m on each of y_l, y_r, x_c, independent.
        reset.schedule.reset_std = SlipStd {
            spread: 0.1 * 2f64.sqrt(),
            centre: 0.1 / 2f64.sqrt(),
            x_c: 0.1,
            alpha: 1e-6,
            alpha_diff: 1e-6,
        };

        vec![
            ("terraslip", EstimatorConfig::default()),
            ("no-slip", no_slip),
            ("ekf-qmin", papers(Q_MIN)),
            ("ekf-qmax", papers(Q_MAX)),
            ("ta-ekf-boost", ta_ekf),
            ("ta-iekf", ta_iekf),
            ("ekf-reset", reset),
        ]
    }

    /// A preset by name.
    pub fn preset(name: &str) -> Option<EstimatorConfig> {
        Self::presets()
            .into_iter()
            .find(|(n, _)| *n == name)
            .map(|(_, c)| c)
    }
}
