//! What the robot records: every sensor (and the truth) sampled at its own
//! rate `k / rate` with its own imperfections, from the true motion.

use std::f64::consts::TAU;
use std::path::PathBuf;

use rand::rngs::StdRng;
use rand::Rng;
use terraslip_core::angle::wrap;
use terraslip_core::kinematics::Twist;
use terraslip_io::{DriveLog, ImageRef, ImuSample, PoseObs, WheelSample};

use crate::motion::Motion;
use crate::sensors::{gauss, GaussMarkov, Vibration};
use crate::streams::stream;
use crate::timeline::Timeline;
use crate::{FrameSpec, Scenario, TruthState};

/// Standard gravity, m/s^2.
pub const GRAVITY: f64 = 9.80665;

/// A sensor sampled at `k / rate`.
struct Clock {
    rate: f64,
    k: u64,
}

impl Clock {
    fn new(rate: f64) -> Self {
        Self { rate, k: 0 }
    }
    fn next(&self) -> f64 {
        if self.rate > 0.0 {
            self.k as f64 / self.rate
        } else {
            f64::INFINITY
        }
    }
    /// True (and advances) when the sample time has been reached.
    fn due(&mut self, t: f64) -> bool {
        if self.next() <= t + 1e-9 {
            self.k += 1;
            true
        } else {
            false
        }
    }
}

/// Everything recorded so far.
#[derive(Default)]
pub(crate) struct Recording {
    pub log: DriveLog,
    pub truth: Vec<TruthState>,
    pub frames: Vec<FrameSpec>,
}

/// The sensors' clocks, noise streams and memories.
pub(crate) struct Recorder<'a> {
    sc: &'a Scenario,
    truth: Clock,
    wheels: Clock,
    gnss: Clock,
    compass: Clock,
    imu: Clock,
    camera: Clock,
    rng_gnss: StdRng,
    rng_compass: StdRng,
    rng_imu: StdRng,
    rng_camera: StdRng,
    /// GNSS multipath episodes `(start, end, east, north)`, s and m.
    jumps: Vec<(f64, f64, f64, f64)>,
    /// Correlated GNSS error per axis, and when it was last stepped.
    gm_east: GaussMarkov,
    gm_north: GaussMarkov,
    gm_t: f64,
    vibration: Vibration,
    /// Encoder ticks and time of the last wheels sample.
    last_ticks: (f64, f64),
    last_wheel_t: f64,
    /// Time and twist of the last IMU sample (for the accelerations).
    last_imu: Option<(f64, Twist)>,
}

impl<'a> Recorder<'a> {
    pub fn new(sc: &'a Scenario, seed: u64, duration: f64) -> Self {
        let mut rng_gnss = stream(seed, "gnss");
        let jumps = gnss_jumps(sc, duration, &mut rng_gnss);
        let gm_east = GaussMarkov::new(sc.gnss.markov_std, sc.gnss.markov_tau, &mut rng_gnss);
        let gm_north = GaussMarkov::new(sc.gnss.markov_std, sc.gnss.markov_tau, &mut rng_gnss);
        Self {
            sc,
            truth: Clock::new(sc.integration.truth_rate),
            wheels: Clock::new(sc.wheels.rate),
            gnss: Clock::new(sc.gnss.rate),
            compass: Clock::new(sc.compass.rate),
            imu: Clock::new(sc.imu.rate),
            camera: Clock::new(sc.camera.rate),
            rng_gnss,
            rng_compass: stream(seed, "compass"),
            rng_imu: stream(seed, "imu"),
            rng_camera: stream(seed, "camera"),
            jumps,
            gm_east,
            gm_north,
            gm_t: 0.0,
            vibration: Vibration::new(),
            last_ticks: (0.0, 0.0),
            last_wheel_t: f64::NAN,
            last_imu: None,
        }
    }

    /// The next time any stream is due, s.
    pub fn next_time(&self) -> f64 {
        [
            self.truth.next(),
            self.wheels.next(),
            self.gnss.next(),
            self.compass.next(),
            self.imu.next(),
            self.camera.next(),
        ]
        .into_iter()
        .fold(f64::INFINITY, f64::min)
    }

