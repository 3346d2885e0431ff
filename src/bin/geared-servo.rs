//! The `geared-servo` command-line tool (see INTERFACES.md and `geared-servo --help`).

use clap::Parser;
use geared_servo::host::cli::{run, Cli};

fn main() {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            // Help and version go to stdout with status 0; usage errors are bad input (2).
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            std::process::exit(code);
        }
    };
    match run(&cli) {
        Ok(report) => {
            use std::io::Write;
            let text = if cli.json {
                report.json.to_string()
            } else {
                report.text
            };
            // A closed pipe (`geared-servo … | head`) is the reader's choice, not an error;
            // `println!` would panic on it.
            let mut out = std::io::stdout().lock();
            match writeln!(out, "{text}").and_then(|()| out.flush()) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
                Err(e) => {
                    eprintln!("error: cannot write to stdout: {e}");
                    std::process::exit(1);
                }
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(e.exit_code());
        }
    }
}
