//! `geared-servo paper`: the paper's figures and design points.

use crate::args::Cli;
use crate::common::{load_params, Report};
use crate::progress::progress;
use geared_servo_host::paper::{compute, job_count, summary};
use geared_servo_host::paper_files::write_all;
use geared_servo_host::record::write_file;
use geared_servo_host::HostError;
use serde_json::{json, Value};
use std::path::Path;

/// The `paper` command.
pub fn run(cli: &Cli, out: &Path, bandwidth_hz: f64) -> Result<Report, HostError> {
    if !(bandwidth_hz.is_finite() && bandwidth_hz > 0.0) {
        return Err(HostError::input(format!(
            "--bandwidth-hz must be a positive frequency, got {bandwidth_hz}"
        )));
    }
    let (p, name) = load_params(cli, None)?;
    // Fail on an unwritable directory before the computation, not after it.
    std::fs::create_dir_all(out)
        .map_err(|e| HostError::other(format!("{}: {e}", out.display())))?;
    let pb = progress(job_count(), "paper");
    let t0 = std::time::Instant::now();
    let data = compute(&p, bandwidth_hz, &pb)?;
    pb.finish();
    let files = write_all(&data, out)?;
    let (mut text, mut json) = summary(&data);
    let secs = t0.elapsed().as_secs_f64();
    text.push_str(&format!(
        "\n{} files written to {} ({name}, {:.2} s)",
        files.len(),
        out.display(),
        secs
    ));
    write_file(&out.join("summary.md"), &text)?;
    if let Value::Object(m) = &mut json {
        m.insert("params".into(), json!(name));
        m.insert(
            "files".into(),
            json!(files
                .iter()
                .map(|f| f.display().to_string())
                .collect::<Vec<_>>()),
        );
    }
    Ok(Report { json, text })
}
