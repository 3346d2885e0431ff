//! `geared_servo.diagnose`: calibrate, trace the residual, report, as `geared-servo
//! diagnose`; the result carries the report (the dict of `diagnose --json`), the calibrated
//! `Params` and the measured and model outputs for plotting.

use crate::params::Params;
use crate::record::record_of;
use crate::{detached, py_err, py_json, InputError};
use geared_servo_host::calibrate::{self, Data};
use geared_servo_host::diagnose::{diagnose_with as run, options_by_name};
use geared_servo_host::diagnose_report::insert;
use geared_servo_host::{params_file, HostError, Progress};
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyList, PyTuple};
use serde_json::json;
use std::sync::Mutex;

/// The result of `diagnose`.
#[pyclass(module = "geared_servo", name = "Diagnosis", frozen)]
pub struct Diagnosis {
    /// The dict of `diagnose --json` (docs/INTERFACES.md): `samples`, `sample_period_s`,
    /// `output`, `nominal`, `steps`, `added_effects`, `final`, `unexplained`, ...
    #[pyo3(get)]
    report: Py<PyAny>,
    /// The calibrated parameters (with the effects added), at the sample period of the
    /// parameters diagnosed: what `diagnose --out` writes to `calibrated.toml`.
    #[pyo3(get)]
    params: Py<Params>,
    /// The human summary `diagnose` prints.
    #[pyo3(get)]
    summary: String,
    /// The output fitted (`tach_voltage_v`, ...), of the first record.
    #[pyo3(get)]
    output: String,
    /// The unit of `output` (`"V"`, `"rad/s"`, ...).
    #[pyo3(get)]
    output_unit: &'static str,
    /// Time of each row of the first record from its start, s.
    #[pyo3(get)]
    time_s: Py<PyArray1<f64>>,
    /// The measured output of the first record, in its unit.
    #[pyo3(get)]
    measured: Py<PyArray1<f64>>,
    /// The model's output with the parameters diagnosed, on the first record.
    #[pyo3(get)]
    model_before: Py<PyArray1<f64>>,
    /// The model's output with the calibrated parameters, on the first record.
    #[pyo3(get)]
    model_after: Py<PyArray1<f64>>,
    toml: String,
}

#[pymethods]
impl Diagnosis {
    /// The calibrated parameter file as `diagnose --out` writes it (`calibrated.toml`,
    /// with its header).
    fn to_toml(&self) -> String {
        self.toml.clone()
    }

    fn __repr__(&self) -> String {
        format!("Diagnosis(output={:?})", self.output)
    }
}

/// The progress of a diagnosis seen from Python: each phase done goes to the callback,
/// when there is one; an exception it raises, or an interrupt (Ctrl-C, a notebook's stop
/// button, seen between phases), stops the diagnosis and is raised by `diagnose`.
struct Stages {
    callback: Option<Py<PyAny>>,
    /// The first exception raised, which stops the diagnosis.
    error: Mutex<Option<PyErr>>,
}

impl Progress for Stages {
    fn stage(&self, name: &str) {
        Python::attach(|py| {
            let called = match &self.callback {
                Some(cb) => cb.call1(py, (name,)).map(|_| ()),
                None => Ok(()),
            };
            if let Err(e) = called.and_then(|()| py.check_signals()) {
                if let Ok(mut first) = self.error.lock() {
                    first.get_or_insert(e);
                }
            }
        });
    }

    fn cancelled(&self) -> bool {
        self.error.lock().map(|e| e.is_some()).unwrap_or(false)
    }
}

