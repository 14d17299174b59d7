//! How the gyro's clock sits against the wheels': found before the run
//! from the drive's first minutes, by lining the gyro's rate up with the
//! tread speed difference (a turn shows in both; a controller that stamps
//! its odometry late, or an IMU driver that stamps early, shifts one
//! against the other by tenths of a second, which over a turn is a heading
//! error the size of the turn's start).

use std::path::Path;

use terraslip_io::{GyroStream, LogError, PoseObs, PoseStream, WheelSample, WheelStream};

/// Seconds of drive looked at.
pub const SPAN: f64 = 300.0;
/// Largest delay searched, s, and the grid step.
pub const MAX_DELAY: f64 = 1.0;
const STEP: f64 = 0.02;
/// Smallest correlation taken as evidence.
const MIN_CORRELATION: f64 = 0.5;
/// Smallest std of the tread speed difference (m/s): a drive that does not
/// turn cannot tell.
const MIN_TURNING: f64 = 0.02;

/// What the drive's first minutes say of the gyro.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GyroClock {
    /// The wheels are stamped `wheels_late_by` s late against the gyro;
    /// at that delay the gyro's rate is `gyro_per_tread` (1/m) times the
    /// tread speed difference, least squares: `1 / gyro_per_tread` is the
    /// spread the gyro's turns show (m, in the tread speeds' scale).
    Delay {
        wheels_late_by: f64,
        gyro_per_tread: f64,
    },
    /// The drive turns too little to tell (or has no gyro): taken as 0.
    Unknown,
    /// The drive turns, but the gyro's rate does not follow the tread speed
    /// difference at any delay (its best correlation): not the yaw rate of
    /// the body (a mounting not applied, an axis or sign flipped).
    NotYaw(f64),
    /// The gyro does not follow the tread speed difference (`wheels`, its
    /// best correlation), but it follows the pose reference's yaw rate
    /// (correlation `gyro_ref`) and the wheels do not (`wheels_ref`): the
    /// treads slip (a robot held or dragged while its wheels spin). The
    /// gyro is the body's yaw rate and is kept, its clock taken as the
    /// wheels'.
    Slipping {
        wheels: f64,
        gyro_ref: f64,
        wheels_ref: f64,
    },
    /// The gyro does not follow the tread speed difference (`wheels`) and
    /// the pose reference's yaw rate backs the wheels (`wheels_ref`), not
    /// the gyro (`gyro_ref`): the gyro is faulty or mounted wrongly.
    Faulty {
        wheels: f64,
        gyro_ref: f64,
        wheels_ref: f64,
    },
}

/// Seconds over which the pose reference's yaw rate is taken (a heading
/// difference over this span; shorter spans are the heading noise's).
const REFERENCE_RATE_SPAN: f64 = 0.5;

/// How late the wheels are stamped against the gyro: the delay `tau`
/// within +-[`MAX_DELAY`] for which the gyro's rate at `t - tau` best
/// correlates with `v_right - v_left` at `t` over the first [`SPAN`] s.
/// Rows that cannot be read are skipped here (the run reports them).
pub fn gyro_delay(
    wheels: &mut dyn Iterator<Item = Result<WheelSample, LogError>>,
    gyro: &mut dyn Iterator<Item = Result<(f64, f64), LogError>>,
) -> GyroClock {
    let (w, g) = first_minutes(wheels, gyro);
    clock_of(&w, &g)
}

/// [`gyro_delay`], with the pose reference's headings as arbiter where the
/// gyro does not follow the tread speed difference: the one of gyro and
/// wheels whose turns the reference's yaw rate follows (correlation at
/// least 0.5, and above the other's) is believed ([`GyroClock::Slipping`]
/// or [`GyroClock::Faulty`]). Without headings in the reference the
/// answer is [`gyro_delay`]'s.
pub fn gyro_delay_referenced(
    wheels: &mut dyn Iterator<Item = Result<WheelSample, LogError>>,
    gyro: &mut dyn Iterator<Item = Result<(f64, f64), LogError>>,
    pose: &mut dyn Iterator<Item = Result<PoseObs, LogError>>,
) -> GyroClock {
    let (w, g) = first_minutes(wheels, gyro);
    let clock = clock_of(&w, &g);
    let GyroClock::NotYaw(c) = clock else {
        return clock;
    };
    let Some(&(t_end, _)) = w.last() else {
        return clock;
    };
    let reference = reference_rate(pose, t_end);
    let gyro_ref = fit(&reference, &g, 0.0).0;
    let wheels_ref = fit(&reference, &w, 0.0).0;
    let backs = |a: f64, b: f64| a >= MIN_CORRELATION && (a > b || !b.is_finite());
    if backs(gyro_ref, wheels_ref) {
        GyroClock::Slipping {
            wheels: c,
            gyro_ref,
            wheels_ref,
        }
    } else if backs(wheels_ref, gyro_ref) {
        GyroClock::Faulty {
            wheels: c,
            gyro_ref,
            wheels_ref,
        }
    } else {
        clock
    }
}

