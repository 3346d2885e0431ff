//! The `geared-servo` command-line tool (see INTERFACES.md and `geared-servo --help`).

use clap::Parser;
use geared_servo_cli::{run, Cli};

fn main() {
    // Traces for developers, off unless asked for: `RUST_LOG=geared_servo_host=debug`
    // prints each phase of a diagnosis with the simulations run so far (docs/cost.md).
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("off"))
        .format_timestamp_millis()
        .init();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            // Help and version go to stdout with status 0. Usage errors are bad input (2),
            // reported as one line: clap's reason without its usage block.
            if !e.use_stderr() {
                let _ = e.print();
                std::process::exit(0);
            }
            let text = e.to_string();
            let reason: Vec<&str> = text
                .split("\n\n")
                .next()
                .unwrap_or("")
                .lines()
                .map(str::trim)
                .collect();
            eprintln!("{} (see `geared-servo --help`)", reason.join(" "));
            std::process::exit(2);
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
