//! Records as users have them (issue 13): a time base that jitters by a few per cent is
//! resampled with one warning and gives the same diagnosis as the uniform record; a record
//! carrying only the load angle, or only the current, works with `simulate` and `diagnose`.

use geared_servo::{ActuatorParams, Effect, Plant, PlantState, REFERENCE};
use geared_servo_host::calibrate::Data;
use geared_servo_host::diagnose::{diagnose, Options};
use geared_servo_host::record;
use geared_servo_host::synth::{self};
use geared_servo_host_tests::cli::cli;
use geared_servo_host_tests::records::square;
use geared_servo_host_tests::scenario::{perturbed, spec, NOISE_V};
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::path::{Path, PathBuf};

/// Fine steps per nominal period of the bench simulation: the jittered instants are
/// placed on this grid (1 % of a period, a third of the jitter tested).
const FINE: usize = 100;

/// A bench record of `truth` driven by `volts` (one command per row), as CSV text: row k is
/// sampled at t_k = k h + e_k, then its command is held until t_{k+1}, with e_k uniform in
/// ±`jitter` h (0: a uniform record). The plant runs at h/100, so switching and sampling
/// fall on the instants themselves (rounded to 1 % of h); the same tachometer noise (of
/// standard deviation `noise`, V) is added either way.
fn bench_csv(truth: &ActuatorParams, volts: &[f64], jitter: f64, noise: f64) -> String {
    let h = truth.sample_period_s;
    let mut fine = *truth;
    fine.sample_period_s = h / FINE as f64;
    let plant = Plant::new(&fine).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
    let noise = Normal::new(0.0, noise).unwrap();
    // Instants in fine steps, strictly increasing.
    let at: Vec<usize> = (0..volts.len())
        .map(|k| {
            let e = if jitter > 0.0 {
                rng.gen_range(-jitter..jitter)
            } else {
                0.0
            };
            ((k as f64 + e) * FINE as f64).round().max(0.0) as usize
        })
        .collect();
    let mut st = PlantState::REST;
    let mut text = String::from("time_s,motor_voltage_v,tach_voltage_v\n");
    let mut j = 0usize;
    for (k, (&v, &t)) in volts.iter().zip(&at).enumerate() {
        // Advance to this row's instant under the previous command.
        let prev = if k == 0 { 0.0 } else { volts[k - 1] };
        while j < t {
            plant.step(&mut st, prev as f32);
            j += 1;
        }
        let y = f64::from(plant.outputs(&st).tach_voltage_v) + noise.sample(&mut rng);
        text.push_str(&format!("{},{v},{y}\n", t as f64 * fine.sample_period_s));
    }
    text
}

/// The verdict that matters to a user: which effects were added (with their values), and
/// whether the residual was left unexplained.
fn verdict(text: &str, name: &str) -> (Vec<(Effect, f64)>, bool, f64, usize) {
    let rec = record::parse(text, name, true).unwrap();
    let warnings = rec.warnings.len();
    for w in &rec.warnings {
        eprintln!("{w}");
    }
    let d = Data::from_record(&rec, name).unwrap();
    let out = diagnose(&REFERENCE, &[d], None, &Options::default()).unwrap();
    let steps = out.steps.iter().map(|s| (s.effect, s.value)).collect();
    (steps, out.unexplained, out.final_analysis.nrmse, warnings)
}

/// 3 % timestamp jitter (the instants, so intervals vary by up to ±6 %) on the diagnosis
/// scenario with a hidden load viscous friction: the record is resampled with one warning,
/// and `diagnose` adds the same effect with the same value (within 5 %) and ends at the same
/// error (within 10 %) as on the uniform record. No backlash, so no rattle: both records
/// are predictable.
#[test]
fn three_percent_jitter_gives_the_verdict_of_the_uniform_record() {
    let mut truth = perturbed();
    truth.effects.set(Effect::LoadViscous, 1.0e-2);
    let mut s = spec(false, 0.0);
    s.duration_s = 2.0;
    let volts = synth::synthesize(&truth, &s).unwrap().motor_voltage_v;
    let (u_steps, u_unexpl, u_nrmse, u_warn) =
        verdict(&bench_csv(&truth, &volts, 0.0, NOISE_V), "uniform");
    let (j_steps, j_unexpl, j_nrmse, j_warn) =
        verdict(&bench_csv(&truth, &volts, 0.03, NOISE_V), "jittered");
    eprintln!("uniform: {u_steps:?} unexplained {u_unexpl} final NRMSE {u_nrmse:.4}");
    eprintln!("jittered: {j_steps:?} unexplained {j_unexpl} final NRMSE {j_nrmse:.4}");
    assert_eq!((u_warn, j_warn), (0, 1));
    assert_eq!(u_unexpl, j_unexpl);
    assert_eq!(
        u_steps.iter().map(|s| s.0).collect::<Vec<_>>(),
        j_steps.iter().map(|s| s.0).collect::<Vec<_>>()
    );
    assert_eq!(u_steps.first().map(|s| s.0), Some(Effect::LoadViscous));
    for ((_, a), (_, b)) in u_steps.iter().zip(&j_steps) {
        assert!(((a - b) / a).abs() <= 0.05, "{a} vs {b}");
    }
    assert!(
        ((j_nrmse - u_nrmse) / u_nrmse).abs() <= 0.1,
        "{u_nrmse} vs {j_nrmse}"
    );
}

