//! Scenario files: what robot drives where, how the operator drives, and what
//! the sensors are like. TOML, every table optional except `[[segment]]`;
//! unknown keys are errors so a typo never silently falls back to a default.
//! `docs/simulator.md` documents every key; the built-in scenarios under
//! `scenarios/` are complete examples.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};
use terraslip_core::kinematics::IcrParams;

use crate::terrain::{self, Terrain, TerrainSpec};
use crate::SimError;

/// Built-in scenarios: (name, TOML text). `NAME-rtk` variants are derived by
/// [`Scenario::with_rtk`].
const BUILTINS: &[(&str, &str)] = &[
    ("papers", include_str!("../scenarios/papers.toml")),
    ("papers-icr3", include_str!("../scenarios/papers-icr3.toml")),
    ("wang4", include_str!("../scenarios/wang4.toml")),
    ("p3at-calib", include_str!("../scenarios/p3at-calib.toml")),
    (
        "p3at-terrains",
        include_str!("../scenarios/p3at-terrains.toml"),
    ),
    ("gnss-outage", include_str!("../scenarios/gnss-outage.toml")),
];

/// Names and one-line descriptions of every built-in scenario, including the
/// derived `-rtk` variant of each one that does not already have an RTK-grade
/// reference.
pub fn builtin_names() -> Vec<(String, String)> {
    let mut out = Vec::new();
    for (name, _) in BUILTINS {
        // The embedded files are tested to parse; an error here is a bug,
        // so it is skipped rather than propagated into a listing.
        if let Ok(s) = Scenario::builtin(name) {
            out.push((s.name.clone(), s.description.clone()));
            if !s.gnss.is_rtk() {
                let r = s.with_rtk();
                out.push((r.name, r.description));
            }
        }
    }
    out
}

/// A complete simulation scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name, written to `meta.toml`.
    #[serde(default = "default_name")]
    pub name: String,
    /// One line shown by `terraslip simulate --list`.
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub robot: Robot,
    /// The terrains driven, in order; each lasts `duration` seconds.
    #[serde(rename = "segment")]
    pub segments: Vec<Segment>,
    /// Overrides of (or additions to) the terrain catalogue, by name.
    #[serde(default)]
    pub terrains: BTreeMap<String, TerrainSpec>,
    #[serde(default)]
    pub slip: Slip,
    #[serde(default)]
    pub drive: Drive,
    #[serde(default)]
    pub integration: Integration,
    #[serde(default)]
    pub wheels: Wheels,
    #[serde(default)]
    pub gnss: Gnss,
    #[serde(default)]
    pub compass: Compass,
    #[serde(default)]
    pub imu: Imu,
    #[serde(default)]
    pub camera: Camera,
}

fn default_name() -> String {
    "custom".into()
}

/// The robot's geometry (nominal, what `meta.toml` says).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Robot {
    pub name: String,
    /// Distance between tread centre lines, m.
    pub track_width: f64,
    /// Nominal wheel radius, m (encoder ticks -> tread speed).
    pub wheel_radius: f64,
    /// Body length, m (scales the default x_c of the catalogue).
    pub length: f64,
    /// Top tread speed, m/s: commands are clipped to it.
    pub max_tread_speed: f64,
}

impl Default for Robot {
    /// The four-wheeled robot of lv2019 §IV: 400 x 320 mm, 130 mm wheels 60 mm
    /// wide, so about 0.26 m between the wheel centre lines.
    fn default() -> Self {
        Self {
            name: "lv2019-4wd".into(),
            track_width: 0.26,
            wheel_radius: 0.065,
            length: 0.40,
            max_tread_speed: 1.6,
        }
    }
}

/// One stretch of terrain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Segment {
    /// Terrain name: a catalogue entry (see [`terrain::CATALOGUE`]) or a key of `[terrains]`.
    pub terrain: String,
    /// s
    pub duration: f64,
}

