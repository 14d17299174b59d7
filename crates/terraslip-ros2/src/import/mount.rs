//! Sensor mountings: the rotation from a sensor's frame into the base frame
//! (REP-103: x forward, y left, z up), from the bag's static transforms or
//! the topics file, applied to an IMU's accelerations, rates and orientation.
//!
//! Quaternions are `[x, y, z, w]` (the ROS order) and rotate vectors from
//! the child frame into the parent: `v_parent = q v_child q*`.

use std::collections::HashMap;

use terraslip_io::{DriveLog, ImuSample, PoseObs, WheelSample};

use super::config::TopicsConfig;
use super::frames::heading_yaw;
pub use super::frames::{
    conj, from_rpy, mul, normalized, rotate, rpy_of, Quat, StaticTf, IDENTITY,
};
use super::report::ImportReport;
use crate::Bag;

/// Rotates IMU samples into the base frame: accelerations when all three
/// axes are present, rates likewise.
pub fn rotate_imu(q: Quat, imu: &mut [ImuSample]) {
    for s in imu {
        if let (Some(x), Some(y)) = (s.accel_x, s.accel_y) {
            let [x, y, z] = rotate(q, [x, y, s.accel_z]);
            (s.accel_x, s.accel_y, s.accel_z) = (Some(x), Some(y), z);
        }
        if let (Some(x), Some(y), Some(z)) = (s.gyro_x, s.gyro_y, s.gyro_z) {
            let [x, y, z] = rotate(q, [x, y, z]);
            (s.gyro_x, s.gyro_y, s.gyro_z) = (Some(x), Some(y), Some(z));
        }
    }
}

/// The base frame's orientation from a sensor's (`world ← sensor`), given
/// the mounting `base ← sensor`: `world ← base = (world ← sensor)(sensor ← base)`.
pub fn base_orientation(sensor: Quat, mount: Quat) -> Quat {
    mul(sensor, conj(mount))
}

/// When the mean acceleration of `imu` is gravity-sized but not along +z
/// (more than 30° off), the mean: the IMU is then not mounted z-up in the
/// base frame (or its mounting is wrong).
pub fn gravity_off_vertical(imu: &[ImuSample]) -> Option<[f64; 3]> {
    let mut sum = [0.0; 3];
    let mut n = 0usize;
    for s in imu {
        if let (Some(x), Some(y)) = (s.accel_x, s.accel_y) {
            if x.is_finite() && y.is_finite() && s.accel_z.is_finite() {
                sum = [sum[0] + x, sum[1] + y, sum[2] + s.accel_z];
                n += 1;
            }
        }
    }
    if n == 0 {
        return None;
    }
    let m = sum.map(|a| a / n as f64);
    let g = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
    (g > 5.0 && m[2] / g < 30f64.to_radians().cos()).then_some(m)
}

/// Rewrites the yaw of heading rows `(index in pose, sensor orientation)`
/// for a sensor mounted `mount` in the base frame; `yaw` maps the base
/// frame's orientation to the logged yaw (offsets, declination).
pub fn remount_heading(
    pose: &mut [PoseObs],
    rows: &[(usize, Quat)],
    mount: Quat,
    yaw: impl Fn(Quat) -> f64,
) {
    for &(i, q) in rows {
        if let Some(p) = pose.get_mut(i) {
            p.yaw = Some(yaw(base_orientation(q, mount)));
        }
    }
}

/// What the mountings are worked out from, after the bag is read.
pub(super) struct Sensors<'a> {
    pub bag: &'a Bag,
    pub cfg: &'a TopicsConfig,
    /// The IMU, heading and static-transform topics.
    pub imu: Option<usize>,
    pub heading: Option<usize>,
    pub tf: Option<usize>,
    /// Each IMU topic's frame.
    pub frames: &'a HashMap<usize, String>,
    pub tf_tree: &'a StaticTf,
    pub heading_rows: &'a [(usize, Quat)],
}

