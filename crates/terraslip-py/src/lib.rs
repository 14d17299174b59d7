//! The `terraslip` Python package's native module: thin wrappers over the
//! `terraslip` library, so that Python runs the same configuration, filter
//! and files as the command line. Units SI, frames ROS REP-103 (body x
//! forward, y left; world ENU, yaw counter-clockwise from east).
//!
//! Errors become Python exceptions with the command's messages (the chain
//! of causes joined by ": "): `FileNotFoundError` for a missing file or
//! directory, `terraslip.TerraslipError` (a `ValueError`) for the rest. No
//! panic crosses into Python: each entry point runs under `catch_unwind`.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use anyhow::Context as _;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pyo3::exceptions::{PyFileNotFoundError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyMapping, PyString};
use terraslip::config::EstimatorConfig;
use terraslip::estimate::{Column, Inputs, COLUMNS};
use terraslip_io::{DriveLog, LogError, ParamsFile, PoseObs, TerrainLabel, WheelSample};
use terraslip_terrain::TerrainError;

pyo3::create_exception!(
    terraslip,
    TerraslipError,
    PyValueError,
    "Bad input or a failed run; the message is the command line's."
);

/// How errors name a file given as a mapping.
const MAPPING: &str = "<mapping>";

/// An error chain as the command line prints it, as a Python exception.
fn to_py(e: anyhow::Error) -> PyErr {
    let msg: Vec<String> = e.chain().map(|c| c.to_string()).collect();
    let msg = msg.join(": ");
    let missing = e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::NotFound)
            || match c.downcast_ref::<LogError>() {
                Some(LogError::MissingFile { .. }) => true,
                Some(LogError::Invalid { path, .. }) => {
                    path != Path::new(MAPPING) && !path.exists()
                }
                _ => false,
            }
            || matches!(c.downcast_ref::<TerrainError>(),
                Some(TerrainError::ModelFile { path, .. }) if !path.exists())
    });
    if missing {
        PyFileNotFoundError::new_err(msg)
    } else {
        TerraslipError::new_err(msg)
    }
}

fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    let what = p
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into());
    format!("internal error (please report it): {what}")
}

/// Runs `f` without a panic escaping.
fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f))
        .unwrap_or_else(|p| Err(TerraslipError::new_err(panic_message(p))))
}

/// Runs `f` with the GIL released, without a panic escaping.
fn detached<T: Send>(py: Python<'_>, f: impl FnOnce() -> anyhow::Result<T> + Send) -> PyResult<T> {
    match py.detach(|| catch_unwind(AssertUnwindSafe(f))) {
        Ok(r) => r.map_err(to_py),
        Err(p) => Err(TerraslipError::new_err(panic_message(p))),
    }
}

/// A Python object as JSON, through the standard `json` module.
fn to_json(obj: &Bound<'_, PyAny>) -> PyResult<serde_json::Value> {
    let text: String = obj
        .py()
        .import("json")?
        .call_method1("dumps", (obj,))?
        .extract()?;
    serde_json::from_str(&text).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// JSON as Python objects, through the standard `json` module (numbers
/// read back exactly as `summary.json` holds them).
fn from_json<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (v.to_string(),))
}

/// A path (`str` or `os.PathLike`), or `None` for other objects.
fn as_path(obj: &Bound<'_, PyAny>) -> Option<PathBuf> {
    if obj.is_instance_of::<PyMapping>() || obj.is_instance_of::<PyList>() {
        return None;
    }
    obj.extract::<PathBuf>().ok()
}

/// `config`: a TOML file's path or a mapping of its tables; `preset` the base.
fn load_config(
    config: Option<&Bound<'_, PyAny>>,
    preset: Option<&str>,
) -> PyResult<EstimatorConfig> {
    match config {
        None => terraslip::estimate::config_from(preset, None).map_err(to_py),
        Some(c) => match as_path(c) {
            Some(p) => terraslip::estimate::load_config(preset, Some(&p)).map_err(to_py),
            None if c.is_instance_of::<PyMapping>() => {
                let value = toml::Value::try_from(to_json(c)?)
                    .map_err(|e| TerraslipError::new_err(format!("config: {e}")))?;
                let text = toml::to_string(&value)
                    .map_err(|e| TerraslipError::new_err(format!("config: {e}")))?;
                terraslip::estimate::config_from(preset, Some((&text, "config"))).map_err(to_py)
            }
            None => Err(PyTypeError::new_err(
                "config: expected a TOML file's path or a mapping of its tables",
            )),
        },
    }
}

