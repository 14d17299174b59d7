//! Regulated pure pursuit, as Nav2's `RegulatedPurePursuitController`
//! does it: the lookahead grows with the speed, the speed drops in tight
//! curvature and on the approach to the goal, and the robot turns on the
//! spot towards the path when it faces far away from it.
//!
//! Frames: world ENU m, yaw rad; the command is a REP-103 body twist.

use terraslip_core::angle::wrap;

use super::course::Course;

/// The follower's settings (Nav2's parameter names, SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pursuit {
    /// m/s
    pub desired_linear_vel: f64,
    /// Lookahead = speed x this, s, clamped to the two distances below.
    pub lookahead_time: f64,
    /// m
    pub min_lookahead_dist: f64,
    pub max_lookahead_dist: f64,
    /// Below this radius of the curvature the speed scales down, m.
    pub regulated_linear_scaling_min_radius: f64,
    /// The regulated speed's floor, m/s.
    pub regulated_linear_scaling_min_speed: f64,
    /// The speed scales down within this distance of the goal, m.
    pub approach_velocity_scaling_dist: f64,
    /// m/s
    pub min_approach_linear_velocity: f64,
    /// Turn on the spot when the path is further round than this, rad.
    pub rotate_to_heading_min_angle: f64,
    /// rad/s
    pub rotate_to_heading_angular_vel: f64,
    /// Limit on the change of the commanded speed, m/s^2.
    pub max_linear_accel: f64,
    /// The goal is reached within this distance, m.
    pub goal_tolerance: f64,
}

impl Default for Pursuit {
    /// Nav2's defaults, with a goal tolerance of 0.25 m.
    fn default() -> Self {
        Self {
            desired_linear_vel: 0.5,
            lookahead_time: 1.5,
            min_lookahead_dist: 0.3,
            max_lookahead_dist: 0.9,
            regulated_linear_scaling_min_radius: 0.9,
            regulated_linear_scaling_min_speed: 0.25,
            approach_velocity_scaling_dist: 0.6,
            min_approach_linear_velocity: 0.05,
            rotate_to_heading_min_angle: 0.785,
            rotate_to_heading_angular_vel: 1.8,
            max_linear_accel: 2.5,
            goal_tolerance: 0.25,
        }
    }
}

/// The follower's memory between calls.
#[derive(Debug, Clone, Default)]
pub struct PursuitState {
    /// Index of the course point the robot is believed nearest.
    pub progress: usize,
    /// The last commanded speed, m/s.
    pub speed: f64,
}

impl Pursuit {
    /// The command `(v m/s, omega rad/s)` for the robot believed at
    /// `(east, north, yaw)`, `dt` s after the previous one; `None` once the
    /// goal is reached.
    pub fn command(
        &self,
        course: &Course,
        st: &mut PursuitState,
        pose: (f64, f64, f64),
        dt: f64,
    ) -> Option<(f64, f64)> {
        let (east, north, yaw) = pose;
        let last = course.points.last()?;
        let to_goal = (last.east - east).hypot(last.north - north);
        let (i, _) = course.project(east, north, st.progress, 2.0);
        st.progress = i;
        if to_goal < self.goal_tolerance || i + 1 >= course.points.len() {
            st.speed = 0.0;
            return None;
        }
        let lookahead = (st.speed.abs() * self.lookahead_time)
            .clamp(self.min_lookahead_dist, self.max_lookahead_dist);
        // The first course point at least the lookahead away.
        let carrot = course.points[i..]
            .iter()
            .find(|p| (p.east - east).hypot(p.north - north) >= lookahead)
            .unwrap_or(last);
        let (s, c) = yaw.sin_cos();
        let (de, dn) = (carrot.east - east, carrot.north - north);
        let (x, y) = (c * de + s * dn, -s * de + c * dn);
        let d2 = x * x + y * y;
        let curvature = if d2 > 1e-9 { 2.0 * y / d2 } else { 0.0 };

        let angle_to_path = wrap(y.atan2(x));
        if angle_to_path.abs() > self.rotate_to_heading_min_angle {
            st.speed = 0.0;
            return Some((
                0.0,
                self.rotate_to_heading_angular_vel * angle_to_path.signum(),
            ));
        }
        let mut v = self.desired_linear_vel;
        let radius = 1.0 / curvature.abs().max(1e-9);
        if radius < self.regulated_linear_scaling_min_radius {
            v *= radius / self.regulated_linear_scaling_min_radius;
        }
        v = v.max(
            self.regulated_linear_scaling_min_speed
                .min(self.desired_linear_vel),
        );
        let remaining = (course.length() - course.points[i].s).max(0.0);
        if remaining < self.approach_velocity_scaling_dist {
            v = (v * remaining / self.approach_velocity_scaling_dist)
                .max(self.min_approach_linear_velocity);
        }
        let dv = self.max_linear_accel * dt.max(0.0);
        v = v.clamp(st.speed - dv, st.speed + dv);
        st.speed = v;
        Some((v, v * curvature))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn on_the_course_it_drives_ahead_and_steers_back_towards_it() {
        let c = Course::new(&["asphalt"], 1);
        let p = Pursuit::default();
        let mut st = PursuitState {
            progress: 0,
            speed: 0.5,
        };
        let (v, w) = p.command(&c, &mut st, (0.5, 0.0, 0.0), 0.05).unwrap();
        assert!((v - 0.5).abs() < 1e-9 && w.abs() < 1e-9);
        // Right of the course: steer left.
        let (_, w) = p.command(&c, &mut st, (0.6, -0.2, 0.0), 0.05).unwrap();
        assert!(w > 0.1, "{w}");
        // Facing backwards: turn on the spot.
        let (v, w) = p.command(&c, &mut st, (0.6, 0.0, 3.0), 0.05).unwrap();
        assert_eq!(v, 0.0);
        assert!(w.abs() > 1.0);
        // At the goal: done.
        let end = *c.points.last().unwrap();
        assert!(p
            .command(&c, &mut st, (end.east, end.north, end.heading), 0.05)
            .is_none());
    }
}
