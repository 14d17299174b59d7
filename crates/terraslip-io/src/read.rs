use std::path::{Path, PathBuf};

use crate::angle::wrap_angle;
use crate::csv_table::read_csv_table;
use crate::stream::{read_pose, read_wheel_rows, Repeats};
use crate::types::*;

/// Which of a log's streams [`DriveLog::read_streams`] reads. `meta.toml`
/// and `terrain.csv` are always read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Streams {
    /// `wheels.csv` (the tread speeds) and `pose.csv`; without them the
    /// caller streams the two files itself ([`crate::WheelStream`],
    /// [`crate::PoseStream`]).
    pub wheels_and_pose: bool,
    /// The motor currents of `wheels.csv`.
    pub currents: bool,
    pub imu: bool,
    pub images: bool,
    pub truth: bool,
}

impl Streams {
    /// Everything.
    pub const ALL: Self = Self {
        wheels_and_pose: true,
        currents: true,
        imu: true,
        images: true,
        truth: true,
    };
    /// What the online estimator uses: wheels, pose and the imu's yaw
    /// rate (truth is for scoring, not estimating; the images are the
    /// terrain classifier's).
    pub const ESTIMATOR: Self = Self {
        wheels_and_pose: true,
        currents: false,
        imu: true,
        images: false,
        truth: false,
    };
    /// Only `meta.toml` and `terrain.csv`.
    pub const HEADER: Self = Self {
        wheels_and_pose: false,
        imu: false,
        ..Self::ESTIMATOR
    };
}

impl DriveLog {
    /// Reads a log directory. `wheels.csv` is required; every other file is
    /// optional. Fails on the first malformed cell, with file and line.
    pub fn read(dir: impl AsRef<Path>) -> Result<Self, LogError> {
        Self::read_streams(dir, Streams::ALL)
    }

    /// [`DriveLog::read`] of the chosen streams only; the others stay empty.
    pub fn read_streams(dir: impl AsRef<Path>, streams: Streams) -> Result<Self, LogError> {
        let dir = dir.as_ref();
        if !dir.exists() {
            return Err(LogError::Invalid {
                path: dir.to_path_buf(),
                reason: "does not exist; check the path".into(),
            });
        }
        if !dir.is_dir() {
            return Err(LogError::Invalid {
                path: dir.to_path_buf(),
                reason: "not a log directory; give the directory that holds wheels.csv".into(),
            });
        }
        let mut log = DriveLog {
            dir: dir.to_path_buf(),
            ..Default::default()
        };
        let opt = |name: &str| {
            let p = dir.join(name);
            p.exists().then_some(p)
        };
        if streams.wheels_and_pose {
            (log.wheels, log.currents) =
                read_wheel_rows(&dir.join("wheels.csv"), &mut log.warnings, streams.currents)?;
            if let Some(p) = opt("pose.csv") {
                log.pose = read_pose(&p, &mut log.warnings)?;
            }
        } else if !dir.join("wheels.csv").exists() {
            return Err(LogError::MissingFile {
                path: dir.join("wheels.csv"),
            });
        }
        if let Some(p) = opt("imu.csv").filter(|_| streams.imu) {
            log.imu = read_imu(&p, &mut log.warnings)?;
        }
        if let Some(p) = opt("images.csv").filter(|_| streams.images) {
            log.images = read_images(&p)?;
        }
        if let Some(p) = opt("terrain.csv") {
            log.terrain = read_terrain(&p)?;
        }
        if let Some(p) = opt("truth.csv").filter(|_| streams.truth) {
            log.truth = read_truth(&p)?;
        }
        if let Some(p) = opt("meta.toml") {
            log.meta = read_meta(&p)?;
        }
        Ok(log)
    }
}

/// Reads `imu.csv`.
pub fn read_imu(path: &Path, warnings: &mut Vec<String>) -> Result<Vec<ImuSample>, LogError> {
    let mut tab = read_csv_table(path)?;
    let az = tab.require("accel_z")?;
    let cols = ["accel_x", "accel_y", "gyro_x", "gyro_y", "gyro_z"].map(|c| tab.optional(c));
    let mut out = Vec::new();
    let mut repeats = Repeats::default();
    tab.each_timed_row(|tab, line, t, rec| {
        let o = |i: usize| tab.opt_f64(line, rec, cols[i]);
        let s = ImuSample {
            t,
            accel_z: tab.req_f64(line, rec, az)?,
            accel_x: o(0)?,
            accel_y: o(1)?,
            gyro_x: o(2)?,
            gyro_y: o(3)?,
            gyro_z: o(4)?,
        };
        if repeats.keep(line, t) {
            out.push(s);
        }
        Ok(())
    })?;
    warnings.extend(repeats.warning(path));
    Ok(out)
}

