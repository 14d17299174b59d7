//! The true motion: the operator's commands through rate limits and wheel
//! lag to tread speeds, the slip model to ICRs, and the ICR kinematics
//! integrated exactly over each step.

use terraslip_core::kinematics::{IcrParams, Twist};

use crate::operator::Operator;
use crate::timeline::Timeline;
use crate::Scenario;

/// The robot's true state between two steps.
pub(crate) struct Motion {
    /// World ENU m and yaw rad (unwrapped).
    pub east: f64,
    pub north: f64,
    pub yaw: f64,
    /// Rate-limited command: forward m/s and yaw rate rad/s.
    cmd_v: f64,
    cmd_w: f64,
    /// Tread surface speeds as the encoders see them, m/s.
    pub v_left: f64,
    pub v_right: f64,
    /// Wheel angles, rad.
    pub angle_left: f64,
    pub angle_right: f64,
    /// Spread scale of the slip model (1: the terrain's own ICRs).
    slip_factor: f64,
    /// Distance driven, m.
    pub odometer: f64,
    /// The ICRs in force.
    pub icr: IcrParams,
    /// Index into [`Timeline::terrains`].
    pub terrain: usize,
    /// Body twist, REP-103.
    pub twist: Twist,
}

impl Motion {
    /// At rest at the origin, heading `yaw0` rad.
    pub fn start(sc: &Scenario, timeline: &Timeline, yaw0: f64) -> Self {
        let slip_factor = 1.0 - 0.5 * sc.slip.turn_sensitivity;
        let (nom0, ter0) = timeline.nominal_at(0.0);
        Self {
            east: 0.0,
            north: 0.0,
            yaw: yaw0,
            cmd_v: 0.0,
            cmd_w: 0.0,
            v_left: 0.0,
            v_right: 0.0,
            angle_left: 0.0,
            angle_right: 0.0,
            slip_factor,
            odometer: 0.0,
            icr: scale_spread(&nom0, slip_factor),
            terrain: ter0,
            twist: Twist::default(),
        }
    }

    /// One step of `h` s from `t`.
    pub fn advance(
        &mut self,
        t: f64,
        h: f64,
        operator: &mut Operator,
        sc: &Scenario,
        timeline: &Timeline,
    ) {
        let (tv, tw) = operator.command(t, self.east, self.north, self.yaw);
        let (nom, ti) = timeline.nominal_at(t);
        self.drive(h, (tv, tw), (nom, ti), sc);
    }

    /// One step of `h` s under the target command `(forward m/s, yaw rate
    /// rad/s)` sent to a nominal differential drive (tread set points from
    /// the robot's track width), on ground `terrain` whose ICRs before the
    /// slip model are `nominal`.
    pub fn drive(&mut self, h: f64, target: (f64, f64), ground: (IcrParams, usize), sc: &Scenario) {
        let (tv, tw) = target;
        let robot = &sc.robot;
        let w = robot.track_width;
        // Command -> rate limits -> wheel set points -> wheel lag.
        self.cmd_v = slew(self.cmd_v, tv, sc.drive.accel_limit * h);
        self.cmd_w = slew(self.cmd_w, tw, sc.drive.yaw_accel_limit * h);
        let (mut sl, mut sr) = (
            self.cmd_v - 0.5 * w * self.cmd_w,
            self.cmd_v + 0.5 * w * self.cmd_w,
        );
        let peak = sl.abs().max(sr.abs());
        if peak > robot.max_tread_speed {
            let k = robot.max_tread_speed / peak;
            sl *= k;
            sr *= k;
        }
        let lag = sc.drive.wheel_lag;
        let follow = if lag > 0.0 {
            1.0 - (-h / lag).exp()
        } else {
            1.0
        };
        self.v_left += (sl - self.v_left) * follow;
        self.v_right += (sr - self.v_right) * follow;
        let (vl, vr) = (self.v_left, self.v_right);

        // Slip: the spread follows the motion with a lag.
        let turn = (vr - vl) / w;
        let speed = 0.5 * (vl + vr);
        let s = &sc.slip;
        let target = 1.0
            + s.turn_sensitivity * ((turn.abs() / s.turn_rate_ref).tanh() - 0.5)
            + s.speed_sensitivity * (speed.abs() - 0.5);
        self.slip_factor += (target - self.slip_factor)
            * if s.lag > 0.0 {
                1.0 - (-h / s.lag).exp()
            } else {
                1.0
            };
        let (nom, ti) = ground;
        self.icr = scale_spread(&nom, self.slip_factor);
        self.terrain = ti;

        self.twist = self.icr.twist(vl, vr);
        let (de, dn, dyaw) = se2_step(self.yaw, &self.twist, h);
        self.east += de;
        self.north += dn;
        self.yaw += dyaw;
        self.angle_left += vl / robot.wheel_radius * h;
        self.angle_right += vr / robot.wheel_radius * h;
        self.odometer += self.twist.v_x.hypot(self.twist.v_y) * h;
    }
}

/// Moves `x` towards `target` by at most `max_step`.
fn slew(x: f64, target: f64, max_step: f64) -> f64 {
    x + (target - x).clamp(-max_step, max_step)
}

/// Exact pose increment in the world frame for a constant body twist over `h`.
fn se2_step(yaw: f64, tw: &Twist, h: f64) -> (f64, f64, f64) {
    let th = tw.omega * h;
    // sin(th)/th and (1-cos(th))/th, with their series near 0.
    let (a, b) = if th.abs() < 1e-6 {
        (1.0 - th * th / 6.0, 0.5 * th)
    } else {
        (th.sin() / th, (1.0 - th.cos()) / th)
    };
    let dx = (a * tw.v_x - b * tw.v_y) * h;
    let dy = (b * tw.v_x + a * tw.v_y) * h;
    let (s, c) = yaw.sin_cos();
    (c * dx - s * dy, s * dx + c * dy, th)
}

/// ICRs moved by the slip model: the spread scales by `factor` around the
/// ICRs' mid point, so the eccentricity stays that of the terrain.
fn scale_spread(p: &IcrParams, factor: f64) -> IcrParams {
    let mid = 0.5 * (p.y_l + p.y_r);
    IcrParams {
        y_l: mid + (p.y_l - mid) * factor,
        y_r: mid + (p.y_r - mid) * factor,
        ..*p
    }
}
