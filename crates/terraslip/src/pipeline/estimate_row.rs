//! The estimate after one wheels row.

/// The estimate after one wheels row (log-format.md columns and more).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimateRow {
    /// Time of the wheels row, s.
    pub t: f64,
    /// Position east / north, m (ENU); yaw, rad (CCW from east).
    pub east: f64,
    pub north: f64,
    pub yaw: f64,
    /// ICRs, m (body frame).
    pub y_l: f64,
    pub y_r: f64,
    pub x_c: f64,
    /// Tread speed factors.
    pub alpha_l: f64,
    pub alpha_r: f64,
    /// Standard deviations of east, north (m), yaw (rad), y_l, y_r, x_c (m),
    /// alpha_l, alpha_r.
    pub std: [f64; 8],
    /// Std of the spread y_l - y_r, m.
    pub std_spread: f64,
    /// Covariance of (east, north, yaw) with its cross terms (m², m·rad,
    /// rad²); a heading not yet found from any fix has variance π² and no
    /// cross terms.
    pub pose_cov: [[f64; 3]; 3],
    /// The position fixes' slow error as estimated (east, north), m, and
    /// the covariance of the position plus it (what a fix's position is
    /// predicted with, less the fix's white noise), m².
    pub fix_bias: [f64; 2],
    pub fix_position_cov: [[f64; 2]; 2],
    /// Covariance of (y_l, y_r, x_c, alpha_l, alpha_r) in effect.
    pub icr_cov: [[f64; 5]; 5],
    /// The filter's model noise at this row.
    pub model_noise: terraslip_core::odometry::ModelNoise,
    /// The model's twist error averaged over one second, as learned from
    /// the fixes so far (what the published twist covariance states).
    pub twist_noise: terraslip_core::odometry::TwistNoise,
    /// Index into [`EstimateRun::terrains`] of the believed terrain.
    pub terrain: Option<usize>,
    /// A pose fix part was fused since the previous row.
    pub fused: bool,
    /// A pose fix part was gated since the previous row.
    pub gated: bool,
    /// NIS of the last fix since the previous row (position + heading
    /// parts; 0 if none).
    pub nis: f64,
    /// Factor the terrain schedule applies to the slip random walk.
    pub q_scale: f64,
    /// The slip-change detector fired since the previous row.
    pub change: bool,
    /// The pose stream's clock offset in effect, s.
    pub clock_offset: f64,
    /// What a 2 s prediction from this row takes of the estimate: the ICRs
    /// at this row's turn, the centripetal terms (applied at each later
    /// row's speed) and the clock offset.
    pub prediction_model: terraslip_calib::prediction::Timed,
    /// The gyro's scale in effect (it reads `scale` times the true yaw
    /// rate); `None` without gyro windows fused or with its scale held.
    pub gyro_scale: Option<f64>,
}

impl EstimateRow {
    /// The ICR parameters in effect at this row.
    pub fn icr(&self) -> terraslip_core::IcrParams {
        terraslip_core::IcrParams {
            y_l: self.y_l,
            y_r: self.y_r,
            x_c: self.x_c,
            alpha_l: self.alpha_l,
            alpha_r: self.alpha_r,
        }
    }
}
