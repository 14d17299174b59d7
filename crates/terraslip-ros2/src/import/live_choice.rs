//! A live graph's topics chosen as `import` chooses a recording's, from the
//! data: every topic a stream could be read from is held from the start
//! (the warm-up window), and `import` itself decides from the held messages
//! which topic feeds which stream, the tread speeds' scale (from the URDF
//! on `/robot_description` when there is one), an IMU's mounting from
//! gravity and whether a heading agrees with the GNSS course. What it
//! settled comes back as a topics file for [`super::LiveImport`], and the
//! held messages are then read through it, so that no row is lost.

use std::collections::HashMap;
use std::path::PathBuf;

use terraslip_io::DriveLog;

use super::config::TopicsConfig;
use super::decoder::Decoder;
use super::report::ImportReport;
use super::role::Role;
use super::{import_bag, receive_only, stamp_ns};
use crate::msg::short_type;
use crate::{Bag, HeldMessage, Ros2Error, Topic};

/// Roles whose topics are held: every stream of the drive log but the
/// camera's.
const HELD_ROLES: [Role; 5] = [Role::Wheels, Role::Pose, Role::Heading, Role::Imu, Role::Tf];

/// What the warm-up window settled.
#[derive(Debug, Clone)]
pub struct Settled {
    /// The topics file that states it, for [`super::LiveImport`].
    pub topics: TopicsConfig,
    /// What `import` reported of the window: the streams, the mountings and
    /// the decisions, one line each.
    pub report: ImportReport,
    /// The log `import` made of the window (its meta: the scale, the pose
    /// reference's lever arm).
    pub log: DriveLog,
}

/// The candidate topics of a live graph, held until the choice is made.
pub struct LiveChoice {
    label: PathBuf,
    /// The graph's topics, as given to [`Self::new`].
    topics: Vec<Topic>,
    /// Indices (into `topics`) of the topics held, in the order given.
    candidates: Vec<usize>,
    /// Header stamp decoders of the candidates that have one.
    stamps: HashMap<usize, Decoder>,
    receive_only: bool,
    /// Held messages, topics indexed into `candidates`.
    held: Vec<HeldMessage>,
    /// First and newest header stamp held, ns since the epoch.
    first: Option<i128>,
    newest: Option<i128>,
}

impl LiveChoice {
    /// The candidates among `topics` (the graph as discovered, named
    /// `label` in errors): every topic of a type some stream reads, the
    /// static transforms and the URDF on `/robot_description`.
    pub fn new(
        label: impl Into<PathBuf>,
        topics: Vec<Topic>,
        cfg: &TopicsConfig,
    ) -> Result<Self, Ros2Error> {
        let label = label.into();
        let accepted = |t: &Topic| {
            let ty = short_type(&t.ty);
            match ty.as_str() {
                "tf2_msgs/TFMessage" => t.name == "/tf_static",
                "std_msgs/String" => t.name == "/robot_description",
                _ => HELD_ROLES
                    .iter()
                    .any(|r| r.types().iter().any(|c| c.contains(&ty.as_str()))),
            }
        };
        let candidates: Vec<usize> = (0..topics.len())
            .filter(|&i| accepted(&topics[i]))
            .collect();
        let bag = Bag::live(label.clone(), topics.clone());
        let wheels = Role::Wheels.types().concat();
        if !topics
            .iter()
            .any(|t| wheels.contains(&short_type(&t.ty).as_str()))
        {
            return Err(Ros2Error::Bag {
                bag: label,
                reason: super::no_wheels::no_wheel_source(&bag, "graph"),
            });
        }
        let mut stamps = HashMap::new();
        for &i in &candidates {
            let d = Decoder::new(&bag, i, &["?header.stamp.sec", "?header.stamp.nanosec"])?;
            let ty = short_type(&topics[i].ty);
            if ty != "tf2_msgs/TFMessage" && ty != "std_msgs/String" {
                stamps.insert(i, d);
            }
        }
        Ok(Self {
            receive_only: receive_only(&bag, cfg)?,
            label,
            topics,
            candidates,
            stamps,
            held: Vec::new(),
            first: None,
            newest: None,
        })
    }

    /// The topics to read during the warm-up (indices into the topics
    /// given to [`Self::new`]).
    pub fn candidates(&self) -> &[usize] {
        &self.candidates
    }

