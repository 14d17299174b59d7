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
pub mod closed_loop;
pub mod family;
mod motion;
mod operator;
mod recorder;
pub mod robot;
pub mod scenario;
mod sensors;
pub mod terrain;
mod timeline;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use terraslip_core::kinematics::{IcrParams, Twist};
use terraslip_io::{write_atomic, write_csv, AtomicFile, DriveLog, LogError, Meta, TruthSample};

pub use camera::FrameSpec;
pub use scenario::{builtin_names, Scenario};
pub use terrain::Terrain;

use motion::Motion;
use operator::Operator;
use recorder::{Recorder, Recording};
use timeline::Timeline;

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

/// Runs `scenario` with `seed`. Deterministic: the same scenario and seed
/// give bit-identical logs. Cheap (tens of ms for a few minutes of driving):
/// camera frames are only described here and rendered by [`SimRun::write`]
/// or [`SimRun::render_frame`].
pub fn simulate(scenario: &Scenario, seed: u64) -> Result<SimRun, SimError> {
    let sc = scenario;
    sc.validate().map_err(|reason| SimError::Scenario {
        path: PathBuf::from(format!("<scenario {}>", sc.name)),
        line: 0,
        reason,
    })?;
    let robot = &sc.robot;
    let timeline = Timeline::new(sc)?;
    let duration = timeline.duration;

    let mut rng_operator = stream(seed, "operator");
    let yaw0 = rng_operator.gen_range(-std::f64::consts::PI..std::f64::consts::PI);
    let mut operator = Operator::new(sc.drive.clone(), rng_operator, robot.track_width);
    let mut motion = Motion::start(sc, &timeline, yaw0);
    let mut recorder = Recorder::new(sc, seed, duration);
    let mut rec = Recording {
        log: DriveLog {
            meta: Meta {
                robot: Some(robot.name.clone()),
                track_width: Some(robot.track_width),
                wheel_radius: Some(robot.wheel_radius),
                length: Some(robot.length),
                ticks_per_rev: Some(sc.wheels.ticks_per_rev),
                pose: (sc.gnss.lever_arm != [0.0; 2]).then_some(terraslip_io::PoseMount {
                    lever_arm_x: sc.gnss.lever_arm[0],
                    lever_arm_y: sc.gnss.lever_arm[1],
                }),
                ..Default::default()
            },
            terrain: timeline.labels.clone(),
            ..DriveLog::default()
        },
        ..Recording::default()
    };

    let mut t = 0.0_f64;
    loop {
        recorder.sample(t, &motion, &timeline, &mut rec);
        if t >= duration - 1e-9 {
            break;
        }
        // Integrate up to the next sample time, in steps of at most dt.
        // Sample times are exact (k / rate): a step that would stop just
        // short of one (rounding in the running sum) goes to it instead.
        let next_sample = recorder.next_time().min(duration);
        let t_next = if t + sc.integration.dt < next_sample - 1e-6 {
            t + sc.integration.dt
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
        motion.advance(t, h, &mut operator, sc, &timeline);
        t = t_next;
    }

    let Recording {
        mut log,
        truth,
        frames,
    } = rec;
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
    let terrain_changes = timeline.changes();
    Ok(SimRun {
        scenario: sc.clone(),
        seed,
        log,
        truth,
        terrains: timeline.terrains,
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
