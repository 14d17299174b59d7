use std::path::{Path, PathBuf};

/// One encoder sample: measured tread surface speeds, m/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WheelSample {
    pub t: f64,
    pub v_left: f64,
    pub v_right: f64,
}

/// Drive-motor currents at one `wheels.csv` row, A (optional columns
/// `current_left,current_right`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorCurrent {
    pub t: f64,
    pub left: f64,
    pub right: f64,
}

/// One absolute pose observation. Any of the fields may be missing.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PoseObs {
    pub t: f64,
    /// m, ENU
    pub east: Option<f64>,
    /// m, ENU
    pub north: Option<f64>,
    /// rad, counter-clockwise from east, wrapped to (-pi, pi]
    pub yaw: Option<f64>,
    /// 1-sigma horizontal position error, m
    pub std_xy: Option<f64>,
    /// 1-sigma yaw error, rad
    pub std_yaw: Option<f64>,
}

/// One IMU sample, m/s^2 and rad/s, body frame, gravity included.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ImuSample {
    pub t: f64,
    pub accel_z: f64,
    pub accel_x: Option<f64>,
    pub accel_y: Option<f64>,
    pub gyro_x: Option<f64>,
    pub gyro_y: Option<f64>,
    pub gyro_z: Option<f64>,
}

/// A ground-camera frame. `path` is as written in `images.csv` (relative to
/// the log directory); use [`DriveLog::image_path`] to resolve it.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageRef {
    pub t: f64,
    pub path: PathBuf,
}

/// A terrain label that holds from `t` until the next label.
#[derive(Debug, Clone, PartialEq)]
pub struct TerrainLabel {
    pub t: f64,
    pub terrain: String,
}

/// Ground truth (simulation, scoring).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TruthSample {
    pub t: f64,
    pub east: f64,
    pub north: f64,
    pub yaw: f64,
    pub y_l: f64,
    pub y_r: f64,
    pub x_c: f64,
}

/// `meta.toml`: robot description; all keys optional.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Meta {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robot: Option<String>,
    /// distance between tread centre lines, m
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub track_width: Option<f64>,
    /// m
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel_radius: Option<f64>,
    /// Where [`Meta::wheel_radius`] came from when `terraslip import` made
    /// the tread speeds of `wheels.csv` from joint rates with it: `given`
    /// (the topics file), `urdf`, `meta` or `default` (a radius assumed:
    /// the speed factors are relative to it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel_radius_source: Option<String>,
    /// m
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length: Option<f64>,
    /// encoder ticks per wheel revolution (terraslip extension)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ticks_per_rev: Option<f64>,
    /// The separation S the tread speeds of `wheels.csv` were made with from
    /// a controller's odometry twist (v ∓ ω·S/2), m (terraslip extension):
    /// learned ICRs are in its scale, and the learned spread / S is the factor
    /// by which the controller's `wheel_separation_multiplier` is off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub separation: Option<f64>,
    /// Where [`Meta::separation`] came from: `given` (the controller's own
    /// value, so the ICRs are absolute), `urdf`, `track_width` or `default`
    /// (a nominal scale).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub separation_source: Option<String>,
    /// Where the pose reference sits on the robot (terraslip extension):
    /// `[pose]` in meta.toml.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pose: Option<PoseMount>,
    /// What the pose reference is (terraslip extension); unstated, its
    /// error is taken to wander as a GNSS receiver's does.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pose_reference: Option<PoseReference>,
}

/// What kind of source the pose reference is: whether its error wanders
/// slowly (a GNSS receiver's multipath and atmosphere, over tens of
/// seconds) or is white from fix to fix (a localiser matching each scan
/// against a map). `meta.toml`'s `pose_reference`, read and written by
/// its name ([`PoseReference::name`], [`str::parse`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "String", into = "&'static str")]
pub enum PoseReference {
    /// A satellite receiver, RTK included: part of its error wanders.
    Gnss,
    /// A lidar or visual localisation against a map, motion capture, ceiling
    /// tags: an error that does not wander. `localizer` is read as well.
    Localiser,
}

impl TryFrom<String> for PoseReference {
    type Error = String;
    fn try_from(s: String) -> Result<Self, String> {
        s.parse()
    }
}

impl From<PoseReference> for &'static str {
    fn from(r: PoseReference) -> Self {
        r.name()
    }
}

impl std::str::FromStr for PoseReference {
    type Err = String;

    /// `gnss`, `localiser` (or `localizer`), as meta.toml writes them.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "gnss" => Ok(Self::Gnss),
            "localiser" | "localizer" => Ok(Self::Localiser),
            _ => Err(format!(
                "`{s}` is not a kind of pose reference: `gnss` (a satellite receiver) or `localiser` (lidar or visual localisation, motion capture, tags)"
            )),
        }
    }
}

