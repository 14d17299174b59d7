//! ICR kinematics of a skid-steering robot.
//!
//! Body frame REP-103: x forward, y left. A tread's ICR is the point of the
//! body plane where that tread's ground contact has zero velocity; the body's
//! ICR is where the chassis has zero velocity. All three lie on one line
//! parallel to x (Martinez et al.), so five numbers describe the slip:
//!
//! * `y_l`  left tread ICR lateral offset, m (positive, usually a bit more than W/2)
//! * `y_r`  right tread ICR lateral offset, m (negative)
//! * `x_c`  longitudinal offset shared by the three ICRs, m
//! * `alpha_l`, `alpha_r` dimensionless scale of the measured tread speeds
//!   (effective rolling radius / nominal; 1.0 = nominal)
//!
//! With `v_l = alpha_l * V_l`, `v_r = alpha_r * V_r` (lv2019 eq. 3, Mandow eq. 6-7
//! rewritten in REP-103):
//!
//! ```text
//! v_x   = (v_r*y_l - v_l*y_r) / (y_l - y_r)
//! v_y   = x_c*(v_l - v_r)     / (y_l - y_r)
//! omega = (v_r - v_l)         / (y_l - y_r)
//! ```
//!
//! The ideal no-slip differential drive is `y_l = W/2, y_r = -W/2, x_c = 0,
//! alpha = 1`.
//!
//! Mandow et al. use a lateral axis that points right and call the lateral
//! ICR coordinates `x_ICRl = -y_l`, `x_ICRr = -y_r` and the longitudinal one
//! `y_ICRv = x_c`. [`IcrParams::from_mandow`] converts.

/// Smallest spread `y_l - y_r` (m) the model will divide by. Below this the
/// ICR model is singular (the treads' ICRs coincide); real robots sit at
/// 0.3-2 m.
pub const MIN_SPREAD: f64 = 1e-3;

/// Errors in kinematic parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum KinematicsError {
    /// A parameter is NaN or infinite.
    NonFinite,
    /// `y_l - y_r` is below [`MIN_SPREAD`]: the model is singular.
    SpreadTooSmall { spread: f64 },
    /// An `alpha` factor is not strictly positive.
    NonPositiveAlpha { alpha: f64 },
}

impl core::fmt::Display for KinematicsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NonFinite => write!(f, "ICR parameter is not finite"),
            Self::SpreadTooSmall { spread } => write!(
                f,
                "ICR spread y_l - y_r = {spread} m is below the minimum {MIN_SPREAD} m"
            ),
            Self::NonPositiveAlpha { alpha } => {
                write!(f, "tread speed factor alpha = {alpha} must be > 0")
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for KinematicsError {}

/// Planar body twist in the body frame (REP-103): `v_x` forward m/s,
/// `v_y` left m/s, `omega` yaw rate rad/s (counter-clockwise positive).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Twist {
    pub v_x: f64,
    pub v_y: f64,
    pub omega: f64,
}

impl Twist {
    /// Every component times `f`: the twist of the ICR model with both
    /// speed factors times `f` (the twist is linear in `alpha_l V_l` and
    /// `alpha_r V_r`).
    #[inline]
    pub fn scaled(self, f: f64) -> Twist {
        Twist {
            v_x: f * self.v_x,
            v_y: f * self.v_y,
            omega: f * self.omega,
        }
    }
}

/// ICR kinematic parameters of one robot on one terrain (body frame, metres).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct IcrParams {
    /// Left tread ICR lateral coordinate, m (positive = left of centre).
    pub y_l: f64,
    /// Right tread ICR lateral coordinate, m (negative = right of centre).
    pub y_r: f64,
    /// Longitudinal ICR coordinate shared by body and treads, m.
    pub x_c: f64,
    /// Left measured-speed scale factor (1 = nominal).
    #[cfg_attr(feature = "serde", serde(default = "one"))]
    pub alpha_l: f64,
    /// Right measured-speed scale factor (1 = nominal).
    #[cfg_attr(feature = "serde", serde(default = "one"))]
    pub alpha_r: f64,
}

