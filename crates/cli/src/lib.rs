//! The `geared-servo` command line (INTERFACES.md): argument definitions and the commands.
//!
//! This crate is the binary's library: argument parsing (clap), progress bars and the
//! rendering of each command's result; the work is done by `geared-servo-host`.
//!
//! Each command returns either a JSON value (printed alone on stdout with `--json`) together
//! with a human summary, or a [`HostError`] that the binary maps to exit status 2 or 1.

pub mod args;
pub mod common;
pub mod diagnose;
pub mod fmu;
pub mod frequency;
pub mod init;
pub mod paper;
pub mod progress;
pub mod synth;
pub mod time_domain;

pub use args::{Cli, Command};
pub use common::{load_params, Report};
use geared_servo_host::error::HostError;

/// Runs the parsed command line.
pub fn run(cli: &Cli) -> Result<Report, HostError> {
    match &cli.command {
        Command::Info => time_domain::info(cli),
        Command::Simulate {
            input,
            output,
            backlash_deg,
            scenario,
        } => time_domain::simulate(cli, input, output, *backlash_deg, scenario.as_deref()),
        Command::Bode {
            vpk,
            backlash_deg,
            from,
            to,
            step,
            csv,
            measure,
        } => frequency::bode(
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
        } => frequency::resonances(cli, *vpk, *backlash_deg, measure),
        Command::MaxBacklash {
            bandwidth_hz,
            vpk,
            measure,
        } => frequency::max_backlash(cli, *bandwidth_hz, *vpk, measure),
        Command::MinVoltage {
            bandwidth_hz,
            backlash_deg,
            measure,
        } => frequency::min_voltage(cli, *bandwidth_hz, *backlash_deg, measure),
        Command::Paper { out, bandwidth_hz } => crate::paper::run(cli, out, *bandwidth_hz),
        Command::Synth(a) => crate::synth::run(cli, a),
        Command::Diagnose(a) => crate::diagnose::run(cli, a),
        Command::Fmu { out, library } => crate::fmu::run(cli, out, library.as_deref()),
        Command::Init(a) => crate::init::run(a),
    }
}
