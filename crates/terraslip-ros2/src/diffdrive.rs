//! Calibrated ICRs as `diff_drive_controller` (ros2_controllers) parameters.
//!
//! The controller's odometry (`diff_drive_controller/src/odometry.cpp`) turns
//! wheel angular velocities ω_l, ω_r (rad/s) into a body twist with
//! r_l = left_wheel_radius_multiplier · wheel_radius,
//! r_r = right_wheel_radius_multiplier · wheel_radius,
//! S = wheel_separation_multiplier · wheel_separation:
//! linear = (r_l ω_l + r_r ω_r)/2, angular = (r_r ω_r − r_l ω_l)/S.
//! The ICR model (`terraslip_core::IcrParams::twist`) with tread speeds
//! v = R ω gives v_x = (α_r v_r y_l − α_l v_l y_r)/(y_l − y_r),
//! ω = (α_r v_r − α_l v_l)/(y_l − y_r), v_y = x_c (α_l v_l − α_r v_r)/(y_l − y_r).
//! They agree exactly when y_l = −y_r and x_c = 0 with the radius
//! multipliers α_l, α_r and S = y_l − y_r; the controller cannot represent
//! x_c (it has no lateral velocity) nor y_l ≠ −y_r (its forward speed is
//! always the mean of the treads'), nor ICRs that move with the motion
//! (the calibration's `rate_model`: turn-rate, traction and centripetal
//! terms, the last a lateral slip on v·ω and a yaw slip growing with the
//! speed): its multipliers are constants, so the blocks hold the constant ICRs.

use std::fmt::Write as _;

/// The five `diff_drive_controller` parameters terraslip sets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiffDriveParams {
    /// m: the nominal separation the multiplier scales.
    pub wheel_separation: f64,
    pub wheel_separation_multiplier: f64,
    /// m, when the recording states it (`meta.toml` `wheel_radius`); the
    /// radius multipliers are relative to it, so without it the file leaves
    /// the controller's own.
    pub wheel_radius: Option<f64>,
    pub left_wheel_radius_multiplier: f64,
    pub right_wheel_radius_multiplier: f64,
}

impl DiffDriveParams {
    /// From calibrated ICRs (m, body frame) and speed factors, keeping the
    /// nominal `wheel_separation` and `wheel_radius` (m, `None` when not
    /// known) the robot's config already has: the multipliers carry the
    /// calibration.
    pub fn from_icr(
        y_l: f64,
        y_r: f64,
        alpha_l: f64,
        alpha_r: f64,
        wheel_separation: f64,
        wheel_radius: Option<f64>,
    ) -> Self {
        Self {
            wheel_separation,
            wheel_separation_multiplier: (y_l - y_r) / wheel_separation,
            wheel_radius,
            left_wheel_radius_multiplier: alpha_l,
            right_wheel_radius_multiplier: alpha_r,
        }
    }

    /// The controller's odometry twist `(linear m/s, angular rad/s)` from
    /// wheel angular velocities (rad/s), as odometry.cpp computes it; with
    /// no `wheel_radius`, from tread speeds (m/s, a unit radius).
    pub fn odometry_twist(&self, omega_left: f64, omega_right: f64) -> (f64, f64) {
        let radius = self.wheel_radius.unwrap_or(1.0);
        let left_vel = omega_left * self.left_wheel_radius_multiplier * radius;
        let right_vel = omega_right * self.right_wheel_radius_multiplier * radius;
        let separation = self.wheel_separation * self.wheel_separation_multiplier;
        (
            (left_vel + right_vel) * 0.5,
            (right_vel - left_vel) / separation,
        )
    }
}