impl Sensors<'_> {
    /// The mounting of `topic` (`base ← sensor`): `given` (degrees, from the
    /// topics file), else the static transforms' chain from its frame. `None`
    /// when neither tells (then [`mounting_from_data`]).
    pub(super) fn mounting(
        &self,
        topic: usize,
        given: Option<[f64; 3]>,
        report: &mut ImportReport,
    ) -> Option<Quat> {
        let name = &self.bag.topics[topic].name;
        let frame = self.frames.get(&topic).map_or("", String::as_str);
        let base = self.cfg.tf.base_frame.as_str();
        let (q, source) = match (given, self.tf) {
            (Some([r, p, y]), _) => (
                from_rpy(r.to_radians(), p.to_radians(), y.to_radians()),
                "the topics file".to_string(),
            ),
            (None, Some(tf)) => {
                let tf_name = &self.bag.topics[tf].name;
                match self.tf_tree.rotation(base, frame) {
                    Some(q) => (q, tf_name.clone()),
                    None => {
                        report.warnings.push(format!(
                            "{name}: its frame `{frame}` has no static transform to {base} in {tf_name}; its mounting is found from the data where it can be, else its axes are taken as {base}'s (give `mount_rpy_deg` in the topics file)"
                        ));
                        return None;
                    }
                }
            }
            (None, None) => return None,
        };
        // Tenths of a degree, without a `-0.0`.
        let [r, p, y] = rpy_of(q).map(|a| (a.to_degrees() * 10.0).round() / 10.0 + 0.0);
        let line = format!(
            "{name} (frame `{frame}`): mounted roll {r:.1}°, pitch {p:.1}°, yaw {y:.1}° in {base}, from {source}"
        );
        if !report.mounts.contains(&line) {
            report.mounts.push(line);
        }
        Some(q)
    }
}

/// Linear interpolation of `(t, value)` rows at `t` (`None` outside them).
fn at(rows: &[(f64, f64)], t: f64) -> Option<f64> {
    let i = rows.partition_point(|r| r.0 < t);
    if i == 0 || i >= rows.len() {
        return None;
    }
    let (a, b) = (rows[i - 1], rows[i]);
    let f = if b.0 > a.0 {
        (t - a.0) / (b.0 - a.0)
    } else {
        0.0
    };
    Some(a.1 + f * (b.1 - a.1))
}

/// Correlation of paired samples (0 when either does not vary).
fn correlation(pairs: &[(f64, f64)]) -> f64 {
    let n = pairs.len() as f64;
    if n < 3.0 {
        return 0.0;
    }
    let (ma, mb) = pairs
        .iter()
        .fold((0.0, 0.0), |(a, b), p| (a + p.0 / n, b + p.1 / n));
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (a, b) in pairs {
        sab += (a - ma) * (b - mb);
        saa += (a - ma) * (a - ma);
        sbb += (b - mb) * (b - mb);
    }
    if saa > 0.0 && sbb > 0.0 {
        sab / (saa * sbb).sqrt()
    } else {
        0.0
    }
}

