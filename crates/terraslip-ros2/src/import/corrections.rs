//! A filter's corrections, read from its own odometry: where fixes arrive
//! its pose covariance shrinks and its pose jumps off the integral of its
//! own twist. A wheel odometry's covariance only grows (or stays put) and
//! its pose is the smooth integral of its twist.

/// A drop of the position variance by more than this fraction, between
/// two messages, is a fix taken in.
const SHRINK: f64 = 0.2;
/// A position off the twist's integral by more than this (m), beyond twice
/// the step the twist itself makes, is a jump.
const JUMP_M: f64 = 0.1;
/// Fewer shrinks or jumps than this are no pattern.
const AT_LEAST: u32 = 3;
/// Jumps in more than this fraction of messages are no corrections (the
/// twist is in another frame, or the stamps are off): no evidence.
const SPARSE: f64 = 0.1;
/// Steps longer than this (s) are gaps, not compared.
const MAX_DT_S: f64 = 1.0;

/// One odometry message's pose, twist and position variance.
#[derive(Debug, Clone, Copy)]
pub(super) struct OdomSample {
    /// Stamp, s.
    pub t: f64,
    /// Position in the odometry's frame, m.
    pub x: f64,
    pub y: f64,
    /// Heading in the odometry's frame, rad.
    pub yaw: f64,
    /// Twist in the child (body) frame, m/s.
    pub vx: f64,
    pub vy: f64,
    /// Position variance (xx + yy of the pose covariance), m².
    pub var: Option<f64>,
}

/// The shrinks and jumps counted over one odometry topic.
#[derive(Debug, Clone, Default)]
pub(super) struct Corrections {
    prev: Option<OdomSample>,
    /// Steps compared.
    pub steps: u32,
    /// Steps where the position variance shrank.
    pub shrinks: u32,
    /// Steps where the pose jumped off the twist's integral.
    pub jumps: u32,
}

impl Corrections {
    /// Takes the next message (in stamp order).
    pub fn add(&mut self, s: OdomSample) {
        let Some(p) = self.prev.replace(s) else {
            return;
        };
        let dt = s.t - p.t;
        if !(dt > 0.0 && dt <= MAX_DT_S) {
            return;
        }
        self.steps += 1;
        if let (Some(a), Some(b)) = (p.var, s.var) {
            if a > 0.0 && b.is_finite() && b < (1.0 - SHRINK) * a {
                self.shrinks += 1;
            }
        }
        let (c, sn) = (p.yaw.cos(), p.yaw.sin());
        let px = p.x + dt * (c * p.vx - sn * p.vy);
        let py = p.y + dt * (sn * p.vx + c * p.vy);
        let off = (s.x - px).hypot(s.y - py);
        let step = dt * p.vx.hypot(p.vy);
        if off > JUMP_M + 2.0 * step {
            self.jumps += 1;
        }
    }

    /// Why these data look like a filter's corrections (empty: they do not).
    pub fn signs(&self) -> Vec<String> {
        let mut signs = Vec::new();
        if self.shrinks >= AT_LEAST {
            signs.push(format!(
                "its pose covariance shrinks {} times (fixes taken in)",
                self.shrinks
            ));
        }
        if self.jumps >= AT_LEAST && f64::from(self.jumps) <= SPARSE * f64::from(self.steps) {
            signs.push(format!(
                "its pose jumps {} times off its own twist's integral (corrections)",
                self.jumps
            ));
        }
        signs
    }
}

/// Heading (rad) of a unit quaternion.
pub(super) fn yaw(x: f64, y: f64, z: f64, w: f64) -> f64 {
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t: f64, x: f64, var: f64) -> OdomSample {
        OdomSample {
            t,
            x,
            y: 0.0,
            yaw: 0.0,
            vx: 1.0,
            vy: 0.0,
            var: Some(var),
        }
    }

    #[test]
    fn a_smooth_growing_odometry_shows_no_corrections() {
        let mut c = Corrections::default();
        for i in 0..200 {
            let t = i as f64 * 0.05;
            c.add(sample(t, t, 0.01 + 0.001 * t));
        }
        assert!(c.signs().is_empty(), "{c:?}");
    }

    #[test]
    fn shrinks_and_sparse_jumps_are_signs() {
        let mut c = Corrections::default();
        for i in 0..200 {
            let t = i as f64 * 0.05;
            let fix = 0.5 * f64::from((i / 40) as u32 % 2 == 1);
            c.add(sample(t, t + fix, 0.01 + 0.01 * (t % 2.0)));
        }
        let s = c.signs();
        assert_eq!(s.len(), 2, "{c:?}");
    }

    #[test]
    fn jumps_at_every_step_are_no_evidence() {
        let mut c = Corrections::default();
        for i in 0..200 {
            let t = i as f64 * 0.05;
            c.add(sample(t, if i % 2 == 0 { 0.0 } else { 1.0 }, 0.01));
        }
        assert!(c.signs().is_empty(), "{c:?}");
    }
}
