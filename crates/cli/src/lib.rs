//! The `geared-servo` command line (INTERFACES.md): argument definitions and the commands.
//!
//! This crate is the binary's library: argument parsing (clap), progress bars and the
//! rendering of each command's result; the work is done by `geared-servo-host`.
//!
//! Each command returns either a JSON value (printed alone on stdout with `--json`) together
//! with a human summary, or a [`HostError`] that the binary maps to exit status 2 or 1.

pub mod diagnose;
pub mod frequency;
pub mod paper;
pub mod progress;
pub mod synth;

use crate::frequency as fr_cli;
use clap::{Parser, Subcommand};
use geared_servo::ActuatorParams;
use geared_servo_host::error::HostError;
use geared_servo_host::simulate::{simulate_with_scenario, SIMULATE_COLUMNS};
use geared_servo_host::{params_file, record, scenario_file};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// Emulator of a DC-motor servo with a two-stage gear reducer and backlash.
#[derive(Parser, Debug)]
#[command(name = "geared-servo", version, about, long_about = None)]
pub struct Cli {
    /// Parameter file (TOML); default: the bundled reference actuator.
    #[arg(long, global = true, value_name = "FILE")]
    pub params: Option<PathBuf>,
    /// Print one JSON object on stdout and nothing else there.
    #[arg(long, global = true)]
    pub json: bool,
    /// The command.
    #[command(subcommand)]
    pub command: Command,
}

/// The commands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Derived quantities of a parameter set (closed form, no backlash).
    Info,
    /// Time-domain run on a voltage record, from rest.
    Simulate {
        /// Input CSV with `time_s` and `motor_voltage_v`.
        #[arg(long, value_name = "IN.csv")]
        input: PathBuf,
        /// Output CSV.
        #[arg(long, value_name = "OUT.csv")]
        output: PathBuf,
        /// Override the total backlash, degrees.
        #[arg(long, value_name = "B")]
        backlash_deg: Option<f64>,
        /// Fault scenario (TOML, see docs/faults.md).
        #[arg(long, value_name = "FAULTS.toml")]
        scenario: Option<PathBuf>,
    },
    /// Stepped-sine frequency response of V_t/V_m, simulated.
    Bode {
        /// Voltage amplitude, V.
        #[arg(long, value_name = "V")]
        vpk: f64,
        /// Override the total backlash, degrees.
        #[arg(long, value_name = "B")]
        backlash_deg: Option<f64>,
        /// First frequency, Hz.
        #[arg(long, default_value_t = 10.0)]
        from: f64,
        /// Last frequency, Hz.
        #[arg(long, default_value_t = 300.0)]
        to: f64,
        /// Frequency step, Hz.
        #[arg(long, default_value_t = 1.0)]
        step: f64,
        /// Write `freq_hz,gain_db,phase_deg` (+ spread, settled) to this CSV file.
        #[arg(long, value_name = "OUT")]
        csv: Option<PathBuf>,
        /// Measurement options.
        #[command(flatten)]
        measure: fr_cli::MeasureArgs,
    },
    /// Anti-resonance and resonance located on the simulated response (refined).
    Resonances {
        /// Voltage amplitude, V.
        #[arg(long, value_name = "V")]
        vpk: f64,
        /// Override the total backlash, degrees.
        #[arg(long, value_name = "B")]
        backlash_deg: Option<f64>,
        /// Measurement options.
        #[command(flatten)]
        measure: fr_cli::MeasureArgs,
    },
    /// Largest total backlash whose simulated f_AR is still >= the bandwidth.
    MaxBacklash {
        /// Required bandwidth (anti-resonance), Hz.
        #[arg(long, value_name = "F")]
        bandwidth_hz: f64,
        /// Voltage amplitude, V.
        #[arg(long, value_name = "V")]
        vpk: f64,
        /// Measurement options.
        #[command(flatten)]
        measure: fr_cli::MeasureArgs,
    },
    /// Smallest voltage amplitude whose simulated f_AR is >= the bandwidth.
    MinVoltage {
        /// Required bandwidth (anti-resonance), Hz.
        #[arg(long, value_name = "F")]
        bandwidth_hz: f64,
        /// Total backlash, degrees.
        #[arg(long, value_name = "B")]
        backlash_deg: f64,
        /// Measurement options.
        #[command(flatten)]
        measure: fr_cli::MeasureArgs,
    },
    /// Regenerates the paper's Fig. 3-6 (CSV + SVG) in DIR and prints the design points.
    Paper {
        /// Output directory (created if missing).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Bandwidth whose contour Fig. 6 draws and the design points use, Hz.
        #[arg(long, default_value_t = 100.0, value_name = "F")]
        bandwidth_hz: f64,
    },
    /// Synthetic measured data: excitation, extra effects, tachometer noise, seed.
    Synth(crate::synth::SynthArgs),
    /// Calibrate, analyse the residual, trace it to a missing effect, report before/after.
    Diagnose(crate::diagnose::DiagnoseArgs),
}