/// How the true ICRs move around the terrain's nominal values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Slip {
    /// Relative change of the spread y_l - y_r between straight driving and
    /// fast turning (|omega| >> `turn_rate_ref`): 0.04 = the spread is 2 %
    /// below nominal going straight and about 2 % above in fast turns;
    /// negative = the spread shrinks in fast turns (-0.5..0.5).
    pub turn_sensitivity: f64,
    /// Turn rate where the turn effect is half way, rad/s.
    pub turn_rate_ref: f64,
    /// Relative change of the spread per m/s of forward speed away from
    /// 0.5 m/s (-0.2..0.2).
    pub speed_sensitivity: f64,
    /// Time constant with which the slip follows the motion, s.
    pub lag: f64,
    /// Time over which the ICRs blend from one terrain into the next, s
    /// (the robot's length crossing the border).
    pub transition: f64,
}

impl Default for Slip {
    fn default() -> Self {
        Self {
            turn_sensitivity: 0.04,
            turn_rate_ref: 0.6,
            speed_sensitivity: 0.01,
            lag: 0.3,
            transition: 1.0,
        }
    }
}

/// Kind of manoeuvre for an explicit drive programme.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ManoeuvreKind {
    Straight,
    Arc,
    Spin,
    SCurve,
    Stop,
}

/// One manoeuvre of an explicit programme.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ManoeuvreSpec {
    pub kind: ManoeuvreKind,
    /// s
    pub duration: f64,
    /// Forward speed, m/s (straight, arc, s_curve).
    #[serde(default)]
    pub speed: f64,
    /// Commanded turn radius, m, positive = left (arc, s_curve).
    #[serde(default)]
    pub radius: f64,
    /// Yaw rate of a spin in place, rad/s, positive = counter-clockwise.
    #[serde(default)]
    pub rate: f64,
    /// Period of an S-curve, s.
    #[serde(default)]
    pub period: f64,
}

/// The operator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Drive {
    /// Forward speeds drawn for each manoeuvre, [min, max] m/s.
    pub speed: [f64; 2],
    /// Arc radii the operator picks from, m (sign drawn at random).
    pub radii: Vec<f64>,
    /// Spin-in-place yaw rates, [min, max] rad/s.
    pub spin_rate: [f64; 2],
    /// Relative frequency of straight, arc, spin, s_curve, stop.
    pub mix: Mix,
    /// Manoeuvre lengths, [min, max] s.
    pub duration: [f64; 2],
    /// The operator stays within this distance of the start, m.
    pub area_radius: f64,
    /// Limits that make speed changes smooth: m/s^2 and rad/s^2.
    pub accel_limit: f64,
    pub yaw_accel_limit: f64,
    /// Wheel speed controller time constant, s.
    pub wheel_lag: f64,
    /// An explicit programme, repeated until the drive ends. When empty the
    /// operator improvises from the settings above.
    pub manoeuvres: Vec<ManoeuvreSpec>,
}

impl Default for Drive {
    fn default() -> Self {
        Self {
            speed: [0.3, 1.0],
            radii: vec![1.0, 2.0, 4.0, 8.0],
            spin_rate: [0.5, 1.5],
            mix: Mix::default(),
            duration: [4.0, 12.0],
            area_radius: 35.0,
            accel_limit: 0.5,
            yaw_accel_limit: 1.5,
            wheel_lag: 0.15,
            manoeuvres: Vec::new(),
        }
    }
}

/// Relative frequency of each manoeuvre kind.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Mix {
    pub straight: f64,
    pub arc: f64,
    pub spin: f64,
    pub s_curve: f64,
    pub stop: f64,
}

impl Default for Mix {
    fn default() -> Self {
        Self {
            straight: 2.0,
            arc: 4.0,
            spin: 0.7,
            s_curve: 2.0,
            stop: 0.5,
        }
    }
}

/// Ground-truth integration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Integration {
    /// Largest integration step, s (at most 0.001).
    pub dt: f64,
    /// Rate of the rows of `truth.csv`, Hz.
    pub truth_rate: f64,
}

impl Default for Integration {
    fn default() -> Self {
        Self {
            dt: 0.001,
            truth_rate: 50.0,
        }
    }
}

/// Wheel encoders.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Wheels {
    /// Hz
    pub rate: f64,
    /// Encoder ticks per wheel revolution.
    pub ticks_per_rev: f64,
}

