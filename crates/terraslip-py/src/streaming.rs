//! `terraslip.Estimator`: the online estimator, one event at a time.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use terraslip::config::EstimatorConfig;
use terraslip::estimate::{Column, COLUMNS};
use terraslip_io::{ParamsFile, PoseObs};

use crate::config::{load_config, load_params};
use crate::errors::{guard, to_py, TerraslipError};
use crate::log::check_pose;

/// The online estimator, one event at a time: the filter `terraslip
/// estimate` runs. `track_width` in m; `config`, `init`, `preset` as for
/// `estimate`; `pose_reference` as meta.toml's (`"gnss"`, `"localiser"`). Feed each wheels row after the pose fixes stamped at or
/// before it; `state()` then equals `estimate`'s row (unrounded).
#[pyclass(module = "terraslip")]
pub struct Estimator {
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
    #[pyo3(signature = (track_width, config=None, init=None, *, preset=None, pose_reference=None))]
    fn new(
        track_width: f64,
        config: Option<&Bound<'_, PyAny>>,
        init: Option<&Bound<'_, PyAny>>,
        preset: Option<&str>,
        pose_reference: Option<&str>,
    ) -> PyResult<Self> {
        guard(|| {
            if !(track_width.is_finite() && track_width > 0.0) {
                return Err(PyValueError::new_err(format!(
                    "track_width = {track_width}: expected a positive number of metres"
                )));
            }
            let reference = pose_reference
                .map(str::parse::<terraslip_io::PoseReference>)
                .transpose()
                .map_err(|e| PyValueError::new_err(format!("pose_reference: {e}")))?;
            let cfg = terraslip::pipeline::decide::for_pose_reference(
                &load_config(config, preset)?,
                reference,
            );
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

    /// A yaw-rate gyro sample `rate` (rad/s, counter-clockwise about body
    /// z) at `t` (s, the wheels' clock); the samples between two wheels
    /// rows are integrated. The filter leaves it out when the
    /// configuration's `measurement.std_gyro` is 0.
    fn on_gyro(&mut self, t: f64, rate: f64) -> PyResult<()> {
        guard(|| {
            self.est
                .on_gyro(t, rate)
                .map_err(|e| PyValueError::new_err(format!("gyro sample at t = {t}: {e}")))
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
