//! A rosbag2 recording to a terraslip drive log.
//!
//! Topics are chosen by message type when the choice is unique, or named in a
//! [`TopicsConfig`] (`--topics FILE.toml`). Time `t` of the log is seconds from
//! the bag's first message (receive time, whole second), taken from each
//! message's header stamp, or its receive time when the stamp is zero or
//! `[time] stamp = "receive"`.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use terraslip_io::{DriveLog, ImageRef, ImuSample, PoseObs, WheelSample};

use crate::msg::{short_type, Registry, Selection, Value};
use crate::{Bag, Ros2Error};

/// `--topics FILE.toml`: which topic feeds which stream, and the numbers a
/// bag cannot tell (wheel radius, the controller's separation, heading offsets).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TopicsConfig {
    #[serde(default)]
    pub wheels: WheelsConfig,
    #[serde(default)]
    pub pose: PoseConfig,
    #[serde(default)]
    pub heading: HeadingConfig,
    #[serde(default)]
    pub imu: TopicOnly,
    #[serde(default)]
    pub images: TopicOnly,
    #[serde(default)]
    pub time: TimeConfig,
    /// Written to the log's `meta.toml`.
    #[serde(default)]
    pub meta: terraslip_io::Meta,
}

/// `[wheels]`: the tread speed source.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelsConfig {
    /// sensor_msgs/JointState, nav_msgs/Odometry or geometry_msgs/TwistStamped.
    pub topic: Option<String>,
    /// JointState: wheel radius, m (velocities in rad/s times this).
    pub wheel_radius: Option<f64>,
    /// JointState: a joint is a left wheel when its name contains one of these (case-insensitive).
    #[serde(default = "left")]
    pub left: Vec<String>,
    /// JointState: right wheel joint name patterns.
    #[serde(default = "right")]
    pub right: Vec<String>,
    /// Odometry / TwistStamped: the controller's effective wheel separation
    /// S = wheel_separation × wheel_separation_multiplier, m. Tread speeds are
    /// v ∓ ω·S/2.
    pub separation: Option<f64>,
}

fn left() -> Vec<String> {
    vec!["left".into()]
}
fn right() -> Vec<String> {
    vec!["right".into()]
}

impl Default for WheelsConfig {
    fn default() -> Self {
        Self {
            topic: None,
            wheel_radius: None,
            left: left(),
            right: right(),
            separation: None,
        }
    }
}

/// `[pose]`: the absolute pose reference.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseConfig {
    /// sensor_msgs/NavSatFix, nav_msgs/Odometry, geometry_msgs/PoseStamped or
    /// PoseWithCovarianceStamped; `""` for none.
    pub topic: Option<String>,
}

/// `[heading]`: yaw from an IMU's orientation, for a GNSS pose source.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeadingConfig {
    /// sensor_msgs/Imu with orientation; `""` for none.
    pub topic: Option<String>,
    /// Added to the IMU's yaw, degrees counter-clockwise.
    #[serde(default)]
    pub yaw_offset_deg: f64,
    /// Magnetic declination, degrees, east positive (as charts give it), for
    /// an IMU whose yaw is measured from magnetic rather than true east:
    /// yaw = imu_yaw + yaw_offset − declination.
    #[serde(default)]
    pub declination_deg: f64,
    /// 1σ of the heading when the message's covariance states none, degrees.
    #[serde(default = "heading_std")]
    pub std_deg: f64,
}

fn heading_std() -> f64 {
    5.0
}

impl Default for HeadingConfig {
    fn default() -> Self {
        Self {
            topic: None,
            yaw_offset_deg: 0.0,
            declination_deg: 0.0,
            std_deg: heading_std(),
        }
    }
}

/// A stream given by its topic alone; `""` for none.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TopicOnly {
    pub topic: Option<String>,
}

/// `[time]`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeConfig {
    /// `header` (default: header stamp, receive time when the stamp is zero)
    /// or `receive`.
    pub stamp: Option<String>,
}

