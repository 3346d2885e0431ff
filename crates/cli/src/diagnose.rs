//! `geared-servo diagnose`: calibrate, trace the residual, report.

use crate::args::{Cli, DiagnoseArgs};
use crate::common::{load_params, read_record, Report};
use crate::progress::spinner;
use geared_servo_host::calibrate::Data;
use geared_servo_host::diagnose::{diagnose_with, options_by_name};
use geared_servo_host::diagnose_report::insert;
use geared_servo_host::HostError;
use serde_json::json;

/// `geared-servo diagnose`.
pub fn run(cli: &Cli, a: &DiagnoseArgs) -> Result<Report, HostError> {
    use geared_servo_host::{diagnose_plots, params_file, record};
    let (p, name) = load_params(cli, None)?;
    // The options before the records: a misspelt effect is reported before a long record is
    // read.
    let opts = options_by_name(
        &p,
        a.max_steps,
        a.candidates.as_deref(),
        a.limits.as_deref(),
        a.fit.as_deref(),
        "--",
    )?;
    let mut data = Vec::new();
    for path in &a.data {
        let rec = read_record(&p, path, true)?;
        data.push(Data::from_record(&rec, &path.display().to_string())?);
    }
    let val = match &a.validate {
        Some(path) => {
            let rec = record::read(path, true)?;
            Some(Data::from_record(&rec, &path.display().to_string())?)
        }
        None => None,
    };
    // Minutes on long records: the phase it is in, on a terminal.
    let bar = spinner("diagnose");
    let out = diagnose_with(&p, &data, val.as_ref(), &opts, &bar);
    bar.finish();
    let out = out?;
    let first = data.first().ok_or_else(|| HostError::input("no record"))?;
    let mut json = out.to_json(first);
    insert(&mut json, "params", json!(name));
    let mut text = format!(
        "diagnose {} with {name}\n",
        a.data
            .iter()
            .map(|d| d.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    text.push_str(&out.summary());
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir)
            .map_err(|e| HostError::other(format!("{}: cannot create: {e}", dir.display())))?;
        let toml_path = dir.join("calibrated.toml");
        let data_names: Vec<String> = a.data.iter().map(|d| d.display().to_string()).collect();
        let header = out.calibrated_header(&name, &data_names);
        let fp = out.calibrated(&p);
        std::fs::write(&toml_path, params_file::to_toml(&fp, &header)?)
            .map_err(|e| HostError::other(format!("{}: {e}", toml_path.display())))?;
        diagnose_plots::time_series(
            &dir.join("time.svg"),
            first,
            &out.nominal,
            &out.final_fit.params,
        )?;
        diagnose_plots::residual_spectra(
            &dir.join("residual_spectra.svg"),
            first,
            &out.nominal,
            &out.final_fit.params,
        )?;
        std::fs::write(dir.join("diagnose.json"), format!("{json:#}"))
            .map_err(|e| HostError::other(format!("{}: {e}", dir.display())))?;
        text.push_str(&format!(
            "wrote {}/calibrated.toml, time.svg, residual_spectra.svg, diagnose.json\n",
            dir.display()
        ));
    }
    Ok(Report { json, text })
}
