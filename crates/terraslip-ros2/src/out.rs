//! Estimates as ROS 2 messages in an MCAP file that Foxglove opens with no
//! plugin: every channel carries its `ros2msg` schema.
//!
//! Topics written by [`EstimateMcap`]: `/terraslip/odom` (nav_msgs/Odometry,
//! frame [`Frames::odom`] → [`Frames::base`], `odom` → `base_link` by
//! default, REP-105), `/tf` (tf2_msgs/TFMessage), `/terraslip/icr`
//! ([`ICR_TYPE`]), `/terraslip/terrain` (std_msgs/String),
//! `/terraslip/innovation` ([`INNOVATION_TYPE`]); input topics may be copied
//! through with [`EstimateMcap::pass_through`].

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::msg::CdrWriter;
use crate::{Bag, Ros2Error};

/// Our ICR message: the ICRs (m, body frame) and speed factors with 1σ.
pub const ICR_TYPE: &str = "terraslip_msgs/msg/Icr";
pub const ICR_DEF: &str = "std_msgs/Header header\nfloat64 y_l\nfloat64 y_r\nfloat64 x_c\nfloat64 alpha_l\nfloat64 alpha_r\nfloat64 std_y_l\nfloat64 std_y_r\nfloat64 std_x_c\nfloat64 std_alpha_l\nfloat64 std_alpha_r\n";
/// Innovation statistics of the filter at a wheel sample.
pub const INNOVATION_TYPE: &str = "terraslip_msgs/msg/Innovation";
pub const INNOVATION_DEF: &str =
    "std_msgs/Header header\nfloat64 nis\nbool fused\nbool gated\nfloat64 q_scale\nbool change\n";

/// The frames of the odometry (REP-105): the fixed frame the pose is in
/// and the robot's body frame (the twist's frame).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frames {
    /// Header frame of the odometry and parent of the transform.
    pub odom: String,
    /// Child frame of the odometry and of the transform.
    pub base: String,
}

impl Default for Frames {
    fn default() -> Self {
        Self {
            odom: "odom".into(),
            base: "base_link".into(),
        }
    }
}

/// Index in a row-major 6×6 ROS covariance `(x, y, z, roll, pitch, yaw)`
/// of the planar component `k` (0: x, 1: y, 2: yaw).
const PLANAR: [usize; 3] = [0, 1, 5];

/// A 6×6 ROS covariance (row-major) holding the planar 3×3 block `c`; z,
/// roll and pitch, which the robot does not observe, are left 0 (fusing
/// filters are told not to use them, `two_d_mode`).
pub fn planar_covariance(c: &[[f64; 3]; 3]) -> [f64; 36] {
    let mut out = [0.0; 36];
    for (r, row) in c.iter().enumerate() {
        for (k, v) in row.iter().enumerate() {
            out[6 * PLANAR[r] + PLANAR[k]] = *v;
        }
    }
    out
}

/// One estimate row to publish; SI units, world ENU, body REP-103.
#[derive(Debug, Clone, Copy, Default)]
pub struct EstimateSample {
    /// ns since the epoch.
    pub stamp_ns: u64,
    pub east: f64,
    pub north: f64,
    pub yaw: f64,
    /// Covariance of east, north (m) and yaw (rad), with cross terms.
    pub pose_cov: [[f64; 3]; 3],
    /// Body twist: v_x, v_y (m/s), ω (rad/s).
    pub twist: [f64; 3],
    /// Covariance of the body twist (v_x, v_y, ω).
    pub twist_cov: [[f64; 3]; 3],
    /// y_l, y_r, x_c (m), alpha_l, alpha_r.
    pub icr: [f64; 5],
    pub std_icr: [f64; 5],
    pub nis: f64,
    pub fused: bool,
    pub gated: bool,
    pub q_scale: f64,
    pub change: bool,
}

/// An MCAP file being written; it appears under its name on [`Self::finish`].
pub struct EstimateMcap {
    writer: mcap::Writer<BufWriter<File>>,
    tmp: PathBuf,
    target: PathBuf,
    channels: BTreeMap<String, u16>,
    seq: u32,
    last_terrain: Option<String>,
    frames: Frames,
}

fn err(path: &Path, e: impl std::fmt::Display) -> Ros2Error {
    Ros2Error::Bag {
        bag: path.to_path_buf(),
        reason: e.to_string(),
    }
}

impl EstimateMcap {
    pub fn create(path: &Path) -> Result<Self, Ros2Error> {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out.mcap".into());
        let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
        let f = File::create(&tmp).map_err(|e| err(&tmp, e))?;
        let writer = mcap::WriteOptions::new()
            .profile("ros2")
            .compression(Some(mcap::Compression::Zstd))
            .create(BufWriter::new(f))
            .map_err(|e| err(path, e))?;
        Ok(Self {
            writer,
            tmp,
            target: path.to_path_buf(),
            channels: BTreeMap::new(),
            seq: 0,
            last_terrain: None,
            frames: Frames::default(),
        })
    }

