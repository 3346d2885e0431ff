//! The frequency-response and design commands as values: `bode`, `resonances`,
//! `max-backlash` and `min-voltage`, each run on a parameter set and returned with the JSON
//! object of INTERFACES.md, plus the checks of their arguments with the command line's
//! messages. The command line renders these and the Python package returns them, so both
//! front ends say the same thing.

use crate::design::{self, Design};
use crate::error::HostError;
use crate::fr::{self, spread_db, Bench, LocateOptions, Located, Point, Resonances, SweepOptions};
use crate::no_answer::{add_reason, Answer};
use crate::progress::Progress;
use geared_servo::analyser::{Hold, SweepSettings};
use geared_servo::{describing, ActuatorParams};
use serde_json::{json, Value};

/// Tolerance of `max-backlash`'s bisection, degrees.
pub const MAX_BACKLASH_TOL_DEG: f64 = 0.001;
/// Tolerance of `min-voltage`'s bisection, V.
pub const MIN_VOLTAGE_TOL_V: f64 = 0.05;

/// The sweep options of `--vpk V`, `--hold`, `--max-time-s S` and `--cold-start`, checked.
pub fn sweep_options(
    vpk: f64,
    hold: Hold,
    max_time_s: f64,
    cold_start: bool,
) -> Result<SweepOptions, HostError> {
    if !(vpk.is_finite() && vpk > 0.0) {
        return Err(HostError::input(format!(
            "--vpk must be a positive number of volts, got {vpk}"
        )));
    }
    if !(max_time_s.is_finite() && max_time_s > 0.0) {
        return Err(HostError::input(format!(
            "--max-time-s must be positive, got {max_time_s}"
        )));
    }
    Ok(SweepOptions {
        vpk,
        hold,
        settings: SweepSettings {
            max_time_s,
            ..SweepSettings::DEFAULT
        },
        warm_start: !cold_start,
    })
}

/// `--bandwidth-hz` is a positive frequency.
pub fn check_bandwidth(f: f64) -> Result<(), HostError> {
    if f.is_finite() && f > 0.0 {
        Ok(())
    } else {
        Err(HostError::input(format!(
            "--bandwidth-hz must be a positive frequency, got {f}"
        )))
    }
}

/// The frequency grid of `bode --from --to --step`, Hz, checked.
pub fn bode_grid(from: f64, to: f64, step: f64) -> Result<Vec<f64>, HostError> {
    if !(from.is_finite() && to.is_finite() && step.is_finite() && from > 0.0 && to >= from) {
        return Err(HostError::input(format!(
            "frequency range must satisfy 0 < --from <= --to, got {from}..{to}"
        )));
    }
    if step <= 0.0 || (to - from) / step > 1.0e6 {
        return Err(HostError::input(format!(
            "--step must be positive and give at most a million points, got {step}"
        )));
    }
    fr::grid(from, to, step)
}

/// A stepped-sine frequency response (`bode`).
pub struct Bode {
    /// One point per grid frequency.
    pub points: Vec<Point>,
    /// No answer when the model rules the notch out, or puts it in range and the grid does
    /// not resolve it.
    pub notch: Answer<()>,
    /// `bode --json`.
    pub json: Value,
}

/// `bode`: the response of `V_t/V_m` of `p` (named `name` in the JSON) on `freqs`.
pub fn bode(
    p: &ActuatorParams,
    name: &str,
    opts: SweepOptions,
    freqs: &[f64],
    progress: &dyn Progress,
) -> Result<Bode, HostError> {
    let bench = Bench::new(p, opts)?;
    let points = bench.sweep(freqs, progress)?;
    let notch: Answer<()> = match fr::unresolved_notch(&bench, &points)? {
        Some(na) => Err(na),
        None => Ok(()),
    };
    let rows: Vec<Value> = points
        .iter()
        .map(|q| {
            json!({"freq_hz": q.freq_hz, "gain_db": q.tach.gain_db(),
                   "phase_deg": q.tach.phase_deg(), "settled": q.settled})
        })
        .collect();
    let mut json = json!({"params": name, "vpk": opts.vpk, "backlash_deg": p.backlash_deg,
                      "points": rows});
    add_reason(&mut json, "f_ar", &notch);
    Ok(Bode {
        points,
        notch,
        json,
    })
}

/// The CSV of `bode --csv`: `freq_hz,gain_db,phase_deg,gain_spread_db,settled`.
pub fn bode_csv(points: &[Point]) -> String {
    let mut s = String::from("freq_hz,gain_db,phase_deg,gain_spread_db,settled\n");
    for q in points {
        s.push_str(&format!(
            "{},{:.6},{:.4},{:.6},{}\n",
            q.freq_hz,
            q.tach.gain_db(),
            q.tach.phase_deg(),
            spread_db(q.tach.spread, q.gain()),
            u8::from(q.settled)
        ));
    }
    s
}