/// Calibrates `params` against `record` (a CSV path, a DataFrame or a dict of arrays with
/// `time_s`, `motor_voltage_v` and an output; or a list of them, fitted together), analyses
/// the residual and adds the effects that explain it, as `geared-servo diagnose`.
/// `validate` is a record that is not fitted (`--validate`), `candidates` the effect names
/// to try (`--candidates`, default all), `max_steps` the most effects added, `fit` the key
/// paths to calibrate instead of the default set (`--fit`), `limits` the effects to bound
/// that the diagnosis did not add (`--limits`; an empty list: every candidate; the report's
/// `limits` key). `progress`, a callable, receives each phase as it ends (a diagnosis of a
/// long record takes minutes; `progress=print` shows where it is). Between phases an
/// interrupt stops the diagnosis (KeyboardInterrupt), as does an exception of `progress`
/// (raised again here).
// One Rust argument per keyword argument of the Python function.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (params, record, validate = None, candidates = None, max_steps = 3, fit = None, progress = None, limits = None))]
pub fn diagnose<'py>(
    py: Python<'py>,
    params: PyRef<'py, Params>,
    record: &Bound<'py, PyAny>,
    validate: Option<&Bound<'py, PyAny>>,
    candidates: Option<Vec<String>>,
    max_steps: usize,
    fit: Option<Vec<String>>,
    progress: Option<Py<PyAny>>,
    limits: Option<Vec<String>>,
) -> PyResult<Diagnosis> {
    let (p, name) = (params.p, params.name.clone());
    let records: Vec<Bound<'py, PyAny>> =
        if record.is_instance_of::<PyList>() || record.is_instance_of::<PyTuple>() {
            record.try_iter()?.collect::<PyResult<_>>()?
        } else {
            vec![record.clone()]
        };
    let mut data = Vec::new();
    let mut names = Vec::new();
    for r in &records {
        let (rec, rname) = record_of(r, true)?;
        params_file::validate_for_record(&p, rec.sample_period_s, &rname).map_err(py_err)?;
        data.push(Data::from_record(&rec, &rname).map_err(py_err)?);
        names.push(rname);
    }
    let val = match validate {
        Some(v) => {
            let (rec, vname) = record_of(v, true)?;
            Some(Data::from_record(&rec, &vname).map_err(py_err)?)
        }
        None => None,
    };
    let opts = options_by_name(
        &p,
        max_steps,
        candidates.as_deref(),
        limits.as_deref(),
        fit.as_deref(),
        "",
    )
    .map_err(py_err)?;
    let first = data
        .first()
        .cloned()
        .ok_or_else(|| InputError::new_err("no record"))?;
    let stages = Stages {
        callback: progress,
        error: Mutex::new(None),
    };
    let done = detached(py, || {
        let out = run(&p, &data, val.as_ref(), &opts, &stages)?;
        let mut json = out.to_json(&first);
        insert(&mut json, "params", json!(name));
        let sim = |q| {
            calibrate::simulate(q, &first)
                .map(|t| t.y)
                .ok_or_else(|| HostError::other("the model cannot run on the record"))
        };
        let (before, after) = (sim(&out.nominal)?, sim(&out.final_fit.params)?);
        Ok((out, json, before, after))
    });
    // An exception of the callback or an interrupt stopped it: that is what the caller sees.
    if let Some(e) = stages.error.into_inner().ok().flatten() {
        return Err(e);
    }
    let (out, json, before, after) = done?;
    let calibrated = out.calibrated(&p);
    let toml =
        params_file::to_toml(&calibrated, &out.calibrated_header(&name, &names)).map_err(py_err)?;
    let h = first.sample_period_s;
    let time_s: Vec<f64> = (0..first.y.len()).map(|k| k as f64 * h).collect();
    Ok(Diagnosis {
        report: py_json(py, &json)?.unbind(),
        params: Py::new(
            py,
            Params {
                p: calibrated,
                name: format!("calibrated from {name}"),
            },
        )?,
        summary: out.summary(),
        output: first.output.clone(),
        output_unit: geared_servo_host::param_list::unit_of(&first.output).unwrap_or("-"),
        time_s: time_s.into_pyarray(py).unbind(),
        measured: first.y.clone().into_pyarray(py).unbind(),
        model_before: before.into_pyarray(py).unbind(),
        model_after: after.into_pyarray(py).unbind(),
        toml,
    })
}
