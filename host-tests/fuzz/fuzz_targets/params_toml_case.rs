//! One `params_toml` fuzz case, shared by the fuzz target and the seed replay test
//! (`host-tests/tests/fuzz_seeds.rs`): any text given as a parameter file gives a value or a
//! one-line error, never a panic.

/// Parses `data` as a parameter file (when it is UTF-8) and checks the error is one line.
pub fn check(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Err(e) = geared_servo_host::params_file::parse(text, "fuzz.toml") {
            assert!(!e.message.contains('\n'), "multi-line error: {}", e.message);
        }
    }
}
