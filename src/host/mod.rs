//! Host-only tools (feature `host`): parameter files, measured-data records, synthetic data,
//! calibration, residual analysis, diagnosis and the `geared-servo` command-line program.
//! Nothing here is used by `step()`.

pub mod calibrate;
pub mod cli;
pub mod diagnose;
pub mod diagnose_plots;
pub mod diagnose_report;
pub mod error;
pub mod fr;
pub mod fr_cli;
pub mod knobs;
pub mod paper;
pub mod params_file;
pub mod plots;
pub mod record;
pub mod residual;
pub mod scenario_file;
pub mod synth;

pub use error::{ErrorKind, HostError};
