//! Writes one case of the foreign diagnosis suite (`host-tests/src/foreign.rs`) to a
//! directory: the estimation and validation records as CSV (INTERFACES.md "Measured data"),
//! the parameter file given to `diagnose` (`file.toml`) and the true unit in the model's form
//! (`truth.toml`, without the second mode, which the schema cannot hold), plus `case.txt`
//! saying what is hidden.
//!
//! ```text
//! cargo run --release -p geared-servo-host-tests --example foreign_records -- DIR \
//!     [--kind clean|motor_viscous|...|pair|second_mode] [--draw N] [--seconds S] [--angle-only | --current-only | --with-current]
//! ```
//! `--seconds` sets the length of the estimation record (the stepped sine gets as many
//! 0.3 s bursts with 0.1 s rests as fit, 10–300 Hz; default 8.8 s): 20 gives the benchmark
//! record "diagnose on 20 s of 2 kHz data with all candidates". `--angle-only`: the records
//! carry the load angle alone (an output encoder or potentiometer, no tachometer);
//! `--current-only`: the armature current alone (a current sense resistor); `--with-current`:
//! the bench's outputs and the armature current too. Then, e.g.:
//! `geared-servo diagnose --params DIR/file.toml --data DIR/estimation.csv --validate DIR/validation.csv`.

use geared_servo_host::params_file;
use geared_servo_host::record::{self, Record};
use geared_servo_host_tests::foreign::{self, Kind, Making, Sensors, SteppedSine};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

fn write_record(path: &Path, rec: &Record) -> Result<(), String> {
    let mut comments: Vec<String> = rec
        .metadata
        .iter()
        .map(|(k, v)| format!("{k}: {v}"))
        .collect();
    comments.push("row k: outputs sampled at time_s, then motor_voltage_v applied".into());
    let mut cols: Vec<(&str, &[f64])> = vec![
        ("time_s", &rec.time_s),
        ("motor_voltage_v", &rec.motor_voltage_v),
    ];
    for (n, v) in &rec.outputs {
        cols.push((n.as_str(), v));
    }
    record::write(path, &comments, &cols).map_err(|e| e.to_string())
}

fn run() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let mut dir: Option<PathBuf> = None;
    let mut kind = Kind::Clean;
    let mut draw = 0u64;
    let mut seconds: Option<f64> = None;
    let mut sensors = Sensors::Bench;
    let usage = "usage: foreign_records DIR [--kind NAME] [--draw N] [--seconds S] [--angle-only | --current-only | --with-current]";
    while let Some(a) = args.next() {
        let mut value = |what: &str| {
            args.next()
                .ok_or_else(|| format!("{what} needs a value; {usage}"))
        };
        match a.as_str() {
            "--kind" => {
                let v = value("--kind")?;
                kind = Kind::from_name(&v).ok_or_else(|| {
                    let names: Vec<String> = Kind::all().iter().map(Kind::name).collect();
                    format!("unknown kind `{v}` (known: {})", names.join(", "))
                })?;
            }
            "--draw" => {
                draw = value("--draw")?
                    .parse()
                    .map_err(|e| format!("--draw: {e}"))?
            }
            "--seconds" => {
                let s: f64 = value("--seconds")?
                    .parse()
                    .map_err(|e| format!("--seconds: {e}"))?;
                if !(s.is_finite() && s > 0.0) {
                    return Err("--seconds must be positive".into());
                }
                seconds = Some(s);
            }
            "--angle-only" => sensors = Sensors::AngleOnly,
            "--current-only" => sensors = Sensors::CurrentOnly,
            "--with-current" => sensors = Sensors::WithCurrent,
            "-h" | "--help" => {
                println!("{usage}");
                return Ok(());
            }
            _ if dir.is_none() && !a.starts_with('-') => dir = Some(PathBuf::from(a)),
            _ => return Err(format!("unexpected argument `{a}`; {usage}")),
        }
    }
    let dir = dir.ok_or(usage)?;
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let making = Making {
        stepped_sine: seconds.map_or_else(SteppedSine::default, SteppedSine::lasting),
        sensors,
        ..Making::default()
    };
    let t = std::time::Instant::now();
    let c = foreign::case_with(kind, draw, &making).map_err(|e| e.to_string())?;
    let made = t.elapsed().as_secs_f64();
    write_record(&dir.join("estimation.csv"), &c.estimation_record)?;
    write_record(&dir.join("validation.csv"), &c.validation_record)?;
    let header = |what: &str| {
        vec![format!(
            "{what} of foreign case {} (host-tests/src/foreign.rs)",
            c.label()
        )]
    };
    let file = params_file::to_toml(&c.file, &header("parameter file given to diagnose"))
        .map_err(|e| e.to_string())?;
    record::write_file(&dir.join("file.toml"), &file).map_err(|e| e.to_string())?;
    let truth = params_file::to_toml(&c.truth, &header("true unit, model form"))
        .map_err(|e| e.to_string())?;
    record::write_file(&dir.join("truth.toml"), &truth).map_err(|e| e.to_string())?;
    let mut about = format!(
        "case {}\nresistance scale s = R_true / R_file = {:.4}\n",
        c.label(),
        c.resistance_scale
    );
    for (e, v) in &c.expected {
        about.push_str(&format!(
            "hidden {e} = {v:.4e} {} (a fit with the file's R should find {:.4e})\n",
            e.unit(),
            c.expected_fitted(*e, *v)
        ));
    }
    if let Some(m) = c.second_mode {
        about.push_str(&format!(
            "second mode (not in truth.toml): J2 {:.4e} kg*m^2, k2 {:.4e} N*m/rad, c2 {:.4e} N*m*s/rad ({:.1} Hz, zeta {:.3}); truth.toml's load inertia is the total\n",
            m.inertia_kg_m2, m.stiffness_nm_per_rad, m.damping_nm_s_per_rad, m.frequency_hz, m.damping_ratio
        ));
    }
    about.push_str(&format!(
        "estimation: {:.1} s, noise floor NRMSE {:.4}, true-parameter NRMSE {:.4}\nvalidation: {:.1} s, noise floor NRMSE {:.4}, true-parameter NRMSE {:.4}\n",
        c.estimation.y.len() as f64 * foreign::SAMPLE_PERIOD_S,
        c.estimation_floor,
        c.true_nrmse_estimation,
        c.validation.y.len() as f64 * foreign::SAMPLE_PERIOD_S,
        c.validation_floor,
        c.true_nrmse_validation
    ));
    record::write_file(&dir.join("case.txt"), &about).map_err(|e| e.to_string())?;
    print!("{about}");
    println!("made in {made:.1} s; wrote {}", dir.display());
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("foreign_records: {e}");
            ExitCode::FAILURE
        }
    }
}
