//! Small deterministic drives for tests and benchmarks that must not depend
//! on the full simulator: exact ICR-model truth, white pose noise, a
//! terrain change schedule. Not a substitute for `terraslip-sim`.

use terraslip_core::IcrParams;
use terraslip_io::{DriveLog, ImuSample, Meta, PoseObs, TerrainLabel, TruthSample, WheelSample};

/// Settings of [`drive`].
#[derive(Debug, Clone)]
pub struct SynthSpec {
    /// Length, s.
    pub duration: f64,
    /// Wheels rate, Hz.
    pub wheel_hz: f64,
    /// Pose rate, Hz.
    pub pose_hz: f64,
    /// Position noise std, m (white).
    pub std_xy: f64,
    /// Heading noise std, rad (white).
    pub std_yaw: f64,
    /// `(start time, name, ICRs)` of each terrain stretch.
    pub terrains: Vec<(f64, String, IcrParams)>,
    /// Track width written to meta.toml, m.
    pub track_width: f64,
    /// Seed of the noise.
    pub seed: u64,
    /// How late the pose stream is stamped, s: a pose stamped `t`
    /// describes the robot at `t - pose_delay`.
    pub pose_delay: f64,
    /// Write the stds into pose.csv (false: the estimator must learn them).
    pub stated_std: bool,
    /// Where the pose reference sits on the robot, m, body frame: its
    /// positions are of that point (the truth stays the axle's centre's).
    pub lever_arm: (f64, f64),
}

impl Default for SynthSpec {
    fn default() -> Self {
        Self {
            duration: 300.0,
            wheel_hz: 50.0,
            pose_hz: 1.0,
            std_xy: 0.05,
            std_yaw: 0.01,
            terrains: vec![
                (0.0, "asphalt".into(), IcrParams::new(0.30, -0.31, 0.01)),
                (100.0, "grass".into(), IcrParams::new(0.36, -0.37, 0.02)),
                (200.0, "asphalt".into(), IcrParams::new(0.30, -0.31, 0.01)),
            ],
            track_width: 0.5,
            seed: 1,
            pose_delay: 0.0,
            stated_std: true,
            lever_arm: (0.0, 0.0),
        }
    }
}

/// Gaussian noise by Box-Muller on a xorshift generator (deterministic).
struct Noise(u64);
impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// Tread speeds of an operator weaving left and right at 0.5-1 m/s.
pub fn tread_speeds(t: f64) -> (f64, f64) {
    let v = 0.75 + 0.25 * (0.05 * t).sin();
    let turn = 0.35 * (0.21 * t).sin() + 0.2 * (0.077 * t).cos();
    (v - turn, v + turn)
}

/// A noiseless yaw-rate gyro at `hz` over `duration` s of the
/// [`tread_speeds`] drive with ICRs `icr`, stamped 3 ms after the wheels'
/// grid.
pub fn gyro(icr: IcrParams, duration: f64, hz: f64) -> Vec<ImuSample> {
    gyro_turning(duration, hz, |_| icr)
}

/// The same gyro on the drive `spec` describes: it turns as the ground
/// under each stretch does.
pub fn terrain_gyro(spec: &SynthSpec, hz: f64) -> Vec<ImuSample> {
    gyro_turning(spec.duration, hz, |t| spec.icr_at(t))
}

fn gyro_turning(duration: f64, hz: f64, icr_at: impl Fn(f64) -> IcrParams) -> Vec<ImuSample> {
    (0..(duration * hz) as usize)
        .map(|k| {
            let t = k as f64 / hz + 0.003;
            let (vl, vr) = tread_speeds(t);
            ImuSample {
                t,
                accel_z: 9.81,
                accel_x: None,
                accel_y: None,
                gyro_x: None,
                gyro_y: None,
                gyro_z: Some(icr_at(t).twist(vl, vr).omega),
            }
        })
        .collect()
}

impl SynthSpec {
    /// The ICRs of the ground at `t` (s): the stretch in effect, the first
    /// before any; no slip with no stretch.
    pub fn icr_at(&self, t: f64) -> IcrParams {
        self.terrains
            .iter()
            .rev()
            .find(|x| x.0 <= t)
            .or(self.terrains.first())
            .map_or(IcrParams::no_slip(self.track_width), |x| x.2)
    }
}

