//! The no-answer catalogue, sibling of the bad-input catalogue ([`crate::catalogue`]): inputs
//! that are valid but whose question has no answer (no resolvable anti-resonance, a bandwidth
//! that is never or always reached), each run through the command line for real, with the
//! JSON null, the cause and the sentence a user sees. `docs/no-answer.md` is this table; a test
//! keeps the two identical and checks every row
//! (`cargo run -p geared-servo-host-tests --example no_answer_catalogue > docs/no-answer.md`
//! regenerates it).

use clap::Parser;
use geared_servo_cli::{run, Cli};
use geared_servo_host::no_answer::Cause;
use geared_servo_host::params_file::REFERENCE_TOML;
use serde_json::Value;

/// A parameter-file edit: the reference file with `key = reference value` lines replaced.
type Edit = &'static [(&'static str, &'static str)];

/// One case.
pub struct Case {
    /// What is special about the input.
    pub what: &'static str,
    /// Edits of the reference parameter file (`act.toml`); empty: the bundled file.
    pub params: Edit,
    /// The command line after `geared-servo` (and before `--params`); `DIR` is replaced by
    /// a temporary directory.
    pub args: &'static [&'static str],
    /// JSON pointer of the value that is null, if the command has one (`bode` has none).
    pub value: Option<&'static str>,
    /// JSON pointer of the reason; the cause sits beside it (`_reason` → `_cause`).
    pub reason: &'static str,
    /// The expected cause.
    pub cause: Cause,
}

const L10: Edit = &[("inductance_h = 0.8e-3 ", "inductance_h = 10.0 ")];
const L10_FRICTIONLESS: Edit = &[
    ("inductance_h = 0.8e-3 ", "inductance_h = 10.0 "),
    (
        "coulomb_friction_nm = 2.0e-4 ",
        "coulomb_friction_nm = 0.0 ",
    ),
    (
        "coulomb_friction_nm = 5.0e-3 ",
        "coulomb_friction_nm = 0.0 ",
    ),
];
const TINY_INERTIAS: Edit = &[
    ("inertia_kg_m2 = 2.5e-7 ", "inertia_kg_m2 = 1e-12 "),
    ("inertia_kg_m2 = 1.0e-3 ", "inertia_kg_m2 = 1e-9 "),
];
const LIGHT_MOTOR: Edit = &[("inertia_kg_m2 = 2.5e-7 ", "inertia_kg_m2 = 5e-9 ")];
const HINGE_3000: Edit = &[("hinge_stiffness = 0.0 ", "hinge_stiffness = 3000.0 ")];
const HINGE_1E5: Edit = &[("hinge_stiffness = 0.0 ", "hinge_stiffness = 1.0e5 ")];
const FRICTIONLESS: Edit = &[
    (
        "coulomb_friction_nm = 2.0e-4 ",
        "coulomb_friction_nm = 0.0 ",
    ),
    (
        "coulomb_friction_nm = 5.0e-3 ",
        "coulomb_friction_nm = 0.0 ",
    ),
];

