//! A rosbag2 recording to a terraslip drive log.
//!
//! Topics are chosen by message type when the choice is unique, or named in a
//! [`TopicsConfig`] (`--topics FILE.toml`). Time `t` of the log is seconds from
//! the bag's first message (receive time, whole second), taken from each
//! message's header stamp, or its receive time when the stamp is zero or
//! `[time] stamp = "receive"`.
//!
//! `config` is the topics file, `topics` picks the topics, `decoder` the
//! fields each reads, `rows` turns messages into log rows, `report` says what
//! was made.

mod config;
mod corrections;
mod course;
mod decoder;
mod evidence;
mod frames;
mod image;
mod lever;
mod live;
mod live_choice;
pub mod mount;
mod no_wheels;
mod odom_scale;
mod prior;
mod reference;
mod report;
pub mod revisit;
mod role;
mod rows;
pub mod scale;
mod settled;
mod topics;
mod tread_scale;
mod unphysical;
mod window;

use std::collections::HashMap;
use std::path::Path;

use terraslip_io::DriveLog;

pub use config::{
    HeadingConfig, ImuConfig, PoseConfig, TfConfig, TimeConfig, TopicOnly, TopicsConfig,
    WheelsConfig,
};
pub use frames::yaw_of;
pub use live::{LiveImport, LiveRow};
pub use live_choice::{LiveChoice, Settled};
pub use prior::{controller_model, CONTROLLER_FILE};
pub use report::{ImportReport, StreamReport};
pub use unphysical::SkippedMessage;
pub use window::{import_bag_within, import_within};

use crate::msg::{self, short_type};
use crate::{Bag, Ros2Error};
use decoder::{fields_for, Decoder};
use report::stream_report;
use role::Role;
use rows::{Msg, Rows};
use topics::{choose, wheel_twists, Decide};
use tread_scale::{needs_urdf, wheel_radius, wheel_scale};

struct Sel {
    topic: usize,
    ty: String,
    dec: Decoder,
    roles: Vec<Role>,
    times: HashMap<&'static str, Vec<f64>>,
    /// The time of the last message kept, s.
    last_t: Option<f64>,
}

/// Reads `bag` into a drive log. Camera frames, when an image topic is used,
/// are written under `out_dir/images/` (required then). The log is returned
/// in memory, its `dir` set to `out_dir`; write it with [`DriveLog::write`].
pub fn import(
    bag_path: &Path,
    cfg: &TopicsConfig,
    out_dir: Option<&Path>,
) -> Result<(DriveLog, ImportReport), Ros2Error> {
    import_bag(Bag::open(bag_path)?, cfg, out_dir).map(|(log, report, _)| (log, report))
}

