//! The wheel radius and separation a base driver's own odometry was made
//! with, read off its twist against the wheel joints' rates.
//!
//! A driver that publishes `/joint_states` and `/odom` (a TurtleBot 3's,
//! most ros2_control set-ups) makes the odometry's twist from the same
//! wheel rates: `v = r (w_l + w_r) / 2`, `ω = r (w_r − w_l) / S`. The
//! least-squares gains through the origin give its radius `r` (m) and
//! separation `S` (m) when both fit (each explains at least
//! [`MIN_FIT`] of the twist's square sum): a filter's odometry, which
//! takes in other sensors, fits worse. They are the driver's nominal
//! values, not the robot's truth: the speed factors and the spread learned
//! in them say how far the driver's odometry is off.

use std::collections::HashMap;

use super::decoder::{fields_for, Decoder};
use super::role::Role;
use super::rows::JointTrack;
use crate::msg::{short_type, Value};
use crate::{Bag, Ros2Error};

/// Smallest share of the twist's square sum each gain must explain.
pub const MIN_FIT: f64 = 0.8;
/// Fewest moving samples the gains are taken over.
const MIN_SAMPLES: usize = 50;
/// Wheel rate (rad/s) under which a sample is standing still.
const STILL: f64 = 0.05;

/// The scale an odometry topic was made with.
#[derive(Debug, Clone, PartialEq)]
pub struct OdomScale {
    /// The odometry's topic.
    pub topic: String,
    /// Wheel radius, m.
    pub radius: f64,
    /// Wheel separation, m.
    pub separation: f64,
    /// Share of the square sum of the forward speed and of the yaw rate
    /// the gains explain.
    pub fit: (f64, f64),
    /// Samples the gains were taken over.
    pub samples: usize,
}

/// Sums of one odometry topic's fit.
#[derive(Debug, Clone, Copy, Default)]
struct Sums {
    mm: f64,
    mv: f64,
    vv: f64,
    dd: f64,
    dw: f64,
    ww: f64,
    n: usize,
}

impl Sums {
    fn add(&mut self, (wl, wr): (f64, f64), v: f64, w: f64) {
        let (m, d) = (0.5 * (wl + wr), wr - wl);
        if !(m.is_finite() && d.is_finite() && v.is_finite() && w.is_finite())
            || wl.abs().max(wr.abs()) < STILL
        {
            return;
        }
        self.mm += m * m;
        self.mv += m * v;
        self.vv += v * v;
        self.dd += d * d;
        self.dw += d * w;
        self.ww += w * w;
        self.n += 1;
    }

    /// Radius, separation and their fits.
    fn scale(&self, topic: &str) -> Option<OdomScale> {
        if self.n < MIN_SAMPLES || self.mm <= 0.0 || self.dd <= 0.0 || self.vv <= 0.0 {
            return None;
        }
        let r = self.mv / self.mm;
        let k = self.dw / self.dd;
        let fit_v = self.mv * self.mv / (self.mm * self.vv);
        let fit_w = if self.ww > 0.0 {
            self.dw * self.dw / (self.dd * self.ww)
        } else {
            0.0
        };
        let separation = r / k;
        let plausible = |x: f64, lo: f64, hi: f64| x.is_finite() && (lo..=hi).contains(&x);
        (plausible(r, 0.005, 2.0)
            && plausible(separation, 0.05, 10.0)
            && fit_v >= MIN_FIT
            && fit_w >= MIN_FIT)
            .then(|| OdomScale {
                topic: topic.to_string(),
                radius: r,
                separation,
                fit: (fit_v, fit_w),
                samples: self.n,
            })
    }
}

/// The left and right wheel rates (rad/s, each side's joints' mean) of
/// the joint state `v` at receive time `t` (s): its velocities, else its
/// positions differentiated (`tracks`).
fn wheel_rates(
    d: &Decoder,
    v: &Value,
    t: f64,
    tracks: &mut HashMap<String, JointTrack>,
    pats: (&[String], &[String]),
) -> Option<(f64, f64)> {
    let Some(Value::Strs(names)) = d.get(v, "name") else {
        return None;
    };
    let nums = |f: &str| match d.get(v, f) {
        Some(Value::Nums(x)) if x.len() == names.len() && !x.is_empty() => Some(x),
        _ => None,
    };
    let rates: Vec<Option<f64>> = match (nums("velocity"), nums("position")) {
        (Some(vel), _) => vel.iter().map(|w| Some(*w)).collect(),
        (None, Some(pos)) => names
            .iter()
            .zip(pos)
            .map(|(n, &p)| tracks.entry(n.clone()).or_default().rate(t, p).map(|a| a.1))
            .collect(),
        (None, None) => return None,
    };
    let side = |pats: &[String]| {
        let (mut sum, mut n) = (0.0, 0);
        for (name, w) in names.iter().zip(&rates) {
            let lname = name.to_lowercase();
            if let Some(w) = w.filter(|_| pats.iter().any(|p| lname.contains(&p.to_lowercase()))) {
                sum += w;
                n += 1;
            }
        }
        (n > 0).then(|| sum / n as f64)
    };
    Some((side(pats.0)?, side(pats.1)?))
}