impl PoseReference {
    /// The name meta.toml gives it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Gnss => "gnss",
            Self::Localiser => "localiser",
        }
    }

    /// What it is, in words.
    pub fn noun(self) -> &'static str {
        match self {
            Self::Gnss => "GNSS receiver",
            Self::Localiser => "localiser",
        }
    }

    /// How a run takes its fixes' error.
    pub fn error_taken(self) -> &'static str {
        match self {
            Self::Gnss => "part of its error is taken to wander slowly",
            Self::Localiser => "its error is taken as white, with no slowly wandering part",
        }
    }
}

/// Where the pose reference (GNSS antenna, tag, lidar frame) sits on the
/// robot: its lever arm from the body frame's origin (the wheel axle's
/// centre), m, body frame (REP-103: x forward, y left). A position fix is
/// of that point.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseMount {
    /// m, forward of the axle's centre.
    #[serde(default)]
    pub lever_arm_x: f64,
    /// m, left of the axle's centre.
    #[serde(default)]
    pub lever_arm_y: f64,
}

impl Meta {
    /// Whether the tread speeds' scale is the robot's own: no separation
    /// was needed (tread speeds measured), or the controller's was given.
    pub fn separation_is_absolute(&self) -> bool {
        self.separation.is_none() || self.separation_source.as_deref() == Some("given")
    }

    /// The `separation` object of a parameters file calibrated on this
    /// log, when its tread speeds were made from a twist with a separation
    /// S: S in m, where it came from, and whether the ICRs are absolute or
    /// in the scale of a nominal S.
    pub fn separation_note(&self) -> Option<serde_json::Value> {
        let s = self.separation?;
        Some(serde_json::json!({
            "separation_m": s,
            "source": self.separation_source.as_deref().unwrap_or("given"),
            "icr_scale": if self.separation_is_absolute() {
                "absolute"
            } else {
                "nominal: the ICRs are in the scale of this separation; spread / separation_m is the factor on the controller's wheel_separation_multiplier"
            },
        }))
    }
}

/// A whole drive log in memory. Every vector is sorted by `t`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DriveLog {
    /// The directory it was read from (empty for an in-memory log).
    pub dir: PathBuf,
    pub wheels: Vec<WheelSample>,
    /// Drive-motor currents, from the rows of `wheels.csv` that give both
    /// (empty when the log has none).
    pub currents: Vec<MotorCurrent>,
    pub pose: Vec<PoseObs>,
    pub imu: Vec<ImuSample>,
    pub images: Vec<ImageRef>,
    pub terrain: Vec<TerrainLabel>,
    pub truth: Vec<TruthSample>,
    pub meta: Meta,
    /// Things that were odd but usable (duplicate timestamps, empty pose
    /// rows...), each naming file, line and what was done about it.
    pub warnings: Vec<String>,
}

impl DriveLog {
    /// The files of a log directory (docs/log-format.md).
    pub const FILES: [&'static str; 7] = [
        "wheels.csv",
        "pose.csv",
        "imu.csv",
        "images.csv",
        "terrain.csv",
        "truth.csv",
        "meta.toml",
    ];

    /// Absolute path of an image referenced from `images.csv`.
    pub fn image_path(&self, image: &ImageRef) -> PathBuf {
        if image.path.is_absolute() {
            image.path.clone()
        } else {
            self.dir.join(&image.path)
        }
    }

    /// The terrain label in force at time `t` (the last label at or before
    /// `t`; the first label before the first row).
    pub fn terrain_at(&self, t: f64) -> Option<&str> {
        terrain_at(&self.terrain, t)
    }

    /// Distinct terrain names in order of first appearance.
    pub fn terrain_names(&self) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        for l in &self.terrain {
            if !names.contains(&l.terrain) {
                names.push(l.terrain.clone());
            }
        }
        names
    }

    /// Name of the log (its directory's last component).
    pub fn name(&self) -> String {
        self.dir
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "log".to_string())
    }

    /// Duration covered by `wheels.csv`, s.
    pub fn duration(&self) -> f64 {
        match (self.wheels.first(), self.wheels.last()) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        }
    }
}

/// The label in force at `t` in a sorted label list.
pub fn terrain_at(labels: &[TerrainLabel], t: f64) -> Option<&str> {
    let idx = labels.partition_point(|l| l.t <= t);
    let i = idx.saturating_sub(1);
    labels.get(i).map(|l| l.terrain.as_str())
}

/// Error reading or writing a log. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    #[error("{path}: {source}; check the path and its permissions")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}:{line}: {reason}")]
    Parse {
        path: PathBuf,
        line: u64,
        reason: String,
    },
    #[error("{path}: missing required column `{column}` (header has: {header}); add it, docs/log-format.md lists each file's columns")]
    MissingColumn {
        path: PathBuf,
        column: String,
        header: String,
    },
    #[error(
        "{path}: required file is missing; a log directory needs wheels.csv (docs/log-format.md)"
    )]
    MissingFile { path: PathBuf },
    #[error("{path}: {reason}")]
    Invalid { path: PathBuf, reason: String },
}

impl LogError {
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}