/// [`import`] of an opened bag (a file, or messages held in memory), with
/// the topics file that states what it settled: each stream's topic, the
/// tread speeds' scale, an IMU mounting found from the data, a heading
/// left out.
pub fn import_bag(
    mut bag: Bag,
    cfg: &TopicsConfig,
    out_dir: Option<&Path>,
) -> Result<(DriveLog, ImportReport, TopicsConfig), Ros2Error> {
    let unread = bag.clone();
    let mut decide = Decide {
        evidence: topic_evidence(&mut bag)?,
        ..Default::default()
    };
    let chosen = choose_streams(&bag, cfg, "bag", &mut decide)?;
    let (wheels, heading, imu, tf) = (chosen.wheels, chosen.heading, chosen.imu, chosen.tf);
    let images = match choose(&bag, Role::Images, &cfg.images.topic, &[], &mut decide)? {
        Some(i) if out_dir.is_none() => {
            return Err(Ros2Error::Bag {
                bag: bag.path.clone(),
                reason: format!(
                    "topic {} has camera frames; they need an output directory (or `[images] topic = \"\"`)",
                    bag.topics[i].name
                ),
            })
        }
        x => x,
    };

    decide.settled(&bag)?;
    // The scale the tread speeds are made in (scale.rs): the topics
    // file's, else the URDF's, else the track width, else a default.
    let urdf = if needs_urdf(&bag, cfg, wheels) {
        robot_description(&mut bag)?
    } else {
        None
    };
    let radius = wheel_radius(&mut bag, cfg, wheels, urdf.as_ref())?;
    let (wheels_cfg, sep_scale, scale_line) =
        wheel_scale(&bag, cfg, wheels, urdf.as_ref(), &radius);
    let mut sels = selections(&bag, &chosen)?;
    if let Some(t) = images {
        let ty = short_type(&bag.topics[t].ty);
        // Before the static transforms, as the streams are reported.
        let at = sels
            .iter()
            .position(|s| s.roles == [Role::Tf])
            .unwrap_or(sels.len());
        sels.insert(
            at,
            Sel {
                topic: t,
                dec: Decoder::new(&bag, t, &fields_for(&ty, Role::Images))?,
                ty,
                roles: vec![Role::Images],
                times: HashMap::new(),
                last_t: None,
            },
        );
    }

    let receive_only = receive_only(&bag, cfg)?;

    let mut rows = Rows {
        log: DriveLog {
            dir: out_dir.map(Path::to_path_buf).unwrap_or_default(),
            meta: cfg.meta.clone(),
            ..Default::default()
        },
        enu: None,
        dropped_fixes: 0,
        wheels: wheels_cfg,
        heading: cfg.heading.clone(),
        images_dir: out_dir.map(|d| d.join("images")),
        frames: HashMap::new(),
        tf: Default::default(),
        heading_rows: Vec::new(),
        unphysical: None,
        joints: HashMap::new(),
        wheels_unusable: None,
    };
    let mut skipped: Vec<SkippedMessage> = Vec::new();
    let mut report = ImportReport {
        bag: bag.path.clone(),
        decisions: std::mem::take(&mut decide.decisions)
            .into_iter()
            .chain([scale_line])
            .collect(),
        warnings: std::mem::take(&mut decide.warnings),
        ..Default::default()
    };
    if let Some(s) = &sep_scale {
        rows.log.meta.separation = Some(s.value);
        rows.log.meta.separation_source = Some(s.source.to_string());
    }
    if let Some((r, from_odom)) = &radius {
        // The radius the joint rates are made tread speeds with.
        rows.log.meta.wheel_radius = Some(r.value);
        rows.log.meta.wheel_radius_source = Some(r.source.to_string());
        // The driver's separation: where the model starts.
        if let (Some(o), None) = (from_odom, rows.log.meta.track_width) {
            rows.log.meta.track_width = Some(o.separation);
        }
    }
    let mut origin: Option<u64> = None;
    let want: Vec<bool> = (0..bag.topics.len())
        .map(|i| sels.iter().any(|s| s.topic == i))
        .collect();
    let want_fn = |i: usize| want.get(i).copied().unwrap_or(false);
    if images.is_some() {
        if let Some(d) = &rows.images_dir {
            std::fs::create_dir_all(d).map_err(|e| Ros2Error::Bag {
                bag: bag.path.clone(),
                reason: format!("{}: {e}", d.display()),
            })?;
        }
    }
    // Time origin: the first message's receive time, whole seconds (any
    // topic that makes rows; static transforms have no time in the log).
    bag.for_each(&want_fn, &mut |bag, m| {
        let Some(sel) = sels.iter_mut().find(|s| s.topic == m.topic) else {
            return Ok(());
        };
        let org = match sel.roles[..] {
            [Role::Tf] => origin.unwrap_or(m.recv_ns),
            _ => *origin.get_or_insert(m.recv_ns / 1_000_000_000 * 1_000_000_000),
        };
        let v = sel
            .dec
            .decode(m.data)
            .map_err(|e| bag.msg_err(m.topic, m.index, e))?;
        let d = &sel.dec;
        let stamp_ns = stamp_ns(d, &v, m.recv_ns, receive_only);
        let t = (stamp_ns - org as i128) as f64 * 1e-9;
        let msg = Msg {
            bag,
            topic: m.topic,
            index: m.index,
            t,
            d,
            v: &v,
        };
        let is_tf = sel.roles == [Role::Tf];
        let mark = unphysical::Mark::of(&rows.log, rows.heading_rows.len());
        let mut made = Vec::new();
        let mut why = if is_tf {
            None
        } else {
            unphysical::out_of_order(t, sel.last_t)
        };
        if why.is_none() {
            for &role in &sel.roles {
                if rows.add(role, &sel.ty, &msg)? {
                    made.push(role);
                }
            }
            why = rows.unphysical.take().or_else(|| mark.unphysical(&rows.log));
        }
        if let Some(reason) = why {
            mark.rollback(&mut rows.log, &mut rows.heading_rows);
            if cfg.strict {
                return Err(bag.msg_err(
                    m.topic,
                    m.index,
                    format!("at t = {t:.6} s (stamp {stamp_ns} ns): {reason}; not physical, refused (--strict)"),
                ));
            }
            skipped.push(SkippedMessage {
                topic: bag.topics[m.topic].name.clone(),
                index: m.index,
                t,
                reason,
            });
            return Ok(());
        }
        if !is_tf && !made.is_empty() {
            sel.last_t = Some(t);
        }
        for role in made {
            sel.times.entry(role.key()).or_default().push(t);
        }
        Ok(())
    })?;
    report.warnings.extend(bag.warnings.iter().cloned());
    report.warnings.extend(unphysical::warnings(&skipped));
    report.skipped = skipped;

    report.time_origin_ns = origin.unwrap_or(0);
    report.enu_origin = rows.enu.map(|(a, b, c)| [a, b, c]);
    if rows.dropped_fixes > 0 {
        report.warnings.push(format!(
            "{} GNSS fixes dropped (status < 0 or no position)",
            rows.dropped_fixes
        ));
    }
    for s in &sels {
        for role in &s.roles {
            let mut times = s.times.get(role.key()).cloned().unwrap_or_default();
            times.sort_by(f64::total_cmp);
            let file = match role {
                Role::Wheels => "wheels.csv",
                Role::Pose => "pose.csv (east, north)",
                Role::Heading => report::HEADING_FILE,
                Role::Imu => "imu.csv",
                Role::Images => "images.csv",
                Role::Tf => "sensor mountings and lever arms",
            };
            report
                .streams
                .push(stream_report(file, &bag.topics[s.topic], &s.ty, &times));
        }
    }
    report.topics = bag
        .topics
        .iter()
        .map(|t| (t.name.clone(), t.ty.clone(), t.count))
        .collect();
    if !rows.joints.is_empty() {
        report.decisions.push(format!(
            "wheel rates of {} from its joint positions (its messages carry no velocities), fitted over windows of {} s",
            bag.topics[wheels].name,
            rows::JointTrack::SPAN
        ));
    }
    let wheels_unusable = rows.wheels_unusable.take();
    let rows_wheels = rows.wheels.clone();
    let mut log = rows.log;
    let by_t = |a: f64, b: f64| a.total_cmp(&b);
    log.wheels.sort_by(|a, b| by_t(a.t, b.t));
    log.imu.sort_by(|a, b| by_t(a.t, b.t));
    log.images.sort_by(|a, b| by_t(a.t, b.t));
    let imu_mount = mount::apply(
        &mount::Sensors {
            bag: &bag,
            cfg,
            imu,
            heading,
            tf,
            frames: &rows.frames,
            tf_tree: &rows.tf,
            heading_rows: &rows.heading_rows,
        },
        &mut log,
        &mut report,
    );
    lever::apply(
        &lever::PoseFrame {
            bag: &bag,
            cfg,
            pose: chosen.pose,
            tf,
            frames: &rows.frames,
            tf_tree: &rows.tf,
        },
        &mut log.meta,
        &mut report,
    );
    reference::apply(&bag, chosen.pose, &mut log.meta, &mut report);
    let heading_kept = match heading {
        Some(h) if cfg.heading.topic.is_none() => {
            course::check_heading(&mut log.pose, &bag.topics[h].name, &mut report)
        }
        _ => true,
    };
    log.pose.sort_by(|a, b| by_t(a.t, b.t));
    if log.wheels.is_empty() {
        let why = wheels_unusable.unwrap_or_else(|| "no message had them".into());
        let name = &bag.topics[wheels].name;
        // The next source the bag has: its odometry (or twist).
        let next = wheel_twists(&bag, &[wheels]);
        if cfg.wheels.topic.is_none() && !next.is_empty() {
            let mut d = Decide {
                evidence: decide.evidence.clone(),
                ..Default::default()
            };
            let i = topics::decide(&bag, Role::Wheels, &next, &mut d);
            let mut cfg = cfg.clone();
            cfg.wheels.topic = Some(bag.topics[i].name.clone());
            let (log, mut report, settled) = import_bag(unread, &cfg, out_dir)?;
            report.decisions.insert(
                0,
                format!(
                    "wheels from {} ({}): {name} gave no tread speeds ({why}); `[wheels] topic = \"{name}\"` with `left`, `right` and `wheel_radius` in a --topics file names it",
                    bag.topics[i].name, bag.topics[i].ty
                ),
            );
            report.decisions.splice(1..1, d.decisions);
            report.warnings.splice(0..0, d.warnings);
            return Ok((log, report, settled));
        }
        return Err(Ros2Error::Bag {
            bag: bag.path.clone(),
            reason: format!("no usable wheel source: topic {name} gave no tread speeds ({why})"),
        });
    }
    let name = |t: Option<usize>| t.map(|i| bag.topics[i].name.as_str());
    let settled = settled::topics_file(
        cfg,
        &settled::Streams {
            wheels: &bag.topics[wheels].name,
            wheels_cfg: &rows_wheels,
            pose: name(chosen.pose),
            heading: name(heading.filter(|_| heading_kept)),
            imu: name(imu),
            imu_mount,
            tf: name(tf),
        },
    );
    Ok((log, report, settled))
}