/// The pose reference's yaw rate (rad/s) up to `t_end`: each heading's
/// change to the first heading at least [`REFERENCE_RATE_SPAN`] s later,
/// at the middle of the two stamps.
fn reference_rate(
    pose: &mut dyn Iterator<Item = Result<PoseObs, LogError>>,
    t_end: f64,
) -> Vec<(f64, f64)> {
    let yaws: Vec<(f64, f64)> = pose
        .flatten()
        .take_while(|p| p.t <= t_end + MAX_DELAY)
        .filter_map(|p| p.yaw.map(|y| (p.t, y)))
        .filter(|(t, y)| t.is_finite() && y.is_finite())
        .collect();
    let mut out = Vec::new();
    let mut j = 0;
    for (i, &(t0, y0)) in yaws.iter().enumerate() {
        j = j.max(i + 1);
        while j < yaws.len() && yaws[j].0 - t0 < REFERENCE_RATE_SPAN {
            j += 1;
        }
        let Some(&(t1, y1)) = yaws.get(j) else { break };
        if t1 - t0 <= 2.0 * REFERENCE_RATE_SPAN {
            let turn = terraslip_core::angle::wrap(y1 - y0);
            out.push((0.5 * (t0 + t1), turn / (t1 - t0)));
        }
    }
    out
}

/// The tread speed differences `(t, v_right - v_left)` of the first
/// [`SPAN`] s and the gyro's rates up to their end (unreadable rows
/// skipped).
#[allow(clippy::type_complexity)]
fn first_minutes(
    wheels: &mut dyn Iterator<Item = Result<WheelSample, LogError>>,
    gyro: &mut dyn Iterator<Item = Result<(f64, f64), LogError>>,
) -> (Vec<(f64, f64)>, Vec<(f64, f64)>) {
    let w: Vec<(f64, f64)> = {
        let mut out = Vec::new();
        for s in wheels.flatten() {
            if out.first().is_some_and(|&(t0, _)| s.t - t0 > SPAN) {
                break;
            }
            out.push((s.t, s.v_right - s.v_left));
        }
        out
    };
    let Some(&(t_end, _)) = w.last() else {
        return (w, Vec::new());
    };
    let g: Vec<(f64, f64)> = gyro
        .flatten()
        .take_while(|&(t, _)| t <= t_end + MAX_DELAY)
        .filter(|(t, r)| t.is_finite() && r.is_finite())
        .collect();
    (w, g)
}

/// What the tread speed differences `w` and the gyro's rates `g` say of
/// the gyro (see [`gyro_delay`]).
fn clock_of(w: &[(f64, f64)], g: &[(f64, f64)]) -> GyroClock {
    if g.len() < 10 || w.len() < 10 {
        return GyroClock::Unknown;
    }
    let n = (2.0 * MAX_DELAY / STEP).round() as usize + 1;
    let corr: Vec<f64> = (0..n)
        .map(|i| fit(w, g, -MAX_DELAY + i as f64 * STEP).0)
        .collect();
    let Some((best, &c)) = corr
        .iter()
        .enumerate()
        .filter(|(_, c)| c.is_finite())
        .max_by(|a, b| a.1.total_cmp(b.1))
    else {
        return GyroClock::Unknown;
    };
    if c < MIN_CORRELATION {
        return GyroClock::NotYaw(c);
    }
    // The peak between grid points (a parabola through three).
    let mut tau = -MAX_DELAY + best as f64 * STEP;
    if best > 0 && best + 1 < n {
        let (a, b, d) = (corr[best - 1], c, corr[best + 1]);
        let den = a - 2.0 * b + d;
        if den < 0.0 {
            tau += STEP * (0.5 * (a - d) / den).clamp(-0.5, 0.5);
        }
    }
    GyroClock::Delay {
        wheels_late_by: tau,
        gyro_per_tread: fit(w, g, tau).1,
    }
}

