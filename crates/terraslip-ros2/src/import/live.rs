//! Messages of a live ROS 2 graph to drive-log rows, one message at a time,
//! with the topic choice, decoding, time base and sensor mountings of
//! [`super::import`], so that a recording played into a live node makes the
//! rows `import` makes of it.
//!
//! Differences a live graph forces: time 0 is the first message's header
//! stamp (whole seconds), not its receive time (a replay is received now);
//! an IMU's mounting is applied as soon as it is known (the topics file, or
//! the static transforms received so far), each row as it is made.

use std::collections::HashMap;
use std::path::PathBuf;

use terraslip_io::{ImuSample, PoseMount, PoseObs, WheelSample};

use super::config::TopicsConfig;
use super::frames::{heading_yaw, Quat};
use super::lever;
use super::mount::{self, Sensors};
use super::report::ImportReport;
use super::role::Role;
use super::rows::{Msg, Rows};
use super::topics::Decide;
use super::tread_scale::wheel_scale;
use super::{choose_streams, receive_only, selections, stamp_ns, unphysical, Sel};
use crate::msg::short_type;
use crate::{Bag, Ros2Error, Topic};

/// One row of the drive log made from a live message; `t` in s from
/// [`LiveImport::origin_ns`].
#[derive(Debug, Clone, PartialEq)]
pub enum LiveRow {
    Wheels(WheelSample),
    Pose(PoseObs),
    Imu(ImuSample),
}

impl LiveRow {
    /// Time of the row, s.
    pub fn t(&self) -> f64 {
        match self {
            LiveRow::Wheels(w) => w.t,
            LiveRow::Pose(p) => p.t,
            LiveRow::Imu(s) => s.t,
        }
    }
}

/// The streams of a live graph being turned into rows.
pub struct LiveImport {
    bag: Bag,
    cfg: TopicsConfig,
    sels: Vec<Sel>,
    rows: Rows,
    pose: Option<usize>,
    imu: Option<usize>,
    heading: Option<usize>,
    tf: Option<usize>,
    /// The pose reference's lever arm once known.
    lever_arm: Option<PoseMount>,
    receive_only: bool,
    origin: Option<u64>,
    /// Messages seen per topic (for error messages).
    seen: HashMap<usize, u64>,
    /// Each IMU topic's mounting once known (`None` inside: none needed).
    mounts: HashMap<usize, Option<Quat>>,
    /// What was decided about the mountings, for the user.
    pub report: ImportReport,
}

impl LiveImport {
    /// Chooses the topics of `topics` (the graph as discovered, named
    /// `graph` in errors) for each stream, as `import` chooses a bag's:
    /// named in `cfg`, or by type when the choice is unique.
    pub fn new(
        graph: impl Into<PathBuf>,
        topics: Vec<Topic>,
        cfg: &TopicsConfig,
    ) -> Result<Self, Ros2Error> {
        let bag = Bag::live(graph, topics);
        let mut decide = Decide::default();
        let c = choose_streams(&bag, cfg, "graph", &mut decide)?;
        let sels = selections(&bag, &c)?;
        let (imu, heading, tf) = (c.imu, c.heading, c.tf);
        let receive_only = receive_only(&bag, cfg)?;
        // A live graph's URDF is not read: the topics file's scale, else
        // the track width, else a default.
        let radius = (short_type(&bag.topics[c.wheels].ty) == "sensor_msgs/JointState")
            .then(|| (super::scale::wheel_radius(cfg, None), None));
        let (wheels_cfg, _, scale_line) = wheel_scale(&bag, cfg, c.wheels, None, &radius);
        let rows = Rows {
            log: Default::default(),
            enu: None,
            dropped_fixes: 0,
            wheels: wheels_cfg,
            heading: cfg.heading.clone(),
            images_dir: None,
            frames: HashMap::new(),
            tf: Default::default(),
            heading_rows: Vec::new(),
            unphysical: None,
            joints: HashMap::new(),
            wheels_unusable: None,
        };
        let report = ImportReport {
            bag: bag.path.clone(),
            decisions: decide.decisions.into_iter().chain([scale_line]).collect(),
            ..Default::default()
        };
        Ok(Self {
            bag,
            cfg: cfg.clone(),
            sels,
            rows,
            pose: c.pose,
            imu,
            heading,
            tf,
            lever_arm: None,
            receive_only,
            origin: None,
            seen: HashMap::new(),
            mounts: HashMap::new(),
            report,
        })
    }

