use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::types::*;

/// A CSV file with its header indexed by column name. Rows keep their
/// 1-based line numbers (the header is line 1) for error messages.
pub struct CsvTable {
    pub path: PathBuf,
    pub header: Vec<String>,
    index: HashMap<String, usize>,
    pub rows: Vec<(u64, csv::StringRecord)>,
}

/// Reads a whole CSV file. Fails with file and line on anything that is not
/// well-formed UTF-8 CSV with a header.
pub fn read_csv_table(path: &Path) -> Result<CsvTable, LogError> {
    if !path.exists() {
        return Err(LogError::MissingFile {
            path: path.to_path_buf(),
        });
    }
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(false)
        .trim(csv::Trim::All)
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
            reason: "empty file or empty header line".into(),
        });
    }
    let index = header
        .iter()
        .enumerate()
        .map(|(i, h)| (h.clone(), i))
        .collect();
    let mut rows = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| csv_err(path, e))?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        rows.push((line, rec));
    }
    Ok(CsvTable {
        path: path.to_path_buf(),
        header,
        index,
        rows,
    })
}

fn csv_err(path: &Path, e: csv::Error) -> LogError {
    let line = e.position().map(|p| p.line()).unwrap_or(1);
    let reason = match e.kind() {
        csv::ErrorKind::Utf8 { .. } => "not UTF-8 text (is this a CSV file?)".to_string(),
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => format!("row has {len} fields, header has {expected_len}"),
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

    fn err(&self, line: u64, reason: impl Into<String>) -> LogError {
        LogError::Parse {
            path: self.path.clone(),
            line,
            reason: reason.into(),
        }
    }

    /// A finite number, or `None` for an empty cell.
    pub fn opt_f64(
        &self,
        line: u64,
        rec: &csv::StringRecord,
        col: Option<usize>,
    ) -> Result<Option<f64>, LogError> {
        let Some(i) = col else { return Ok(None) };
        let cell = rec.get(i).unwrap_or("");
        if cell.is_empty() {
            return Ok(None);
        }
        let name = &self.header[i];
        let v: f64 = cell
            .parse()
            .map_err(|_| self.err(line, format!("column `{name}`: `{cell}` is not a number")))?;
        if !v.is_finite() {
            return Err(self.err(line, format!("column `{name}`: `{cell}` is not finite")));
        }
        Ok(Some(v))
    }

    /// A finite number that must be present.
    pub fn req_f64(&self, line: u64, rec: &csv::StringRecord, col: usize) -> Result<f64, LogError> {
        self.opt_f64(line, rec, Some(col))?
            .ok_or_else(|| self.err(line, format!("column `{}` is empty", self.header[col])))
    }

    /// Reads the `t` column of every row and checks it never decreases.
    /// Returns `(line, t, record)` triples.
    pub fn timed_rows(&self) -> Result<Vec<(u64, f64, &csv::StringRecord)>, LogError> {
        let ti = self.require("t")?;
        let mut out = Vec::with_capacity(self.rows.len());
        let mut last: Option<(u64, f64)> = None;
        for (line, rec) in &self.rows {
            let t = self.req_f64(*line, rec, ti)?;
            if let Some((pl, pt)) = last {
                if t < pt {
                    return Err(self.err(
                        *line,
                        format!("time goes backwards: t = {t} after t = {pt} at line {pl}"),
                    ));
                }
            }
            last = Some((*line, t));
            out.push((*line, t, rec));
        }
        Ok(out)
    }
}

/// Collapses rows that repeat the previous timestamp (keeping the first) and
/// returns a warning describing what was dropped.
fn dedup_time<T>(
    items: &mut Vec<(u64, T)>,
    time: impl Fn(&T) -> f64,
    path: &Path,
) -> Option<String> {
    let n0 = items.len();
    let mut first_line = None;
    let mut last_t = f64::NEG_INFINITY;
    items.retain(|(line, it)| {
        let t = time(it);
        let keep = t != last_t;
        if !keep && first_line.is_none() {
            first_line = Some(*line);
        }
        last_t = t;
        keep
    });
    let dropped = n0 - items.len();
    first_line.map(|l| {
        format!(
            "{}:{l}: {dropped} row(s) repeat the previous timestamp; kept the first of each",
            path.display()
        )
    })
}

fn strip<T>(v: Vec<(u64, T)>) -> Vec<T> {
    v.into_iter().map(|(_, x)| x).collect()
}

impl DriveLog {
    /// Reads a log directory. `wheels.csv` is required; every other file is
    /// optional. Fails on the first malformed cell, with file and line.
    pub fn read(dir: impl AsRef<Path>) -> Result<Self, LogError> {
        let dir = dir.as_ref();
        if !dir.is_dir() {
            return Err(LogError::Invalid {
                path: dir.to_path_buf(),
                reason: "not a log directory".into(),
            });
        }
        let mut log = DriveLog {
            dir: dir.to_path_buf(),
            ..Default::default()
        };
        log.wheels = read_wheels(&dir.join("wheels.csv"), &mut log.warnings)?;
        let opt = |name: &str| {
            let p = dir.join(name);
            p.exists().then_some(p)
        };
        if let Some(p) = opt("pose.csv") {
            log.pose = read_pose(&p, &mut log.warnings)?;
        }
        if let Some(p) = opt("imu.csv") {
            log.imu = read_imu(&p, &mut log.warnings)?;
        }
        if let Some(p) = opt("images.csv") {
            log.images = read_images(&p)?;
        }
        if let Some(p) = opt("terrain.csv") {
            log.terrain = read_terrain(&p)?;
        }
        if let Some(p) = opt("truth.csv") {
            log.truth = read_truth(&p)?;
        }
        if let Some(p) = opt("meta.toml") {
            log.meta = read_meta(&p)?;
        }
        Ok(log)
    }
}

/// Reads `wheels.csv`.
pub fn read_wheels(path: &Path, warnings: &mut Vec<String>) -> Result<Vec<WheelSample>, LogError> {
    let tab = read_csv_table(path)?;
    let (l, r) = (tab.require("v_left")?, tab.require("v_right")?);
    let mut out = Vec::with_capacity(tab.rows.len());
    for (line, t, rec) in tab.timed_rows()? {
        let w = WheelSample {
            t,
            v_left: tab.req_f64(line, rec, l)?,
            v_right: tab.req_f64(line, rec, r)?,
        };
        out.push((line, w));
    }
    if out.is_empty() {
        return Err(LogError::Invalid {
            path: path.to_path_buf(),
            reason: "no data rows".into(),
        });
    }
    warnings.extend(dedup_time(&mut out, |w| w.t, path));
    Ok(strip(out))
}

/// Reads `pose.csv`. Rows with no field at all are dropped with a warning.
pub fn read_pose(path: &Path, warnings: &mut Vec<String>) -> Result<Vec<PoseObs>, LogError> {
    let tab = read_csv_table(path)?;
    let (e, n, y) = (
        tab.require("east")?,
        tab.require("north")?,
        tab.require("yaw")?,
    );
    let (sxy, syaw) = (tab.optional("std_xy"), tab.optional("std_yaw"));
    let mut out = Vec::with_capacity(tab.rows.len());
    let mut empty = Vec::new();
    for (line, t, rec) in tab.timed_rows()? {
        let mut p = PoseObs {
            t,
            east: tab.opt_f64(line, rec, Some(e))?,
            north: tab.opt_f64(line, rec, Some(n))?,
            yaw: tab.opt_f64(line, rec, Some(y))?.map(wrap_angle),
            std_xy: tab.opt_f64(line, rec, sxy)?,
            std_yaw: tab.opt_f64(line, rec, syaw)?,
        };
        for (name, s) in [("std_xy", &mut p.std_xy), ("std_yaw", &mut p.std_yaw)] {
            if matches!(*s, Some(v) if v <= 0.0) {
                return Err(tab.err(line, format!("column `{name}` must be > 0")));
            }
        }
        if p.east.is_some() != p.north.is_some() {
            return Err(tab.err(line, "east and north must both be given or both be empty"));
        }
        if p.east.is_none() && p.yaw.is_none() {
            empty.push(line);
            continue;
        }
        out.push((line, p));
    }
    if let Some(first) = empty.first() {
        warnings.push(format!(
            "{}:{first}: {} row(s) with no east/north/yaw were skipped",
            path.display(),
            empty.len()
        ));
    }
    warnings.extend(dedup_time(&mut out, |p| p.t, path));
    Ok(strip(out))
}

/// Reads `imu.csv`.
pub fn read_imu(path: &Path, warnings: &mut Vec<String>) -> Result<Vec<ImuSample>, LogError> {
    let tab = read_csv_table(path)?;
    let az = tab.require("accel_z")?;
    let cols = ["accel_x", "accel_y", "gyro_x", "gyro_y", "gyro_z"].map(|c| tab.optional(c));
    let mut out = Vec::with_capacity(tab.rows.len());
    for (line, t, rec) in tab.timed_rows()? {
        let o = |i: usize| tab.opt_f64(line, rec, cols[i]);
        out.push((
            line,
            ImuSample {
                t,
                accel_z: tab.req_f64(line, rec, az)?,
                accel_x: o(0)?,
                accel_y: o(1)?,
                gyro_x: o(2)?,
                gyro_y: o(3)?,
                gyro_z: o(4)?,
            },
        ));
    }
    warnings.extend(dedup_time(&mut out, |s| s.t, path));
    Ok(strip(out))
}

/// Reads `images.csv` (paths are not opened here).
pub fn read_images(path: &Path) -> Result<Vec<ImageRef>, LogError> {
    let tab = read_csv_table(path)?;
    let pc = tab.require("path")?;
    let mut out = Vec::new();
    for (line, t, rec) in tab.timed_rows()? {
        let p = rec.get(pc).unwrap_or("");
        if p.is_empty() {
            return Err(tab.err(line, "column `path` is empty"));
        }
        out.push(ImageRef {
            t,
            path: PathBuf::from(p),
        });
    }
    Ok(out)
}

/// Reads `terrain.csv`.
pub fn read_terrain(path: &Path) -> Result<Vec<TerrainLabel>, LogError> {
    let tab = read_csv_table(path)?;
    let c = tab.require("terrain")?;
    let mut out = Vec::new();
    for (line, t, rec) in tab.timed_rows()? {
        let name = rec.get(c).unwrap_or("");
        if name.is_empty() {
            return Err(tab.err(line, "column `terrain` is empty"));
        }
        out.push(TerrainLabel {
            t,
            terrain: name.to_string(),
        });
    }
    Ok(out)
}

/// Reads `truth.csv`.
pub fn read_truth(path: &Path) -> Result<Vec<TruthSample>, LogError> {
    let tab = read_csv_table(path)?;
    let cols = ["east", "north", "yaw", "y_l", "y_r", "x_c"];
    let mut idx = [0usize; 6];
    for (i, c) in cols.iter().enumerate() {
        idx[i] = tab.require(c)?;
    }
    let mut out = Vec::with_capacity(tab.rows.len());
    for (line, t, rec) in tab.timed_rows()? {
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
    }
    Ok(out)
}

/// Reads `meta.toml`. Unknown keys are ignored (other tools may add their own).
pub fn read_meta(path: &Path) -> Result<Meta, LogError> {
    let text = std::fs::read_to_string(path).map_err(|e| LogError::io(path, e))?;
    let meta: Meta = toml::from_str(&text).map_err(|e| {
        let line = e
            .span()
            .map(|s| {
                text.as_bytes()[..s.start.min(text.len())]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count() as u64
                    + 1
            })
            .unwrap_or(1);
        LogError::Parse {
            path: path.to_path_buf(),
            line,
            reason: e.message().to_string(),
        }
    })?;
    for (name, v) in [
        ("track_width", meta.track_width),
        ("wheel_radius", meta.wheel_radius),
        ("length", meta.length),
        ("ticks_per_rev", meta.ticks_per_rev),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0) {
                return Err(LogError::Invalid {
                    path: path.to_path_buf(),
                    reason: format!("`{name}` = {v} must be a positive number"),
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