    /// Samples every stream due at `t` from `m`.
    pub fn sample(&mut self, t: f64, m: &Motion, timeline: &Timeline, rec: &mut Recording) {
        if self.truth.due(t) {
            rec.truth.push(TruthState {
                t,
                east: m.east,
                north: m.north,
                yaw: wrap(m.yaw),
                icr: m.icr,
                twist: m.twist,
                v_left: m.v_left,
                v_right: m.v_right,
                terrain: m.terrain,
            });
        }
        if self.wheels.due(t) {
            let w = self.wheel_sample(t, m);
            rec.log.wheels.push(w);
        }
        if self.gnss.due(t) {
            if let Some(p) = self.gnss_fix(t, m) {
                rec.log.pose.push(p);
            }
        }
        if self.compass.due(t) {
            self.compass_fix(t, m, &mut rec.log.pose);
        }
        if self.imu.due(t) {
            let s = self.imu_sample(t, m, timeline);
            rec.log.imu.push(s);
        }
        if self.camera.due(t) {
            let i = rec.frames.len();
            rec.frames.push(self.frame(t, m, timeline));
            rec.log.images.push(ImageRef {
                t,
                path: PathBuf::from(format!("images/{i:06}.png")),
            });
        }
    }

    /// Tread speeds from the encoder ticks counted since the last sample.
    fn wheel_sample(&mut self, t: f64, m: &Motion) -> WheelSample {
        let sc = self.sc;
        let tick_len = TAU * sc.robot.wheel_radius / sc.wheels.ticks_per_rev;
        let ticks_of = |ang: f64| (ang / TAU * sc.wheels.ticks_per_rev).floor();
        let (tl, tr) = (ticks_of(m.angle_left), ticks_of(m.angle_right));
        let dt = t - self.last_wheel_t;
        let (v_left, v_right) = if dt.is_finite() && dt > 0.0 {
            (
                (tl - self.last_ticks.0) * tick_len / dt,
                (tr - self.last_ticks.1) * tick_len / dt,
            )
        } else {
            (0.0, 0.0)
        };
        (self.last_ticks, self.last_wheel_t) = ((tl, tr), t);
        WheelSample { t, v_left, v_right }
    }

    /// A GNSS position: white and correlated error, multipath jumps; `None`
    /// in an outage (the noise processes still advance).
    fn gnss_fix(&mut self, t: f64, m: &Motion) -> Option<PoseObs> {
        let g = &self.sc.gnss;
        let rng = &mut self.rng_gnss;
        let e_err = self.gm_east.step(t - self.gm_t, rng);
        let n_err = self.gm_north.step(t - self.gm_t, rng);
        self.gm_t = t;
        let we = g.white_std * gauss(rng);
        let wn = g.white_std * gauss(rng);
        let in_outage = g
            .outages
            .iter()
            .any(|o| t >= o.start && t < o.start + o.duration);
        if in_outage {
            return None;
        }
        let (je, jn) = self
            .jumps
            .iter()
            .filter(|j| t >= j.0 && t < j.1)
            .fold((0.0, 0.0), |acc, j| (acc.0 + j.2, acc.1 + j.3));
        let (s, c) = m.yaw.sin_cos();
        let [lx, ly] = g.lever_arm;
        Some(PoseObs {
            t,
            east: Some(m.east + (c * lx - s * ly) + e_err + we + je),
            north: Some(m.north + (s * lx + c * ly) + n_err + wn + jn),
            yaw: None,
            std_xy: Some(g.reported_std),
            std_yaw: None,
        })
    }

