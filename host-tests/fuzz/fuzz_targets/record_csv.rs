//! Any text given as a measured-data record: a record or a one-line error, never a panic. The
//! case itself is in `record_csv_case.rs`, which the seed replay test shares.
#![no_main]
use libfuzzer_sys::fuzz_target;

mod record_csv_case;

fuzz_target!(|data: &[u8]| record_csv_case::check(data));
