//! Host-only tools (feature `host`): parameter files, measured-data records and the
//! `geared-servo` command-line program. Nothing here is used by `step()`.

pub mod cli;
pub mod error;
pub mod fr;
pub mod fr_cli;
pub mod paper;
pub mod params_file;
pub mod plots;
pub mod record;
pub mod scenario_file;

pub use error::{ErrorKind, HostError};
