//! What a person reads from the topics that could feed one stream to tell
//! them apart: a drive controller's or base driver's odometry is the
//! wheels; a filter's output is not (its name: `filtered`, `combined`,
//! `ekf`, ...; its frame: `map`, `combined_odom`, ...; a lateral velocity a
//! wheeled base's odometry never reports; a pose covariance that shrinks
//! and a pose that jumps where fixes arrive). A pose topic with a tenth of
//! the messages of another (a goal, a single fix) is no reference, nor is
//! a filter's fusion of the robot's own sensors when another is there.

use std::collections::HashMap;

use super::corrections::{yaw, Corrections, OdomSample};
use super::decoder::Decoder;
use crate::msg::{short_type, Value};
use crate::{Bag, Ros2Error};

/// One topic's evidence.
#[derive(Debug, Clone, Default)]
pub(super) struct TopicEvidence {
    /// The first message's `header.frame_id`.
    pub frame: Option<String>,
    /// Mean |lateral velocity| of a twist, m/s.
    pub lateral: Option<f64>,
    /// An odometry's covariance shrinks and pose jumps.
    pub corrections: Corrections,
}

/// Evidence for the topics that were read (by topic index).
#[derive(Debug, Clone, Default)]
pub(super) struct Evidence(pub HashMap<usize, TopicEvidence>);

/// Name tokens of a filter's (or a localizer's) output.
const FILTER_WORDS: &[&str] = &[
    "filtered",
    "filter",
    "combined",
    "ekf",
    "ukf",
    "fused",
    "fusion",
    "global",
    "localization",
    "amcl",
    "slam",
];
/// Name tokens of a filter fusing the robot's own sensors (its wheels, an
/// IMU): its output is no reference independent of the wheels.
const FUSION_WORDS: &[&str] = &[
    "filtered", "filter", "combined", "ekf", "ukf", "fused", "fusion",
];
/// Frames a filter's output is in, never a wheel odometry's.
const FILTER_FRAMES: &[&str] = &["map", "world", "earth", "utm"];
/// Name tokens of a drive controller's or base driver's odometry.
const WHEEL_WORDS: &[&str] = &[
    "controller",
    "drive",
    "diff",
    "base",
    "wheel",
    "wheels",
    "encoder",
    "encoders",
    "raw",
];
/// A lateral speed a wheeled base's own odometry does not report, m/s.
const LATERAL: f64 = 0.02;

fn tokens(name: &str) -> impl Iterator<Item = String> + '_ {
    name.split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|s| !s.is_empty())
        .map(str::to_lowercase)
}

impl Evidence {
    /// Why topic `i` looks like a filter's output (empty: it does not).
    pub fn filter_signs(&self, bag: &Bag, i: usize) -> Vec<String> {
        let name = &bag.topics[i].name;
        let mut signs = Vec::new();
        if let Some(w) = tokens(name).find(|t| FILTER_WORDS.contains(&t.as_str())) {
            signs.push(format!("its name says `{w}`"));
        }
        let e = self.0.get(&i).cloned().unwrap_or_default();
        if let Some(f) = e.frame.filter(|f| {
            let f = f.to_lowercase();
            FILTER_FRAMES.contains(&f.as_str())
                || tokens(&f).any(|t| FILTER_WORDS.contains(&t.as_str()))
        }) {
            signs.push(format!("its frame is `{f}`"));
        }
        if let Some(l) = e.lateral.filter(|l| *l > LATERAL) {
            signs.push(format!("a lateral velocity of {l:.2} m/s on average"));
        }
        signs.extend(e.corrections.signs());
        signs
    }

    /// Why topic `i` looks like a filter fusing the robot's own sensors
    /// (its name or frame says `filtered`, `combined`, `ekf` ...; empty: it
    /// does not). A localizer's output (`amcl`, `slam`, a `map` frame) is
    /// not such a filter: it is placed by something besides the wheels.
    pub fn fusion_signs(&self, bag: &Bag, i: usize) -> Vec<String> {
        let fusion = |name: &str| tokens(name).find(|t| FUSION_WORDS.contains(&t.as_str()));
        let mut signs = Vec::new();
        if let Some(w) = fusion(&bag.topics[i].name) {
            signs.push(format!("its name says `{w}`"));
        }
        if let Some(f) = self.0.get(&i).and_then(|e| e.frame.as_deref()) {
            if fusion(f).is_some() {
                signs.push(format!("its frame is `{f}`"));
            }
        }
        signs
    }