#[cfg(feature = "serde")]
fn one() -> f64 {
    1.0
}

impl IcrParams {
    /// The ideal no-slip differential drive of track width `track_width` (m).
    pub const fn no_slip(track_width: f64) -> Self {
        Self {
            y_l: 0.5 * track_width,
            y_r: -0.5 * track_width,
            x_c: 0.0,
            alpha_l: 1.0,
            alpha_r: 1.0,
        }
    }

    /// Parameters with unit speed factors.
    pub const fn new(y_l: f64, y_r: f64, x_c: f64) -> Self {
        Self {
            y_l,
            y_r,
            x_c,
            alpha_l: 1.0,
            alpha_r: 1.0,
        }
    }

    /// From Mandow et al.'s notation (lateral axis pointing right):
    /// `x_ICRl`, `x_ICRr`, `y_ICRv`, `alpha_l`, `alpha_r`.
    pub const fn from_mandow(
        x_icr_l: f64,
        x_icr_r: f64,
        y_icr_v: f64,
        alpha_l: f64,
        alpha_r: f64,
    ) -> Self {
        Self {
            y_l: -x_icr_l,
            y_r: -x_icr_r,
            x_c: y_icr_v,
            alpha_l,
            alpha_r,
        }
    }

    /// Checks that the parameters describe a usable (non-singular) model.
    pub fn validate(&self) -> Result<(), KinematicsError> {
        let all = [self.y_l, self.y_r, self.x_c, self.alpha_l, self.alpha_r];
        if all.iter().any(|v| !v.is_finite()) {
            return Err(KinematicsError::NonFinite);
        }
        let spread = self.spread();
        if spread < MIN_SPREAD {
            return Err(KinematicsError::SpreadTooSmall { spread });
        }
        for alpha in [self.alpha_l, self.alpha_r] {
            if alpha <= 0.0 {
                return Err(KinematicsError::NonPositiveAlpha { alpha });
            }
        }
        Ok(())
    }

    /// `y_l - y_r`, m: the effective track width the robot turns with.
    pub fn spread(&self) -> f64 {
        self.y_l - self.y_r
    }

    /// Spread clamped to [`MIN_SPREAD`] so the model never divides by ~0.
    pub fn guarded_spread(&self) -> f64 {
        let d = self.spread();
        if d.is_finite() && d > MIN_SPREAD {
            d
        } else {
            MIN_SPREAD
        }
    }

    /// Body twist from measured tread speeds `v_left`, `v_right` (m/s).
    ///
    /// Uses [`Self::guarded_spread`], so it is finite for any finite input;
    /// call [`Self::validate`] first if a singular model must be an error.
    pub fn twist(&self, v_left: f64, v_right: f64) -> Twist {
        let v_l = self.alpha_l * v_left;
        let v_r = self.alpha_r * v_right;
        let d = self.guarded_spread();
        Twist {
            v_x: (v_r * self.y_l - v_l * self.y_r) / d,
            v_y: self.x_c * (v_l - v_r) / d,
            omega: (v_r - v_l) / d,
        }
    }

    /// Measured tread speeds `(v_left, v_right)` (m/s) that produce forward
    /// speed `v_x` and yaw rate `omega` (Mandow eqs. 16-17): for controllers.
    /// The lateral speed is not free: it follows as `-x_c * omega`.
    pub fn tread_speeds(&self, v_x: f64, omega: f64) -> (f64, f64) {
        let v_l = v_x - omega * self.y_l;
        let v_r = v_x - omega * self.y_r;
        (v_l / self.alpha_l, v_r / self.alpha_r)
    }

    /// Steering efficiency `chi = W / (y_l - y_r)` (Mandow eq. 9): 1 for an
    /// ideal differential drive, smaller the more the treads slip in turns.
    pub fn steering_efficiency(&self, track_width: f64) -> f64 {
        track_width / self.guarded_spread()
    }