/// `init`: a parameters file's path or its content as a mapping.
fn load_params(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<ParamsFile> {
    match as_path(obj) {
        Some(p) => ParamsFile::read(&p)
            .context(what.to_string())
            .map_err(to_py),
        None if obj.is_instance_of::<PyMapping>() => {
            let text = to_json(obj)?.to_string();
            ParamsFile::parse(&text, Path::new(MAPPING))
                .context(what.to_string())
                .map_err(to_py)
        }
        None => Err(PyTypeError::new_err(format!(
            "{what}: expected a parameters file's path or its content as a mapping"
        ))),
    }
}

/// A float64 column; no copy when it already is a contiguous float64 array.
fn column<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<PyReadonlyArray1<'py, f64>> {
    let np = obj.py().import("numpy")?;
    let arr = np
        .call_method1("ascontiguousarray", (obj, "float64"))
        .map_err(|e| PyValueError::new_err(format!("{name}: not numbers: {e}")))?;
    arr.extract::<PyReadonlyArray1<f64>>()
        .map_err(|_| PyValueError::new_err(format!("{name}: expected a one-dimensional array")))
}

fn item<'py>(
    map: &Bound<'py, PyAny>,
    table: &str,
    key: &str,
) -> PyResult<Option<Bound<'py, PyAny>>> {
    // Any table with `in` and `[]`: a dict, a pandas DataFrame...
    if !(map.hasattr("__contains__")? && map.hasattr("__getitem__")?)
        || map.is_instance_of::<PyString>()
    {
        return Err(PyTypeError::new_err(format!(
            "{table}: expected a mapping of arrays (a dict, a pandas DataFrame)"
        )));
    }
    if map.contains(key)? {
        Ok(Some(map.get_item(key)?))
    } else {
        Ok(None)
    }
}

fn required<'py>(map: &Bound<'py, PyAny>, table: &str, key: &str) -> PyResult<Bound<'py, PyAny>> {
    item(map, table, key)?
        .ok_or_else(|| PyValueError::new_err(format!("{table}: missing required column `{key}`")))
}

/// Fails unless `t` is finite and strictly increasing.
fn check_time(t: &[f64], table: &str) -> PyResult<()> {
    if let Some(i) = t.iter().position(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{table}: t[{i}] is not finite"
        )));
    }
    match t.windows(2).position(|w| w[1] <= w[0]) {
        Some(i) => Err(PyValueError::new_err(format!(
            "{table}: t must increase strictly (row {}: {} after {})",
            i + 1,
            t[i + 1],
            t[i]
        ))),
        None => Ok(()),
    }
}

fn same_length(n: usize, cols: &[(&str, usize)], table: &str) -> PyResult<()> {
    match cols.iter().find(|(_, m)| *m != n) {
        Some((name, m)) => Err(PyValueError::new_err(format!(
            "{table}: `{name}` has {m} values, `t` has {n}"
        ))),
        None => Ok(()),
    }
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
        let t = column(&required(&pose, "pose", "t")?, "pose.t")?;
        let t = t.as_slice()?;
        check_time(t, "pose")?;
        let mut cols = Vec::new();
        for name in ["east", "north", "yaw", "std_xy", "std_yaw"] {
            cols.push(match item(&pose, "pose", name)? {
                Some(c) => Some(column(&c, &format!("pose.{name}"))?),
                None => None,
            });
        }
        let slices: Vec<Option<&[f64]>> = cols
            .iter()
            .map(|c| c.as_ref().map(|a| a.as_slice()).transpose())
            .collect::<Result<_, _>>()?;
        let lens: Vec<(&str, usize)> = ["east", "north", "yaw", "std_xy", "std_yaw"]
            .iter()
            .zip(&slices)
            .filter_map(|(n, s)| s.map(|s| (*n, s.len())))
            .collect();
        same_length(t.len(), &lens, "pose")?;
        // NaN is an empty cell.
        let get = |k: usize, i: usize| slices[k].map(|s| s[i]).filter(|v| !v.is_nan());
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
                out.pose.push(p);
            }
        }
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

