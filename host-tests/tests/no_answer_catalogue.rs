//! Every catalogued no-answer case is answered honestly: exit status 0, the value null in
//! `--json` with the expected cause and a one-line reason beside it, the same reason in the
//! text output; and `docs/no-answer.md` is exactly what the tool says.

use geared_servo_host_tests::no_answer_catalogue::{cases, markdown, rows};
use serde_json::Value;

#[test]
fn every_no_answer_case_is_null_with_its_cause_and_the_same_sentence_in_text() {
    let rows = rows();
    for (case, r) in cases().iter().zip(&rows) {
        let what = case.what;
        assert_eq!(r.status, 0, "{what}: exit {} ({})", r.status, r.reason);
        if case.value.is_some() {
            assert_eq!(r.value, Some(Value::Null), "{what}: value not null");
        }
        assert_eq!(r.cause, case.cause.code(), "{what}: {}", r.reason);
        assert!(
            !r.reason.is_empty() && !r.reason.contains('\n'),
            "{what}: reason `{}` is not one line",
            r.reason
        );
        assert!(
            r.text.contains(&r.reason),
            "{what}: the text does not carry the reason:\n{}",
            r.text
        );
    }
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/no-answer.md");
    let doc = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        doc == markdown(&rows),
        "docs/no-answer.md is stale: regenerate with `cargo run -p geared-servo-host-tests --example no_answer_catalogue > docs/no-answer.md`"
    );
}