    /// Eccentricity (Mandow eq. 10) in Mandow's sign convention (lateral axis
    /// right): `e = -(y_l + y_r) / (y_l - y_r)`. Zero for a symmetric robot;
    /// positive when the ICRs are shifted to the right.
    pub fn eccentricity(&self) -> f64 {
        -(self.y_l + self.y_r) / self.guarded_spread()
    }

    /// The ROS `diff_drive_controller` `wheel_separation_multiplier` that
    /// makes a no-slip model turn like these ICRs (for symmetric ICRs).
    pub fn wheel_separation_multiplier(&self, track_width: f64) -> f64 {
        self.guarded_spread() / track_width
    }
}

/// Smallest factor a turn-rate law may apply to the spread or the speed
/// factors (the calibration's bound, `terraslip_calib::model`).
pub const RATE_GAIN_MIN: f64 = 0.2;
/// Largest such factor.
pub const RATE_GAIN_MAX: f64 = 5.0;

/// Turn-rate dependence of the ICRs, the calibration's law
/// (`terraslip-calib`'s `RateSlopes`): with `dv = |V_r - V_l|` the measured
/// tread speed difference (m/s, before the speed factors), the spread
/// `y_l - y_r` scales by `1 + k_spread dv` and both speed factors by
/// `1 + k_alpha dv`, each factor clamped to
/// [[`RATE_GAIN_MIN`], [`RATE_GAIN_MAX`]] so a slope fitted on gentle
/// turns cannot make the model singular on a faster one. The spread scales
/// about the body's centre line (`y_l` and `y_r` by the same factor, `x_c`
/// unchanged), which makes `omega` and `v_y` scale by the ratio of the two
/// factors and `v_x` by the speed factor's, as the calibration has it.
///
/// The [`IcrParams`] the law is applied to are the straight-line values
/// (`dv = 0`); [`Self::at`] gives the ICRs in effect at a turn. Zero slopes
/// are the constant model.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct TurnRateSlopes {
    /// Relative change of the spread per m/s of tread speed difference, s/m.
    pub k_spread: f64,
    /// Relative change of both speed factors per m/s of difference, s/m.
    pub k_alpha: f64,
}

impl TurnRateSlopes {
    /// The constant-ICR model.
    pub const NONE: TurnRateSlopes = TurnRateSlopes {
        k_spread: 0.0,
        k_alpha: 0.0,
    };

    /// True for the constant model (both slopes zero).
    pub fn is_constant(&self) -> bool {
        self.k_spread == 0.0 && self.k_alpha == 0.0
    }

    /// Both slopes finite.
    pub fn is_finite(&self) -> bool {
        self.k_spread.is_finite() && self.k_alpha.is_finite()
    }

    /// `(spread factor, speed factor)` at measured tread speeds (m/s).
    /// Both are 1 for the constant model or a straight.
    #[inline]
    pub fn gains(&self, v_left: f64, v_right: f64) -> (f64, f64) {
        let dv = (v_right - v_left).abs();
        (
            (1.0 + self.k_spread * dv).clamp(RATE_GAIN_MIN, RATE_GAIN_MAX),
            (1.0 + self.k_alpha * dv).clamp(RATE_GAIN_MIN, RATE_GAIN_MAX),
        )
    }

    /// The ICRs in effect at measured tread speeds `v_left`, `v_right`
    /// (m/s) when `p` are the straight-line values.
    pub fn at(&self, p: &IcrParams, v_left: f64, v_right: f64) -> IcrParams {
        let (gs, ga) = self.gains(v_left, v_right);
        scaled(p, gs, ga)
    }

    /// Body twist from measured tread speeds (m/s) with straight-line ICRs
    /// `p`: the plain ICR model of [`Self::at`].
    pub fn twist(&self, p: &IcrParams, v_left: f64, v_right: f64) -> Twist {
        self.at(p, v_left, v_right).twist(v_left, v_right)
    }
}

