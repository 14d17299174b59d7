//! `wheels.csv` and `pose.csv` row by row: [`WheelStream`] and
//! [`PoseStream`] check each row as it is read and hand it over, so a
//! consumer that does not keep the rows (`terraslip estimate`) runs in
//! memory that does not grow with the log. The whole-file readers are the
//! same streams collected.

use std::path::Path;

use crate::angle::wrap_angle;
use crate::csv_table::{read_csv_table, CsvTable};
use crate::pose_steps::PoseSteps;
use crate::types::*;

/// Drops rows that repeat the previous timestamp (keeping the first) and
/// remembers what it dropped, for one warning.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Repeats {
    last_t: f64,
    first_line: Option<u64>,
    dropped: usize,
}

impl Default for Repeats {
    fn default() -> Self {
        Self {
            last_t: f64::NEG_INFINITY,
            first_line: None,
            dropped: 0,
        }
    }
}

impl Repeats {
    /// Whether the row at `line` with time `t` is kept.
    pub(crate) fn keep(&mut self, line: u64, t: f64) -> bool {
        let keep = t != self.last_t;
        if !keep {
            self.first_line.get_or_insert(line);
            self.dropped += 1;
        }
        self.last_t = t;
        keep
    }

    /// The warning describing what was dropped, if anything was.
    pub(crate) fn warning(&self, path: &Path) -> Option<String> {
        self.first_line.map(|l| {
            format!(
                "{}:{l}: {} row(s) repeat the previous timestamp; kept the first of each",
                path.display(),
                self.dropped
            )
        })
    }
}

/// A stream's next item; the stream is `done` after its last row or its
/// first error.
fn ended_by_error<T>(
    done: &mut bool,
    read: Result<Option<T>, LogError>,
) -> Option<Result<T, LogError>> {
    let item = read.transpose();
    *done = !matches!(item, Some(Ok(_)));
    item
}

/// `wheels.csv` row by row: the tread speeds, rows repeating the previous
/// timestamp dropped. An error (file and line) ends the stream.
pub struct WheelStream {
    tab: CsvTable,
    speeds: (usize, usize),
    /// The current columns, when they are read.
    amps: Option<(usize, usize)>,
    repeats: Repeats,
    amp_repeats: Repeats,
    currents: Vec<MotorCurrent>,
    rows: usize,
    done: bool,
}

impl WheelStream {
    /// Opens `wheels.csv` and checks its header.
    pub fn open(path: &Path) -> Result<Self, LogError> {
        Self::open_with(path, false)
    }

    /// With `currents`, the motor currents of the rows that give both are
    /// kept for [`WheelStream::into_currents`].
    fn open_with(path: &Path, currents: bool) -> Result<Self, LogError> {
        let tab = read_csv_table(path)?;
        let speeds = (tab.require("v_left")?, tab.require("v_right")?);
        let amps = match (tab.optional("current_left"), tab.optional("current_right")) {
            (Some(cl), Some(cr)) if currents => Some((cl, cr)),
            _ => None,
        };
        Ok(Self {
            tab,
            speeds,
            amps,
            repeats: Repeats::default(),
            amp_repeats: Repeats::default(),
            currents: Vec::new(),
            rows: 0,
            done: false,
        })
    }

    /// Bytes of the file read so far (for progress).
    pub fn bytes_read(&self) -> u64 {
        self.tab.bytes_read()
    }

    /// What the rows read so far call for (repeated timestamps).
    pub fn warnings(&self) -> Vec<String> {
        self.repeats.warning(&self.tab.path).into_iter().collect()
    }

    /// The motor currents read (with repeated timestamps dropped).
    fn into_currents(self) -> Vec<MotorCurrent> {
        self.currents
    }

