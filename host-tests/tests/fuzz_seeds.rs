//! Every committed fuzz seed (among them the inputs of past crashes) passes its fuzz target's
//! own check, replayed here on plain `cargo test` through the very same code
//! (`fuzz/fuzz_targets/*_case.rs`), so a regression does not wait for a fuzz run, and the
//! seeds are checked on every CI run even where `.ci/run` has no time left to fuzz.

use std::path::{Path, PathBuf};

#[path = "../fuzz/fuzz_targets/params_toml_case.rs"]
mod params_toml_case;
#[path = "../fuzz/fuzz_targets/plant_step_case.rs"]
mod plant_step_case;
#[path = "../fuzz/fuzz_targets/record_csv_case.rs"]
mod record_csv_case;

/// The committed seeds of one target, sorted by name.
fn seeds(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz/seeds")
        .join(target);
    let mut seeds: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    seeds.sort();
    seeds
}

/// Runs `check` on every seed of `target`; returns how many seeds there were and how many are
/// the inputs of past crashes (`regression-*`).
fn replay(target: &str, check: fn(&[u8])) -> (usize, usize) {
    let seeds = seeds(target);
    for path in &seeds {
        let data = std::fs::read(path).unwrap();
        let run = std::panic::catch_unwind(|| check(&data));
        assert!(run.is_ok(), "seed {} fails", path.display());
    }
    let regressions = seeds
        .iter()
        .filter(|p| p.to_string_lossy().contains("regression-"))
        .count();
    (seeds.len(), regressions)
}

#[test]
fn every_plant_step_seed_keeps_outputs_and_state_finite() {
    let (_, regressions) = replay("plant_step", plant_step_case::check);
    assert!(regressions >= 2, "the crash inputs are among the seeds");
}

#[test]
fn every_params_toml_seed_gives_a_value_or_a_one_line_error() {
    let (n, _) = replay("params_toml", params_toml_case::check);
    assert!(n >= 3, "the seeds are there");
}

#[test]
fn every_record_csv_seed_gives_a_record_or_a_one_line_error() {
    let (n, regressions) = replay("record_csv", record_csv_case::check);
    assert!(
        n >= 4 && regressions >= 1,
        "the seeds are there, the crash input among them"
    );
}