    /// Writes the odometry and transform in `frames`.
    pub fn with_frames(mut self, frames: Frames) -> Self {
        self.frames = frames;
        self
    }

    /// The channel of `topic`, registered with its type and definition on first use.
    pub fn channel(&mut self, topic: &str, ty: &str, definition: &str) -> Result<u16, Ros2Error> {
        if let Some(&c) = self.channels.get(topic) {
            return Ok(c);
        }
        let schema = self
            .writer
            .add_schema(ty, "ros2msg", definition.as_bytes())
            .map_err(|e| err(&self.target, e))?;
        let c = self
            .writer
            .add_channel(schema, topic, "cdr", &BTreeMap::new())
            .map_err(|e| err(&self.target, e))?;
        self.channels.insert(topic.to_string(), c);
        Ok(c)
    }

    /// Writes one CDR message.
    pub fn write(&mut self, channel: u16, ns: u64, data: &[u8]) -> Result<(), Ros2Error> {
        self.seq = self.seq.wrapping_add(1);
        self.writer
            .write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: channel,
                    sequence: self.seq,
                    log_time: ns,
                    publish_time: ns,
                },
                data,
            )
            .map_err(|e| err(&self.target, e))
    }

    /// Publishes one estimate row on the terraslip topics.
    pub fn estimate(&mut self, s: &EstimateSample, terrain: Option<&str>) -> Result<(), Ros2Error> {
        let frames = self.frames.clone();
        for m in estimate_messages(s, &frames, terrain, &mut self.last_terrain) {
            let c = self.channel(m.topic, m.ty, &m.definition())?;
            self.write(c, s.stamp_ns, &m.data)?;
        }
        Ok(())
    }

    /// Copies `topics` of `bag` through unchanged (receive times kept).
    pub fn pass_through(&mut self, bag: &mut Bag, topics: &[usize]) -> Result<u64, Ros2Error> {
        let mut chans = Vec::new();
        for &t in topics {
            let topic = &bag.topics[t];
            let def = if topic.definition.trim().is_empty() {
                crate::defs::definition_of(&topic.ty).unwrap_or_default()
            } else {
                topic.definition.clone()
            };
            chans.push((
                t,
                self.channel(&topic.name.clone(), &topic.ty.clone(), &def)?,
            ));
        }
        let mut n = 0;
        bag.for_each(&|t| topics.contains(&t), &mut |_, m| {
            if let Some(&(_, c)) = chans.iter().find(|(t, _)| *t == m.topic) {
                self.write(c, m.recv_ns, m.data)?;
                n += 1;
            }
            Ok(())
        })?;
        Ok(n)
    }

    /// Finishes the file and moves it into place.
    pub fn finish(mut self) -> Result<(), Ros2Error> {
        self.writer.finish().map_err(|e| err(&self.target, e))?;
        std::fs::rename(&self.tmp, &self.target).map_err(|e| err(&self.target, e))?;
        Ok(())
    }
}

impl Drop for EstimateMcap {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.tmp);
    }
}

/// One encoded output message: topic, type and CDR (with its
/// encapsulation header).
#[derive(Debug, Clone, PartialEq)]
pub struct OutMessage {
    pub topic: &'static str,
    pub ty: &'static str,
    pub data: Vec<u8>,
}

impl OutMessage {
    /// The type's `ros2msg` definition, as a schema stores it.
    pub fn definition(&self) -> String {
        match self.ty {
            ICR_TYPE => format!("{ICR_DEF}{}", header_sections()),
            INNOVATION_TYPE => format!("{INNOVATION_DEF}{}", header_sections()),
            ty => crate::defs::definition_of(ty).unwrap_or_default(),
        }
    }
}

