//! The scale the tread speeds of a bag are made in, as decided for it:
//! the separation of an odometry twist's tread speeds, or the wheel radius
//! of joint rates (the topics file's, the URDF's, the base driver's
//! odometry's, else a default: [`super::scale`]), and the line that tells
//! the user.

use super::config::{TopicsConfig, WheelsConfig};
use super::{odom_scale, scale};
use crate::msg::short_type;
use crate::{Bag, Ros2Error};

/// Whether the tread speeds' scale is left to the bag's URDF: the topics
/// file gives no separation (a twist) or no wheel radius (joint velocities).
pub(super) fn needs_urdf(bag: &Bag, cfg: &TopicsConfig, wheels: usize) -> bool {
    if short_type(&bag.topics[wheels].ty) == "sensor_msgs/JointState" {
        cfg.wheels.wheel_radius.is_none()
    } else {
        cfg.wheels.separation.is_none()
    }
}

/// For JointState wheels, the radius their rates are made tread speeds
/// with ([`scale::wheel_radius`]); where that is a default, the radius of
/// the bag's base-driver odometry made from the same joints
/// ([`odom_scale`], source `odometry`), with its scale.
pub(super) fn wheel_radius(
    bag: &mut Bag,
    cfg: &TopicsConfig,
    wheels: usize,
    urdf: Option<&scale::UrdfWheels>,
) -> Result<Option<(scale::Scale, Option<odom_scale::OdomScale>)>, Ros2Error> {
    if short_type(&bag.topics[wheels].ty) != "sensor_msgs/JointState" {
        return Ok(None);
    }
    let r = scale::wheel_radius(cfg, urdf);
    if r.source != "default" {
        return Ok(Some((r, None)));
    }
    Ok(Some(
        match odom_scale::fit(bag, wheels, &cfg.wheels.left, &cfg.wheels.right)? {
            Some(o) => (
                scale::Scale {
                    value: o.radius,
                    source: "odometry",
                },
                Some(o),
            ),
            None => (r, None),
        },
    ))
}

/// The wheel settings the tread speeds are made with: the topics file's,
/// with the separation (a twist) or the wheel radius (joint velocities)
/// from [`scale`] when it gives none; the separation's scale when it was
/// decided here; and the line that tells the user what was decided.
pub(super) fn wheel_scale(
    bag: &Bag,
    cfg: &TopicsConfig,
    wheels: usize,
    urdf: Option<&scale::UrdfWheels>,
    radius: &Option<(scale::Scale, Option<odom_scale::OdomScale>)>,
) -> (WheelsConfig, Option<scale::Scale>, String) {
    let mut wheels_cfg = cfg.wheels.clone();
    let wheel_name = &bag.topics[wheels].name;
    if let Some((r, from_odom)) = radius {
        wheels_cfg.wheel_radius = Some(r.value);
        let source = match from_odom {
            Some(o) => format!(
                "{}; {}'s twist against {wheel_name}'s rates over {} samples explains {:.1} % / {:.1} % of its speed / yaw rate; its separation {:.4} m starts the model",
                scale::describe(r.source),
                o.topic,
                o.samples,
                100.0 * o.fit.0,
                100.0 * o.fit.1,
                o.separation
            ),
            None => scale::describe(r.source).to_string(),
        };
        let line = format!(
            "wheel radius {} m ({source}; {wheel_name} gives rad/s){}",
            if from_odom.is_some() {
                format!("{:.4}", r.value)
            } else {
                r.value.to_string()
            },
            if r.is_given() {
                ""
            } else {
                ": the speed factors are relative to it"
            }
        );
        (wheels_cfg, None, line)
    } else {
        let s = scale::separation(cfg, urdf);
        wheels_cfg.separation = Some(s.value);
        let line = format!(
            "separation S = {} m for the tread speeds v ∓ ω·S/2 of {wheel_name} ({}){}",
            s.value,
            scale::describe(s.source),
            if s.is_given() {
                ""
            } else {
                "; the ICRs are learned in this scale and the controller's correction is given as a factor (learned spread / S)"
            }
        );
        (wheels_cfg, Some(s), line)
    }
}
