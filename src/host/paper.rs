//! `paper`: regenerates the paper's Fig. 3–6.
use crate::host::cli::{Cli, Report};
use crate::host::error::HostError;
use std::path::Path;

/// Runs everything and writes into `out`.
pub fn run(_cli: &Cli, _out: &Path, _bw: f64) -> Result<Report, HostError> {
    Err(HostError::other("paper: in progress"))
}