/// The messages of one estimate row: `/terraslip/odom`, `/tf` (both in
/// `frames`), `/terraslip/icr`, `/terraslip/innovation`, and
/// `/terraslip/terrain` when the terrain differs from `last_terrain` (then
/// updated).
pub fn estimate_messages(
    s: &EstimateSample,
    frames: &Frames,
    terrain: Option<&str>,
    last_terrain: &mut Option<String>,
) -> Vec<OutMessage> {
    let mut out = Vec::with_capacity(5);
    // Quaternion of a rotation by yaw about z: (0, 0, sin yaw/2, cos yaw/2).
    let (sz, cz) = (s.yaw / 2.0).sin_cos();
    let mut w = CdrWriter::new();
    w.header(s.stamp_ns, &frames.odom).string(&frames.base);
    planar_pose(&mut w, s.east, s.north, sz, cz);
    for c in planar_covariance(&s.pose_cov) {
        w.f64(c);
    }
    w.f64(s.twist[0])
        .f64(s.twist[1])
        .f64(0.0)
        .f64(0.0)
        .f64(0.0)
        .f64(s.twist[2]);
    for c in planar_covariance(&s.twist_cov) {
        w.f64(c);
    }
    out.push(OutMessage {
        topic: "/terraslip/odom",
        ty: "nav_msgs/msg/Odometry",
        data: w.finish(),
    });

    let mut w = CdrWriter::new();
    w.u32(1)
        .header(s.stamp_ns, &frames.odom)
        .string(&frames.base);
    planar_pose(&mut w, s.east, s.north, sz, cz);
    out.push(OutMessage {
        topic: "/tf",
        ty: "tf2_msgs/msg/TFMessage",
        data: w.finish(),
    });

    let mut w = CdrWriter::new();
    w.header(s.stamp_ns, &frames.base);
    for v in s.icr.iter().chain(&s.std_icr) {
        w.f64(*v);
    }
    out.push(OutMessage {
        topic: "/terraslip/icr",
        ty: ICR_TYPE,
        data: w.finish(),
    });

    let mut w = CdrWriter::new();
    w.header(s.stamp_ns, &frames.base);
    w.f64(s.nis)
        .u8(s.fused as u8)
        .u8(s.gated as u8)
        .f64(s.q_scale)
        .u8(s.change as u8);
    out.push(OutMessage {
        topic: "/terraslip/innovation",
        ty: INNOVATION_TYPE,
        data: w.finish(),
    });

    // The terrain label when it changes (and first), latched for Foxglove's state view.
    let t = terrain.unwrap_or("");
    if last_terrain.as_deref() != Some(t) {
        let mut w = CdrWriter::new();
        w.string(t);
        out.push(OutMessage {
            topic: "/terraslip/terrain",
            ty: "std_msgs/msg/String",
            data: w.finish(),
        });
        *last_terrain = Some(t.to_string());
    }
    out
}

/// Level of a `diagnostic_msgs/DiagnosticStatus`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DiagnosticLevel {
    Ok = 0,
    Warn = 1,
    Error = 2,
    Stale = 3,
}

/// A `/diagnostics` message (`diagnostic_msgs/DiagnosticArray`) with one
/// status: `name`, `level`, `message`, and `values` as key/value strings.
pub fn diagnostics_message(
    stamp_ns: u64,
    name: &str,
    level: DiagnosticLevel,
    message: &str,
    values: &[(String, String)],
) -> OutMessage {
    let mut w = CdrWriter::new();
    w.header(stamp_ns, "");
    w.u32(1);
    w.u8(level as u8).string(name).string(message).string("");
    w.u32(values.len() as u32);
    for (k, v) in values {
        w.string(k).string(v);
    }
    OutMessage {
        topic: "/diagnostics",
        ty: "diagnostic_msgs/msg/DiagnosticArray",
        data: w.finish(),
    }
}

/// A `geometry_msgs/Pose` (or `Transform`) in the plane: x, y, z = 0, and
/// the quaternion (0, 0, sz, cz).
fn planar_pose(w: &mut CdrWriter, x: f64, y: f64, sz: f64, cz: f64) {
    for v in [x, y, 0.0, 0.0, 0.0, sz, cz] {
        w.f64(v);
    }
}

