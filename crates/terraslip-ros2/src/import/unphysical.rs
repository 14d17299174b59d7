//! The one rule for a message that cannot be physical: a value that is not
//! finite or lies beyond the log format's physical range
//! ([`terraslip_io::physical_limit`], the limits the log reader enforces),
//! or a stamp not after the previous kept message of its topic (out of
//! order or repeated). Such a message makes no row: it is skipped, counted
//! and warned about with its topic, index and stamp, or, with
//! [`super::TopicsConfig::strict`], refused with the same names. So an
//! import never writes a log the log reader refuses.

use terraslip_io::{physical_limit, DriveLog};

/// A message skipped by the rule.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SkippedMessage {
    pub topic: String,
    /// Index of the message in the bag's order of the topic's messages.
    pub index: u64,
    /// Its time in the log, s.
    pub t: f64,
    pub reason: String,
}

/// How many rows each stream of the log had before a message was turned
/// into rows, to take back the rows of a message found bad.
#[derive(Debug, Clone, Copy)]
pub(super) struct Mark {
    wheels: usize,
    pose: usize,
    imu: usize,
    heading_rows: usize,
}

impl Mark {
    pub fn of(log: &DriveLog, heading_rows: usize) -> Self {
        Self {
            wheels: log.wheels.len(),
            pose: log.pose.len(),
            imu: log.imu.len(),
            heading_rows,
        }
    }

    /// Removes the rows made since the mark.
    pub fn rollback<T>(&self, log: &mut DriveLog, heading_rows: &mut Vec<T>) {
        log.wheels.truncate(self.wheels);
        log.pose.truncate(self.pose);
        log.imu.truncate(self.imu);
        heading_rows.truncate(self.heading_rows);
    }

    /// Why the rows made since the mark cannot be physical, if they cannot.
    pub fn unphysical(&self, log: &DriveLog) -> Option<String> {
        let w = log.wheels[self.wheels..].iter().flat_map(|s| {
            [
                ("t", Some(s.t)),
                ("v_left", Some(s.v_left)),
                ("v_right", Some(s.v_right)),
            ]
        });
        let p = log.pose[self.pose..].iter().flat_map(|s| {
            [
                ("t", Some(s.t)),
                ("east", s.east),
                ("north", s.north),
                ("yaw", s.yaw),
                ("std_xy", s.std_xy),
                ("std_yaw", s.std_yaw),
            ]
        });
        let i = log.imu[self.imu..].iter().flat_map(|s| {
            [
                ("t", Some(s.t)),
                ("accel_x", s.accel_x),
                ("accel_y", s.accel_y),
                ("accel_z", Some(s.accel_z)),
                ("gyro_x", s.gyro_x),
                ("gyro_y", s.gyro_y),
                ("gyro_z", s.gyro_z),
            ]
        });
        w.chain(p)
            .chain(i)
            .find_map(|(name, v)| v.and_then(|v| beyond(name, v)))
    }
}

/// Why `v` cannot be the log column `name`, if it cannot.
fn beyond(name: &str, v: f64) -> Option<String> {
    if !v.is_finite() {
        return Some(format!("{name} = {v} is not finite"));
    }
    match physical_limit(name) {
        Some((limit, unit)) if v.abs() > limit => Some(format!(
            "{name} = {v:e} is outside the physical range ±{limit:e} {unit}"
        )),
        _ => None,
    }
}

/// Why a message at log time `t` is out of order, if it is: its stamp is
/// not after `last`, the previous kept message's of the topic.
pub(super) fn out_of_order(t: f64, last: Option<f64>) -> Option<String> {
    match last {
        Some(last) if t == last => Some(format!(
            "its stamp repeats the previous message's (t = {t:.6} s)"
        )),
        Some(last) if t < last => Some(format!(
            "its stamp goes back {:.6} s, before the previous message's (t = {last:.6} s)",
            last - t
        )),
        _ => None,
    }
}

/// One warning line per topic with skipped messages: how many, and the
/// first few with their index, stamp and reason.
pub(super) fn warnings(skipped: &[SkippedMessage]) -> Vec<String> {
    let mut topics: Vec<&str> = skipped.iter().map(|s| s.topic.as_str()).collect();
    topics.dedup();
    topics.sort_unstable();
    topics.dedup();
    topics
        .into_iter()
        .map(|topic| {
            let on: Vec<&SkippedMessage> = skipped.iter().filter(|s| s.topic == topic).collect();
            let first: Vec<String> = on
                .iter()
                .take(5)
                .map(|s| format!("message {} at t = {:.3} s: {}", s.index, s.t, s.reason))
                .collect();
            format!(
                "{topic}: {} message{} skipped as not physical ({}{}); --strict refuses such a bag",
                on.len(),
                if on.len() == 1 { "" } else { "s" },
                first.join("; "),
                if on.len() > 5 { "; ..." } else { "" }
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use terraslip_io::{ImuSample, PoseObs, WheelSample};

    #[test]
    fn the_rule_names_the_first_bad_value() {
        let mut log = DriveLog::default();
        log.wheels.push(WheelSample {
            t: 0.0,
            v_left: 1.0,
            v_right: 1.0,
        });
        let mark = Mark::of(&log, 0);
        assert_eq!(mark.unphysical(&log), None);
        log.wheels.push(WheelSample {
            t: 0.1,
            v_left: 1e308,
            v_right: 1.0,
        });
        let why = mark.unphysical(&log).unwrap();
        assert!(
            why.starts_with("v_left = 1e308 is outside the physical range ±1e2 m/s"),
            "{why}"
        );
        mark.rollback(&mut log, &mut Vec::<()>::new());
        assert_eq!(log.wheels.len(), 1);
        log.pose.push(PoseObs {
            t: 0.1,
            yaw: Some(f64::NAN),
            ..Default::default()
        });
        assert_eq!(mark.unphysical(&log).unwrap(), "yaw = NaN is not finite");
        mark.rollback(&mut log, &mut Vec::<()>::new());
        log.imu.push(ImuSample {
            t: 0.1,
            accel_z: 9.8,
            gyro_z: Some(f64::INFINITY),
            ..Default::default()
        });
        assert_eq!(mark.unphysical(&log).unwrap(), "gyro_z = inf is not finite");
        assert!(out_of_order(1.0, Some(1.0)).unwrap().contains("repeats"));
        assert!(out_of_order(0.5, Some(1.5))
            .unwrap()
            .contains("goes back 1.000000 s"));
        assert_eq!(out_of_order(2.0, Some(1.5)), None);
        assert_eq!(out_of_order(2.0, None), None);
    }
}