/// Centripetal dependence of the ICRs: how they move with the forward
/// speed in a turn, which the constant model and the turn-rate law
/// ([`TurnRateSlopes`]) cannot express.
///
/// With `v = (V_l + V_r) / 2` the mean measured tread speed (m/s, before
/// the speed factors, signed: > 0 forward):
///
/// * `x_c` becomes `x_c + k_x_speed v` (`k_x_speed` in s). Since
///   `v_y = -x_c omega`, the body gains a lateral slip speed
///   `-k_x_speed v omega`: proportional to the centripetal acceleration
///   `a_y = v omega` (m/s^2, body y), as a tread whose lateral resistance
///   grows linearly with its lateral slip speed makes it (the robot slides
///   outward, by `k_x_speed` m/s per m/s^2, when `k_x_speed > 0`). This is
///   the lateral slip on `v omega` of DRIVE's learned model.
/// * the spread `y_l - y_r` scales by `1 + k_spread_speed |v|` about the
///   centre line (`k_spread_speed` in s/m, the factor clamped to
///   [[`RATE_GAIN_MIN`], [`RATE_GAIN_MAX`]]): the yaw rate becomes
///   `omega / (1 + k_spread_speed |v|)`, a yaw slip `~ k_spread_speed |v| omega`
///   that grows with the centripetal acceleration, DRIVE's yaw slip on `v omega`.
///
/// The [`IcrParams`] the terms are applied to are those at rest (`v = 0`);
/// zero slopes are the constant model. [`Self::at`] composes with
/// [`TurnRateSlopes::at`] (either order: they scale the spread by
/// independent factors and only this one moves `x_c`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct CentripetalSlopes {
    /// Longitudinal ICR shift per m/s of mean tread speed, s.
    pub k_x_speed: f64,
    /// Relative change of the spread per m/s of mean tread speed, s/m.
    pub k_spread_speed: f64,
}

impl CentripetalSlopes {
    /// The constant-ICR model.
    pub const NONE: CentripetalSlopes = CentripetalSlopes {
        k_x_speed: 0.0,
        k_spread_speed: 0.0,
    };

    /// True for the constant model (both slopes zero).
    pub fn is_constant(&self) -> bool {
        self.k_x_speed == 0.0 && self.k_spread_speed == 0.0
    }

    /// `(spread factor, x_c shift in m)` at measured tread speeds (m/s).
    #[inline]
    pub fn terms(&self, v_left: f64, v_right: f64) -> (f64, f64) {
        let v = 0.5 * (v_left + v_right);
        (
            (1.0 + self.k_spread_speed * v.abs()).clamp(RATE_GAIN_MIN, RATE_GAIN_MAX),
            self.k_x_speed * v,
        )
    }

    /// The ICRs in effect at measured tread speeds `v_left`, `v_right`
    /// (m/s) when `p` are the values at rest.
    pub fn at(&self, p: &IcrParams, v_left: f64, v_right: f64) -> IcrParams {
        let (gs, dx) = self.terms(v_left, v_right);
        let mut q = scaled(p, gs, 1.0);
        q.x_c += dx;
        q
    }
}

