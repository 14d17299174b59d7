//! `terraslip.calibrate` and `terraslip.validate`: `terraslip calibrate`
//! and `terraslip calibrate validate --json`, their JSON as dicts.

use anyhow::Context as _;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use terraslip::bag::{Imported, Input};
use terraslip_io::{DriveLog, ParamsFile};

use crate::config::load_params;
use crate::convert::{as_path, from_json};
use crate::errors::{detached, guard, to_py};
use crate::log::{read_logs, topics_arg};

/// The logs read, and the bags' temporary logs to keep while they are used.
fn split(inputs: Vec<Input>) -> (Vec<DriveLog>, Vec<Option<Imported>>) {
    inputs.into_iter().map(|i| (i.log, i.bag)).unzip()
}

/// Identifies the ICR parameters offline, as `terraslip calibrate`:
/// `method` "lm", "ga", "symmetric" or None (all three, the best kept).
/// `logs`: log directories or bags (`topics` as `--topics`). Returns the
/// parameters file's content (y_l, y_r, x_c in m, alpha_l, alpha_r, their
/// 1-sigma std, per terrain when the logs are labelled).
#[pyfunction]
#[pyo3(
    signature = (logs, method=Some("lm"), *, topics=None),
    text_signature = "(logs, method='lm', *, topics=None)"
)]
pub fn calibrate<'py>(
    py: Python<'py>,
    logs: &Bound<'py, PyAny>,
    method: Option<&str>,
    topics: Option<&Bound<'py, PyAny>>,
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
        let (logs, _bags) = split(read_logs(py, logs, &topics_arg(topics)?)?);
        let pf = detached(py, move || {
            let cfg = terraslip_calib::CalibConfig {
                method,
                ..Default::default()
            };
            let cal =
                terraslip_calib::calibrate(&logs, &cfg, &|_| {}).context("calibration failed")?;
            let mut pf = cal.params_file();
            // As `terraslip calibrate` writes it.
            if let Some(scale) = logs.first().and_then(|l| l.meta.separation_note()) {
                pf.extra.insert("separation".into(), scale);
            }
            Ok(serde_json::to_value(pf)?)
        })?;
        from_json(py, &pf)
    })
}

/// Scores parameters on drives, as `terraslip calibrate validate --json`:
/// mean squared segment errors dx, dy (m^2) and dyaw (rad^2) in the frame
/// of each segment start, against the no-slip model, and the 2 s
/// prediction error (on position-only references, GNSS without a heading,
/// the 2 s prediction alone, start headings profiled out). `logs`: log
/// directories or bags (`topics` as `--topics`); `params`: a parameters
/// file or its content.
#[pyfunction]
#[pyo3(signature = (logs, params, *, topics=None))]
pub fn validate<'py>(
    py: Python<'py>,
    logs: &Bound<'py, PyAny>,
    params: &Bound<'py, PyAny>,
    topics: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    guard(|| {
        let params = match as_path(params) {
            Some(p) => ParamsFile::read(&p)
                .with_context(|| format!("reading parameters {}", p.display()))
                .map_err(to_py)?,
            None => load_params(params, "params")?,
        };
        let (logs, _bags) = split(read_logs(py, logs, &topics_arg(topics)?)?);
        let v = detached(py, move || {
            let cfg = terraslip_calib::ValidateConfig::default();
            Ok(terraslip::validation::score(&logs, &params, &cfg)?.to_json())
        })?;
        from_json(py, &v)
    })
}