/// What `pose.csv`'s reader refuses in a row.
fn check_pose(p: &PoseObs) -> Result<(), String> {
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

/// The log a `log` argument names: a directory (read as the command reads
/// it; with the sensor streams when `sensors`) or a mapping of arrays.
fn read_log(py: Python<'_>, log: &Bound<'_, PyAny>, sensors: bool) -> PyResult<DriveLog> {
    if let Some(dir) = as_path(log) {
        return detached(py, move || {
            if sensors {
                DriveLog::read(&dir)
            } else {
                terraslip::estimate::read_log(&dir)
            }
            .with_context(|| format!("reading log {}", dir.display()))
        });
    }
    if log.is_instance_of::<PyMapping>() {
        return log_from_mapping(log);
    }
    Err(PyTypeError::new_err(
        "log: expected a log directory's path or a mapping of arrays (wheels=..., pose=...)",
    ))
}

/// Runs the online ICR estimator over a drive log, as `terraslip estimate`.
///
/// `log`: a log directory (docs/log-format.md) or a mapping of arrays
/// {"wheels": {"t" s, "v_left" m/s, "v_right" m/s}, "pose": {"t" s, "east" m,
/// "north" m, "yaw" rad, "std_xy" m, "std_yaw" rad}, "terrain": {"t",
/// "terrain"}, "meta": {"track_width" m, ...}} (pose, terrain, meta optional).
/// `config`: a TOML file or a mapping of its tables, on top of `preset`.
/// `init`: a parameters file or the dict `calibrate` returns.
///
/// Returns one numpy array per column of estimate.csv (`COLUMNS`), equal to
/// what the command writes: pose east, north (m, ENU), yaw (rad, CCW from
/// east); ICRs y_l, y_r, x_c (m, body frame: x forward, y left) and their
/// stds; alphas; flags as bool; `terrain` as str. Key `summary`: the dict
/// of summary.json. Releases the GIL while reading and running.
#[pyfunction]
#[pyo3(signature = (log, *, config=None, init=None, terrain_labels=false, terrain_model=None, preset=None))]
fn estimate<'py>(
    py: Python<'py>,
    log: &Bound<'py, PyAny>,
    config: Option<&Bound<'py, PyAny>>,
    init: Option<&Bound<'py, PyAny>>,
    terrain_labels: bool,
    terrain_model: Option<PathBuf>,
    preset: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let cfg = load_config(config, preset)?;
        let init = init.map(|i| load_params(i, "--init")).transpose()?;
        // A terrain model needs the sensor streams it classifies.
        let log = read_log(py, log, terrain_model.is_some())?;
        let est = detached(py, || {
            let inputs = Inputs {
                init: init.as_ref(),
                terrain_labels,
                terrain_model: terrain_model.as_deref(),
                outage: None,
            };
            terraslip::estimate::estimate(&log, cfg, &inputs, &mut |_, _| {})
        })?;
        let out = PyDict::new(py);
        let run = &est.run;
        let n = run.rows.len();
        let mut cols: Vec<Vec<f64>> = (0..COLUMNS.len()).map(|_| Vec::with_capacity(n)).collect();
        for r in &run.rows {
            for ((v, (_, col)), c) in terraslip::estimate::values(r)
                .into_iter()
                .zip(COLUMNS)
                .zip(cols.iter_mut())
            {
                c.push(terraslip::estimate::as_written(v, col));
            }
        }
        for ((name, col), values) in COLUMNS.into_iter().zip(cols) {
            match col {
                Column::Time | Column::Fixed(_) => {
                    out.set_item(name, PyArray1::from_vec(py, values))?;
                }
                Column::Flag => {
                    let b: Vec<bool> = values.iter().map(|v| *v != 0.0).collect();
                    out.set_item(name, PyArray1::from_vec(py, b))?;
                }
                Column::Terrain => {
                    let names: Vec<&str> = run
                        .rows
                        .iter()
                        .map(|r| run.terrain_name(r).unwrap_or(""))
                        .collect();
                    let list = PyList::new(py, names)?;
                    let arr = py
                        .import("numpy")?
                        .call_method1("array", (list, "object"))?;
                    out.set_item(name, arr)?;
                }
            }
        }
        out.set_item("summary", from_json(py, &est.summary)?)?;
        Ok(out)
    })
}

