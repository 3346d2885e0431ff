//! `geared-servo init` (docs/datasheet.md): a rig from a gear motor's data sheet. The file it
//! writes reproduces the data sheet's operating points when simulated, and `diagnose`
//! calibrates its guesses against a record of a rig that differs from them.

use geared_servo::{Plant, PlantState};
use geared_servo_cli::Report;
use geared_servo_host::calibrate::{self, Param};
use geared_servo_host::{params_file, record, ErrorKind, HostError};
use geared_servo_host_tests::cli::cli;
use geared_servo_host_tests::records::square;
use std::path::PathBuf;

/// A fresh scratch directory for test `name`.
fn scratch(name: &str) -> PathBuf {
    geared_servo_host_tests::cli::scratch("init", name)
}

/// A 12 V, 100 rpm gear motor (ratio 100, 1.2 N*m and 1.6 A at stall, 0.12 A at no load)
/// with a 2e-4 kg*m² arm, as a user types it.
const SHEET: [&str; 16] = [
    "--supply-v",
    "12",
    "--no-load-rpm",
    "100",
    "--stall-torque-nm",
    "1.2",
    "--stall-current-a",
    "1.6",
    "--no-load-current-a",
    "0.12",
    "--gear-ratio",
    "100",
    "--load-inertia",
    "2e-4",
    "--sample-period",
    "0.001",
];

/// `init` with the figures of [`SHEET`], `changed` (option, value) replacing or adding some.
fn init(out: &std::path::Path, changed: &[(&str, &str)]) -> Result<Report, HostError> {
    let mut args = vec!["--json", "init", "--output", out.to_str().unwrap()];
    for pair in SHEET.chunks(2) {
        if let [opt, value] = pair {
            let v = changed
                .iter()
                .find(|(o, _)| o == opt)
                .map_or(*value, |c| c.1);
            args.extend([*opt, v]);
        }
    }
    for (o, v) in changed {
        if !SHEET.contains(o) {
            args.extend([*o, *v]);
        }
    }
    cli(&args)
}

/// Simulated at the supply voltage with nothing but its own friction, the file's motor runs
/// at the data sheet's no-load speed drawing its no-load current (within 2 %: the guessed
/// load friction, 1 % of the stall torque, is the difference), and held still it draws the
/// stall current.
#[test]
fn the_file_reproduces_the_data_sheets_operating_points() {
    let dir = scratch("points");
    let rig = dir.join("rig.toml");
    let r = init(&rig, &[]).unwrap();
    assert_eq!(r.json["n_total"], 100.0);
    assert!(r.json["guesses"]
        .as_array()
        .unwrap()
        .iter()
        .any(|g| g == "backlash.total_deg"));
    let p = params_file::load(Some(&rig)).unwrap();
    let plant = Plant::new(&p).unwrap();
    let mut st = PlantState::REST;
    let mut o = plant.outputs(&st);
    for _ in 0..3000 {
        o = plant.step(&mut st, 12.0);
    }
    let rpm = f64::from(o.load_speed_rad_s) * 30.0 / std::f64::consts::PI;
    let amps = f64::from(o.mean_current_a);
    eprintln!("no load: {rpm:.2} rpm, {amps:.4} A");
    assert!((rpm - 100.0).abs() <= 2.0, "{rpm}");
    assert!((amps - 0.12).abs() <= 0.02 * 1.6, "{amps}");
    // Stalled: the current the winding lets through at 12 V.
    let stall = 12.0 / p.motor.resistance_ohm;
    assert!((stall - 1.6).abs() < 1e-9);
    let eff = r.json["stall_efficiency"].as_f64().unwrap();
    assert!((eff - 1.2 / (100.0 * p.motor.torque_constant_nm_per_a * 1.6)).abs() < 1e-12);
    std::fs::remove_dir_all(&dir).ok();
}

