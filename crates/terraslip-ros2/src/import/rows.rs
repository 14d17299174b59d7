//! One decoded message to rows of the drive log, stream by stream.

use std::collections::HashMap;
use std::path::PathBuf;

use terraslip_io::{DriveLog, ImageRef, ImuSample, PoseObs, WheelSample};

use super::config::{HeadingConfig, WheelsConfig};
use super::decoder::Decoder;
use super::frames::{heading_yaw, normalized, wrap, yaw_of, Quat, StaticTf};
use super::role::Role;
use crate::msg::Value;
use crate::{Bag, Ros2Error};

/// One decoded message and where it came from.
pub(super) struct Msg<'a> {
    pub bag: &'a Bag,
    pub topic: usize,
    pub index: u64,
    /// Log time, s.
    pub t: f64,
    pub d: &'a Decoder,
    pub v: &'a Value,
}

impl Msg<'_> {
    fn err(&self, reason: impl std::fmt::Display) -> Ros2Error {
        self.bag.msg_err(self.topic, self.index, reason)
    }
    /// A numeric field the stream cannot do without.
    fn need(&self, name: &str) -> Result<f64, Ros2Error> {
        self.d
            .f(self.v, name)
            .ok_or_else(|| self.err(format!("no field `{name}`")))
    }
    fn get(&self, name: &str) -> Option<&Value> {
        self.d.get(self.v, name)
    }
    /// A quaternion `prefix.{x,y,z,w}`.
    fn quaternion(&self, prefix: &str) -> Result<Quat, Ros2Error> {
        let mut q = [0.0; 4];
        for (v, c) in q.iter_mut().zip(["x", "y", "z", "w"]) {
            *v = self.need(&format!("{prefix}.{c}"))?;
        }
        Ok(q)
    }
}

/// The log being made, and what the streams need besides their messages.
pub(super) struct Rows {
    pub log: DriveLog,
    /// ENU origin: the first good fix (latitude, longitude in degrees, altitude).
    pub enu: Option<(f64, f64, f64)>,
    /// Fixes dropped for a status < 0 or no position.
    pub dropped_fixes: u64,
    pub wheels: WheelsConfig,
    pub heading: HeadingConfig,
    /// Where camera frames go (`LOG/images`).
    pub images_dir: Option<PathBuf>,
    /// Each IMU topic's frame (its first message's `header.frame_id`), and
    /// the pose topic's: the frame on the robot whose position it gives (a
    /// NavSatFix's `header.frame_id`, an Odometry's `child_frame_id`).
    pub frames: HashMap<usize, String>,
    /// The bag's static transforms.
    pub tf: StaticTf,
    /// Heading rows: index in `log.pose` and the sensor's orientation, for
    /// a mounting known only at the end.
    pub heading_rows: Vec<(usize, Quat)>,
    /// Why the message just read cannot be physical, when a stream found
    /// that before making rows.
    pub unphysical: Option<String>,
    /// Each wheel joint's recent positions, for joint states with none of
    /// their velocities.
    pub joints: HashMap<String, JointTrack>,
    /// Why the wheel source's last message gave no tread speeds.
    pub wheels_unusable: Option<String>,
}

impl Rows {
    /// Adds the rows stream `role` makes of message `m` of type `ty`; false
    /// when it makes none (a dropped fix, a missing value).
    pub fn add(&mut self, role: Role, ty: &str, m: &Msg) -> Result<bool, Ros2Error> {
        match (role, ty) {
            (Role::Wheels, "sensor_msgs/JointState") => self.joint_state(m),
            (Role::Wheels, ty) => self.twist(m, ty),
            (Role::Pose, "sensor_msgs/NavSatFix") => self.fix(m),
            (Role::Pose, ty) => self.pose(m, ty),
            (Role::Heading, _) => self.heading(m),
            (Role::Imu, _) => self.imu(m),
            (Role::Images, ty) => self.image(m, ty),
            (Role::Tf, _) => self.static_tf(m),
        }
    }

    /// Keeps the first `header.frame_id` of the topic.
    fn note_frame(&mut self, m: &Msg) {
        self.note_frame_of(m, "header.frame_id");
    }

    /// Keeps the first frame named by field `name` of the topic.
    fn note_frame_of(&mut self, m: &Msg, name: &str) {
        if let (std::collections::hash_map::Entry::Vacant(e), Some(Value::Str(f))) =
            (self.frames.entry(m.topic), m.get(name))
        {
            e.insert(f.clone());
        }
    }

