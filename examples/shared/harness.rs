//! The one harness of the examples that run both on the host and bare-metal on QEMU
//! `mps2-an386` (Cortex-M4F): `plant_smoke`, `fr_smoke` and `fin_loop`.
//!
//! An example includes it with `#[path = "shared/harness.rs"] mod harness;`, brings the host
//! entry point in with `#[cfg(not(target_os = "none"))] use harness::main;`, and defines at
//! its root `fn program() -> bool`: the whole run, printing through [`line`], true when every
//! figure is within its bounds. The harness gives the program the same output and exit status
//! on both sides, so CI can diff the target's output with the host's expected files:
//! - target: cortex-m-rt entry, lines over semihosting, QEMU exits with the program's status
//!   (semihosting `exit`), a panic prints over semihosting and exits non-zero;
//! - host: lines on stdout, exit status 1 when the program reports a failure.

/// Prints one line of the example's output: semihosting on the target, stdout on the host.
/// Its signature fits the `line` callbacks of the shared example code.
pub fn line(args: core::fmt::Arguments) {
    #[cfg(target_os = "none")]
    cortex_m_semihosting::hprintln!("{}", args);
    #[cfg(not(target_os = "none"))]
    println!("{args}");
}

#[cfg(target_os = "none")]
mod bare {
    use cortex_m_rt::entry;
    use cortex_m_semihosting::debug;
    use panic_semihosting as _;

    // A fault hangs in cortex-m-rt's default handler (a custom one needs `unsafe`, which the
    // workspace forbids); CI runs QEMU under `timeout`.
    #[entry]
    fn main() -> ! {
        let ok = crate::program();
        debug::exit(if ok {
            debug::EXIT_SUCCESS
        } else {
            debug::EXIT_FAILURE
        });
        // Only reached if the debugger ignores the exit request; spinning is then harmless.
        #[allow(clippy::empty_loop)]
        loop {}
    }
}

/// The host entry point: runs the program, exit status 1 when it reports a failure.
#[cfg(not(target_os = "none"))]
pub fn main() {
    if !crate::program() {
        std::process::exit(1);
    }
}