/// The URDF of the bag's `/robot_description` (std_msgs/String, the first
/// message), read in a pass of its own; `None` when the bag has none or it
/// names no wheel joints.
fn robot_description(bag: &mut Bag) -> Result<Option<scale::UrdfWheels>, Ros2Error> {
    let Some(t) = bag
        .topic("/robot_description")
        .filter(|&i| short_type(&bag.topics[i].ty) == "std_msgs/String")
    else {
        return Ok(None);
    };
    let dec = Decoder::new(bag, t, &["data"])?;
    let mut xml: Option<String> = None;
    bag.for_each(&|i| i == t, &mut |bag, m| {
        if xml.is_none() {
            let v = dec
                .decode(m.data)
                .map_err(|e| bag.msg_err(m.topic, m.index, e))?;
            if let Some(crate::msg::Value::Str(s)) = dec.get(&v, "data") {
                xml = Some(s.clone());
            }
        }
        Ok(())
    })?;
    Ok(xml.as_deref().and_then(scale::urdf_wheels))
}

/// `[time] stamp`: whether times are the receive times (`receive`) rather
/// than the header stamps (`header`, the default).
fn receive_only(bag: &Bag, cfg: &TopicsConfig) -> Result<bool, Ros2Error> {
    match cfg.time.stamp.as_deref() {
        None | Some("header") => Ok(false),
        Some("receive") => Ok(true),
        Some(x) => Err(Ros2Error::Bag {
            bag: bag.path.clone(),
            reason: format!("[time] stamp = `{x}`: expected `header` or `receive`"),
        }),
    }
}

