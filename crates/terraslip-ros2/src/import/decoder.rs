//! The fields each stream reads from its topic's messages.

use std::collections::HashMap;

use super::role::Role;
use crate::msg::{Registry, Selection, Value};
use crate::{Bag, Ros2Error};

/// A decoder for one topic: its registry and the field paths it reads.
pub(super) struct Decoder {
    reg: Registry,
    root: usize,
    paths: HashMap<&'static str, Vec<usize>>,
    sel: Selection,
}

impl Decoder {
    pub(super) fn new(bag: &Bag, t: usize, fields: &[&'static str]) -> Result<Self, Ros2Error> {
        let topic = &bag.topics[t];
        let builtin = crate::defs::BUILTIN;
        let (reg, root) = if topic.definition.trim().is_empty() {
            Registry::parse(&topic.ty, "", Some(builtin))
        } else {
            Registry::parse(&topic.ty, &topic.definition, Some(builtin))
        }
        .map_err(|e| bag.msg_err(t, 0, format!("message definition: {e}")))?;
        let mut paths = HashMap::new();
        for f in fields {
            let optional = f.starts_with('?');
            let name = f.trim_start_matches('?');
            match reg.resolve(root, name) {
                Some(p) => {
                    paths.insert(name_key(f), p);
                }
                None if optional => {}
                None => {
                    return Err(bag.msg_err(t, 0, format!("the definition has no field `{name}`")))
                }
            }
        }
        let mut sel = Selection::default();
        for p in paths.values() {
            sel.add(p);
        }
        Ok(Self {
            reg,
            root,
            paths,
            sel,
        })
    }
    /// Decodes the selected fields of one message.
    pub(super) fn decode(&self, data: &[u8]) -> Result<Value, String> {
        self.reg.decode_selected(self.root, data, &self.sel)
    }
    /// Resolves `path` inside message type `ty` of this topic's definitions
    /// (for the elements of a sequence field).
    pub(super) fn resolve_in(&self, ty: &str, path: &str) -> Option<Vec<usize>> {
        let m = self.reg.msgs.iter().position(|m| m.name == ty)?;
        self.reg.resolve(m, path)
    }
    pub(super) fn f(&self, v: &Value, name: &str) -> Option<f64> {
        v.f64_at(self.paths.get(name)?)
    }
    pub(super) fn get<'a>(&self, v: &'a Value, name: &str) -> Option<&'a Value> {
        v.at(self.paths.get(name)?)
    }
}

fn name_key(f: &'static str) -> &'static str {
    f.trim_start_matches('?')
}

const HEADER: [&str; 2] = ["?header.stamp.sec", "?header.stamp.nanosec"];

pub(super) fn fields_for(ty: &str, role: Role) -> Vec<&'static str> {
    let mut f: Vec<&'static str> = HEADER.to_vec();
    match (ty, role) {
        ("sensor_msgs/JointState", _) => f.extend(["name", "?velocity", "?position"]),
        ("nav_msgs/Odometry", Role::Wheels) | ("geometry_msgs/TwistStamped", _) => {
            let p: &[&str] = if ty == "nav_msgs/Odometry" {
                &["twist.twist.linear.x", "twist.twist.angular.z"]
            } else {
                &["twist.linear.x", "twist.angular.z"]
            };
            f.extend(p)
        }
        ("nav_msgs/Odometry", _) | ("geometry_msgs/PoseWithCovarianceStamped", _) => f.extend([
            "?child_frame_id",
            "pose.pose.position.x",
            "pose.pose.position.y",
            "pose.pose.orientation.x",
            "pose.pose.orientation.y",
            "pose.pose.orientation.z",
            "pose.pose.orientation.w",
            "pose.covariance",
        ]),
        ("geometry_msgs/PoseStamped", _) => f.extend([
            "pose.position.x",
            "pose.position.y",
            "pose.orientation.x",
            "pose.orientation.y",
            "pose.orientation.z",
            "pose.orientation.w",
        ]),
        ("sensor_msgs/NavSatFix", _) => f.extend([
            "?header.frame_id",
            "status.status",
            "latitude",
            "longitude",
            "altitude",
            "position_covariance",
            "position_covariance_type",
        ]),
        ("sensor_msgs/Imu", _) => f.extend([
            "?header.frame_id",
            "orientation.x",
            "orientation.y",
            "orientation.z",
            "orientation.w",
            "orientation_covariance",
            "angular_velocity.x",
            "angular_velocity.y",
            "angular_velocity.z",
            "linear_acceleration.x",
            "linear_acceleration.y",
            "linear_acceleration.z",
        ]),
        ("tf2_msgs/TFMessage", _) => f.push("transforms"),
        ("sensor_msgs/CompressedImage", _) => f.extend(["format", "data"]),
        ("sensor_msgs/Image", _) => f.extend(["height", "width", "encoding", "step", "data"]),
        _ => {}
    }
    f
}
