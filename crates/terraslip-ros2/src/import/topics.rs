//! Which topic feeds which stream: by name, or by message type when the
//! choice is unique.

use std::fmt::Write as _;

use crate::msg::short_type;
use crate::{Bag, Ros2Error};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Role {
    Wheels,
    Pose,
    Heading,
    Imu,
    Images,
    /// Static transforms: sensor mountings.
    Tf,
}

impl Role {
    pub(super) fn key(self) -> &'static str {
        match self {
            Role::Wheels => "wheels",
            Role::Pose => "pose",
            Role::Heading => "heading",
            Role::Imu => "imu",
            Role::Images => "images",
            Role::Tf => "tf",
        }
    }
    /// Accepted types, in order of preference when choosing by type.
    fn types(self) -> &'static [&'static [&'static str]] {
        match self {
            Role::Wheels => &[
                &["sensor_msgs/JointState"],
                &["nav_msgs/Odometry", "geometry_msgs/TwistStamped"],
            ],
            Role::Pose => &[
                &["sensor_msgs/NavSatFix"],
                &[
                    "geometry_msgs/PoseWithCovarianceStamped",
                    "geometry_msgs/PoseStamped",
                ],
                &["nav_msgs/Odometry"],
            ],
            Role::Heading | Role::Imu => &[&["sensor_msgs/Imu"]],
            Role::Images => &[&["sensor_msgs/CompressedImage"], &["sensor_msgs/Image"]],
            Role::Tf => &[&["tf2_msgs/TFMessage"]],
        }
    }
}

/// Picks the topic for `role`: the configured one, or the unique one of the
/// most preferred type class present. `taken` topics are not candidates.
pub(super) fn choose(
    bag: &Bag,
    role: Role,
    configured: &Option<String>,
    taken: &[usize],
) -> Result<Option<usize>, Ros2Error> {
    let accepted: Vec<&str> = role
        .types()
        .iter()
        .flat_map(|c| c.iter().copied())
        .collect();
    if let Some(name) = configured {
        if name.is_empty() {
            return Ok(None);
        }
        let i = bag.topic(name).ok_or_else(|| Ros2Error::Bag {
            bag: bag.path.clone(),
            reason: format!(
                "[{}] topic `{name}` is not in the bag (it has: {})",
                role.key(),
                list(bag, &(0..bag.topics.len()).collect::<Vec<_>>())
            ),
        })?;
        let ty = short_type(&bag.topics[i].ty);
        if !accepted.contains(&ty.as_str()) {
            return Err(Ros2Error::Bag {
                bag: bag.path.clone(),
                reason: format!(
                    "[{}] topic `{name}` is {}; {} takes {}",
                    role.key(),
                    bag.topics[i].ty,
                    role.key(),
                    accepted.join(", ")
                ),
            });
        }
        return Ok(Some(i));
    }
    for class in role.types() {
        let c: Vec<usize> = (0..bag.topics.len())
            .filter(|i| {
                !taken.contains(i) && class.contains(&short_type(&bag.topics[*i].ty).as_str())
            })
            .collect();
        match c.len() {
            0 => continue,
            1 => return Ok(Some(c[0])),
            _ => {
                let mut lines = String::new();
                for &i in &c {
                    let _ = write!(
                        lines,
                        " `[{}] topic = \"{}\"`",
                        role.key(),
                        bag.topics[i].name
                    );
                }
                return Err(Ros2Error::Bag {
                    bag: bag.path.clone(),
                    reason: format!(
                        "{} topics could be the {} source: {}; name one in a --topics file with one of the lines{lines}",
                        c.len(),
                        role.key(),
                        list(bag, &c)
                    ),
                });
            }
        }
    }
    Ok(None)
}

pub(super) fn list(bag: &Bag, idx: &[usize]) -> String {
    idx.iter()
        .map(|&i| format!("{} ({})", bag.topics[i].name, bag.topics[i].ty))
        .collect::<Vec<_>>()
        .join(", ")
}
