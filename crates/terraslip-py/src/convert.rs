//! Python objects to and from Rust values: paths, numpy columns, JSON-like
//! dicts, arrays of str.

use std::path::PathBuf;

use numpy::PyReadonlyArray1;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyList, PyMapping, PyString};

/// A Python object as JSON, through the standard `json` module.
pub fn to_json(obj: &Bound<'_, PyAny>) -> PyResult<serde_json::Value> {
    let text: String = obj
        .py()
        .import("json")?
        .call_method1("dumps", (obj,))?
        .extract()?;
    serde_json::from_str(&text).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// JSON as Python objects, through the standard `json` module (numbers
/// read back exactly as `summary.json` holds them).
pub fn from_json<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (v.to_string(),))
}

/// A mapping (of TOML tables) as TOML text; `what` names it in errors.
pub fn to_toml(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<String> {
    let value = toml::Value::try_from(to_json(obj)?)
        .map_err(|e| crate::errors::TerraslipError::new_err(format!("{what}: {e}")))?;
    toml::to_string(&value)
        .map_err(|e| crate::errors::TerraslipError::new_err(format!("{what}: {e}")))
}

/// A path (`str` or `os.PathLike`), or `None` for other objects.
pub fn as_path(obj: &Bound<'_, PyAny>) -> Option<PathBuf> {
    if obj.is_instance_of::<PyMapping>() || obj.is_instance_of::<PyList>() {
        return None;
    }
    obj.extract::<PathBuf>().ok()
}

/// A float64 column; no copy when it already is a contiguous float64 array.
pub fn column<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<PyReadonlyArray1<'py, f64>> {
    let np = obj.py().import("numpy")?;
    let arr = np
        .call_method1("ascontiguousarray", (obj, "float64"))
        .map_err(|e| PyValueError::new_err(format!("{name}: not numbers: {e}")))?;
    arr.extract::<PyReadonlyArray1<f64>>()
        .map_err(|_| PyValueError::new_err(format!("{name}: expected a one-dimensional array")))
}

/// A numpy array of Python str (dtype object).
pub fn str_array<'py>(py: Python<'py>, items: Vec<&str>) -> PyResult<Bound<'py, PyAny>> {
    let list = PyList::new(py, items)?;
    py.import("numpy")?.call_method1("array", (list, "object"))
}

/// Column `key` of table `table`, if it has one.
pub fn item<'py>(
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

/// Column `key` of table `table`, which must have it.
pub fn required<'py>(
    map: &Bound<'py, PyAny>,
    table: &str,
    key: &str,
) -> PyResult<Bound<'py, PyAny>> {
    item(map, table, key)?
        .ok_or_else(|| PyValueError::new_err(format!("{table}: missing required column `{key}`")))
}

/// Fails unless `t` is finite and strictly increasing.
pub fn check_time(t: &[f64], table: &str) -> PyResult<()> {
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

/// Fails unless every column of `cols` (name, length) has `n` values.
pub fn same_length(n: usize, cols: &[(&str, usize)], table: &str) -> PyResult<()> {
    match cols.iter().find(|(_, m)| *m != n) {
        Some((name, m)) => Err(PyValueError::new_err(format!(
            "{table}: `{name}` has {m} values, `t` has {n}"
        ))),
        None => Ok(()),
    }
}