/// The warning when the gyro's turns show a spread (`1 /
/// gyro_per_tread`, m) outside the band `min_spread..max_spread` (m) the
/// slip model holds for this track width: the estimate cannot follow the
/// gyro, whether the ground slips more than the band allows or the wheels'
/// turn is wrong.
pub fn turn_disagreement(
    dir: &str,
    gyro_per_tread: f64,
    track_width: f64,
    min_spread: f64,
    max_spread: f64,
) -> Option<String> {
    let spread = 1.0 / gyro_per_tread;
    if gyro_per_tread.is_finite() && (min_spread..=max_spread).contains(&spread) {
        return None;
    }
    Some(format!(
        "{dir}: the gyro turns {:.2} x what the tread speeds turn on a {track_width} m track: the spread its turns show, {spread:.2} m, lies outside the {min_spread:.2}-{max_spread:.2} m the slip model holds ([band] min_spread, max_spread times the track), so the estimate cannot follow the gyro. Either the ground lets the treads slip more than that (widen [band]), or the wheels' turn is wrong: check the track width (for an odometry twist, the separation its tread speeds were made with), the IMU's axes and the odometry",
        gyro_per_tread * track_width
    ))
}

/// [`gyro_delay_referenced`] of the log directory `dir`'s `wheels.csv`,
/// `imu.csv` and `pose.csv` (a second read of their start; unreadable
/// files tell nothing).
pub fn gyro_delay_in(dir: &Path) -> GyroClock {
    match (
        WheelStream::open(&dir.join("wheels.csv")),
        GyroStream::open(&dir.join("imu.csv")),
    ) {
        (Ok(mut w), Ok(mut g)) => match PoseStream::open(&dir.join("pose.csv")) {
            Ok(mut p) => gyro_delay_referenced(&mut w, &mut g, &mut p),
            Err(_) => gyro_delay(&mut w, &mut g),
        },
        _ => GyroClock::Unknown,
    }
}