    /// The topics read, with the streams each feeds (`wheels`, `pose`,
    /// `heading`, `imu`, `tf`).
    pub fn subscriptions(&self) -> Vec<(&Topic, Vec<&'static str>)> {
        self.sels
            .iter()
            .map(|s| {
                (
                    &self.bag.topics[s.topic],
                    s.roles.iter().map(|r| r.key()).collect(),
                )
            })
            .collect()
    }

    /// Time 0 of the rows, ns since the epoch (once a message came).
    pub fn origin_ns(&self) -> Option<u64> {
        self.origin
    }

    /// The ENU origin (latitude, longitude in degrees, altitude in m): the
    /// first good GNSS fix.
    pub fn enu_origin(&self) -> Option<[f64; 3]> {
        self.rows.enu.map(|(a, b, c)| [a, b, c])
    }

    /// GNSS fixes dropped (status < 0 or no position).
    pub fn dropped_fixes(&self) -> u64 {
        self.rows.dropped_fixes
    }

    /// The rows message `data` (CDR) of topic `topic` (index into the
    /// topics given to [`Self::new`]) makes; `recv_ns` is its arrival time,
    /// ns since the epoch, used only when it has no header stamp. Messages
    /// of topics not read make none.
    pub fn message(
        &mut self,
        topic: usize,
        recv_ns: u64,
        data: &[u8],
    ) -> Result<Vec<LiveRow>, Ros2Error> {
        let Some(k) = self.sels.iter().position(|s| s.topic == topic) else {
            return Ok(Vec::new());
        };
        let index = {
            let n = self.seen.entry(topic).or_default();
            *n += 1;
            *n - 1
        };
        let sel = &self.sels[k];
        let v = sel
            .dec
            .decode(data)
            .map_err(|e| self.bag.msg_err(topic, index, e))?;
        let stamp = stamp_ns(&sel.dec, &v, recv_ns, self.receive_only);
        let org = match sel.roles[..] {
            [Role::Tf] => self.origin.unwrap_or(0),
            _ => *self
                .origin
                .get_or_insert((stamp.max(0) as u64) / 1_000_000_000 * 1_000_000_000),
        };
        let msg = Msg {
            bag: &self.bag,
            topic,
            index,
            t: (stamp - org as i128) as f64 * 1e-9,
            d: &sel.dec,
            v: &v,
        };
        let (w0, p0, i0) = (
            self.rows.log.wheels.len(),
            self.rows.log.pose.len(),
            self.rows.log.imu.len(),
        );
        let h0 = self.rows.heading_rows.len();
        // The import's rule for a message that cannot be physical: not
        // finite, out of range, or not after the last one kept.
        let is_tf = sel.roles == [Role::Tf];
        let mark = unphysical::Mark::of(&self.rows.log, h0);
        let mut why = if is_tf {
            None
        } else {
            unphysical::out_of_order(msg.t, sel.last_t)
        };
        if why.is_none() {
            for &role in &sel.roles {
                self.rows.add(role, &sel.ty, &msg)?;
            }
            why = self
                .rows
                .unphysical
                .take()
                .or_else(|| mark.unphysical(&self.rows.log));
        }
        let t = msg.t;
        if let Some(reason) = why {
            mark.rollback(&mut self.rows.log, &mut self.rows.heading_rows);
            return Err(self.bag.msg_err(
                topic,
                index,
                format!("at t = {t:.6} s (stamp {stamp} ns): {reason}; not physical, skipped"),
            ));
        }
        let made = self.rows.log.wheels.len() > w0
            || self.rows.log.pose.len() > p0
            || self.rows.log.imu.len() > i0;
        if !is_tf && made {
            self.sels[k].last_t = Some(t);
        }
        // What this message made, moved out: the live log keeps no rows.
        let heading: Vec<(usize, Quat)> = self.rows.heading_rows.drain(h0..).collect();
        let mut pose: Vec<PoseObs> = self.rows.log.pose.drain(p0..).collect();
        let mut imu: Vec<ImuSample> = self.rows.log.imu.drain(i0..).collect();
        let wheels: Vec<WheelSample> = self.rows.log.wheels.drain(w0..).collect();
        if !imu.is_empty() {
            if let Some(q) = self.mounting(topic, self.cfg.imu.mount_rpy_deg) {
                mount::rotate_imu(q, &mut imu);
            }
        }
        if !heading.is_empty() && Some(topic) == self.heading {
            let given = self.cfg.heading.mount_rpy_deg.or(self
                .cfg
                .imu
                .mount_rpy_deg
                .filter(|_| self.imu == Some(topic)));
            if let Some(q) = self.mounting(topic, given) {
                let rows: Vec<(usize, Quat)> = heading.iter().map(|&(i, q)| (i - p0, q)).collect();
                let h = &self.cfg.heading;
                mount::remount_heading(&mut pose, &rows, q, |b| heading_yaw(h, b));
            }
        }
        let mut out: Vec<LiveRow> = wheels.into_iter().map(LiveRow::Wheels).collect();
        out.extend(pose.into_iter().map(LiveRow::Pose));
        out.extend(imu.into_iter().map(LiveRow::Imu));
        Ok(out)
    }