    /// A compass heading, merged into a GNSS fix of the same time.
    fn compass_fix(&mut self, t: f64, m: &Motion, pose: &mut Vec<PoseObs>) {
        let c = &self.sc.compass;
        let y = wrap(
            m.yaw + c.bias_deg.to_radians() + c.std_deg.to_radians() * gauss(&mut self.rng_compass),
        );
        let std_yaw = Some(c.reported_std_deg.to_radians());
        match pose.last_mut() {
            Some(p) if p.t == t && p.yaw.is_none() => {
                p.yaw = Some(y);
                p.std_yaw = std_yaw;
            }
            _ => pose.push(PoseObs {
                t,
                yaw: Some(y),
                std_yaw,
                ..PoseObs::default()
            }),
        }
    }

    /// Accelerations from the change of twist, the terrain's vibration,
    /// gyro rates with scale, bias and noise.
    fn imu_sample(&mut self, t: f64, m: &Motion, timeline: &Timeline) -> ImuSample {
        let imu = &self.sc.imu;
        let twist = m.twist;
        let dt = 1.0 / imu.rate;
        let (ax, ay) = match self.last_imu {
            Some((tp, tw)) if t > tp => {
                let h = t - tp;
                (
                    (twist.v_x - tw.v_x) / h - twist.omega * twist.v_y,
                    (twist.v_y - tw.v_y) / h + twist.omega * twist.v_x,
                )
            }
            _ => (0.0, 0.0),
        };
        self.last_imu = Some((t, twist));
        let rng = &mut self.rng_imu;
        let az = self.vibration.sample(
            t,
            dt,
            twist.v_x.hypot(twist.v_y),
            m.odometer,
            &timeline.terrains[m.terrain],
            imu.vibration_gain,
            rng,
        );
        let an = imu.accel_noise;
        let gn = imu.gyro_noise;
        // Roll and pitch rates: the shaking seen by the gyro.
        let shake = 0.05 * az.abs();
        ImuSample {
            t,
            accel_z: GRAVITY + az + an * gauss(rng),
            accel_x: Some(ax + an * gauss(rng)),
            accel_y: Some(ay + an * gauss(rng)),
            gyro_x: Some((gn + shake) * gauss(rng)),
            gyro_y: Some((gn + shake) * gauss(rng)),
            gyro_z: Some(imu.gyro_scale * twist.omega + imu.gyro_bias + gn * gauss(rng)),
        }
    }

    /// A camera frame to render later: where the robot is, the ground's
    /// texture, and this frame's scale, lighting and noise.
    fn frame(&mut self, t: f64, m: &Motion, timeline: &Timeline) -> FrameSpec {
        let cam = &self.sc.camera;
        let rng = &mut self.rng_camera;
        FrameSpec {
            t,
            east: m.east,
            north: m.north,
            yaw: wrap(m.yaw),
            texture: timeline.terrains[m.terrain].texture,
            footprint: cam.footprint * (1.0 + rng.gen_range(-1.0..=1.0) * cam.scale_variation),
            gain: rng.gen_range(cam.lighting[0]..=cam.lighting[1]),
            shade_dir: rng.gen_range(0.0..TAU),
            shade: rng.gen_range(0.0..0.4),
            noise_seed: rng.gen(),
        }
    }
}

/// The GNSS multipath episodes `(start, end, east, north)`: the scenario's
/// own, then random ones drawn up front so they do not depend on the
/// receiver's rate.
fn gnss_jumps(sc: &Scenario, duration: f64, rng: &mut StdRng) -> Vec<(f64, f64, f64, f64)> {
    let g = &sc.gnss;
    let mut jumps: Vec<(f64, f64, f64, f64)> = g
        .jumps
        .iter()
        .map(|j| (j.start, j.start + j.duration, j.east, j.north))
        .collect();
    if g.multipath_rate > 0.0 && g.rate > 0.0 {
        let mut t = 0.0;
        loop {
            t += -(1.0 - rng.gen::<f64>()).ln() / g.multipath_rate;
            if t >= duration {
                break;
            }
            let [d0, d1] = g.multipath_duration;
            let len = rng.gen_range(d0..=d1.max(d0));
            let dir = rng.gen_range(0.0..TAU);
            let m = g.multipath_jump;
            jumps.push((t, t + len, m * dir.cos(), m * dir.sin()));
        }
    }
    jumps
}