    /// tf2_msgs/TFMessage: each transform parent ← child.
    fn static_tf(&mut self, m: &Msg) -> Result<bool, Ros2Error> {
        let Some(Value::List(items)) = m.get("transforms") else {
            return Err(m.err("no field `transforms`"));
        };
        let ts = "geometry_msgs/TransformStamped";
        let path = |p: &str| {
            m.d.resolve_in(ts, p)
                .ok_or_else(|| m.err(format!("{ts} has no field `{p}`")))
        };
        let (parent, child) = (path("header.frame_id")?, path("child_frame_id")?);
        let q: Vec<Vec<usize>> = ["x", "y", "z", "w"]
            .iter()
            .map(|c| path(&format!("transform.rotation.{c}")))
            .collect::<Result<_, _>>()?;
        let o: Vec<Vec<usize>> = ["x", "y", "z"]
            .iter()
            .map(|c| path(&format!("transform.translation.{c}")))
            .collect::<Result<_, _>>()?;
        for (k, item) in items.iter().enumerate() {
            let (Some(Value::Str(parent)), Some(Value::Str(child))) =
                (item.at(&parent), item.at(&child))
            else {
                return Err(m.err(format!("transform {k}: no frame names")));
            };
            let r = [0, 1, 2, 3].map(|i| item.f64_at(&q[i]).unwrap_or(f64::NAN));
            let Some(r) = normalized(r) else {
                return Err(m.err(format!(
                    "transform {k} ({parent} -> {child}): rotation {r:?} is not a quaternion"
                )));
            };
            let origin = [0, 1, 2].map(|i| item.f64_at(&o[i]).unwrap_or(f64::NAN));
            if !origin.iter().all(|c| c.is_finite()) {
                return Err(m.err(format!(
                    "transform {k} ({parent} -> {child}): translation {origin:?} is not finite"
                )));
            }
            self.tf.add_transform(parent, child, r, origin);
        }
        Ok(true)
    }

