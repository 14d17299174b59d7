//! A ROS 2 node on RustDDS: joins the graph as the environment says,
//! lists the topics discovered, and reads and writes messages as raw CDR
//! (the bytes a rosbag2 recording stores), so that the messages are
//! decoded and encoded by terraslip's own definitions.
//!
//! Readers are best-effort (ROS `SensorDataQoS`: a best-effort writer, as
//! most IMU and GNSS drivers have, does not match a reliable reader) and
//! writers reliable; static transforms are read reliable and transient
//! local, as `/tf_static` is published.

use std::collections::BTreeMap;
use std::net::{IpAddr, Ipv4Addr};
use std::time::Duration;

use ros2_client::dds::{Context, Node};
use ros2_client::{NodeName, NodeOptions};
use rustdds::no_key::{
    DataWriter, Decode, DefaultDecoder, DeserializerAdapter, SerializerAdapter, SimpleDataReader,
};
use rustdds::policy::{Durability, History, Reliability};
use rustdds::{
    DomainParticipant, DomainParticipantBuilder, Publisher, QosPolicies, QosPolicyBuilder,
    RepresentationIdentifier, Subscriber, TopicKind,
};

use crate::env::{DiscoveryRange, RosEnv};
use crate::params::{Changes, Parameters};
use crate::NodeError;

/// A message as CDR with its 4-byte encapsulation header (as rosbag2
/// stores it).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawCdr(pub Vec<u8>);

/// Reads and writes [`RawCdr`] for RustDDS.
pub struct RawAdapter;

/// The error of a payload that is not CDR.
#[derive(Debug, thiserror::Error)]
#[error("payload in representation {0:?}, not CDR")]
pub struct NotCdr(RepresentationIdentifier);

impl DeserializerAdapter<RawCdr> for RawAdapter {
    type Error = NotCdr;
    type Decoded = RawCdr;
    fn supported_encodings() -> &'static [RepresentationIdentifier] {
        &[
            RepresentationIdentifier::CDR_LE,
            RepresentationIdentifier::CDR_BE,
        ]
    }
    fn transform_decoded(decoded: RawCdr) -> RawCdr {
        decoded
    }
}

/// The decoder of [`RawAdapter`]: puts the encapsulation header back.
#[derive(Clone)]
pub struct RawDecoder;

impl<'de> Decode<'de, RawCdr> for RawDecoder {
    type Error = NotCdr;
    fn decode_bytes(
        self,
        input: &'de [u8],
        encoding: RepresentationIdentifier,
    ) -> Result<RawCdr, NotCdr> {
        let mut v = Vec::with_capacity(input.len() + 4);
        v.extend_from_slice(&encoding.to_bytes());
        v.extend_from_slice(&[0, 0]);
        v.extend_from_slice(input);
        Ok(RawCdr(v))
    }
}

impl DefaultDecoder<RawCdr> for RawAdapter {
    type Decoder = RawDecoder;
    const DECODER: RawDecoder = RawDecoder;
}

impl SerializerAdapter<RawCdr> for RawAdapter {
    type Error = NotCdr;
    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }
    fn to_bytes(value: &RawCdr) -> Result<rustdds::bytes::Bytes, NotCdr> {
        // Our writer makes little-endian CDR with its header.
        let body = value.0.get(4..).unwrap_or_default();
        Ok(rustdds::bytes::Bytes::copy_from_slice(body))
    }
}

/// How a topic is read or written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TopicQos {
    /// `SensorDataQoS`: best effort, volatile, keep last 50 (readers).
    Sensor,
    /// Reliable, volatile, keep last 100 (writers).
    Reliable,
    /// Reliable, transient local, keep last 100 (`/tf_static`).
    Latched,
}

