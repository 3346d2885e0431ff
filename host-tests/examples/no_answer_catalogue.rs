//! Prints the no-answer catalogue (docs/no-answer.md) as Markdown.
use geared_servo_host_tests::no_answer_catalogue::{markdown, rows};

fn main() {
    print!("{}", markdown(&rows()));
}