    /// Whether topic `i`'s name is a drive controller's or base driver's
    /// (`/odom` itself, or a name with `controller`, `drive`, `base` ...).
    pub fn wheel_like(&self, bag: &Bag, i: usize) -> bool {
        let name = &bag.topics[i].name;
        name == "/odom" || tokens(name).any(|t| WHEEL_WORDS.contains(&t.as_str()))
    }
}

/// The fields of an odometry its corrections are read from.
const ODOM: &[&str] = &[
    "?twist.twist.linear.y",
    "?twist.twist.linear.x",
    "?pose.pose.position.x",
    "?pose.pose.position.y",
    "?pose.pose.orientation.x",
    "?pose.pose.orientation.y",
    "?pose.pose.orientation.z",
    "?pose.pose.orientation.w",
    "?pose.covariance",
    "?header.stamp.sec",
    "?header.stamp.nanosec",
];

/// Reads the frame, lateral velocity and (of an odometry) corrections of
/// topics `idx` (twists and poses) in one pass over the bag.
pub(super) fn gather(bag: &mut Bag, idx: &[usize]) -> Result<Evidence, Ros2Error> {
    let mut decs: HashMap<usize, Decoder> = HashMap::new();
    for &i in idx {
        let lateral: &[&'static str] = match short_type(&bag.topics[i].ty).as_str() {
            "nav_msgs/Odometry" => ODOM,
            "geometry_msgs/TwistStamped" => &["?twist.linear.y"],
            _ => &[],
        };
        let mut f = vec!["?header.frame_id"];
        f.extend(lateral);
        decs.insert(i, Decoder::new(bag, i, &f)?);
    }
    let mut ev = Evidence::default();
    let mut sums: HashMap<usize, (f64, u64)> = HashMap::new();
    bag.for_each(&|i| decs.contains_key(&i), &mut |bag, m| {
        let d = &decs[&m.topic];
        let v = d
            .decode(m.data)
            .map_err(|e| bag.msg_err(m.topic, m.index, e))?;
        let e = ev.0.entry(m.topic).or_default();
        if e.frame.is_none() {
            if let Some(Value::Str(f)) = d.get(&v, "header.frame_id") {
                e.frame = Some(f.clone());
            }
        }
        if let Some(o) = odom_sample(d, &v, m.recv_ns) {
            e.corrections.add(o);
        }
        let y = d
            .f(&v, "twist.twist.linear.y")
            .or_else(|| d.f(&v, "twist.linear.y"));
        if let Some(y) = y.filter(|y| y.is_finite()) {
            let s = sums.entry(m.topic).or_default();
            s.0 += y.abs();
            s.1 += 1;
        }
        Ok(())
    })?;
    for (i, (sum, n)) in sums {
        if n > 0 {
            ev.0.entry(i).or_default().lateral = Some(sum / n as f64);
        }
    }
    Ok(ev)
}

/// An odometry message's pose, twist and position variance (`None`: not an
/// odometry, or no finite pose).
fn odom_sample(d: &Decoder, v: &Value, recv_ns: u64) -> Option<OdomSample> {
    let f = |name: &str| d.f(v, name).filter(|x| x.is_finite());
    let t = match (f("header.stamp.sec"), f("header.stamp.nanosec")) {
        (Some(s), Some(n)) if s != 0.0 || n != 0.0 => s + n * 1e-9,
        _ => recv_ns as f64 * 1e-9,
    };
    let var = match d.get(v, "pose.covariance") {
        Some(Value::Nums(c)) if c.len() == 36 => Some(c[0] + c[7]).filter(|x| x.is_finite()),
        _ => None,
    };
    Some(OdomSample {
        t,
        x: f("pose.pose.position.x")?,
        y: f("pose.pose.position.y")?,
        yaw: yaw(
            f("pose.pose.orientation.x")?,
            f("pose.pose.orientation.y")?,
            f("pose.pose.orientation.z")?,
            f("pose.pose.orientation.w")?,
        ),
        vx: f("twist.twist.linear.x")?,
        vy: f("twist.twist.linear.y").unwrap_or(0.0),
        var,
    })
}
