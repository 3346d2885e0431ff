//! The frequency-response commands of the CLI: `bode`, `resonances`, `max-backlash`,
//! `min-voltage` (and the arguments `paper` shares with them).

use crate::args::{Cli, MeasureArgs};
use crate::common::{load_params, Report};
use crate::progress::progress;
use geared_servo::describing;
use geared_servo_host::design;
use geared_servo_host::error::HostError;
use geared_servo_host::fr::spread_db;
use geared_servo_host::fr::{self, Bench, LocateOptions, Located};
use geared_servo_host::no_answer::{add_reason, Answer};
use geared_servo_host::record::write_file;
use serde_json::{json, Value};
use std::path::PathBuf;

/// `bode`: stepped-sine response of `V_t/V_m` on a frequency grid.
#[allow(clippy::too_many_arguments)]
pub fn bode(
    cli: &Cli,
    vpk: f64,
    backlash: Option<f64>,
    from: f64,
    to: f64,
    step: f64,
    csv_out: Option<&PathBuf>,
    m: &MeasureArgs,
) -> Result<Report, HostError> {
    let (p, name) = load_params(cli, backlash)?;
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
    let freqs = fr::grid(from, to, step)?;
    let bench = Bench::new(&p, m.options(vpk)?)?;
    let pb = progress(freqs.len() as u64, "bode");
    let pts = bench.sweep(&freqs, &pb)?;
    pb.finish();
    let notch: Answer<()> = match fr::unresolved_notch(&bench, &pts)? {
        Some(na) => Err(na),
        None => Ok(()),
    };
    if let Some(path) = csv_out {
        let mut s = String::from("freq_hz,gain_db,phase_deg,gain_spread_db,settled\n");
        for q in &pts {
            s.push_str(&format!(
                "{},{:.6},{:.4},{:.6},{}\n",
                q.freq_hz,
                q.tach.gain_db(),
                q.tach.phase_deg(),
                spread_db(q.tach.spread, q.gain()),
                u8::from(q.settled)
            ));
        }
        write_file(path, &s)?;
    }
    let rows: Vec<Value> = pts
        .iter()
        .map(|q| {
            json!({"freq_hz": q.freq_hz, "gain_db": q.tach.gain_db(),
                   "phase_deg": q.tach.phase_deg(), "settled": q.settled})
        })
        .collect();
    let mut json = json!({"params": name, "vpk": vpk, "backlash_deg": p.backlash_deg,
                      "points": rows});
    add_reason(&mut json, "f_ar", &notch);
    let mut text = format!(
        "V_t/V_m of {name} at {vpk} V_pk, backlash {} deg ({} points)\n freq_hz   gain_db  phase_deg\n",
        p.backlash_deg,
        pts.len()
    );
    if csv_out.is_none() {
        for q in &pts {
            text.push_str(&format!(
                "{:8.3} {:9.3} {:10.2}\n",
                q.freq_hz,
                q.tach.gain_db(),
                q.tach.phase_deg()
            ));
        }
    } else if let Some(path) = csv_out {
        text.push_str(&format!("wrote {}\n", path.display()));
    }
    if let Err(na) = &notch {
        text.push_str(&format!("notice: {}\n", na.reason));
    }
    Ok(Report {
        json,
        text: text.trim_end().to_string(),
    })
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
fn found(a: Option<&Answer<Located>>) -> Option<&Located> {
    a.and_then(|a| a.as_ref().ok())
}

/// `resonances`: f_AR and f_R located on the simulated response, with the DF prediction.
pub fn resonances(
    cli: &Cli,
    vpk: f64,
    backlash: Option<f64>,
    m: &MeasureArgs,
) -> Result<Report, HostError> {
    let (p, name) = load_params(cli, backlash)?;
    let bench = Bench::new(&p, m.options(vpk)?)?;
    let lo = LocateOptions::default();
    let pb = progress(
        fr::grid(lo.from_hz, lo.to_hz, lo.step_hz)?.len() as u64,
        "grid",
    );
    let (r, _) = fr::locate(&bench, &lo, &pb)?;
    pb.finish();
    let d = p.derived().map_err(HostError::from)?;
    let df = describing::predict(&p, vpk).map_err(HostError::from)?;
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
    let fmt = |l: Option<&Answer<Located>>| match l {
        Some(Ok(l)) => format!(
            "{:9.3} Hz  (band {:.3}..{:.3} Hz{})",
            l.freq_hz,
            l.band_hz.0,
            l.band_hz.1,
            if l.settled { "" } else { ", not settled" },
        ),
        Some(Err(na)) => format!("none: {}", na.reason),
        None => "not searched".to_string(),
    };
    let text = format!(
        "{name} at {vpk} V_pk, backlash {} deg\n\
         anti-resonance f_AR  {}\n\
         resonance f_R        {}\n\
         gain peak            {}\n\
         closed form          f_AR {:.3} Hz, f_R {:.3} Hz (no backlash, eqs. 17a/b)\n\
         describing function  f_AR {:.3} Hz (N = {:.4}), f_R {:.3} Hz (N = {:.4})\n\
         {} points simulated",
        p.backlash_deg,
        fmt(Some(&r.anti_resonance)),
        match fmt(r.resonance.as_ref()) {
            // What f_R is, beside a value (a reason is sentence enough).
            f if res.is_some() => f + "   (minimum of |I/V_m|: the pole of wm/T_m)",
            f => f,
        },
        fmt(r.gain_peak.as_ref()),
        d.f_ar_hz,
        d.f_r_hz,
        df.anti_resonance.freq_hz,
        df.anti_resonance.df_gain,
        df.resonance.freq_hz,
        df.resonance.df_gain,
        r.evaluations
    );
    Ok(Report { json, text })
}

/// `max-backlash`.
pub fn max_backlash(
    cli: &Cli,
    bandwidth: f64,
    vpk: f64,
    m: &MeasureArgs,
) -> Result<Report, HostError> {
    let (p, name) = load_params(cli, None)?;
    let opts = m.options(vpk)?;
    check_bandwidth(bandwidth)?;
    let d = design::max_backlash(&p, bandwidth, opts, 0.001)?;
    let mut json = json!({"params": name, "bandwidth_hz": bandwidth, "vpk": vpk,
        "max_backlash_deg": d.value.as_ref().ok(), "tolerance_deg": 0.001,
        "trace": trace_json(&d, "backlash_deg")});
    add_reason(&mut json, "max_backlash", &d.value);
    let text = match &d.value {
        Ok(b) => format!(
            "{name}: largest total backlash with simulated f_AR >= {bandwidth} Hz at {vpk} V_pk: \
             {b:.3} deg (bisection to 0.001 deg, {} evaluations)",
            d.trace.len()
        ),
        Err(na) => format!(
            "{name}: no largest total backlash with simulated f_AR >= {bandwidth} Hz at {vpk} V_pk: \
             {} (evaluations: {})",
            na.reason,
            d.trace.len()
        ),
    };
    Ok(Report { json, text })
}

/// `min-voltage`.
pub fn min_voltage(
    cli: &Cli,
    bandwidth: f64,
    backlash: f64,
    m: &MeasureArgs,
) -> Result<Report, HostError> {
    let (p, name) = load_params(cli, Some(backlash))?;
    let opts = m.options(10.0)?;
    check_bandwidth(bandwidth)?;
    let d = design::min_voltage(&p, bandwidth, opts, 0.05)?;
    let mut json = json!({"params": name, "bandwidth_hz": bandwidth, "backlash_deg": backlash,
        "min_vpk": d.value.as_ref().ok(), "tolerance_v": 0.05,
        "trace": trace_json(&d, "vpk")});
    add_reason(&mut json, "min_vpk", &d.value);
    let text = match &d.value {
        Ok(v) => format!(
            "{name}: smallest voltage amplitude with simulated f_AR >= {bandwidth} Hz at \
             {backlash} deg: {v:.2} V_pk (bisection to 0.05 V, {} evaluations)",
            d.trace.len()
        ),
        Err(na) => format!(
            "{name}: no smallest voltage amplitude with simulated f_AR >= {bandwidth} Hz at \
             {backlash} deg: {} (evaluations: {})",
            na.reason,
            d.trace.len()
        ),
    };
    Ok(Report { json, text })
}

/// The evaluations of a design query: the argument under `arg`, f_AR (null where none).
fn trace_json(d: &design::Design, arg: &str) -> Vec<Value> {
    d.trace
        .iter()
        .map(|(x, f)| json!({arg: x, "f_ar_hz": f.as_ref().ok()}))
        .collect()
}

/// `--bandwidth-hz` is a positive frequency.
fn check_bandwidth(f: f64) -> Result<(), HostError> {
    if f.is_finite() && f > 0.0 {
        Ok(())
    } else {
        Err(HostError::input(format!(
            "--bandwidth-hz must be a positive frequency, got {f}"
        )))
    }
}