/// A drive with truth, labels and noisy pose.
pub fn drive(spec: &SynthSpec) -> DriveLog {
    let mut noise = Noise(spec.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let icr_at = |t: f64| spec.icr_at(t);
    let n = (spec.duration * spec.wheel_hz).round() as usize;
    let dt = 1.0 / spec.wheel_hz;
    let sub = 10;
    let mut s = [0.0f64; 3];
    let mut log = DriveLog {
        meta: Meta {
            track_width: Some(spec.track_width),
            ..Default::default()
        },
        ..Default::default()
    };
    let pose_every = (spec.wheel_hz / spec.pose_hz).round().max(1.0) as usize;
    for k in 0..=n {
        let t = k as f64 * dt;
        let (vl, vr) = tread_speeds(t);
        if k > 0 {
            // Finer truth integration than the filter's step.
            let icr = icr_at(t);
            let tw = icr.twist(vl, vr);
            let h = dt / sub as f64;
            for _ in 0..sub {
                let (sn, cs) = s[2].sin_cos();
                s[0] += h * (tw.v_x * cs - tw.v_y * sn);
                s[1] += h * (tw.v_x * sn + tw.v_y * cs);
                s[2] = terraslip_core::angle::wrap(s[2] + h * tw.omega);
            }
        }
        let icr = icr_at(t);
        log.wheels.push(WheelSample {
            t,
            v_left: vl,
            v_right: vr,
        });
        log.truth.push(TruthSample {
            t,
            east: s[0],
            north: s[1],
            yaw: s[2],
            y_l: icr.y_l,
            y_r: icr.y_r,
            x_c: icr.x_c,
        });
        if k > 0 && k % pose_every == 0 {
            let (sn, cs) = s[2].sin_cos();
            let (lx, ly) = spec.lever_arm;
            log.pose.push(PoseObs {
                t: t + spec.pose_delay,
                east: Some(s[0] + cs * lx - sn * ly + spec.std_xy * noise.gauss()),
                north: Some(s[1] + sn * lx + cs * ly + spec.std_xy * noise.gauss()),
                yaw: Some(terraslip_core::angle::wrap(
                    s[2] + spec.std_yaw * noise.gauss(),
                )),
                std_xy: spec.stated_std.then_some(spec.std_xy),
                std_yaw: spec.stated_std.then_some(spec.std_yaw),
            });
        }
    }
    log.terrain = spec
        .terrains
        .iter()
        .map(|(t, name, _)| TerrainLabel {
            t: *t,
            terrain: name.clone(),
        })
        .collect();
    log
}

/// The drive `name` of the repository's `data/` (a log that ships with
/// it, e.g. DRIVE's `warthog_sand_a`).
pub fn repo_drive(name: &str) -> DriveLog {
    let dir = terraslip_io::shared::repo_data(name);
    DriveLog::read(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
}

/// The bag at `path` played message by message through the node's live
/// import (no DDS) with `topics`: the live import after its last message
/// and the samples it made, in the bag's order.
#[cfg(feature = "ros2")]
pub fn play_bag(
    path: &std::path::Path,
    topics: &terraslip_ros2::TopicsConfig,
) -> (
    terraslip_ros2::import::LiveImport,
    Vec<crate::pipeline::live::Sample>,
) {
    use crate::pipeline::live::Sample;
    use terraslip_ros2::import::LiveImport;
    let mut bag = terraslip_ros2::Bag::open(path).unwrap();
    let mut live = LiveImport::new("graph", bag.topics.clone(), topics).unwrap();
    let mut samples: Vec<Sample> = Vec::new();
    bag.for_each(&|_| true, &mut |_, m| {
        for r in live.message(m.topic, m.recv_ns, m.data).unwrap() {
            samples.push(r.into());
        }
        Ok(())
    })
    .unwrap();
    (live, samples)
}

/// Live rows against the offline run's, row for row: the median and p99 of
/// their position differences (m). `shift` (s) moves the live clock onto
/// the offline one (the two origins differ by whole seconds); panics when
/// the rows differ in number or time.
pub fn live_against_offline(
    live: &[crate::pipeline::EstimateRow],
    offline: &[crate::pipeline::EstimateRow],
    shift: f64,
) -> (f64, f64) {
    assert_eq!(live.len(), offline.len(), "live and offline rows");
    let mut gaps: Vec<f64> = live
        .iter()
        .zip(offline)
        .map(|(a, b)| {
            assert!(
                (a.t + shift - b.t).abs() < 1e-6,
                "{} against {}",
                a.t + shift,
                b.t
            );
            (a.east - b.east).hypot(a.north - b.north)
        })
        .collect();
    gaps.sort_by(f64::total_cmp);
    let at = |q: f64| gaps[((gaps.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.99))
}