impl TopicQos {
    fn policies(self) -> QosPolicies {
        let b = QosPolicyBuilder::new();
        let reliable = Reliability::Reliable {
            max_blocking_time: rustdds::Duration::from_millis(100),
        };
        match self {
            TopicQos::Sensor => b
                .reliability(Reliability::BestEffort)
                .durability(Durability::Volatile)
                .history(History::KeepLast { depth: 50 }),
            TopicQos::Reliable => b
                .reliability(reliable)
                .durability(Durability::Volatile)
                .history(History::KeepLast { depth: 100 }),
            TopicQos::Latched => b
                .reliability(reliable)
                .durability(Durability::TransientLocal)
                .history(History::KeepLast { depth: 100 }),
        }
        .build()
    }
}

/// A topic of the graph: ROS name and type (`pkg/msg/Type`).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct GraphTopic {
    pub name: String,
    pub ty: String,
}

/// The DDS name of ROS topic `name` (`/a/b` -> `rt/a/b`).
pub fn dds_topic(name: &str) -> String {
    format!("rt/{}", name.trim_start_matches('/'))
}

/// The DDS type of ROS type `pkg/msg/Type` (`pkg::msg::dds_::Type_`).
pub fn dds_type(ty: &str) -> String {
    let parts: Vec<&str> = ty.split('/').collect();
    match parts.as_slice() {
        [pkg, "msg", name] | [pkg, name] => format!("{pkg}::msg::dds_::{name}_"),
        _ => ty.to_string(),
    }
}

/// The ROS topic of a DDS topic and type, when they are ROS ones.
pub fn ros_topic(dds_name: &str, dds_ty: &str) -> Option<GraphTopic> {
    let name = dds_name.strip_prefix("rt/")?;
    let (pkg, rest) = dds_ty.split_once("::msg::dds_::")?;
    let ty = rest.strip_suffix('_')?;
    Some(GraphTopic {
        name: format!("/{name}"),
        ty: format!("{pkg}/msg/{ty}"),
    })
}

/// This process on the ROS 2 graph.
pub struct Graph {
    participant: DomainParticipant,
    // Kept for the graph: ROS tools list the node (and its parameter
    // services stop when it is dropped).
    _context: Context,
    _node: Node,
    subscriber: Subscriber,
    publisher: Publisher,
    pub env: RosEnv,
}

/// A raw reader of one topic.
pub struct Reader {
    pub topic: GraphTopic,
    reader: SimpleDataReader<RawCdr, RawAdapter>,
}

impl Reader {
    /// The next message waiting, with its source timestamp (ns since the
    /// epoch, 0 when the writer gave none).
    pub fn take(&self) -> Result<Option<(RawCdr, u64)>, NodeError> {
        self.reader.drain_read_notifications();
        match self.reader.try_take_one() {
            Ok(Some(c)) => {
                let ns = c.write_options.source_timestamp().map_or(0, |t| {
                    // RTPS time: seconds and 2^-32 fractions since 1970.
                    let ticks = t.to_ticks();
                    (ticks >> 32) * 1_000_000_000 + (((ticks & 0xffff_ffff) * 1_000_000_000) >> 32)
                });
                Ok(Some((c.sample, ns)))
            }
            Ok(None) => Ok(None),
            Err(e) => Err(NodeError::Dds(format!("{}: read: {e}", self.topic.name))),
        }
    }
}

/// Waits for messages on readers (or a timeout), without spinning.
pub struct Wait {
    poll: rustdds::mio1::Poll,
    events: rustdds::mio1::Events,
}

impl Wait {
    pub fn new() -> std::io::Result<Self> {
        Ok(Self {
            poll: rustdds::mio1::Poll::new()?,
            events: rustdds::mio1::Events::with_capacity(64),
        })
    }

    /// Wakes [`Wait::wait`] when `r` has messages.
    pub fn register(&self, r: &mut Reader, token: usize) -> std::io::Result<()> {
        self.poll.registry().register(
            &mut r.reader,
            rustdds::mio1::Token(token),
            rustdds::mio1::Interest::READABLE,
        )
    }

