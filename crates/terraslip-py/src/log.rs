//! The `log` / `logs` and `topics` arguments: log directories and ROS 2
//! bags (read as the command reads a LOG), or a log as a mapping of arrays.

use std::path::PathBuf;

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyMapping;
use terraslip::bag::{Input, Topics};
use terraslip_io::{DriveLog, PoseObs, TerrainLabel, WheelSample};

use crate::convert::{as_path, check_time, column, item, required, same_length, to_json, to_toml};
use crate::errors::{detached, MAPPING};

/// `topics`: a topics file's path (`--topics FILE.toml`), a mapping of its
/// tables, or None (topics chosen by message type).
pub fn topics_arg(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Topics> {
    let Some(obj) = obj else {
        return Ok(Topics::ByType);
    };
    match as_path(obj) {
        Some(p) => Ok(Topics::File(p)),
        None if obj.is_instance_of::<PyMapping>() => Ok(Topics::Toml {
            text: to_toml(obj, "topics")?,
            name: "topics".into(),
        }),
        None => Err(PyTypeError::new_err(
            "topics: expected a topics file's path or a mapping of its tables",
        )),
    }
}

/// The log a `log` argument names: a log directory or a bag (read as the
/// command reads a LOG; with the sensor streams when `sensors`), or a
/// mapping of arrays. A bag's temporary log lives as long as the result.
pub fn read_log(
    py: Python<'_>,
    log: &Bound<'_, PyAny>,
    sensors: bool,
    topics: &Topics,
) -> PyResult<Input> {
    if let Some(path) = as_path(log) {
        return detached(py, move || {
            if sensors {
                terraslip::bag::read(&path, topics, |p| DriveLog::read(p))
            } else {
                terraslip::bag::read(&path, topics, terraslip::estimate::read_log)
            }
        });
    }
    if log.is_instance_of::<PyMapping>() {
        if topics.is_given() {
            return Err(PyValueError::new_err(
                "topics: for ROS 2 bags; this log is a mapping of arrays",
            ));
        }
        return Ok(Input {
            log: log_from_mapping(log)?,
            bag: None,
        });
    }
    Err(PyTypeError::new_err(
        "log: expected a log directory's or a bag's path, or a mapping of arrays (wheels=..., pose=...)",
    ))
}

/// Paths from a path or a sequence of paths.
fn log_paths(logs: &Bound<'_, PyAny>) -> PyResult<Vec<PathBuf>> {
    if let Some(p) = as_path(logs) {
        return Ok(vec![p]);
    }
    logs.extract::<Vec<PathBuf>>().map_err(|_| {
        PyTypeError::new_err("logs: expected a log directory or bag, or a sequence of them")
    })
}

/// The logs a `logs` argument names (log directories or bags), read whole
/// with the GIL released.
pub fn read_logs(py: Python<'_>, logs: &Bound<'_, PyAny>, topics: &Topics) -> PyResult<Vec<Input>> {
    let paths = log_paths(logs)?;
    detached(py, move || {
        paths
            .iter()
            .map(|p| terraslip::bag::read(p, topics, |p| DriveLog::read(p)))
            .collect()
    })
}

/// A log from a mapping of arrays (the columns of docs/log-format.md).
fn log_from_mapping(log: &Bound<'_, PyAny>) -> PyResult<DriveLog> {
    // Messages and the summary name the log.
    let mut out = DriveLog {
        dir: PathBuf::from(MAPPING),
        ..Default::default()
    };
    let wheels = required(log, "log", "wheels")?;
    let (t, l, r) = (
        column(&required(&wheels, "wheels", "t")?, "wheels.t")?,
        column(&required(&wheels, "wheels", "v_left")?, "wheels.v_left")?,
        column(&required(&wheels, "wheels", "v_right")?, "wheels.v_right")?,
    );
    let (t, l, r) = (t.as_slice()?, l.as_slice()?, r.as_slice()?);
    same_length(
        t.len(),
        &[("v_left", l.len()), ("v_right", r.len())],
        "wheels",
    )?;
    if t.is_empty() {
        return Err(PyValueError::new_err("wheels: no rows"));
    }
    check_time(t, "wheels")?;
    out.wheels = (0..t.len())
        .map(|i| WheelSample {
            t: t[i],
            v_left: l[i],
            v_right: r[i],
        })
        .collect();
    if let Some(pose) = item(log, "log", "pose")? {
        out.pose = pose_from_mapping(&pose)?;
    }
    if let Some(terrain) = item(log, "log", "terrain")? {
        let t = column(&required(&terrain, "terrain", "t")?, "terrain.t")?;
        let t = t.as_slice()?;
        let names: Vec<String> = required(&terrain, "terrain", "terrain")?
            .extract()
            .map_err(|_| PyValueError::new_err("terrain.terrain: expected a sequence of str"))?;
        same_length(t.len(), &[("terrain", names.len())], "terrain")?;
        out.terrain = t
            .iter()
            .zip(names)
            .map(|(&t, terrain)| TerrainLabel { t, terrain })
            .collect();
    }
    if let Some(meta) = item(log, "log", "meta")? {
        out.meta = serde_json::from_value(to_json(&meta)?)
            .map_err(|e| PyValueError::new_err(format!("meta: {e}")))?;
    }
    Ok(out)
}

/// The pose table: rows with a position or a heading (NaN is an empty cell).
fn pose_from_mapping(pose: &Bound<'_, PyAny>) -> PyResult<Vec<PoseObs>> {
    const NAMES: [&str; 5] = ["east", "north", "yaw", "std_xy", "std_yaw"];
    let t = column(&required(pose, "pose", "t")?, "pose.t")?;
    let t = t.as_slice()?;
    check_time(t, "pose")?;
    let mut cols = Vec::new();
    for name in NAMES {
        cols.push(match item(pose, "pose", name)? {
            Some(c) => Some(column(&c, &format!("pose.{name}"))?),
            None => None,
        });
    }
    let slices: Vec<Option<&[f64]>> = cols
        .iter()
        .map(|c| c.as_ref().map(|a| a.as_slice()).transpose())
        .collect::<Result<_, _>>()?;
    let lens: Vec<(&str, usize)> = NAMES
        .iter()
        .zip(&slices)
        .filter_map(|(n, s)| s.map(|s| (*n, s.len())))
        .collect();
    same_length(t.len(), &lens, "pose")?;
    let get = |k: usize, i: usize| slices[k].map(|s| s[i]).filter(|v| !v.is_nan());
    let mut out = Vec::new();
    for (i, &ti) in t.iter().enumerate() {
        let p = PoseObs {
            t: ti,
            east: get(0, i),
            north: get(1, i),
            yaw: get(2, i).map(terraslip_io::wrap_angle),
            std_xy: get(3, i),
            std_yaw: get(4, i),
        };
        check_pose(&p).map_err(|e| PyValueError::new_err(format!("pose row {i}: {e}")))?;
        if p.east.is_some() || p.yaw.is_some() {
            out.push(p);
        }
    }
    Ok(out)
}

/// What `pose.csv`'s reader refuses in a row.
pub fn check_pose(p: &PoseObs) -> Result<(), String> {
    if p.east.is_some() != p.north.is_some() {
        return Err("east and north must both be given or both be empty".into());
    }
    for (name, s) in [("std_xy", p.std_xy), ("std_yaw", p.std_yaw)] {
        if matches!(s, Some(v) if v.is_nan() || v <= 0.0) {
            return Err(format!("`{name}` must be > 0"));
        }
    }
    Ok(())
}