/// `p` with the spread scaled by `gs` about the centre line and the speed
/// factors by `ga`.
#[inline]
pub fn scaled(p: &IcrParams, gs: f64, ga: f64) -> IcrParams {
    IcrParams {
        y_l: gs * p.y_l,
        y_r: gs * p.y_r,
        x_c: p.x_c,
        alpha_l: ga * p.alpha_l,
        alpha_r: ga * p.alpha_r,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;
    use proptest::prelude::*;

    #[test]
    fn no_slip_is_differential_drive() {
        let p = IcrParams::no_slip(0.5);
        let t = p.twist(1.0, 1.5);
        assert_abs_diff_eq!(t.v_x, 1.25, epsilon = 1e-12);
        assert_abs_diff_eq!(t.v_y, 0.0, epsilon = 1e-12);
        assert_abs_diff_eq!(t.omega, 1.0, epsilon = 1e-12);
        assert_abs_diff_eq!(p.steering_efficiency(0.5), 1.0, epsilon = 1e-12);
        assert_abs_diff_eq!(p.eccentricity(), 0.0, epsilon = 1e-12);
    }

    #[test]
    fn icr_definitions_hold() {
        // Each tread's ground contact at its ICR must be at rest.
        let p = IcrParams {
            y_l: 0.31,
            y_r: -0.27,
            x_c: 0.04,
            alpha_l: 0.97,
            alpha_r: 1.02,
        };
        let (vl, vr) = (0.4, 0.9);
        let t = p.twist(vl, vr);
        // velocity of body point (x, y): (v_x - omega*y, v_y + omega*x)
        assert_abs_diff_eq!(
            t.v_x - t.omega * p.y_l - p.alpha_l * vl,
            0.0,
            epsilon = 1e-12
        );
        assert_abs_diff_eq!(
            t.v_x - t.omega * p.y_r - p.alpha_r * vr,
            0.0,
            epsilon = 1e-12
        );
        assert_abs_diff_eq!(t.v_y + t.omega * p.x_c, 0.0, epsilon = 1e-12);
    }

    #[test]
    fn validate_rejects_singular_models() {
        assert_eq!(
            IcrParams::new(0.1, 0.1, 0.0).validate(),
            Err(KinematicsError::SpreadTooSmall { spread: 0.0 })
        );
        assert_eq!(
            IcrParams::new(f64::NAN, -0.2, 0.0).validate(),
            Err(KinematicsError::NonFinite)
        );
        let mut p = IcrParams::no_slip(0.4);
        p.alpha_r = 0.0;
        assert_eq!(
            p.validate(),
            Err(KinematicsError::NonPositiveAlpha { alpha: 0.0 })
        );
        // Even a singular model gives a finite twist.
        let t = IcrParams::new(0.1, 0.1, 0.0).twist(1.0, 2.0);
        assert!(t.v_x.is_finite() && t.omega.is_finite());
    }

    #[test]
    fn mandow_conversion_matches_paper_signs() {
        // Mandow Table I (P3-AT, asphalt): x_ICRl < 0 on the left.
        let p = IcrParams::from_mandow(-0.2955, 0.2889, -0.0086, 0.9712, 0.9788);
        assert!(p.y_l > 0.0 && p.y_r < 0.0);
        assert_abs_diff_eq!(p.x_c, -0.0086);
        // Eccentricity in Mandow's convention: (x_r + x_l)/(x_r - x_l).
        assert_abs_diff_eq!(
            p.eccentricity(),
            (0.2889 - 0.2955) / (0.2889 + 0.2955),
            epsilon = 1e-12
        );
    }

    #[test]
    fn turn_rate_law_is_the_calibration_law() {
        // Calibration: omega and v_y scale by ga/gs, v_x by ga.
        let p = IcrParams {
            y_l: 0.31,
            y_r: -0.27,
            x_c: 0.04,
            alpha_l: 0.97,
            alpha_r: 1.02,
        };
        let k = TurnRateSlopes {
            k_spread: -0.2,
            k_alpha: 0.05,
        };
        let (vl, vr) = (0.3, 0.9);
        let (gs, ga) = (1.0 - 0.2 * 0.6, 1.0 + 0.05 * 0.6);
        let t0 = p.twist(vl, vr);
        let t = k.twist(&p, vl, vr);
        assert_abs_diff_eq!(t.v_x, ga * t0.v_x, epsilon = 1e-12);
        assert_abs_diff_eq!(t.v_y, ga / gs * t0.v_y, epsilon = 1e-12);
        assert_abs_diff_eq!(t.omega, ga / gs * t0.omega, epsilon = 1e-12);
        assert_abs_diff_eq!(k.at(&p, vl, vr).spread(), gs * p.spread(), epsilon = 1e-12);
        // Symmetric in the turn direction, the identity on a straight.
        assert_eq!(k.gains(vr, vl), k.gains(vl, vr));
        assert_eq!(k.at(&p, 0.7, 0.7), p);
        assert_eq!(TurnRateSlopes::NONE.at(&p, vl, vr), p);
        // A steep slope on a fast turn is clamped, never singular.
        let steep = TurnRateSlopes {
            k_spread: -10.0,
            k_alpha: 10.0,
        };
        assert_eq!(steep.gains(-1.0, 1.0), (RATE_GAIN_MIN, RATE_GAIN_MAX));
        assert!(steep.at(&p, -1.0, 1.0).validate().is_ok());
    }

    #[test]
    fn centripetal_terms_are_drives_lateral_and_yaw_slip_on_v_omega() {
        let p = IcrParams {
            y_l: 0.31,
            y_r: -0.27,
            x_c: 0.04,
            alpha_l: 0.97,
            alpha_r: 1.02,
        };
        let c = CentripetalSlopes {
            k_x_speed: 0.05,
            k_spread_speed: 0.1,
        };
        let (vl, vr) = (0.6, 1.2);
        let v = 0.9;
        let t0 = p.twist(vl, vr);
        let t = c.at(&p, vl, vr).twist(vl, vr);
        // Yaw slip: the spread grows by 1 + k |v|, the yaw rate shrinks.
        assert_abs_diff_eq!(t.omega, t0.omega / (1.0 + 0.1 * v), epsilon = 1e-12);
        // Lateral slip -k_x v omega on top of the ICR's -x_c omega.
        assert_abs_diff_eq!(t.v_y, -(p.x_c + 0.05 * v) * t.omega, epsilon = 1e-12);
        assert_abs_diff_eq!(t.v_x, t0.v_x, epsilon = 1e-12);
        // Reversing flips the lateral slip with v omega, not the yaw slip.
        let back = c.at(&p, -vr, -vl);
        assert_abs_diff_eq!(back.x_c, p.x_c - 0.05 * v, epsilon = 1e-12);
        assert_abs_diff_eq!(back.spread(), (1.0 + 0.1 * v) * p.spread(), epsilon = 1e-12);
        // At rest and for zero slopes: the constant model.
        assert_eq!(c.at(&p, 0.0, 0.0), p);
        assert_eq!(CentripetalSlopes::NONE.at(&p, vl, vr), p);
        // It composes with the turn-rate law in either order.
        let k = TurnRateSlopes {
            k_spread: -0.2,
            k_alpha: 0.05,
        };
        let a = c.at(&k.at(&p, vl, vr), vl, vr);
        let b = k.at(&c.at(&p, vl, vr), vl, vr);
        for (x, y) in [
            (a.y_l, b.y_l),
            (a.y_r, b.y_r),
            (a.x_c, b.x_c),
            (a.alpha_l, b.alpha_l),
        ] {
            assert_abs_diff_eq!(x, y, epsilon = 1e-12);
        }
        // A steep slope stays non-singular.
        let steep = CentripetalSlopes {
            k_x_speed: 0.0,
            k_spread_speed: -10.0,
        };
        assert!(steep.at(&p, 3.0, 3.0).validate().is_ok());
    }

    proptest! {
        #[test]
        fn tread_speeds_invert_twist(
            y_l in 0.1f64..1.5, y_r in -1.5f64..-0.1, x_c in -0.3f64..0.3,
            a_l in 0.7f64..1.3, a_r in 0.7f64..1.3, vx in -3.0f64..3.0, w in -3.0f64..3.0,
        ) {
            let p = IcrParams { y_l, y_r, x_c, alpha_l: a_l, alpha_r: a_r };
            let (vl, vr) = p.tread_speeds(vx, w);
            let t = p.twist(vl, vr);
            prop_assert!((t.v_x - vx).abs() < 1e-9);
            prop_assert!((t.omega - w).abs() < 1e-9);
            prop_assert!((t.v_y + x_c * w).abs() < 1e-9);
        }
    }
}