/// What one log stream was made from.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StreamReport {
    /// Log file written (`wheels.csv`, `pose.csv`, ...).
    pub file: String,
    pub topic: String,
    pub ty: String,
    /// Messages on the topic.
    pub messages: u64,
    /// Rows made (messages dropped for a bad fix or a missing field are not).
    pub rows: u64,
    /// Mean rate of the rows, Hz.
    pub rate_hz: f64,
    /// Longest time between consecutive rows, s.
    pub max_gap_s: f64,
    /// Gaps longer than five median periods.
    pub gaps: u64,
}

/// What [`import`] did.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct ImportReport {
    pub bag: PathBuf,
    /// `t` = 0 of the log, ns since the epoch.
    pub time_origin_ns: u64,
    /// ENU origin: latitude, longitude (degrees), altitude (m), when GNSS was used.
    pub enu_origin: Option<[f64; 3]>,
    pub streams: Vec<StreamReport>,
    /// Every topic of the bag: name, type, messages.
    pub topics: Vec<(String, String, u64)>,
    pub warnings: Vec<String>,
}

impl ImportReport {
    /// One line per stream: topic → file, counts, rate, gaps.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        for r in &self.streams {
            let _ = writeln!(
                s,
                "{} ({}) -> {}: {} of {} messages, {:.1} Hz, longest gap {:.2} s{}",
                r.topic,
                r.ty,
                r.file,
                r.rows,
                r.messages,
                r.rate_hz,
                r.max_gap_s,
                if r.gaps > 0 {
                    format!(", {} gaps > 5 periods", r.gaps)
                } else {
                    String::new()
                }
            );
        }
        s
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Wheels,
    Pose,
    Heading,
    Imu,
    Images,
}

impl Role {
    fn key(self) -> &'static str {
        match self {
            Role::Wheels => "wheels",
            Role::Pose => "pose",
            Role::Heading => "heading",
            Role::Imu => "imu",
            Role::Images => "images",
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
        }
    }
}