/// The online estimator, one event at a time: the filter `terraslip
/// estimate` runs. `track_width` in m; `config`, `init`, `preset` as for
/// `estimate`. Feed each wheels row after the pose fixes stamped at or
/// before it; `state()` then equals `estimate`'s row (unrounded).
#[pyclass(module = "terraslip")]
struct Estimator {
    est: terraslip_core::Estimator,
    cfg: EstimatorConfig,
    init: Option<ParamsFile>,
    track_width: f64,
    terrains: Vec<String>,
    current: Option<usize>,
    init_source: String,
    warnings: Vec<String>,
}

#[pymethods]
impl Estimator {
    #[new]
    #[pyo3(signature = (track_width, config=None, init=None, *, preset=None))]
    fn new(
        track_width: f64,
        config: Option<&Bound<'_, PyAny>>,
        init: Option<&Bound<'_, PyAny>>,
        preset: Option<&str>,
    ) -> PyResult<Self> {
        guard(|| {
            if !(track_width.is_finite() && track_width > 0.0) {
                return Err(PyValueError::new_err(format!(
                    "track_width = {track_width}: expected a positive number of metres"
                )));
            }
            let cfg = load_config(config, preset)?;
            let init = init.map(|i| load_params(i, "--init")).transpose()?;
            let (est, init_source, warnings) =
                terraslip::pipeline::estimator(&cfg, track_width, init.as_ref())
                    .map_err(|e| to_py(e.into()))?;
            Ok(Self {
                est,
                cfg,
                init,
                track_width,
                terrains: Vec::new(),
                current: None,
                init_source,
                warnings,
            })
        })
    }

    /// Tread speeds `v_left`, `v_right` (m/s) over the interval ending at
    /// `t` (s).
    fn on_wheels(&mut self, t: f64, v_left: f64, v_right: f64) -> PyResult<()> {
        guard(|| {
            self.est
                .on_wheels(t, v_left, v_right)
                .map_err(|e| TerraslipError::new_err(format!("wheels row at t = {t}: {e}")))
        })
    }

    /// A pose fix stamped `t` (s): `east`, `north` (m, ENU, both or
    /// neither), `yaw` (rad, CCW from east), 1-sigma `std_xy` (m) and
    /// `std_yaw` (rad); without stds the configuration's.
    #[pyo3(signature = (t, east=None, north=None, yaw=None, std_xy=None, std_yaw=None))]
    fn on_pose(
        &mut self,
        t: f64,
        east: Option<f64>,
        north: Option<f64>,
        yaw: Option<f64>,
        std_xy: Option<f64>,
        std_yaw: Option<f64>,
    ) -> PyResult<()> {
        guard(|| {
            let p = PoseObs {
                t,
                east,
                north,
                yaw: yaw.map(terraslip_io::wrap_angle),
                std_xy,
                std_yaw,
            };
            check_pose(&p).map_err(|e| PyValueError::new_err(format!("pose at t = {t}: {e}")))?;
            if p.east.is_none() && p.yaw.is_none() {
                return Err(PyValueError::new_err(format!(
                    "pose at t = {t}: give east and north, yaw, or both"
                )));
            }
            self.est
                .on_pose(t, terraslip::pipeline::pose_fix(&self.cfg, &p))
                .map_err(|e| TerraslipError::new_err(format!("pose at t = {t}: {e}")))
        })
    }