    /// Returns when a registered reader has messages, or after `timeout`.
    pub fn wait(&mut self, timeout: Duration) -> std::io::Result<()> {
        match self.poll.poll(&mut self.events, Some(timeout)) {
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => Ok(()),
            r => r,
        }
    }
}

/// A raw writer of one topic.
pub struct Writer {
    pub topic: GraphTopic,
    writer: DataWriter<RawCdr, RawAdapter>,
}

impl Writer {
    /// Writes one message (CDR with its encapsulation header).
    pub fn write(&self, data: Vec<u8>) -> Result<(), NodeError> {
        self.writer
            .write(RawCdr(data), None)
            .map_err(|e| NodeError::Dds(format!("{}: write: {e:?}", self.topic.name)))
    }
}

impl Graph {
    /// Joins the graph as node `name` in `namespace` (`/` for none), with
    /// no parameter services.
    pub fn join(name: &str, namespace: &str, env: RosEnv) -> Result<Self, NodeError> {
        Self::join_with(name, namespace, env, None).map(|(g, _)| g)
    }

    /// Joins the graph as [`Graph::join`] does, serving `params` on the
    /// parameter services when given; the changes they take.
    pub fn join_serving(
        name: &str,
        namespace: &str,
        env: RosEnv,
        params: Parameters,
    ) -> Result<(Self, Changes), NodeError> {
        let (graph, changes) = Self::join_with(name, namespace, env, Some(params))?;
        Ok((graph, changes.expect("parameters were given")))
    }

    fn join_with(
        name: &str,
        namespace: &str,
        env: RosEnv,
        params: Option<Parameters>,
    ) -> Result<(Self, Option<Changes>), NodeError> {
        let dds = |what: &str, e: &dyn std::fmt::Display| NodeError::Dds(format!("{what}: {e}"));
        let mut b = DomainParticipantBuilder::new(env.domain_id);
        if env.range == DiscoveryRange::Localhost {
            b = b.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        }
        let participant = b.build().map_err(|e| dds("domain participant", &e))?;
        let context = Context::from_domain_participant(participant.clone())
            .map_err(|e| dds("ROS context", &e))?;
        let node_name = NodeName::new(namespace, name)
            .map_err(|e| dds(&format!("node name {namespace}/{name}"), &e))?;
        let options = NodeOptions::new()
            .enable_rosout(false)
            .start_parameter_services(false);
        let (options, armed, changes) = match params {
            Some(p) => {
                let (o, armed, changes) = crate::params::with_parameters(options, p)?;
                (o, Some(armed), Some(changes))
            }
            None => (options, None, None),
        };
        let mut node = context
            .new_node(node_name, options)
            .map_err(|e| dds("node", &e))?;
        if let Some(armed) = armed {
            armed.store(true, std::sync::atomic::Ordering::SeqCst);
            crate::params::serve(&mut node)?;
        }
        let subscriber = participant
            .create_subscriber(&TopicQos::Sensor.policies())
            .map_err(|e| dds("subscriber", &e))?;
        let publisher = participant
            .create_publisher(&TopicQos::Reliable.policies())
            .map_err(|e| dds("publisher", &e))?;
        let graph = Self {
            participant,
            _context: context,
            _node: node,
            subscriber,
            publisher,
            env,
        };
        Ok((graph, changes))
    }

    /// The ROS topics discovered so far with their writers' count (our own
    /// writers included), by name.
    pub fn topics(&self) -> BTreeMap<GraphTopic, usize> {
        let mut out: BTreeMap<GraphTopic, usize> = BTreeMap::new();
        for t in self.participant.discovered_topics() {
            if let Some(g) = ros_topic(&t.topic_data.name, &t.topic_data.type_name) {
                out.entry(g).or_default();
            }
        }
        for w in self.participant.discovered_writers() {
            let p = &w.publication_topic_data;
            if let Some(g) = ros_topic(&p.topic_name, &p.type_name) {
                *out.entry(g).or_default() += 1;
            }
        }
        out
    }