    fn next_sample(&mut self) -> Result<Option<WheelSample>, LogError> {
        let (l, r) = self.speeds;
        while let Some((line, t)) = self.tab.advance()? {
            self.rows += 1;
            let (tab, rec) = (&self.tab, self.tab.record());
            let w = WheelSample {
                t,
                v_left: tab.req_f64(line, rec, l)?,
                v_right: tab.req_f64(line, rec, r)?,
            };
            if let Some((cl, cr)) = self.amps {
                if let (Some(left), Some(right)) = (
                    tab.opt_f64(line, rec, Some(cl))?,
                    tab.opt_f64(line, rec, Some(cr))?,
                ) {
                    // The repeated timestamps are warned about with the
                    // tread speeds.
                    if self.amp_repeats.keep(line, t) {
                        self.currents.push(MotorCurrent { t, left, right });
                    }
                }
            }
            if self.repeats.keep(line, t) {
                return Ok(Some(w));
            }
        }
        if self.rows == 0 {
            return Err(LogError::Invalid {
                path: self.tab.path.clone(),
                reason: "no data rows; a drive needs at least one wheels row".into(),
            });
        }
        Ok(None)
    }
}

impl Iterator for WheelStream {
    type Item = Result<WheelSample, LogError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let read = self.next_sample();
        ended_by_error(&mut self.done, read)
    }
}

/// `pose.csv` row by row. Rows with no field at all are dropped, as are
/// rows repeating the previous timestamp; half a position (only one of
/// east/north) is dropped from its row. An error (file and line) ends the
/// stream.
pub struct PoseStream {
    tab: CsvTable,
    cols: [usize; 3],
    stds: (Option<usize>, Option<usize>),
    repeats: Repeats,
    /// First line and count of rows with half a position, and of empty rows.
    half: (Option<u64>, usize),
    empty: (Option<u64>, usize),
    /// The steps between consecutive positions, for fixes stamped on arrival.
    steps: PoseSteps,
    done: bool,
}

impl PoseStream {
    /// Opens `pose.csv` and checks its header.
    pub fn open(path: &Path) -> Result<Self, LogError> {
        let tab = read_csv_table(path)?;
        let cols = [
            tab.require("east")?,
            tab.require("north")?,
            tab.require("yaw")?,
        ];
        let stds = (tab.optional("std_xy"), tab.optional("std_yaw"));
        Ok(Self {
            tab,
            cols,
            stds,
            repeats: Repeats::default(),
            half: (None, 0),
            empty: (None, 0),
            steps: PoseSteps::default(),
            done: false,
        })
    }

    /// What the rows read so far call for (half positions, empty rows,
    /// repeated timestamps, fixes stamped on arrival).
    pub fn warnings(&self) -> Vec<String> {
        let path = self.tab.path.display();
        let mut out = Vec::new();
        if let (Some(first), n) = self.half {
            out.push(format!(
                "{path}:{first}: {n} row(s) with only one of east/north; their position was not used"
            ));
        }
        if let (Some(first), n) = self.empty {
            out.push(format!(
                "{path}:{first}: {n} row(s) with no east/north/yaw were skipped"
            ));
        }
        out.extend(self.repeats.warning(&self.tab.path));
        out.extend(self.steps.warning(&self.tab.path));
        out
    }

    fn next_obs(&mut self) -> Result<Option<PoseObs>, LogError> {
        let [e, n, y] = self.cols;
        while let Some((line, t)) = self.tab.advance()? {
            let (tab, rec) = (&self.tab, self.tab.record());
            let mut p = PoseObs {
                t,
                east: tab.opt_f64(line, rec, Some(e))?,
                north: tab.opt_f64(line, rec, Some(n))?,
                yaw: tab.opt_f64(line, rec, Some(y))?.map(wrap_angle),
                std_xy: tab.opt_f64(line, rec, self.stds.0)?,
                std_yaw: tab.opt_f64(line, rec, self.stds.1)?,
            };
            for (name, s) in [("std_xy", p.std_xy), ("std_yaw", p.std_yaw)] {
                if matches!(s, Some(v) if v <= 0.0) {
                    return Err(tab.err(
                        line,
                        format!(
                            "column `{name}` must be > 0; give the 1-sigma error, or leave it empty"
                        ),
                    ));
                }
            }
            if p.east.is_some() != p.north.is_some() {
                // Half a position is no position; the yaw (if any) is still used.
                self.half.0.get_or_insert(line);
                self.half.1 += 1;
                (p.east, p.north) = (None, None);
            }
            if p.east.is_none() && p.yaw.is_none() {
                self.empty.0.get_or_insert(line);
                self.empty.1 += 1;
                continue;
            }
            if self.repeats.keep(line, t) {
                if let (Some(e), Some(n)) = (p.east, p.north) {
                    self.steps.observe(line, t, e, n);
                }
                return Ok(Some(p));
            }
        }
        Ok(None)
    }
}

