//! Every committed `plant_step` fuzz seed (among them the inputs of past crashes) passes the
//! fuzz target's own check, replayed here on plain `cargo test` through the very same code
//! (`fuzz/fuzz_targets/plant_step_case.rs`), so a regression does not wait for a fuzz run.

#[path = "../fuzz/fuzz_targets/plant_step_case.rs"]
mod plant_step_case;

#[test]
fn every_plant_step_seed_keeps_outputs_and_state_finite() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds/plant_step");
    let mut seeds: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    seeds.sort();
    let regressions = seeds
        .iter()
        .filter(|p| p.to_string_lossy().contains("regression-"))
        .count();
    assert!(regressions >= 2, "the crash inputs are among the seeds");
    for path in &seeds {
        let data = std::fs::read(path).unwrap();
        let run = std::panic::catch_unwind(|| plant_step_case::check(&data));
        assert!(run.is_ok(), "seed {} fails", path.display());
    }
}
