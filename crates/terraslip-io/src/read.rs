use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::stream::{read_pose, read_wheel_rows, Repeats};
use crate::types::*;

/// A CSV file open for reading, with its header indexed by column name.
/// Rows are streamed one at a time ([`CsvTable::each_timed_row`]) with
/// their 1-based line numbers (the header is line 1) for error messages,
/// so memory does not grow with the file. Cells are read through
/// [`CsvTable::cell`], which trims their whitespace (trimming each cell
/// read, not every field of every row, is what a 200 MB log can afford).
pub struct CsvTable {
    pub path: PathBuf,
    pub header: Vec<String>,
    index: HashMap<String, usize>,
    /// The `t` column, and each column's physical limit ([`physical_limit`]).
    t_col: Option<usize>,
    limits: Vec<Option<(f64, &'static str)>>,
    reader: Option<csv::Reader<std::fs::File>>,
    /// The row [`CsvTable::advance`] read last, and its line and time.
    rec: csv::StringRecord,
    last: Option<(u64, f64)>,
}

/// Opens a CSV file and reads its header. Fails with file and line on
/// anything that is not well-formed UTF-8 CSV with a header; rows are
/// checked as they are read.
pub fn read_csv_table(path: &Path) -> Result<CsvTable, LogError> {
    if !path.exists() {
        return Err(LogError::MissingFile {
            path: path.to_path_buf(),
        });
    }
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(false)
        .trim(csv::Trim::Headers)
        // Fewer, larger reads than the default 8 KiB.
        .buffer_capacity(READ_BUFFER)
        .from_path(path)
        .map_err(|e| csv_err(path, e))?;
    let header: Vec<String> = rdr
        .headers()
        .map_err(|e| csv_err(path, e))?
        .iter()
        .map(|h| h.trim_start_matches('\u{feff}').to_string())
        .collect();
    if header.iter().all(|h| h.is_empty()) {
        return Err(LogError::Parse {
            path: path.to_path_buf(),
            line: 1,
            reason: "empty file or empty header line; the first line must name the columns (docs/log-format.md)".into(),
        });
    }
    let mut index = HashMap::with_capacity(header.len());
    for (i, h) in header.iter().enumerate() {
        if h.is_empty() {
            continue;
        }
        if let Some(first) = index.insert(h.clone(), i) {
            return Err(LogError::Parse {
                path: path.to_path_buf(),
                line: 1,
                reason: format!(
                    "columns {} and {} are both named `{h}`; rename or remove one of them",
                    first + 1,
                    i + 1
                ),
            });
        }
    }
    Ok(CsvTable {
        path: path.to_path_buf(),
        t_col: index.get("t").copied(),
        limits: header.iter().map(|h| physical_limit(h)).collect(),
        header,
        index,
        reader: Some(rdr),
        rec: csv::StringRecord::new(),
        last: None,
    })
}

/// Bytes the CSV reader asks the file for at a time.
const READ_BUFFER: usize = 1 << 16;

fn csv_err(path: &Path, e: csv::Error) -> LogError {
    let line = e.position().map(|p| p.line()).unwrap_or(1);
    let reason = match e.kind() {
        csv::ErrorKind::Utf8 { .. } => {
            "not UTF-8 text; is this a CSV file? Save it as UTF-8 CSV".to_string()
        }
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => format!("row has {len} fields, header has {expected_len}; give every row one field per column (empty for not measured)"),
        _ => e.to_string(),
    };
    match e.kind() {
        csv::ErrorKind::Io(_) => LogError::Invalid {
            path: path.to_path_buf(),
            reason,
        },
        _ => LogError::Parse {
            path: path.to_path_buf(),
            line,
            reason,
        },
    }
}

impl CsvTable {
    /// Index of a required column.
    pub fn require(&self, name: &str) -> Result<usize, LogError> {
        self.index
            .get(name)
            .copied()
            .ok_or_else(|| LogError::MissingColumn {
                path: self.path.clone(),
                column: name.to_string(),
                header: self.header.join(","),
            })
    }

    /// Index of an optional column.
    pub fn optional(&self, name: &str) -> Option<usize> {
        self.index.get(name).copied()
    }

    pub(crate) fn err(&self, line: u64, reason: impl Into<String>) -> LogError {
        LogError::Parse {
            path: self.path.clone(),
            line,
            reason: reason.into(),
        }
    }

