//! A ground-truth drive simulator for skid-steering robots.
//!
//! The truth is the ICR kinematic model ([`IcrParams::twist`]) with
//! per-terrain ICRs that move a few percent with the turn rate and speed,
//! blended over a second at terrain borders, and tread speed factors alpha
//! != 1; it is integrated exactly (constant twist on each step) in steps of at
//! most 1 ms, so the truth is not any filter's discretisation. An operator
//! drives manoeuvres with rate-limited commands through wheel speed
//! controllers with lag. Each sensor samples at its own rate with its own
//! imperfections (see [`scenario`]).
//!
//! Frames: world ENU metres, yaw radians counter-clockwise from east; body
//! REP-103 (x forward, y left). Time in seconds from the start of the drive.
//!
//! ```no_run
//! use terraslip_sim::{simulate, Scenario};
//! let run = simulate(&Scenario::builtin("papers").unwrap(), 1).unwrap();
//! println!("{} wheel samples", run.log.wheels.len());
//! run.write("papers-log").unwrap();
//! ```

// `!(x <= 0.5)` is meant: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod camera;
pub mod family;
mod operator;
pub mod scenario;
mod sensors;
pub mod terrain;

use std::f64::consts::TAU;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use terraslip_core::angle::wrap;
use terraslip_core::kinematics::{IcrParams, Twist};
use terraslip_io::{
    write_atomic, write_csv, AtomicFile, DriveLog, ImageRef, ImuSample, LogError, Meta, PoseObs,
    TerrainLabel, TruthSample, WheelSample,
};

pub use camera::FrameSpec;
pub use scenario::{builtin_names, Scenario};
pub use terrain::Terrain;

use operator::Operator;
use sensors::{gauss, GaussMarkov, Vibration};

/// Standard gravity, m/s^2.
pub const GRAVITY: f64 = 9.80665;

/// Errors of the simulator.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A scenario file that does not parse or validate; `line` 0 = whole file.
    #[error("{}{}: {reason}", path.display(), if *line > 0 { format!(":{line}") } else { String::new() })]
    Scenario {
        path: PathBuf,
        line: usize,
        reason: String,
    },
    #[error("unknown scenario `{name}` (built-in: {known}; or give a .toml file)")]
    UnknownScenario { name: String, known: String },
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Log(#[from] LogError),
    #[error("{}: cannot encode image: {reason}", path.display())]
    Image { path: PathBuf, reason: String },
}

/// The full truth at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthState {
    /// s
    pub t: f64,
    /// m, ENU
    pub east: f64,
    pub north: f64,
    /// rad, wrapped to (-pi, pi]
    pub yaw: f64,
    /// The ICRs (and alphas) in force at `t`.
    pub icr: IcrParams,
    /// Body twist, REP-103.
    pub twist: Twist,
    /// True tread surface speeds as the encoders would see them without
    /// quantisation (i.e. before alpha), m/s.
    pub v_left: f64,
    pub v_right: f64,
    /// Index into [`SimRun::terrains`].
    pub terrain: usize,
}

/// One simulated drive, in memory.
#[derive(Debug, Clone)]
pub struct SimRun {
    /// The scenario that was run.
    pub scenario: Scenario,
    pub seed: u64,
    /// The sensor log (what the robot recorded) plus `truth` and `terrain`.
    /// `images` name files that exist only after [`SimRun::write`].
    pub log: DriveLog,
    /// Truth at `integration.truth_rate`, with alphas, twist and tread speeds.
    pub truth: Vec<TruthState>,
    /// The terrains of the drive, in order of first appearance.
    pub terrains: Vec<Terrain>,
    /// Camera frames to render (see [`SimRun::render_frame`]).
    pub frames: Vec<FrameSpec>,
    /// Start times of the terrain changes (the first segment excluded), s.
    pub terrain_changes: Vec<f64>,
}

/// One RNG stream per subsystem, so that e.g. switching the camera off does
/// not change the GNSS noise of a seed.
fn stream(seed: u64, name: &str) -> StdRng {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in name.bytes() {
        h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
    }
    StdRng::seed_from_u64(seed ^ h)
}

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

