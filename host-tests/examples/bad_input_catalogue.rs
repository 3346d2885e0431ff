//! Prints the bad-input catalogue (docs/bad-input.md) as Markdown.
fn main() {
    print!("{}", geared_servo_host_tests::catalogue::markdown());
}
