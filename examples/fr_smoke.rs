//! On-target frequency-response analyser: QEMU `mps2-an386` (Cortex-M4F) measures a few
//! stepped-sine points with the same `no_std` analyser the host sweeps use; CI compares the
//! output with `examples/expected/fr_smoke.txt`, and a host test checks that the host sweep
//! (`geared_servo_host::fr::Bench`) gives the same gain and phase.
//!
//! Target: `cargo run --release --example fr_smoke --target thumbv7em-none-eabihf`
//! Host:   `cargo run --release --example fr_smoke`
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[path = "shared/harness.rs"]
mod harness;
#[cfg(not(target_os = "none"))]
use harness::main;

#[path = "shared/fr_smoke.rs"]
mod fr_smoke;

/// The run the harness starts on the host and on the target.
fn program() -> bool {
    fr_smoke::run(&mut harness::line)
}
