//! Determinism: the same inputs give bit-identical outputs across runs and thread counts,
//! parallel sweeps and calibration included. (Host and target agreement is proved bit for
//! bit by `target_parity.rs`, `fin_loop.rs` and `frequency_response.rs` against the files CI
//! diffs the QEMU output with.)

use geared_servo::REFERENCE;
use geared_servo_host::design;
use geared_servo_host::fr::{self, grid, Bench, SweepOptions};

/// Runs `f` on a fresh rayon pool of `threads` threads.
fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

fn sweep() -> Vec<fr::Point> {
    // A new bench builds its sine drives afresh: every run starts cold.
    let opts = SweepOptions {
        vpk: 10.0,
        ..SweepOptions::default()
    };
    Bench::new(&REFERENCE.with_backlash_deg(0.08), opts)
        .unwrap()
        .sweep(&grid(10.0, 300.0, 9.0).unwrap(), &())
        .unwrap()
}

#[test]
fn parallel_sweeps_are_bit_identical_across_runs_and_thread_counts() {
    let one = with_threads(1, sweep);
    let two = with_threads(2, sweep);
    let four = with_threads(4, sweep);
    let again = with_threads(4, sweep);
    assert_eq!(one, two);
    assert_eq!(one, four);
    assert_eq!(four, again);
}

#[test]
fn design_query_is_bit_identical_across_thread_counts() {
    let run = || {
        let opts = SweepOptions {
            vpk: 10.0,
            ..SweepOptions::default()
        };
        design::max_backlash(&REFERENCE, 100.0, opts, 0.002).unwrap()
    };
    let a = with_threads(1, run);
    let b = with_threads(3, run);
    assert_eq!(
        a.value.as_ref().map(|v| v.to_bits()),
        b.value.as_ref().map(|v| v.to_bits())
    );
    assert_eq!(a.trace, b.trace);
}

#[test]
fn diagnose_is_bit_identical_across_thread_counts() {
    use clap::Parser;
    use geared_servo_cli::{run, Cli};
    let dir = std::env::temp_dir().join(format!("gs-determinism-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let meas = dir.join("meas.csv");
    let cli = |args: &[&str]| {
        Cli::try_parse_from(std::iter::once("geared-servo").chain(args.iter().copied())).unwrap()
    };
    let m = meas.to_str().unwrap();
    run(&cli(&[
        "synth",
        "--output",
        m,
        "--excitation",
        "multisine",
        "--amplitude",
        "10",
        "--f-min",
        "2",
        "--f-max",
        "300",
        "--duration",
        "1",
        "--noise",
        "0.01",
        "--seed",
        "5",
        "--effect",
        "mesh_damping=0.05",
    ]))
    .unwrap();
    let diag = || {
        run(&cli(&["--json", "diagnose", "--data", m]))
            .unwrap()
            .json
            .to_string()
    };
    let a = with_threads(1, diag);
    let b = with_threads(2, diag);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        a.contains("\"added_effects\"") && a.contains("mesh_damping"),
        "{a}"
    );
    assert_eq!(a, b);
}
