//! Whether a heading topic agrees with the course of the GNSS fixes, as a
//! person would judge after plotting the two (scripts/ros2-course-check.py).
//!
//! Over straight-ish stretches (10 s in which the heading turns less than
//! 0.1 rad and the fixes move more than 7 m), the direction of the chord
//! between the first and last fix is the course, good to about 0.1 rad
//! with metre-level GNSS. The heading is compared with it at the stretch's
//! middle (a robot drives forwards on most of them). A heading whose median
//! difference from the course exceeds 20°, or whose differences scatter by
//! more than 15° (median absolute deviation: an uncalibrated magnetometer is
//! off by different amounts in different directions), is left out with a
//! warning. Fewer than 3 stretches decide nothing.

use terraslip_io::PoseObs;

use super::report::ImportReport;

/// Stretch length, s; least chord, m; most heading change, rad.
const STRETCH_S: f64 = 10.0;
const MIN_CHORD_M: f64 = 7.0;
const MAX_TURN_RAD: f64 = 0.1;
/// Largest median offset and scatter a usable heading shows, degrees.
const MAX_OFFSET_DEG: f64 = 20.0;
const MAX_SCATTER_DEG: f64 = 15.0;

fn wrap(a: f64) -> f64 {
    let r = a.rem_euclid(std::f64::consts::TAU);
    if r > std::f64::consts::PI {
        r - std::f64::consts::TAU
    } else {
        r
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Heading minus course on each straight stretch, rad.
pub(super) fn differences(pose: &[PoseObs]) -> Vec<f64> {
    let mut fixes: Vec<(f64, f64, f64)> = pose
        .iter()
        .filter_map(|p| Some((p.t, p.east?, p.north?)))
        .collect();
    let mut yaws: Vec<(f64, f64)> = pose.iter().filter_map(|p| Some((p.t, p.yaw?))).collect();
    fixes.sort_by(|a, b| a.0.total_cmp(&b.0));
    yaws.sort_by(|a, b| a.0.total_cmp(&b.0));
    let yaw_at = |t: f64| {
        let i = yaws.partition_point(|y| y.0 < t);
        let y = yaws.get(i).or_else(|| yaws.get(i.wrapping_sub(1)))?;
        ((y.0 - t).abs() < 1.0).then_some(y.1)
    };
    let (Some(first), Some(last)) = (fixes.first(), fixes.last()) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let mut t = first.0;
    while t + STRETCH_S <= last.0 {
        let i0 = fixes.partition_point(|f| f.0 < t);
        let i1 = fixes.partition_point(|f| f.0 <= t + STRETCH_S);
        let straight = (i1 > i0 + 1)
            .then(|| {
                let (a, b) = (fixes[i0], fixes[i1 - 1]);
                let chord = (b.1 - a.1).hypot(b.2 - a.2);
                let (y0, ym, y1) = (yaw_at(a.0)?, yaw_at(0.5 * (a.0 + b.0))?, yaw_at(b.0)?);
                (chord > MIN_CHORD_M && wrap(y1 - y0).abs() < MAX_TURN_RAD)
                    .then(|| wrap(ym - (b.2 - a.2).atan2(b.1 - a.1)))
            })
            .flatten();
        match straight {
            Some(d) => {
                out.push(d);
                t += STRETCH_S;
            }
            None => t += 1.0,
        }
    }
    out
}

/// How a heading compares with the GNSS course over some pose rows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Judged {
    /// Median heading minus course, degrees.
    pub offset_deg: f64,
    /// Median absolute deviation of the differences, degrees.
    pub scatter: f64,
    /// Straight stretches compared.
    pub n: usize,
    /// Whether the heading is usable (offset and scatter within bounds).
    pub agrees: bool,
}

/// The heading of `pose` against its fixes' course; `Err` with the
/// number of straight stretches when fewer than 3 tell.
pub(super) fn judge(pose: &[PoseObs]) -> Result<Judged, usize> {
    let d = differences(pose);
    if d.len() < 3 {
        return Err(d.len());
    }
    let offset = median(&mut d.clone());
    let mut dev: Vec<f64> = d.iter().map(|x| wrap(x - offset).abs()).collect();
    let scatter = median(&mut dev).to_degrees();
    let offset_deg = offset.to_degrees();
    Ok(Judged {
        offset_deg,
        scatter,
        n: d.len(),
        agrees: offset_deg.abs() <= MAX_OFFSET_DEG && scatter <= MAX_SCATTER_DEG,
    })
}

/// Why a heading that does not agree is not usable.
pub(super) fn disagreement(j: &Judged) -> &'static str {
    if j.scatter > MAX_SCATTER_DEG {
        "off by different amounts in different directions (an uncalibrated magnetometer?)"
    } else {
        "a constant offset (a wrong declination or yaw offset? set [heading] yaw_offset_deg / declination_deg to use it)"
    }
}

