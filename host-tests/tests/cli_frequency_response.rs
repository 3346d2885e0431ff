//! The frequency-response commands honour INTERFACES.md: JSON keys, the Bode CSV columns,
//! and bad input as exit status 2 with a reason.

use clap::Parser;
use geared_servo_cli::{run, Cli};

fn cli(args: &[&str]) -> Cli {
    Cli::try_parse_from(std::iter::once("geared-servo").chain(args.iter().copied())).unwrap()
}

#[test]
fn bode_csv_has_the_interface_columns_and_one_row_per_frequency() {
    let dir = std::env::temp_dir().join(format!("gs-bode-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("bode.csv");
    let o = out.to_str().unwrap();
    run(&cli(&[
        "bode",
        "--vpk",
        "10",
        "--backlash-deg",
        "0.02",
        "--from",
        "50",
        "--to",
        "60",
        "--csv",
        o,
    ]))
    .unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert!(lines
        .next()
        .unwrap()
        .starts_with("freq_hz,gain_db,phase_deg"));
    assert_eq!(lines.count(), 11);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn resonances_and_design_queries_report_the_interface_json_keys() {
    let r = run(&cli(&[
        "--json",
        "resonances",
        "--vpk",
        "17.9",
        "--backlash-deg",
        "0.04",
    ]))
    .unwrap();
    assert!(r.json["f_ar_hz"].as_f64().unwrap() > 90.0);
    assert!(r.json["f_r_hz"].as_f64().unwrap() > r.json["f_ar_hz"].as_f64().unwrap());
    let r = run(&cli(&[
        "--json",
        "max-backlash",
        "--bandwidth-hz",
        "110",
        "--vpk",
        "17.9",
    ]))
    .unwrap();
    assert!(r.json["max_backlash_deg"].as_f64().unwrap() > 0.0);
    let r = run(&cli(&[
        "--json",
        "min-voltage",
        "--bandwidth-hz",
        "110",
        "--backlash-deg",
        "0.02",
    ]))
    .unwrap();
    assert!(r.json["min_vpk"].as_f64().unwrap() > 1.0);
}

#[test]
fn bad_frequency_response_arguments_are_bad_input() {
    for args in [
        &["bode", "--vpk=-1"][..],
        &["bode", "--vpk", "10", "--from", "300", "--to", "10"],
        &["bode", "--vpk", "10", "--to", "1500"],
        &["resonances", "--vpk", "10", "--backlash-deg=-0.1"],
        &[
            "min-voltage",
            "--bandwidth-hz",
            "0",
            "--backlash-deg",
            "0.05",
        ],
    ] {
        let e = run(&cli(args))
            .err()
            .unwrap_or_else(|| panic!("{args:?} succeeded"));
        assert_eq!(e.exit_code(), 2, "{args:?}: {}", e.message);
    }
}