    /// The cell of column `i` in `rec`, without leading and trailing
    /// whitespace; empty where the row has no such column.
    pub fn cell<'r>(&self, rec: &'r csv::StringRecord, i: usize) -> &'r str {
        crate::cell::trim(rec.get(i).unwrap_or(""))
    }

    /// A finite number, or `None` for an empty cell.
    pub fn opt_f64(
        &self,
        line: u64,
        rec: &csv::StringRecord,
        col: Option<usize>,
    ) -> Result<Option<f64>, LogError> {
        let Some(i) = col else { return Ok(None) };
        let cell = self.cell(rec, i);
        if cell.is_empty() {
            return Ok(None);
        }
        let name = &self.header[i];
        let v = crate::cell::parse_f64(cell)
            .ok_or_else(|| self.err(line, format!("column `{name}`: `{cell}` is not a number; write a number with `.` as the decimal point, or leave the cell empty")))?;
        if !v.is_finite() {
            return Err(self.err(line, format!("column `{name}`: `{cell}` is not finite; write a finite number, or leave the cell empty")));
        }
        if let Some(&Some((limit, unit))) = self.limits.get(i) {
            if v.abs() > limit {
                return Err(self.err(
                    line,
                    format!(
                        "column `{name}`: {cell} is outside the physical range ±{limit:e} {unit}; \
                         fix or remove the row (docs/log-format.md gives the units)"
                    ),
                ));
            }
        }
        Ok(Some(v))
    }

    /// A finite number that must be present.
    pub fn req_f64(&self, line: u64, rec: &csv::StringRecord, col: usize) -> Result<f64, LogError> {
        self.opt_f64(line, rec, Some(col))?.ok_or_else(|| {
            self.err(
                line,
                format!(
                    "column `{}` is empty; this column needs a number in every row",
                    self.header[col]
                ),
            )
        })
    }

    /// Reads the next row: its line and its `t` (checked never to
    /// decrease); the row itself is then [`CsvTable::record`]. `None` at the
    /// end of the file.
    pub fn advance(&mut self) -> Result<Option<(u64, f64)>, LogError> {
        let ti = match self.t_col {
            Some(i) => i,
            None => self.require("t")?,
        };
        let Some(rdr) = self.reader.as_mut() else {
            return Ok(None);
        };
        if !rdr
            .read_record(&mut self.rec)
            .map_err(|e| csv_err(&self.path, e))?
        {
            return Ok(None);
        }
        let line = self.rec.position().map(|p| p.line()).unwrap_or(0);
        let t = self.req_f64(line, &self.rec, ti)?;
        if let Some((pl, pt)) = self.last {
            if t < pt {
                return Err(self.err(
                    line,
                    format!("time goes backwards: t = {t} after t = {pt} at line {pl}; sort the file by t"),
                ));
            }
        }
        self.last = Some((line, t));
        Ok(Some((line, t)))
    }

    /// The row [`CsvTable::advance`] read last.
    pub fn record(&self) -> &csv::StringRecord {
        &self.rec
    }

    /// Bytes of the file read so far.
    pub fn bytes_read(&self) -> u64 {
        self.reader.as_ref().map_or(0, |r| r.position().byte())
    }

    /// Calls `f(table, line, t, record)` for every row in turn, with `t`
    /// read from the `t` column and checked never to decrease. The rows
    /// can be streamed once.
    pub fn each_timed_row(
        &mut self,
        mut f: impl FnMut(&Self, u64, f64, &csv::StringRecord) -> Result<(), LogError>,
    ) -> Result<(), LogError> {
        while let Some((line, t)) = self.advance()? {
            f(self, line, t, &self.rec)?;
        }
        Ok(())
    }
}

/// The largest magnitude a log column can physically have, with its unit.
/// Values beyond it are corrupt (or in the wrong unit) and would overflow
/// the arithmetic downstream. The log reader refuses them; a bag import
/// skips the messages that would make them.
pub fn physical_limit(column: &str) -> Option<(f64, &'static str)> {
    Some(match column {
        // Seconds: an epoch in nanoseconds (~1.7e18) is refused here.
        "t" => (1e11, "s"),
        "v_left" | "v_right" => (100.0, "m/s"),
        "current_left" | "current_right" => (1e4, "A"),
        // ENU metres around a local origin: within the Earth's circumference.
        "east" | "north" => (4e7, "m"),
        "yaw" => (1e4, "rad"),
        "std_xy" => (1e7, "m"),
        "std_yaw" => (1e3, "rad"),
        "accel_x" | "accel_y" | "accel_z" => (1e4, "m/s^2"),
        "gyro_x" | "gyro_y" | "gyro_z" => (1e3, "rad/s"),
        "y_l" | "y_r" | "x_c" => (1e3, "m"),
        _ => return None,
    })
}

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
const META_KEYS: [&str; 10] = [
    "robot",
    "track_width",
    "wheel_radius",
    "length",
    "ticks_per_rev",
    "separation",
    "separation_source",
    "pose",
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

/// Wraps to (-pi, pi], as the readers wrap `yaw` columns.
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::PI;
    let mut w = a.rem_euclid(2.0 * PI);
    if w > PI {
        w -= 2.0 * PI;
    }
    w
}