/// Resampling is what makes a jittered record fit: without noise, the true actuator predicts
/// the resampled record better than the same rows taken as if uniform (which misplaces each
/// sample and each switch by up to 3 % of a period).
#[test]
fn resampling_fits_the_true_actuator_better_than_ignoring_the_jitter() {
    let truth = perturbed();
    let mut s = spec(false, 0.0);
    s.duration_s = 1.0;
    let volts = synth::synthesize(&truth, &s).unwrap().motor_voltage_v;
    let text = bench_csv(&truth, &volts, 0.03, 0.0);
    let resampled = record::parse(&text, "jittered", true).unwrap();
    // The same rows on the nominal grid: what reading the record as uniform would give.
    let mut naive = resampled.clone();
    naive.motor_voltage_v = volts.clone();
    naive.outputs = vec![(
        "tach_voltage_v".into(),
        text.lines()
            .skip(1)
            .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
            .collect(),
    )];
    let mut p = truth;
    p.sample_period_s = resampled.sample_period_s;
    let e = |r: &record::Record| {
        geared_servo_host::calibrate::nrmse(&p, &Data::from_record(r, "r").unwrap())
    };
    let (e_resampled, e_naive) = (e(&resampled), e(&naive));
    eprintln!("true actuator on the jittered record: NRMSE {e_resampled:.2e} resampled, {e_naive:.2e} taken as uniform");
    assert!(e_resampled < 0.5 * e_naive, "{e_resampled} vs {e_naive}");
}

/// A fresh scratch directory for test `name`.
fn scratch(name: &str) -> PathBuf {
    geared_servo_host_tests::cli::scratch("outputs", name)
}

/// `simulate` of a ±10 V square on the rig `params`, cut down to `time_s`,
/// `motor_voltage_v` and `column`: what a rig logging only that sensor has.
fn one_output_record(dir: &Path, params: &Path, column: &str) -> PathBuf {
    let h = 0.0005;
    let volts = square(10.0, 0.1, 1000, h);
    let time: Vec<f64> = (0..volts.len()).map(|k| k as f64 * h).collect();
    let input = dir.join("in.csv");
    record::write(
        &input,
        &[],
        &[("time_s", &time), ("motor_voltage_v", &volts)],
    )
    .unwrap();
    let sim = dir.join("sim.csv");
    let (i, s, p) = (
        input.to_str().unwrap(),
        sim.to_str().unwrap(),
        params.to_str().unwrap(),
    );
    cli(&["--params", p, "simulate", "--input", i, "--output", s]).unwrap();
    let full = record::read(&sim, true).unwrap();
    let y = full.output(column).unwrap().to_vec();
    let meas = dir.join(format!("{column}.csv"));
    record::write(
        &meas,
        &[],
        &[
            ("time_s", &full.time_s),
            ("motor_voltage_v", &full.motor_voltage_v),
            (column, &y),
        ],
    )
    .unwrap();
    meas
}

/// A record with only the load angle, or only the current: read without warnings, a valid
/// input to `simulate`, and `diagnose` fits that output (and says so), bringing the error of
/// a rig whose load inertia is 20 % off well down.
#[test]
fn a_record_with_only_the_load_angle_or_only_the_current_works_everywhere() {
    let dir = scratch("one");
    let toml = geared_servo_host::params_file::REFERENCE_TOML.replacen(
        "inertia_kg_m2 = 1.0e-3 ",
        "inertia_kg_m2 = 1.2e-3 ",
        1,
    );
    let rig = dir.join("rig.toml");
    std::fs::write(&rig, toml).unwrap();
    for column in ["load_angle_deg", "current_a"] {
        let meas = one_output_record(&dir, &rig, column);
        let rec = record::read(&meas, true).unwrap();
        assert!(rec.warnings.is_empty(), "{column}: {:?}", rec.warnings);
        assert_eq!(rec.outputs.len(), 1);
        let m = meas.to_str().unwrap();
        let out = dir.join("out.csv");
        cli(&["simulate", "--input", m, "--output", out.to_str().unwrap()]).unwrap();
        let r = cli(&["--json", "diagnose", "--data", m, "--max-steps", "0"]).unwrap();
        let j = &r.json;
        assert_eq!(j["output"], column);
        let (before, after) = (
            j["nominal"]["nrmse"].as_f64().unwrap(),
            j["final"]["nrmse"].as_f64().unwrap(),
        );
        eprintln!("{column}: NRMSE {before:.4} -> {after:.2e}");
        assert!(
            after.is_finite() && after < 0.5 * before,
            "{column}: {before} -> {after}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