/// Reads `images.csv` (paths are not opened here).
pub fn read_images(path: &Path) -> Result<Vec<ImageRef>, LogError> {
    let mut tab = read_csv_table(path)?;
    let pc = tab.require("path")?;
    let mut out = Vec::new();
    tab.each_timed_row(|tab, line, t, rec| {
        let p = tab.cell(rec, pc);
        if p.is_empty() {
            return Err(tab.err(
                line,
                "column `path` is empty; give the image file, relative to the log directory",
            ));
        }
        let rel = Path::new(p);
        if rel.is_absolute()
            || rel.components().any(|c| {
                !matches!(
                    c,
                    std::path::Component::Normal(_) | std::path::Component::CurDir
                )
            })
        {
            return Err(tab.err(
                line,
                format!(
                    "column `path`: `{p}` leaves the log directory; \
                     give a path relative to it, without `..`"
                ),
            ));
        }
        out.push(ImageRef {
            t,
            path: PathBuf::from(p),
        });
        Ok(())
    })?;
    Ok(out)
}

/// Reads `terrain.csv`.
pub fn read_terrain(path: &Path) -> Result<Vec<TerrainLabel>, LogError> {
    let mut tab = read_csv_table(path)?;
    let c = tab.require("terrain")?;
    let mut out = Vec::new();
    tab.each_timed_row(|tab, line, t, rec| {
        let name = tab.cell(rec, c);
        if name.is_empty() {
            return Err(tab.err(line, "column `terrain` is empty; give the terrain's name"));
        }
        out.push(TerrainLabel {
            t,
            terrain: name.to_string(),
        });
        Ok(())
    })?;
    Ok(out)
}

/// Reads `truth.csv`.
pub fn read_truth(path: &Path) -> Result<Vec<TruthSample>, LogError> {
    let mut tab = read_csv_table(path)?;
    let cols = ["east", "north", "yaw", "y_l", "y_r", "x_c"];
    let mut idx = [0usize; 6];
    for (i, c) in cols.iter().enumerate() {
        idx[i] = tab.require(c)?;
    }
    let mut out = Vec::new();
    tab.each_timed_row(|tab, line, t, rec| {
        let mut v = [0.0; 6];
        for i in 0..6 {
            v[i] = tab.req_f64(line, rec, idx[i])?;
        }
        out.push(TruthSample {
            t,
            east: v[0],
            north: v[1],
            yaw: wrap_angle(v[2]),
            y_l: v[3],
            y_r: v[4],
            x_c: v[5],
        });
        Ok(())
    })?;
    Ok(out)
}

/// The keys of `meta.toml`: the robot description, then the provenance
/// `terraslip simulate` records.
const META_KEYS: [&str; 12] = [
    "robot",
    "track_width",
    "wheel_radius",
    "wheel_radius_source",
    "length",
    "ticks_per_rev",
    "separation",
    "separation_source",
    "pose",
    "pose_reference",
    "scenario",
    "seed",
];

/// Reads `meta.toml`. Unknown keys are errors that list the valid ones.
pub fn read_meta(path: &Path) -> Result<Meta, LogError> {
    let text = std::fs::read_to_string(path).map_err(|e| LogError::io(path, e))?;
    let line_of = |offset: usize| {
        text.as_bytes()[..offset.min(text.len())]
            .iter()
            .filter(|&&b| b == b'\n')
            .count() as u64
            + 1
    };
    let parse_err = |e: toml::de::Error| LogError::Parse {
        path: path.to_path_buf(),
        line: e.span().map(|s| line_of(s.start)).unwrap_or(1),
        reason: format!(
            "{}; docs/log-format.md lists the keys and their types",
            e.message().trim().replace('\n', " ")
        ),
    };
    let table: toml::Table = toml::from_str(&text).map_err(parse_err)?;
    for key in table.keys() {
        if !META_KEYS.contains(&key.as_str()) {
            let line = text.find(key.as_str()).map(line_of).unwrap_or(1);
            return Err(LogError::Parse {
                path: path.to_path_buf(),
                line,
                reason: format!(
                    "unknown key `{key}`; valid keys are {}",
                    META_KEYS.join(", ")
                ),
            });
        }
    }
    let meta: Meta = toml::from_str(&text).map_err(parse_err)?;
    for (name, v, max, unit) in [
        ("track_width", meta.track_width, 20.0, "m"),
        ("wheel_radius", meta.wheel_radius, 5.0, "m"),
        ("length", meta.length, 50.0, "m"),
        ("ticks_per_rev", meta.ticks_per_rev, 1e9, "ticks"),
        ("separation", meta.separation, 20.0, "m"),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                return Err(LogError::Invalid {
                    path: path.to_path_buf(),
                    reason: format!(
                        "`{name}` = {v} is outside (0, {max}] {unit}; give the robot's value in {unit}"
                    ),
                });
            }
        }
    }
    if let Some(m) = meta.pose {
        for (name, v) in [
            ("lever_arm_x", m.lever_arm_x),
            ("lever_arm_y", m.lever_arm_y),
        ] {
            if !(v.is_finite() && v.abs() <= 50.0) {
                return Err(LogError::Invalid {
                    path: path.to_path_buf(),
                    reason: format!(
                        "`[pose] {name}` = {v} is outside +-50 m; give where the pose reference sits on the robot in m"
                    ),
                });
            }
        }
    }
    Ok(meta)
}