/// What a command produced: the JSON object and the human-readable text.
pub struct Report {
    /// Printed with `--json`.
    pub json: Value,
    /// Printed otherwise.
    pub text: String,
}

/// Loads `--params` and applies a `--backlash-deg` override, validating the result.
pub fn load_params(
    cli: &Cli,
    backlash_deg: Option<f64>,
) -> Result<(ActuatorParams, String), HostError> {
    let name = cli
        .params
        .as_ref()
        .map(|p| p.display().to_string())
        .unwrap_or_else(|| params_file::REFERENCE_NAME.to_string());
    let mut p = params_file::load(cli.params.as_deref())?;
    if let Some(b) = backlash_deg {
        p.backlash_deg = b;
        params_file::validate(&p, "--backlash-deg").map_err(|e| {
            HostError::input(e.message.replace("key `backlash.total_deg`", "value"))
        })?;
    }
    Ok((p, name))
}

/// Runs the parsed command line.
pub fn run(cli: &Cli) -> Result<Report, HostError> {
    match &cli.command {
        Command::Info => info(cli),
        Command::Simulate {
            input,
            output,
            backlash_deg,
            scenario,
        } => simulate(cli, input, output, *backlash_deg, scenario.as_deref()),
        Command::Bode {
            vpk,
            backlash_deg,
            from,
            to,
            step,
            csv,
            measure,
        } => fr_cli::bode(
            cli,
            *vpk,
            *backlash_deg,
            *from,
            *to,
            *step,
            csv.as_ref(),
            measure,
        ),
        Command::Resonances {
            vpk,
            backlash_deg,
            measure,
        } => fr_cli::resonances(cli, *vpk, *backlash_deg, measure),
        Command::MaxBacklash {
            bandwidth_hz,
            vpk,
            measure,
        } => fr_cli::max_backlash(cli, *bandwidth_hz, *vpk, measure),
        Command::MinVoltage {
            bandwidth_hz,
            backlash_deg,
            measure,
        } => fr_cli::min_voltage(cli, *bandwidth_hz, *backlash_deg, measure),
        Command::Paper { out, bandwidth_hz } => crate::paper::run(cli, out, *bandwidth_hz),
        Command::Synth(a) => crate::synth::run(cli, a),
        Command::Diagnose(a) => crate::diagnose::run(cli, a),
    }
}