/// A located feature as JSON; `at_grid_edge` stays for scripts that read it and is always
/// false now (an extremum at the grid's edge is no answer, null).
fn located_json(l: Option<&Located>) -> Value {
    match l {
        Some(l) => json!({"freq_hz": l.freq_hz, "band_hz": [l.band_hz.0, l.band_hz.1],
                          "settled": l.settled, "at_grid_edge": false}),
        None => Value::Null,
    }
}

/// The resolved feature of a search, if any.
pub fn found(a: Option<&Answer<Located>>) -> Option<&Located> {
    a.and_then(|a| a.as_ref().ok())
}

/// `resonances`: f_AR and f_R located on the simulated response of `p` at `opts.vpk`, with
/// the closed form and the describing function's prediction in the JSON.
pub fn resonances(
    p: &ActuatorParams,
    name: &str,
    opts: SweepOptions,
    progress: &dyn Progress,
) -> Result<(Resonances, Value), HostError> {
    let vpk = opts.vpk;
    let bench = Bench::new(p, opts)?;
    let (r, _) = fr::locate(&bench, &LocateOptions::default(), progress)?;
    let d = p.derived().map_err(HostError::from)?;
    let df = describing::predict(p, vpk).map_err(HostError::from)?;
    let (ar, res, peak) = (
        found(Some(&r.anti_resonance)),
        found(r.resonance.as_ref()),
        found(r.gain_peak.as_ref()),
    );
    let mut json = json!({
        "params": name, "vpk": vpk, "backlash_deg": p.backlash_deg,
        "f_ar_hz": ar.map(|x| x.freq_hz), "f_r_hz": res.map(|x| x.freq_hz),
        "f_gain_peak_hz": peak.map(|x| x.freq_hz),
        "anti_resonance": located_json(ar),
        "resonance": located_json(res),
        "gain_peak": located_json(peak),
        "closed_form": {"f_ar_hz": d.f_ar_hz, "f_r_hz": d.f_r_hz},
        "describing_function": {
            "f_ar_hz": df.anti_resonance.freq_hz, "f_r_hz": df.resonance.freq_hz,
            "twist_amplitude_ar_rad": df.anti_resonance.twist_amplitude_rad,
            "n_ar": df.anti_resonance.df_gain,
            "twist_amplitude_r_rad": df.resonance.twist_amplitude_rad,
            "n_r": df.resonance.df_gain,
        },
        "evaluations": r.evaluations,
    });
    add_reason(&mut json, "f_ar", &r.anti_resonance);
    for (stem, a) in [("f_r", &r.resonance), ("f_gain_peak", &r.gain_peak)] {
        if let Some(a) = a {
            add_reason(&mut json, stem, a);
        }
    }
    Ok((r, json))
}

/// The evaluations of a design query: the argument under `arg`, f_AR (null where none).
fn trace_json(d: &Design, arg: &str) -> Vec<Value> {
    d.trace
        .iter()
        .map(|(x, f)| json!({arg: x, "f_ar_hz": f.as_ref().ok()}))
        .collect()
}

/// `max-backlash`: the largest total backlash of `p` whose simulated f_AR at `opts.vpk` is
/// still at least `bandwidth_hz`.
pub fn max_backlash(
    p: &ActuatorParams,
    name: &str,
    bandwidth_hz: f64,
    opts: SweepOptions,
) -> Result<(Design, Value), HostError> {
    check_bandwidth(bandwidth_hz)?;
    let d = design::max_backlash(p, bandwidth_hz, opts, MAX_BACKLASH_TOL_DEG)?;
    let mut json = json!({"params": name, "bandwidth_hz": bandwidth_hz, "vpk": opts.vpk,
        "max_backlash_deg": d.value.as_ref().ok(), "tolerance_deg": MAX_BACKLASH_TOL_DEG,
        "trace": trace_json(&d, "backlash_deg")});
    add_reason(&mut json, "max_backlash", &d.value);
    Ok((d, json))
}

/// `min-voltage`: the smallest voltage amplitude whose simulated f_AR of `p` (its backlash)
/// is at least `bandwidth_hz`; `opts.vpk` is not used.
pub fn min_voltage(
    p: &ActuatorParams,
    name: &str,
    bandwidth_hz: f64,
    opts: SweepOptions,
) -> Result<(Design, Value), HostError> {
    check_bandwidth(bandwidth_hz)?;
    let d = design::min_voltage(p, bandwidth_hz, opts, MIN_VOLTAGE_TOL_V)?;
    let mut json = json!({"params": name, "bandwidth_hz": bandwidth_hz,
        "backlash_deg": p.backlash_deg,
        "min_vpk": d.value.as_ref().ok(), "tolerance_v": MIN_VOLTAGE_TOL_V,
        "trace": trace_json(&d, "vpk")});
    add_reason(&mut json, "min_vpk", &d.value);
    Ok((d, json))
}