/// Bad figures are bad input (exit status 2) with one line naming the option.
#[test]
fn bad_figures_are_refused_naming_the_option() {
    let dir = scratch("bad");
    let out = dir.join("x.toml");
    for (changed, start) in [
        (("--supply-v", "-12"), "--supply-v:"),
        (("--gear-ratio", "0"), "--gear-ratio:"),
        (("--no-load-current-a", "2"), "--no-load-current-a:"),
        (("--stall-torque-nm", "40"), "--stall-torque-nm:"),
        (("--motor-inertia", "nan"), "--motor-inertia:"),
    ] {
        let extra = [changed];
        let e = init(&out, &extra).err().expect("refused");
        assert_eq!(e.kind, ErrorKind::BadInput, "{extra:?}");
        assert!(
            e.message.starts_with(start) && !e.message.contains('\n'),
            "{}",
            e.message
        );
    }
    assert!(!out.exists(), "nothing written on bad input");
    std::fs::remove_dir_all(&dir).ok();
}

/// The workflow the file is for: a rig whose gear train is half as stiff, with 0.5° of
/// backlash and an arm 30 % heavier than the guesses, logs its output speed (an encoder on
/// the output shaft) on a square wave; `diagnose` from the init file calibrates the guesses
/// and brings the error well down (no effect search: `--max-steps 0`).
#[test]
fn diagnose_calibrates_the_guesses_of_an_init_file() {
    let dir = scratch("diagnose");
    let rig = dir.join("rig.toml");
    init(&rig, &[]).unwrap();
    let file = params_file::load(Some(&rig)).unwrap();
    let mut truth = calibrate::with_measured_stiffness(&file).unwrap();
    let k = calibrate::get(&truth, Param::StiffnessKeq);
    calibrate::set(&mut truth, Param::StiffnessKeq, 0.5 * k);
    truth.backlash_deg = 0.5;
    truth.load.inertia_kg_m2 *= 1.3;
    let true_file = dir.join("truth.toml");
    std::fs::write(&true_file, params_file::to_toml(&truth, &[]).unwrap()).unwrap();
    let h = truth.sample_period_s;
    let volts = square(8.0, 0.5, 3000, h);
    let time: Vec<f64> = (0..volts.len()).map(|k| k as f64 * h).collect();
    let input = dir.join("in.csv");
    record::write(
        &input,
        &[],
        &[("time_s", &time), ("motor_voltage_v", &volts)],
    )
    .unwrap();
    let sim = dir.join("sim.csv");
    let (i, s, t) = (
        input.to_str().unwrap(),
        sim.to_str().unwrap(),
        true_file.to_str().unwrap(),
    );
    cli(&["--params", t, "simulate", "--input", i, "--output", s]).unwrap();
    let full = record::read(&sim, true).unwrap();
    let speed = full.output("load_speed_rad_s").unwrap().to_vec();
    let meas = dir.join("meas.csv");
    record::write(
        &meas,
        &[],
        &[
            ("time_s", &full.time_s),
            ("motor_voltage_v", &full.motor_voltage_v),
            ("load_speed_rad_s", &speed),
        ],
    )
    .unwrap();
    let r = cli(&[
        "--json",
        "--params",
        rig.to_str().unwrap(),
        "diagnose",
        "--data",
        meas.to_str().unwrap(),
        "--max-steps",
        "0",
    ])
    .unwrap();
    let j = &r.json;
    let (before, after) = (
        j["nominal"]["nrmse"].as_f64().unwrap(),
        j["final"]["nrmse"].as_f64().unwrap(),
    );
    eprintln!("output speed from the init file: NRMSE {before:.4} -> {after:.2e}");
    assert_eq!(j["output"], "load_speed_rad_s");
    // Measured 0.33 -> below 1e-4: the record is noiseless and the model the truth's.
    assert!(before > 0.1 && after < 0.01, "{before} -> {after}");
    std::fs::remove_dir_all(&dir).ok();
}
