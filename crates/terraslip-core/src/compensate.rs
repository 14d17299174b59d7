//! Slip compensation: the twist a drive controller must be sent for the
//! robot to move with a desired twist under the ICR model in effect.
//!
//! Frames and units: twists in the body frame (REP-103: x forward, y left,
//! yaw counter-clockwise), m/s and rad/s; time in s on any clock that does
//! not go back (the command stream's stamps).
//!
//! A drive controller (ROS `diff_drive_controller` and its kind) holds an
//! ideal differential drive of wheel separation `S` (its
//! `wheel_separation` times its multiplier): sent `(v, omega)` it turns the
//! treads at `V_l = v - omega S / 2`, `V_r = v + omega S / 2` (tread speeds,
//! m/s, on the scale the estimator reads them). The ground answers those
//! with the twist of the ICR model at `(V_l, V_r)` ([`IcrModel::twist`]).
//! Compensation inverts that: the tread speeds whose twist is the desired
//! `(v_x, omega)` ([`IcrModel::tread_speeds`]), then the command the
//! controller turns into them, `v = (V_l + V_r) / 2`,
//! `omega = (V_r - V_l) / S`. The desired lateral speed cannot be
//! commanded (the model's follows as `-x_c omega`): it is ignored and the
//! command's is 0.
//!
//! At the model's operating point the map from desired to command is
//! linear: the *correction* `C`, a 2x2 matrix, `command = C desired`
//! ([`correction`]). It is made dimensionless by the separation
//! (`[[C00, C01 / S], [C10 S, C11]]`), the identity for a ground that
//! turns like the controller's model. [`Compensator`] moves the model it
//! applies towards the estimate's so that no entry of that matrix changes
//! faster than [`CompensateConfig::max_correction_rate`] per second.

pub use crate::icr_model::IcrModel;
use crate::kinematics::Twist;

/// The command `(v, omega)` (m/s, rad/s) a controller of wheel separation
/// `separation` (m) turns into tread speeds `(v_left, v_right)` (m/s).
#[inline]
pub fn controller_command(separation: f64, v_left: f64, v_right: f64) -> (f64, f64) {
    (0.5 * (v_left + v_right), (v_right - v_left) / separation)
}

/// The dimensionless correction of `model` for a controller of wheel
/// separation `separation` (m) at the operating point of the desired
/// `(v_x, omega)`: `N` with `command = [[N00, N01 S], [N10 / S, N11]]
/// desired` (the constant ICRs in effect there inverted). The identity
/// when the ground turns as the controller's model; `None` where
/// [`IcrModel::tread_speeds`] is.
pub fn correction(
    model: &IcrModel,
    separation: f64,
    v_x: f64,
    omega: f64,
) -> Option<[[f64; 2]; 2]> {
    let (vl, vr) = model.tread_speeds(v_x, omega)?;
    let p = model.at(vl, vr);
    let (il, ir) = (1.0 / p.alpha_l, 1.0 / p.alpha_r);
    let s = separation;
    let n = [
        [0.5 * (il + ir), -0.5 * (p.y_l * il + p.y_r * ir) / s],
        [ir - il, (p.y_l * il - p.y_r * ir) / s],
    ];
    n.iter().flatten().all(|x| x.is_finite()).then_some(n)
}

/// Most shortenings [`slewed`] tries.
const MAX_SHORTENINGS: usize = 30;

/// The model on the way from `from` (correction `n_from`) to `target`
/// (correction `n_target`) whose correction at the operating point `op`
/// (`(v_x, omega)`) is at most `allowed` from `n_from`: `target` when it
/// is near enough, else the furthest interpolated model found within
/// reach (the correction is not linear in the parameters, so the step is
/// shortened until it is), else `from`.
fn slewed(
    from: &IcrModel,
    n_from: &[[f64; 2]; 2],
    target: &IcrModel,
    n_target: &[[f64; 2]; 2],
    allowed: f64,
    separation: f64,
    op: (f64, f64),
) -> IcrModel {
    let gap = distance(n_target, n_from);
    if gap <= allowed {
        return *target;
    }
    let mut s = allowed / gap;
    for _ in 0..MAX_SHORTENINGS {
        let m = from.towards(target, s);
        match correction(&m, separation, op.0, op.1) {
            Some(n) => {
                let moved = distance(&n, n_from);
                if moved <= allowed {
                    return m;
                }
                s *= 0.99 * allowed / moved;
            }
            None => s *= 0.5,
        }
    }
    *from
}

