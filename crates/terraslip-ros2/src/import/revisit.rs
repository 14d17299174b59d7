//! Decisions made from the data, checked again over later windows: an
//! IMU's mounting found from the data (gravity along the base's +z, the
//! rotated gyro turning with the treads) and a heading kept because it
//! agreed with the GNSS course ([`super::course`]). The same tests the
//! first decision used are run on every [`SPAN`] s window of stamp time
//! (aligned on the epoch, so that a live node and `estimate` cut the same
//! windows whatever their time origins); when [`IN_A_ROW`] windows in a row
//! contradict a decision, it is made again from the last of them and
//! applies from [`MARGIN`] s after that window's end: an IMU's new mounting
//! to its samples from then on, a heading left out from then on. A window
//! that tells nothing (too few samples, no straight stretch) leaves the
//! count as it is; one that agrees resets it.
//!
//! One piece of code for both: `estimate` passes a log's rows through it
//! in stamp order ([`revisit_log`]), the node each row as the live import
//! makes it ([`Revisit::row`]); a window is judged when the first row
//! [`MARGIN`] s past its end comes, so rows up to that much late (jitter
//! between topics) are still in it.

use std::collections::BTreeMap;

use terraslip_io::{DriveLog, ImuSample, PoseObs, WheelSample};

use super::config::TopicsConfig;
use super::course::{self, Judged};
use super::frames::{conj, from_rpy, mul, rpy_of, Quat, IDENTITY};
use super::live::LiveRow;
use super::mount::{
    gravity_off_vertical, mounting_from_data, rotate_imu, tread_difference, turn_correlation,
};

/// Length of a check window, s (whole seconds).
pub const SPAN: f64 = 60.0;
/// Stamp time past a window's end before it is judged, s.
pub const MARGIN: f64 = 2.0;
/// Windows in a row that must contradict a decision before it is made again.
pub const IN_A_ROW: usize = 2;
/// Samples of the IMU a window needs to tell anything of its mounting.
const MIN_IMU: usize = 50;
/// Least scatter (standard deviation, m/s) of the tread speed difference
/// for the gyro's turn to be judged: the robot turns in the window.
const MIN_TURNING: f64 = 0.02;
/// A rotated gyro that turns against the treads this clearly contradicts
/// the mounting (the first decision turns it 180° below the same value).
const AGAINST: f64 = -0.3;

/// One decision made again: when (s on the rows' clock, and ns since the
/// epoch) and the `decided:` line that says what changed and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Revision {
    pub t: f64,
    pub stamp_ns: u64,
    pub line: String,
}

/// Rows of one check window, as the import made them.
#[derive(Default)]
struct Window {
    imu: Vec<ImuSample>,
    wheels: Vec<WheelSample>,
    pose: Vec<PoseObs>,
}

/// An IMU's mounting found from the data, watched.
struct MountWatch {
    topic: String,
    base: String,
    /// The mounting the import applied (`base ← sensor`).
    first: Quat,
    /// The mounting now (`base ← sensor`), and the rotation from the
    /// import's base frame to it, from each stamp (s) on.
    now: Quat,
    schedule: Vec<(f64, Quat)>,
    against: usize,
}

/// A heading kept because it agreed with the GNSS course, watched.
struct HeadingWatch {
    topic: String,
    /// Left out from this time on (s).
    left_out_from: Option<f64>,
    against: usize,
}

/// The decisions a window of data can contradict, watched over a run.
pub struct Revisit {
    /// Where the epoch's windows start on the rows' clock, s into a window.
    phase: f64,
    origin_ns: u64,
    mount: Option<MountWatch>,
    heading: Option<HeadingWatch>,
    windows: BTreeMap<i64, Window>,
    /// Windows before this one are judged.
    judged: i64,
    revisions: Vec<Revision>,
    told: usize,
}

