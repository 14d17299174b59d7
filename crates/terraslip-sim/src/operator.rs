//! The operator at the joystick: picks manoeuvres (straight runs, arcs of
//! several radii, spins in place, S-curves, stops) and commands a forward
//! speed and a turn rate; keeps the robot inside its field by turning home
//! when it strays too far.

use std::f64::consts::TAU;

use rand::rngs::StdRng;
use rand::Rng;
use terraslip_core::angle::wrap;

use crate::scenario::{Drive, ManoeuvreKind, ManoeuvreSpec};

/// What the operator is doing now.
#[derive(Debug, Clone, PartialEq)]
struct Active {
    spec: ManoeuvreSpec,
    t_start: f64,
}

impl Active {
    fn t_end(&self) -> f64 {
        self.t_start + self.spec.duration
    }

    /// Commanded (forward speed m/s, yaw rate rad/s) at `t`.
    fn command(&self, t: f64) -> (f64, f64) {
        let s = &self.spec;
        match s.kind {
            ManoeuvreKind::Straight => (s.speed, 0.0),
            ManoeuvreKind::Arc => (s.speed, s.speed / s.radius),
            ManoeuvreKind::Spin => (0.0, s.rate),
            ManoeuvreKind::SCurve => {
                let phase = TAU * (t - self.t_start) / s.period;
                (s.speed, s.speed / s.radius * phase.sin())
            }
            ManoeuvreKind::Stop => (0.0, 0.0),
        }
    }
}

pub(crate) struct Operator {
    cfg: Drive,
    rng: StdRng,
    active: Option<Active>,
    next_programmed: usize,
    /// The last improvised manoeuvre went straight or stopped.
    last_was_straight: bool,
    /// Robot track width, m: turn rates for the homing arcs.
    track_width: f64,
}

impl Operator {
    pub(crate) fn new(cfg: Drive, rng: StdRng, track_width: f64) -> Self {
        Self {
            cfg,
            rng,
            active: None,
            next_programmed: 0,
            last_was_straight: true,
            track_width,
        }
    }

    /// Target (forward speed m/s, yaw rate rad/s) at time `t` with the robot
    /// at `east`, `north` (m) heading `yaw` (rad).
    pub(crate) fn command(&mut self, t: f64, east: f64, north: f64, yaw: f64) -> (f64, f64) {
        let done = self.active.as_ref().map_or(true, |a| t >= a.t_end());
        if done {
            let spec = self.next(east, north, yaw);
            self.active = Some(Active { spec, t_start: t });
        }
        match &self.active {
            Some(a) => a.command(t),
            None => (0.0, 0.0),
        }
    }

    fn next(&mut self, east: f64, north: f64, yaw: f64) -> ManoeuvreSpec {
        if !self.cfg.manoeuvres.is_empty() {
            let m = self.cfg.manoeuvres[self.next_programmed % self.cfg.manoeuvres.len()].clone();
            self.next_programmed += 1;
            return m;
        }
        let dist = east.hypot(north);
        if dist > self.cfg.area_radius {
            let err = wrap((-north).atan2(-east) - yaw);
            let speed = 0.5 * (self.cfg.speed[0] + self.cfg.speed[1]);
            if err.abs() > 0.35 {
                // Turn home on a moderate arc; slip makes the real turn
                // slower than commanded, so over-steer the duration a bit.
                let radius = 2.0_f64.max(self.track_width * 4.0);
                let rate = speed / radius;
                return ManoeuvreSpec {
                    kind: ManoeuvreKind::Arc,
                    duration: (1.3 * err.abs() / rate).clamp(1.0, 30.0),
                    speed,
                    radius: radius.copysign(err),
                    rate: 0.0,
                    period: 0.0,
                };
            }
            return ManoeuvreSpec {
                kind: ManoeuvreKind::Straight,
                duration: (0.5 * dist / speed.max(0.1)).clamp(2.0, 20.0),
                speed,
                radius: 0.0,
                rate: 0.0,
                period: 0.0,
            };
        }
        let m = &self.cfg.mix;
        // An operator rarely goes straight twice in a row: after a straight
        // run or a stop comes a turn (unless the mix has no turns at all).
        let turns = m.arc + m.spin + m.s_curve;
        let calm = if self.last_was_straight && turns > 0.0 {
            0.0
        } else {
            1.0
        };
        let weights = [calm * m.straight, m.arc, m.spin, m.s_curve, calm * m.stop];
        let total: f64 = weights.iter().sum();
        let mut pick = self.rng.gen::<f64>() * total;
        let mut kind = ManoeuvreKind::Stop;
        for (w, k) in weights.iter().zip([
            ManoeuvreKind::Straight,
            ManoeuvreKind::Arc,
            ManoeuvreKind::Spin,
            ManoeuvreKind::SCurve,
            ManoeuvreKind::Stop,
        ]) {
            if pick < *w {
                kind = k;
                break;
            }
            pick -= w;
        }
        let [d0, d1] = self.cfg.duration;
        let mut duration = self.rng.gen_range(d0..=d1).max(0.5);
        let speed = self.rng.gen_range(self.cfg.speed[0]..=self.cfg.speed[1]);
        let sign = if self.rng.gen::<bool>() { 1.0 } else { -1.0 };
        let mut radius = sign * self.cfg.radii[self.rng.gen_range(0..self.cfg.radii.len())];
        let (rate, period) = match kind {
            ManoeuvreKind::Spin => {
                let r = self
                    .rng
                    .gen_range(self.cfg.spin_rate[0]..=self.cfg.spin_rate[1]);
                // Spins are short: at most about one turn.
                duration = duration.min(TAU / r.max(0.1)).min(8.0);
                (sign * r, 0.0)
            }
            ManoeuvreKind::SCurve => {
                // Wide S-curves are hardly curves: swing at 4 m or tighter.
                radius = radius.clamp(-4.0, 4.0);
                let p = self.rng.gen_range(6.0..=14.0);
                // Whole periods, so an S-curve ends heading the way it began.
                duration = (duration / p).ceil().max(1.0) * p;
                (0.0, p)
            }
            ManoeuvreKind::Stop => {
                duration = duration.min(5.0);
                (0.0, 0.0)
            }
            _ => (0.0, 0.0),
        };
        self.last_was_straight = matches!(kind, ManoeuvreKind::Straight | ManoeuvreKind::Stop);
        // Tight arcs at full speed would exceed the tread speed limit; the
        // operator slows down for them as a person would.
        let speed = if kind == ManoeuvreKind::Arc || kind == ManoeuvreKind::SCurve {
            speed.min(radius.abs() * 0.8).max(0.15)
        } else {
            speed
        };
        ManoeuvreSpec {
            kind,
            duration,
            speed,
            radius,
            rate,
            period,
        }
    }
}