/// Picks the topic for `role`: the configured one, or the unique one of the
/// most preferred type class present. `taken` topics are not candidates.
fn choose(
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

fn list(bag: &Bag, idx: &[usize]) -> String {
    idx.iter()
        .map(|&i| format!("{} ({})", bag.topics[i].name, bag.topics[i].ty))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A decoder for one topic: its registry and the field paths it reads.
struct Decoder {
    reg: Registry,
    root: usize,
    paths: HashMap<&'static str, Vec<usize>>,
    sel: Selection,
}

impl Decoder {
    fn new(bag: &Bag, t: usize, fields: &[&'static str]) -> Result<Self, Ros2Error> {
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
    fn f(&self, v: &Value, name: &str) -> Option<f64> {
        v.f64_at(self.paths.get(name)?)
    }
    fn get<'a>(&self, v: &'a Value, name: &str) -> Option<&'a Value> {
        v.at(self.paths.get(name)?)
    }
}

fn name_key(f: &'static str) -> &'static str {
    f.trim_start_matches('?')
}

/// Yaw (rad, counter-clockwise about z) of a quaternion.
pub fn yaw_of(x: f64, y: f64, z: f64, w: f64) -> f64 {
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

const HEADER: [&str; 2] = ["?header.stamp.sec", "?header.stamp.nanosec"];

fn fields_for(ty: &str, role: Role) -> Vec<&'static str> {
    let mut f: Vec<&'static str> = HEADER.to_vec();
    match (ty, role) {
        ("sensor_msgs/JointState", _) => f.extend(["name", "velocity"]),
        ("nav_msgs/Odometry", Role::Wheels) | ("geometry_msgs/TwistStamped", _) => {
            let p: &[&str] = if ty == "nav_msgs/Odometry" {
                &["twist.twist.linear.x", "twist.twist.angular.z"]
            } else {
                &["twist.linear.x", "twist.angular.z"]
            };
            f.extend(p)
        }
        ("nav_msgs/Odometry", _) | ("geometry_msgs/PoseWithCovarianceStamped", _) => f.extend([
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
            "status.status",
            "latitude",
            "longitude",
            "altitude",
            "position_covariance",
            "position_covariance_type",
        ]),
        ("sensor_msgs/Imu", _) => f.extend([
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
        ("sensor_msgs/CompressedImage", _) => f.extend(["format", "data"]),
        ("sensor_msgs/Image", _) => f.extend(["height", "width", "encoding", "step", "data"]),
        _ => {}
    }
    f
}

struct Sel {
    topic: usize,
    ty: String,
    dec: Decoder,
    roles: Vec<Role>,
    times: HashMap<&'static str, Vec<f64>>,
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

    let mut log = DriveLog {
        dir: out_dir.map(Path::to_path_buf).unwrap_or_default(),
        meta: cfg.meta.clone(),
        ..Default::default()
    };
    let mut report = ImportReport {
        bag: bag.path.clone(),
        ..Default::default()
    };
    let mut origin: Option<u64> = None;
    let mut enu: Option<(f64, f64, f64)> = None;
    let mut warned_dropped_fix = 0u64;
    let want: Vec<bool> = (0..bag.topics.len())
        .map(|i| sels.iter().any(|s| s.topic == i))
        .collect();
    let want_fn = |i: usize| want.get(i).copied().unwrap_or(false);
    let hcfg = cfg.heading.clone();
    let wcfg = cfg.wheels.clone();
    let images_dir = out_dir.map(|d| d.join("images"));
    if images.is_some() {
        if let Some(d) = &images_dir {
            std::fs::create_dir_all(d).map_err(|e| Ros2Error::Bag {
                bag: bag.path.clone(),
                reason: format!("{}: {e}", d.display()),
            })?;
        }
    }
    // Time origin: the first message's receive time, whole seconds (any topic).
    bag.for_each(&want_fn, &mut |bag, m| {
        let org = *origin.get_or_insert(m.recv_ns / 1_000_000_000 * 1_000_000_000);
        let Some(sel) = sels.iter_mut().find(|s| s.topic == m.topic) else {
            return Ok(());
        };
        let v = sel
            .dec
            .reg
            .decode_selected(sel.dec.root, m.data, &sel.dec.sel)
            .map_err(|e| bag.msg_err(m.topic, m.index, e))?;
        let d = &sel.dec;
        // Integer nanoseconds: f64 of ns since the epoch would lose ~0.2 µs.
        let stamp_ns: i128 = match (
            d.f(&v, "header.stamp.sec"),
            d.f(&v, "header.stamp.nanosec"),
        ) {
            (Some(s), Some(n)) if !receive_only && (s != 0.0 || n != 0.0) => {
                s as i128 * 1_000_000_000 + n as i128
            }
            _ => m.recv_ns as i128,
        };
        let t = (stamp_ns - org as i128) as f64 * 1e-9;
        let need = |name: &str| {
            d.f(&v, name)
                .ok_or_else(|| bag.msg_err(m.topic, m.index, format!("no field `{name}`")))
        };
        for role in sel.roles.clone() {
            let mut made = true;
            match (role, sel.ty.as_str()) {
                (Role::Wheels, "sensor_msgs/JointState") => {
                    let (Some(Value::Strs(names)), Some(Value::Nums(vel))) =
                        (d.get(&v, "name"), d.get(&v, "velocity"))
                    else {
                        return Err(bag.msg_err(m.topic, m.index, "name or velocity missing"));
                    };
                    let pick = |pats: &[String]| {
                        let mut sum = 0.0;
                        let mut n = 0;
                        for (name, w) in names.iter().zip(vel) {
                            let lname = name.to_lowercase();
                            if pats.iter().any(|p| lname.contains(&p.to_lowercase())) && w.is_finite() {
                                sum += w;
                                n += 1;
                            }
                        }
                        (n > 0).then(|| sum / n as f64)
                    };
                    let r = wcfg.wheel_radius.unwrap_or(f64::NAN);
                    match (pick(&wcfg.left), pick(&wcfg.right)) {
                        (Some(l), Some(rr)) => log.wheels.push(WheelSample {
                            t,
                            v_left: l * r,
                            v_right: rr * r,
                        }),
                        _ if vel.is_empty() => made = false,
                        _ => {
                            return Err(bag.msg_err(
                                m.topic,
                                m.index,
                                format!(
                                    "no joint matches the left {:?} and right {:?} patterns (joints: {}); set [wheels] left/right",
                                    wcfg.left,
                                    wcfg.right,
                                    names.join(", ")
                                ),
                            ))
                        }
                    }
                }
                (Role::Wheels, ty) => {
                    let (vx, wz) = if ty == "nav_msgs/Odometry" {
                        (need("twist.twist.linear.x")?, need("twist.twist.angular.z")?)
                    } else {
                        (need("twist.linear.x")?, need("twist.angular.z")?)
                    };
                    let s = wcfg.separation.unwrap_or(f64::NAN);
                    if vx.is_finite() && wz.is_finite() {
                        log.wheels.push(WheelSample {
                            t,
                            v_left: vx - wz * s / 2.0,
                            v_right: vx + wz * s / 2.0,
                        });
                    } else {
                        made = false;
                    }
                }
                (Role::Pose, "sensor_msgs/NavSatFix") => {
                    let status = need("status.status")?;
                    let (lat, lon) = (need("latitude")?, need("longitude")?);
                    let alt = d.f(&v, "altitude").filter(|a| a.is_finite()).unwrap_or(0.0);
                    if status < 0.0 || !lat.is_finite() || !lon.is_finite() || lat.abs() > 90.0 {
                        warned_dropped_fix += 1;
                        made = false;
                    } else {
                        let (lat0, lon0, alt0) = *enu.get_or_insert((lat, lon, alt));
                        let (e, n, _u) = map_3d::geodetic2enu(
                            lat.to_radians(),
                            lon.to_radians(),
                            alt,
                            lat0.to_radians(),
                            lon0.to_radians(),
                            alt0,
                            map_3d::Ellipsoid::WGS84,
                        );
                        let ctype = need("position_covariance_type")?;
                        let std_xy = match d.get(&v, "position_covariance") {
                            Some(Value::Nums(c)) if ctype >= 1.0 && c.len() == 9 && c[0] > 0.0 && c[4] > 0.0 => {
                                Some(((c[0] + c[4]) / 2.0).sqrt())
                            }
                            _ => None,
                        };
                        log.pose.push(PoseObs {
                            t,
                            east: Some(e),
                            north: Some(n),
                            yaw: None,
                            std_xy,
                            std_yaw: None,
                        });
                    }
                }
                (Role::Pose, ty) => {
                    let pre = if ty == "geometry_msgs/PoseStamped" { "pose" } else { "pose.pose" };
                    let x = need(&format!("{pre}.position.x"))?;
                    let y = need(&format!("{pre}.position.y"))?;
                    let q: Vec<f64> = ["x", "y", "z", "w"]
                        .iter()
                        .map(|c| need(&format!("{pre}.orientation.{c}")))
                        .collect::<Result<_, _>>()?;
                    let qn = q.iter().map(|a| a * a).sum::<f64>();
                    let yaw = (qn > 0.5 && qn < 1.5).then(|| yaw_of(q[0], q[1], q[2], q[3]));
                    let (std_xy, std_yaw) = match d.get(&v, "pose.covariance") {
                        Some(Value::Nums(c)) if c.len() == 36 => (
                            (c[0] > 0.0 && c[7] > 0.0).then(|| ((c[0] + c[7]) / 2.0).sqrt()),
                            (c[35] > 0.0 && c[35] < 1e3).then(|| c[35].sqrt()),
                        ),
                        _ => (None, None),
                    };
                    if x.is_finite() && y.is_finite() {
                        log.pose.push(PoseObs {
                            t,
                            east: Some(x),
                            north: Some(y),
                            yaw,
                            std_xy,
                            std_yaw: yaw.and(std_yaw),
                        });
                    } else {
                        made = false;
                    }
                }
                (Role::Heading, _) => {
                    let q: Vec<f64> = ["x", "y", "z", "w"]
                        .iter()
                        .map(|c| need(&format!("orientation.{c}")))
                        .collect::<Result<_, _>>()?;
                    let cov = match d.get(&v, "orientation_covariance") {
                        Some(Value::Nums(c)) if c.len() == 9 => Some((c[0], c[8])),
                        _ => None,
                    };
                    let qn = q.iter().map(|a| a * a).sum::<f64>();
                    if cov.is_some_and(|c| c.0 == -1.0) || !(0.5..1.5).contains(&qn) {
                        made = false;
                    } else {
                        let yaw = yaw_of(q[0], q[1], q[2], q[3]) + (hcfg.yaw_offset_deg - hcfg.declination_deg).to_radians();
                        let std = cov
                            .map(|c| c.1)
                            .filter(|s| *s > 0.0 && s.is_finite())
                            .map(f64::sqrt)
                            .unwrap_or(hcfg.std_deg.to_radians());
                        log.pose.push(PoseObs {
                            t,
                            yaw: Some(wrap(yaw)),
                            std_yaw: Some(std),
                            ..Default::default()
                        });
                    }
                }
                (Role::Imu, _) => {
                    let az = need("linear_acceleration.z")?;
                    log.imu.push(ImuSample {
                        t,
                        accel_z: az,
                        accel_x: d.f(&v, "linear_acceleration.x"),
                        accel_y: d.f(&v, "linear_acceleration.y"),
                        gyro_x: d.f(&v, "angular_velocity.x"),
                        gyro_y: d.f(&v, "angular_velocity.y"),
                        gyro_z: d.f(&v, "angular_velocity.z"),
                    });
                }
                (Role::Images, ty) => {
                    let Some(dir) = &images_dir else { return Ok(()) };
                    let Some(Value::Bytes(data)) = d.get(&v, "data") else {
                        return Err(bag.msg_err(m.topic, m.index, "no image data"));
                    };
                    let (name, bytes) = if ty == "sensor_msgs/CompressedImage" {
                        let ext = if data.starts_with(&[0x89, b'P', b'N', b'G']) {
                            "png"
                        } else if data.starts_with(&[0xff, 0xd8]) {
                            "jpg"
                        } else {
                            return Err(bag.msg_err(m.topic, m.index, "compressed image is neither JPEG nor PNG"));
                        };
                        (format!("{:08}.{ext}", m.index), data.clone())
                    } else {
                        let png = raw_to_png(d, &v, data).map_err(|e| bag.msg_err(m.topic, m.index, e))?;
                        (format!("{:08}.png", m.index), png)
                    };
                    terraslip_io::write_atomic(dir.join(&name), &bytes)?;
                    log.images.push(ImageRef {
                        t,
                        path: PathBuf::from("images").join(name),
                    });
                }
            }
            if made {
                sel.times.entry(role.key()).or_default().push(t);
            }
        }
        Ok(())
    })?;

    report.time_origin_ns = origin.unwrap_or(0);
    report.enu_origin = enu.map(|(a, b, c)| [a, b, c]);
    if warned_dropped_fix > 0 {
        report.warnings.push(format!(
            "{warned_dropped_fix} GNSS fixes dropped (status < 0 or no position)"
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

fn wrap(a: f64) -> f64 {
    let mut a = a % std::f64::consts::TAU;
    if a > std::f64::consts::PI {
        a -= std::f64::consts::TAU;
    } else if a <= -std::f64::consts::PI {
        a += std::f64::consts::TAU;
    }
    a
}

fn stream_report(file: &str, topic: &crate::Topic, ty: &str, times: &[f64]) -> StreamReport {
    let dur = match (times.first(), times.last()) {
        (Some(a), Some(b)) if b > a => b - a,
        _ => 0.0,
    };
    let mut dts: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    let max_gap = dts.iter().copied().fold(0.0, f64::max);
    dts.sort_by(f64::total_cmp);
    let median = dts.get(dts.len() / 2).copied().unwrap_or(0.0);
    let gaps = dts
        .iter()
        .filter(|&&d| median > 0.0 && d > 5.0 * median)
        .count() as u64;
    StreamReport {
        file: file.to_string(),
        topic: topic.name.clone(),
        ty: ty.to_string(),
        messages: topic.count,
        rows: times.len() as u64,
        rate_hz: if dur > 0.0 {
            (times.len() - 1) as f64 / dur
        } else {
            0.0
        },
        max_gap_s: max_gap,
        gaps,
    }
}

fn raw_to_png(d: &Decoder, v: &Value, data: &[u8]) -> Result<Vec<u8>, String> {
    let h = d.f(v, "height").unwrap_or(0.0) as u32;
    let w = d.f(v, "width").unwrap_or(0.0) as u32;
    let step = d.f(v, "step").unwrap_or(0.0) as usize;
    let enc = match d.get(v, "encoding") {
        Some(Value::Str(s)) => s.as_str(),
        _ => "",
    };
    let ch = match enc {
        "mono8" | "8UC1" => 1,
        "rgb8" | "bgr8" | "8UC3" => 3,
        "rgba8" | "bgra8" | "8UC4" => 4,
        _ => {
            return Err(format!(
                "image encoding `{enc}` is not supported (mono8, rgb8, bgr8, rgba8, bgra8 are)"
            ))
        }
    };
    let row = w as usize * ch;
    if w == 0 || h == 0 || step < row || data.len() < step * (h as usize - 1) + row {
        return Err(format!(
            "image {w}x{h} step {step} does not fit its {} bytes",
            data.len()
        ));
    }
    let mut px = Vec::with_capacity(row * h as usize);
    for r in 0..h as usize {
        let line = &data[r * step..r * step + row];
        if enc.starts_with("bgr") {
            for c in line.chunks_exact(ch) {
                px.extend_from_slice(&[c[2], c[1], c[0]]);
                if ch == 4 {
                    px.push(c[3]);
                }
            }
        } else {
            px.extend_from_slice(line);
        }
    }
    let color = match ch {
        1 => image::ExtendedColorType::L8,
        3 => image::ExtendedColorType::Rgb8,
        _ => image::ExtendedColorType::Rgba8,
    };
    let mut out = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut out),
        &px,
        w,
        h,
        color,
    )
    .map_err(|e| e.to_string())?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternion_yaw_and_wrap() {
        let a: f64 = 2.5;
        let (s, c) = (a / 2.0).sin_cos();
        assert!((yaw_of(0.0, 0.0, s, c) - a).abs() < 1e-12);
        assert!((wrap(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
        assert!((wrap(-0.5) + 0.5).abs() < 1e-15);
    }

    #[test]
    fn unknown_topics_file_keys_are_errors() {
        assert!(toml::from_str::<TopicsConfig>("[wheels]\nseperation = 1.0\n").is_err());
        let c: TopicsConfig =
            toml::from_str("[wheels]\nseparation = 1.04\n[heading]\ndeclination_deg = 3\n")
                .unwrap();
        assert_eq!(c.wheels.separation, Some(1.04));
        assert_eq!(c.wheels.left, vec!["left"]);
    }
}