/// A mounting found from the data, when nothing states one, and how sure
/// it is (one line).
///
/// Roll and pitch from gravity: the rotation that takes the mean
/// acceleration (the specific force, up) onto +z, when it is more than 5°
/// off. Yaw about the vertical from the forward acceleration: the
/// horizontal acceleration's covariance with the rate of change of the
/// mean tread speed (over ±0.5 s) points along base x; used when their
/// correlation exceeds 0.2, rounded to a multiple of 90° within 15°; then
/// roll, pitch and yaw within 3° of a multiple of 90° are rounded to it. The
/// yaw-rate axis's sign from the gyro: the rotated `gyro_z` must follow the
/// tread speed difference v_r − v_l; a clearly negative correlation (an IMU
/// that reports gravity downwards) turns the mounting 180° about x.
/// `None` when the mean acceleration is not gravity-sized (7-12.5 m/s²) or
/// there are fewer than 50 samples.
pub fn mounting_from_data(imu: &[ImuSample], wheels: &[WheelSample]) -> Option<(Quat, String)> {
    let acc: Vec<(f64, [f64; 3])> = imu
        .iter()
        .filter_map(|s| {
            let a = [s.accel_x?, s.accel_y?, s.accel_z];
            a.iter().all(|c| c.is_finite()).then_some((s.t, a))
        })
        .collect();
    if acc.len() < 50 {
        return None;
    }
    let n = acc.len() as f64;
    let m = acc.iter().fold([0.0; 3], |m, (_, a)| {
        [m[0] + a[0] / n, m[1] + a[1] / n, m[2] + a[2] / n]
    });
    let g = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
    if !(7.0..=12.5).contains(&g) {
        return None;
    }
    let u = m.map(|c| c / g);
    let tilt = u[2].clamp(-1.0, 1.0).acos();
    let mut q = IDENTITY;
    let mut line = format!(
        "gravity ({:.2}, {:.2}, {:.2}) m/s² is {:.1}° off the IMU's +z",
        m[0],
        m[1],
        m[2],
        tilt.to_degrees()
    );
    if tilt > 5f64.to_radians() {
        // Shortest arc u -> +z: axis u × z, angle tilt (about x when u = -z).
        let axis = [u[1], -u[0], 0.0];
        let an = axis[0].hypot(axis[1]);
        let axis = if an > 1e-9 {
            axis.map(|c| c / an)
        } else {
            [1.0, 0.0, 0.0]
        };
        let (sh, ch) = (tilt / 2.0).sin_cos();
        q = [axis[0] * sh, axis[1] * sh, 0.0, ch];
    }
    let mean_v: Vec<(f64, f64)> = wheels
        .iter()
        .map(|w| (w.t, 0.5 * (w.v_left + w.v_right)))
        .collect();
    let diff_v = tread_difference(wheels);
    // Yaw from the forward acceleration.
    let (mut cx, mut cy, mut pairs) = (0.0, 0.0, Vec::new());
    for (t, a) in &acc {
        let (Some(v0), Some(v1)) = (at(&mean_v, t - 0.5), at(&mean_v, t + 0.5)) else {
            continue;
        };
        let h = rotate(q, *a);
        let dv = v1 - v0;
        cx += h[0] * dv;
        cy += h[1] * dv;
        pairs.push((h[0], h[1], dv));
    }
    let psi = (-cy).atan2(cx);
    let along: Vec<(f64, f64)> = pairs
        .iter()
        .map(|(x, y, dv)| (x * psi.cos() - y * psi.sin(), *dv))
        .collect();
    let r_fwd = correlation(&along);
    if r_fwd > 0.2 {
        let quarter = std::f64::consts::FRAC_PI_2;
        let snapped = (psi / quarter).round() * quarter;
        let yaw = if (psi - snapped).abs() < 15f64.to_radians() {
            snapped
        } else {
            psi
        };
        q = mul(from_rpy(0.0, 0.0, yaw), q);
        line.push_str(&format!(
            "; forward axis from the acceleration against the tread speeds' change (correlation {r_fwd:.2})"
        ));
    } else {
        line.push_str(&format!(
            "; yaw about the vertical not told by the data (forward correlation {r_fwd:.2}): accel_x/accel_y may not be the robot's"
        ));
    }
    // Brackets are square: angles within 3° of a multiple of 90° are that
    // multiple (a mean over a drive is tilted by slopes and turns).
    let snap = |a: f64| {
        let k = (a / std::f64::consts::FRAC_PI_2).round() * std::f64::consts::FRAC_PI_2;
        if (a - k).abs() < 3f64.to_radians() {
            k
        } else {
            a
        }
    };
    let [r, p, y] = rpy_of(q).map(snap);
    q = from_rpy(r, p, y);
    // The yaw-rate axis's sign.
    let mut r_turn = turn_correlation(q, imu, &diff_v);
    if r_turn < -0.3 {
        q = mul([1.0, 0.0, 0.0, 0.0], q);
        r_turn = -r_turn;
        line.push_str("; turned 180° about x: the gyro turned against the treads");
    }
    line.push_str(&format!(
        "; gyro_z against v_r − v_l: correlation {r_turn:.2}{}",
        if r_turn > 0.5 {
            ""
        } else {
            " (weak: check the mounting)"
        }
    ));
    Some((q, line))
}

/// The tread speed difference v_r − v_l (m/s) of `wheels`, by time.
pub(super) fn tread_difference(wheels: &[WheelSample]) -> Vec<(f64, f64)> {
    wheels.iter().map(|w| (w.t, w.v_right - w.v_left)).collect()
}

/// Correlation of the gyro's yaw rate, rotated by the mounting `q`
/// (`base ← sensor`), with the tread speed difference `diff_v` (`(t, m/s)`
/// rows, [`tread_difference`]): near 1 when the mounting's z is the yaw
/// axis, negative when it turns against the treads.
pub(super) fn turn_correlation(q: Quat, imu: &[ImuSample], diff_v: &[(f64, f64)]) -> f64 {
    let turn: Vec<(f64, f64)> = imu
        .iter()
        .filter_map(|s| {
            let w = rotate(q, [s.gyro_x?, s.gyro_y?, s.gyro_z?]);
            Some((w[2], at(diff_v, s.t)?))
        })
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    correlation(&turn)
}