/// Correlation of the tread speed difference at `t` with the gyro's rate at
/// `t - tau` (linear between samples), over the wheel samples the gyro
/// covers, and the least-squares slope of the rate on the difference (1/m);
/// NaN without enough turning.
fn fit(w: &[(f64, f64)], g: &[(f64, f64)], tau: f64) -> (f64, f64) {
    let (mut n, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for &(t, x) in w {
        let tg = t - tau;
        let k = g.partition_point(|&(ts, _)| ts < tg);
        if k == 0 || k >= g.len() {
            continue;
        }
        let ((t0, r0), (t1, r1)) = (g[k - 1], g[k]);
        let y = if t1 > t0 {
            r0 + (r1 - r0) * (tg - t0) / (t1 - t0)
        } else {
            r1
        };
        n += 1.0;
        sx += x;
        sy += y;
        sxx += x * x;
        syy += y * y;
        sxy += x * y;
    }
    if n < 10.0 {
        return (f64::NAN, f64::NAN);
    }
    let vx = sxx / n - (sx / n) * (sx / n);
    let vy = syy / n - (sy / n) * (sy / n);
    if !(vx.sqrt() >= MIN_TURNING && vy > 0.0) {
        return (f64::NAN, f64::NAN);
    }
    let cov = sxy / n - sx * sy / (n * n);
    (cov / (vx * vy).sqrt(), cov / vx)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drive(delay: f64) -> (Vec<WheelSample>, Vec<(f64, f64)>) {
        // Turns of varying rate; the gyro sees each `delay` s before the
        // wheels are stamped with it, at 30 Hz against 10 Hz wheels.
        let turn = |t: f64| 0.3 * (0.7 * t).sin() + 0.2 * (0.23 * t).sin();
        let wheels = (0..1200)
            .map(|i| {
                let t = i as f64 * 0.1;
                let dv = turn(t);
                WheelSample {
                    t,
                    v_left: 1.0 - 0.5 * dv,
                    v_right: 1.0 + 0.5 * dv,
                }
            })
            .collect();
        let gyro = (0..3600)
            .map(|i| {
                let t = i as f64 / 30.0;
                (t, 0.9 * turn(t + delay) + 0.01)
            })
            .collect();
        (wheels, gyro)
    }

    #[test]
    fn finds_how_late_the_wheels_are_stamped() {
        for delay in [-0.3, 0.0, 0.4] {
            let (w, g) = drive(delay);
            let clock = gyro_delay(&mut w.into_iter().map(Ok), &mut g.into_iter().map(Ok));
            let GyroClock::Delay {
                wheels_late_by: tau,
                gyro_per_tread,
            } = clock
            else {
                panic!("{clock:?}")
            };
            assert!((tau - delay).abs() < 0.01, "{tau} for {delay}");
            // The gyro turns 0.9 x the tread speed difference (1 m).
            assert!((gyro_per_tread - 0.9).abs() < 0.01, "{gyro_per_tread}");
        }
        // Upside down (or its x axis taken for z): not the yaw rate.
        let (w, g) = drive(0.0);
        let flipped = g.into_iter().map(|(t, r)| Ok((t, -r)));
        let c = gyro_delay(&mut w.into_iter().map(Ok), &mut flipped.into_iter());
        assert!(matches!(c, GyroClock::NotYaw(c) if c < 0.5), "{c:?}");
    }

    /// Wheels whose tread speed difference turns one way (`0.3 sin 0.7t`)
    /// while the body turns another (`body(t)` rad/s): a gyro reading
    /// `gyro(t)` and a pose reference at 10 Hz whose heading is the body's.
    #[allow(clippy::type_complexity)]
    fn held_robot(
        body: fn(f64) -> f64,
        gyro: fn(f64) -> f64,
    ) -> (Vec<WheelSample>, Vec<(f64, f64)>, Vec<PoseObs>) {
        let wheels = (0..1200)
            .map(|i| {
                let t = i as f64 * 0.1;
                let dv = 0.3 * (0.7 * t).sin();
                WheelSample {
                    t,
                    v_left: 0.5 - 0.5 * dv,
                    v_right: 0.5 + 0.5 * dv,
                }
            })
            .collect();
        let g = (0..3600)
            .map(|i| {
                let t = i as f64 / 30.0;
                (t, gyro(t))
            })
            .collect();
        let mut yaw = 0.0;
        let pose = (0..1200)
            .map(|i| {
                let t = i as f64 * 0.1;
                // Heading noise of 0.005 rad on the integrated turn.
                let noise = 0.005 * ((i * 7919 % 1000) as f64 / 500.0 - 1.0);
                let p = PoseObs {
                    t,
                    east: Some(0.0),
                    north: Some(0.0),
                    yaw: Some(terraslip_core::angle::wrap(yaw + noise)),
                    std_xy: None,
                    std_yaw: None,
                };
                yaw += 0.1 * body(t + 0.05);
                p
            })
            .collect();
        (wheels, g, pose)
    }

    fn dragged(t: f64) -> f64 {
        0.2 * (0.23 * t).sin() + 0.1 * (1.3 * t).cos()
    }

    fn wheels_turn(t: f64) -> f64 {
        0.3 * (0.7 * t).sin()
    }

    fn check(body: fn(f64) -> f64, gyro: fn(f64) -> f64) -> GyroClock {
        let (w, g, p) = held_robot(body, gyro);
        gyro_delay_referenced(
            &mut w.into_iter().map(Ok),
            &mut g.into_iter().map(Ok),
            &mut p.into_iter().map(Ok),
        )
    }

    #[test]
    fn the_reference_keeps_a_gyro_it_follows_when_the_treads_slip() {
        // The body turns as it is dragged, not as its treads spin; the gyro
        // reads the body.
        let clock = check(dragged, dragged);
        let GyroClock::Slipping {
            wheels,
            gyro_ref,
            wheels_ref,
        } = clock
        else {
            panic!("{clock:?}")
        };
        assert!(
            wheels < 0.5 && gyro_ref > 0.9 && wheels_ref < 0.5,
            "{clock:?}"
        );
        // Without the reference, the same gyro is not the yaw rate.
        let (w, g, _) = held_robot(dragged, dragged);
        let alone = gyro_delay(&mut w.into_iter().map(Ok), &mut g.into_iter().map(Ok));
        assert!(matches!(alone, GyroClock::NotYaw(_)), "{alone:?}");
    }

    #[test]
    fn the_reference_names_a_gyro_that_does_not_follow_it_or_the_wheels() {
        // The body turns as its treads say; the gyro reads something else.
        let clock = check(wheels_turn, dragged);
        let GyroClock::Faulty {
            gyro_ref,
            wheels_ref,
            ..
        } = clock
        else {
            panic!("{clock:?}")
        };
        assert!(gyro_ref < 0.5 && wheels_ref > 0.9, "{clock:?}");
        // A gyro that follows the wheels needs no arbiter.
        let clock = check(wheels_turn, wheels_turn);
        assert!(matches!(clock, GyroClock::Delay { .. }), "{clock:?}");
    }

    /// A run of a held robot keeps the gyro the reference backs and reports
    /// slip; one whose gyro the reference does not back drops it, naming
    /// the gyro.
    #[test]
    fn a_run_keeps_the_gyro_the_reference_backs() {
        use crate::pipeline::{run, TerrainEvidence};
        use crate::testkit::{drive, SynthSpec};
        let cfg = crate::config::EstimatorConfig::default();
        let warnings = |body: fn(f64) -> f64, gyro: fn(f64) -> f64| {
            let (w, g, p) = held_robot(body, gyro);
            let mut log = drive(&SynthSpec {
                duration: 10.0,
                ..Default::default()
            });
            log.wheels = w;
            log.pose = p;
            log.imu = g
                .into_iter()
                .map(|(t, r)| terraslip_io::ImuSample {
                    t,
                    accel_z: 9.81,
                    accel_x: None,
                    accel_y: None,
                    gyro_x: None,
                    gyro_y: None,
                    gyro_z: Some(r),
                })
                .collect();
            let run = run(&log, &cfg, &TerrainEvidence::None, None).unwrap();
            (run.warnings, run.gyro_delay)
        };
        let (kept, _) = warnings(dragged, dragged);
        assert!(
            kept.iter().any(|w| w.contains("the treads slip heavily")),
            "{kept:?}"
        );
        assert!(!kept.iter().any(|w| w.contains("not fused")), "{kept:?}");
        let (dropped, _) = warnings(wheels_turn, dragged);
        assert!(
            dropped.iter().any(|w| w.contains("the gyro is faulty")),
            "{dropped:?}"
        );
    }

    #[test]
    fn a_straight_drive_tells_nothing() {
        let w: Vec<WheelSample> = (0..600)
            .map(|i| WheelSample {
                t: i as f64 * 0.1,
                v_left: 1.0,
                v_right: 1.0,
            })
            .collect();
        let g: Vec<(f64, f64)> = (0..1800).map(|i| (i as f64 / 30.0, 0.001)).collect();
        let tau = gyro_delay(&mut w.into_iter().map(Ok), &mut g.into_iter().map(Ok));
        assert_eq!(tau, GyroClock::Unknown);
    }

    #[test]
    fn a_gyro_turning_far_from_the_wheels_is_named() {
        // A 0.5 m track whose slip model holds spreads of 0.4-2 m.
        let warn = |k: f64| turn_disagreement("log", k, 0.5, 0.4, 2.0);
        // Spreads of 0.5 and 1.25 m: slip explains them.
        assert_eq!(warn(2.0), None);
        assert_eq!(warn(0.8), None);
        // The gyro turns a tenth of the wheels' no-slip turn (spread 5 m),
        // or the other way, or against them.
        for k in [0.2, 4.0, -1.0] {
            let w = warn(k).expect("a warning");
            assert!(w.starts_with("log: the gyro turns"), "{w}");
            assert!(w.contains(&format!("{:.2} x", k * 0.5)), "{w}");
        }
    }

    /// A run whose gyro reads a tenth of the body's yaw rate warns; one
    /// whose gyro reads it does not.
    #[test]
    fn a_run_names_a_gyro_that_turns_far_from_the_wheels() {
        use crate::pipeline::{run, TerrainEvidence};
        use crate::testkit::{drive, gyro, SynthSpec};
        let icr = terraslip_core::IcrParams::new(0.30, -0.31, 0.01);
        let spec = SynthSpec {
            duration: 120.0,
            terrains: vec![(0.0, "asphalt".into(), icr)],
            ..Default::default()
        };
        let cfg = crate::config::EstimatorConfig::default();
        let warned = |scale: f64| {
            let mut log = drive(&spec);
            log.imu = gyro(icr, 120.0, 100.0);
            for s in &mut log.imu {
                s.gyro_z = s.gyro_z.map(|g| scale * g);
            }
            let run = run(&log, &cfg, &TerrainEvidence::None, None).unwrap();
            run.warnings.iter().any(|w| w.contains("the gyro turns"))
        };
        assert!(!warned(1.0));
        assert!(warned(0.1));
    }
}