impl Revisit {
    /// What to watch of the streams read with `settled` (the topics file
    /// the decisions were written into) when `given` (the user's topics
    /// file) left it open: the IMU's mounting when it was found from the
    /// data, the heading when it was kept by the course check. `origin_ns`:
    /// time 0 of the rows, ns since the epoch. `None` when nothing is
    /// watched.
    pub fn new(given: &TopicsConfig, settled: &TopicsConfig, origin_ns: u64) -> Option<Self> {
        let named = |t: &Option<String>| t.clone().filter(|t| !t.is_empty());
        let mount = match (given.imu.mount_rpy_deg, settled.imu.mount_rpy_deg) {
            (None, Some([r, p, y])) => named(&settled.imu.topic).map(|topic| {
                let q = from_rpy(r.to_radians(), p.to_radians(), y.to_radians());
                MountWatch {
                    topic,
                    base: settled.tf.base_frame.clone(),
                    first: q,
                    now: q,
                    schedule: Vec::new(),
                    against: 0,
                }
            }),
            _ => None,
        };
        let heading = match (&given.heading.topic, named(&settled.heading.topic)) {
            (None, Some(topic)) if named(&settled.pose.topic).is_some() => Some(HeadingWatch {
                topic,
                left_out_from: None,
                against: 0,
            }),
            _ => None,
        };
        if mount.is_none() && heading.is_none() {
            return None;
        }
        let span_ns = (SPAN * 1e9) as u64;
        Some(Self {
            phase: (origin_ns % span_ns) as f64 * 1e-9,
            origin_ns,
            mount,
            heading,
            windows: BTreeMap::new(),
            judged: i64::MIN,
            revisions: Vec::new(),
            told: 0,
        })
    }

    /// The window a row at `t` s belongs to.
    fn window_of(&self, t: f64) -> i64 {
        ((t + self.phase) / SPAN).floor() as i64
    }

    /// When window `k` ends, s on the rows' clock.
    fn end_of(&self, k: i64) -> f64 {
        (k + 1) as f64 * SPAN - self.phase
    }

    /// Takes the next row as the import made it and returns it as the
    /// estimator is to see it (`None`: left out): windows due are judged
    /// first, then what was decided again is applied to it.
    pub fn row(&mut self, mut row: LiveRow) -> Option<LiveRow> {
        let t = row.t();
        if !t.is_finite() {
            return Some(row);
        }
        while let Some((&k, _)) = self.windows.first_key_value() {
            if t < self.end_of(k) + MARGIN {
                break;
            }
            let w = self.windows.remove(&k).unwrap_or_default();
            self.judge(k, &w);
            self.judged = k + 1;
        }
        let k = self.window_of(t);
        if k >= self.judged {
            let w = self.windows.entry(k).or_default();
            match &row {
                LiveRow::Wheels(s) => w.wheels.push(*s),
                LiveRow::Imu(s) if self.mount.is_some() => w.imu.push(*s),
                LiveRow::Pose(p) if self.heading.is_some() => w.pose.push(*p),
                _ => {}
            }
        }
        match &mut row {
            LiveRow::Imu(s) => {
                let q = self.mount.as_ref().and_then(|m| {
                    let i = m.schedule.partition_point(|(from, _)| *from <= t);
                    i.checked_sub(1).map(|i| m.schedule[i].1)
                });
                if let Some(q) = q {
                    rotate_imu(q, std::slice::from_mut(s));
                }
            }
            LiveRow::Pose(p) => {
                let out = self.heading.as_ref().and_then(|h| h.left_out_from);
                if out.is_some_and(|from| t >= from) {
                    (p.yaw, p.std_yaw) = (None, None);
                    // A row left with no position is left out.
                    p.east?;
                }
            }
            LiveRow::Wheels(_) => {}
        }
        Some(row)
    }

    /// Every decision made again so far.
    pub fn revisions(&self) -> &[Revision] {
        &self.revisions
    }

    /// The decisions made again since the last call.
    pub fn take_new(&mut self) -> Vec<Revision> {
        let new = self.revisions[self.told..].to_vec();
        self.told = self.revisions.len();
        new
    }