/// Every case, in the order of the document.
pub fn cases() -> Vec<Case> {
    let c = |what, params, args, value, reason, cause| Case {
        what,
        params,
        args,
        value,
        reason,
        cause,
    };
    let f_ar = (Some("/f_ar_hz"), "/f_ar_reason");
    let f_r = (Some("/f_r_hz"), "/f_r_reason");
    let peak = (Some("/f_gain_peak_hz"), "/f_gain_peak_reason");
    let notch = (None, "/f_ar_reason");
    let backlash = (Some("/max_backlash_deg"), "/max_backlash_reason");
    let volts = (Some("/min_vpk"), "/min_vpk_reason");
    let res10: &[&str] = &["resonances", "--vpk", "10"];
    vec![
        c("10 H winding (L/R = 0.3 s): the current at the notch cannot move the load against its friction", L10, res10, f_ar.0, f_ar.1, Cause::LoadNotDriven),
        c("10 H winding, a short Bode plot around the notch", L10, &["bode", "--vpk", "10", "--from", "100", "--to", "150", "--step", "10"], notch.0, notch.1, Cause::LoadNotDriven),
        c("10 H winding, 0.02° backlash: the describing function lowers the notch to 27 Hz, where the load would move, but no frequency stands out of the simulated response's spread", L10, &["resonances", "--vpk", "10", "--backlash-deg", "0.02"], f_ar.0, f_ar.1, Cause::Flat),
        c("10 H winding: the gain peak", L10, res10, peak.0, peak.1, Cause::Flat),
        c("10 H winding without friction: the plant has its notch, the response around it is at the analyser's resolution (−80 dB)", L10_FRICTIONLESS, &["bode", "--vpk", "10", "--from", "100", "--to", "300", "--step", "10"], notch.0, notch.1, Cause::Shallow),
        c("Inertias 1e-12 / 1e-9 kg·m²: f_AR = 127.6 kHz", TINY_INERTIAS, res10, f_ar.0, f_ar.1, Cause::AboveNyquist),
        c("Inertias 1e-12 / 1e-9 kg·m²: f_R", TINY_INERTIAS, res10, f_r.0, f_r.1, Cause::AboveNyquist),
        c("Inertias 1e-12 / 1e-9 kg·m²: a Bode plot", TINY_INERTIAS, &["bode", "--vpk", "10", "--from", "100", "--to", "110", "--step", "10"], notch.0, notch.1, Cause::AboveNyquist),
        c("Inertias 1e-12 / 1e-9 kg·m²: max-backlash", TINY_INERTIAS, &["max-backlash", "--bandwidth-hz", "100", "--vpk", "10"], backlash.0, backlash.1, Cause::AboveNyquist),
        c("Inertias 1e-12 / 1e-9 kg·m²: min-voltage", TINY_INERTIAS, &["min-voltage", "--bandwidth-hz", "100", "--backlash-deg", "0.05"], volts.0, volts.1, Cause::AboveNyquist),
        c("Motor inertia 5e-9 kg·m²: f_AR resolved, f_R = 1148 Hz", LIGHT_MOTOR, res10, f_r.0, f_r.1, Cause::AboveNyquist),
        c("Hinge spring 3000 N·m/rad: the notch moves to 304 Hz", HINGE_3000, res10, f_ar.0, f_ar.1, Cause::AtRangeEdge),
        c("Hinge spring 1e5 N·m/rad: the notch moves to 1.6 kHz", HINGE_1E5, res10, f_ar.0, f_ar.1, Cause::AboveNyquist),
        c("10° backlash at 10 V: the describing function puts f_AR at 9.3 Hz", &[], &["resonances", "--vpk", "10", "--backlash-deg", "10"], f_ar.0, f_ar.1, Cause::AtRangeEdge),
        c("1 V with 0.08° backlash: friction and the gap leave no notch", &[], &["resonances", "--vpk", "1", "--backlash-deg", "0.08"], f_ar.0, f_ar.1, Cause::AtRangeEdge),
        c("Nothing settles: every frequency from rest, 10 ms each", &[], &["resonances", "--vpk", "10", "--backlash-deg", "0.08", "--cold-start", "--max-time-s", "0.01"], f_ar.0, f_ar.1, Cause::NotSettled),
        c("A bandwidth above f_AR without backlash", &[], &["max-backlash", "--bandwidth-hz", "500", "--vpk", "10"], backlash.0, backlash.1, Cause::NeverReached),
        c("A bandwidth still met with the model's largest backlash", &[], &["max-backlash", "--bandwidth-hz", "20", "--vpk", "1000"], backlash.0, backlash.1, Cause::AlwaysReached),
        c("10 H winding: no anti-resonance even without backlash", L10, &["max-backlash", "--bandwidth-hz", "100", "--vpk", "10"], backlash.0, backlash.1, Cause::NeverReached),
        c("A bandwidth above f_AR at every voltage", &[], &["min-voltage", "--bandwidth-hz", "500", "--backlash-deg", "0.05"], volts.0, volts.1, Cause::NeverReached),
        c("Nothing settles at any voltage (from rest, 10 ms per frequency)", &[], &["min-voltage", "--bandwidth-hz", "100", "--backlash-deg", "0.05", "--cold-start", "--max-time-s", "0.01"], volts.0, volts.1, Cause::NeverReached),
        c("No friction, no backlash: f_AR does not depend on the voltage", FRICTIONLESS, &["min-voltage", "--bandwidth-hz", "100", "--backlash-deg", "0"], volts.0, volts.1, Cause::AlwaysReached),
        c("10 H winding: the paper's design points", L10, &["paper", "--out", "DIR"], Some("/design_points/0/max_backlash_deg"), "/design_points/0/max_backlash_reason", Cause::NeverReached),
    ]
}

/// What the tool said for one case.
pub struct Row {
    /// The case's description.
    pub what: &'static str,
    /// The command line as documented.
    pub command: String,
    /// Exit status (0: success).
    pub status: i32,
    /// The value at the case's pointer (`None`: no such key).
    pub value: Option<Value>,
    /// The cause code at the case's pointer.
    pub cause: String,
    /// The reason sentence.
    pub reason: String,
    /// The text output (without `--json`).
    pub text: String,
}

