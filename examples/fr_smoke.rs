//! On-target frequency-response analyser: QEMU `mps2-an386` (Cortex-M4F) measures a few
//! stepped-sine points with the same `no_std` analyser the host sweeps use; CI compares the
//! output with `examples/expected/fr_smoke.txt`, and a host test checks that the host sweep
//! (`geared_servo::host::fr::Bench`) gives the same gain and phase.
//!
//! Target: `cargo run --release --example fr_smoke --target thumbv7em-none-eabihf`
//! Host:   `cargo run --release --example fr_smoke`
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[path = "shared/fr_smoke.rs"]
mod fr_smoke;

#[cfg(target_os = "none")]
mod bare {
    use cortex_m_rt::entry;
    use cortex_m_semihosting::{debug, hprintln};
    use panic_semihosting as _;

    // A fault hangs in cortex-m-rt's default handler (a custom one needs `unsafe`, which the
    // workspace forbids); CI runs QEMU under `timeout`.
    #[entry]
    fn main() -> ! {
        let ok = super::fr_smoke::run(&mut |a| hprintln!("{}", a));
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
    if !fr_smoke::run(&mut |a| println!("{a}")) {
        std::process::exit(1);
    }
}
