//! `simulate`, `bode`, `resonances`, `max_backlash`, `min_voltage`: the commands of the same
//! names on a `Params`, computed by the host library with the GIL released. Arguments carry
//! the command line's names and checks (its messages name its options: `--vpk`, ...).

use crate::params::Params;
use crate::record::{floats, is_columns, is_path, record_of};
use crate::{detached, py_err, py_json, InputError};
use geared_servo::analyser::Hold;
use geared_servo::ActuatorParams;
use geared_servo_host::fr::{spread_db, SweepOptions};
use geared_servo_host::simulate::{simulate_columns, SIMULATE_COLUMNS};
use geared_servo_host::{fr_report, params_file, record};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// `params` with `backlash_deg` when given (checked as `--backlash-deg`), and its name.
fn with_backlash(params: &Params, backlash_deg: Option<f64>) -> PyResult<(ActuatorParams, String)> {
    let p = match backlash_deg {
        Some(b) => params_file::with_backlash(&params.p, b).map_err(py_err)?,
        None => params.p,
    };
    Ok((p, params.name.clone()))
}

/// The sweep options of `--vpk`, `--hold`, `--max-time-s`, `--cold-start`.
fn options(vpk: f64, hold: &str, max_time_s: f64, cold_start: bool) -> PyResult<SweepOptions> {
    let hold = match hold {
        "continuous" => Hold::Continuous,
        "zoh" => Hold::Zoh,
        other => {
            return Err(InputError::new_err(format!(
                "--hold must be `continuous` or `zoh`, got `{other}`"
            )))
        }
    };
    fr_report::sweep_options(vpk, hold, max_time_s, cold_start).map_err(py_err)
}

/// The plant from rest on a voltage record, as `geared-servo simulate`: `volts` is an array
/// of voltages (V, one per sample period `dt`, s; default the parameters' period) or a
/// record (a CSV path, a DataFrame or a dict with `time_s` and `motor_voltage_v`; `dt` is
/// then the record's). Row k holds the outputs at `time_s[k]`, before `motor_voltage_v[k]`
/// is applied until the next row (docs/INTERFACES.md).
///
/// Returns a dict of numpy arrays: `time_s` (s), `motor_voltage_v` (V), `tach_voltage_v`
/// (V), `motor_speed_rad_s` (rad/s), `load_angle_deg` (deg), `current_a` (A),
/// `load_speed_rad_s` (rad/s), `transmitted_torque_nm` (N*m), `in_contact` (1 while the
/// gears touch, else 0), `mean_current_a` (A, averaged over the step).
#[pyfunction]
#[pyo3(signature = (params, volts, dt = None, backlash_deg = None))]
pub fn simulate<'py>(
    py: Python<'py>,
    params: PyRef<'py, Params>,
    volts: &Bound<'py, PyAny>,
    dt: Option<f64>,
    backlash_deg: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let (p, _) = with_backlash(&params, backlash_deg)?;
    let (time_s, v, dt) = if is_path(volts) || is_columns(volts) {
        if dt.is_some() {
            return Err(InputError::new_err(
                "dt: give it with an array of volts only (a record has its own time_s)",
            ));
        }
        let (rec, name) = record_of(volts, false)?;
        params_file::validate_for_record(&p, rec.sample_period_s, &name).map_err(py_err)?;
        (rec.time_s, rec.motor_voltage_v, rec.sample_period_s)
    } else {
        let dt = dt.unwrap_or(p.sample_period_s);
        params_file::validate_for_record(&p, dt, "dt").map_err(py_err)?;
        let v = floats(volts, "volts")?;
        let t: Vec<f64> = (0..v.len()).map(|k| k as f64 * dt).collect();
        // The checks of a record (finite values, two rows at least), for arrays.
        record::from_columns("volts", &[("time_s", &t), ("motor_voltage_v", &v)], false)
            .map_err(py_err)?;
        (t, v, dt)
    };
    let cols = detached(py, || simulate_columns(&p, dt, &v))?;
    let out = PyDict::new(py);
    out.set_item("time_s", time_s.into_pyarray(py))?;
    out.set_item("motor_voltage_v", v.into_pyarray(py))?;
    for (name, c) in SIMULATE_COLUMNS.iter().zip(cols) {
        out.set_item(*name, c.into_pyarray(py))?;
    }
    Ok(out)
}

/// Stepped-sine frequency response of `V_t/V_m`, as `geared-servo bode`: amplitude `vpk`
/// (V), frequencies `from_hz` to `to_hz` by `step_hz` (Hz), the sine `hold`
/// (`"continuous"`, the paper's, or `"zoh"`, the firmware's), at most `max_time_s` (s) per
/// frequency, warm start unless `cold_start`.
///
/// Returns the dict of `bode --json` with its `points` as numpy arrays (the columns of
/// `bode --csv`): `freq_hz` (Hz), `gain_db` (dB), `phase_deg` (deg), `gain_spread_db` (dB)
/// and `settled` (bool).
#[pyfunction]
#[pyo3(signature = (params, vpk, backlash_deg = None, from_hz = 10.0, to_hz = 300.0,
                    step_hz = 1.0, hold = "continuous", max_time_s = 1.0, cold_start = false))]