/// Largest entry of `|a - b|`.
fn distance(a: &[[f64; 2]; 2], b: &[[f64; 2]; 2]) -> f64 {
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .fold(0.0, |d, (x, y)| d.max(libm::fabs(x - y)))
}

const IDENTITY: [[f64; 2]; 2] = [[1.0, 0.0], [0.0, 1.0]];

/// What the compensator must respect and when it may act.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompensateConfig {
    /// The controller's wheel separation times its multiplier, m (> 0).
    pub separation: f64,
    /// Largest forward speed the controller takes, m/s (`INFINITY`: none).
    pub max_speed: f64,
    /// Largest yaw rate the controller takes, rad/s (`INFINITY`: none).
    pub max_yaw_rate: f64,
    /// Largest forward acceleration between commands, m/s^2.
    pub max_acceleration: f64,
    /// Largest yaw acceleration between commands, rad/s^2.
    pub max_yaw_acceleration: f64,
    /// Fastest the dimensionless correction may change, per s: how fast a
    /// new estimate reaches the command.
    pub max_correction_rate: f64,
    /// Seconds the estimate must have been confident, without a break,
    /// before it is applied.
    pub engage_after: f64,
    /// Largest entry of `|N - I|` ([`correction`]) applied; a model asking
    /// for more is not believed and the command passes through.
    pub max_correction: f64,
    /// The controller's command timeout, s: after this long without a
    /// command it has stopped, and the next command is not rate-limited
    /// against the last.
    pub command_timeout: f64,
}

impl CompensateConfig {
    /// Unlimited speeds and accelerations, the correction reaching a new
    /// estimate at 0.5 per second, applied as soon as it is confident (a
    /// model once applied is held through a break in confidence, and the
    /// correction moves at its bounded rate) and up to 2.0 away from the
    /// identity, the controller's timeout 0.5 s.
    pub const fn new(separation: f64) -> Self {
        Self {
            separation,
            max_speed: f64::INFINITY,
            max_yaw_rate: f64::INFINITY,
            max_acceleration: f64::INFINITY,
            max_yaw_acceleration: f64::INFINITY,
            max_correction_rate: 0.5,
            engage_after: 0.0,
            max_correction: 2.0,
            command_timeout: 0.5,
        }
    }

    /// The first setting out of range, named.
    pub fn validate(&self) -> Result<(), &'static str> {
        let positive = |x: f64| x > 0.0 && !x.is_nan();
        if !(self.separation.is_finite() && self.separation >= crate::kinematics::MIN_SPREAD) {
            return Err("separation must be a finite length >= 1 mm");
        }
        for (x, what) in [
            (self.max_speed, "max_speed must be > 0"),
            (self.max_yaw_rate, "max_yaw_rate must be > 0"),
            (self.max_acceleration, "max_acceleration must be > 0"),
            (
                self.max_yaw_acceleration,
                "max_yaw_acceleration must be > 0",
            ),
            (self.max_correction_rate, "max_correction_rate must be > 0"),
            (self.max_correction, "max_correction must be > 0"),
            (self.command_timeout, "command_timeout must be > 0"),
        ] {
            if !positive(x) {
                return Err(what);
            }
        }
        if !(self.engage_after.is_finite() && self.engage_after >= 0.0) {
            return Err("engage_after must be finite seconds >= 0");
        }
        Ok(())
    }
}

/// Why a command went through unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PassReason {
    /// No estimate yet.
    NoModel,
    /// The estimate is not confident (early in a drive, after a detected
    /// change, on an unknown terrain).
    NotConfident,
    /// Confident for less than [`CompensateConfig::engage_after`].
    Settling,
    /// The model is singular or not finite.
    InvalidModel,
    /// The model cannot be inverted at this command.
    NotInvertible,
    /// The correction asked for exceeds [`CompensateConfig::max_correction`].
    OutOfRange,
    /// The desired twist is not finite: the command is zero (stop).
    NonFiniteCommand,
}