/// Moves `x` towards `target` by at most `max_step`.
fn slew(x: f64, target: f64, max_step: f64) -> f64 {
    x + (target - x).clamp(-max_step, max_step)
}

/// Exact pose increment in the world frame for a constant body twist over `h`.
fn se2_step(yaw: f64, tw: &Twist, h: f64) -> (f64, f64, f64) {
    let th = tw.omega * h;
    // sin(th)/th and (1-cos(th))/th, with their series near 0.
    let (a, b) = if th.abs() < 1e-6 {
        (1.0 - th * th / 6.0, 0.5 * th)
    } else {
        (th.sin() / th, (1.0 - th.cos()) / th)
    };
    let dx = (a * tw.v_x - b * tw.v_y) * h;
    let dy = (b * tw.v_x + a * tw.v_y) * h;
    let (s, c) = yaw.sin_cos();
    (c * dx - s * dy, s * dx + c * dy, th)
}

/// ICRs moved by the slip model: the spread scales by `factor` around the
/// ICRs' mid point, so the eccentricity stays that of the terrain.
fn scale_spread(p: &IcrParams, factor: f64) -> IcrParams {
    let mid = 0.5 * (p.y_l + p.y_r);
    IcrParams {
        y_l: mid + (p.y_l - mid) * factor,
        y_r: mid + (p.y_r - mid) * factor,
        ..*p
    }
}

fn blend(a: &IcrParams, b: &IcrParams, w: f64) -> IcrParams {
    let m = |x: f64, y: f64| x + (y - x) * w;
    IcrParams {
        y_l: m(a.y_l, b.y_l),
        y_r: m(a.y_r, b.y_r),
        x_c: m(a.x_c, b.x_c),
        alpha_l: m(a.alpha_l, b.alpha_l),
        alpha_r: m(a.alpha_r, b.alpha_r),
    }
}