impl Default for Wheels {
    fn default() -> Self {
        Self {
            rate: 50.0,
            ticks_per_rev: 540.0,
        }
    }
}

/// A time window, s from the start of the drive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Window {
    pub start: f64,
    pub duration: f64,
}

/// A scheduled multipath jump.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Jump {
    pub start: f64,
    pub duration: f64,
    /// Offset of the reported position, m east and north.
    pub east: f64,
    pub north: f64,
}

/// GNSS receiver (position only; heading comes from [`Compass`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Gnss {
    /// Hz; 0 disables the receiver.
    pub rate: f64,
    /// White error per axis, 1-sigma m.
    pub white_std: f64,
    /// Stationary std of the first-order Gauss-Markov error per axis, m.
    pub markov_std: f64,
    /// Correlation time of the Gauss-Markov error, s.
    pub markov_tau: f64,
    /// The `std_xy` the receiver reports in `pose.csv`, m.
    pub reported_std: f64,
    /// Random multipath jumps per second (Poisson).
    pub multipath_rate: f64,
    /// Size of a random multipath jump, m (direction drawn at random).
    pub multipath_jump: f64,
    /// Length of a random multipath jump, [min, max] s.
    pub multipath_duration: [f64; 2],
    /// Scheduled jumps (for tests and demos that need one at a known time).
    pub jumps: Vec<Jump>,
    /// Outages: no position fixes in these windows.
    pub outages: Vec<Window>,
}

impl Default for Gnss {
    /// lv2019's receiver: 1 Hz, "2 m", the error correlated over tens of seconds.
    fn default() -> Self {
        Self {
            rate: 1.0,
            white_std: 0.8,
            markov_std: 1.8,
            markov_tau: 30.0,
            reported_std: 2.0,
            multipath_rate: 0.002,
            multipath_jump: 30.0,
            multipath_duration: [1.0, 3.0],
            jumps: Vec::new(),
            outages: Vec::new(),
        }
    }
}

impl Gnss {
    /// An RTK-grade receiver: centimetre white error, no multipath.
    pub fn rtk(rate: f64) -> Self {
        Self {
            rate,
            white_std: 0.01,
            markov_std: 0.01,
            markov_tau: 20.0,
            reported_std: 0.015,
            multipath_rate: 0.0,
            multipath_jump: 0.0,
            multipath_duration: [1.0, 1.0],
            jumps: Vec::new(),
            outages: Vec::new(),
        }
    }

    /// Total 1-sigma error per axis, m (without jumps).
    pub fn total_std(&self) -> f64 {
        self.white_std.hypot(self.markov_std)
    }

    fn is_rtk(&self) -> bool {
        self.total_std() < 0.05
    }
}

/// Heading sensor (compass or dual-antenna GNSS heading).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Compass {
    /// Hz; 0 disables it.
    pub rate: f64,
    /// White noise, 1-sigma degrees.
    pub std_deg: f64,
    /// Constant bias, degrees (magnetic declination left uncorrected, mounting).
    pub bias_deg: f64,
    /// The `std_yaw` reported in `pose.csv`, degrees.
    pub reported_std_deg: f64,
}

impl Default for Compass {
    fn default() -> Self {
        Self {
            rate: 1.0,
            std_deg: 1.0,
            bias_deg: 0.5,
            reported_std_deg: 1.0,
        }
    }
}

/// Inertial unit mounted on the chassis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Imu {
    /// Hz; 0 disables it.
    pub rate: f64,
    /// Accelerometer white noise, m/s^2.
    pub accel_noise: f64,
    /// Gyro white noise, rad/s.
    pub gyro_noise: f64,
    /// Gyro z bias, rad/s.
    pub gyro_bias: f64,
    /// Scales every terrain's vibration (1 = catalogue values).
    pub vibration_gain: f64,
}

impl Default for Imu {
    fn default() -> Self {
        Self {
            rate: 200.0,
            accel_noise: 0.02,
            gyro_noise: 0.004,
            gyro_bias: 0.003,
            vibration_gain: 1.0,
        }
    }
}

