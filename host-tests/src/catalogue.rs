//! The bad-input catalogue: every rejected input of the parameter file, the measured-data
//! record, the fault scenario and the command line, run for real, with the exact one-line
//! error a user sees. `docs/bad-input.md` is this table; a test keeps the two identical
//! (`cargo run -p geared-servo-host-tests --example bad_input_catalogue > docs/bad-input.md`
//! regenerates it).

use clap::Parser;
use geared_servo_cli::{run, Cli};
use geared_servo_host::{params_file, record, scenario_file};

/// One rejected input.
pub struct Row {
    /// What was given.
    pub input: String,
    /// Exit status of the command-line tool (2: bad input).
    pub status: i32,
    /// The message, exactly.
    pub message: String,
}

/// Sections of the catalogue: (title, rows).
pub fn catalogue() -> Vec<(&'static str, Vec<Row>)> {
    vec![
        ("Parameter file (`--params FILE`, file shown as `act.toml`)", params_rows()),
        ("Measured-data record (`--data`, `--input`; file shown as `meas.csv`)", record_rows()),
        ("Fault scenario (`simulate --scenario`; file shown as `faults.toml`, a 1 s run at 2 kHz)", scenario_rows()),
        ("Command line", cli_rows()),
    ]
}

fn params_rows() -> Vec<Row> {
    let reference = params_file::REFERENCE_TOML;
    let mut rows = Vec::new();
    let mut check = |input: String, text: String| {
        let message = match params_file::parse(&text, "act.toml") {
            Ok(_) => "(accepted)".to_string(),
            Err(e) => e.message,
        };
        rows.push(Row {
            input,
            status: 2,
            message,
        });
    };
    // Every numeric key of the reference file, made NaN and made negative.
    let mut table = String::new();
    for line in reference.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            table = t
                .trim_start_matches('[')
                .split(']')
                .next()
                .unwrap_or("")
                .to_string();
            continue;
        }
        let Some((key, rest)) = t.split_once('=') else {
            continue;
        };
        let value = rest.split('#').next().unwrap_or("").trim();
        if value.parse::<f64>().is_err() {
            continue;
        }
        let key = key.trim();
        let path = if table.is_empty() {
            key.to_string()
        } else {
            format!("{table}.{key}")
        };
        for bad in ["nan", "-1"] {
            let edited = reference.replacen(line, &line.replacen(value, bad, 1), 1);
            check(format!("`{path} = {bad}`"), edited);
        }
    }
    type Edit<'a> = &'a dyn Fn(&str) -> String;
    let structural: [(&str, Edit); 9] = [
        ("a key misspelt (`inductance` for `inductance_h`)", &|t| {
            t.replacen("inductance_h =", "inductance =", 1)
        }),
        ("a required key missing (`motor.inductance_h`)", &|t| {
            t.lines()
                .filter(|l| !l.starts_with("inductance_h"))
                .collect::<Vec<_>>()
                .join("\n")
        }),
        ("a table missing (`[load]`)", &|t| {
            t.replacen("[load]", "[unused]", 1)
        }),
        ("a string where a number is expected", &|t| {
            t.replacen("ratio = 5 ", "ratio = \"5\" ", 1)
        }),
        ("an array where a number is expected", &|t| {
            t.replacen("total_deg = 0.0 ", "total_deg = [1] ", 1)
        }),
        ("TOML syntax error", &|t| t.replacen("[motor]", "[motor", 1)),
        ("geometry and a `[stiffness]` table both given", &|t| {
            format!("{t}\n[stiffness]\nk1_nm_per_rad = 1.0\nk2_nm_per_rad = 2.0\n")
        }),
        ("backlash beyond the model's range", &|t| {
            t.replacen("total_deg = 0.0 ", "total_deg = 45 ", 1)
        }),
        ("tachometer gain error of −100 % or worse", &|t| {
            t.replacen("tach_gain = 0.0 ", "tach_gain = -1 ", 1)
        }),
    ];
    for (what, edit) in structural {
        check(what.to_string(), edit(reference));
    }
    rows
}