    /// Holds message `data` (CDR) of topic `topic` (an index into the
    /// topics given to [`Self::new`]), received at `recv_ns` (ns since the
    /// epoch). Messages of other topics are not held; one whose header
    /// cannot be read is refused (and not held).
    pub fn hold(&mut self, topic: usize, recv_ns: u64, data: &[u8]) -> Result<(), Ros2Error> {
        let Some(k) = self.candidates.iter().position(|&c| c == topic) else {
            return Ok(());
        };
        if let Some(d) = self.stamps.get(&topic) {
            let bag = || Bag::live(self.label.clone(), self.topics.clone());
            let v = d
                .decode(data)
                .map_err(|e| bag().msg_err(topic, self.held.len() as u64, e))?;
            let s = stamp_ns(d, &v, recv_ns, self.receive_only);
            self.first = Some(self.first.map_or(s, |f| f.min(s)));
            self.newest = Some(self.newest.map_or(s, |n| n.max(s)));
        }
        self.held.push(HeldMessage {
            topic: k,
            recv_ns,
            data: data.to_vec(),
        });
        Ok(())
    }

    /// Stamp time the held messages span, s.
    pub fn span(&self) -> f64 {
        match (self.first, self.newest) {
            (Some(a), Some(b)) => (b - a) as f64 * 1e-9,
            _ => 0.0,
        }
    }

    /// Messages held.
    pub fn held(&self) -> usize {
        self.held.len()
    }

    /// Decides from the held messages with `import` (`cfg`: the topics
    /// file, empty when none was given).
    pub fn decide(&self, cfg: &TopicsConfig) -> Result<Settled, Ros2Error> {
        let topics: Vec<Topic> = self
            .candidates
            .iter()
            .map(|&i| self.topics[i].clone())
            .collect();
        let bag = Bag::held(self.label.clone(), topics, self.held.clone());
        let (log, report, topics) = import_bag(bag, cfg, None)?;
        Ok(Settled {
            topics,
            report,
            log,
        })
    }

    /// The held messages in arrival order, taken (none is held after):
    /// (topic index into the topics given to [`Self::new`], receive time in
    /// ns, CDR bytes).
    pub fn take_held(&mut self) -> Vec<(usize, u64, Vec<u8>)> {
        let c = &self.candidates;
        std::mem::take(&mut self.held)
            .into_iter()
            .map(|m| (c[m.topic], m.recv_ns, m.data))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn topic(name: &str, ty: &str) -> Topic {
        Topic {
            name: name.into(),
            ty: ty.into(),
            definition: String::new(),
            count: 0,
        }
    }

    #[test]
    fn a_graph_without_a_wheel_source_is_named() {
        let t = vec![topic("/imu", "sensor_msgs/msg/Imu")];
        let e = LiveChoice::new("graph", t, &TopicsConfig::default())
            .err()
            .expect("no wheel source")
            .to_string();
        assert!(
            e.contains("no usable wheel source") && e.contains("/imu"),
            "{e}"
        );
    }

    #[test]
    fn an_empty_graph_is_said_to_be_empty() {
        let e = LiveChoice::new("graph", Vec::new(), &TopicsConfig::default())
            .err()
            .expect("no wheel source")
            .to_string();
        assert!(
            e.contains("no other node writes a topic yet") && !e.contains("has: )"),
            "{e}"
        );
    }

    #[test]
    fn candidates_leave_cameras_and_transforms_other_than_the_static_ones_out() {
        let t = vec![
            topic("/odom", "nav_msgs/msg/Odometry"),
            topic("/camera/image", "sensor_msgs/msg/Image"),
            topic("/tf", "tf2_msgs/msg/TFMessage"),
            topic("/tf_static", "tf2_msgs/msg/TFMessage"),
            topic("/robot_description", "std_msgs/msg/String"),
            topic("/chatter", "std_msgs/msg/String"),
        ];
        let c = LiveChoice::new("graph", t, &TopicsConfig::default()).unwrap();
        assert_eq!(c.candidates(), &[0, 3, 4]);
    }

    #[test]
    fn a_held_message_of_no_topic_is_an_error() {
        let m = HeldMessage {
            topic: 3,
            recv_ns: 0,
            data: Vec::new(),
        };
        let mut bag = Bag::held("graph", Vec::new(), vec![m]);
        let r = bag.for_each(&|_| true, &mut |_, _| Ok(()));
        assert!(r.is_err());
    }
}
