//! `geared-servo fmu`: the FMI 2.0 co-simulation FMU of a parameter file.
//!
//! The archive's shared library is the crate `geared-servo-fmu`, built by cargo like this
//! binary: `fmu` takes it from beside the running executable (both land in
//! `target/<profile>/`), or from `--library`. It is not embedded in this binary, which would
//! need cargo to build one workspace member from another's build script.

use crate::args::Cli;
use crate::common::{load_params, Report};
use geared_servo_host::error::HostError;
use geared_servo_host::fmu::{self, MODEL_IDENTIFIER};
use geared_servo_host::param_list::ParamList;
use serde_json::json;
use std::path::{Path, PathBuf};

/// File name of the FMU library as cargo builds it.
fn library_file() -> String {
    format!("lib{MODEL_IDENTIFIER}.so")
}

/// The library: `--library`, else the one beside the executable.
fn find_library(given: Option<&Path>) -> Result<PathBuf, HostError> {
    if let Some(p) = given {
        return Ok(p.to_path_buf());
    }
    let exe = std::env::current_exe()
        .map_err(|e| HostError::other(format!("cannot locate this executable: {e}")))?;
    let dir = exe.parent().unwrap_or(Path::new("."));
    let lib = dir.join(library_file());
    if lib.is_file() {
        Ok(lib)
    } else {
        Err(HostError::input(format!(
            "{}: no FMU library beside this executable: build it with `cargo build --release -p geared-servo-fmu` (the same profile as geared-servo), or give --library PATH",
            lib.display()
        )))
    }
}

/// `fmu --out OUT.fmu [--library LIB.so]`.
pub fn run(cli: &Cli, out: &Path, library: Option<&Path>) -> Result<Report, HostError> {
    if !cfg!(all(target_os = "linux", target_arch = "x86_64")) {
        return Err(HostError::input(
            "the FMU's library is built for Linux x86-64 only (FMI platform linux64)",
        ));
    }
    let (p, name) = load_params(cli, None)?;
    let lib = find_library(library)?;
    let bytes = std::fs::read(&lib)
        .map_err(|e| HostError::input(format!("{}: cannot read: {e}", lib.display())))?;
    let header = vec![
        format!(
            "parameters of an FMU built by geared-servo {} fmu",
            env!("CARGO_PKG_VERSION")
        ),
        format!("from {name}"),
    ];
    fmu::write(&p, &header, &bytes, out)?;
    let n = ParamList::new(&p)?.entries().len();
    let guid = fmu::guid(&fmu::params_resource(&p, &header)?);
    let json = json!({
        "output": out.display().to_string(),
        "params": name,
        "library": lib.display().to_string(),
        "model_identifier": MODEL_IDENTIFIER,
        "guid": guid,
        "parameters": n,
    });
    let text = format!(
        "wrote {} (FMI 2.0 co-simulation, {}): input {}, outputs {}, {n} parameters from {name}",
        out.display(),
        fmu::PLATFORM,
        fmu::INPUT,
        geared_servo_host::simulate::SIMULATE_COLUMNS.join(", "),
    );
    Ok(Report { json, text })
}
