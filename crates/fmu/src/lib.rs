//! The FMI 2.0 co-simulation FMU of geared-servo: a shared library (Linux x86-64) exporting
//! the fmi2 C functions over the firmware crate's [`geared_servo::Plant::step`].
//!
//! `geared-servo fmu --params FILE --out actuator.fmu` packs this library with the
//! `modelDescription.xml` and `resources/params.toml` that `geared_servo_host::fmu` writes
//! for the parameter file. One input, the motor voltage; the outputs of `simulate`; every key
//! of the parameter file as a parameter, its start value the file's (docs/INTERFACES.md,
//! "FMU"). Each communication step is a whole number of sample periods, each of them the
//! exact `Plant::step` of the firmware, so the FMU's outputs equal `simulate`'s bit for bit.
//!
//! Parameters are validated at `fmi2ExitInitializationMode` with the parameter file's
//! messages; a bad one is `fmi2Error` and a message to the importer's logger, never a crash.
//!
//! The C ABI (`src/ffi.rs`, private) is the only module allowed `unsafe`; the instance it drives
//! ([`instance`]) is safe Rust.

pub mod instance;

// The fmi2 C functions: `unsafe` is allowed there and nowhere else in the crate.
#[allow(unsafe_code)]
mod ffi;