    /// The terrain evidence declares terrain `label`; returns what the
    /// schedule did ("recalled", "learning", "none"), None if unchanged.
    fn on_terrain(&mut self, label: &str) -> PyResult<Option<String>> {
        guard(|| {
            let k = match self.terrains.iter().position(|n| n == label) {
                Some(k) => k,
                None => {
                    let k = self.terrains.len();
                    if let Some(init) = &self.init {
                        terraslip::pipeline::seed_terrain(&mut self.est, &self.cfg, init, k, label);
                    }
                    self.terrains.push(label.to_string());
                    k
                }
            };
            if self.current == Some(k) {
                return Ok(None);
            }
            self.current = Some(k);
            let action = self
                .est
                .on_terrain(k)
                .map_err(|e| TerraslipError::new_err(format!("terrain `{label}`: {e}")))?;
            Ok(Some(format!("{action:?}").to_lowercase()))
        })
    }

    /// The estimate now: the keys of `COLUMNS`, unrounded (`fused`,
    /// `gated`, `nis`, `change`: since the previous `state()` call).
    fn state<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let t = self.est.time().unwrap_or(f64::NAN);
            let summary = self.est.take_fix_summary();
            let row = terraslip::pipeline::row(&self.est, t, self.current, &summary);
            let out = PyDict::new(py);
            for (v, (name, col)) in terraslip::estimate::values(&row).into_iter().zip(COLUMNS) {
                match col {
                    Column::Time | Column::Fixed(_) => out.set_item(name, v)?,
                    Column::Flag => out.set_item(name, v != 0.0)?,
                    Column::Terrain => {
                        let name_of = self.current.and_then(|k| self.terrains.get(k));
                        out.set_item(name, name_of.map(|s| PyString::new(py, s)))?
                    }
                }
            }
            Ok(out)
        })
    }

    #[getter]
    fn track_width(&self) -> f64 {
        self.track_width
    }

    #[getter]
    fn init_source(&self) -> &str {
        &self.init_source
    }

    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    #[getter]
    fn terrains(&self) -> Vec<String> {
        self.terrains.clone()
    }
}

/// Log directories from a path or a sequence of paths.
fn log_paths(logs: &Bound<'_, PyAny>) -> PyResult<Vec<PathBuf>> {
    if let Some(p) = as_path(logs) {
        return Ok(vec![p]);
    }
    logs.extract::<Vec<PathBuf>>()
        .map_err(|_| PyTypeError::new_err("logs: expected a log directory or a sequence of them"))
}

fn read_logs(paths: &[PathBuf]) -> anyhow::Result<Vec<DriveLog>> {
    paths
        .iter()
        .map(|p| DriveLog::read(p).with_context(|| format!("reading log {}", p.display())))
        .collect()
}

/// Identifies the ICR parameters offline, as `terraslip calibrate`:
/// `method` "lm", "ga", "symmetric" or None (all three, the best kept).
/// Returns the parameters file's content (y_l, y_r, x_c in m, alpha_l,
/// alpha_r, their 1-sigma std, per terrain when the logs are labelled).
#[pyfunction]
#[pyo3(signature = (logs, method=Some("lm")), text_signature = "(logs, method='lm')")]
fn calibrate<'py>(
    py: Python<'py>,
    logs: &Bound<'py, PyAny>,
    method: Option<&str>,
) -> PyResult<Bound<'py, PyAny>> {
    guard(|| {
        use terraslip_calib::Method;
        let method = match method {
            None => None,
            Some("lm") => Some(Method::Lm),
            Some("ga") => Some(Method::Ga),
            Some("symmetric") => Some(Method::Symmetric),
            Some(m) => {
                return Err(PyValueError::new_err(format!(
                    "method `{m}`: expected \"lm\", \"ga\", \"symmetric\" or None (all three, the best kept)"
                )))
            }
        };
        let paths = log_paths(logs)?;
        let pf = detached(py, move || {
            let logs = read_logs(&paths)?;
            let cfg = terraslip_calib::CalibConfig {
                method,
                ..Default::default()
            };
            let cal =
                terraslip_calib::calibrate(&logs, &cfg, &|_| {}).context("calibration failed")?;
            Ok(serde_json::to_value(cal.params_file())?)
        })?;
        from_json(py, &pf)
    })
}

