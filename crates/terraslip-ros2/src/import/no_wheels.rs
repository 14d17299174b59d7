//! What `import` says when a bag has no topic it reads tread speeds from:
//! the topics it has and, for a recording, the way on. Wheel speeds in
//! other messages (per-wheel motor speeds, a vendor's status message) are
//! not read, so the drive goes in as a log directory, with the pose
//! reference the bag has.

use super::role::Role;
use super::topics::list;
use crate::msg::short_type;
use crate::Bag;

/// The refusal's reason for `bag` (`what` it is: `bag`, `graph`).
pub(super) fn no_wheel_source(bag: &Bag, what: &str) -> String {
    let has = match (bag.topics.is_empty(), what) {
        // Every node writes /parameter_events and /rosout; the live node
        // leaves them (and its own outputs) out of the graph it is given.
        (true, "graph") => "no other node writes a topic yet".to_string(),
        (true, _) => format!("the {what} has no topic"),
        (false, _) => format!(
            "the {what} has: {}",
            list(bag, &(0..bag.topics.len()).collect::<Vec<_>>())
        ),
    };
    let mut reason = format!(
        "no usable wheel source: no sensor_msgs/JointState, nav_msgs/Odometry or geometry_msgs/TwistStamped topic ({has})"
    );
    if what == "bag" {
        let pose = bag.topics.iter().find(|t| {
            let ty = short_type(&t.ty);
            Role::Pose.types()[..2]
                .iter()
                .any(|tier| tier.contains(&ty.as_str()))
        });
        reason.push_str(
            "; wheel speeds in other messages are not read: write the drive as a log directory, \
             wheels.csv with t,v_left,v_right (tread speeds, m/s; docs/log-format.md)",
        );
        if let Some(p) = pose {
            reason.push_str(&format!(
                ", the pose reference {} as pose.csv (t,east,north,yaw)",
                p.name
            ));
        }
        reason.push_str(", and give the commands that directory");
    }
    reason
}