fn record_rows() -> Vec<Row> {
    let cases = [
        (
            "an empty field",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,,0\n",
        ),
        (
            "a non-numeric value",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,abc,0\n",
        ),
        (
            "a non-finite value",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,inf,0\n",
        ),
        (
            "column `motor_voltage_v` missing",
            "time_s,tach_voltage_v\n0,0\n0.0005,1\n",
        ),
        (
            "column `time_s` missing",
            "motor_voltage_v,tach_voltage_v\n0,0\n1,1\n",
        ),
        (
            "no output column (measured data needs one)",
            "time_s,motor_voltage_v\n0,0\n0.0005,1\n",
        ),
        (
            "time not increasing",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.001,1,0\n0.0005,1,0\n",
        ),
        (
            "a gap in the time base (samples missing: an interval over 1.5 typical periods)",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,1,0\n0.001,1,0\n0.0025,1,0\n0.003,1,0\n",
        ),
        (
            "a row with too few fields",
            "# a: b\ntime_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,1\n",
        ),
        (
            "a column named twice",
            "time_s,motor_voltage_v,time_s\n0,1,0\n0.0005,1,0\n",
        ),
        (
            "one data row only",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n",
        ),
        ("an empty file", ""),
    ];
    cases
        .iter()
        .map(|(what, text)| Row {
            input: (*what).to_string(),
            status: 2,
            message: match record::parse(text, "meas.csv", true) {
                Ok(_) => "(accepted)".to_string(),
                Err(e) => e.message,
            },
        })
        .collect()
}

fn scenario_rows() -> Vec<Row> {
    let ev = |body: &str| format!("[[event]]\n{body}\n");
    let cases: Vec<(&str, String)> = vec![
        ("an unknown fault", ev("at_s = 0.1\napply = \"meltdown\"")),
        ("an event past the end of the run", ev("at_s = 5.0\napply = \"jam\"")),
        ("events out of time order", ev("at_s = 0.2\napply = \"jam\"") + &ev("at_s = 0.1\nclear = \"jam\"")),
        ("two winding faults overlapping", ev("at_s = 0.1\napply = \"open_winding\"") + &ev("at_s = 0.2\napply = \"shorted_winding\"")),
        ("a fault applied again while in force", ev("at_s = 0.1\napply = \"tach_stuck\"\ncounts = 5") + &ev("at_s = 0.2\napply = \"tach_offset\"\ncounts = 5")),
        ("`apply` and `clear` in one event", ev("at_s = 0.1\napply = \"jam\"\nclear = \"jam\"")),
        ("neither `apply` nor `clear`", ev("at_s = 0.1")),
        ("a fault's value missing", ev("at_s = 0.1\napply = \"load_torque\"")),
        ("an unknown key", ev("at_s = 0.1\napply = \"jam\"\nspeed = 3")),
        ("a value out of range", ev("at_s = 0.1\napply = \"broken_tooth\"\nangle_deg = 0\nwidth_deg = 3\ntorque_loss = 2")),
        ("a negative time", ev("at_s = -1\napply = \"jam\"")),
        ("a negative friction factor", ev("at_s = 0.1\napply = \"friction_factor\"\nfactor = -1.7e9")),
        ("a friction factor beyond 1000", ev("at_s = 0.1\napply = \"friction_factor\"\nfactor = 1e9")),
        ("negative backlash wear", ev("at_s = 0.1\napply = \"backlash_wear\"\nextra_deg = -0.5")),
        ("a load torque beyond ±1e6 N·m", ev("at_s = 0.1\napply = \"load_torque\"\namplitude_nm = -1.7e9")),
        ("a non-finite load torque", ev("at_s = 0.1\napply = \"load_torque\"\namplitude_nm = nan")),
        ("a jam angle beyond ±1e6 rad", ev("at_s = 0.1\napply = \"jam\"\nangle_deg = -1e11")),
        ("an infinite jam angle", ev("at_s = 0.1\napply = \"jam\"\nangle_deg = inf")),
        ("a broken tooth wider than a revolution", ev("at_s = 0.1\napply = \"broken_tooth\"\nangle_deg = 0\nwidth_deg = 400\ntorque_loss = 0.5")),
        ("a sensor gain error below −100 %", ev("at_s = 0.1\napply = \"tach_gain\"\ndrift = -2")),
        ("sensor noise beyond 1e9 counts", ev("at_s = 0.1\napply = \"pot_noise\"\npeak_counts = 1e12")),
        ("a bus voltage factor beyond 10", ev("at_s = 0.1\napply = \"bus_sag\"\nfactor = 11")),
        ("more events than the capacity (64)", {
            let mut t = String::new();
            for k in 0..=scenario_file::CAPACITY {
                t += &ev(&format!("at_s = {}\napply = \"friction_factor\"\nfactor = 1.5", k as f64 * 0.001));
            }
            t
        }),
    ];
    cases
        .into_iter()
        .map(|(what, text)| Row {
            input: what.to_string(),
            status: 2,
            message: match scenario_file::parse(&text, "faults.toml", 0.0005, 2000) {
                Ok(_) => "(accepted)".to_string(),
                Err(e) => e.message,
            },
        })
        .collect()
}

