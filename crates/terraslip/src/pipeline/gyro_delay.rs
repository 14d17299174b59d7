//! How the gyro's clock sits against the wheels': found before the run
//! from the drive's first minutes, by lining the gyro's rate up with the
//! tread speed difference (a turn shows in both; a controller that stamps
//! its odometry late, or an IMU driver that stamps early, shifts one
//! against the other by tenths of a second, which over a turn is a heading
//! error the size of the turn's start).

use std::path::Path;

use terraslip_io::{GyroStream, LogError, WheelSample, WheelStream};

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
}

/// How late the wheels are stamped against the gyro: the delay `tau`
/// within +-[`MAX_DELAY`] for which the gyro's rate at `t - tau` best
/// correlates with `v_right - v_left` at `t` over the first [`SPAN`] s.
/// Rows that cannot be read are skipped here (the run reports them).
pub fn gyro_delay(
    wheels: &mut dyn Iterator<Item = Result<WheelSample, LogError>>,
    gyro: &mut dyn Iterator<Item = Result<(f64, f64), LogError>>,
) -> GyroClock {
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
        return GyroClock::Unknown;
    };
    let g: Vec<(f64, f64)> = gyro
        .flatten()
        .take_while(|&(t, _)| t <= t_end + MAX_DELAY)
        .filter(|(t, r)| t.is_finite() && r.is_finite())
        .collect();
    if g.len() < 10 || w.len() < 10 {
        return GyroClock::Unknown;
    }
    let n = (2.0 * MAX_DELAY / STEP).round() as usize + 1;
    let corr: Vec<f64> = (0..n)
        .map(|i| fit(&w, &g, -MAX_DELAY + i as f64 * STEP).0)
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
        gyro_per_tread: fit(&w, &g, tau).1,
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

/// [`gyro_delay`] of the log directory `dir`'s `wheels.csv` and `imu.csv`
/// (a second read of their start; unreadable files tell nothing).
pub fn gyro_delay_in(dir: &Path) -> GyroClock {
    match (
        WheelStream::open(&dir.join("wheels.csv")),
        GyroStream::open(&dir.join("imu.csv")),
    ) {
        (Ok(mut w), Ok(mut g)) => gyro_delay(&mut w, &mut g),
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
