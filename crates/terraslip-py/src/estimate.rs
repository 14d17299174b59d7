//! `terraslip.estimate`: `terraslip estimate` over a log, a bag or arrays,
//! its `estimate.csv` columns as numpy arrays.

use std::path::PathBuf;

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use terraslip::estimate::{Column, Inputs, COLUMNS};

use crate::config::{load_config, load_params};
use crate::convert::{from_json, str_array};
use crate::errors::{detached, guard};
use crate::log::{read_log, topics_arg};

/// Runs the online ICR estimator over a drive log, as `terraslip estimate`.
///
/// `log`: a log directory (docs/log-format.md), a ROS 2 bag (a directory
/// with metadata.yaml, or an .mcap / .db3 file; `topics` as `--topics`) or
/// a mapping of arrays {"wheels": {"t" s, "v_left" m/s, "v_right" m/s},
/// "pose": {"t" s, "east" m, "north" m, "yaw" rad, "std_xy" m, "std_yaw"
/// rad}, "terrain": {"t", "terrain"}, "meta": {"track_width" m, ...}}
/// (pose, terrain, meta optional).
/// `config`: a TOML file or a mapping of its tables, on top of `preset`.
/// `init`: a parameters file or the dict `calibrate` returns.
///
/// Returns one numpy array per column of estimate.csv (`COLUMNS`), equal to
/// what the command writes: pose east, north (m, ENU), yaw (rad, CCW from
/// east); ICRs y_l, y_r, x_c (m, body frame: x forward, y left) and their
/// stds; alphas; flags as bool; `terrain` as str. Key `summary`: the dict
/// of summary.json. Releases the GIL while reading and running.
#[pyfunction]
#[pyo3(signature = (log, *, config=None, init=None, terrain_labels=false, terrain_model=None, preset=None, topics=None))]
#[allow(clippy::too_many_arguments)]
pub fn estimate<'py>(
    py: Python<'py>,
    log: &Bound<'py, PyAny>,
    config: Option<&Bound<'py, PyAny>>,
    init: Option<&Bound<'py, PyAny>>,
    terrain_labels: bool,
    terrain_model: Option<PathBuf>,
    preset: Option<&str>,
    topics: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let cfg = load_config(config, preset)?;
        let init = init.map(|i| load_params(i, "--init")).transpose()?;
        let topics = topics_arg(topics)?;
        // A terrain model needs the sensor streams it classifies.
        let input = read_log(py, log, terrain_model.is_some(), &topics)?;
        let log = &input.log;
        let est = detached(py, || {
            let inputs = Inputs {
                init: init.as_ref(),
                terrain_labels,
                terrain_model: terrain_model.as_deref(),
                outage: None,
            };
            terraslip::estimate::estimate(log, cfg, &inputs, &mut |_, _| {})
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
                    out.set_item(name, str_array(py, names)?)?;
                }
            }
        }
        out.set_item("summary", from_json(py, &est.summary)?)?;
        Ok(out)
    })
}
