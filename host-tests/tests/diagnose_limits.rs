//! `diagnose` on data it should not explain with an effect: clean data (noise only) and data
//! with a structural mode outside the candidate list. And the command line's bad-input paths.

use clap::Parser;
use geared_servo::REFERENCE;
use geared_servo_cli::{run, Cli};
use geared_servo_host::diagnose::{diagnose, diagnose_with, Options};
use geared_servo_host::synth;
use geared_servo_host::{ErrorKind, Progress};
use geared_servo_host_tests::scenario::{data, perturbed, record, spec, NOISE_V};
use std::sync::Mutex;

/// A progress sink that keeps the stages reported to it.
#[derive(Default)]
struct Stages(Mutex<Vec<String>>);

impl Progress for Stages {
    fn stage(&self, name: &str) {
        if let Ok(mut v) = self.0.lock() {
            v.push(name.to_string());
        }
    }
}

/// Also: `diagnose_with` reports its phases as they end, from the noise levels to the fine
/// search that finishes a diagnosis without a validation record.
#[test]
fn clean_data_adds_no_effect_and_reaches_the_noise_floor() {
    let (d, floor) = record(&perturbed(), false);
    let stages = Stages::default();
    let out = diagnose_with(&REFERENCE, &[d], None, &Options::default(), &stages).unwrap();
    let stages = stages.0.into_inner().unwrap();
    assert_eq!(
        stages.first().map(String::as_str),
        Some("pass: 1 record, their noise levels estimated"),
        "{stages:?}"
    );
    assert!(
        stages
            .get(1)
            .is_some_and(|s| s.starts_with("pass: base settled, NRMSE 0.")),
        "{stages:?}"
    );
    assert_eq!(
        stages.last().map(String::as_str),
        Some("fine search"),
        "{stages:?}"
    );
    assert!(
        out.steps.is_empty(),
        "added {:?}",
        out.steps.iter().map(|s| &s.effect).collect::<Vec<_>>()
    );
    assert!(!out.unexplained);
    // The default set alone must fit to the noise floor (5 % slack for the fitted noise).
    assert!(
        out.final_analysis.nrmse <= 1.05 * floor,
        "{} vs {floor}",
        out.final_analysis.nrmse
    );
}

/// Adds a second structural mode to the tachometer signal: the clean tachometer passed
/// through a resonant band-pass at `f0` (ζ = 0.02), discretised by the bilinear transform
/// with prewarping, scaled by `gain`. Models a fin-bending mode the 2-mass model lacks.
fn with_second_mode(y: &[f64], h: f64, f0: f64, gain: f64) -> Vec<f64> {
    let w0 = 2.0 * std::f64::consts::PI * f0;
    let zeta = 0.02;
    let c = w0 / (w0 * h / 2.0).tan();
    // H(s) = 2ζω0 s / (s² + 2ζω0 s + ω0²)
    let a0 = c * c + 2.0 * zeta * w0 * c + w0 * w0;
    let b0 = 2.0 * zeta * w0 * c / a0;
    let b2 = -b0;
    let a1 = (2.0 * w0 * w0 - 2.0 * c * c) / a0;
    let a2 = (c * c - 2.0 * zeta * w0 * c + w0 * w0) / a0;
    let (mut x1, mut x2, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0);
    y.iter()
        .map(|&x| {
            let out = b0 * x + b2 * x2 - a1 * y1 - a2 * y2;
            x2 = x1;
            x1 = x;
            y2 = y1;
            y1 = out;
            x + gain * out
        })
        .collect()
}

