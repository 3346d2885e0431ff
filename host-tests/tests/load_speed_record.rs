//! Records from output-shaft encoders: `load_speed_rad_s` is a measured output (INTERFACES.md
//! "Measured data"). A record carrying only it is read without warnings, fitted on it with the
//! model's own load speed as the prediction, and `diagnose` runs on it and names it.

use geared_servo::REFERENCE;
use geared_servo_host::calibrate::{nrmse, Data};
use geared_servo_host::record;
use geared_servo_host_tests::cli::cli;
use geared_servo_host_tests::records::square;
use std::path::{Path, PathBuf};

/// A fresh scratch directory for test `name`.
fn scratch(name: &str) -> PathBuf {
    geared_servo_host_tests::cli::scratch("load-speed", name)
}

/// `simulate` run on a 0.5 s, ±10 V square wave at 2 kHz (`params`: a parameter file, or the
/// bundled reference), then cut down to `time_s, motor_voltage_v, load_speed_rad_s`: what a
/// rig with only an output-shaft encoder logs. Returns its path.
fn load_speed_record(dir: &Path, params: Option<&Path>) -> PathBuf {
    let h = 0.0005;
    let volts = square(10.0, 0.1, 1000, h);
    let time: Vec<f64> = (0..volts.len()).map(|k| k as f64 * h).collect();
    let input = dir.join("in.csv");
    record::write(
        &input,
        &[],
        &[("time_s", &time), ("motor_voltage_v", &volts)],
    )
    .unwrap();
    let sim = dir.join("sim.csv");
    let mut args = vec![
        "simulate",
        "--input",
        input.to_str().unwrap(),
        "--output",
        sim.to_str().unwrap(),
    ];
    if let Some(p) = params {
        args.extend(["--params", p.to_str().unwrap()]);
    }
    cli(&args).unwrap();
    // simulate's output is itself a measured record now: load speed is among its outputs.
    let full = record::read(&sim, true).unwrap();
    assert!(
        full.warnings
            .iter()
            .all(|w| !w.contains("load_speed_rad_s")),
        "{:?}",
        full.warnings
    );
    let speed = full.output("load_speed_rad_s").unwrap().to_vec();
    let meas = dir.join("meas.csv");
    record::write(
        &meas,
        &["rig: output-shaft encoder only".to_string()],
        &[
            ("time_s", &full.time_s),
            ("motor_voltage_v", &full.motor_voltage_v),
            ("load_speed_rad_s", &speed),
        ],
    )
    .unwrap();
    meas
}

#[test]
fn a_record_with_only_load_speed_is_read_and_fitted_on_the_models_load_speed() {
    let dir = scratch("read");
    let meas = load_speed_record(&dir, None);
    let rec = record::read(&meas, true).unwrap();
    assert!(rec.warnings.is_empty(), "{:?}", rec.warnings);
    assert_eq!(rec.outputs.len(), 1);
    let data = Data::from_record(&rec, "meas.csv").unwrap();
    assert_eq!(data.output, "load_speed_rad_s");
    // The record is the reference plant's own load speed, so the model that made it predicts
    // it: the CSV text round-trips f32 values exactly, and what remains comes from the sample
    // period recomputed from times written as f32 (about 1e-8 relative; 1.8e-8 NRMSE seen).
    let e = nrmse(&REFERENCE, &data);
    assert!(e < 1e-6, "NRMSE {e}");
    // A wrong model does not: the prediction is the load speed, not a constant.
    let mut heavy = REFERENCE;
    heavy.load.inertia_kg_m2 *= 1.5;
    assert!(nrmse(&heavy, &data) > 100.0 * e.max(1e-6));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn diagnose_runs_on_a_load_speed_record_and_names_the_output() {
    let dir = scratch("diagnose");
    // Data from a plant whose load inertia is 20 % off the reference the fit starts from.
    let toml = geared_servo_host::params_file::REFERENCE_TOML.replacen(
        "inertia_kg_m2 = 1.0e-3 ",
        "inertia_kg_m2 = 1.2e-3 ",
        1,
    );
    let params = dir.join("rig.toml");
    std::fs::write(&params, toml).unwrap();
    let meas = load_speed_record(&dir, Some(&params));
    let r = cli(&[
        "--json",
        "diagnose",
        "--data",
        meas.to_str().unwrap(),
        "--max-steps",
        "0",
    ])
    .unwrap();
    let j = &r.json;
    assert_eq!(j["output"], "load_speed_rad_s");
    assert_eq!(j["samples"], 1000);
    let (before, after) = (
        j["nominal"]["nrmse"].as_f64().unwrap(),
        j["final"]["nrmse"].as_f64().unwrap(),
    );
    // The fit moves the error well down (0.12 -> 2e-6 seen); no claim on the parameters.
    assert!(
        after.is_finite() && after < 0.5 * before,
        "{before} -> {after}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
