//! Scenario files: what robot drives where, how the operator drives, and what
//! the sensors are like. TOML, every table optional except `[[segment]]`;
//! unknown keys are errors so a typo never silently falls back to a default.
//! `docs/simulator.md` documents every key; the built-in scenarios under
//! `scenarios/` are complete examples.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};
use terraslip_core::kinematics::IcrParams;

pub use crate::robot::Robot;
use crate::terrain::{self, Terrain, TerrainSpec};
use crate::SimError;

mod sensors;
mod validate;

pub use sensors::{Camera, Compass, Gnss, Imu, Jump, Wheels, Window};

/// Built-in scenarios: (name, TOML text). `NAME-rtk` variants are derived by
/// [`Scenario::with_rtk`].
const BUILTINS: &[(&str, &str)] = &[
    ("papers", include_str!("../../scenarios/papers.toml")),
    (
        "papers-icr3",
        include_str!("../../scenarios/papers-icr3.toml"),
    ),
    ("wang4", include_str!("../../scenarios/wang4.toml")),
    (
        "p3at-calib",
        include_str!("../../scenarios/p3at-calib.toml"),
    ),
    (
        "p3at-terrains",
        include_str!("../../scenarios/p3at-terrains.toml"),
    ),
    (
        "gnss-outage",
        include_str!("../../scenarios/gnss-outage.toml"),
    ),
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
}

#[cfg(test)]
mod tests;