#[test]
fn a_mode_outside_the_candidates_is_reported_unexplained_with_its_band() {
    let truth = perturbed();
    let mut s = synth::synthesize(&truth, &spec(false, 0.0)).unwrap();
    let f0 = 260.0;
    s.tach_voltage_v = with_second_mode(&s.tach_voltage_v, 0.0005, f0, 2.0);
    // Same noise as the other scenarios, added after the mode.
    let noise = synth::synthesize(&truth, &spec(false, NOISE_V)).unwrap();
    let clean = synth::synthesize(&truth, &spec(false, 0.0)).unwrap();
    for ((y, n), c) in s
        .tach_voltage_v
        .iter_mut()
        .zip(&noise.tach_voltage_v)
        .zip(&clean.tach_voltage_v)
    {
        *y += n - c;
    }
    let d = data(&s);
    let e: f64 = noise
        .tach_voltage_v
        .iter()
        .zip(&clean.tach_voltage_v)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    let floor = e / d.norm;
    let out = diagnose(&REFERENCE, &[d], None, &Options::default()).unwrap();
    eprintln!("{}", out.summary());
    assert!(out.unexplained);
    // An effect may still earn its parameter on part of the residual (a little damping near
    // the mode), but none is claimed with confidence and none explains the mode away.
    assert!(
        out.steps.iter().all(|s| s.partial),
        "claimed {:?}",
        out.steps.iter().map(|s| &s.effect).collect::<Vec<_>>()
    );
    assert!(
        out.final_analysis.nrmse > 1.5 * floor,
        "the mode was explained away"
    );
    let (lo, hi, share) = out.final_analysis.dominant_band();
    assert!(
        lo <= f0 && f0 < hi,
        "band {lo}-{hi} Hz does not hold {f0} Hz"
    );
    assert!(share > 0.5, "{share}");
    assert!(
        (out.final_analysis.peak_hz - f0).abs() < 10.0,
        "{}",
        out.final_analysis.peak_hz
    );
}

fn cli(args: &[&str]) -> Result<geared_servo_cli::Report, geared_servo_host::HostError> {
    let mut v = vec!["geared-servo"];
    v.extend_from_slice(args);
    run(&Cli::try_parse_from(v).unwrap())
}

