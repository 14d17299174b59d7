//! Errors as Python exceptions, and no panic across into Python.
//!
//! A run's error becomes `FileNotFoundError` when it is about a missing file
//! or directory, `terraslip.TerraslipError` (a `ValueError`) otherwise; the
//! message is the line the command prints after `error: `.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use pyo3::exceptions::{PyFileNotFoundError, PyValueError};
use pyo3::prelude::*;
use terraslip_io::LogError;
use terraslip_terrain::TerrainError;

pyo3::create_exception!(
    terraslip,
    TerraslipError,
    PyValueError,
    "Bad input or a failed run; the message is the command line's."
);

/// How errors name a file given as a mapping.
pub const MAPPING: &str = "<mapping>";

/// An error chain as the command line prints it, as a Python exception.
pub fn to_py(e: anyhow::Error) -> PyErr {
    let msg = terraslip::one_line(&e);
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
pub fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f))
        .unwrap_or_else(|p| Err(TerraslipError::new_err(panic_message(p))))
}

/// Runs `f` with the GIL released, without a panic escaping.
pub fn detached<T: Send>(
    py: Python<'_>,
    f: impl FnOnce() -> anyhow::Result<T> + Send,
) -> PyResult<T> {
    match py.detach(|| catch_unwind(AssertUnwindSafe(f))) {
        Ok(r) => r.map_err(to_py),
        Err(p) => Err(TerraslipError::new_err(panic_message(p))),
    }
}
