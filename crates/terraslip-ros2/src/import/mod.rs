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
mod decoder;
mod image;
pub mod mount;
mod prior;
mod report;
mod rows;
mod topics;
mod unphysical;

use std::collections::HashMap;
use std::path::Path;

use terraslip_io::DriveLog;

pub use config::{
    HeadingConfig, ImuConfig, PoseConfig, TfConfig, TimeConfig, TopicOnly, TopicsConfig,
    WheelsConfig,
};
pub use prior::{controller_model, CONTROLLER_FILE};
pub use report::{ImportReport, StreamReport};
pub use rows::yaw_of;
pub use unphysical::SkippedMessage;

use crate::msg::short_type;
use crate::{Bag, Ros2Error};
use decoder::{fields_for, Decoder};
use report::stream_report;
use rows::{Msg, Rows};
use topics::{choose, list, Role};

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
    let mut bag = Bag::open(bag_path)?;
    let wheels = choose(&bag, Role::Wheels, &cfg.wheels.topic, &[])?.ok_or_else(|| Ros2Error::Bag {
        bag: bag.path.clone(),
        reason: format!(
            "no usable wheel source: no sensor_msgs/JointState, nav_msgs/Odometry or geometry_msgs/TwistStamped topic (the bag has: {})",
            list(&bag, &(0..bag.topics.len()).collect::<Vec<_>>())
        ),
    })?;
    let pose = choose(&bag, Role::Pose, &cfg.pose.topic, &[wheels])?;
    let pose_is_gnss =
        pose.is_some_and(|p| short_type(&bag.topics[p].ty) == "sensor_msgs/NavSatFix");
    let heading = if pose_is_gnss || cfg.heading.topic.is_some() {
        choose(&bag, Role::Heading, &cfg.heading.topic, &[])?
    } else {
        None
    };
    let imu = choose(&bag, Role::Imu, &cfg.imu.topic, &[])?;
    // Static transforms, for the IMUs' mountings.
    let tf = match &cfg.tf.topic {
        _ if imu.is_none() && heading.is_none() => None,
        Some(_) => choose(&bag, Role::Tf, &cfg.tf.topic, &[])?,
        None => bag
            .topic("/tf_static")
            .filter(|&i| short_type(&bag.topics[i].ty) == "tf2_msgs/TFMessage"),
    };
    let images = match choose(&bag, Role::Images, &cfg.images.topic, &[])? {
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

    let wheel_ty = short_type(&bag.topics[wheels].ty);
    let sep = cfg.wheels.separation;
    if wheel_ty != "sensor_msgs/JointState" {
        match sep {
            Some(s) if s.is_finite() && s > 0.0 => {}
            _ => {
                return Err(Ros2Error::Bag {
                    bag: bag.path.clone(),
                    reason: format!(
                        "the wheel source is {} ({}): tread speeds from its twist need the controller's effective wheel separation S = wheel_separation × wheel_separation_multiplier (not the track width). Give it in a --topics file: `[wheels] separation = <S in m>`",
                        bag.topics[wheels].name, bag.topics[wheels].ty
                    ),
                })
            }
        }
    } else if !cfg
        .wheels
        .wheel_radius
        .is_some_and(|r| r.is_finite() && r > 0.0)
    {
        return Err(Ros2Error::Bag {
            bag: bag.path.clone(),
            reason: format!(
                "the wheel source is {} (sensor_msgs/JointState): wheel speeds in rad/s need the wheel radius. Give it in a --topics file: `[wheels] wheel_radius = <m>`",
                bag.topics[wheels].name
            ),
        });
    }

    let mut sels: Vec<Sel> = Vec::new();
    for (t, role) in [
        (Some(wheels), Role::Wheels),
        (pose, Role::Pose),
        (heading, Role::Heading),
        (imu, Role::Imu),
        (images, Role::Images),
        (tf, Role::Tf),
    ] {
        let Some(t) = t else { continue };
        if let Some(s) = sels.iter_mut().find(|s| s.topic == t) {
            s.roles.push(role);
            continue;
        }
        let ty = short_type(&bag.topics[t].ty);
        let mut fields = fields_for(&ty, role);
        if ty == "nav_msgs/Odometry" && role == Role::Wheels && pose == Some(t) {
            fields.extend(fields_for(&ty, Role::Pose));
        }
        sels.push(Sel {
            topic: t,
            dec: Decoder::new(&bag, t, &fields)?,
            ty,
            roles: vec![role],
            times: HashMap::new(),
            last_t: None,
        });
    }

    let receive_only = match cfg.time.stamp.as_deref() {
        None | Some("header") => false,
        Some("receive") => true,
        Some(x) => {
            return Err(Ros2Error::Bag {
                bag: bag.path.clone(),
                reason: format!("[time] stamp = `{x}`: expected `header` or `receive`"),
            })
        }
    };

    let mut rows = Rows {
        log: DriveLog {
            dir: out_dir.map(Path::to_path_buf).unwrap_or_default(),
            meta: cfg.meta.clone(),
            ..Default::default()
        },
        enu: None,
        dropped_fixes: 0,
        wheels: &cfg.wheels,
        heading: &cfg.heading,
        images_dir: out_dir.map(|d| d.join("images")),
        frames: HashMap::new(),
        tf: Default::default(),
        heading_rows: Vec::new(),
        unphysical: None,
    };
    let mut skipped: Vec<SkippedMessage> = Vec::new();
    let mut report = ImportReport {
        bag: bag.path.clone(),
        ..Default::default()
    };
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
        // Integer nanoseconds: f64 of ns since the epoch would lose ~0.2 µs.
        let stamp_ns: i128 = match (d.f(&v, "header.stamp.sec"), d.f(&v, "header.stamp.nanosec")) {
            (Some(s), Some(n)) if !receive_only && (s != 0.0 || n != 0.0) => {
                s as i128 * 1_000_000_000 + n as i128
            }
            _ => m.recv_ns as i128,
        };
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
                Role::Heading => "pose.csv (yaw)",
                Role::Imu => "imu.csv",
                Role::Images => "images.csv",
                Role::Tf => "sensor mountings",
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
    let mut log = rows.log;
    mount::apply(
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
    if log.wheels.is_empty() {
        return Err(Ros2Error::Bag {
            bag: bag.path.clone(),
            reason: format!(
                "no usable wheel source: topic {} gave no tread speeds",
                bag.topics[wheels].name
            ),
        });
    }
    let by_t = |a: f64, b: f64| a.total_cmp(&b);
    log.wheels.sort_by(|a, b| by_t(a.t, b.t));
    log.pose.sort_by(|a, b| by_t(a.t, b.t));
    log.imu.sort_by(|a, b| by_t(a.t, b.t));
    log.images.sort_by(|a, b| by_t(a.t, b.t));
    Ok((log, report))
}
