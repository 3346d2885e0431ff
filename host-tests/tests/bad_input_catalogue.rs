//! `docs/bad-input.md` is exactly what the tool says for every catalogued bad input, every
//! input is rejected (none accepted), and every message is one line.

use geared_servo_host_tests::catalogue::{catalogue, markdown};

#[test]
fn every_catalogued_input_is_rejected_with_one_line() {
    for (title, rows) in catalogue() {
        for r in rows {
            assert_eq!(r.status, 2, "{title}: {} → {}", r.input, r.message);
            assert!(
                r.message != "(accepted)" && !r.message.is_empty(),
                "{title}: {} accepted",
                r.input
            );
            assert!(!r.message.contains('\n'), "{title}: {}", r.input);
        }
    }
}

#[test]
fn the_documented_catalogue_is_what_the_tool_says() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/bad-input.md");
    let doc = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        doc == markdown(),
        "docs/bad-input.md is stale: regenerate with `cargo run -p geared-servo-host-tests --example bad_input_catalogue > docs/bad-input.md`"
    );
}
