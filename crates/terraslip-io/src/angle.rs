//! Angles as the log readers store them.

/// Wraps to (-pi, pi], as the readers wrap `yaw` columns.
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::PI;
    let mut w = a.rem_euclid(2.0 * PI);
    if w > PI {
        w -= 2.0 * PI;
    }
    w
}