/// Runs one case through the command line, with and without `--json`.
pub fn run_case(case: &Case, scratch: &std::path::Path) -> Row {
    let params = (!case.params.is_empty()).then(|| {
        let mut toml = REFERENCE_TOML.to_string();
        for (from, to) in case.params {
            assert!(toml.contains(from), "edit `{from}` does not apply");
            toml = toml.replacen(from, to, 1);
        }
        let path = scratch.join("act.toml");
        std::fs::write(&path, toml).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        path
    });
    let out = scratch.join("out");
    let args: Vec<String> = case
        .args
        .iter()
        .map(|a| {
            if *a == "DIR" {
                out.display().to_string()
            } else {
                a.to_string()
            }
        })
        .collect();
    let mut line: Vec<String> = case.args.iter().map(|a| a.to_string()).collect();
    if params.is_some() {
        line.extend(["--params".to_string(), "act.toml".to_string()]);
    }
    let invoke = |json: bool| {
        let mut argv: Vec<String> = vec!["geared-servo".into()];
        if json {
            argv.push("--json".into());
        }
        argv.extend(args.iter().cloned());
        if let Some(p) = &params {
            argv.extend(["--params".to_string(), p.display().to_string()]);
        }
        run(&Cli::try_parse_from(argv).unwrap_or_else(|e| panic!("{}: {e}", case.what)))
    };
    let (json, text) = match (invoke(true), invoke(false)) {
        (Ok(j), Ok(t)) => (j.json, t.text),
        (Err(e), _) | (_, Err(e)) => {
            return Row {
                what: case.what,
                command: line.join(" "),
                status: e.exit_code(),
                value: None,
                cause: String::new(),
                reason: e.message,
                text: String::new(),
            }
        }
    };
    let cause_ptr = case.reason.replace("_reason", "_cause");
    let string = |ptr: &str| {
        json.pointer(ptr)
            .and_then(Value::as_str)
            .unwrap_or("")
            .to_string()
    };
    Row {
        what: case.what,
        command: line.join(" "),
        status: 0,
        value: case.value.and_then(|p| json.pointer(p).cloned()),
        cause: string(&cause_ptr),
        reason: string(case.reason),
        text,
    }
}

/// Every case run, each in its own scratch directory.
pub fn rows() -> Vec<Row> {
    cases()
        .iter()
        .enumerate()
        .map(|(i, case)| {
            let scratch =
                std::env::temp_dir().join(format!("gs-no-answer-{}-{i}", std::process::id()));
            std::fs::create_dir_all(&scratch)
                .unwrap_or_else(|e| panic!("{}: {e}", scratch.display()));
            let row = run_case(case, &scratch);
            // Best effort: a leftover scratch directory does not change any result.
            let _ = std::fs::remove_dir_all(&scratch);
            row
        })
        .collect()
}

/// The catalogue as Markdown, from the rows of [`rows`].
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::from(
        "# No answer: valid input, no number, and why\n\n\
         Generated by `cargo run -p geared-servo-host-tests --example no_answer_catalogue`;\n\
         `host-tests/tests/no_answer_catalogue.rs` fails if this file and the tool disagree and\n\
         checks every row: exit status 0, the value null in `--json` with `*_reason` (the\n\
         sentence) and `*_cause` (the code) beside it, and the same sentence in the text output\n\
         (`bode`, which has no value, adds the keys and a `notice:` line). The sibling of\n\
         [bad-input.md](bad-input.md): there the input is wrong; here it is right and the\n\
         answer does not exist or cannot be resolved by the simulation.\n\
         Parameter edits are of the bundled reference file, shown as `act.toml`.\n\n\
         ## Causes\n\n\
         The criteria, from the physics and from what the simulation resolves, are documented\n\
         in `geared_servo_host::no_answer`; they are checked in this order.\n\n\
         | cause | meaning |\n|---|---|\n",
    );
    for c in Cause::ALL {
        s += &format!("| `{}` | {} |\n", c.code(), c.meaning());
    }
    s += "\n## Cases\n\n| case | command | exit | value | cause | reason |\n|---|---|---|---|---|---|\n";
    for (case, r) in cases().iter().zip(rows) {
        let edits: Vec<String> = case
            .params
            .iter()
            .map(|(from, to)| format!("`{}` → `{}`", from.trim(), to.trim()))
            .collect();
        let what = if edits.is_empty() {
            r.what.to_string()
        } else {
            format!("{} ({})", r.what, edits.join(", "))
        };
        let value = match (case.value, &r.value) {
            (Some(p), Some(v)) => format!("`{}` = {v}", p.trim_start_matches('/')),
            (Some(p), None) => format!("`{}` missing", p.trim_start_matches('/')),
            (None, _) => "–".to_string(),
        };
        s += &format!(
            "| {what} | `geared-servo {}` | {} | {value} | `{}` | {} |\n",
            r.command,
            r.status,
            r.cause,
            r.reason.replace('|', "\\|")
        );
    }
    s
}