    /// Writers discovered on topic `name` whose reliability a reader of
    /// `qos` cannot match (a best-effort writer and a reliable reader), and
    /// of another type than `ty`.
    pub fn unmatchable_writers(&self, name: &str, ty: &str, qos: TopicQos) -> Vec<String> {
        let want = dds_topic(name);
        let mut out = Vec::new();
        for w in self.participant.discovered_writers() {
            let p = &w.publication_topic_data;
            if p.topic_name != want {
                continue;
            }
            if p.type_name != dds_type(ty) {
                out.push(format!("a writer of type {} (read as {ty})", p.type_name));
            }
            if qos != TopicQos::Sensor && matches!(p.reliability, Some(Reliability::BestEffort)) {
                out.push("a best-effort writer (read reliably)".into());
            }
        }
        out
    }

    /// A best-effort reader of `topic` (`/tf_static`: reliable, transient local).
    pub fn reader(&self, topic: &GraphTopic, qos: TopicQos) -> Result<Reader, NodeError> {
        let t = self
            .participant
            .create_topic(
                dds_topic(&topic.name),
                dds_type(&topic.ty),
                &qos.policies(),
                TopicKind::NoKey,
            )
            .map_err(|e| NodeError::Dds(format!("{}: topic: {e}", topic.name)))?;
        let reader = self
            .subscriber
            .create_simple_datareader_no_key::<RawCdr, RawAdapter>(&t, Some(qos.policies()))
            .map_err(|e| NodeError::Dds(format!("{}: reader: {e}", topic.name)))?;
        Ok(Reader {
            topic: topic.clone(),
            reader,
        })
    }

    /// A reliable writer of `topic`.
    pub fn writer(&self, topic: &GraphTopic) -> Result<Writer, NodeError> {
        let qos = TopicQos::Reliable.policies();
        let t = self
            .participant
            .create_topic(
                dds_topic(&topic.name),
                dds_type(&topic.ty),
                &qos,
                TopicKind::NoKey,
            )
            .map_err(|e| NodeError::Dds(format!("{}: topic: {e}", topic.name)))?;
        let writer = self
            .publisher
            .create_datawriter_no_key::<RawCdr, RawAdapter>(&t, Some(qos))
            .map_err(|e| NodeError::Dds(format!("{}: writer: {e}", topic.name)))?;
        Ok(Writer {
            topic: topic.clone(),
            writer,
        })
    }

    /// Waits `d` for discovery to fill in.
    pub fn settle(&self, d: Duration) {
        std::thread::sleep(d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros_and_dds_names_map_both_ways() {
        assert_eq!(dds_topic("/terraslip/odom"), "rt/terraslip/odom");
        assert_eq!(
            dds_type("nav_msgs/msg/Odometry"),
            "nav_msgs::msg::dds_::Odometry_"
        );
        assert_eq!(
            dds_type("nav_msgs/Odometry"),
            "nav_msgs::msg::dds_::Odometry_"
        );
        let g = ros_topic("rt/fix", "sensor_msgs::msg::dds_::NavSatFix_").unwrap();
        assert_eq!(
            (g.name.as_str(), g.ty.as_str()),
            ("/fix", "sensor_msgs/msg/NavSatFix")
        );
        assert!(ros_topic("DCPSParticipant", "x").is_none());
    }

    #[test]
    fn raw_cdr_keeps_its_bytes_through_the_adapter() {
        let msg = vec![0, 1, 0, 0, 7, 0, 0, 0, 1, 2, 3];
        let body =
            <RawAdapter as SerializerAdapter<RawCdr>>::to_bytes(&RawCdr(msg.clone())).unwrap();
        let back = RawDecoder
            .decode_bytes(&body, RepresentationIdentifier::CDR_LE)
            .unwrap();
        assert_eq!(back.0, msg);
    }
}
