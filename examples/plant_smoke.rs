//! Minimal on-target run of the emulator: QEMU `mps2-an386` (Cortex-M4F) prints a few stepped
//! outputs, which CI compares with the host's (`examples/expected/plant_smoke.txt`).
//!
//! Target: `cargo run --release --example plant_smoke --target thumbv7em-none-eabihf`
//! Host:   `cargo run --release --example plant_smoke`
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[path = "shared/plant_smoke.rs"]
mod plant_smoke;

#[cfg(target_os = "none")]
mod bare {
    use cortex_m_rt::entry;
    use cortex_m_semihosting::{debug, hprintln};
    use panic_semihosting as _;

    // A fault hangs in cortex-m-rt's default handler (a custom one needs `unsafe`, which the
    // workspace forbids); CI runs QEMU under `timeout`.
    #[entry]
    fn main() -> ! {
        let ok = super::plant_smoke::run(&mut |a| hprintln!("{}", a));
        debug::exit(if ok {
            debug::EXIT_SUCCESS
        } else {
            debug::EXIT_FAILURE
        });
        loop {}
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    if !plant_smoke::run(&mut |a| println!("{a}")) {
        std::process::exit(1);
    }
}
