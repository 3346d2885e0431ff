//! Minimal on-target run of the emulator: QEMU `mps2-an386` (Cortex-M4F) prints a few stepped
//! outputs, which CI compares with the host's (`examples/expected/plant_smoke.txt`).
//!
//! Target: `cargo run --release --example plant_smoke --target thumbv7em-none-eabihf`
//! Host:   `cargo run --release --example plant_smoke`
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[path = "shared/harness.rs"]
mod harness;
#[cfg(not(target_os = "none"))]
use harness::main;

#[path = "shared/plant_smoke.rs"]
mod plant_smoke;

/// The run the harness starts on the host and on the target.
fn program() -> bool {
    plant_smoke::run(&mut harness::line)
}
