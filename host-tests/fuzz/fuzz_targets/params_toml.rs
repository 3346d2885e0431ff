//! Any text given as a parameter file: a value or a one-line error, never a panic. The case
//! itself is in `params_toml_case.rs`, which the seed replay test shares.
#![no_main]
use libfuzzer_sys::fuzz_target;

mod params_toml_case;

fuzz_target!(|data: &[u8]| params_toml_case::check(data));