/// A message's time, ns since the epoch: its header stamp, or `recv_ns`
/// when the stamp is zero, absent or not wanted. Integer nanoseconds: f64
/// of ns since the epoch would lose ~0.2 µs.
fn stamp_ns(d: &Decoder, v: &msg::Value, recv_ns: u64, receive_only: bool) -> i128 {
    match (d.f(v, "header.stamp.sec"), d.f(v, "header.stamp.nanosec")) {
        (Some(s), Some(n)) if !receive_only && (s != 0.0 || n != 0.0) => {
            s as i128 * 1_000_000_000 + n as i128
        }
        _ => recv_ns as i128,
    }
}

/// The topic of each sensor stream (`None`: not read).
struct Chosen {
    wheels: usize,
    pose: Option<usize>,
    heading: Option<usize>,
    imu: Option<usize>,
    /// Static transforms, for the IMUs' mountings and the pose
    /// reference's lever arm.
    tf: Option<usize>,
}

/// Chooses the topics of the sensor streams (all but the camera's) of
/// `bag` (`what` it is, for messages: `bag`, `graph`).
fn choose_streams(
    bag: &Bag,
    cfg: &TopicsConfig,
    what: &str,
    d: &mut Decide,
) -> Result<Chosen, Ros2Error> {
    let wheels =
        choose(bag, Role::Wheels, &cfg.wheels.topic, &[], d)?.ok_or_else(|| Ros2Error::Bag {
            bag: bag.path.clone(),
            reason: no_wheels::no_wheel_source(bag, what),
        })?;
    let pose = choose(bag, Role::Pose, &cfg.pose.topic, &[wheels], d)?;
    let pose_is_gnss =
        pose.is_some_and(|p| short_type(&bag.topics[p].ty) == "sensor_msgs/NavSatFix");
    let heading = if pose_is_gnss || cfg.heading.topic.is_some() {
        choose(bag, Role::Heading, &cfg.heading.topic, &[], d)?
    } else {
        None
    };
    let imu = choose(bag, Role::Imu, &cfg.imu.topic, &[], d)?;
    // Static transforms, for the IMUs' mountings and the pose's lever arm.
    let tf = match &cfg.tf.topic {
        _ if imu.is_none() && heading.is_none() && pose.is_none() => None,
        Some(_) => choose(bag, Role::Tf, &cfg.tf.topic, &[], d)?,
        None => bag
            .topic("/tf_static")
            .filter(|&i| short_type(&bag.topics[i].ty) == "tf2_msgs/TFMessage"),
    };
    d.settled(bag)?;
    Ok(Chosen {
        wheels,
        pose,
        heading,
        imu,
        tf,
    })
}

