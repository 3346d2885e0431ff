//! Host library of geared-servo (std): parameter files, measured-data records and fault
//! scenarios; time-domain simulation, synthetic data; the stepped-sine frequency response,
//! resonances, design queries and the paper's figures; calibration, residual analysis and
//! diagnosis, with their reports and plots.
//!
//! Everything here returns values and errors: nothing prints, exits or keeps process-wide
//! state. Long computations report progress through a [`Progress`] the caller supplies. The
//! `geared-servo` command line (crate `geared-servo-cli`) is a thin layer over this crate.
//! Nothing here is used by the plant's `step()`, which lives in the `geared-servo` core crate.
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)
)]

pub mod calibrate;
pub mod datasheet;
pub mod design;
pub mod diagnose;
pub mod diagnose_plots;
pub mod diagnose_report;
pub mod error;
pub mod fmu;
pub mod fr;
pub mod fr_report;
pub mod knobs;
pub mod no_answer;
pub mod noise;
pub mod paper;
pub mod paper_files;
pub mod param_list;
pub mod params_file;
pub mod plots;
pub mod predictability;
pub mod progress;
pub mod record;
pub mod repeat;
pub mod residual;
pub mod response;
pub mod scenario_file;
pub mod simulate;
pub mod synth;

pub use error::{ErrorKind, HostError};
pub use progress::Progress;