/// One block of the parameter file.
#[derive(Debug, Clone)]
pub struct ParamsBlock {
    /// Terrain name (`all` for a pooled set).
    pub terrain: String,
    pub params: DiffDriveParams,
    /// The ICRs it came from, m.
    pub y_l: f64,
    pub y_r: f64,
    pub x_c: f64,
    /// 2 s prediction position error on the calibration drives, m RMS:
    /// (full ICR model, the diff-drive approximation), when known.
    pub cost: Option<(f64, f64)>,
    /// For tread speeds made from the controller's odometry twist with a
    /// separation S: spread / S, the factor by which the recording's
    /// `wheel_separation_multiplier` is off when the radius multipliers
    /// of `params` are set too. The file also gives it divided by their
    /// mean: the factor with the radius multipliers left at 1 (the
    /// summary's `turn_factor`).
    pub separation_factor: Option<f64>,
    /// The terms of the set's selected variable model the controller
    /// leaves out (e.g. `k_x_speed = 0.12 s`), when there is one.
    pub left_out: Option<String>,
}

/// A ROS 2 parameter YAML, one controller block per terrain, named
/// `<controller>_<terrain>` (the pooled set keeps the plain name).
/// `nominal`: the separation (m) and its source when the tread speeds were
/// made with a nominal one, not the controller's: the ICRs are then in its
/// scale, so the blocks give the radius multipliers and, as a comment, the
/// factor on the controller's own `wheel_separation_multiplier`, not
/// absolute separations.
/// The controller whose odometry topic is `topic`: its namespace (the
/// node `/husky_velocity_controller` publishes `/husky_velocity_controller/odom`);
/// `None` for a topic without one (`/odom`).
pub fn controller_name(topic: &str) -> Option<&str> {
    let (ns, _) = topic.trim_start_matches('/').rsplit_once('/')?;
    let name = ns.rsplit('/').next()?;
    let plain = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    plain.then_some(name)
}

