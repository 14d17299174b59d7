//! What kind of source the pose reference is (meta.toml's
//! `pose_reference`): a `sensor_msgs/NavSatFix` is a GNSS receiver; any
//! other pose message may be a localiser, motion capture or a GNSS fed
//! through another node, so its kind is left to the topics file's `[meta]`
//! and the `decided:` line says how to state it.

use terraslip_io::{Meta, PoseReference};

use super::report::ImportReport;
use crate::msg::short_type;
use crate::Bag;

/// The topics-file line that states the kind.
const STATE_IT: &str =
    "for a lidar or visual localiser, motion capture or tags: `[meta] pose_reference = \"localiser\"` in a --topics file";

/// Sets `meta.pose_reference` for the pose topic `pose` when its message
/// type tells (a GNSS fix), and says what the run takes it as.
pub(super) fn apply(bag: &Bag, pose: Option<usize>, meta: &mut Meta, report: &mut ImportReport) {
    let Some(pose) = pose else { return };
    let topic = &bag.topics[pose];
    let line = match meta.pose_reference {
        Some(r) => format!(
            "pose reference {} is a {}, as the topics file's [meta] states: {}",
            topic.name,
            r.noun(),
            r.error_taken()
        ),
        None if short_type(&topic.ty) == "sensor_msgs/NavSatFix" => {
            let gnss = PoseReference::Gnss;
            meta.pose_reference = Some(gnss);
            format!(
                "pose reference {} is a {} (a NavSatFix): {}; written to meta.toml as pose_reference = \"{}\"",
                topic.name,
                gnss.noun(),
                gnss.error_taken(),
                gnss.name()
            )
        }
        None => format!(
            "pose reference {} ({}) of a kind not stated: its error is taken to wander slowly as a GNSS receiver's; {STATE_IT}",
            topic.name,
            short_type(&topic.ty)
        ),
    };
    report.decisions.push(line);
}
