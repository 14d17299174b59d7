//! The `terraslip` Python package's native module: thin wrappers over the
//! `terraslip` library, so that Python runs the same configuration, filter
//! and files as the command line. Units SI, frames ROS REP-103 (body x
//! forward, y left; world ENU, yaw counter-clockwise from east).
//!
//! * [`errors`]: Python exceptions with the command's messages, no panic
//!   across;
//! * [`convert`]: paths, numpy columns, JSON-like dicts;
//! * [`config`], [`log`]: the arguments that name files (configuration,
//!   parameters, logs and bags, topics) or give their content;
//! * [`estimate`], [`streaming`], [`calibrate`], [`terrain`]: the API.

use pyo3::prelude::*;

mod calibrate;
mod config;
mod convert;
mod errors;
mod estimate;
mod log;
mod streaming;
mod terrain;

#[pymodule]
fn _terraslip(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add(
        "TerraslipError",
        m.py().get_type::<errors::TerraslipError>(),
    )?;
    m.add(
        "COLUMNS",
        terraslip::estimate::COLUMNS.map(|c| c.0).to_vec(),
    )?;
    m.add_function(wrap_pyfunction!(estimate::estimate, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(calibrate::validate, m)?)?;
    m.add_class::<streaming::Estimator>()?;
    m.add_class::<terrain::PyTerrainModel>()?;
    Ok(())
}