/// Downward-looking ground camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Camera {
    /// Frames per second; 0 disables the camera.
    pub rate: f64,
    /// Pixels.
    pub width: u32,
    pub height: u32,
    /// Width of the ground patch seen at nominal height, m.
    pub footprint: f64,
    /// Relative variation of the footprint (camera height, pitch), e.g. 0.15.
    pub scale_variation: f64,
    /// Brightness gain range [min, max] (sun, cloud, shadow).
    pub lighting: [f64; 2],
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            rate: 0.5,
            width: 320,
            height: 240,
            footprint: 0.5,
            scale_variation: 0.15,
            lighting: [0.6, 1.3],
        }
    }
}

impl Scenario {
    /// A built-in scenario by name; `NAME-rtk` gives the RTK-grade variant of `NAME`.
    pub fn builtin(name: &str) -> Result<Self, SimError> {
        if let Some((_, text)) = BUILTINS.iter().find(|(n, _)| *n == name) {
            return Self::from_toml_str(text, Path::new(&format!("<builtin {name}>")));
        }
        if let Some(base) = name.strip_suffix("-rtk") {
            if BUILTINS.iter().any(|(n, _)| *n == base) {
                return Ok(Self::builtin(base)?.with_rtk());
            }
        }
        Err(SimError::UnknownScenario {
            name: name.to_string(),
            known: builtin_names()
                .into_iter()
                .map(|(n, _)| n)
                .collect::<Vec<_>>()
                .join(", "),
        })
    }

