//! Any text given as a parameter file: a value or a one-line error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Err(e) = geared_servo_host::params_file::parse(text, "fuzz.toml") {
            assert!(!e.message.contains('\n'), "multi-line error: {}", e.message);
        }
    }
});
