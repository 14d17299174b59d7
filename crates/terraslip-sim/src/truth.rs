//! The simulated robot's true state at one instant.

use terraslip_core::kinematics::{IcrParams, Twist};

/// The full truth at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthState {
    /// s
    pub t: f64,
    /// m, ENU
    pub east: f64,
    pub north: f64,
    /// rad, wrapped to (-pi, pi]
    pub yaw: f64,
    /// The ICRs (and alphas) in force at `t`.
    pub icr: IcrParams,
    /// Body twist, REP-103.
    pub twist: Twist,
    /// True tread surface speeds as the encoders would see them without
    /// quantisation (i.e. before alpha), m/s.
    pub v_left: f64,
    pub v_right: f64,
    /// Index into [`SimRun::terrains`].
    pub terrain: usize,
}

impl From<&TruthState> for terraslip_io::TruthSample {
    fn from(s: &TruthState) -> Self {
        terraslip_io::TruthSample {
            t: s.t,
            east: s.east,
            north: s.north,
            yaw: s.yaw,
            y_l: s.icr.y_l,
            y_r: s.icr.y_r,
            x_c: s.icr.x_c,
        }
    }
}
