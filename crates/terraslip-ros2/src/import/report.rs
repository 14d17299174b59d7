//! What an import did: one line per stream, counts, rates and gaps.

use std::fmt::Write as _;
use std::path::PathBuf;

/// [`StreamReport::file`] of a heading topic's rows.
pub(super) const HEADING_FILE: &str = "pose.csv (yaw)";

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
    /// Why the rows were left out of the log after all (a heading that
    /// disagrees with the GNSS course); `None` when they are in it.
    pub left_out: Option<String>,
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
    /// How IMU topics were rotated into the base frame, one line each.
    pub mounts: Vec<String>,
    /// What the import decided that the bag does not state (the tread
    /// speeds' scale, a mounting found from the data, a heading left out),
    /// and how sure it is, one line each.
    pub decisions: Vec<String>,
    /// Decisions made from the data and made again when later windows
    /// contradicted them (`super::revisit`), one line each (also among
    /// `decisions`).
    pub revisited: Vec<String>,
    /// Every topic of the bag: name, type, messages.
    pub topics: Vec<(String, String, u64)>,
    /// Messages that made no row because they cannot be physical (not
    /// finite, beyond the log's physical range, a stamp out of order).
    pub skipped: Vec<super::SkippedMessage>,
    pub warnings: Vec<String>,
}

impl ImportReport {
    /// One line per stream: topic → file, counts, rate, gaps; then the
    /// IMU mountings.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        for r in &self.streams {
            if let Some(why) = &r.left_out {
                let _ = writeln!(
                    s,
                    "{} ({}) -> {}: left out ({why}), {} messages",
                    r.topic, r.ty, r.file, r.messages
                );
                continue;
            }
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
        for m in &self.mounts {
            let _ = writeln!(s, "{m}");
        }
        for d in &self.decisions {
            let _ = writeln!(s, "decided: {d}");
        }
        s
    }
}

pub(super) fn stream_report(
    file: &str,
    topic: &crate::Topic,
    ty: &str,
    times: &[f64],
) -> StreamReport {
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
        left_out: None,
    }
}