/// Runs `scenario` with `seed`. Deterministic: the same scenario and seed
/// give bit-identical logs. Cheap (tens of ms for a few minutes of driving):
/// camera frames are only described here and rendered by [`SimRun::write`]
/// or [`SimRun::render_frame`].
pub fn simulate(scenario: &Scenario, seed: u64) -> Result<SimRun, SimError> {
    scenario.validate().map_err(|reason| SimError::Scenario {
        path: PathBuf::from(format!("<scenario {}>", scenario.name)),
        line: 0,
        reason,
    })?;
    let sc = scenario;
    let robot = &sc.robot;
    let w = robot.track_width;

    // Terrain schedule.
    let mut terrains: Vec<Terrain> = Vec::new();
    let mut schedule: Vec<(f64, usize)> = Vec::new(); // (start, terrain index)
    let mut labels = Vec::new();
    let mut t0 = 0.0;
    for seg in &sc.segments {
        let ter = sc
            .terrain(&seg.terrain)
            .map_err(|reason| SimError::Scenario {
                path: PathBuf::from(format!("<scenario {}>", sc.name)),
                line: 0,
                reason,
            })?;
        let idx = match terrains.iter().position(|t| t.name == ter.name) {
            Some(i) => i,
            None => {
                terrains.push(ter);
                terrains.len() - 1
            }
        };
        schedule.push((t0, idx));
        labels.push(TerrainLabel {
            t: t0,
            terrain: seg.terrain.clone(),
        });
        t0 += seg.duration;
    }
    let duration = t0;
    let nominal: Vec<IcrParams> = terrains.iter().map(|t| t.icr(robot)).collect();
    let terrain_changes: Vec<f64> = schedule
        .windows(2)
        .filter(|w| w[0].1 != w[1].1)
        .map(|w| w[1].0)
        .collect();

    // Nominal ICRs (terrain blend, before the slip model) and terrain at t.
    let segment_at = |t: f64| -> usize { schedule.partition_point(|s| s.0 <= t).saturating_sub(1) };
    let nominal_at = |t: f64| -> (IcrParams, usize) {
        let i = segment_at(t);
        let (start, ti) = schedule[i];
        let here = nominal[ti];
        if i == 0 || sc.slip.transition <= 0.0 || t - start >= sc.slip.transition {
            return (here, ti);
        }
        let prev = nominal[schedule[i - 1].1];
        (blend(&prev, &here, (t - start) / sc.slip.transition), ti)
    };

    let mut rng_op = stream(seed, "operator");
    let mut rng_gnss = stream(seed, "gnss");
    let mut rng_compass = stream(seed, "compass");
    let mut rng_imu = stream(seed, "imu");
    let mut rng_cam = stream(seed, "camera");

    // Random multipath episodes, drawn up front so they do not depend on
    // the receiver's rate.
    let mut jumps: Vec<(f64, f64, f64, f64)> = sc
        .gnss
        .jumps
        .iter()
        .map(|j| (j.start, j.start + j.duration, j.east, j.north))
        .collect();
    if sc.gnss.multipath_rate > 0.0 && sc.gnss.rate > 0.0 {
        let mut t = 0.0;
        loop {
            t += -(1.0 - rng_gnss.gen::<f64>()).ln() / sc.gnss.multipath_rate;
            if t >= duration {
                break;
            }
            let [d0, d1] = sc.gnss.multipath_duration;
            let len = rng_gnss.gen_range(d0..=d1.max(d0));
            let dir = rng_gnss.gen_range(0.0..TAU);
            let m = sc.gnss.multipath_jump;
            jumps.push((t, t + len, m * dir.cos(), m * dir.sin()));
        }
    }
    let in_outage = |t: f64| {
        sc.gnss
            .outages
            .iter()
            .any(|o| t >= o.start && t < o.start + o.duration)
    };

    let yaw0 = rng_op.gen_range(-std::f64::consts::PI..std::f64::consts::PI);
    let mut operator = Operator::new(sc.drive.clone(), rng_op, w);

    let mut gm_e = GaussMarkov::new(sc.gnss.markov_std, sc.gnss.markov_tau, &mut rng_gnss);
    let mut gm_n = GaussMarkov::new(sc.gnss.markov_std, sc.gnss.markov_tau, &mut rng_gnss);
    let mut gm_t = 0.0;
    let compass_bias = sc.compass.bias_deg.to_radians();
    let mut vibration = Vibration::new();
    let gyro_bias = sc.imu.gyro_bias;

    // State.
    let (mut east, mut north, mut yaw) = (0.0_f64, 0.0_f64, yaw0);
    let (mut cmd_v, mut cmd_w) = (0.0_f64, 0.0_f64);
    let (mut vl, mut vr) = (0.0_f64, 0.0_f64);
    let (mut ang_l, mut ang_r) = (0.0_f64, 0.0_f64);
    let mut slip_factor = 1.0 - 0.5 * sc.slip.turn_sensitivity;
    let mut odometer = 0.0;
    let (nom0, ter0) = nominal_at(0.0);
    let mut icr = scale_spread(&nom0, slip_factor);
    let mut terrain_idx = ter0;
    let mut twist = Twist::default();
    let mut t = 0.0_f64;

    let mut c_truth = Clock::new(sc.integration.truth_rate);
    let mut c_wheels = Clock::new(sc.wheels.rate);
    let mut c_gnss = Clock::new(sc.gnss.rate);
    let mut c_compass = Clock::new(sc.compass.rate);
    let mut c_imu = Clock::new(sc.imu.rate);
    let mut c_cam = Clock::new(sc.camera.rate);

    let tick_len = TAU * robot.wheel_radius / sc.wheels.ticks_per_rev;
    let ticks_of = |ang: f64| (ang / TAU * sc.wheels.ticks_per_rev).floor();
    let (mut last_ticks_l, mut last_ticks_r, mut last_wheel_t) = (0.0, 0.0, f64::NAN);
    let mut last_imu: Option<(f64, Twist)> = None;

    let mut log = DriveLog {
        meta: Meta {
            robot: Some(robot.name.clone()),
            track_width: Some(robot.track_width),
            wheel_radius: Some(robot.wheel_radius),
            length: Some(robot.length),
            ticks_per_rev: Some(sc.wheels.ticks_per_rev),
        },
        terrain: labels,
        ..DriveLog::default()
    };
    let mut truth = Vec::new();
    let mut frames = Vec::new();
    let dt_max = sc.integration.dt;
    let lag = sc.drive.wheel_lag;

    loop {
        // Sample every sensor due now, from the state at t.
        if c_truth.due(t) {
            truth.push(TruthState {
                t,
                east,
                north,
                yaw: wrap(yaw),
                icr,
                twist,
                v_left: vl,
                v_right: vr,
                terrain: terrain_idx,
            });
        }
        if c_wheels.due(t) {
            let (tl, tr) = (ticks_of(ang_l), ticks_of(ang_r));
            let dt = t - last_wheel_t;
            let (v_left, v_right) = if dt.is_finite() && dt > 0.0 {
                (
                    (tl - last_ticks_l) * tick_len / dt,
                    (tr - last_ticks_r) * tick_len / dt,
                )
            } else {
                (0.0, 0.0)
            };
            log.wheels.push(WheelSample { t, v_left, v_right });
            (last_ticks_l, last_ticks_r, last_wheel_t) = (tl, tr, t);
        }
        if c_gnss.due(t) {
            let e_err = gm_e.step(t - gm_t, &mut rng_gnss);
            let n_err = gm_n.step(t - gm_t, &mut rng_gnss);
            gm_t = t;
            let we = sc.gnss.white_std * gauss(&mut rng_gnss);
            let wn = sc.gnss.white_std * gauss(&mut rng_gnss);
            if !in_outage(t) {
                let (je, jn) = jumps
                    .iter()
                    .filter(|j| t >= j.0 && t < j.1)
                    .fold((0.0, 0.0), |acc, j| (acc.0 + j.2, acc.1 + j.3));
                log.pose.push(PoseObs {
                    t,
                    east: Some(east + e_err + we + je),
                    north: Some(north + n_err + wn + jn),
                    yaw: None,
                    std_xy: Some(sc.gnss.reported_std),
                    std_yaw: None,
                });
            }
        }
        if c_compass.due(t) {
            let y = wrap(
                yaw + compass_bias + sc.compass.std_deg.to_radians() * gauss(&mut rng_compass),
            );
            let std_yaw = Some(sc.compass.reported_std_deg.to_radians());
            match log.pose.last_mut() {
                Some(p) if p.t == t && p.yaw.is_none() => {
                    p.yaw = Some(y);
                    p.std_yaw = std_yaw;
                }
                _ => log.pose.push(PoseObs {
                    t,
                    yaw: Some(y),
                    std_yaw,
                    ..PoseObs::default()
                }),
            }
        }
        if c_imu.due(t) {
            let dt = 1.0 / sc.imu.rate;
            let (ax, ay) = match last_imu {
                Some((tp, tw)) if t > tp => {
                    let h = t - tp;
                    (
                        (twist.v_x - tw.v_x) / h - twist.omega * twist.v_y,
                        (twist.v_y - tw.v_y) / h + twist.omega * twist.v_x,
                    )
                }
                _ => (0.0, 0.0),
            };
            last_imu = Some((t, twist));
            let ter = &terrains[terrain_idx];
            let az = vibration.sample(
                t,
                dt,
                twist.v_x.hypot(twist.v_y),
                odometer,
                ter,
                sc.imu.vibration_gain,
                &mut rng_imu,
            );
            let an = sc.imu.accel_noise;
            let gn = sc.imu.gyro_noise;
            // Roll and pitch rates: the shaking seen by the gyro.
            let shake = 0.05 * az.abs();
            log.imu.push(ImuSample {
                t,
                accel_z: GRAVITY + az + an * gauss(&mut rng_imu),
                accel_x: Some(ax + an * gauss(&mut rng_imu)),
                accel_y: Some(ay + an * gauss(&mut rng_imu)),
                gyro_x: Some((gn + shake) * gauss(&mut rng_imu)),
                gyro_y: Some((gn + shake) * gauss(&mut rng_imu)),
                gyro_z: Some(twist.omega + gyro_bias + gn * gauss(&mut rng_imu)),
            });
        }
        if c_cam.due(t) {
            let cam = &sc.camera;
            let i = frames.len();
            let path = PathBuf::from(format!("images/{i:06}.png"));
            frames.push(FrameSpec {
                t,
                east,
                north,
                yaw: wrap(yaw),
                texture: terrains[terrain_idx].texture,
                footprint: cam.footprint
                    * (1.0 + rng_cam.gen_range(-1.0..=1.0) * cam.scale_variation),
                gain: rng_cam.gen_range(cam.lighting[0]..=cam.lighting[1]),
                shade_dir: rng_cam.gen_range(0.0..TAU),
                shade: rng_cam.gen_range(0.0..0.4),
                noise_seed: rng_cam.gen(),
            });
            log.images.push(ImageRef { t, path });
        }

        if t >= duration - 1e-9 {
            break;
        }
        // Integrate up to the next sample time, in steps of at most dt_max.
        // Sample times are exact (k / rate): a step that would stop just
        // short of one (rounding in the running sum) goes to it instead.
        let next_sample = [
            duration,
            c_truth.next(),
            c_wheels.next(),
            c_gnss.next(),
            c_compass.next(),
            c_imu.next(),
            c_cam.next(),
        ]
        .into_iter()
        .fold(f64::INFINITY, f64::min);
        let t_next = if t + dt_max < next_sample - 1e-6 {
            t + dt_max
        } else {
            next_sample
        };
        let h = t_next - t;
        if h <= 0.0 {
            // A sample time at t that was not consumed cannot happen (every
            // clock was polled above); guard against an endless loop anyway.
            t = t_next + 1e-9;
            continue;
        }

        // Operator -> rate-limited command -> wheel set points -> wheel lag.
        let (tv, tw) = operator.command(t, east, north, yaw);
        cmd_v = slew(cmd_v, tv, sc.drive.accel_limit * h);
        cmd_w = slew(cmd_w, tw, sc.drive.yaw_accel_limit * h);
        let (mut sl, mut sr) = (cmd_v - 0.5 * w * cmd_w, cmd_v + 0.5 * w * cmd_w);
        let peak = sl.abs().max(sr.abs());
        if peak > robot.max_tread_speed {
            let k = robot.max_tread_speed / peak;
            sl *= k;
            sr *= k;
        }
        let follow = if lag > 0.0 {
            1.0 - (-h / lag).exp()
        } else {
            1.0
        };
        vl += (sl - vl) * follow;
        vr += (sr - vr) * follow;

        // Slip: the spread follows the motion with a lag.
        let turn = (vr - vl) / w;
        let speed = 0.5 * (vl + vr);
        let s = &sc.slip;
        let target = 1.0
            + s.turn_sensitivity * ((turn.abs() / s.turn_rate_ref).tanh() - 0.5)
            + s.speed_sensitivity * (speed.abs() - 0.5);
        slip_factor += (target - slip_factor)
            * if s.lag > 0.0 {
                1.0 - (-h / s.lag).exp()
            } else {
                1.0
            };
        let (nom, ti) = nominal_at(t);
        icr = scale_spread(&nom, slip_factor);
        terrain_idx = ti;

        twist = icr.twist(vl, vr);
        let (de, dn, dyaw) = se2_step(yaw, &twist, h);
        east += de;
        north += dn;
        yaw += dyaw;
        ang_l += vl / robot.wheel_radius * h;
        ang_r += vr / robot.wheel_radius * h;
        odometer += twist.v_x.hypot(twist.v_y) * h;
        t = t_next;
    }

    log.truth = truth
        .iter()
        .map(|s| TruthSample {
            t: s.t,
            east: s.east,
            north: s.north,
            yaw: s.yaw,
            y_l: s.icr.y_l,
            y_r: s.icr.y_r,
            x_c: s.icr.x_c,
        })
        .collect();
    Ok(SimRun {
        scenario: sc.clone(),
        seed,
        log,
        truth,
        terrains,
        frames,
        terrain_changes,
    })
}