fn cli_rows() -> Vec<Row> {
    // A valid query without an answer (a bandwidth never reached) is not bad input: it is in
    // the no-answer catalogue (`crate::no_answer_catalogue`).
    // `init`'s figures are checked before anything is written (its output path is never
    // created here).
    const INIT: [&str; 9] = [
        "init",
        "--output",
        "never-written.toml",
        "--no-load-rpm",
        "100",
        "--gear-ratio",
        "100",
        "--load-inertia",
        "2e-4",
    ];
    let init_neg = [
        &INIT[..],
        &["--supply-v", "-12", "--stall-torque-nm", "1.2"],
    ]
    .concat();
    let init_none = [&INIT[..], &["--supply-v", "12"]].concat();
    let init_mismatch = [
        &INIT[..],
        &[
            "--supply-v",
            "12",
            "--stall-torque-nm",
            "40",
            "--stall-current-a",
            "1.6",
        ],
    ]
    .concat();
    let cases: [&[&str]; 14] = [
        &["frobnicate"],
        &["simulate", "--input", "in.csv"],
        &["bode", "--vpk", "ten"],
        &["info", "--params", "missing.toml"],
        &["bode", "--vpk", "10", "--backlash-deg=-1"],
        &["bode", "--vpk", "10", "--from", "300", "--to", "10"],
        &["bode", "--vpk", "nan"],
        &["max-backlash", "--bandwidth-hz", "0", "--vpk", "10"],
        &["diagnose", "--data", "missing.csv"],
        &[
            "diagnose",
            "--data",
            "missing.csv",
            "--candidates",
            "stiction",
        ],
        &[
            "diagnose",
            "--data",
            "missing.csv",
            "--limits",
            "tach_gain,nope",
        ],
        &init_neg,
        &init_none,
        &init_mismatch,
    ];
    cases
        .iter()
        .map(|args| {
            let line = format!("`geared-servo {}`", args.join(" "));
            match Cli::try_parse_from(std::iter::once("geared-servo").chain(args.iter().copied())) {
                // clap's own usage errors: exit 2; the reason is the text before the usage
                // block that follows it, shown here on one line.
                Err(e) => Row {
                    input: line,
                    status: 2,
                    message: e
                        .to_string()
                        .split("\n\n")
                        .next()
                        .unwrap_or("")
                        .lines()
                        .map(str::trim)
                        .collect::<Vec<_>>()
                        .join(" "),
                },
                Ok(cli) => match run(&cli) {
                    Ok(_) => Row {
                        input: line,
                        status: 0,
                        message: "(accepted)".to_string(),
                    },
                    Err(e) => Row {
                        input: line,
                        status: e.exit_code(),
                        message: e.message,
                    },
                },
            }
        })
        .collect()
}

/// The catalogue as Markdown.
pub fn markdown() -> String {
    let mut s = String::from(
        "# Bad input: what is rejected, and the exact error\n\n\
         Generated by `cargo run -p geared-servo-host-tests --example bad_input_catalogue`;\n\
         `host-tests/tests/bad_input_catalogue.rs` fails if this file and the tool disagree, so\n\
         every row is a test. The command-line tool prints the message after `error: ` on\n\
         stderr, as one line, and exits with the status shown (2: bad input); nothing panics.\n\
         Usage errors found by the argument parser print their reason and\n\
         `(see geared-servo --help)` instead, also on one line.\n\
         In firmware the same parameter checks return `ParamError`, whose `Display` is the\n\
         key and the reason (`motor.resistance_ohm: must be greater than zero`); a fault\n\
         scenario built with `Scenario::push` gets a `ScenarioError` the same way\n\
         (`FrictionFactor: must not be negative`).\n",
    );
    for (title, rows) in catalogue() {
        s += &format!("\n## {title}\n\n| input | exit | message |\n|---|---|---|\n");
        for r in rows {
            s += &format!(
                "| {} | {} | {} |\n",
                r.input,
                r.status,
                r.message.replace('|', "\\|")
            );
        }
    }
    s
}
