//! What every command shares: the parameter file it loads and the report it returns.

use crate::args::Cli;
use geared_servo::ActuatorParams;
use geared_servo_host::error::HostError;
use geared_servo_host::params_file;
use geared_servo_host::record::{self, Record};
use serde_json::Value;
use std::path::Path;

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
    let p = params_file::load(cli.params.as_deref())?;
    match backlash_deg {
        Some(b) => Ok((params_file::with_backlash(&p, b)?, name)),
        None => Ok((p, name)),
    }
}

/// Reads the record at `path` (with at least one output column when `require_output`),
/// prints its warnings on stderr, and checks that `params` are valid at the record's sample
/// period.
pub fn read_record(
    params: &ActuatorParams,
    path: &Path,
    require_output: bool,
) -> Result<Record, HostError> {
    let rec = record::read(path, require_output)?;
    for w in &rec.warnings {
        eprintln!("warning: {w}");
    }
    params_file::validate_for_record(params, rec.sample_period_s, &path.display().to_string())?;
    Ok(rec)
}
