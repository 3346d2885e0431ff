//! Records from Python: a CSV path (the file format of docs/INTERFACES.md), a pandas
//! DataFrame, a dict of numpy arrays or a numpy structured array (columns by name), checked by the host library with
//! the messages it gives for files; its warnings (ignored columns) become Python warnings.

use crate::{py_err, InputError};
use geared_servo_host::record::{self, Record, OUTPUT_COLUMNS};
use numpy::PyReadonlyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyString, PyTuple};
use std::path::PathBuf;

/// Whether `obj` names a file (a str or an `os.PathLike`).
pub fn is_path(obj: &Bound<'_, PyAny>) -> bool {
    obj.is_instance_of::<PyString>() || obj.hasattr("__fspath__").unwrap_or(false)
}

/// The column names of a record given by columns: a DataFrame or a mapping (`keys()`), or a
/// numpy structured array (`dtype.names`); `None` for anything else.
fn column_names(obj: &Bound<'_, PyAny>) -> PyResult<Option<Vec<String>>> {
    let names = if obj.hasattr("keys")? {
        obj.call_method0("keys")?
    } else {
        match obj.getattr("dtype").and_then(|d| d.getattr("names")) {
            Ok(n) if !n.is_none() => n,
            _ => return Ok(None),
        }
    };
    let names = names
        .try_iter()?
        .map(|k| k.and_then(|k| k.str().map(|s| s.to_string())))
        .collect::<PyResult<_>>()?;
    Ok(Some(names))
}

/// Whether `obj` is a record given by columns (a DataFrame, a mapping, a structured array).
pub fn is_columns(obj: &Bound<'_, PyAny>) -> bool {
    matches!(column_names(obj), Ok(Some(_)))
}

/// `obj` as a float64 array: `numpy.asarray(obj, dtype="float64")`, one-dimensional.
pub fn floats(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
    let py = obj.py();
    let kwargs = pyo3::types::PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let arr = py
        .import("numpy")?
        .call_method("asarray", (obj,), Some(&kwargs))
        .map_err(|e| InputError::new_err(format!("{what}: not numbers ({e})")))?;
    let arr: PyReadonlyArray1<'_, f64> = arr.extract().map_err(|_| {
        InputError::new_err(format!(
            "{what}: expected a one-dimensional array of numbers"
        ))
    })?;
    Ok(arr.as_array().to_vec())
}

/// The record `obj` (a path, a DataFrame or a dict of arrays), its name for messages, and its
/// warnings issued. With `require_output`, it must have an output column (measured data).
pub fn record_of(obj: &Bound<'_, PyAny>, require_output: bool) -> PyResult<(Record, String)> {
    let py = obj.py();
    let (rec, name) = if is_path(obj) {
        let path: PathBuf = obj.extract()?;
        let rec = py
            .detach(|| record::read(&path, require_output))
            .map_err(py_err)?;
        (rec, path.display().to_string())
    } else if let Some(keys) = column_names(obj)? {
        let name = format!("<{}>", obj.get_type().name()?);
        let mut columns: Vec<(String, Vec<f64>)> = Vec::new();
        for k in keys {
            let used =
                k == "time_s" || k == "motor_voltage_v" || OUTPUT_COLUMNS.contains(&k.as_str());
            // Columns the record format does not use are only named (and warned about).
            let values = if used {
                floats(&obj.get_item(&k)?, &format!("{name}: column `{k}`"))?
            } else {
                Vec::new()
            };
            columns.push((k, values));
        }
        let cols: Vec<(&str, &[f64])> = columns
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_slice()))
            .collect();
        let rec = record::from_columns(&name, &cols, require_output).map_err(py_err)?;
        (rec, name)
    } else {
        return Err(InputError::new_err(format!(
            "a record is a CSV path, a pandas DataFrame, a dict of arrays or a structured array (time_s, motor_voltage_v, ...), got {}",
            obj.get_type().name()?
        )));
    };
    let warn = py.import("warnings")?;
    for w in &rec.warnings {
        warn.call_method1("warn", PyTuple::new(py, [w.as_str()])?)?;
    }
    Ok((rec, name))
}
