//! CSV tables: a log file open for reading, its header indexed by column
//! name, its rows streamed with line numbers and checked against the
//! physical range of each column.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::types::LogError;

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