pub fn params_yaml(
    controller: &str,
    blocks: &[ParamsBlock],
    nominal: Option<(f64, &str)>,
) -> String {
    let mut s = String::new();
    s.push_str("# diff_drive_controller parameters from `terraslip calibrate`.\n");
    s.push_str("# The differential-drive model cannot represent the ICR model's longitudinal\n");
    s.push_str("# ICR x_c (a lateral velocity -x_c*omega in turns) nor unequal ICRs y_l != -y_r\n");
    s.push_str("# (forward speed weighted towards one tread): it keeps the spread y_l - y_r as\n");
    s.push_str("# the effective separation and the speed factors as radius multipliers.\n");
    s.push_str("# Nor can it make them move with the turn rate, the acceleration or the speed\n");
    s.push_str("# (the calibration's rate_model; its centripetal terms are a lateral slip\n");
    s.push_str("# -k_x_speed*v*omega and a spread growing by k_spread_speed*|v|): each block\n");
    s.push_str("# holds the constant ICRs and names what its set's selected model adds.\n");
    s.push_str("# wheel_separation and wheel_radius are the nominal values; the multipliers\n");
    s.push_str("# assume the recording's controller ran with radius multipliers of 1.\n");
    if blocks.iter().any(|b| b.params.wheel_radius.is_none()) {
        s.push_str(
            "# The recording does not state the wheel radius (`wheel_radius` in meta.toml,\n",
        );
        s.push_str("# `[meta] wheel_radius` in a bag's topics file): keep the controller's own\n");
        s.push_str("# wheel_radius; the radius multipliers are relative to it.\n");
    }
    if let Some((sep, source)) = nominal {
        let _ = writeln!(
            s,
            "# The recording's controller separation was not given: the tread speeds were made\n# with a nominal S = {sep} m ({source}), so the ICRs below are in that scale. As written\n# the blocks set nothing: multiply the controller's own wheel_separation_multiplier\n# and radius multipliers by the factors each block names, all three together."
        );
    }
    for b in blocks {
        let name = if b.terrain == "all" || blocks.len() == 1 {
            controller.to_string()
        } else {
            format!("{controller}_{}", b.terrain)
        };
        let p = &b.params;
        let _ = writeln!(
            s,
            "\n# terrain {}: y_l = {:.4} m, y_r = {:.4} m, x_c = {:.4} m",
            b.terrain, b.y_l, b.y_r, b.x_c
        );
        if let Some((full, dd)) = b.cost {
            let _ = writeln!(
                s,
                "# 2 s prediction error on the calibration drive (RMS, this set in its two forms): {full:.3} m as ICRs, {dd:.3} m as diff-drive (+{:.3} m)",
                dd - full
            );
        }
        if let Some(t) = &b.left_out {
            let _ = writeln!(
                s,
                "# not representable here, from the selected variable model: {t}"
            );
        }
        if let Some(f) = b.separation_factor {
            let alpha = 0.5 * (p.left_wheel_radius_multiplier + p.right_wheel_radius_multiplier);
            let _ = writeln!(
                s,
                "# factor on the recording's wheel_separation_multiplier: {f:.4} (spread / the separation the tread speeds were made with), with the radius multipliers below;\n# {:.4} with the radius multipliers left at 1 (spread / (mean speed factor x S): the odometry's turn over the true one, what a course check measures)",
                f / alpha
            );
        }
        if nominal.is_some() {
            let f = b
                .separation_factor
                .map_or("(not known)".to_string(), |f| format!("{f:.6}"));
            // The recording does not state the controller's separation, so
            // the block cannot set it; the radius multipliers alone would
            // scale the turn by their mean, the wrong way. As written it
            // sets nothing: each line says which value to multiply by what.
            let alpha = 0.5 * (p.left_wheel_radius_multiplier + p.right_wheel_radius_multiplier);
            let _ = write!(
                s,
                "{name}:\n  ros__parameters: {{}}\n    # Set these three together, each the controller's own value times the factor\n    # (the recording does not state the controller's wheel_separation_multiplier;\n    # the radius multipliers alone would scale the odometry's turn by {alpha:.4}):\n    # wheel_separation_multiplier: the controller's own x {f}\n    # left_wheel_radius_multiplier: the controller's own x {:.6}\n    # right_wheel_radius_multiplier: the controller's own x {:.6}\n",
                p.left_wheel_radius_multiplier, p.right_wheel_radius_multiplier
            );
            continue;
        }
        let _ = write!(
            s,
            "{name}:\n  ros__parameters:\n    wheel_separation: {:.6}\n    wheel_separation_multiplier: {:.6}\n",
            p.wheel_separation, p.wheel_separation_multiplier,
        );
        if let Some(r) = p.wheel_radius {
            let _ = writeln!(s, "    wheel_radius: {r:.6}");
        }
        let _ = write!(
            s,
            "    left_wheel_radius_multiplier: {:.6}\n    right_wheel_radius_multiplier: {:.6}\n",
            p.left_wheel_radius_multiplier, p.right_wheel_radius_multiplier
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_controller_is_named_by_its_odometry_topic() {
        assert_eq!(
            controller_name("/husky_velocity_controller/odom"),
            Some("husky_velocity_controller")
        );
        assert_eq!(controller_name("/robot1/diff_cont/odom"), Some("diff_cont"));
        assert_eq!(controller_name("/odom"), None);
        assert_eq!(controller_name("odom"), None);
    }

    /// The ICR model's body twist (terraslip-core's formula, restated so this
    /// crate stays free of the core).
    fn icr_twist(
        y_l: f64,
        y_r: f64,
        x_c: f64,
        a_l: f64,
        a_r: f64,
        v_l: f64,
        v_r: f64,
    ) -> (f64, f64, f64) {
        let (v_l, v_r) = (a_l * v_l, a_r * v_r);
        let d = y_l - y_r;
        (
            (v_r * y_l - v_l * y_r) / d,
            x_c * (v_l - v_r) / d,
            (v_r - v_l) / d,
        )
    }

    #[test]
    fn controller_odometry_reproduces_symmetric_icr_twist() {
        let (radius, sep) = (0.165, 0.555);
        for &(y, a_l, a_r) in &[(0.52, 0.95, 0.97), (0.30, 1.0, 1.0), (0.9, 0.8, 1.1)] {
            let p = DiffDriveParams::from_icr(y, -y, a_l, a_r, sep, Some(radius));
            for &(w_l, w_r) in &[(1.0, 3.0), (-2.0, 2.0), (4.0, 4.0), (0.5, -1.5)] {
                let (lin, ang) = p.odometry_twist(w_l, w_r);
                let (vx, vy, om) = icr_twist(y, -y, 0.0, a_l, a_r, w_l * radius, w_r * radius);
                assert!((lin - vx).abs() < 1e-12, "{lin} {vx}");
                assert!((ang - om).abs() < 1e-12, "{ang} {om}");
                assert_eq!(vy, 0.0);
            }
        }
    }

    #[test]
    fn asymmetric_icrs_are_not_reproduced() {
        // Control for the test above: the equality is not automatic.
        let p = DiffDriveParams::from_icr(0.7, -0.3, 1.0, 1.0, 0.555, Some(0.165));
        let (lin, ang) = p.odometry_twist(1.0, 3.0);
        let (vx, _, om) = icr_twist(0.7, -0.3, 0.0, 1.0, 1.0, 0.165, 0.495);
        assert!((ang - om).abs() < 1e-12);
        assert!((lin - vx).abs() > 1e-3);
    }

    #[test]
    fn yaml_has_one_block_per_terrain() {
        let p = DiffDriveParams::from_icr(0.52, -0.52, 1.0, 1.0, 0.555, Some(0.165));
        let b = |t: &str| ParamsBlock {
            terrain: t.into(),
            params: p,
            y_l: 0.52,
            y_r: -0.52,
            x_c: 0.0,
            cost: Some((0.1, 0.12)),
            separation_factor: None,
            left_out: (t == "grass").then(|| "k_x_speed = 0.1200 s".to_string()),
        };
        let y = params_yaml(
            "diff_drive_base_controller",
            &[b("grass"), b("asphalt")],
            None,
        );
        assert!(y.contains("diff_drive_base_controller_grass:\n  ros__parameters:"));
        assert!(y.contains("diff_drive_base_controller_asphalt:"));
        assert!(y.contains("wheel_separation_multiplier: 1.873874"));
        assert!(y.contains("cannot represent"));
        // The grass set's variable model is named in its block only.
        let grass = y.find("# terrain grass").unwrap();
        let asphalt = y.find("# terrain asphalt").unwrap();
        let named = y
            .find("selected variable model: k_x_speed = 0.1200 s")
            .unwrap();
        assert!(grass < named && named < asphalt, "{y}");
    }

    #[test]
    fn a_nominal_separation_gives_a_factor_not_a_separation() {
        let p = DiffDriveParams::from_icr(0.45, -0.45, 0.9, 0.92, 1.0, None);
        let block = ParamsBlock {
            terrain: "all".into(),
            params: p,
            y_l: 0.45,
            y_r: -0.45,
            x_c: 0.0,
            cost: None,
            separation_factor: Some(0.9),
            left_out: None,
        };
        let y = params_yaml("c", std::slice::from_ref(&block), Some((1.0, "default")));
        assert!(y.contains("nominal S = 1 m (default)"), "{y}");
        assert!(y.contains("wheel_separation_multiplier: 0.9000"), "{y}");
        // The factor with the radius multipliers left at 1, spread / (mean
        // speed factor x S) = 0.9 / 0.91: the odometry's turn over the
        // true one, what a course check measures.
        assert!(
            y.contains("0.9890 with the radius multipliers left at 1"),
            "{y}"
        );
        assert!(!y.contains("    wheel_separation:"), "{y}");
        // As written it sets nothing: the radius multipliers go with the
        // separation's factor, which the recording cannot make absolute.
        assert!(y.contains("c:\n  ros__parameters: {}\n"), "{y}");
        for line in [
            "    # wheel_separation_multiplier: the controller's own x 0.900000",
            "    # left_wheel_radius_multiplier: the controller's own x 0.900000",
            "    # right_wheel_radius_multiplier: the controller's own x 0.920000",
        ] {
            assert!(y.contains(line), "{line} in\n{y}");
        }
        assert!(
            !y.lines().any(|l| l.trim_start().starts_with("left_wheel")),
            "{y}"
        );
        // Given, the absolute values and the factor.
        let y = params_yaml("c", &[block], None);
        assert!(
            y.contains("    wheel_separation: 1.000000") && y.contains("0.9000"),
            "{y}"
        );
    }
}
