//! `step()` on parameters that pass validation, with arbitrary f32 inputs and fault values
//! (NaN, ±∞, subnormals, ±1e30 included): finite outputs and state in bounded time, never a
//! panic. The case itself is in `plant_step_case.rs`, which the seed replay test shares.
#![no_main]
use libfuzzer_sys::fuzz_target;

mod plant_step_case;

fuzz_target!(|data: &[u8]| plant_step_case::check(data));
