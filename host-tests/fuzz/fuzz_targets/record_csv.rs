//! Any text given as a measured-data record: a record or a one-line error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        for require_output in [false, true] {
            match geared_servo_host::record::parse(text, "fuzz.csv", require_output) {
                Ok(r) => {
                    assert!(r.len() >= 2 && r.sample_period_s > 0.0);
                    assert!(r.time_s.iter().chain(&r.motor_voltage_v).all(|v| v.is_finite()));
                }
                Err(e) => assert!(!e.message.contains('\n'), "multi-line error: {}", e.message),
            }
        }
    }
});
