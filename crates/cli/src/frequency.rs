//! The frequency-response commands of the CLI: `bode`, `resonances`, `max-backlash`,
//! `min-voltage` (and the arguments `paper` shares with them).

use crate::progress::progress;
use crate::{load_params, Cli, Report};
use clap::{Args, ValueEnum};
use geared_servo::analyser::Hold;
use geared_servo::describing;
use geared_servo_host::error::HostError;
use geared_servo_host::fr::spread_db;
use geared_servo_host::fr::{self, Bench, LocateOptions, Located, SweepOptions};
use geared_servo_host::record::write_file;
use serde_json::{json, Value};
use std::path::PathBuf;

/// How the sine reaches the winding (`--hold`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Default)]
pub enum HoldArg {
    /// Continuous sine within each step, output sampled every step (the paper's Simulink).
    #[default]
    Continuous,
    /// Sine sampled and held for each step (what firmware applies); its notch sits ~1 Hz
    /// higher for the reference actuator (the held system's aliasing).
    Zoh,
}

/// Measurement options shared by the frequency-response commands.
#[derive(Args, Debug, Clone)]
pub struct MeasureArgs {
    /// Sine input: continuous (paper) or zero-order hold (firmware).
    #[arg(long, value_enum, default_value_t = HoldArg::Continuous)]
    pub hold: HoldArg,
    /// Longest simulated time per frequency when the response does not settle, s.
    #[arg(long, default_value_t = 1.0, value_name = "S")]
    pub max_time_s: f64,
    /// Start every frequency from rest instead of the linearised steady state (slower to
    /// settle; with backlash it may land on another branch of the response).
    #[arg(long)]
    pub cold_start: bool,
}

impl MeasureArgs {
    /// The sweep options for amplitude `vpk` (V).
    pub fn options(&self, vpk: f64) -> Result<SweepOptions, HostError> {
        if !(vpk.is_finite() && vpk > 0.0) {
            return Err(HostError::input(format!(
                "--vpk must be a positive number of volts, got {vpk}"
            )));
        }
        if !(self.max_time_s.is_finite() && self.max_time_s > 0.0) {
            return Err(HostError::input(format!(
                "--max-time-s must be positive, got {}",
                self.max_time_s
            )));
        }
        Ok(SweepOptions {
            vpk,
            hold: match self.hold {
                HoldArg::Continuous => Hold::Continuous,
                HoldArg::Zoh => Hold::Zoh,
            },
            settings: geared_servo::analyser::SweepSettings {
                max_time_s: self.max_time_s,
                ..geared_servo::analyser::SweepSettings::DEFAULT
            },
            warm_start: !self.cold_start,
        })
    }
}

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
    let freqs = fr::grid(from, to, step)?;
    let bench = Bench::new(&p, m.options(vpk)?)?;
    let pb = progress(freqs.len() as u64, "bode");
    let pts = bench.sweep(&freqs, &pb)?;
    pb.finish();
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
    let json = json!({"params": name, "vpk": vpk, "backlash_deg": p.backlash_deg,
                      "points": rows});
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
    Ok(Report {
        json,
        text: text.trim_end().to_string(),
    })
}

fn located_json(l: &Option<Located>) -> Value {
    match l {
        Some(l) => json!({"freq_hz": l.freq_hz, "band_hz": [l.band_hz.0, l.band_hz.1],
                          "settled": l.settled, "at_grid_edge": l.at_edge}),
        None => Value::Null,
    }
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
    let d = p
        .derived()
        .map_err(|e| HostError::input(format!("key `{}` {}", e.field(), e.reason())))?;
    let df = describing::predict(&p, vpk)
        .map_err(|e| HostError::input(format!("key `{}` {}", e.field(), e.reason())))?;
    let ar = r.anti_resonance;
    let json = json!({
        "params": name, "vpk": vpk, "backlash_deg": p.backlash_deg,
        "f_ar_hz": ar.freq_hz, "f_r_hz": r.resonance.map(|x| x.freq_hz),
        "f_gain_peak_hz": r.gain_peak.map(|x| x.freq_hz),
        "anti_resonance": located_json(&Some(ar)),
        "resonance": located_json(&r.resonance),
        "gain_peak": located_json(&r.gain_peak),
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
    let fmt = |l: &Option<Located>| match l {
        Some(l) => format!(
            "{:9.3} Hz  (band {:.3}..{:.3} Hz{}{})",
            l.freq_hz,
            l.band_hz.0,
            l.band_hz.1,
            if l.settled { "" } else { ", not settled" },
            if l.at_edge {
                ", AT THE GRID EDGE: no feature in range"
            } else {
                ""
            }
        ),
        None => "not found".to_string(),
    };
    let text = format!(
        "{name} at {vpk} V_pk, backlash {} deg\n\
         anti-resonance f_AR  {}\n\
         resonance f_R        {}   (minimum of |I/V_m|: the pole of wm/T_m)\n\
         gain peak            {}\n\
         closed form          f_AR {:.3} Hz, f_R {:.3} Hz (no backlash, eqs. 17a/b)\n\
         describing function  f_AR {:.3} Hz (N = {:.4}), f_R {:.3} Hz (N = {:.4})\n\
         {} points simulated",
        p.backlash_deg,
        fmt(&Some(ar)),
        fmt(&r.resonance),
        fmt(&r.gain_peak),
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
    let d = fr::max_backlash(&p, bandwidth, m.options(vpk)?, 0.001)?;
    let json = json!({"params": name, "bandwidth_hz": bandwidth, "vpk": vpk,
        "max_backlash_deg": d.value, "tolerance_deg": 0.001,
        "trace": d.trace.iter().map(|(b, f)| json!({"backlash_deg": b, "f_ar_hz": f})).collect::<Vec<_>>()});
    let text = format!(
        "{name}: largest total backlash with simulated f_AR >= {bandwidth} Hz at {vpk} V_pk: \
         {:.3} deg (bisection to 0.001 deg, {} evaluations)",
        d.value,
        d.trace.len()
    );
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
    let d = fr::min_voltage(&p, bandwidth, m.options(10.0)?, 0.05)?;
    let json = json!({"params": name, "bandwidth_hz": bandwidth, "backlash_deg": backlash,
        "min_vpk": d.value, "tolerance_v": 0.05,
        "trace": d.trace.iter().map(|(v, f)| json!({"vpk": v, "f_ar_hz": f})).collect::<Vec<_>>()});
    let text = format!(
        "{name}: smallest voltage amplitude with simulated f_AR >= {bandwidth} Hz at \
         {backlash} deg: {:.2} V_pk (bisection to 0.05 V, {} evaluations)",
        d.value,
        d.trace.len()
    );
    Ok(Report { json, text })
}