impl Iterator for PoseStream {
    type Item = Result<PoseObs, LogError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let read = self.next_obs();
        ended_by_error(&mut self.done, read)
    }
}

/// `imu.csv`'s yaw rate row by row: `(t, gyro_z)` (s, rad/s) of the rows
/// that give `gyro_z`, rows repeating the previous timestamp dropped. A
/// file without the column yields nothing. An error (file and line) ends
/// the stream.
pub struct GyroStream {
    tab: CsvTable,
    col: Option<usize>,
    repeats: Repeats,
    done: bool,
}

impl GyroStream {
    /// Opens `imu.csv` and checks its header.
    pub fn open(path: &Path) -> Result<Self, LogError> {
        let tab = read_csv_table(path)?;
        let col = tab.optional("gyro_z");
        Ok(Self {
            tab,
            col,
            repeats: Repeats::default(),
            done: col.is_none(),
        })
    }

    /// Whether the file has a `gyro_z` column.
    pub fn has_gyro(&self) -> bool {
        self.col.is_some()
    }

    /// What the rows read so far call for (repeated timestamps).
    pub fn warnings(&self) -> Vec<String> {
        self.repeats.warning(&self.tab.path).into_iter().collect()
    }

    fn next_rate(&mut self) -> Result<Option<(f64, f64)>, LogError> {
        while let Some((line, t)) = self.tab.advance()? {
            let (tab, rec) = (&self.tab, self.tab.record());
            if let Some(rate) = tab.opt_f64(line, rec, self.col)? {
                if self.repeats.keep(line, t) {
                    return Ok(Some((t, rate)));
                }
            }
        }
        Ok(None)
    }
}

impl Iterator for GyroStream {
    type Item = Result<(f64, f64), LogError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let read = self.next_rate();
        ended_by_error(&mut self.done, read)
    }
}

/// Reads `wheels.csv`.
pub fn read_wheels(path: &Path, warnings: &mut Vec<String>) -> Result<Vec<WheelSample>, LogError> {
    read_wheel_rows(path, warnings, false).map(|(w, _)| w)
}

/// Reads the optional `current_left,current_right` columns of `wheels.csv`:
/// empty without them; rows where either cell is empty are skipped.
pub fn read_currents(path: &Path) -> Result<Vec<MotorCurrent>, LogError> {
    read_wheel_rows(path, &mut Vec::new(), true).map(|(_, c)| c)
}

/// One pass over `wheels.csv`: the tread speeds and, with `currents`, the
/// motor currents where the file has them.
pub(crate) fn read_wheel_rows(
    path: &Path,
    warnings: &mut Vec<String>,
    currents: bool,
) -> Result<(Vec<WheelSample>, Vec<MotorCurrent>), LogError> {
    let mut stream = WheelStream::open_with(path, currents)?;
    let wheels = stream.by_ref().collect::<Result<Vec<_>, _>>()?;
    warnings.extend(stream.warnings());
    Ok((wheels, stream.into_currents()))
}

/// Reads `pose.csv`. Rows with no field at all are dropped with a warning.
pub fn read_pose(path: &Path, warnings: &mut Vec<String>) -> Result<Vec<PoseObs>, LogError> {
    let mut stream = PoseStream::open(path)?;
    let pose = stream.by_ref().collect::<Result<Vec<_>, _>>()?;
    warnings.extend(stream.warnings());
    Ok(pose)
}
