//! The best constant slip model for a drive's own outages, in hindsight:
//! a model's speed and turn rate each scaled by the factor (a grid of
//! [`STEP`] over [`RANGE`]) whose dead reckoning misses the scored span's
//! own 30 s outage ends least on average. Fitted on the very outages it is
//! scored on, it bounds what any model of that class (constant ICRs,
//! its turn law) reaches there.

use terraslip_calib::outage::{OutageEnd, OutageSpec, Start, Track};
use terraslip_calib::prediction::predict_with;
use terraslip_core::Twist;
use terraslip_io::{DriveLog, WheelSample};

/// Range of each scale.
pub const RANGE: (f64, f64) = (0.5, 1.5);
/// Step of the grid.
pub const STEP: f64 = 0.02;
/// The outage length the scales are chosen for, s.
const HORIZON: f64 = 30.0;

/// The scales (speed, turn rate) of `twist` with the least mean 30 s
/// outage error from `starts` on `log`, and the scaled model's ends at
/// every horizon. `None` without a 30 s end.
pub fn best_scaled(
    log: &DriveLog,
    twist: &dyn Fn(f64, &WheelSample) -> Twist,
    starts: &[Start],
) -> Option<((f64, f64), Vec<OutageEnd>)> {
    let gap = OutageSpec::default().max_gap;
    let track = Track::of(&log.pose);
    // The model's twist of every wheels row, once.
    let base: Vec<Twist> = log.wheels.iter().map(|w| twist(0.0, w)).collect();
    let at = |w: &WheelSample| {
        base[log
            .wheels
            .partition_point(|s| s.t < w.t)
            .min(base.len() - 1)]
    };
    let scaled = |(a, c): (f64, f64)| {
        move |w: &WheelSample| {
            let tw = at(w);
            Twist {
                v_x: a * tw.v_x,
                v_y: a * tw.v_y,
                omega: c * tw.omega,
            }
        }
    };
    let mean_30 = |k: (f64, f64)| {
        let f = scaled(k);
        let (mut sum, mut n) = (0.0, 0usize);
        for s in starts {
            let (east, north) = predict_with(
                &log.wheels,
                &f,
                s.t,
                s.t + HORIZON,
                (s.east, s.north, s.yaw),
            );
            let end = terraslip_calib::outage::End {
                east,
                north,
                cov: None,
            };
            if let Some(e) = track.score(s.t, HORIZON, s.clock, end, gap) {
                sum += e.error;
                n += 1;
            }
        }
        (n > 0).then(|| sum / n as f64)
    };
    let steps = ((RANGE.1 - RANGE.0) / STEP).round() as usize;
    let grid = (0..=steps).map(|k| RANGE.0 + k as f64 * STEP);
    let mut best: Option<((f64, f64), f64)> = None;
    for a in grid.clone() {
        for c in grid.clone() {
            if let Some(m) = mean_30((a, c)) {
                if best.is_none_or(|b| m < b.1) {
                    best = Some(((a, c), m));
                }
            }
        }
    }
    let (k, _) = best?;
    let f = scaled(k);
    let ends = track.fixed_model(&log.wheels, &|_, w| f(w), starts, gap);
    Some((k, ends))
}

#[cfg(test)]
mod tests {
    use super::*;
    use terraslip_io::PoseObs;

    #[test]
    fn the_scales_that_undo_a_model_s_error_are_found() {
        // Driving a circle of radius 20 m at 1 m/s; the model reads the
        // speed 20 % low and the turn rate 10 % high.
        let (v, r) = (1.0, 20.0);
        let mut log = DriveLog::default();
        for k in 0..=15000 {
            let t = k as f64 * 0.02;
            log.wheels.push(WheelSample {
                t,
                v_left: v,
                v_right: v,
            });
            if k % 5 == 0 {
                let th = v * t / r;
                log.pose.push(PoseObs {
                    t,
                    east: Some(r * th.sin()),
                    north: Some(r * (1.0 - th.cos())),
                    yaw: Some(th),
                    std_xy: None,
                    std_yaw: None,
                });
            }
        }
        let model = |_: f64, w: &WheelSample| Twist {
            v_x: 0.8 * 0.5 * (w.v_left + w.v_right),
            v_y: 0.0,
            omega: 1.1 * v / r,
        };
        let starts: Vec<Start> = [60.0, 120.0, 180.0]
            .iter()
            .map(|&t| {
                let th: f64 = v * t / r;
                Start {
                    t,
                    east: r * th.sin(),
                    north: r * (1.0 - th.cos()),
                    yaw: th,
                    clock: 0.0,
                }
            })
            .collect();
        let ((a, c), ends) = best_scaled(&log, &model, &starts).unwrap();
        assert!(
            (a - 1.25).abs() < 0.0125 && (c - 1.0 / 1.1).abs() < 0.0125,
            "{a} {c}"
        );
        let worst = ends
            .iter()
            .filter(|e| e.horizon == 30.0)
            .map(|e| e.error)
            .fold(0.0, f64::max);
        assert!(worst < 0.5, "{worst}");
    }
}
