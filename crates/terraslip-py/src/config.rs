//! The `config`, `preset`, `init` and `params` arguments: files or their
//! content as mappings, read as the command reads the files.

use std::path::Path;

use anyhow::Context as _;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyMapping;
use terraslip::config::EstimatorConfig;
use terraslip_io::ParamsFile;

use crate::convert::{as_path, to_json, to_toml};
use crate::errors::{to_py, MAPPING};

/// `config`: a TOML file's path or a mapping of its tables; `preset` the base.
pub fn load_config(
    config: Option<&Bound<'_, PyAny>>,
    preset: Option<&str>,
) -> PyResult<EstimatorConfig> {
    match config {
        None => terraslip::estimate::config_from(preset, None).map_err(to_py),
        Some(c) => match as_path(c) {
            Some(p) => terraslip::estimate::load_config(preset, Some(&p)).map_err(to_py),
            None if c.is_instance_of::<PyMapping>() => {
                let text = to_toml(c, "config")?;
                terraslip::estimate::config_from(preset, Some((&text, "config"))).map_err(to_py)
            }
            None => Err(PyTypeError::new_err(
                "config: expected a TOML file's path or a mapping of its tables",
            )),
        },
    }
}

/// `init` / `params`: a parameters file's path or its content as a mapping;
/// `what` names it in errors.
pub fn load_params(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<ParamsFile> {
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
