//! The Python package `geared_servo`: this crate is its extension module
//! `geared_servo._native`; `python/geared_servo/__init__.py` re-exports it and adds the
//! parameter tables' attributes (`p.motor.resistance_ohm`, documented with their units).
//!
//! Everything here wraps `geared-servo-host`: parameter files, records, `simulate`, the
//! frequency response, the design queries and `diagnose`, with the command line's results
//! (the same JSON objects, as dicts) and its one-line messages (as exceptions:
//! [`InputError`] for bad input, exit status 2 of the command line; [`ModelError`] for the
//! rest). Long computations release the GIL; a panic, which the host library does not
//! expect, becomes a [`ModelError`] rather than crossing into Python.

use geared_servo_host::error::{ErrorKind, HostError};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::panic::{catch_unwind, AssertUnwindSafe};

mod diagnose;
mod functions;
mod params;
mod record;

pyo3::create_exception!(
    geared_servo,
    InputError,
    PyValueError,
    "Bad input: a file, key, column or argument is wrong. The message is the command line's."
);
pyo3::create_exception!(
    geared_servo,
    ModelError,
    PyRuntimeError,
    "A failure that is not the input's fault (writing a file, a numerical failure)."
);

/// The Python exception of a host error, with its one-line message.
pub(crate) fn py_err(e: HostError) -> PyErr {
    match e.kind {
        ErrorKind::BadInput => InputError::new_err(e.message),
        ErrorKind::Other => ModelError::new_err(e.message),
    }
}

/// Runs `f` with the GIL released; its error becomes an exception, a panic a [`ModelError`].
pub(crate) fn detached<T: Send>(
    py: Python<'_>,
    f: impl FnOnce() -> Result<T, HostError> + Send,
) -> PyResult<T> {
    py.detach(|| catch_unwind(AssertUnwindSafe(f)))
        .map_err(|p| {
            let why = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            ModelError::new_err(format!("internal error: {why}"))
        })?
        .map_err(py_err)
}

/// A JSON value as Python objects (dicts, lists, floats, None), through `json.loads`.
pub(crate) fn py_json<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (v.to_string(),))
}

/// The extension module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add_class::<params::Params>()?;
    m.add_class::<diagnose::Diagnosis>()?;
    m.add_function(wrap_pyfunction!(params::schema, m)?)?;
    m.add_function(wrap_pyfunction!(params::register_tables, m)?)?;
    m.add_function(wrap_pyfunction!(functions::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(functions::bode, m)?)?;
    m.add_function(wrap_pyfunction!(functions::resonances, m)?)?;
    m.add_function(wrap_pyfunction!(functions::max_backlash, m)?)?;
    m.add_function(wrap_pyfunction!(functions::min_voltage, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose::diagnose, m)?)?;
    m.add(
        "SIMULATE_COLUMNS",
        geared_servo_host::simulate::SIMULATE_COLUMNS.to_vec(),
    )?;
    m.add(
        "OUTPUT_COLUMNS",
        geared_servo_host::record::OUTPUT_COLUMNS.to_vec(),
    )?;
    Ok(())
}
