//! The frequency-response commands of the CLI: `bode`, `resonances`, `max-backlash`,
//! `min-voltage` (and the arguments `paper` shares with them).

use crate::args::{Cli, MeasureArgs};
use crate::common::{load_params, Report};
use crate::progress::progress;
use geared_servo::describing;
use geared_servo_host::error::HostError;
use geared_servo_host::fr::{self, LocateOptions, Located};
use geared_servo_host::fr_report;
use geared_servo_host::no_answer::Answer;
use geared_servo_host::record::write_file;
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
    let freqs = fr_report::bode_grid(from, to, step)?;
    let opts = m.options(vpk)?;
    let pb = progress(freqs.len() as u64, "bode");
    let b = fr_report::bode(&p, &name, opts, &freqs, &pb)?;
    pb.finish();
    if let Some(path) = csv_out {
        write_file(path, &fr_report::bode_csv(&b.points))?;
    }
    let pts = &b.points;
    let mut text = format!(
        "V_t/V_m of {name} at {vpk} V_pk, backlash {} deg ({} points)\n freq_hz   gain_db  phase_deg\n",
        p.backlash_deg,
        pts.len()
    );
    if csv_out.is_none() {
        for q in pts {
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
    if let Err(na) = &b.notch {
        text.push_str(&format!("notice: {}\n", na.reason));
    }
    Ok(Report {
        json: b.json,
        text: text.trim_end().to_string(),
    })
}

/// `resonances`: f_AR and f_R located on the simulated response, with the DF prediction.
pub fn resonances(
    cli: &Cli,
    vpk: f64,
    backlash: Option<f64>,
    m: &MeasureArgs,
) -> Result<Report, HostError> {
    let (p, name) = load_params(cli, backlash)?;
    let opts = m.options(vpk)?;
    let lo = LocateOptions::default();
    let pb = progress(
        fr::grid(lo.from_hz, lo.to_hz, lo.step_hz)?.len() as u64,
        "grid",
    );
    let (r, json) = fr_report::resonances(&p, &name, opts, &pb)?;
    pb.finish();
    let d = p.derived().map_err(HostError::from)?;
    let df = describing::predict(&p, vpk).map_err(HostError::from)?;
    let res = fr_report::found(r.resonance.as_ref());
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
    let (d, json) = fr_report::max_backlash(&p, &name, bandwidth, opts)?;
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
    let (d, json) = fr_report::min_voltage(&p, &name, bandwidth, opts)?;
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