fn header_sections() -> String {
    let d = crate::defs::definition_of("std_msgs/Header").unwrap_or_default();
    format!("================================================================================\nMSG: std_msgs/Header\n{d}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_estimates_read_back_with_their_schemas() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("e.mcap");
        let mut m = EstimateMcap::create(&p).unwrap();
        for k in 0..10u64 {
            let s = EstimateSample {
                stamp_ns: 1_000_000_000 + k * 100_000_000,
                east: k as f64,
                yaw: 0.5,
                icr: [0.5, -0.5, 0.1, 1.0, 1.0],
                ..Default::default()
            };
            m.estimate(&s, Some(if k < 5 { "grass" } else { "asphalt" }))
                .unwrap();
        }
        m.finish().unwrap();
        let mut bag = Bag::open(&p).unwrap();
        let mut seen: BTreeMap<String, u64> = BTreeMap::new();
        let mut easts = Vec::new();
        let odom = bag.topic("/terraslip/odom").unwrap();
        let (reg, root) =
            crate::msg::Registry::parse(&bag.topics[odom].ty, &bag.topics[odom].definition, None)
                .unwrap();
        let path = reg.resolve(root, "pose.pose.position.x").unwrap();
        bag.for_each(&|_| true, &mut |b, msg| {
            *seen.entry(b.topics[msg.topic].name.clone()).or_default() += 1;
            if msg.topic == odom {
                easts.push(reg.decode(root, msg.data).unwrap().f64_at(&path).unwrap());
            }
            Ok(())
        })
        .unwrap();
        assert_eq!(seen["/terraslip/odom"], 10);
        assert_eq!(seen["/tf"], 10);
        assert_eq!(seen["/terraslip/icr"], 10);
        assert_eq!(seen["/terraslip/innovation"], 10);
        assert_eq!(seen["/terraslip/terrain"], 2);
        assert_eq!(easts, (0..10).map(|k| k as f64).collect::<Vec<_>>());
        let icr = bag.topic("/terraslip/icr").unwrap();
        assert!(crate::msg::Registry::parse(ICR_TYPE, &bag.topics[icr].definition, None).is_ok());
    }

    #[test]
    fn odometry_carries_the_planar_covariances_and_its_frames() {
        let s = EstimateSample {
            stamp_ns: 1_700_000_000_000_000_000,
            twist: [1.0, -0.02, 0.3],
            pose_cov: [
                [0.04, 0.01, 0.002],
                [0.01, 0.09, -0.003],
                [0.002, -0.003, 0.01],
            ],
            twist_cov: [[1e-3, 0.0, 2e-4], [0.0, 5e-4, -1e-4], [2e-4, -1e-4, 4e-4]],
            ..Default::default()
        };
        let frames = Frames {
            odom: "husky/odom".into(),
            base: "husky/base_link".into(),
        };
        let msgs = estimate_messages(&s, &frames, None, &mut None);
        let odom = msgs.iter().find(|m| m.topic == "/terraslip/odom").unwrap();
        let (reg, root) = crate::msg::Registry::parse(odom.ty, &odom.definition(), None).unwrap();
        let v = reg.decode(root, &odom.data).unwrap();
        let flat = format!("{v:?}");
        for f in ["husky/odom", "husky/base_link"] {
            assert!(flat.contains(f), "{f} missing: {flat}");
        }
        let cov = |path: &str| -> Vec<f64> {
            let p = reg.resolve(root, path).unwrap();
            match v.at(&p) {
                Some(crate::msg::Value::Nums(xs)) => xs.clone(),
                other => panic!("{path}: {other:?}"),
            }
        };
        let (pose, twist) = (cov("pose.covariance"), cov("twist.covariance"));
        assert_eq!((pose.len(), twist.len()), (36, 36));
        // Row-major (x, y, z, roll, pitch, yaw).
        assert_eq!(
            [pose[0], pose[1], pose[5], pose[7], pose[11], pose[35]],
            [0.04, 0.01, 0.002, 0.09, -0.003, 0.01]
        );
        assert_eq!([pose[6], pose[30], pose[31]], [0.01, 0.002, -0.003]);
        assert_eq!(
            [twist[0], twist[5], twist[7], twist[11], twist[35]],
            [1e-3, 2e-4, 5e-4, -1e-4, 4e-4]
        );
        assert_eq!(twist[14], 0.0, "z is not observed");
        let tf = msgs.iter().find(|m| m.topic == "/tf").unwrap();
        let (reg, root) = crate::msg::Registry::parse(tf.ty, &tf.definition(), None).unwrap();
        let flat = format!("{:?}", reg.decode(root, &tf.data).unwrap());
        assert!(
            flat.contains("husky/odom") && flat.contains("husky/base_link"),
            "{flat}"
        );
    }

    #[test]
    fn diagnostics_decode_with_the_ros_definition() {
        let values = vec![
            ("y_l_m".to_string(), "0.3".to_string()),
            (
                "warning_0".to_string(),
                "clock offset at its limit".to_string(),
            ),
        ];
        let m = diagnostics_message(
            1_700_000_000_250_000_000,
            "terraslip: slip estimator",
            DiagnosticLevel::Warn,
            "clock offset at its limit",
            &values,
        );
        let (reg, root) =
            crate::msg::Registry::parse(m.ty, "", Some(crate::defs::BUILTIN)).unwrap();
        let v = reg.decode(root, &m.data).unwrap();
        let sec = reg.resolve(root, "header.stamp.sec").unwrap();
        assert_eq!(v.f64_at(&sec), Some(1_700_000_000.0));
        let status = reg.resolve(root, "status").unwrap();
        let Some(crate::msg::Value::List(items)) = v.at(&status) else {
            panic!("no status list: {v:?}")
        };
        assert_eq!(items.len(), 1);
        let flat = format!("{:?}", items[0]);
        for s in ["terraslip: slip estimator", "y_l_m", "0.3", "warning_0"] {
            assert!(flat.contains(s), "{s} missing from {flat}");
        }
        let crate::msg::Value::Struct(fields) = &items[0] else {
            panic!("{flat}")
        };
        assert_eq!(fields[0].as_f64(), Some(1.0), "level WARN: {flat}");
    }
}