/// Scores parameters on drives, as `terraslip calibrate validate --json`:
/// mean squared segment errors dx, dy (m^2) and dyaw (rad^2) in the frame
/// of each segment start, against the no-slip model, and the 2 s
/// prediction error. `params`: a parameters file or its content.
#[pyfunction]
fn validate<'py>(
    py: Python<'py>,
    logs: &Bound<'py, PyAny>,
    params: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    guard(|| {
        let paths = log_paths(logs)?;
        let params = match as_path(params) {
            Some(p) => ParamsFile::read(&p)
                .with_context(|| format!("reading parameters {}", p.display()))
                .map_err(to_py)?,
            None => load_params(params, "params")?,
        };
        let v = detached(py, move || {
            let logs = read_logs(&paths)?;
            let cfg = terraslip_calib::ValidateConfig::default();
            let v = terraslip_calib::validate(&logs, &params, &cfg).context("validation failed")?;
            let prediction = terraslip::validation::prediction(&logs, &params);
            Ok(terraslip::validation::to_json(&v, prediction.as_ref()))
        })?;
        from_json(py, &v)
    })
}

/// A trained terrain classifier (`terraslip terrain train`).
#[pyclass(module = "terraslip", name = "TerrainModel")]
struct PyTerrainModel {
    model: terraslip_terrain::TerrainModel,
}

#[pymethods]
impl PyTerrainModel {
    /// Reads a model file from `terraslip terrain train`.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        guard(|| {
            let model = detached(py, move || {
                Ok(terraslip_terrain::TerrainModel::load(&path)?)
            })?;
            Ok(Self { model })
        })
    }

    /// Terrain names; column k of `probabilities` is `classes[k]`.
    #[getter]
    fn classes(&self) -> Vec<String> {
        self.model.classes.clone()
    }

    /// Classifies a log directory's windows (imu) or frames (camera):
    /// `t` (s), `probabilities` (windows x classes), `label` (most probable
    /// class), `terrain` (the filtered, voted terrain; "" before any),
    /// `changes` (s, camera change detections).
    fn classify<'py>(
        &self,
        py: Python<'py>,
        log: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let log = read_log(py, log, true)?;
            let model = &self.model;
            let (tl, filtered) = detached(py, || {
                let tl = model
                    .classify_log(&log)
                    .with_context(|| format!("classifying {}", log.dir.display()))?;
                let filtered = tl.filter(&model.belief);
                Ok((tl, filtered))
            })?;
            let k = tl.classes.len();
            let t: Vec<f64> = tl.frames.iter().map(|f| f.0).collect();
            let probs: Vec<f64> = tl.frames.iter().flat_map(|f| f.1.iter().copied()).collect();
            let name = |i: usize| tl.classes.get(i).map_or("", |s| s.as_str());
            let label: Vec<&str> = filtered.iter().map(|f| name(f.raw)).collect();
            let voted: Vec<&str> = filtered.iter().map(|f| f.voted.map_or("", name)).collect();
            let np = py.import("numpy")?;
            let out = PyDict::new(py);
            out.set_item("t", PyArray1::from_vec(py, t))?;
            out.set_item(
                "probabilities",
                PyArray1::from_vec(py, probs).reshape([tl.frames.len(), k])?,
            )?;
            out.set_item(
                "label",
                np.call_method1("array", (PyList::new(py, label)?, "object"))?,
            )?;
            out.set_item(
                "terrain",
                np.call_method1("array", (PyList::new(py, voted)?, "object"))?,
            )?;
            out.set_item("changes", PyArray1::from_vec(py, tl.changes.clone()))?;
            Ok(out)
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "TerrainModel({:?} classifier, classes {:?})",
            self.model.source, self.model.classes
        )
    }
}

#[pymodule]
fn _terraslip(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("TerraslipError", m.py().get_type::<TerraslipError>())?;
    m.add("COLUMNS", COLUMNS.map(|c| c.0).to_vec())?;
    m.add_function(wrap_pyfunction!(estimate, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(validate, m)?)?;
    m.add_class::<Estimator>()?;
    m.add_class::<PyTerrainModel>()?;
    Ok(())
}