/// The scale of the odometry topic of `bag` that fits the wheel joints of
/// topic `joints` best (left and right joints by the name patterns
/// `left`, `right`), each odometry message paired with the latest wheel
/// rates received; `None` when none fits.
pub(super) fn fit(
    bag: &mut Bag,
    joints: usize,
    left: &[String],
    right: &[String],
) -> Result<Option<OdomScale>, Ros2Error> {
    let odoms: Vec<usize> = (0..bag.topics.len())
        .filter(|&i| short_type(&bag.topics[i].ty) == "nav_msgs/Odometry")
        .collect();
    if odoms.is_empty() {
        return Ok(None);
    }
    let mut decs: HashMap<usize, Decoder> = HashMap::new();
    decs.insert(
        joints,
        Decoder::new(
            bag,
            joints,
            &fields_for("sensor_msgs/JointState", Role::Wheels),
        )?,
    );
    for &i in &odoms {
        decs.insert(
            i,
            Decoder::new(bag, i, &["?twist.twist.linear.x", "?twist.twist.angular.z"])?,
        );
    }
    let mut tracks: HashMap<String, JointTrack> = HashMap::new();
    let mut latest: Option<(f64, (f64, f64))> = None;
    let mut sums: HashMap<usize, Sums> = HashMap::new();
    bag.for_each(&|i| decs.contains_key(&i), &mut |bag, m| {
        let d = &decs[&m.topic];
        let v = d
            .decode(m.data)
            .map_err(|e| bag.msg_err(m.topic, m.index, e))?;
        let t = m.recv_ns as f64 * 1e-9;
        if m.topic == joints {
            if let Some(w) = wheel_rates(d, &v, t, &mut tracks, (left, right)) {
                latest = Some((t, w));
            }
        } else if let (Some(vx), Some(wz), Some((tj, w))) = (
            d.f(&v, "twist.twist.linear.x"),
            d.f(&v, "twist.twist.angular.z"),
            latest,
        ) {
            // Rates from positions belong half a window back.
            if t - tj <= JointTrack::SPAN {
                sums.entry(m.topic).or_default().add(w, vx, wz);
            }
        }
        Ok(())
    })?;
    let best = odoms
        .iter()
        .filter_map(|&i| sums.get(&i)?.scale(&bag.topics[i].name))
        .max_by(|a, b| (a.fit.0 + a.fit.1).total_cmp(&(b.fit.0 + b.fit.1)));
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sums(r: f64, s: f64, noise_w: f64) -> Sums {
        let mut x = Sums::default();
        for i in 0..200 {
            let t = f64::from(i) * 0.05;
            let (wl, wr) = (10.0 + 3.0 * t.sin(), 10.0 + 3.0 * (1.3 * t).cos());
            let wz = r * (wr - wl) / s + noise_w * (7.0 * t).sin();
            x.add((wl, wr), r * 0.5 * (wl + wr), wz);
        }
        x
    }

    #[test]
    fn a_drivers_odometry_gives_its_radius_and_separation() {
        let o = sums(0.033, 0.287, 0.0).scale("/odom").unwrap();
        assert!((o.radius - 0.033).abs() < 1e-9, "{o:?}");
        assert!((o.separation - 0.287).abs() < 1e-9, "{o:?}");
        assert_eq!(o.samples, 200);
    }

    #[test]
    fn an_odometry_that_does_not_follow_the_wheels_gives_none() {
        // A yaw rate the wheels do not explain (a filter's, a gyro's).
        assert!(sums(0.033, 0.287, 0.5)
            .scale("/odometry/filtered")
            .is_none());
        // Too few samples.
        let mut x = Sums::default();
        x.add((1.0, 2.0), 0.05, 0.1);
        assert!(x.scale("/odom").is_none());
    }
}