/// The evidence for choosing among several odometries, twists or poses,
/// and for warning of a filter's odometry taken as the wheels: read (one
/// pass over those topics) when the bag has an odometry or twist, or
/// several poses.
fn topic_evidence(bag: &mut Bag) -> Result<evidence::Evidence, Ros2Error> {
    let twists = wheel_twists(bag, &[]);
    let poses = topics::candidates(
        bag,
        &[
            "geometry_msgs/PoseWithCovarianceStamped",
            "geometry_msgs/PoseStamped",
        ],
        &[],
    );
    if twists.is_empty() && poses.len() < 2 {
        return Ok(Default::default());
    }
    let all: Vec<usize> = twists.into_iter().chain(poses).collect();
    evidence::gather(bag, &all)
}

/// A decoder for each topic of `c`, with the streams it feeds (an
/// odometry that is both the wheel and the pose source decodes both).
fn selections(bag: &Bag, c: &Chosen) -> Result<Vec<Sel>, Ros2Error> {
    let mut sels: Vec<Sel> = Vec::new();
    for (t, role) in [
        (Some(c.wheels), Role::Wheels),
        (c.pose, Role::Pose),
        (c.heading, Role::Heading),
        (c.imu, Role::Imu),
        (c.tf, Role::Tf),
    ] {
        let Some(t) = t else { continue };
        if let Some(s) = sels.iter_mut().find(|s| s.topic == t) {
            s.roles.push(role);
            continue;
        }
        let ty = short_type(&bag.topics[t].ty);
        let mut fields = fields_for(&ty, role);
        if ty == "nav_msgs/Odometry" && role == Role::Wheels && c.pose == Some(t) {
            fields.extend(fields_for(&ty, Role::Pose));
        }
        sels.push(Sel {
            topic: t,
            dec: Decoder::new(bag, t, &fields)?,
            ty,
            roles: vec![role],
            times: HashMap::new(),
            last_t: None,
        });
    }
    Ok(sels)
}
