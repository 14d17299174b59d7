//! `terraslip.TerrainModel`: a classifier from `terraslip terrain train`.

use std::path::PathBuf;

use anyhow::Context as _;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::str_array;
use crate::errors::{detached, guard};
use crate::log::{read_log, topics_arg};

/// A trained terrain classifier (`terraslip terrain train`).
#[pyclass(module = "terraslip", name = "TerrainModel")]
pub struct PyTerrainModel {
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

    /// Classifies a log's windows (imu) or frames (camera); `log` a log
    /// directory, a bag (`topics` as `--topics`) or a mapping of arrays:
    /// `t` (s), `probabilities` (windows x classes), `label` (most probable
    /// class), `terrain` (the filtered, voted terrain; "" before any),
    /// `changes` (s, camera change detections), `outside_envelope` (bool
    /// per window: driven at a tread speed and tread speed difference no
    /// training run of the terrain it is read as had; its probabilities are
    /// mixed half and half with uniform; `None` for a model without an
    /// envelope: camera or `paper` features) and `outside_envelope_share`
    /// (their share, 0..1; `None` likewise or without windows).
    #[pyo3(signature = (log, *, topics=None))]
    fn classify<'py>(
        &self,
        py: Python<'py>,
        log: &Bound<'py, PyAny>,
        topics: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let input = read_log(py, log, true, &topics_arg(topics)?)?;
            let log = &input.log;
            let model = &self.model;
            let (tl, filtered) = detached(py, || {
                let tl = model
                    .classify_log(log)
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
            let out = PyDict::new(py);
            out.set_item("t", PyArray1::from_vec(py, t))?;
            out.set_item(
                "probabilities",
                PyArray1::from_vec(py, probs).reshape([tl.frames.len(), k])?,
            )?;
            out.set_item("label", str_array(py, label)?)?;
            out.set_item("terrain", str_array(py, voted)?)?;
            out.set_item("changes", PyArray1::from_vec(py, tl.changes.clone()))?;
            match model.envelope {
                Some(_) => out.set_item(
                    "outside_envelope",
                    PyArray1::from_vec(py, tl.outside_envelope.clone()),
                )?,
                None => out.set_item("outside_envelope", py.None())?,
            }
            out.set_item("outside_envelope_share", tl.outside_envelope_share())?;
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