    /// Reads and validates a scenario file.
    pub fn from_toml_file(path: impl AsRef<Path>) -> Result<Self, SimError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| SimError::Io {
            path: path.to_path_buf(),
            source: e,
        })?;
        Self::from_toml_str(&text, path)
    }

    /// Parses and validates scenario text; `origin` names it in errors.
    pub fn from_toml_str(text: &str, origin: &Path) -> Result<Self, SimError> {
        let s: Scenario = toml::from_str(text).map_err(|e| {
            let line = e
                .span()
                .map(|sp| text[..sp.start.min(text.len())].matches('\n').count() + 1)
                .unwrap_or(1);
            SimError::Scenario {
                path: origin.to_path_buf(),
                line,
                reason: e.message().trim().to_string(),
            }
        })?;
        s.validate().map_err(|reason| SimError::Scenario {
            path: origin.to_path_buf(),
            line: 0,
            reason,
        })?;
        Ok(s)
    }

    /// A name or a path: a built-in if one has that name, else a TOML file.
    pub fn resolve(name_or_path: &str) -> Result<Self, SimError> {
        let p = Path::new(name_or_path);
        // A directory of that name (say, a log written earlier with
        // `--out papers`) does not shadow the built-in.
        if p.extension().is_some_and(|e| e == "toml") || p.is_file() {
            Self::from_toml_file(p)
        } else {
            Self::builtin(name_or_path)
        }
    }

    /// The same drive with an RTK-grade reference: 5 Hz centimetre fixes, a
    /// 0.2° dual-antenna heading, no multipath. Outages are kept (they are
    /// part of the drive), scheduled jumps are dropped.
    pub fn with_rtk(&self) -> Self {
        let mut s = self.clone();
        let outages = std::mem::take(&mut s.gnss.outages);
        s.gnss = Gnss::rtk(5.0);
        s.gnss.outages = outages;
        s.compass = Compass {
            rate: 5.0,
            std_deg: 0.2,
            bias_deg: 0.0,
            reported_std_deg: 0.2,
        };
        s.name = format!("{}-rtk", self.name);
        s.description = format!(
            "{} [RTK-grade reference: 5 Hz, 1.5 cm, 0.2°]",
            self.description
        );
        s
    }

    /// Total duration, s.
    pub fn duration(&self) -> f64 {
        self.segments.iter().map(|s| s.duration).sum()
    }

    /// The terrain `name`: the catalogue entry with this scenario's overrides.
    pub fn terrain(&self, name: &str) -> Result<Terrain, String> {
        match self.terrains.get(name) {
            Some(spec) => spec.resolve(name),
            None => terrain::catalogue(name).ok_or_else(|| {
                format!(
                    "unknown terrain `{name}` (catalogue: {}; or define it under [terrains.{name}] with `like`)",
                    terrain::CATALOGUE.join(", ")
                )
            }),
        }
    }

    /// The true nominal ICRs of terrain `name` for this robot (the slip
    /// model moves them a few percent with the motion).
    pub fn terrain_icr(&self, name: &str) -> Result<IcrParams, String> {
        self.terrain(name).map(|t| t.icr(&self.robot))
    }

    /// Checks every number; the reason names the key.
    pub fn validate(&self) -> Result<(), String> {
        fn pos(name: &str, v: f64) -> Result<(), String> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("`{name}` = {v} must be a positive number"))
            }
        }
        fn nonneg(name: &str, v: f64) -> Result<(), String> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("`{name}` = {v} must be zero or positive"))
            }
        }
        fn range(name: &str, r: [f64; 2]) -> Result<(), String> {
            nonneg(name, r[0])?;
            nonneg(name, r[1])?;
            if r[0] <= r[1] {
                Ok(())
            } else {
                Err(format!("`{name}` = [{}, {}]: min above max", r[0], r[1]))
            }
        }
        let r = &self.robot;
        pos("robot.track_width", r.track_width)?;
        pos("robot.wheel_radius", r.wheel_radius)?;
        pos("robot.length", r.length)?;
        pos("robot.max_tread_speed", r.max_tread_speed)?;
        if self.segments.is_empty() {
            return Err("no `[[segment]]`: a scenario needs at least one terrain segment".into());
        }
        for (i, seg) in self.segments.iter().enumerate() {
            pos(&format!("segment[{i}].duration"), seg.duration)?;
            let spec = self
                .terrain(&seg.terrain)
                .map_err(|e| format!("segment[{i}]: {e}"))?;
            spec.icr(r)
                .validate()
                .map_err(|e| format!("terrain `{}`: {e}", seg.terrain))?;
        }
        for (name, spec) in &self.terrains {
            spec.resolve(name)?;
        }
        let s = &self.slip;
        if !(s.turn_sensitivity.abs() <= 0.5) {
            return Err("`slip.turn_sensitivity` beyond +-0.5 is not a plausible robot".into());
        }
        pos("slip.turn_rate_ref", s.turn_rate_ref)?;
        if !(s.speed_sensitivity.abs() <= 0.2) {
            return Err(
                "`slip.speed_sensitivity` beyond +-0.2 per m/s is not a plausible robot".into(),
            );
        }
        nonneg("slip.lag", s.lag)?;
        nonneg("slip.transition", s.transition)?;
        let d = &self.drive;
        range("drive.speed", d.speed)?;
        range("drive.spin_rate", d.spin_rate)?;
        range("drive.duration", d.duration)?;
        pos("drive.duration[1]", d.duration[1])?;
        if d.radii.is_empty() {
            return Err("`drive.radii` must not be empty".into());
        }
        for v in &d.radii {
            pos("drive.radii", *v)?;
        }
        let m = &d.mix;
        for (n, v) in [
            ("straight", m.straight),
            ("arc", m.arc),
            ("spin", m.spin),
            ("s_curve", m.s_curve),
            ("stop", m.stop),
        ] {
            nonneg(&format!("drive.mix.{n}"), v)?;
        }
        pos(
            "drive.mix (sum)",
            m.straight + m.arc + m.spin + m.s_curve + m.stop,
        )?;
        pos("drive.area_radius", d.area_radius)?;
        pos("drive.accel_limit", d.accel_limit)?;
        pos("drive.yaw_accel_limit", d.yaw_accel_limit)?;
        nonneg("drive.wheel_lag", d.wheel_lag)?;
        for (i, m) in d.manoeuvres.iter().enumerate() {
            pos(&format!("drive.manoeuvres[{i}].duration"), m.duration)?;
            for (n, v) in [
                ("speed", m.speed),
                ("radius", m.radius),
                ("rate", m.rate),
                ("period", m.period),
            ] {
                if !v.is_finite() {
                    return Err(format!("`drive.manoeuvres[{i}].{n}` is not a number"));
                }
            }
            if matches!(m.kind, ManoeuvreKind::Arc | ManoeuvreKind::SCurve) && m.radius == 0.0 {
                return Err(format!("`drive.manoeuvres[{i}].radius` must not be 0"));
            }
            if m.kind == ManoeuvreKind::SCurve && m.period <= 0.0 {
                return Err(format!("`drive.manoeuvres[{i}].period` must be positive"));
            }
        }
        let it = &self.integration;
        pos("integration.dt", it.dt)?;
        if it.dt > 0.001 + 1e-12 {
            return Err(format!(
                "`integration.dt` = {} s: at most 0.001 s, so the truth is not a filter's discretisation",
                it.dt
            ));
        }
        pos("integration.truth_rate", it.truth_rate)?;
        pos("wheels.rate", self.wheels.rate)?;
        pos("wheels.ticks_per_rev", self.wheels.ticks_per_rev)?;
        let g = &self.gnss;
        nonneg("gnss.rate", g.rate)?;
        nonneg("gnss.white_std", g.white_std)?;
        nonneg("gnss.markov_std", g.markov_std)?;
        pos("gnss.markov_tau", g.markov_tau)?;
        pos("gnss.reported_std", g.reported_std)?;
        nonneg("gnss.multipath_rate", g.multipath_rate)?;
        nonneg("gnss.multipath_jump", g.multipath_jump)?;
        range("gnss.multipath_duration", g.multipath_duration)?;
        for (i, w) in g.outages.iter().enumerate() {
            nonneg(&format!("gnss.outages[{i}].start"), w.start)?;
            pos(&format!("gnss.outages[{i}].duration"), w.duration)?;
        }
        for (i, j) in g.jumps.iter().enumerate() {
            nonneg(&format!("gnss.jumps[{i}].start"), j.start)?;
            pos(&format!("gnss.jumps[{i}].duration"), j.duration)?;
            if !(j.east.is_finite() && j.north.is_finite()) {
                return Err(format!("`gnss.jumps[{i}]` offset is not a number"));
            }
        }
        let c = &self.compass;
        nonneg("compass.rate", c.rate)?;
        nonneg("compass.std_deg", c.std_deg)?;
        if !c.bias_deg.is_finite() {
            return Err("`compass.bias_deg` is not a number".into());
        }
        pos("compass.reported_std_deg", c.reported_std_deg)?;
        let m = &self.imu;
        nonneg("imu.rate", m.rate)?;
        nonneg("imu.accel_noise", m.accel_noise)?;
        nonneg("imu.gyro_noise", m.gyro_noise)?;
        if !m.gyro_bias.is_finite() {
            return Err("`imu.gyro_bias` is not a number".into());
        }
        nonneg("imu.vibration_gain", m.vibration_gain)?;
        let c = &self.camera;
        nonneg("camera.rate", c.rate)?;
        if c.rate > 0.0 {
            if !(8..=4096).contains(&c.width) || !(8..=4096).contains(&c.height) {
                return Err(format!(
                    "camera {}x{} pixels: each side must be 8..4096",
                    c.width, c.height
                ));
            }
            pos("camera.footprint", c.footprint)?;
            nonneg("camera.scale_variation", c.scale_variation)?;
            if c.scale_variation >= 0.9 {
                return Err("`camera.scale_variation` must be below 0.9".into());
            }
            range("camera.lighting", c.lighting)?;
            pos("camera.lighting[0]", c.lighting[0])?;
        }
        // Rates and steps that would exhaust memory or never finish.
        if it.dt < 1e-5 {
            return Err(format!("`integration.dt` = {} s: at least 1e-5 s", it.dt));
        }
        for (name, rate) in [
            ("integration.truth_rate", it.truth_rate),
            ("wheels.rate", self.wheels.rate),
            ("gnss.rate", self.gnss.rate),
            ("compass.rate", self.compass.rate),
            ("imu.rate", self.imu.rate),
            ("camera.rate", self.camera.rate),
        ] {
            if rate > 10_000.0 {
                return Err(format!("`{name}` = {rate} Hz: at most 10000 Hz"));
            }
        }
        if self.gnss.multipath_rate > 1.0 {
            return Err(format!(
                "`gnss.multipath_rate` = {} per s: at most 1 (that is no longer the odd jump)",
                self.gnss.multipath_rate
            ));
        }
        if self.camera.rate * self.duration() > 100_000.0 {
            return Err(format!(
                "camera: {:.0} frames; at most 100000 per drive (lower `camera.rate`)",
                self.camera.rate * self.duration()
            ));
        }
        // A drive of days would exhaust memory long before it finished.
        if self.duration() > 36_000.0 {
            return Err(format!(
                "drive of {} s: at most 36000 s (10 h) per scenario",
                self.duration()
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_parses_and_validates() {
        for (name, _) in BUILTINS {
            let s = Scenario::builtin(name).unwrap();
            assert_eq!(&s.name, name);
            assert!(!s.description.is_empty(), "{name} has no description");
            assert!(s.duration() > 60.0);
        }
        let names = builtin_names();
        assert!(names.iter().any(|(n, _)| n == "papers-rtk"));
        assert!(!names.iter().any(|(n, _)| n == "p3at-calib-rtk"));
        let r = Scenario::builtin("papers-rtk").unwrap();
        assert!(r.gnss.total_std() < 0.05);
        assert_eq!(
            r.gnss.outages,
            Scenario::builtin("papers").unwrap().gnss.outages
        );
    }

    #[test]
    fn papers_icr3_is_papers_with_unit_alpha() {
        let p = Scenario::builtin("papers").unwrap();
        let q = Scenario::builtin("papers-icr3").unwrap();
        for seg in &p.segments {
            let (a, b) = (
                p.terrain(&seg.terrain).unwrap(),
                q.terrain(&seg.terrain).unwrap(),
            );
            assert!(a.alpha_l < 1.0 && a.alpha_r < 1.0, "{}", seg.terrain);
            assert_eq!((b.alpha_l, b.alpha_r), (1.0, 1.0), "{}", seg.terrain);
            let robot = &p.robot;
            let (ia, ib) = (a.icr(robot), b.icr(robot));
            assert_eq!((ia.y_l, ia.y_r, ia.x_c), (ib.y_l, ib.y_r, ib.x_c));
        }
        // Everything but the name, description and terrain overrides is the same.
        let mut q2 = q.clone();
        q2.name = p.name.clone();
        q2.description = p.description.clone();
        q2.terrains = p.terrains.clone();
        assert_eq!(q2, p);
        assert!(builtin_names().iter().any(|(n, _)| n == "papers-icr3-rtk"));
    }

    #[test]
    fn unknown_names_and_keys_are_errors() {
        let e = Scenario::builtin("nope").unwrap_err().to_string();
        assert!(e.contains("nope") && e.contains("papers"), "{e}");
        let text = "[[segment]]\nterrain = \"soil\"\nduration = 10\n[gnss]\nrat = 1\n";
        let e = Scenario::from_toml_str(text, Path::new("x.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.toml:5") && e.contains("rat"), "{e}");
    }

    #[test]
    fn bad_values_are_named() {
        let base = "[[segment]]\nterrain = \"soil\"\nduration = 10\n";
        for (extra, key) in [
            ("[integration]\ndt = 0.01\n", "integration.dt"),
            ("[wheels]\nrate = -5\n", "wheels.rate"),
            ("[[segment]]\nterrain = \"lava\"\nduration = 5\n", "lava"),
            ("[gnss]\nwhite_std = nan\n", "gnss.white_std"),
            ("[imu]\nrate = 1e9\n", "imu.rate"),
            ("[integration]\ndt = 1e-9\n", "integration.dt"),
            ("[gnss]\nmultipath_rate = 50.0\n", "gnss.multipath_rate"),
            ("[drive]\nspeed = [1.0, 0.5]\n", "drive.speed"),
            ("[terrains.soil]\nchi = 3.0\n", "chi"),
        ] {
            let text = format!("{base}{extra}");
            let e = Scenario::from_toml_str(&text, Path::new("s.toml"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(key) && e.contains("s.toml"), "{extra:?}: {e}");
        }
        let e = Scenario::from_toml_str("name = \"x\"\n", Path::new("s.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("segment"), "{e}");
    }
}