impl PassReason {
    /// A short phrase for diagnostics.
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::NoModel => "no estimate yet",
            Self::NotConfident => "estimate not confident",
            Self::Settling => "estimate confident too briefly",
            Self::InvalidModel => "estimate singular or not finite",
            Self::NotInvertible => "estimate cannot be inverted at this command",
            Self::OutOfRange => "correction out of range",
            Self::NonFiniteCommand => "desired twist not finite: stop sent",
        }
    }
}

/// What a command became.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Status {
    /// The command is the compensated one.
    Compensating,
    /// The command is compensated under the model last applied, held
    /// (not moved towards the estimate) while the estimate is not
    /// believed, for this reason: a change in slip rarely makes the last
    /// believed model worse than none.
    Holding(PassReason),
    /// The desired twist went through unchanged (or, when it was not
    /// finite, a stop).
    PassThrough(PassReason),
}

/// One answered command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// The twist to send the controller (body frame, m/s, rad/s).
    pub twist: Twist,
    /// How it was made.
    pub status: Status,
}

/// Turns desired twists into controller commands, one at a time. Holds
/// the model it applies (moving towards the estimate at a bounded rate),
/// since when the estimate is confident, and the last command.
#[derive(Debug, Clone)]
pub struct Compensator {
    cfg: CompensateConfig,
    applied: Option<IcrModel>,
    confident_since: Option<f64>,
    last: Option<(f64, Twist)>,
}