fn info(cli: &Cli) -> Result<Report, HostError> {
    let (p, name) = load_params(cli, None)?;
    let d = p.derived().map_err(|e| HostError::from(e).at(&name))?;
    let tau_e = p.motor.inductance_h / p.motor.resistance_ohm;
    let json = json!({
        "params": name,
        "n_total": d.n_total,
        "n_r": d.n_r,
        "k1_nm_per_rad": d.k1_nm_per_rad,
        "k2_nm_per_rad": d.k2_nm_per_rad,
        "k_eq_nm_per_rad": d.k_eq_nm_per_rad,
        "f_ar_hz": d.f_ar_hz,
        "f_r_hz": d.f_r_hz,
        "backlash_deg": p.backlash_deg,
        "half_gap_rad": d.delta_rad,
        "electrical_time_constant_s": tau_e,
        "sample_period_s": p.sample_period_s,
    });
    let text = format!(
        "parameters            {name}\n\
         total ratio N         {:.6}\n\
         revolution ratio N_r  {:.6}\n\
         k1 (rotating shaft)   {:.6} N*m/rad\n\
         k2 (load)             {:.6} N*m/rad\n\
         k_eq (eq. 16)         {:.6} N*m/rad\n\
         anti-resonance f_AR   {:.4} Hz (eq. 17a, no backlash)\n\
         resonance f_R         {:.4} Hz (eq. 17b, no backlash)\n\
         backlash b_t          {} deg (half gap {:.6e} rad)\n\
         L/R                   {:.3e} s\n\
         sample period         {} s",
        d.n_total,
        d.n_r,
        d.k1_nm_per_rad,
        d.k2_nm_per_rad,
        d.k_eq_nm_per_rad,
        d.f_ar_hz,
        d.f_r_hz,
        p.backlash_deg,
        d.delta_rad,
        tau_e,
        p.sample_period_s
    );
    Ok(Report { json, text })
}

fn simulate(
    cli: &Cli,
    input: &Path,
    output: &Path,
    backlash: Option<f64>,
    scenario: Option<&Path>,
) -> Result<Report, HostError> {
    let (p, name) = load_params(cli, backlash)?;
    let rec = record::read(input, false)?;
    for w in &rec.warnings {
        eprintln!("warning: {w}");
    }
    let mut pp = p;
    pp.sample_period_s = rec.sample_period_s;
    params_file::validate(
        &pp,
        &format!("{} (sample period of the record)", input.display()),
    )?;
    let mut sc = match scenario {
        Some(path) => {
            let sc = scenario_file::load(path, rec.sample_period_s, rec.len())?;
            if let Some(i) = scenario_file::has_io_faults(&sc) {
                return Err(HostError::input(format!(
                    "{}: event {}: sensor and PWM faults act on the virtual actuator's sensors and bridge; `simulate` writes the plant's physical outputs from a voltage record",
                    path.display(),
                    i + 1
                )));
            }
            Some(sc)
        }
        None => None,
    };
    let cols = simulate_with_scenario(&p, rec.sample_period_s, &rec.motor_voltage_v, sc.as_mut())?;
    let mut columns: Vec<(&str, &[f64])> = vec![
        ("time_s", &rec.time_s),
        ("motor_voltage_v", &rec.motor_voltage_v),
    ];
    for (n, c) in SIMULATE_COLUMNS.iter().zip(cols.iter()) {
        columns.push((n, c.as_slice()));
    }
    let comments = vec![
        format!(
            "generated by: geared-servo {} simulate",
            env!("CARGO_PKG_VERSION")
        ),
        format!("params: {name}"),
        format!("input: {}", input.display()),
        format!("backlash_deg: {}", p.backlash_deg),
        format!("sample_period_s: {}", rec.sample_period_s),
        format!(
            "scenario: {}",
            scenario.map_or("none".to_string(), |p| p.display().to_string())
        ),
    ];
    record::write(output, &comments, &columns)?;
    let json = json!({
        "output": output.display().to_string(),
        "rows": rec.len(),
        "sample_period_s": rec.sample_period_s,
        "backlash_deg": p.backlash_deg,
    });
    let text = format!(
        "simulated {} rows at {:.6e} s ({}), wrote {}",
        rec.len(),
        rec.sample_period_s,
        name,
        output.display()
    );
    Ok(Report { json, text })
}