/// Rotates the IMU's accelerations and rates, and the heading's
/// orientation, into the base frame; warns when gravity is then not along
/// +z (an IMU not mounted z-up, with no mounting given). Returns the IMU's
/// mounting when it was found from the data.
pub(super) fn apply(s: &Sensors, log: &mut DriveLog, report: &mut ImportReport) -> Option<Quat> {
    let cfg = s.cfg;
    let mut found = None;
    if let Some(t) = s.imu {
        let q = s.mounting(t, cfg.imu.mount_rpy_deg, report).or_else(|| {
            let (q, how) = mounting_from_data(&log.imu, &log.wheels)?;
            let name = &s.bag.topics[t].name;
            let [r, p, y] = rpy_of(q).map(|a| (a.to_degrees() * 10.0).round() / 10.0 + 0.0);
            report.mounts.push(format!(
                "{name}: mounted roll {r:.1}°, pitch {p:.1}°, yaw {y:.1}° in {}, from the data",
                cfg.tf.base_frame
            ));
            report.decisions.push(format!(
                "{name} mounting from the data ({how}); give `[imu] mount_rpy_deg` or record /tf_static to state it"
            ));
            found = Some(q);
            Some(q)
        });
        if let Some(q) = q.filter(|q| *q != IDENTITY) {
            rotate_imu(q, &mut log.imu);
        }
        if let Some(g) = gravity_off_vertical(&log.imu) {
            report.warnings.push(format!(
                "{}: the mean acceleration ({:.1}, {:.1}, {:.1}) m/s² is not along +z of {}: the IMU is not mounted z-up there, so accel_z is not the vertical and its yaw not the heading; give its mounting as `[imu] mount_rpy_deg = [roll, pitch, yaw]` (or record /tf_static)",
                s.bag.topics[t].name, g[0], g[1], g[2], cfg.tf.base_frame
            ));
        }
    }
    if let Some(t) = s.heading {
        let given = cfg
            .heading
            .mount_rpy_deg
            .or(cfg.imu.mount_rpy_deg.filter(|_| s.imu == Some(t)));
        let q = s
            .mounting(t, given, report)
            .or(found.filter(|_| s.imu == Some(t)));
        if let Some(q) = q.filter(|q| *q != IDENTITY) {
            remount_heading(&mut log.pose, s.heading_rows, q, |b| {
                heading_yaw(&cfg.heading, b)
            });
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
    }

    #[test]
    fn rpy_follows_urdf_fixed_axes() {
        // Roll 90° then yaw -90° (about the fixed axes): the sensor's y axis
        // ends up along base z, its z along base -x, its x along base -y.
        let q = from_rpy(FRAC_PI_2, 0.0, -FRAC_PI_2);
        assert!(close(rotate(q, [0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]));
        assert!(close(rotate(q, [0.0, 0.0, 1.0]), [-1.0, 0.0, 0.0]));
        assert!(close(rotate(q, [1.0, 0.0, 0.0]), [0.0, -1.0, 0.0]));
        let [r, p, y] = rpy_of(q);
        assert!(
            close([r, p, y], [FRAC_PI_2, 0.0, -FRAC_PI_2]),
            "{r} {p} {y}"
        );
    }

    #[test]
    fn a_chain_of_static_transforms_composes() {
        let mut tf = StaticTf::default();
        tf.add("base_link", "plate", from_rpy(0.0, 0.0, FRAC_PI_2));
        tf.add("/plate", "imu_link", from_rpy(FRAC_PI_2, 0.0, 0.0));
        let q = tf.rotation("base_link", "imu_link").unwrap();
        // imu y -> plate z -> base z; imu z -> plate -y -> base x.
        assert!(close(rotate(q, [0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]));
        assert!(close(rotate(q, [0.0, 0.0, 1.0]), [1.0, 0.0, 0.0]));
        assert_eq!(tf.rotation("base_link", "base_link"), Some(IDENTITY));
        assert_eq!(tf.rotation("base_link", "camera"), None);
        assert_eq!(tf.rotation("odom", "imu_link"), None);
    }

    #[test]
    fn base_heading_from_a_rotated_sensor() {
        // The base faces 30° left of east; the sensor is mounted yawed 90°.
        let mount = from_rpy(0.3, 0.0, FRAC_PI_2);
        let base = from_rpy(0.0, 0.0, 30f64.to_radians());
        let sensor = mul(base, mount);
        let [_, _, yaw] = rpy_of(base_orientation(sensor, mount));
        assert!((yaw - 30f64.to_radians()).abs() < 1e-12);
    }
}