    /// Where the pose reference sits on the robot, as `import` decides it
    /// (the topics file's `[pose] lever_arm`, else the static transforms
    /// received so far: the chain from the base frame to the frame the pose
    /// messages name); `None` while neither tells it. The `decided:` line
    /// (also kept in [`Self::report`]) comes with the first answer only.
    pub fn lever_arm(&mut self) -> (Option<PoseMount>, Option<String>) {
        if self.lever_arm.is_some() {
            return (self.lever_arm, None);
        }
        let mut meta = self.cfg.meta.clone();
        let mut said = ImportReport::default();
        let frame = lever::PoseFrame {
            bag: &self.bag,
            cfg: &self.cfg,
            pose: self.pose,
            tf: self.tf,
            frames: &self.rows.frames,
            tf_tree: &self.rows.tf,
        };
        lever::apply(&frame, &mut meta, &mut said);
        self.lever_arm = meta.pose;
        // Without an answer, a line saying why is the bag's (no
        // /tf_static): live, the transform may still come.
        let line = self.lever_arm.and(said.decisions.pop());
        self.report.decisions.extend(line.clone());
        (self.lever_arm, line)
    }

    /// The mounting of IMU topic `topic` (`base ← sensor`), once it is
    /// known: `given` in the topics file, or the static transforms.
    fn mounting(&mut self, topic: usize, given: Option<[f64; 3]>) -> Option<Quat> {
        if let Some(&q) = self.mounts.get(&topic) {
            return q;
        }
        let frame = self.rows.frames.get(&topic).map_or("", String::as_str);
        let known = given.is_some()
            || self.tf.is_none()
            || self
                .rows
                .tf
                .rotation(&self.cfg.tf.base_frame, frame)
                .is_some();
        let s = Sensors {
            bag: &self.bag,
            cfg: &self.cfg,
            imu: self.imu,
            heading: self.heading,
            tf: self.tf,
            frames: &self.rows.frames,
            tf_tree: &self.rows.tf,
            heading_rows: &[],
        };
        let mut report = ImportReport::default();
        let q = s.mounting(topic, given, &mut report);
        // Until the static transforms name the frame, rows pass unrotated
        // and the question stays open.
        if known {
            self.mounts.insert(topic, q);
            self.report.mounts.extend(report.mounts);
        }
        q
    }
}