/// Leaves the heading rows of `pose` out (their yaw, and rows left with
/// nothing) when the heading disagrees with the fixes' course; says what
/// was decided either way. Returns whether the heading is kept.
pub(super) fn check_heading(
    pose: &mut Vec<PoseObs>,
    topic: &str,
    report: &mut ImportReport,
) -> bool {
    let j = match judge(pose) {
        Ok(j) => j,
        Err(n) => {
            report.decisions.push(format!(
                "{topic} heading kept unchecked: {n} straight stretches of {STRETCH_S} s over {MIN_CHORD_M} m to compare it with the GNSS course (3 needed)"
            ));
            return true;
        }
    };
    let Judged {
        offset_deg,
        scatter,
        n,
        ..
    } = j;
    if j.agrees {
        report.decisions.push(format!(
            "{topic} heading used: on {n} straight stretches it is {offset_deg:.1}° from the GNSS course (scatter {scatter:.1}°)"
        ));
        return true;
    }
    // With a GNSS pose, every yaw of pose.csv is the heading topic's.
    pose.retain_mut(|p| {
        (p.yaw, p.std_yaw) = (None, None);
        p.east.is_some()
    });
    let why = disagreement(&j);
    report.warnings.push(format!(
        "{topic}: heading left out: on {n} straight stretches it is {offset_deg:.1}° from the GNSS course with a scatter of {scatter:.1}°, {why}; the estimator learns the heading from the fixes (`[heading] topic = \"{topic}\"` keeps it)"
    ));
    let summary =
        format!("{offset_deg:.1}° from the GNSS course, scatter {scatter:.1}° over {n} stretches");
    for r in report.streams.iter_mut() {
        if r.topic == topic && r.file == super::report::HEADING_FILE {
            r.rows = 0;
            r.left_out = Some(format!("heading {summary}; see the warning"));
        }
    }
    report
        .decisions
        .push(format!("{topic} heading left out: {summary}"));
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drive of straight legs at 1 m/s turning 90° every 30 s, fixes at
    /// 2 Hz and headings at 10 Hz; `bias(course)` is the heading's error.
    fn drive(bias: impl Fn(f64) -> f64) -> Vec<PoseObs> {
        let mut pose = Vec::new();
        let (mut e, mut n) = (0.0, 0.0);
        for k in 0..3000 {
            let t = k as f64 * 0.1;
            let course = (t / 30.0).floor() * std::f64::consts::FRAC_PI_2;
            e += 0.1 * course.cos();
            n += 0.1 * course.sin();
            if k % 5 == 0 {
                pose.push(PoseObs {
                    t,
                    east: Some(e),
                    north: Some(n),
                    yaw: None,
                    std_xy: Some(0.5),
                    std_yaw: None,
                });
            }
            pose.push(PoseObs {
                t,
                east: None,
                north: None,
                yaw: Some(wrap(course + bias(course))),
                std_xy: None,
                std_yaw: Some(0.1),
            });
        }
        pose
    }

    #[test]
    fn a_heading_that_follows_the_course_is_kept() {
        let mut pose = drive(|_| 0.05);
        let mut report = ImportReport::default();
        check_heading(&mut pose, "/imu", &mut report);
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
        assert_eq!(pose.iter().filter(|p| p.yaw.is_some()).count(), 3000);
        assert!(
            report.decisions[0].contains("heading used"),
            "{:?}",
            report.decisions
        );
    }

    #[test]
    fn a_heading_biased_or_scattered_against_the_course_is_left_out() {
        for bias in [
            Box::new(|_: f64| 0.6) as Box<dyn Fn(f64) -> f64>,
            Box::new(|c: f64| 0.7 * c.sin()),
        ] {
            let mut pose = drive(bias);
            let fixes = pose.iter().filter(|p| p.east.is_some()).count();
            let mut report = ImportReport::default();
            let imu = crate::Topic {
                name: "/imu".into(),
                ty: "sensor_msgs/Imu".into(),
                definition: String::new(),
                count: 3000,
            };
            let times: Vec<f64> = (0..3000).map(|k| k as f64 * 0.1).collect();
            let r = super::super::report::stream_report(
                super::super::report::HEADING_FILE,
                &imu,
                &imu.ty,
                &times,
            );
            report.streams.push(r);
            check_heading(&mut pose, "/imu", &mut report);
            let w = report.warnings.join("\n");
            assert!(w.contains("/imu: heading left out"), "{w}");
            // The stream's line says so, not that it fed pose.csv.
            let text = report.to_text();
            assert!(
                text.contains("/imu (sensor_msgs/Imu) -> pose.csv (yaw): left out ("),
                "{text}"
            );
            assert!(pose.iter().all(|p| p.yaw.is_none()));
            assert_eq!(pose.len(), fixes);
        }
    }
}