#[allow(clippy::too_many_arguments)]
pub fn bode<'py>(
    py: Python<'py>,
    params: PyRef<'py, Params>,
    vpk: f64,
    backlash_deg: Option<f64>,
    from_hz: f64,
    to_hz: f64,
    step_hz: f64,
    hold: &str,
    max_time_s: f64,
    cold_start: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let (p, name) = with_backlash(&params, backlash_deg)?;
    let freqs = fr_report::bode_grid(from_hz, to_hz, step_hz).map_err(py_err)?;
    let opts = options(vpk, hold, max_time_s, cold_start)?;
    let b = detached(py, || fr_report::bode(&p, &name, opts, &freqs, &()))?;
    let mut json = b.json;
    if let Some(o) = json.as_object_mut() {
        o.remove("points");
    }
    let out = py_json(py, &json)?;
    let pts = &b.points;
    let col = |f: &dyn Fn(&geared_servo_host::fr::Point) -> f64| -> Vec<f64> {
        pts.iter().map(f).collect()
    };
    out.set_item("freq_hz", col(&|q| q.freq_hz).into_pyarray(py))?;
    out.set_item("gain_db", col(&|q| q.tach.gain_db()).into_pyarray(py))?;
    out.set_item("phase_deg", col(&|q| q.tach.phase_deg()).into_pyarray(py))?;
    out.set_item(
        "gain_spread_db",
        col(&|q| spread_db(q.tach.spread, q.gain())).into_pyarray(py),
    )?;
    let settled: Vec<bool> = pts.iter().map(|q| q.settled).collect();
    out.set_item("settled", settled.into_pyarray(py))?;
    Ok(out)
}

/// Anti-resonance and resonance located on the simulated response, as
/// `geared-servo resonances`: the dict of `resonances --json` (`f_ar_hz`, `f_r_hz`, Hz, or
/// None with `f_ar_reason`/`f_ar_cause`, ...). Arguments as for `bode`.
#[pyfunction]
#[pyo3(signature = (params, vpk, backlash_deg = None, hold = "continuous", max_time_s = 1.0,
                    cold_start = false))]
pub fn resonances<'py>(
    py: Python<'py>,
    params: PyRef<'py, Params>,
    vpk: f64,
    backlash_deg: Option<f64>,
    hold: &str,
    max_time_s: f64,
    cold_start: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let (p, name) = with_backlash(&params, backlash_deg)?;
    let opts = options(vpk, hold, max_time_s, cold_start)?;
    let (_, json) = detached(py, || fr_report::resonances(&p, &name, opts, &()))?;
    py_json(py, &json)
}

/// The largest total backlash (deg) whose simulated f_AR at `vpk` (V) is still at least
/// `bandwidth_hz` (Hz), as `geared-servo max-backlash`: the dict of its `--json`
/// (`max_backlash_deg`, or None with `max_backlash_reason`, and the bisection's `trace`).
#[pyfunction]
#[pyo3(signature = (params, bandwidth_hz, vpk, hold = "continuous", max_time_s = 1.0,
                    cold_start = false))]
pub fn max_backlash<'py>(
    py: Python<'py>,
    params: PyRef<'py, Params>,
    bandwidth_hz: f64,
    vpk: f64,
    hold: &str,
    max_time_s: f64,
    cold_start: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let (p, name) = with_backlash(&params, None)?;
    let opts = options(vpk, hold, max_time_s, cold_start)?;
    let (_, json) = detached(py, || {
        fr_report::max_backlash(&p, &name, bandwidth_hz, opts)
    })?;
    py_json(py, &json)
}

/// The smallest voltage amplitude (V) whose simulated f_AR with `backlash_deg` (deg) is at
/// least `bandwidth_hz` (Hz), as `geared-servo min-voltage`: the dict of its `--json`
/// (`min_vpk`, or None with `min_vpk_reason`, and the bisection's `trace`).
#[pyfunction]
#[pyo3(signature = (params, bandwidth_hz, backlash_deg, hold = "continuous", max_time_s = 1.0,
                    cold_start = false))]
pub fn min_voltage<'py>(
    py: Python<'py>,
    params: PyRef<'py, Params>,
    bandwidth_hz: f64,
    backlash_deg: f64,
    hold: &str,
    max_time_s: f64,
    cold_start: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let (p, name) = with_backlash(&params, Some(backlash_deg))?;
    // The amplitude is what is sought; 10 V only passes the check, as on the command line.
    let opts = options(10.0, hold, max_time_s, cold_start)?;
    let (_, json) = detached(py, || fr_report::min_voltage(&p, &name, bandwidth_hz, opts))?;
    py_json(py, &json)
}