    /// Runs the tests on window `k` and makes a decision again when it is
    /// contradicted [`IN_A_ROW`] times in a row.
    fn judge(&mut self, k: i64, w: &Window) {
        let from = self.end_of(k) + MARGIN;
        let (a, b) = (self.end_of(k) - SPAN, self.end_of(k));
        let stamp_ns = self.origin_ns as i128 + (from * 1e9).round() as i128;
        let stamp_ns = stamp_ns.max(0) as u64;
        let stamp = format!(
            "{}.{:03}",
            stamp_ns / 1_000_000_000,
            stamp_ns % 1_000_000_000 / 1_000_000
        );
        let mut said = Vec::new();
        if let Some(m) = &mut self.mount {
            if let Some(line) = m.judge(w, (a, b, from), &stamp) {
                said.push(line);
            }
        }
        if let Some(h) = self.heading.as_mut().filter(|h| h.left_out_from.is_none()) {
            if let Some(line) = h.judge(w, (a, b, from), &stamp) {
                said.push(line);
            }
        }
        self.revisions.extend(said.into_iter().map(|line| Revision {
            t: from,
            stamp_ns,
            line,
        }));
    }
}

/// What a window says of a decision.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Verdict {
    Agrees,
    Contradicts,
    Untold,
}

/// Counts a verdict; whether the decision is now to be made again.
fn count(against: &mut usize, v: Verdict) -> bool {
    match v {
        Verdict::Agrees => *against = 0,
        Verdict::Contradicts => *against += 1,
        Verdict::Untold => {}
    }
    *against >= IN_A_ROW
}

impl MountWatch {
    /// The window's IMU samples in the sensor's frame.
    fn sensor_frame(&self, w: &Window) -> Vec<ImuSample> {
        let mut imu = w.imu.clone();
        rotate_imu(conj(self.first), &mut imu);
        imu
    }

    /// Gravity and the gyro's turn under the mounting `q`, and why they
    /// contradict it (`None`: they do not).
    fn verdict(q: Quat, imu: &[ImuSample], w: &Window) -> (Verdict, String) {
        if imu.len() < MIN_IMU {
            return (Verdict::Untold, String::new());
        }
        let mut base = imu.to_vec();
        rotate_imu(q, &mut base);
        if let Some(g) = gravity_off_vertical(&base) {
            let why = format!(
                "gravity ({:.1}, {:.1}, {:.1}) m/s² is not along +z",
                g[0], g[1], g[2]
            );
            return (Verdict::Contradicts, why);
        }
        let diff_v = tread_difference(&w.wheels);
        let n = diff_v.len() as f64;
        let mean = diff_v.iter().map(|d| d.1).sum::<f64>() / n.max(1.0);
        let var = diff_v.iter().map(|d| (d.1 - mean).powi(2)).sum::<f64>() / n.max(1.0);
        if var.sqrt() < MIN_TURNING {
            return (Verdict::Untold, String::new());
        }
        let r = turn_correlation(IDENTITY, &base, &diff_v);
        if r < AGAINST {
            let why = format!("the gyro turns against the treads (correlation {r:.2})");
            return (Verdict::Contradicts, why);
        }
        (Verdict::Agrees, String::new())
    }

    /// Judges window `w` (`a`..`b` s, a new decision applying from `from`
    /// s, stamped `stamp`); the `decided:` line when the mounting is made
    /// again.
    fn judge(&mut self, w: &Window, (a, b, from): (f64, f64, f64), stamp: &str) -> Option<String> {
        let imu = self.sensor_frame(w);
        let (v, why) = Self::verdict(self.now, &imu, w);
        if !count(&mut self.against, v) {
            return None;
        }
        let (q, how) = mounting_from_data(&imu, &w.wheels)?;
        if Self::verdict(q, &imu, w).0 == Verdict::Contradicts {
            return None;
        }
        self.against = 0;
        self.now = q;
        self.schedule.push((from, mul(q, conj(self.first))));
        let deg = |q: Quat| rpy_of(q).map(|a| (a.to_degrees() * 10.0).round() / 10.0 + 0.0);
        let [r, p, y] = deg(q);
        Some(format!(
            "{} mounting revisited at stamp {stamp} s (t = {from:.1} s): {why} on {IN_A_ROW} windows of {SPAN} s in a row; found again from {a:.0}-{b:.0} s: mounted roll {r:.1}°, pitch {p:.1}°, yaw {y:.1}° in {} ({how})",
            self.topic, self.base
        ))
    }
}

