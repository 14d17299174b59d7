//! Angle helpers. Headings are radians, counter-clockwise from east.

use core::f64::consts::PI;

/// Wraps an angle to `(-pi, pi]`. Non-finite input is returned unchanged so
/// callers can detect it rather than get a silently wrong finite number.
pub fn wrap(a: f64) -> f64 {
    if !a.is_finite() {
        return a;
    }
    // The filter's headings are nearly always in range already.
    if a > -PI && a <= PI {
        return a;
    }
    let mut w = libm::remainder(a, 2.0 * PI);
    if w <= -PI {
        w += 2.0 * PI;
    }
    w
}

/// Converts a compass heading (degrees clockwise from north) to an ENU yaw
/// (radians counter-clockwise from east), wrapped to `(-pi, pi]`.
pub fn yaw_from_compass_deg(heading_deg: f64) -> f64 {
    wrap((90.0 - heading_deg).to_radians())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    #[test]
    fn wrap_maps_into_half_open_interval() {
        assert_abs_diff_eq!(wrap(3.0 * PI), PI, epsilon = 1e-12);
        assert_abs_diff_eq!(wrap(-3.0 * PI), PI, epsilon = 1e-12);
        assert_abs_diff_eq!(wrap(0.5), 0.5, epsilon = 1e-15);
        assert_abs_diff_eq!(wrap(2.0 * PI + 0.1), 0.1, epsilon = 1e-12);
        assert!(wrap(f64::NAN).is_nan());
    }

    #[test]
    fn compass_north_is_enu_quarter_turn() {
        assert_abs_diff_eq!(yaw_from_compass_deg(0.0), PI / 2.0, epsilon = 1e-12);
        assert_abs_diff_eq!(yaw_from_compass_deg(90.0), 0.0, epsilon = 1e-12);
        assert_abs_diff_eq!(yaw_from_compass_deg(180.0), -PI / 2.0, epsilon = 1e-12);
    }
}