impl Compensator {
    /// A compensator for `cfg` ([`CompensateConfig::validate`]d).
    pub fn new(cfg: CompensateConfig) -> Result<Self, &'static str> {
        cfg.validate()?;
        Ok(Self {
            cfg,
            applied: None,
            confident_since: None,
            last: None,
        })
    }

    /// The settings.
    pub fn config(&self) -> &CompensateConfig {
        &self.cfg
    }

    /// Takes new settings ([`CompensateConfig::validate`]d) from the next
    /// command on, keeping the model applied, since when it is confident and
    /// the last command; invalid settings leave the old ones.
    pub fn set_config(&mut self, cfg: CompensateConfig) -> Result<(), &'static str> {
        cfg.validate()?;
        self.cfg = cfg;
        Ok(())
    }

    /// The model applied now (`None` while passing through).
    pub fn applied(&self) -> Option<&IcrModel> {
        self.applied.as_ref()
    }

    /// The command for desired twist `desired` at time `t` (s), given the
    /// estimate (`model`, and whether it is confident). A zero desired
    /// twist gives exactly zero; a missing estimate, or one not confident
    /// before any was applied, the desired twist unchanged; one not
    /// confident (or settling, or singular) after a model was applied, the
    /// command under that model, held; every output is finite.
    pub fn command(
        &mut self,
        t: f64,
        desired: Twist,
        estimate: Option<(IcrModel, bool)>,
    ) -> Command {
        let dt = match self.last {
            Some((t0, _)) if t >= t0 && t - t0 <= self.cfg.command_timeout => Some(t - t0),
            _ => None,
        };
        let finite =
            desired.v_x.is_finite() && desired.v_y.is_finite() && desired.omega.is_finite();
        let out = if !finite {
            self.applied = None;
            Command {
                twist: Twist::default(),
                status: Status::PassThrough(PassReason::NonFiniteCommand),
            }
        } else {
            match self.gate(t, estimate) {
                Ok(target) => self.compensate(desired, &target, dt),
                Err(why) => self.hold(desired, dt, why),
            }
            .unwrap_or_else(|why| {
                self.applied = None;
                Command {
                    twist: desired,
                    status: Status::PassThrough(why),
                }
            })
        };
        if t.is_finite() {
            self.last = Some((t, out.twist));
        }
        out
    }

    /// The estimate's model when it may be applied at `t`, else why not.
    fn gate(&mut self, t: f64, estimate: Option<(IcrModel, bool)>) -> Result<IcrModel, PassReason> {
        let (model, confident) = estimate.ok_or(PassReason::NoModel)?;
        if !confident || !t.is_finite() {
            self.confident_since = None;
            return Err(PassReason::NotConfident);
        }
        let since = *self.confident_since.get_or_insert(t);
        if t < since {
            self.confident_since = Some(t);
        }
        if t - since < self.cfg.engage_after {
            return Err(PassReason::Settling);
        }
        model.validate().map_err(|_| PassReason::InvalidModel)?;
        Ok(model)
    }

    /// The command under the model applied now, held because the estimate
    /// may not be applied (`why`); `Err(why)` when no model was applied,
    /// or the estimate is gone.
    fn hold(
        &mut self,
        desired: Twist,
        dt: Option<f64>,
        why: PassReason,
    ) -> Result<Command, PassReason> {
        let holds = matches!(
            why,
            PassReason::NotConfident | PassReason::Settling | PassReason::InvalidModel
        );
        let Some(held) = self.applied.filter(|_| holds) else {
            return Err(why);
        };
        let mut c = self.compensate(desired, &held, dt)?;
        c.status = Status::Holding(why);
        Ok(c)
    }

    /// The compensated command under `target`, the applied model moved
    /// towards it for `dt` seconds (`None`: not moved).
    fn compensate(
        &mut self,
        desired: Twist,
        target: &IcrModel,
        dt: Option<f64>,
    ) -> Result<Command, PassReason> {
        let s = self.cfg.separation;
        let (vx, w) = (desired.v_x, desired.omega);
        let n_target = correction(target, s, vx, w).ok_or(PassReason::NotInvertible)?;
        if distance(&n_target, &IDENTITY) > self.cfg.max_correction {
            return Err(PassReason::OutOfRange);
        }
        let from = self.applied.unwrap_or(IcrModel::nominal(s));
        let allowed = self.cfg.max_correction_rate * dt.unwrap_or(0.0);
        let applied = match correction(&from, s, vx, w) {
            Some(n_from) => slewed(&from, &n_from, target, &n_target, allowed, s, (vx, w)),
            None => *target,
        };
        self.applied = Some(applied);
        if vx == 0.0 && w == 0.0 {
            return Ok(Command {
                twist: Twist::default(),
                status: Status::Compensating,
            });
        }
        let (vl, vr) = applied
            .tread_speeds(vx, w)
            .ok_or(PassReason::NotInvertible)?;
        let (v, omega) = controller_command(s, vl, vr);
        let (v, omega) = self.limited(v, omega, dt);
        if !(v.is_finite() && omega.is_finite()) {
            return Err(PassReason::NotInvertible);
        }
        Ok(Command {
            twist: Twist {
                v_x: v,
                v_y: 0.0,
                omega,
            },
            status: Status::Compensating,
        })
    }

    /// `(v, omega)` within the speed limits (both scaled by one factor, so
    /// the treads keep their ratio and the path its curvature), then
    /// within the accelerations from the last command `dt` s ago (moved
    /// along the straight line from it).
    fn limited(&self, v: f64, omega: f64, dt: Option<f64>) -> (f64, f64) {
        let c = &self.cfg;
        let over = (libm::fabs(v) / c.max_speed).max(libm::fabs(omega) / c.max_yaw_rate);
        let (v, omega) = if over > 1.0 {
            (v / over, omega / over)
        } else {
            (v, omega)
        };
        let (Some(dt), Some((_, last))) = (dt, self.last) else {
            return (v, omega);
        };
        let (dv, dw) = (v - last.v_x, omega - last.omega);
        let over = (libm::fabs(dv) / (c.max_acceleration * dt))
            .max(libm::fabs(dw) / (c.max_yaw_acceleration * dt));
        if over > 1.0 {
            (last.v_x + dv / over, last.omega + dw / over)
        } else {
            (v, omega)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{CentripetalSlopes, IcrParams};
    use crate::model::{self, LawInputs, State};
    use crate::slip::{Chart, TreadInput};
    use proptest::prelude::*;

    const S: f64 = 0.55;

    /// A sandy ground: wide spread, slow treads, laws of both signs.
    fn sand() -> IcrModel {
        IcrModel::EXAMPLE_SAND
    }

    fn twist(v_x: f64, omega: f64) -> Twist {
        Twist {
            v_x,
            v_y: 0.0,
            omega,
        }
    }

    /// Confident at once, correction free to jump.
    fn eager_config() -> CompensateConfig {
        let mut cfg = CompensateConfig::new(S);
        cfg.engage_after = 0.0;
        cfg.max_correction_rate = 1e9;
        cfg
    }

    /// A compensator of `cfg` that has applied `m` since t = -0.9 s (two
    /// stops sent to it: the first applies no correction, having no time
    /// step to move it by).
    fn engaged(cfg: CompensateConfig, m: IcrModel) -> Compensator {
        let mut c = Compensator::new(cfg).unwrap();
        for t in [-1.0, -0.9] {
            c.command(t, Twist::default(), Some((m, true)));
        }
        assert_eq!(c.applied(), Some(&m));
        c
    }

    fn eager() -> Compensator {
        engaged(eager_config(), sand())
    }

    /// What the ground does with a command: the controller's tread speeds
    /// through the model.
    fn driven(model: &IcrModel, cmd: Twist) -> Twist {
        let (vl, vr) = (cmd.v_x - 0.5 * S * cmd.omega, cmd.v_x + 0.5 * S * cmd.omega);
        model.twist(vl, vr)
    }

    #[test]
    fn model_is_the_filters_process_model() {
        let m = sand();
        let mut x = State::zeros();
        x.fixed_rows_mut::<5>(model::SLIP)
            .copy_from(&Chart::Tread.from_icr(&m.icr));
        x[model::LAW] = m.spread_law;
        x[model::SPEED_LAW] = m.speed_law;
        x[model::K_X_SPEED] = m.centripetal.k_x_speed;
        x[model::K_SPREAD_SPEED] = m.centripetal.k_spread_speed;
        for (vl, vr) in [
            (0.3, 0.9),
            (1.2, -0.4),
            (-0.8, -0.5),
            (0.0, 0.0),
            (2.0, -2.0),
        ] {
            let u = TreadInput {
                v_left: vl,
                v_right: vr,
            };
            let (t, ..) = model::twist_at(&x, Chart::Tread, u, LawInputs::both((vr - vl).abs()));
            let ours = m.twist(vl, vr);
            for (a, b) in [(t.v_x, ours.v_x), (t.v_y, ours.v_y), (t.omega, ours.omega)] {
                assert!((a - b).abs() < 1e-12, "{vl} {vr}: {t:?} vs {ours:?}");
            }
        }
    }

    /// The least `|v_x - vx| + |omega - w|` of `m`'s twist over tread
    /// speeds within `bound` (m/s): a grid, then a shrinking pattern search
    /// from its best point.
    fn closest_reach(m: &IcrModel, vx: f64, w: f64, bound: f64) -> f64 {
        let miss = |vl: f64, vr: f64| {
            let t = m.twist(vl, vr);
            (t.v_x - vx).abs() + (t.omega - w).abs()
        };
        let n = 150;
        let step = 2.0 * bound / n as f64;
        let mut best = (f64::INFINITY, 0.0, 0.0);
        for i in 0..=n {
            for j in 0..=n {
                let (vl, vr) = (-bound + i as f64 * step, -bound + j as f64 * step);
                let e = miss(vl, vr);
                if e < best.0 {
                    best = (e, vl, vr);
                }
            }
        }
        let mut h = step;
        while h > 1e-9 {
            let mut moved = false;
            for (dl, dr) in [
                (h, 0.0),
                (-h, 0.0),
                (0.0, h),
                (0.0, -h),
                (h, h),
                (-h, -h),
                (h, -h),
                (-h, h),
            ] {
                let (vl, vr) = (best.1 + dl, best.2 + dr);
                if vl.abs() <= bound && vr.abs() <= bound {
                    let e = miss(vl, vr);
                    if e < best.0 {
                        best = (e, vl, vr);
                        moved = true;
                    }
                }
            }
            if !moved {
                h *= 0.5;
            }
        }
        best.0
    }

    proptest! {
        #[test]
        fn command_drives_the_desired_twist(
            y_l in 0.2f64..0.8, y_r in -0.8f64..-0.2, x_c in -0.1f64..0.1,
            a_l in 0.8f64..1.1, a_r in 0.8f64..1.1, law in -0.2f64..0.3, speed_law in -0.1f64..0.1,
            kx in -0.05f64..0.05, ks in -0.1f64..0.1, vx in -1.5f64..1.5, w in -1.5f64..1.5,
        ) {
            let m = IcrModel {
                icr: IcrParams { y_l, y_r, x_c, alpha_l: a_l, alpha_r: a_r },
                spread_law: law,
                speed_law,
                centripetal: CentripetalSlopes { k_x_speed: kx, k_spread_speed: ks },
            };
            let mut cfg = eager_config();
            cfg.max_correction = 100.0;
            let mut c = engaged(cfg, m);
            let out = c.command(0.0, twist(vx, w), Some((m, true)));
            if out.status == Status::PassThrough(PassReason::NotInvertible) {
                // Only a command no tread speeds within 3 m/s reach may be refused.
                let closest = closest_reach(&m, vx, w, 3.0);
                prop_assert!(closest > 1e-3, "refused, yet {closest} from ({vx}, {w})");
                return Ok(());
            }
            prop_assert_eq!(out.status, Status::Compensating);
            let got = driven(&m, out.twist);
            prop_assert!((got.v_x - vx).abs() < 1e-9 && (got.omega - w).abs() < 1e-9,
                "{:?} drives {:?}", out.twist, got);
            // The correction is the linear map of the command.
            let n = correction(&m, S, vx, w).unwrap();
            let v = n[0][0] * vx + n[0][1] * S * w;
            let om = n[1][0] / S * vx + n[1][1] * w;
            prop_assert!((v - out.twist.v_x).abs() < 1e-9 && (om - out.twist.omega).abs() < 1e-9);
        }
    }

    #[test]
    fn the_controllers_own_model_is_no_correction() {
        let n = correction(&IcrModel::nominal(S), S, 0.7, -0.4).unwrap();
        assert!(distance(&n, &IDENTITY) < 1e-15, "{n:?}");
        let m = IcrModel::nominal(S);
        let out = engaged(eager_config(), m).command(0.0, twist(0.7, -0.4), Some((m, true)));
        assert!((out.twist.v_x - 0.7).abs() < 1e-15 && (out.twist.omega + 0.4).abs() < 1e-15);
    }

    #[test]
    fn zero_stays_exactly_zero() {
        let mut cfg = eager_config();
        cfg.max_acceleration = 0.5;
        cfg.max_yaw_acceleration = 1.0;
        let mut c = engaged(cfg, sand());
        let m = Some((sand(), true));
        let moving = c.command(0.0, twist(0.8, 0.5), m);
        assert_eq!(moving.status, Status::Compensating);
        assert!(moving.twist.omega != 0.5);
        // Stopping from speed is not rate-limited: zero is zero at once.
        for (t, e) in [(0.05, m), (0.1, None), (0.15, Some((sand(), false)))] {
            let out = c.command(t, Twist::default(), e);
            assert_eq!(out.twist, Twist::default(), "{:?}", out.status);
            assert!(out.twist.v_x.is_sign_positive() && out.twist.omega.is_sign_positive());
        }
    }

    #[test]
    fn not_confident_passes_through_unchanged() {
        let mut cfg = CompensateConfig::new(S);
        cfg.engage_after = 1.0;
        let mut c = Compensator::new(cfg).unwrap();
        let d = Twist {
            v_x: 0.6,
            v_y: 0.1,
            omega: -0.3,
        };
        let cases = [
            (0.0, None, PassReason::NoModel),
            (0.1, Some((sand(), false)), PassReason::NotConfident),
            (0.2, Some((sand(), true)), PassReason::Settling),
            (1.1, Some((sand(), true)), PassReason::Settling),
            (1.2, Some((sand(), false)), PassReason::NotConfident),
            (1.3, Some((sand(), true)), PassReason::Settling),
        ];
        for (t, e, why) in cases {
            let out = c.command(t, d, e);
            assert_eq!(
                out,
                Command {
                    twist: d,
                    status: Status::PassThrough(why)
                },
                "t = {t}"
            );
            assert!(c.applied().is_none());
        }
        // A second of unbroken confidence engages it.
        assert_eq!(
            c.command(2.4, d, Some((sand(), true))).status,
            Status::Compensating
        );
    }

    #[test]
    fn an_unbelieved_estimate_holds_the_model_last_applied() {
        let mut cfg = CompensateConfig::new(S);
        cfg.engage_after = 1.0;
        cfg.max_correction_rate = 1e9;
        let mut c = Compensator::new(cfg).unwrap();
        for t in [-2.0, -1.0, -0.95] {
            c.command(t, Twist::default(), Some((sand(), true)));
        }
        assert_eq!(c.applied(), Some(&sand()));
        let d = twist(0.6, 0.5);
        let under_sand = eager().command(0.0, d, Some((sand(), true))).twist;
        assert!((under_sand.omega - d.omega).abs() > 0.05);
        let mut other = sand();
        other.icr.y_l = 0.3;
        other.icr.alpha_r = 1.0;
        let mut singular = sand();
        singular.icr.y_r = singular.icr.y_l;
        // A detected change (not confident), the new estimate settling, a
        // singular estimate: the last applied model is held, not dropped.
        for (t, e, why) in [
            (0.0, Some((other, false)), PassReason::NotConfident),
            (0.5, Some((other, true)), PassReason::Settling),
            (1.6, Some((singular, true)), PassReason::InvalidModel),
            (1.7, Some((other, false)), PassReason::NotConfident),
            (1.8, Some((other, true)), PassReason::Settling),
        ] {
            let out = c.command(t, d, e);
            assert_eq!(out.twist, under_sand, "t = {t}");
            assert_eq!(out.status, Status::Holding(why), "t = {t}");
            assert_eq!(c.applied(), Some(&sand()));
        }
        // Believed long enough: the new estimate is applied.
        c.command(2.8, d, Some((other, true)));
        let out = c.command(2.85, d, Some((other, true)));
        assert_eq!(out.status, Status::Compensating);
        assert_eq!(c.applied(), Some(&other));
        // No estimate at all: passed through, and nothing is held after.
        let out = c.command(2.9, d, None);
        assert_eq!(out.twist, d);
        assert!(c.applied().is_none());
        let out = c.command(2.95, d, Some((other, false)));
        assert_eq!(out.status, Status::PassThrough(PassReason::NotConfident));
    }

    #[test]
    fn by_default_a_confident_estimate_is_applied_at_once() {
        let mut c = Compensator::new(CompensateConfig::new(S)).unwrap();
        let d = twist(0.6, 0.5);
        c.command(0.0, d, Some((sand(), true)));
        let out = c.command(0.05, d, Some((sand(), true)));
        assert_eq!(out.status, Status::Compensating);
        assert!(out.twist.omega > d.omega, "{out:?}");
    }

    #[test]
    fn correction_moves_at_the_bounded_rate() {
        let mut cfg = CompensateConfig::new(S);
        cfg.engage_after = 0.0;
        cfg.max_correction_rate = 0.2;
        let mut c = Compensator::new(cfg).unwrap();
        let d = twist(0.8, 0.6);
        let dt = 0.05;
        let mut model = sand();
        let mut before = IDENTITY;
        let mut reached = None;
        for k in 0..400 {
            let t = k as f64 * dt;
            // The estimate changes ground at 10 s.
            if k == 200 {
                model.icr.y_l = 0.36;
                model.icr.alpha_l = 0.97;
                reached = None;
            }
            let out = c.command(t, d, Some((model, true)));
            assert_eq!(out.status, Status::Compensating);
            let now = correction(c.applied().unwrap(), S, d.v_x, d.omega).unwrap();
            let step = distance(&now, &before);
            assert!(
                step <= 0.2 * dt * (1.0 + 1e-6),
                "t = {t}: correction moved {step}"
            );
            before = now;
            if reached.is_none()
                && distance(&now, &correction(&model, S, 0.8, 0.6).unwrap()) < 1e-12
            {
                reached = Some(t);
            }
        }
        // It does arrive (not stuck short), and not at once.
        let r = reached.expect("the correction reaches the second ground's");
        assert!(r > 10.0 + dt, "reached at {r}");
        assert!(c.applied() == Some(&model));
    }

    #[test]
    fn new_limits_apply_from_the_next_command() {
        let mut c = engaged(eager_config(), sand());
        let fast = Some((sand(), true));
        assert!(c.command(0.0, twist(2.0, 0.0), fast).twist.v_x > 1.5);
        let mut cfg = eager_config();
        cfg.max_speed = 1.0;
        c.set_config(cfg).unwrap();
        let limited = c.command(1.0, twist(2.0, 0.0), fast);
        assert_eq!(limited.status, Status::Compensating);
        assert!(limited.twist.v_x <= 1.0 + 1e-12, "{limited:?}");
        cfg.max_speed = -1.0;
        assert!(c.set_config(cfg).is_err());
        assert_eq!(c.config().max_speed, 1.0);
    }

    #[test]
    fn limits_are_respected() {
        let mut cfg = eager_config();
        cfg.max_speed = 1.0;
        cfg.max_yaw_rate = 0.8;
        cfg.max_acceleration = 1.0;
        cfg.max_yaw_acceleration = 2.0;
        let mut c = engaged(cfg, sand());
        let m = Some((sand(), true));
        let free = eager().command(0.0, twist(0.95, 0.7), m).twist;
        let first = c.command(0.0, twist(0.95, 0.7), m).twist;
        assert!(first.v_x.abs() <= 1.0 + 1e-12 && first.omega.abs() <= 0.8 + 1e-12);
        // Speed limits scale both, keeping the curvature the treads make.
        assert!((first.omega / first.v_x - free.omega / free.v_x).abs() < 1e-12);
        assert!(free.omega > 0.8, "the case must hit a limit: {free:?}");
        let mut last = first;
        for k in 1..40 {
            let d = if k % 2 == 0 {
                twist(-1.2, -0.9)
            } else {
                twist(1.2, 0.9)
            };
            let out = c.command(k as f64 * 0.02, d, m);
            assert_eq!(out.status, Status::Compensating);
            let out = out.twist;
            assert!(out.v_x.abs() <= 1.0 + 1e-12 && out.omega.abs() <= 0.8 + 1e-12);
            assert!((out.v_x - last.v_x).abs() <= 1.0 * 0.02 + 1e-12, "{k}");
            assert!((out.omega - last.omega).abs() <= 2.0 * 0.02 + 1e-12, "{k}");
            last = out;
        }
        // After the controller's timeout the next command starts afresh.
        let late = c.command(5.0, twist(0.5, 0.0), m).twist;
        assert!((late.v_x - eager().command(0.0, twist(0.5, 0.0), m).twist.v_x).abs() < 1e-12);
    }

    #[test]
    fn degenerate_models_and_commands_stay_finite() {
        // Nothing applied yet, so nothing to hold.
        let mut c = Compensator::new(eager_config()).unwrap();
        let d = twist(0.5, 0.5);
        let mut singular = sand();
        singular.icr.y_r = singular.icr.y_l;
        let mut nan = sand();
        nan.spread_law = f64::NAN;
        let mut zero_alpha = sand();
        zero_alpha.icr.alpha_l = 0.0;
        for (k, m) in [singular, nan, zero_alpha].into_iter().enumerate() {
            let out = c.command(k as f64, d, Some((m, true)));
            assert_eq!(out.status, Status::PassThrough(PassReason::InvalidModel));
            assert_eq!(out.twist, d);
        }
        // A ground asking for more than twice the turn is not believed.
        let mut wild = sand();
        wild.icr.y_l = 2.5;
        wild.icr.y_r = -2.5;
        let out = c.command(4.0, d, Some((wild, true)));
        assert_eq!(out.status, Status::PassThrough(PassReason::OutOfRange));
        // A law steeper than the turn it answers cannot be inverted.
        let mut steep = sand();
        steep.spread_law = 2.0;
        let out = c.command(5.0, twist(0.0, 3.0), Some((steep, true)));
        assert!(out.twist.omega.is_finite());
        let out = c.command(6.0, twist(f64::NAN, 0.3), Some((sand(), true)));
        assert_eq!(out.twist, Twist::default());
        assert_eq!(
            out.status,
            Status::PassThrough(PassReason::NonFiniteCommand)
        );
        let bad = CompensateConfig {
            separation: 0.0,
            ..CompensateConfig::new(S)
        };
        assert!(Compensator::new(bad).is_err());
    }
}