    /// Wheel joint velocities (rad/s) times the wheel radius, left and right
    /// picked by name patterns (the mean of each side's joints); the
    /// positions differentiated ([`JointTrack`]) when the message carries no
    /// velocities. A message that gives no tread speeds makes no row and
    /// says why in [`Rows::wheels_unusable`].
    fn joint_state(&mut self, m: &Msg) -> Result<bool, Ros2Error> {
        let Some(Value::Strs(names)) = m.get("name") else {
            return Err(m.err("no joint names"));
        };
        let nums = |f: &str| match m.get(f) {
            Some(Value::Nums(v)) if v.len() == names.len() && !v.is_empty() => Some(v),
            _ => None,
        };
        // A rate from positions belongs to its window's mean time.
        let mut t = m.t;
        let rates: Vec<Option<f64>> = match (nums("velocity"), nums("position")) {
            (Some(vel), _) => vel.iter().map(|w| Some(*w)).collect(),
            (None, Some(pos)) => {
                let r: Vec<_> = names
                    .iter()
                    .zip(pos)
                    .map(|(n, &p)| self.joints.entry(n.clone()).or_default().rate(m.t, p))
                    .collect();
                t = r.iter().flatten().map(|a| a.0).next().unwrap_or(t);
                r.into_iter().map(|a| a.map(|a| a.1)).collect()
            }
            (None, None) => {
                self.wheels_unusable =
                    Some("its messages carry neither velocities nor positions".into());
                return Ok(false);
            }
        };
        let pick = |pats: &[String]| {
            let (mut sum, mut n, mut named) = (0.0, 0, false);
            for (name, w) in names.iter().zip(&rates) {
                let lname = name.to_lowercase();
                if pats.iter().any(|p| lname.contains(&p.to_lowercase())) {
                    named = true;
                    if let Some(w) = w {
                        sum += w;
                        n += 1;
                    }
                }
            }
            (named, (n > 0).then(|| sum / n as f64))
        };
        let wcfg = &self.wheels;
        let r = wcfg.wheel_radius.unwrap_or(f64::NAN);
        match (pick(&wcfg.left), pick(&wcfg.right)) {
            ((_, Some(l)), (_, Some(rr))) => self.log.wheels.push(WheelSample {
                t,
                v_left: l * r,
                v_right: rr * r,
            }),
            ((true, _), (true, _)) => return Ok(false),
            _ => {
                self.wheels_unusable = Some(format!(
                    "no joint matches the left {:?} and right {:?} patterns (joints: {}); set [wheels] left/right",
                    wcfg.left,
                    wcfg.right,
                    names.join(", ")
                ));
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// Odometry or TwistStamped: tread speeds v ∓ ω·S/2 with the
    /// controller's effective separation S.
    fn twist(&mut self, m: &Msg, ty: &str) -> Result<bool, Ros2Error> {
        let (vx, wz) = if ty == "nav_msgs/Odometry" {
            (
                m.need("twist.twist.linear.x")?,
                m.need("twist.twist.angular.z")?,
            )
        } else {
            (m.need("twist.linear.x")?, m.need("twist.angular.z")?)
        };
        let s = self.wheels.separation.unwrap_or(f64::NAN);
        self.log.wheels.push(WheelSample {
            t: m.t,
            v_left: vx - wz * s / 2.0,
            v_right: vx + wz * s / 2.0,
        });
        Ok(true)
    }

    /// NavSatFix to ENU about the first good fix (WGS-84), σ from a known
    /// position covariance.
    fn fix(&mut self, m: &Msg) -> Result<bool, Ros2Error> {
        let status = m.need("status.status")?;
        let (lat, lon) = (m.need("latitude")?, m.need("longitude")?);
        let alt =
            m.d.f(m.v, "altitude")
                .filter(|a| a.is_finite())
                .unwrap_or(0.0);
        self.note_frame_of(m, "header.frame_id");
        if status < 0.0 {
            self.dropped_fixes += 1;
            return Ok(false);
        }
        if !(lat.abs() <= 90.0 && lon.abs() <= 360.0) {
            self.unphysical = Some(format!(
                "latitude {lat}, longitude {lon} is not a place on Earth"
            ));
            return Ok(false);
        }
        let (lat0, lon0, alt0) = *self.enu.get_or_insert((lat, lon, alt));
        let (e, n, _u) = map_3d::geodetic2enu(
            lat.to_radians(),
            lon.to_radians(),
            alt,
            lat0.to_radians(),
            lon0.to_radians(),
            alt0,
            map_3d::Ellipsoid::WGS84,
        );
        let ctype = m.need("position_covariance_type")?;
        let std_xy = match m.get("position_covariance") {
            Some(Value::Nums(c)) if ctype >= 1.0 && c.len() == 9 && c[0] > 0.0 && c[4] > 0.0 => {
                Some(((c[0] + c[4]) / 2.0).sqrt())
            }
            _ => None,
        };
        self.log.pose.push(PoseObs {
            t: m.t,
            east: Some(e),
            north: Some(n),
            yaw: None,
            std_xy,
            std_yaw: None,
        });
        Ok(true)
    }

    /// Odometry, PoseStamped or PoseWithCovarianceStamped: position and yaw,
    /// σ from the covariance when it states one.
    fn pose(&mut self, m: &Msg, ty: &str) -> Result<bool, Ros2Error> {
        let pre = if ty == "geometry_msgs/PoseStamped" {
            "pose"
        } else {
            "pose.pose"
        };
        if ty == "nav_msgs/Odometry" {
            self.note_frame_of(m, "child_frame_id");
        }
        let x = m.need(&format!("{pre}.position.x"))?;
        let y = m.need(&format!("{pre}.position.y"))?;
        let q = m.quaternion(&format!("{pre}.orientation"))?;
        let qn = q.iter().map(|a| a * a).sum::<f64>();
        let yaw = (qn > 0.5 && qn < 1.5).then(|| yaw_of(q[0], q[1], q[2], q[3]));
        let (std_xy, std_yaw) = match m.get("pose.covariance") {
            Some(Value::Nums(c)) if c.len() == 36 => (
                (c[0] > 0.0 && c[7] > 0.0).then(|| ((c[0] + c[7]) / 2.0).sqrt()),
                (c[35] > 0.0 && c[35] < 1e3).then(|| c[35].sqrt()),
            ),
            _ => (None, None),
        };
        self.log.pose.push(PoseObs {
            t: m.t,
            east: Some(x),
            north: Some(y),
            yaw,
            std_xy,
            std_yaw: yaw.and(std_yaw),
        });
        Ok(true)
    }

    /// An IMU's orientation yaw as the heading, with the configured offset
    /// and declination; none when the orientation is marked unknown.
    fn heading(&mut self, m: &Msg) -> Result<bool, Ros2Error> {
        let q = m.quaternion("orientation")?;
        let cov = match m.get("orientation_covariance") {
            Some(Value::Nums(c)) if c.len() == 9 => Some((c[0], c[8])),
            _ => None,
        };
        let qn = q.iter().map(|a| a * a).sum::<f64>();
        // A quaternion far from unit length is no orientation; one that is
        // not finite is a bad message (the rule of `unphysical`).
        if cov.is_some_and(|c| c.0 == -1.0) || (qn.is_finite() && !(0.5..1.5).contains(&qn)) {
            return Ok(false);
        }
        let h = &self.heading;
        let std = cov
            .map(|c| c.1)
            .filter(|s| *s > 0.0 && s.is_finite())
            .map(f64::sqrt)
            .unwrap_or(h.std_deg.to_radians());
        self.log.pose.push(PoseObs {
            t: m.t,
            yaw: Some(heading_yaw(h, q)),
            std_yaw: Some(std),
            ..Default::default()
        });
        self.heading_rows.push((self.log.pose.len() - 1, q));
        self.note_frame(m);
        Ok(true)
    }

    /// Accelerations and angular rates, in the IMU's frame.
    fn imu(&mut self, m: &Msg) -> Result<bool, Ros2Error> {
        let az = m.need("linear_acceleration.z")?;
        self.note_frame(m);
        let f = |name: &str| m.d.f(m.v, name);
        self.log.imu.push(ImuSample {
            t: m.t,
            accel_z: az,
            accel_x: f("linear_acceleration.x"),
            accel_y: f("linear_acceleration.y"),
            gyro_x: f("angular_velocity.x"),
            gyro_y: f("angular_velocity.y"),
            gyro_z: f("angular_velocity.z"),
        });
        Ok(true)
    }

    /// A camera frame written under `images/` (JPEG or PNG as recorded, raw
    /// images as PNG).
    fn image(&mut self, m: &Msg, ty: &str) -> Result<bool, Ros2Error> {
        let Some(dir) = &self.images_dir else {
            return Ok(false);
        };
        let Some(Value::Bytes(data)) = m.get("data") else {
            return Err(m.err("no image data"));
        };
        let (name, bytes) = if ty == "sensor_msgs/CompressedImage" {
            let ext = if data.starts_with(&[0x89, b'P', b'N', b'G']) {
                "png"
            } else if data.starts_with(&[0xff, 0xd8]) {
                "jpg"
            } else {
                return Err(m.err("compressed image is neither JPEG nor PNG"));
            };
            (format!("{:08}.{ext}", m.index), data.clone())
        } else {
            let png = super::image::raw_to_png(m.d, m.v, data).map_err(|e| m.err(e))?;
            (format!("{:08}.png", m.index), png)
        };
        terraslip_io::write_atomic(dir.join(&name), &bytes)?;
        self.log.images.push(ImageRef {
            t: m.t,
            path: PathBuf::from("images").join(name),
        });
        Ok(true)
    }
}

/// A wheel joint's recent positions, differentiated into its rate by a
/// least-squares line over the last [`JointTrack::SPAN`] (jittered stamps
/// average out; the rate belongs to the window's mean time). Positions
/// that stay within ±π are a wrapping joint's: a step of more than π
/// between messages is a wrap.
#[derive(Debug, Clone, Default)]
pub(super) struct JointTrack {
    /// (log time s, unwrapped position rad), oldest first.
    recent: std::collections::VecDeque<(f64, f64)>,
    /// The last position as recorded, rad.
    last_raw: Option<f64>,
}

impl JointTrack {
    /// The span a rate is fitted over, s.
    pub const SPAN: f64 = 0.3;

    /// Adds position `p` (rad) at `t` (s); the window's mean time (s) and
    /// the rate (rad/s), once the window spans half of [`Self::SPAN`].
    pub fn rate(&mut self, t: f64, p: f64) -> Option<(f64, f64)> {
        if !p.is_finite() || self.recent.back().is_some_and(|b| t <= b.0) {
            return None;
        }
        let step = match self.last_raw {
            Some(q) if q.abs() <= PI_WRAP && p.abs() <= PI_WRAP => wrap(p - q),
            Some(q) => p - q,
            None => 0.0,
        };
        self.last_raw = Some(p);
        let u = self.recent.back().map_or(p, |b| b.1 + step);
        self.recent.push_back((t, u));
        while self.recent.len() > 2 && t - self.recent[0].0 > Self::SPAN {
            self.recent.pop_front();
        }
        let n = self.recent.len() as f64;
        if t - self.recent[0].0 < Self::SPAN / 2.0 {
            return None;
        }
        let tm = self.recent.iter().map(|a| a.0).sum::<f64>() / n;
        let um = self.recent.iter().map(|a| a.1).sum::<f64>() / n;
        let (mut stu, mut stt) = (0.0, 0.0);
        for &(ti, ui) in &self.recent {
            stu += (ti - tm) * (ui - um);
            stt += (ti - tm) * (ti - tm);
        }
        (stt > 0.0).then(|| (tm, stu / stt))
    }
}

/// π with room for rounding: the bound of a wrapping joint's positions.
const PI_WRAP: f64 = std::f64::consts::PI + 1e-6;