#[test]
fn each_bad_file_defect_gives_its_error_and_no_panic() {
    let dir = std::env::temp_dir().join(format!("gs-diag-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cases: [(&str, &str, &str); 8] = [
        (
            "empty_field.csv",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,,0\n0.001,1,0\n",
            "line 3, column `motor_voltage_v`: empty field",
        ),
        (
            "non_numeric.csv",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,1,abc\n0.001,1,0\n",
            "line 3, column `tach_voltage_v`: `abc` is not a number",
        ),
        (
            "non_monotonic.csv",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.001,1,0\n0.0005,1,0\n",
            "line 4, column `time_s`",
        ),
        (
            "time_gap.csv",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,1,0\n0.001,1,0\n0.0025,1,0\n0.003,1,0\n",
            "samples are missing",
        ),
        (
            "no_output.csv",
            "time_s,motor_voltage_v\n0,1\n0.0005,1\n",
            "no output column",
        ),
        (
            "no_time.csv",
            "motor_voltage_v,tach_voltage_v\n1,0\n1,0\n",
            "missing required column `time_s`",
        ),
        (
            "short_row.csv",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,1\n",
            "line 3: has 2 fields",
        ),
        (
            "constant.csv",
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,1,0\n0.001,1,0\n",
            "constant",
        ),
    ];
    for (file, text, want) in cases {
        let p = dir.join(file);
        std::fs::write(&p, text).unwrap();
        let e = match cli(&["diagnose", "--data", p.to_str().unwrap()]) {
            Err(e) => e,
            Ok(_) => panic!("{file}: accepted"),
        };
        assert_eq!(e.kind, ErrorKind::BadInput, "{file}: {}", e.message);
        assert!(
            e.message.contains(want),
            "{file}: `{}` lacks `{want}`",
            e.message
        );
        assert!(
            e.message.contains(file),
            "{file}: `{}` does not name the file",
            e.message
        );
    }
    let missing = dir.join("missing.csv");
    let e = cli(&["diagnose", "--data", missing.to_str().unwrap()])
        .err()
        .unwrap();
    assert_eq!(e.kind, ErrorKind::BadInput);
    let e = cli(&[
        "synth",
        "--output",
        dir.join("x.csv").to_str().unwrap(),
        "--effect",
        "bogus=1",
    ])
    .err()
    .unwrap();
    assert!(
        e.message.contains("unknown effect `bogus`"),
        "{}",
        e.message
    );
    let e = cli(&[
        "synth",
        "--output",
        dir.join("x.csv").to_str().unwrap(),
        "--effect",
        "mesh_damping=-1",
    ])
    .err()
    .unwrap();
    assert!(e.message.contains("effects.mesh_damping"), "{}", e.message);
    // An unknown parameter for --fit.
    let ok = dir.join("ok.csv");
    cli(&[
        "synth",
        "--output",
        ok.to_str().unwrap(),
        "--duration",
        "0.5",
    ])
    .unwrap();
    let e = cli(&[
        "diagnose",
        "--data",
        ok.to_str().unwrap(),
        "--fit",
        "motor.bogus",
    ])
    .err()
    .unwrap();
    assert_eq!(e.kind, ErrorKind::BadInput);
    assert!(
        e.message.contains("`motor.bogus` cannot be calibrated"),
        "{}",
        e.message
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn synth_then_diagnose_on_the_command_line_writes_the_report_and_a_loadable_file() {
    let dir = std::env::temp_dir().join(format!("gs-diag-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let meas = dir.join("meas.csv");
    let val = dir.join("val.csv");
    let m = meas.to_str().unwrap();
    let common = [
        "--duration",
        "2",
        "--noise",
        "0.01",
        "--effect",
        "mesh_damping=0.05",
    ];
    let mut a = vec!["synth", "--output", m, "--seed", "4"];
    a.extend_from_slice(&common);
    cli(&a).unwrap();
    let mut a = vec![
        "synth",
        "--output",
        val.to_str().unwrap(),
        "--seed",
        "9",
        "--excitation",
        "chirp",
    ];
    a.extend_from_slice(&common);
    cli(&a).unwrap();
    let text = std::fs::read_to_string(&meas).unwrap();
    assert!(text.contains("# effect_mesh_damping: 0.05") && text.contains("# seed: 4"));
    let out = dir.join("out");
    let r = cli(&[
        "--json",
        "diagnose",
        "--data",
        m,
        "--validate",
        val.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ])
    .unwrap();
    let j = &r.json;
    for k in [
        "samples",
        "sample_period_s",
        "output",
        "nominal",
        "steps",
        "added_effects",
        "final",
        "validation",
        "unexplained",
    ] {
        assert!(j.get(k).is_some(), "missing key {k}");
    }
    assert_eq!(j["samples"], 4000);
    assert_eq!(j["output"], "tach_voltage_v");
    assert_eq!(j["added_effects"][0], "mesh_damping");
    for k in ["effect", "value", "unit", "nrmse_before", "nrmse_after"] {
        assert!(j["steps"][0].get(k).is_some(), "missing steps[0].{k}");
    }
    for k in ["nrmse", "fit_percent", "residual_white"] {
        assert!(j["final"].get(k).is_some(), "missing final.{k}");
    }
    assert!(
        j["validation"]["nrmse_after"].as_f64().unwrap()
            < j["validation"]["nrmse_before"].as_f64().unwrap()
    );
    // The calibrated file loads and carries the effect.
    let p = geared_servo_host::params_file::load(Some(&out.join("calibrated.toml"))).unwrap();
    assert!(
        (p.effects.mesh_damping - 0.05).abs() < 0.01,
        "{}",
        p.effects.mesh_damping
    );
    geared_servo::Plant::new(&p).unwrap();
    for f in ["time.svg", "residual_spectra.svg", "diagnose.json"] {
        assert!(out.join(f).exists(), "{f}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