impl SimRun {
    /// Renders camera frame `i` (see [`FrameSpec`]); `None` past the end.
    pub fn render_frame(&self, i: usize) -> Option<image::RgbImage> {
        self.frames
            .get(i)
            .map(|f| camera::render(f, &self.scenario.camera))
    }

    /// The truth state nearest before `t` (the first one before the start).
    pub fn truth_at(&self, t: f64) -> Option<&TruthState> {
        let i = self.truth.partition_point(|s| s.t <= t).saturating_sub(1);
        self.truth.get(i)
    }

    /// Writes the log directory (created if needed): the files of
    /// `log-format.md`, `truth.csv` with extra columns (alphas, body twist,
    /// terrain), `meta.toml` with the scenario and seed, the rendered
    /// `images/`, and the scenario itself as `scenario.toml`. Every file
    /// appears atomically.
    pub fn write(&self, dir: impl AsRef<Path>) -> Result<(), SimError> {
        self.write_with_progress(dir, |_, _| {})
    }

    /// As [`SimRun::write`], calling `progress(done, total)` after each frame.
    pub fn write_with_progress(
        &self,
        dir: impl AsRef<Path>,
        mut progress: impl FnMut(usize, usize),
    ) -> Result<(), SimError> {
        let dir = dir.as_ref();
        self.log.write(dir)?;
        // Richer truth than DriveLog knows about; readers ignore extra columns.
        write_csv(
            &dir.join("truth.csv"),
            "t,east,north,yaw,y_l,y_r,x_c,alpha_l,alpha_r,v_x,v_y,omega,terrain",
            &self.truth,
            |s, b| {
                let _ = write!(
                    b,
                    "{},{},{},{},{},{},{},{},{},{},{},{},{}",
                    s.t,
                    s.east,
                    s.north,
                    s.yaw,
                    s.icr.y_l,
                    s.icr.y_r,
                    s.icr.x_c,
                    s.icr.alpha_l,
                    s.icr.alpha_r,
                    s.twist.v_x,
                    s.twist.v_y,
                    s.twist.omega,
                    self.terrains[s.terrain].name
                );
            },
        )?;
        let mut meta = toml::to_string(&self.log.meta).unwrap_or_default();
        let _ = write!(
            meta,
            "\n# simulated by terraslip-sim {}\nscenario = {:?}\nseed = {}\n",
            env!("CARGO_PKG_VERSION"),
            self.scenario.name,
            self.seed
        );
        write_atomic(dir.join("meta.toml"), meta.as_bytes())?;
        let scen = toml::to_string(&self.scenario).map_err(|e| SimError::Scenario {
            path: dir.join("scenario.toml"),
            line: 0,
            reason: e.to_string(),
        })?;
        write_atomic(dir.join("scenario.toml"), scen.as_bytes())?;
        if !self.frames.is_empty() {
            let img_dir = dir.join("images");
            std::fs::create_dir_all(&img_dir).map_err(|e| SimError::Io {
                path: img_dir.clone(),
                source: e,
            })?;
            for (i, r) in self.log.images.iter().enumerate() {
                let img = camera::render(&self.frames[i], &self.scenario.camera);
                let path = dir.join(&r.path);
                let mut f = AtomicFile::create(&path)?;
                image::codecs::png::PngEncoder::new_with_quality(
                    &mut f,
                    image::codecs::png::CompressionType::Fast,
                    image::codecs::png::FilterType::Sub,
                )
                .write_image(
                    img.as_raw(),
                    img.width(),
                    img.height(),
                    image::ExtendedColorType::Rgb8,
                )
                .map_err(|e| SimError::Image {
                    path: path.clone(),
                    reason: e.to_string(),
                })?;
                f.commit()?;
                progress(i + 1, self.frames.len());
            }
        }
        Ok(())
    }
}

use image::ImageEncoder as _;
