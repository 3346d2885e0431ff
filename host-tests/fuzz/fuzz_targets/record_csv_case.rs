//! One `record_csv` fuzz case, shared by the fuzz target and the seed replay test
//! (`host-tests/tests/fuzz_seeds.rs`): any text given as a measured-data record gives a
//! record with a finite time base and voltage, or a one-line error, never a panic.

/// Parses `data` as a record (when it is UTF-8), with and without an output column required.
pub fn check(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data) {
        for require_output in [false, true] {
            match geared_servo_host::record::parse(text, "fuzz.csv", require_output) {
                Ok(r) => {
                    assert!(r.len() >= 2 && r.sample_period_s > 0.0);
                    assert!(r
                        .time_s
                        .iter()
                        .chain(&r.motor_voltage_v)
                        .all(|v| v.is_finite()));
                }
                Err(e) => assert!(!e.message.contains('\n'), "multi-line error: {}", e.message),
            }
        }
    }
}