impl HeadingWatch {
    /// Judges window `w` as [`MountWatch::judge`] does; the `decided:`
    /// line when the heading is left out.
    fn judge(&mut self, w: &Window, (a, b, from): (f64, f64, f64), stamp: &str) -> Option<String> {
        let (v, judged) = match course::judge(&w.pose) {
            Ok(j) if j.agrees => (Verdict::Agrees, Some(j)),
            Ok(j) => (Verdict::Contradicts, Some(j)),
            Err(_) => (Verdict::Untold, None),
        };
        if !count(&mut self.against, v) {
            return None;
        }
        let Judged {
            offset_deg,
            scatter,
            n,
            ..
        } = judged?;
        self.left_out_from = Some(from);
        Some(format!(
            "{} heading revisited at stamp {stamp} s (t = {from:.1} s): left out from then on: on {IN_A_ROW} windows of {SPAN} s in a row it disagrees with the GNSS course; over {a:.0}-{b:.0} s it is {offset_deg:.1}° from it with a scatter of {scatter:.1}° on {n} straight stretches, {}",
            self.topic,
            course::disagreement(&judged?)
        ))
    }
}

/// A log's rows passed through `revisit` in stamp order (wheels, then
/// pose, then IMU rows at the same stamp), as a live node passes them:
/// IMU rows remounted and heading rows left out as it decides.
pub fn revisit_log(log: &mut DriveLog, revisit: &mut Revisit) {
    let mut order: Vec<(f64, u8, usize)> = Vec::new();
    order.extend(log.wheels.iter().enumerate().map(|(i, w)| (w.t, 0, i)));
    order.extend(log.pose.iter().enumerate().map(|(i, p)| (p.t, 1, i)));
    order.extend(log.imu.iter().enumerate().map(|(i, s)| (s.t, 2, i)));
    order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut keep = vec![true; log.pose.len()];
    for (_, stream, i) in order {
        let row = match stream {
            0 => LiveRow::Wheels(log.wheels[i]),
            1 => LiveRow::Pose(log.pose[i]),
            _ => LiveRow::Imu(log.imu[i]),
        };
        match revisit.row(row) {
            Some(LiveRow::Imu(s)) => log.imu[i] = s,
            Some(LiveRow::Pose(p)) => log.pose[i] = p,
            Some(LiveRow::Wheels(_)) => {}
            None => keep[i] = false,
        }
    }
    let mut k = keep.into_iter();
    log.pose.retain(|_| k.next().unwrap_or(true));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drive of `seconds` s at 10 Hz: legs of 20 s straight at 1 m/s,
    /// each followed by a turn of 5 s at 0.3 rad/s. The heading rows are
    /// `offset(t)` rad off the truth; the IMU lies on its side while
    /// `side(t)`.
    fn drive(seconds: usize, offset: impl Fn(f64) -> f64, side: impl Fn(f64) -> bool) -> DriveLog {
        let mut log = DriveLog::default();
        let (mut x, mut y, mut yaw) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..seconds * 10 {
            let t = i as f64 * 0.1;
            let wz = if t % 25.0 >= 20.0 { 0.3 } else { 0.0 };
            log.wheels.push(WheelSample {
                t,
                v_left: 1.0 - 0.25 * wz,
                v_right: 1.0 + 0.25 * wz,
            });
            let (g, w) = ([0.0, 0.0, 9.81], [0.0, 0.0, wz]);
            let on = |[a, b, c]: [f64; 3]| if side(t) { [a, c, -b] } else { [a, b, c] };
            let (g, w) = (on(g), on(w));
            log.imu.push(ImuSample {
                t,
                accel_x: Some(g[0]),
                accel_y: Some(g[1]),
                accel_z: g[2],
                gyro_x: Some(w[0]),
                gyro_y: Some(w[1]),
                gyro_z: Some(w[2]),
            });
            if i % 10 == 0 {
                log.pose.push(PoseObs {
                    t,
                    east: Some(x),
                    north: Some(y),
                    ..Default::default()
                });
            }
            log.pose.push(PoseObs {
                t: t + 0.05,
                yaw: Some(yaw + offset(t)),
                ..Default::default()
            });
            x += 0.1 * yaw.cos();
            y += 0.1 * yaw.sin();
            yaw += 0.1 * wz;
        }
        log
    }

    /// The topics file a choice settles: an IMU mounted upright (found from
    /// the data), a heading kept, a GNSS pose.
    fn settled() -> TopicsConfig {
        let mut c = TopicsConfig::default();
        c.imu.topic = Some("/imu".into());
        c.imu.mount_rpy_deg = Some([0.0, 0.0, 0.0]);
        c.heading.topic = Some("/heading".into());
        c.pose.topic = Some("/fix".into());
        c
    }

    fn revisited(log: &mut DriveLog) -> Vec<Revision> {
        let mut r = Revisit::new(
            &TopicsConfig::default(),
            &settled(),
            1_700_000_000_000_000_000,
        )
        .expect("watched");
        revisit_log(log, &mut r);
        r.revisions().to_vec()
    }

    #[test]
    fn a_drive_that_contradicts_nothing_is_not_revisited() {
        let mut log = drive(900, |_| 0.02, |_| false);
        let before = log.clone();
        assert_eq!(revisited(&mut log), Vec::new());
        assert_eq!(log, before);
    }

    #[test]
    fn one_contradicting_window_is_not_enough() {
        // On its side for 40 s: one window of 60 s sees it.
        let mut log = drive(900, |_| 0.0, |t| (130.0..170.0).contains(&t));
        assert_eq!(revisited(&mut log), Vec::new());
    }

    #[test]
    fn a_remounted_imu_is_mounted_again_from_a_stamp_on() {
        let mut log = drive(900, |_| 0.0, |t| t >= 330.0);
        let r = revisited(&mut log);
        assert_eq!(r.len(), 1, "{r:?}");
        // Windows start on the epoch's minutes: 1_700_000_000 s is 20 s
        // into one, so they end at 40 + 60 k s; 340-400 and 400-460 s
        // contradict the mounting, which applies again from 462 s.
        assert_eq!(r[0].t, 462.0);
        assert_eq!(r[0].stamp_ns, 1_700_000_462_000_000_000);
        assert!(r[0].line.contains("roll 90.0°"), "{}", r[0].line);
        let g = |t: f64| log.imu.iter().find(|s| s.t >= t).map(|s| s.accel_z);
        assert_eq!(g(300.0), Some(9.81));
        assert!(g(420.0).is_some_and(|z| z.abs() < 1e-9));
        assert!(g(462.0).is_some_and(|z| (z - 9.81).abs() < 1e-9));
    }

    #[test]
    fn a_heading_that_goes_bad_is_left_out_from_a_stamp_on() {
        let bad = |t: f64| if t >= 400.0 { 1.0 } else { 0.0 };
        let mut log = drive(900, bad, |_| false);
        let r = revisited(&mut log);
        assert_eq!(r.len(), 1, "{r:?}");
        let from = r[0].t;
        assert!(from > 400.0 && from < 400.0 + 3.0 * SPAN + MARGIN, "{from}");
        assert!(
            r[0].line.contains("/heading heading revisited"),
            "{}",
            r[0].line
        );
        assert!(log.pose.iter().all(|p| p.t < from || p.yaw.is_none()));
        assert!(log.pose.iter().all(|p| p.yaw.is_some() || p.east.is_some()));
        assert!(log.pose.iter().any(|p| p.t < from && p.yaw.is_some()));
    }
}
