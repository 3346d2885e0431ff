//! The command line as tests drive it: parsed and run in process, with scratch directories.

use clap::Parser;
use geared_servo_cli::{run, Cli, Report};
use geared_servo_host::HostError;
use std::path::PathBuf;

/// Runs `geared-servo ARGS` in process (the arguments must parse).
pub fn cli(args: &[&str]) -> Result<Report, HostError> {
    run(&Cli::try_parse_from(std::iter::once("geared-servo").chain(args.iter().copied())).unwrap())
}

/// A fresh directory `gs-TAG-NAME-PID` under the system's temporary directory.
pub fn scratch(tag: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gs-{tag}-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
