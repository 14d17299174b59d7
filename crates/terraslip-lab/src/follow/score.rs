//! How well one run followed the course, against the true pose, per ground.

use terraslip_core::angle::wrap;
use terraslip_sim::TruthState;

use super::course::Course;

/// Window of the moving RMS the recovery is judged on, s.
pub const RECOVERY_WINDOW: f64 = 2.0;
/// "Back" means the moving RMS within this multiple of its settled value.
pub const RECOVERY_FACTOR: f64 = 1.5;

/// The figures of one ground in one run.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct GroundScore {
    /// RMS of the cross-track distance, m.
    pub cross_track_rms_m: f64,
    /// RMS of the heading error where each turn of the ground ends, deg.
    pub turn_heading_deg: f64,
    /// Time from entering the ground to leaving it (or finishing), s.
    pub time_s: f64,
    /// After crossing onto this ground, the time until the cross-track
    /// error's moving RMS (over [`RECOVERY_WINDOW`] s) is back within
    /// [`RECOVERY_FACTOR`] x its settled value (the largest it reaches on
    /// the ground's second lap, the same turns again) for the rest of the
    /// first lap, s. NaN on the first ground or when not reached.
    pub recovery_s: f64,
}

/// The figures of one run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunScore {
    pub grounds: Vec<GroundScore>,
    /// RMS cross-track over the whole course, m.
    pub cross_track_rms_m: f64,
    /// Time to finish, s (infinite when the goal was not reached).
    pub time_s: f64,
}

/// Scores `truth` (the run, ended at `finished` s when the goal was
/// reached) against `course`.
pub fn score(course: &Course, truth: &[TruthState], finished: Option<f64>) -> RunScore {
    let n_g = course.grounds.len();
    // (t, s, cross-track) of every truth sample.
    let mut progress = 0;
    let track: Vec<(f64, f64, f64, f64)> = truth
        .iter()
        .map(|x| {
            let (i, e) = course.project(x.east, x.north, progress, 3.0);
            progress = i;
            (x.t, course.points[i].s, e, x.yaw)
        })
        .collect();
    let end_t = track.last().map_or(0.0, |x| x.0);
    let entry = |g: usize| {
        track
            .iter()
            .find(|x| course.ground_of(x.1) >= g)
            .map_or(f64::NAN, |x| x.0)
    };
    let mut grounds = Vec::with_capacity(n_g);
    for g in 0..n_g {
        let t0 = entry(g);
        let t1 = if g + 1 < n_g { entry(g + 1) } else { end_t };
        let t1 = if t1.is_nan() { end_t } else { t1 };
        let on: Vec<&(f64, f64, f64, f64)> =
            track.iter().filter(|x| x.0 >= t0 && x.0 < t1).collect();
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        let cross: Vec<f64> = on.iter().map(|x| x.2).collect();
        let turns: Vec<f64> = course
            .turn_ends
            .iter()
            .filter(|te| te.ground == g)
            .filter_map(|te| {
                track
                    .iter()
                    .find(|x| x.1 >= te.s)
                    .map(|x| wrap(x.3 - te.heading).to_degrees())
            })
            .collect();
        let recovery_s = if g == 0 {
            f64::NAN
        } else {
            let g_end = course
                .ground_s
                .get(g + 1)
                .copied()
                .unwrap_or(course.length());
            let mid = 0.5 * (course.ground_s[g] + g_end);
            let t_mid = track.iter().find(|x| x.1 >= mid).map_or(f64::NAN, |x| x.0);
            recovery(&track, t0, t_mid, t1)
        };
        grounds.push(GroundScore {
            cross_track_rms_m: rms(&cross),
            turn_heading_deg: rms(&turns),
            time_s: t1 - t0,
            recovery_s,
        });
    }
    let all: Vec<f64> = track.iter().map(|x| x.2).collect();
    RunScore {
        grounds,
        cross_track_rms_m: (all.iter().map(|x| x * x).sum::<f64>() / all.len().max(1) as f64)
            .sqrt(),
        time_s: finished.unwrap_or(f64::INFINITY),
    }
}

/// The recovery time after a change at `t0`: the first lap is
/// `[t0, t_mid)`, the second (settled) `[t_mid, t1)`.
fn recovery(track: &[(f64, f64, f64, f64)], t0: f64, t_mid: f64, t1: f64) -> f64 {
    if !(t0 < t_mid && t_mid < t1) {
        return f64::NAN;
    }
    // Moving RMS at each sample, over the trailing window.
    let mut moving = Vec::with_capacity(track.len());
    let (mut lo, mut sum) = (0, 0.0);
    for (k, x) in track.iter().enumerate() {
        sum += x.2 * x.2;
        while track[lo].0 <= x.0 - RECOVERY_WINDOW {
            sum -= track[lo].2 * track[lo].2;
            lo += 1;
        }
        moving.push((x.0, (sum.max(0.0) / (k + 1 - lo) as f64).sqrt()));
    }
    let settled = moving
        .iter()
        .filter(|m| m.0 >= t_mid + RECOVERY_WINDOW && m.0 < t1)
        .map(|m| m.1)
        .fold(f64::NAN, f64::max);
    if settled.is_nan() {
        return f64::NAN;
    }
    let last_out = moving
        .iter()
        .filter(|m| m.0 >= t0 && m.0 < t_mid && m.1 > RECOVERY_FACTOR * settled)
        .map(|m| m.0)
        .fold(f64::NAN, f64::max);
    if last_out.is_nan() {
        0.0
    } else {
        last_out - t0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovery_is_the_last_time_the_error_was_out() {
        // 50 Hz; error 0.3 m for the first 3 s after the change at 10 s,
        // then 0.05 m, the second lap from 20 s at 0.05 m.
        let track: Vec<(f64, f64, f64, f64)> = (0..2000)
            .map(|k| {
                let t = k as f64 * 0.02;
                let e = if (10.0..13.0).contains(&t) { 0.3 } else { 0.05 };
                (t, t, e, 0.0)
            })
            .collect();
        let r = recovery(&track, 10.0, 20.0, 30.0);
        // The 2 s moving RMS stays above 0.075 m until well after 13 s.
        assert!(r > 3.0 && r < 3.0 + RECOVERY_WINDOW, "{r}");
        assert!(recovery(&track, 10.0, 9.0, 30.0).is_nan());
    }
}
