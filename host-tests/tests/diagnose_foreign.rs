//! The generalisation suite of `diagnose` (issue 12): records of perturbed units made by the
//! independent reference integrator, not by the emulator (`host-tests/src/foreign.rs`), ten
//! kinds (clean, each effect alone, a pair, a structural mode outside the library) times three
//! draws. Prints one line per case and a summary, then checks the issue's requirements:
//! at least 90 % of verdicts right, no effect added on a clean record, recovered values (the
//! final model's) within 30 % of the truth (after the resistance scale), and a calibrated
//! NRMSE within 1.2 times that of the true parameters on the estimation record (on the rows
//! `diagnose` keeps; for a hidden effect the records cannot show and that is rightly not
//! claimed, no worse than the model without it refitted from the truth — the truth itself is
//! then out of the model's reach). A tachometer gain near the one the unit's own motor
//! constants make ([`ForeignCase::unit_tach_gain`]) is the unit's property, not a hidden
//! effect.

use geared_servo::{ActuatorParams, Effect};
use geared_servo_host::calibrate::{self, Param, BASE_KNOBS};
use geared_servo_host::diagnose::{self, Options, Outcome, Step};
use geared_servo_host_tests::foreign::{
    self, identifiability, ForeignCase, Kind, Making, Sensors, FINE_STEP_S, WITNESS_RATIO,
};
use std::time::{Duration, Instant};

/// Least share of right verdicts.
const MIN_RIGHT: f64 = 0.9;
/// Largest relative error of a recovered effect value.
const VALUE_TOL: f64 = 0.3;
/// A burst the true parameters miss by more than this many noise floors is a rattle span
/// (reported only).
const RATTLE_FLOORS: f64 = 5.0;
/// Largest ratio of the calibrated NRMSE to the true parameters' on the estimation record.
const NRMSE_RATIO: f64 = 1.2;

/// Whether step effect `s` (or one it cannot be told from) is `e`.
fn names(step: &Step, e: Effect) -> bool {
    step.effect == e || step.indistinguishable_from.iter().any(|(x, _)| *x == e)
}

/// Whether `step` is the unit's own tachometer gain error rather than an effect the suite
/// hid: a `tach_gain` the case does not hide, within [`VALUE_TOL`] of the gain error the
/// unit's tachometer and back-EMF constants make together
/// ([`ForeignCase::unit_tach_gain`]; up to 2 %, which the data can show), by its value in
/// the final model ([`final_value`]).
fn is_unit_property(case: &ForeignCase, out: &Outcome, step: &Step) -> bool {
    let g = case.unit_tach_gain();
    step.effect == Effect::TachGain
        && !hides_tach_gain(case)
        && (final_value(out, step) - g).abs() <= VALUE_TOL * g.abs()
}

/// Whether `case` hides a tachometer gain error (beyond the unit's own).
fn hides_tach_gain(case: &ForeignCase) -> bool {
    case.expected.iter().any(|&(e, _)| e == Effect::TachGain)
}

/// The value of `step`'s effect in the final model: what `diagnose` ends with, and what it
/// lists under the final parameters. The step's own value is the one it had when it was
/// added; an effect added later is fitted together with it and can move it (drive_deadband/16:
/// 1.83 V when added, 1.36 V once a tachometer gain was added beside it, the unit's 1.34 V).
fn final_value(out: &Outcome, step: &Step) -> f64 {
    out.final_fit.params.effects.get(step.effect)
}

/// The steps that claim an effect the suite could have hidden (every step but the unit's
/// own tachometer gain error: [`is_unit_property`]).
fn effect_steps<'a>(case: &ForeignCase, out: &'a Outcome) -> Vec<&'a Step> {
    out.steps
        .iter()
        .filter(|s| !is_unit_property(case, out, s))
        .collect()
}

/// The verdict rule of the issue; an effect the records cannot show ([`identifiability`]) is
/// rightly not claimed (a clean verdict), and rightly claimed only as itself. A step that
/// names the unit's own tachometer gain error ([`is_unit_property`]) is neither wrong nor
/// required.
fn verdict_right(case: &ForeignCase, out: &Outcome, identifiable: bool) -> bool {
    let steps = effect_steps(case, out);
    match case.kind {
        Kind::Clean => steps.is_empty() && !out.unexplained,
        Kind::Single(_) if !identifiable && steps.is_empty() => !out.unexplained,
        Kind::Single(e) => steps.len() == 1 && names(steps[0], e) && !out.unexplained,
        // As many steps as the unit has effects, each naming one of them, and each of them
        // named: a third effect the unit lacks makes the verdict wrong, as one added to a
        // single effect's unit does (until 2026-11-29 a pair was right with extra steps).
        Kind::Pair => {
            !out.unexplained
                && steps.len() == case.expected.len()
                && steps
                    .iter()
                    .all(|s| case.expected.iter().any(|&(e, _)| names(s, e)))
                && case
                    .expected
                    .iter()
                    .all(|&(e, _)| steps.iter().any(|s| names(s, e)))
        }
        Kind::OutOfLibrary => out.unexplained,
    }
}

/// Recovered values of the expected effects that were named as themselves: (effect, fitted
/// in the final model ([`final_value`]), expected fitted value, relative error, value when
/// the step added it).
fn recovered(case: &ForeignCase, out: &Outcome) -> Vec<(Effect, f64, f64, f64, f64)> {
    case.expected
        .iter()
        .filter_map(|&(e, v)| {
            let s = out.steps.iter().find(|s| s.effect == e)?;
            let want = case.expected_fitted(e, v);
            let got = final_value(out, s);
            Some((e, got, want, ((got - want) / want).abs(), s.value))
        })
        .collect()
}

fn fmt_expected(case: &ForeignCase) -> String {
    if case.out_of_library {
        let m = case.second_mode.unwrap();
        return format!(
            "mode J2 {:.2e} at {:.0} Hz zeta {:.3}",
            m.inertia_kg_m2, m.frequency_hz, m.damping_ratio
        );
    }
    if case.expected.is_empty() {
        return "-".into();
    }
    case.expected
        .iter()
        .map(|&(e, v)| format!("{e}={v:.3e} (fit {:.3e})", case.expected_fitted(e, v)))
        .collect::<Vec<_>>()
        .join(" + ")
}

fn fmt_steps(out: &Outcome) -> String {
    if out.steps.is_empty() {
        return "none".into();
    }
    out.steps
        .iter()
        .map(|s| {
            let mut t = format!("{}={:.3e} dBIC {:.0}", s.effect, s.value, s.delta_bic);
            if !s.indistinguishable_from.is_empty() {
                let o: Vec<&str> = s
                    .indistinguishable_from
                    .iter()
                    .map(|(e, _)| e.name())
                    .collect();
                t.push_str(&format!(" ~[{}]", o.join(",")));
            }
            if !s.told_apart.is_empty() {
                let o: Vec<&str> = s.told_apart.iter().map(|r| r.effect.name()).collect();
                t.push_str(&format!(" not[{}]", o.join(",")));
            }
            if s.partial {
                t.push_str(" partial");
            }
            t
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// The unit's true parameters as the model carries them (its measured stiffness, the
/// records' sample period: both records are sampled at foreign::SAMPLE_PERIOD_S), and the
/// estimation record on the rows `out` judged predictable, as diagnose sees it (the file's
/// backlash gives the load angle's floor).
fn truth_on_rows(c: &ForeignCase, out: &Outcome) -> (ActuatorParams, calibrate::Data) {
    let mut truth = calibrate::with_measured_stiffness(&c.truth).unwrap();
    truth.sample_period_s = c.estimation.sample_period_s;
    let rows = c
        .estimation
        .with_backlash(c.file.backlash_deg)
        .with_weights(&out.weights.first().cloned().unwrap_or_default());
    (truth, rows)
}

/// The base set of `p` against the truth scaled by s ([`ForeignCase::fitted_scale`]), as
/// "name fitted/expected"; the resistance too when it is fitted (records with the current).
fn fmt_base(case: &ForeignCase, p: &ActuatorParams) -> String {
    let resistance = (case.fitted_scale() == 1.0).then_some(Param::MotorResistance);
    BASE_KNOBS
        .iter()
        .copied()
        .chain(resistance)
        .map(|k| {
            let truth = calibrate::get(&case.truth, k);
            let want = if matches!(k, Param::Backlash | Param::MotorResistance) {
                truth
            } else {
                truth * case.fitted_scale()
            };
            format!(
                "{} {:+.1}%",
                k.name().rsplit('.').next().unwrap_or(""),
                100.0 * (calibrate::get(p, k) / want - 1.0)
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

struct Row {
    label: String,
    kind: Kind,
    right: bool,
    values_ok: bool,
    /// Expected effects named as themselves (their values were checked).
    named: usize,
    nrmse_ok: bool,
    /// The first output alone within its bar (reported: a record with several outputs is
    /// judged on all of them).
    first_ok: bool,
    steps_on_clean: bool,
    /// A step named the unit's own tachometer gain error ([`is_unit_property`]).
    unit_tach: bool,
    identifiable: bool,
    wall: Duration,
    error: Option<String>,
}

// Issue 12's acceptance test (2026-11-27: 47 of 48 verdicts right, every value within 30 %,
// nothing added on a clean unit; the final NRMSE over its bar on stiction_ratio/1 and
// gravity_torque/1, 1.33x and 1.21x the truth's on their rows, so it fails on the bar). At
// about an hour on 2 cores (52 min for 43 cases of draws 15–17 on 2026-11-28) it is beyond
// CI's budget (docs/diagnose.md, "On records the emulator did not make"). Run it with
// `cargo test --release -p geared-servo-host-tests --test diagnose_foreign -- --ignored --nocapture`
// (`GS_FOREIGN_CASES=tach_lag/0,pair/1` for a subset; `GS_FOREIGN_DRAWS=3..6` for other
// draws: 47 of 48 there on 2026-11-27, one bar missed; `GS_FOREIGN_DRAWS=9..12`: 42 of 48
// there the same day when fresh, two bars missed; 46 of 48 and every bar met on 2026-11-28
// after three judge changes made on them, so they are no longer held out; draws 12–14,
// 15–17, 18–20 and 21–23 have since been run too (README.md's table, docs/diagnose.md);
// draws 24–26 since (47 of 48), 27–29 (40 of 48), 30–32 (44 of 48), 33–35 (43 of 48), 36–38 (45 of 48)
// 39–41 (47 of 48) and 42–44 (46 of 48); 45–47 are held out. Those figures counted a pair right with a third,
// spurious step; since 2026-11-29 `verdict_right` does not: draws 21–23, 47 → 45 of 48. They
// also used the weaker witness of `identifiability` before 2026-12-02, which counted eleven
// stiction units wrong that the records cannot show: docs/diagnose.md).
#[test]
#[ignore = "issue 12 acceptance suite (draws 0-2, 48 cases, about an hour on 2 cores): beyond CI's budget; scores in README.md and docs/diagnose.md; run with --ignored"]
fn diagnose_names_effects_in_records_of_the_independent_reference() {
    let t_all = Instant::now();
    // `RUST_LOG=geared_servo_host::diagnose=debug` prints each diagnosis's trace (its
    // rounds, the resettle's ratios) before the case's verdict line.
    let _ = env_logger::builder().is_test(true).try_init();

    // The reference's fine step: 2 µs against 1 µs (and 0.5 µs, which marks the chaotic
    // bursts where no step converges sample by sample) on one clean estimation record.
    let t = Instant::now();
    let (bursts, whole_2, whole_05) = foreign::fine_step_check(Kind::Clean, 0).unwrap();
    eprintln!(
        "fine-step check (clean/0 estimation record, {:.1} s): whole record {:.2e} at {:.0} us, {:.2e} at 0.5 us, relative to 1 us",
        t.elapsed().as_secs_f64(),
        whole_2,
        FINE_STEP_S * 1e6,
        whole_05
    );
    let mut worst_calm: f64 = 0.0;
    let mut chaotic = Vec::new();
    for b in &bursts {
        let rattle = b.half_vs_1us > 1e-3;
        eprintln!(
            "  burst {:6.1} Hz: 2us-1us {:.2e}, 0.5us-1us {:.2e}{}",
            b.f_hz,
            b.coarse_vs_1us,
            b.half_vs_1us,
            if rattle { "  (rattle)" } else { "" }
        );
        if rattle {
            chaotic.push(b.f_hz);
        } else {
            worst_calm = worst_calm.max(b.coarse_vs_1us);
        }
    }
    eprintln!(
        "  worst 2us-1us gap outside rattle bursts: {worst_calm:.2e} (noise is {:.0e}); rattle bursts: {chaotic:.0?}",
        foreign::NOISE_REL
    );

    let t = Instant::now();
    // A subset for development (`GS_FOREIGN_CASES=tach_lag/0,pair/1`): the summary and the
    // checks are then over those cases alone. `GS_FOREIGN_SECONDS=20` makes the estimation
    // records' stepped sines that long (the benchmark's 50 bursts, which the global search
    // sees thinned: calibrate::thinned); the bars are the same.
    // `GS_FOREIGN_DRAWS=3..6`: other draws than the suite's (units, effect values and noise
    // that no change was ever tried on: a held-out check of the method).
    let draws = match std::env::var("GS_FOREIGN_DRAWS") {
        Ok(s) => {
            let (a, b) = s
                .split_once("..")
                .expect("GS_FOREIGN_DRAWS: a range such as 3..6");
            let a: u64 = a.trim().parse().expect("GS_FOREIGN_DRAWS: first draw");
            let b: u64 = b.trim().parse().expect("GS_FOREIGN_DRAWS: end draw");
            assert!(a < b, "GS_FOREIGN_DRAWS={s}: empty range");
            a..b
        }
        Err(_) => foreign::SUITE_DRAWS,
    };
    let mut jobs = foreign::jobs(draws);
    if let Ok(only) = std::env::var("GS_FOREIGN_CASES") {
        let wanted: Vec<&str> = only.split(',').map(str::trim).collect();
        jobs.retain(|&(k, d)| wanted.contains(&foreign::label(k, d).as_str()));
        assert!(!jobs.is_empty(), "GS_FOREIGN_CASES={only}: no such case");
    }
    let making = foreign::Making::from_env();
    let cases = foreign::cases_with(&jobs, &making).unwrap();
    let gen = t.elapsed();
    eprintln!(
        "generated {} cases in {:.1} s (estimation {:.1} s, validation {:.1} s of 2 kHz data each)",
        cases.len(),
        gen.as_secs_f64(),
        cases[0].estimation.y.len() as f64 * foreign::SAMPLE_PERIOD_S,
        cases[0].validation.y.len() as f64 * foreign::SAMPLE_PERIOD_S,
    );
    eprintln!(
        "  (est: true-parameter NRMSE of the emulator on the estimation record; 'outside' is that NRMSE without the bursts it misses by more than {RATTLE_FLOORS} x their own noise floor, listed after 'rattle' with their share of its residual energy)"
    );
    for c in &cases {
        let r = c.rattle(RATTLE_FLOORS);
        eprintln!(
            "  {:<18} s {:.3}  est: true {:.4} (outside {:.4}) floor {:.4}  val: true {:.4} floor {:.4}  {}{}\n      rattle {:.0?} Hz, {:.0} % of the true residual",
            c.label(),
            c.resistance_scale,
            c.true_nrmse_estimation,
            r.nrmse_outside,
            c.estimation_floor,
            c.true_nrmse_validation,
            c.validation_floor,
            fmt_expected(c),
            if c.estimation_record.output("load_angle_deg").is_some() {
                "  [+load angle]"
            } else {
                ""
            },
            r.bursts_hz,
            (100.0 * r.residual_share).max(0.0)
        );
    }

    let mut rows = Vec::new();
    for c in &cases {
        let t = Instant::now();
        let res = c.diagnose(&Options::default());
        let wall = t.elapsed();
        let out = match res {
            Ok(o) => o,
            Err(e) => {
                eprintln!("{:<18} ERROR {e} ({:.1} s)", c.label(), wall.as_secs_f64());
                rows.push(Row {
                    label: c.label(),
                    kind: c.kind,
                    right: false,
                    values_ok: false,
                    named: 0,
                    nrmse_ok: false,
                    first_ok: false,
                    steps_on_clean: c.kind == Kind::Clean,
                    unit_tach: false,
                    identifiable: true,
                    wall,
                    error: Some(e.to_string()),
                });
                continue;
            }
        };
        let mut id = identifiability(c);
        // The diagnosis's own final model, when it claims no effect, is a model without the
        // hidden effect too: within WITNESS_RATIO of the truth on both records, on the
        // truth's rows as the refitted witness is judged, it is the witness (the refitted
        // one stopped further out; stiction_ratio/62: a final 1.08x the truth on its rows).
        if id.identifiable && matches!(c.kind, Kind::Single(_)) && effect_steps(c, &out).is_empty()
        {
            let n = foreign::on_truth_rows(c, &out.final_fit.params);
            eprintln!(
                "    the final model on the truth's predictable rows: NRMSE {:.4} (truth {:.4}) on the estimation record, {:.4} (truth {:.4}) on the validation record; the refitted witness {:.4}, {:.4}",
                n[1], n[0], n[3], n[2], id.nrmse[1], id.nrmse[3]
            );
            if n[1] <= WITNESS_RATIO * n[0] && n[3] <= WITNESS_RATIO * n[2] {
                id.identifiable = false;
                id.nrmse = n;
                id.witness = Some(out.final_fit.params);
            }
        }
        if !id.identifiable {
            eprintln!(
                "    not identifiable from these records: without the effect, refitted, NRMSE {:.4} (truth {:.4}) on the estimation record and {:.4} (truth {:.4}) on the validation record, on the truth's predictable rows",
                id.nrmse[1], id.nrmse[0], id.nrmse[3], id.nrmse[2]
            );
        }
        let right = verdict_right(c, &out, id.identifiable);
        let rec = recovered(c, &out);
        let values_ok = rec.iter().all(|r| r.3 <= VALUE_TOL);
        // Like with like: the true parameters on the rows diagnose judged predictable.
        let fin = out.final_analysis.nrmse;
        // The estimation record on diagnose's predictable rows as diagnose sees it: every
        // output it has, each in units of its own floor (`calibrate::Channel`, the load
        // angle's with the file's gap). A record with several outputs is fitted on all of
        // them, so its bar compares that cost, final against truth on the same rows
        // (`calibrate::nrmse_all`, the first output's NRMSE when it has one); the first
        // output's ratio is reported beside it.
        let (truth, est_rows) = truth_on_rows(c, &out);
        let truth_pred = calibrate::nrmse(&truth, &est_rows);
        let multi = !est_rows.extra.is_empty();
        let score = |p: &ActuatorParams| calibrate::nrmse_all(p, &est_rows);
        let (fin_all, truth_all) = (score(&out.final_fit.params), score(&truth));
        // A hidden effect the records cannot show, rightly not claimed: the final model has no
        // such effect, and the truth (which has it) is out of its reach; the bar is then the
        // witness (the best model without it that we know, refitted from the truth) on the
        // same rows, without slack.
        let claimed = effect_steps(c, &out);
        let witness_rows = match (id.identifiable, id.witness, claimed.is_empty()) {
            (false, Some(wp), true) => {
                let x = score(&wp);
                eprintln!(
                    "    the witness on diagnose's predictable rows of the estimation record: NRMSE {x:.4}"
                );
                Some(x)
            }
            _ => None,
        };
        eprintln!(
            "    predictable rows {:.1} % of the estimation record: final {fin:.4}, true parameters {truth_pred:.4}, floor {:.4}; every row: final {:.4}",
            100.0 * (1.0 - out.unpredictable_share.first().copied().unwrap_or(0.0)),
            out.floor_nrmse,
            out.final_nrmse_all_rows
        );
        // Reported only: the same on the validation record when the fit used it.
        if let Some(w) = out
            .weights
            .get(1)
            .filter(|w| w.len() == c.validation.y.len())
        {
            let v = c.validation.with_weights(w);
            eprintln!(
                "    predictable rows of the validation record: final {:.4}, true parameters {:.4}",
                calibrate::nrmse(&out.final_fit.params, &v),
                calibrate::nrmse(&truth, &v)
            );
        }
        let nrmse_ok =
            fin_all <= NRMSE_RATIO * truth_all || witness_rows.is_some_and(|x| fin_all <= x);
        let first_ok = fin <= NRMSE_RATIO * truth_pred;
        if multi {
            eprintln!(
                "    every output (the fit's cost, first output's unit): final {fin_all:.4}, true parameters {truth_all:.4} ({:.2}x); the first output alone {:.2}x",
                fin_all / truth_all,
                fin / truth_pred
            );
        }
        let (vb, va) = out.validation.unwrap_or((f64::NAN, f64::NAN));
        eprintln!(
            "{:<18} {} expected {} | steps {} | unexplained {} | nrmse nominal {:.4} base {:.4} final {:.4} (true {:.4}, floor {:.4}){} | validation {:.4} -> {:.4} (true {:.4}, floor {:.4}) | {:.1} s",
            c.label(),
            if right { "RIGHT" } else { "WRONG" },
            fmt_expected(c),
            fmt_steps(&out),
            out.unexplained,
            out.nominal_analysis.nrmse,
            out.base_analysis.nrmse,
            fin,
            c.true_nrmse_estimation,
            c.estimation_floor,
            if nrmse_ok { "" } else { " TOO HIGH" },
            vb,
            va,
            c.true_nrmse_validation,
            c.validation_floor,
            wall.as_secs_f64()
        );
        let hidden_gain = hides_tach_gain(c);
        for s in out
            .steps
            .iter()
            .filter(|s| s.effect == Effect::TachGain && !hidden_gain)
        {
            eprintln!(
                "    tach_gain {:.4e}: {} the unit's own tachometer gain error (its tachometer and back-EMF constants: {:.4e})",
                final_value(&out, s),
                if is_unit_property(c, &out, s) { "is" } else { "is not" },
                c.unit_tach_gain()
            );
        }
        for (e, got, want, err, added) in &rec {
            eprintln!(
                "    {e}: fitted {got:.4e} (when added {added:.4e}), expected {want:.4e} (error {:.1} %){}",
                100.0 * err,
                if *err <= VALUE_TOL { "" } else { " OUT" }
            );
        }
        // How the verdict's residual was read: its kind, whether the validation record was
        // fitted, and per record whose command repeats, the residual's RMS and the part of
        // it that repeats with the command, over the record's noise level.
        let rep = |r: &Option<geared_servo_host::repeat::Repeating>| match r {
            Some(r) => format!(
                "{:.2}/{:.2} sigma",
                r.mean_square.sqrt() / r.noise_sigma,
                r.repeating_mean_square.sqrt() / r.noise_sigma
            ),
            None => "-".into(),
        };
        // Per record: the bursts mostly coherent / those the model reaches from another rest
        // position of the gears, and the coherent part's RMS over the noise.
        let coh = |c: &Option<geared_servo_host::repeat::Coherent>| match c {
            Some(c) => format!(
                "{}/{} bursts {:.2} sigma",
                c.coherent_bursts,
                c.other_response_bursts,
                c.coherent_mean_square.sqrt() / c.noise_sigma
            ),
            None => "-".into(),
        };
        // The base with a background quantity (the mesh damping) at the top of its range:
        // `diagnose` then tries it as an effect even below the material line.
        eprintln!(
            "    residual {} (robust x{:.2}); background at its top: base {}, final {}; validation in fit {}; residual/repeating per record {:?}, held-out validation {}; coherent/other response {:?}",
            out.residual.name(),
            out.robust_floor_ratio,
            calibrate::background_at_top(&out.base),
            calibrate::background_at_top(&out.final_fit),
            out.validation_in_fit.is_some(),
            out.repeating.iter().map(rep).collect::<Vec<_>>(),
            rep(&out.validation_repeating),
            out.coherent.iter().map(coh).collect::<Vec<_>>()
        );
        if !right || !values_ok || !nrmse_ok {
            eprintln!(
                "    base fit vs truth x s: {}",
                fmt_base(c, &out.base.params)
            );
            eprintln!(
                "    final fit vs truth x s: {}",
                fmt_base(c, &out.final_fit.params)
            );
            eprintln!(
                "    final residual: white {} bands {:?} regimes {:?} peak {:.1} Hz",
                out.final_analysis.white,
                out.final_analysis
                    .bands
                    .iter()
                    .map(|b| format!("{:.0}-{:.0} Hz {:.2}", b.0, b.1, b.2))
                    .collect::<Vec<_>>(),
                out.final_analysis
                    .regimes
                    .iter()
                    .map(|r| format!("{} {:.2}/{:.2}", r.0, r.1, r.2))
                    .collect::<Vec<_>>(),
                out.final_analysis.peak_hz
            );
            eprintln!(
                "    last scores {:?}; rejected {:?}",
                out.last_scores
                    .iter()
                    .map(|s| format!("{} {:.4} @{:.2e}", s.0, s.1, s.2))
                    .collect::<Vec<_>>(),
                out.rejected
                    .iter()
                    .map(|r| format!("{} {:.3e}: {}", r.effect, r.value, r.reason))
                    .collect::<Vec<_>>()
            );
            for s in &out.steps {
                eprintln!(
                    "    step {} scores {:?}",
                    s.effect,
                    s.scores
                        .iter()
                        .map(|x| format!("{} {:.4}", x.0, x.1))
                        .collect::<Vec<_>>()
                );
            }
        }
        rows.push(Row {
            label: c.label(),
            kind: c.kind,
            right,
            values_ok,
            named: rec.len(),
            nrmse_ok,
            first_ok,
            steps_on_clean: c.kind == Kind::Clean && !claimed.is_empty(),
            unit_tach: claimed.len() < out.steps.len(),
            identifiable: id.identifiable,
            wall,
            error: None,
        });
    }

    // Summary.
    let n = rows.len();
    let n_right = rows.iter().filter(|r| r.right).count();
    let total: Duration = rows.iter().map(|r| r.wall).sum();
    let slowest = rows.iter().map(|r| r.wall).max().unwrap_or_default();
    eprintln!(
        "\nsummary: {n_right}/{n} verdicts right (need {:.0} %)",
        100.0 * MIN_RIGHT
    );
    for k in Kind::all() {
        let of: Vec<&Row> = rows.iter().filter(|r| r.kind == k).collect();
        eprintln!(
            "  {:<16} right {}/{}  effects named as themselves {}, values ok in {}/{} cases  nrmse ok {}/{}",
            k.name(),
            of.iter().filter(|r| r.right).count(),
            of.len(),
            of.iter().map(|r| r.named).sum::<usize>(),
            of.iter().filter(|r| r.values_ok).count(),
            of.len(),
            of.iter().filter(|r| r.nrmse_ok).count(),
            of.len()
        );
    }
    let labels = |pick: fn(&Row) -> bool| -> Vec<&str> {
        rows.iter()
            .filter(|r| pick(r))
            .map(|r| r.label.as_str())
            .collect()
    };
    let wrong = labels(|r| !r.right);
    let bad_values = labels(|r| !r.values_ok);
    let bad_nrmse = labels(|r| !r.nrmse_ok);
    let bad_first = labels(|r| !r.first_ok);
    let clean_steps = labels(|r| r.steps_on_clean);
    let unidentifiable = labels(|r| !r.identifiable);
    let unit_tach = labels(|r| r.unit_tach);
    let errors: Vec<String> = rows
        .iter()
        .filter_map(|r| r.error.as_ref().map(|e| format!("{}: {e}", r.label)))
        .collect();
    eprintln!("  wrong verdicts: {wrong:?}");
    eprintln!(
        "  values off by more than {:.0} %: {bad_values:?}",
        100.0 * VALUE_TOL
    );
    eprintln!("  final NRMSE above its bar ({NRMSE_RATIO} x true, or the witness; every output a record has, in units of its floor): {bad_nrmse:?}");
    eprintln!("  the first output alone above {NRMSE_RATIO} x true (reported): {bad_first:?}");
    eprintln!("  effects added on clean records: {clean_steps:?}");
    eprintln!(
        "  hidden effects these records cannot show (a refit without them within {WITNESS_RATIO} x the truth on both records; a clean verdict counts as right): {unidentifiable:?}"
    );
    eprintln!(
        "  the unit's own tachometer gain error named (its tachometer and back-EMF constants, not a hidden effect): {unit_tach:?}"
    );
    eprintln!("  errors: {errors:?}");
    eprintln!(
        "  diagnose wall time: total {:.1} s, mean {:.1} s, slowest {:.1} s; generation {:.1} s; whole test {:.1} s",
        total.as_secs_f64(),
        total.as_secs_f64() / n.max(1) as f64,
        slowest.as_secs_f64(),
        gen.as_secs_f64(),
        t_all.elapsed().as_secs_f64()
    );

    let mut failures = Vec::new();
    if (n_right as f64) < MIN_RIGHT * n as f64 {
        failures.push(format!(
            "{n_right}/{n} verdicts right, below {:.0} %",
            100.0 * MIN_RIGHT
        ));
    }
    if !clean_steps.is_empty() {
        failures.push(format!("effects added on clean records: {clean_steps:?}"));
    }
    if !bad_values.is_empty() {
        failures.push(format!("values out of tolerance: {bad_values:?}"));
    }
    if !bad_nrmse.is_empty() {
        failures.push(format!("final NRMSE too high: {bad_nrmse:?}"));
    }
    if !errors.is_empty() {
        failures.push(format!("errors: {errors:?}"));
    }
    assert!(failures.is_empty(), "{}", failures.join("; "));
}

/// The claim behind [`is_unit_property`]: a unit whose motor constants differ from the
/// file's is, on a record of the tachometer alone, exactly a model with the file's constants,
/// rescaled mechanics and a tachometer gain error ([`foreign::in_file_constants`]); without
/// that gain error it is not (draw 4: 1.5 %).
#[test]
fn the_unit_in_the_files_constants_is_exact() {
    let file = calibrate::with_measured_stiffness(&foreign::file_params()).unwrap();
    let h = foreign::SAMPLE_PERIOD_S;
    // A slow swing in one direction (the gears stay in contact after the first take-up, and
    // nothing excites the gear mode): no rattle, so two equivalent models agree to rounding
    // (MODEL.md, "Gear rattle"; a 43 Hz component already makes a 10⁻⁶ change of an inertia
    // move the output by 2 %).
    let n = 6000;
    let volts: Vec<f64> = (0..n)
        .map(|k| {
            let t = k as f64 * h;
            6.0 + (2.0 * std::f64::consts::PI * 3.0 * t).sin()
        })
        .collect();
    let blank = calibrate::Data {
        volts,
        y: vec![0.0; n],
        output: "tach_voltage_v".into(),
        sample_period_s: h,
        preroll: 0,
        weight: vec![1.0; n],
        norm: 1.0,
        robust: None,
        extra: Vec::new(),
        steps: false,
    };
    for draw in [0, 4] {
        let mut truth = foreign::true_unit(draw).unwrap();
        truth.sample_period_s = h;
        let mut d = blank.clone();
        d.y = calibrate::output(&truth, &blank).unwrap();
        // Normalised by the output's size about zero (not about its mean, as `Data` does):
        // the question is how close the two outputs are relative to the output itself.
        d.norm = d.y.iter().map(|y| y * y).sum::<f64>().sqrt();
        let mut eq = foreign::in_file_constants(&truth, &file);
        eq.sample_period_s = h;
        let exact = calibrate::nrmse(&eq, &d);
        let g = eq.effects.tach_gain;
        eq.effects.tach_gain = 0.0;
        let without = calibrate::nrmse(&eq, &d);
        eprintln!("draw {draw}: g {g:+.4}, NRMSE {exact:.2e} with it, {without:.2e} without");
        assert!(exact < 1e-3, "draw {draw}: {exact}");
        assert!(without > 0.5 * g.abs(), "draw {draw}: {without} for g {g}");
    }
}

/// `c` diagnosed with the default options, printed, and required to end explained in exactly
/// one step (the shape of the CI tests below, each of which then asks what that step says).
fn diagnosed_in_one_step(c: &ForeignCase) -> Outcome {
    let out = c.diagnose(&Options::default()).unwrap();
    eprintln!("{}: {}", c.label(), fmt_steps(&out));
    assert!(!out.unexplained, "{}", fmt_steps(&out));
    assert_eq!(out.steps.len(), 1, "one step expected: {}", fmt_steps(&out));
    out
}

/// `case` diagnosed with the limits of `limits` asked for ([`Options::limits`]); then, for each effect it
/// hides and the diagnosis did not name: the limit on the effect's side must not rule out the
/// unit's value (the limits are an honest "at most": a limit below the truth is a false
/// exclusion). Returns the outcome.
fn limits_cover_the_unit(case: &ForeignCase, limits: &[Effect]) -> Outcome {
    let opts = Options {
        limits: limits.to_vec(),
        ..Options::default()
    };
    let out = case.diagnose(&opts).unwrap();
    eprintln!("{}: {}", case.label(), fmt_steps(&out));
    for l in &out.limits {
        eprintln!(
            "  {} {} {:+.4e} ({:?}); best {:+.4e} at {:.1}",
            l.effect,
            if l.side < 0.0 { "-" } else { "+" },
            l.value,
            l.kind,
            l.best.0,
            l.best.1
        );
    }
    assert!(!out.limits.is_empty(), "no limits given");
    for &(e, v) in &case.expected {
        if out.steps.iter().any(|s| names(s, e)) {
            continue;
        }
        let want = case.expected_fitted(e, v);
        let side = out
            .limits
            .iter()
            .find(|l| l.effect == e && l.side * want > 0.0)
            .unwrap_or_else(|| panic!("no limit for {e} on the side of {want}"));
        let covers = match side.kind {
            diagnose::limits::LimitKind::BeyondRange => true,
            diagnose::limits::LimitKind::Within => side.value.abs() >= want.abs(),
            diagnose::limits::LimitKind::BelowRange => false,
        };
        assert!(
            covers,
            "{e}: the unit's {want:.4e} ruled out ({:?} at {:.4e})",
            side.kind, side.value
        );
    }
    out
}

/// The limits of what was not added are honest where the records cannot show an effect
/// (`diagnose::limits`): on stiction_ratio/87 the unit's breakaway friction is 1.51 times its
/// running friction, and the model without it follows both records as well as the truth does
/// (every row of the square wave at NRMSE 0.0410 against 0.0406: docs/dev/period_average.py),
/// so nothing is added. The walk with the polish alone stopped at 1.39 (at 1.41 the polish
/// from there cost 4.9 times the effect off): a false exclusion of the unit. With the local
/// search where the polish would rule out, 1.41 and 1.60 fit as well as none and the ratio is
/// not ruled out in its plausible range; the load's viscous friction, which those records do
/// show, is bounded inside its range. Records of the independent reference integrator, every
/// parameter perturbed, rattle included.
#[test]
fn limits_of_an_effect_the_records_cannot_show_do_not_rule_out_the_unit() {
    let c = foreign::case(Kind::Single(Effect::StictionRatio), 87).unwrap();
    let out = limits_cover_the_unit(&c, &[Effect::StictionRatio, Effect::LoadViscous]);
    let lv = out
        .limits
        .iter()
        .find(|l| l.effect == Effect::LoadViscous)
        .expect("a limit for the load's viscous friction");
    assert_eq!(
        lv.kind,
        diagnose::limits::LimitKind::Within,
        "load_viscous {:?} at {:.3e}",
        lv.kind,
        lv.value
    );
}

/// The same on the held-out units the diagnosis got wrong by leaving their effect out
/// (2026-12-08): stiction_ratio/86 (the unit's 2.16; the walk leans to 2.06 and rules out
/// nothing up to 3.0), stiction_ratio/88 (2.03; its profile ragged, nothing ruled out) and
/// tach_gain/88 (−6.8 %; a dead band named instead, the gain allowed to −9.0 %).
#[test]
#[ignore = "a trace of the limits (7 min beside other runs on 2 cores): beyond CI's budget beside the others; run with `cargo test --release -p geared-servo-host-tests --test diagnose_foreign -- --ignored --skip diagnose_names_effects`"]
fn limits_do_not_rule_out_the_effects_the_diagnosis_missed() {
    for (kind, draw) in [
        (Effect::StictionRatio, 86),
        (Effect::StictionRatio, 88),
        (Effect::TachGain, 88),
    ] {
        let c = foreign::case(Kind::Single(kind), draw).unwrap();
        limits_cover_the_unit(&c, &[kind]);
    }
}

/// A hanging arm whose records cannot tell its gravity from a hinge spring: on
/// gravity_torque/29 the stepped sine swings the arm by a few degrees (a spring of stiffness
/// T, exactly, in the plant's linear part), and the square wave's large swings fall in its
/// rattle, outside the 4 % of it that is predictable. The first pass named the spring and
/// told gravity apart on those few validation rows (NRMSE 0.0573 against 0.0534, at a model
/// fitted to the stepped sine alone); once both records are fitted the two follow them
/// equally (0.0383 each), so the second pass reports gravity beside the spring, with its
/// value and the measurement that would separate them, instead of the spring alone
/// (`judge::swap_in_class`, 2026-12-04). Records of the independent reference integrator,
/// every parameter perturbed, rattle included.
#[test]
#[ignore = "a trace of the search (74 s on 2 cores): beyond CI's budget beside the others (the class of gravity and a spring is in CI on synthetic records: diagnose_bench_effects); run with `cargo test --release -p geared-servo-host-tests --test diagnose_foreign -- --ignored --skip diagnose_names_effects`"]
fn gravity_that_the_records_cannot_tell_from_a_spring_is_reported_beside_it() {
    let c = foreign::case(Kind::Single(Effect::GravityTorque), 29).unwrap();
    let out = diagnosed_in_one_step(&c);
    let step = &out.steps[0];
    assert!(names(step, Effect::GravityTorque), "{}", fmt_steps(&out));
    let g = if step.effect == Effect::GravityTorque {
        step.value
    } else {
        assert!(
            step.separate_by.contains("large load angles"),
            "what separates them: {}",
            step.separate_by
        );
        step.indistinguishable_from
            .iter()
            .find(|(e, _)| *e == Effect::GravityTorque)
            .map_or(f64::NAN, |&(_, v)| v)
    };
    let (_, v) = c.expected[0];
    let want = c.expected_fitted(Effect::GravityTorque, v);
    assert!(
        (g / want - 1.0).abs() <= VALUE_TOL,
        "gravity {g} for {want}"
    );
}

/// The prior where the validation record cannot decide (`judge::with_plausible_kin`): on
/// motor_viscous/6 of the fresh draws the stepped sine alone can prefer a tachometer gain
/// error of a third, with every mechanical quantity rescaled to match (ΔBIC −5080 against
/// −2814 for the motor friction that is there, before the search restarted from both places
/// of the background damping), a value outside the gain error's plausible range. The
/// plausible motor friction is named, within [`VALUE_TOL`], and the gain error is not. It is
/// reported as told apart (a better fit of the estimation record at an implausible value,
/// refused by the validation record) when, and only when, its refit beat the motor friction's
/// on the estimation record: since the restart from both places the motor friction's refit
/// beats it there (NRMSE 0.0219 against 0.0264 on their common rows), so no such line is
/// owed; if one is given, its value must be the implausible one. Records of the independent
/// reference integrator, every parameter perturbed, rattle included.
#[test]
#[ignore = "a trace of the search (115 s on 2 cores): beyond CI's budget beside the others; run with `cargo test --release -p geared-servo-host-tests --test diagnose_foreign -- --ignored --skip diagnose_names_effects`"]
fn an_implausible_tachometer_gain_gives_way_to_the_friction_that_is_there() {
    let c = foreign::case(Kind::Single(Effect::MotorViscous), 6).unwrap();
    let out = diagnosed_in_one_step(&c);
    let step = &out.steps[0];
    assert_eq!(step.effect, Effect::MotorViscous);
    let (_, v) = c.expected[0];
    let want = c.expected_fitted(Effect::MotorViscous, v);
    assert!(
        (step.value / want - 1.0).abs() <= VALUE_TOL,
        "{} for {want}",
        step.value
    );
    let (_, gain_hi) = Effect::TachGain.plausible_range();
    assert!(
        step.indistinguishable_from
            .iter()
            .all(|&(e, v)| e != Effect::TachGain || v.abs() > gain_hi),
        "a plausible tachometer gain error tied with the friction: {}",
        fmt_steps(&out)
    );
    if let Some(gain) = step
        .told_apart
        .iter()
        .find(|r| r.effect == Effect::TachGain)
    {
        assert!(
            gain.value.abs() > gain_hi,
            "the gain error told apart at a plausible value: {}",
            gain.value
        );
    }
}

/// A tachometer that reads low and a viscous motor friction are one model on a record of
/// the tachometer alone, every mechanical quantity rescaled by the gain
/// (`diagnose::kin::mirror`): the diagnosis reports them together, with the measurement
/// that separates them, and does not guess. On tach_gain/28 (a gain error of −9.2 %, −8.6 %
/// after the resistance scale) it named the motor friction alone (1.2e-6 N·m·s/rad) before
/// the mirror points: the gain's own refit stopped where it followed its own predictable
/// rows worse than the current model (NRMSE 0.1026 against 0.0792) and was refused. The
/// friction that stands in is b = −b_e g / (1 + g), b_e = k_t k_b / R the back-EMF damping.
/// Records of the independent reference integrator, every parameter perturbed, rattle
/// included.
#[test]
fn a_slow_tachometer_and_a_motor_friction_are_reported_together() {
    let c = foreign::case(Kind::Single(Effect::TachGain), 28).unwrap();
    let out = diagnosed_in_one_step(&c);
    let step = &out.steps[0];
    let value_of = |e: Effect| {
        if step.effect == e {
            Some(step.value)
        } else {
            step.indistinguishable_from
                .iter()
                .find(|(x, _)| *x == e)
                .map(|&(_, v)| v)
        }
    };
    let (Some(g), Some(b)) = (value_of(Effect::TachGain), value_of(Effect::MotorViscous)) else {
        panic!(
            "the gain and the motor friction together: {}",
            fmt_steps(&out)
        );
    };
    let (_, v) = c.expected[0];
    let want = c.expected_fitted(Effect::TachGain, v);
    assert!((g / want - 1.0).abs() <= VALUE_TOL, "gain {g} for {want}");
    let b_e = c.file.effect_scales(0.0).back_emf_damping;
    let b_want = -b_e * want / (1.0 + want);
    assert!(
        (b / b_want - 1.0).abs() <= VALUE_TOL,
        "motor friction {b} for {b_want}"
    );
    assert!(
        step.separate_by.contains("current"),
        "what separates them: {}",
        step.separate_by
    );
}

/// A structural mode outside the library is reported as such: `unexplained`, nothing
/// claimed with confidence, and the band that holds most of the residual's energy holds the
/// mode's frequency (second_mode/1: J2 a fifth of the load's inertia at 217 Hz on a held
/// load, the tachometer and the load angle logged). Until 2026-12-07 this test was the
/// witness of the stuck rule of `diagnose` (its last resettle, `diagnose/mod.rs`): the
/// second pass ended in a model at 0.093 on its own rows against a floor of 0.019, the rule
/// took the settle from it, and the search ended at 0.025. Since the floor counts a load
/// angle at its noise (`settle::record_floor_cost`) the search takes another path on this
/// unit: its second pass ends at 2.58x its rows' floor, the settle from there at 4.05x
/// (with a second random stream 3.50x, at a new bound), so the rule has nothing to take and
/// the search ends at 0.0409 against a floor of 0.0204; the band of 80-250 Hz then holds
/// 79 % of the residual's energy (49 % before), peak 191 Hz. second_mode/82 was its witness
/// for an hour (`a_mode_that_rattles_almost_everywhere_is_unexplained_near_its_floor`).
/// Records of the independent reference integrator, every parameter perturbed, rattle
/// included.
#[test]
#[ignore = "a trace of the search (150 s on 2 cores): beyond CI's budget beside the others; run with `cargo test --release -p geared-servo-host-tests --test diagnose_foreign -- --ignored --skip diagnose_names_effects`"]
fn a_mode_outside_the_library_is_unexplained_with_its_band() {
    let c = foreign::case(Kind::OutOfLibrary, 1).unwrap();
    let out = c.diagnose(&Options::default()).unwrap();
    let fin = &out.final_analysis;
    let (lo, hi, share) = fin.dominant_band();
    eprintln!(
        "{}: {}; final NRMSE {:.4}, floor {:.4}; band {lo}-{hi} Hz ({share:.2}), peak {:.1} Hz",
        c.label(),
        fmt_steps(&out),
        fin.nrmse,
        out.floor_nrmse,
        fin.peak_hz
    );
    assert!(
        verdict_right(&c, &out, true),
        "an out-of-library mode is unexplained"
    );
    let f0 = c.second_mode.map_or(f64::NAN, |m| m.frequency_hz);
    assert!(
        lo <= f0 && f0 < hi,
        "band {lo}-{hi} Hz does not hold the mode's {f0} Hz"
    );
}

/// A mode outside the library on a unit that rattles almost everywhere (second_mode/82, a
/// held-out draw until 2026-12-07: J2 1.61e-4 kg·m² at 237 Hz, the tachometer alone, rattle
/// in 18 of 22 bursts) is `unexplained`, and the search does not stay stuck far above the
/// floor: the final model follows its predictable rows within `Options::poor_ratio` of their
/// floor. For an hour on 2026-12-07 this was the stuck rule's witness (its last resettle,
/// `diagnose/mod.rs`): the second pass sat at 3.35x its rows' floor, the settle from there
/// at 1.63x, the rule took it and the diagnosis ended at 1.69x, and at 4.3x without the
/// rule (the test failed). Since the second pass keeps the first pass's model where its
/// settle is worse (fd956fc), the search there never gets stuck: 0.0413 for a floor of
/// 0.0214 (1.93x) with the rule and without it (both measured), so the rule is again without
/// a witness. Records of the independent reference integrator, every parameter perturbed,
/// rattle included.
#[test]
#[ignore = "a trace of the search (150-310 s on 2 cores): beyond CI's budget beside the others; run with `cargo test --release -p geared-servo-host-tests --test diagnose_foreign -- --ignored --skip diagnose_names_effects`"]
fn a_mode_that_rattles_almost_everywhere_is_unexplained_near_its_floor() {
    let c = foreign::case(Kind::OutOfLibrary, 82).unwrap();
    let opts = Options::default();
    let out = c.diagnose(&opts).unwrap();
    let fin = &out.final_analysis;
    eprintln!(
        "{}: {}; unexplained {}; final NRMSE {:.4} on the predictable rows, floor {:.4}",
        c.label(),
        fmt_steps(&out),
        out.unexplained,
        fin.nrmse,
        out.floor_nrmse
    );
    assert!(
        verdict_right(&c, &out, true),
        "an out-of-library mode is unexplained"
    );
    assert!(
        fin.nrmse < opts.poor_ratio * out.floor_nrmse,
        "the final model at {:.4}, {:.2}x the floor {:.4}: stuck far above it",
        fin.nrmse,
        fin.nrmse / out.floor_nrmse,
        out.floor_nrmse
    );
}

#[test]
fn the_suite_is_what_the_issue_asks_for() {
    // Cheap structural checks of the generator (no diagnosis): the file, the truth's
    // perturbations, the kinds.
    let file = foreign::file_params();
    assert_eq!(file.backlash_deg, foreign::FILE_BACKLASH_DEG);
    // Clean, one per effect, the pair, the out-of-library mode.
    assert_eq!(Kind::all().len(), Effect::ALL.len() + 3);
    for draw in foreign::SUITE_DRAWS {
        let u = foreign::true_unit(draw).unwrap();
        let f = calibrate::with_measured_stiffness(&file).unwrap();
        let rel = |a: f64, b: f64| (a / b - 1.0).abs();
        let s = u.motor.resistance_ohm / f.motor.resistance_ohm;
        assert!((1.03..=1.10).contains(&s), "{s}");
        for k in [Param::MotorInertia, Param::LoadInertia] {
            let r = rel(calibrate::get(&u, k), calibrate::get(&f, k));
            assert!((0.08..=0.25).contains(&r), "{k}: {r}");
        }
        for k in [Param::MotorFriction, Param::LoadFriction] {
            let r = rel(calibrate::get(&u, k), calibrate::get(&f, k));
            assert!((0.15..=0.30).contains(&r), "{k}: {r}");
        }
        assert!((0.045..=0.06).contains(&u.backlash_deg));
        assert!((0.002..=0.005).contains(&u.effects.mesh_damping));
        assert!(rel(u.motor.tach_v_s_per_rad, f.motor.tach_v_s_per_rad) <= 0.01);
        assert_eq!(u.derived().unwrap().n_total, f.derived().unwrap().n_total);
        for e in Effect::ALL {
            let v = foreign::effect_value(e, draw);
            let (lo, hi) = e.plausible_range();
            assert!(lo <= v && v <= hi, "{e} {v}");
        }
    }
}

/// A record of the armature current alone (a drive with a current sense resistor, no speed
/// sensor). The current fixes the torque's scale (i = T_m/k_t), which speeds alone cannot
/// tell from the armature resistance, so `diagnose` fits R too
/// (`calibrate::RESISTANCE_OUTPUTS`); with the file's R, 8 % below this unit's, the fit of
/// a clean unit so recorded stayed at 2.5 times its floor and took a spurious dead band. The
/// unit is tach_lag/2's: its lag acts on a tachometer these records do not carry, so it is
/// the clean unit, the lag is not tried, and nothing is added. Records of the independent
/// reference integrator, every parameter perturbed, rattle included.
#[test]
fn a_record_of_the_current_alone_is_fitted_with_the_units_resistance() {
    let making = Making::with_sensors(Sensors::CurrentOnly);
    let c = foreign::case_with(Kind::Single(Effect::TachLag), 2, &making).unwrap();
    let out = c.diagnose(&Options::default()).unwrap();
    assert!(out.unseen.contains(&Effect::TachLag), "{:?}", out.unseen);
    assert!(
        out.steps.is_empty() && !out.unexplained,
        "{} (unexplained {})",
        fmt_steps(&out),
        out.unexplained
    );
    let p = &out.final_fit.params;
    let r = p.motor.resistance_ohm / c.truth.motor.resistance_ohm;
    assert!((r - 1.0).abs() < 0.01, "R {r} of the unit's");
    assert_eq!(c.fitted_scale(), 1.0);
    eprintln!("base vs the unit: {}", fmt_base(&c, p));
    for k in [Param::MotorInertia, Param::LoadInertia, Param::StiffnessKeq] {
        let x = calibrate::get(p, k) / calibrate::get(&c.truth, k);
        assert!((x - 1.0).abs() < 0.1, "{} {x} of the unit's", k.name());
    }
}

/// The base calibration finds how the friction splits between motor and load. In contact a
/// record sees the two only as one torque at the motor, and the split shows in the backlash
/// gap, mostly in rattle, which the search weights out; on clean/1 stripped to the armature
/// current both global settles ended at motor −62 %, load +108 % of the unit's friction,
/// with the background damping 5× the unit's mesh damping, a model that rattled much less
/// than the unit and left a residual that the diagnosis called unexplained. The local
/// settle from the file's dissipation (`settle::dissipation_from_start`) finds the unit's
/// split. tach_offset/1 is the same unit with other noise draws (its tachometer error unseen
/// without a tachometer): there the rows both settles keep could not tell the two apart
/// (0.4 standard errors for the seeded one) and the seeded split (motor −75 %, load +88 %)
/// was kept; a tie now goes to the split nearer the file's (`settle::better_or_nearer`).
/// The estimation record alone, no effect searched. Records of the independent reference
/// integrator, every parameter perturbed, rattle included.
#[test]
fn the_base_finds_how_the_friction_splits_between_motor_and_load() {
    let making = Making::with_sensors(Sensors::CurrentOnly);
    for kind in [Kind::Clean, Kind::Single(Effect::TachOffset)] {
        let c = foreign::case_with(kind, 1, &making).unwrap();
        let opts = Options {
            max_steps: 0,
            ..Options::default()
        };
        let out =
            diagnose::diagnose(&c.file, std::slice::from_ref(&c.estimation), None, &opts).unwrap();
        let p = &out.base.params;
        eprintln!("{}: base vs the unit: {}", c.label(), fmt_base(&c, p));
        for k in [Param::MotorFriction, Param::LoadFriction] {
            let x = calibrate::get(p, k) / calibrate::get(&c.truth, k);
            assert!(
                (x - 1.0).abs() < 0.3,
                "{}: {} {x} of the unit's",
                c.label(),
                k.name()
            );
        }
    }
}

/// The measurement the diagnosis asks for does separate what it reports together. On the
/// tachometer alone, tach_gain/28's slow tachometer and a viscous motor friction are one
/// model ([`a_slow_tachometer_and_a_motor_friction_are_reported_together`]); with the
/// armature current logged too (the same unit, the same tachometer and noise), the current
/// fixes the torque and so the speed the back-EMF implies, and the gain is named alone, at
/// its value (with the resistance fitted, the unit's own gain error of the motor constants
/// combined: −8.9 % for −9.2 % hidden), the friction neither named nor beside it. Records of
/// the independent reference integrator, every parameter perturbed, rattle included.
#[test]
#[ignore = "a trace of the search (140 s on 2 cores): beyond CI's budget beside the others; run with `cargo test --release -p geared-servo-host-tests --test diagnose_foreign -- --ignored --skip diagnose_names_effects`"]
fn with_the_current_logged_a_slow_tachometer_is_told_from_a_motor_friction() {
    let making = Making::with_sensors(Sensors::WithCurrent);
    let c = foreign::case_with(Kind::Single(Effect::TachGain), 28, &making).unwrap();
    assert_eq!(c.fitted_scale(), 1.0);
    let out = diagnosed_in_one_step(&c);
    let step = &out.steps[0];
    assert_eq!(step.effect, Effect::TachGain, "{}", fmt_steps(&out));
    assert!(
        step.indistinguishable_from.is_empty() && step.separate_by.is_empty(),
        "nothing beside the gain: {}",
        fmt_steps(&out)
    );
    let (_, v) = c.expected[0];
    let want = c.expected_fitted(Effect::TachGain, v);
    assert!(
        (step.value / want - 1.0).abs() <= VALUE_TOL,
        "gain {} for {want}",
        step.value
    );
    let r = out.final_fit.params.motor.resistance_ohm / c.truth.motor.resistance_ohm;
    assert!((r - 1.0).abs() < 0.01, "R {r} of the unit's");
}

/// Rattle is not a response the model lacks: on a periodic validation record, with no step
/// taken, only a material part of the residual that repeats with the command sends the
/// diagnosis on to its second pass (`diagnose::diagnose_with`). On clean/1 (the tachometer
/// and the load angle) the first pass left a validation residual of 2.42 noise levels over
/// every row, of which nothing repeated: rattle that the first pass's model kept as predictable.
/// Fitted in a second pass, it moved the friction split from +4/-4 % to +13/-12 % of the
/// unit's, and the final ended at 1.42x the truth's NRMSE on the estimation record's
/// predictable rows (every output, each in units of its floor); without the second pass it
/// ends at 1.01x, the fine search alone taking the validation record to its floor on its
/// rows (0.0498 against 0.0451). Nothing is added either way. Records of the independent
/// reference integrator, every parameter perturbed, rattle included.
#[test]
fn rattle_that_does_not_repeat_sends_no_second_pass() {
    let c = foreign::case(Kind::Clean, 1).unwrap();
    let out = c.diagnose(&Options::default()).unwrap();
    eprintln!("{}: {}", c.label(), fmt_steps(&out));
    assert!(
        out.steps.is_empty() && !out.unexplained,
        "a clean unit: {} (unexplained {})",
        fmt_steps(&out),
        out.unexplained
    );
    let (truth, rows) = truth_on_rows(&c, &out);
    let (fin, tru) = (
        calibrate::nrmse_all(&out.final_fit.params, &rows),
        calibrate::nrmse_all(&truth, &rows),
    );
    eprintln!(
        "every output on diagnose's rows: final {fin:.4}, true parameters {tru:.4} ({:.2}x); second pass: {}",
        fin / tru,
        out.validation_in_fit.is_some()
    );
    assert!(
        fin <= NRMSE_RATIO * tru,
        "final {fin:.4} against the truth's {tru:.4} on the same rows"
    );
}

/// A fold of the held-out check whose rows do not see an effect leaves the effect's value
/// where the full fit put it (`diagnose::judge::held_out`): the fold's refit is kept only
/// where it lowers the fold's cost by more than refitting one value to noise alone does on
/// average. On voltage_limit/1 with the load angle alone (a 7.20 V limit; the fold of the
/// rests and the fastest bursts, where the angle is at its noise and no model does better
/// than 1.03 in cost) the limit's refit lowered that fold's cost by 1e-9 of itself and went
/// to its bound of 20 V; the other parameters, fitted with the limit at 7.16 V, then failed
/// the other fold (5.72 against 0.043 without the limit), the right limit was refused in the
/// first pass, and the diagnosis ended `partial` and `unexplained` with a load viscous
/// friction beside the limit. Now the limit alone is named, at its value. Records of the
/// independent reference integrator, every parameter perturbed, rattle included.
#[test]
#[ignore = "a trace of the search (170 s on 2 cores): beyond CI's budget beside the others; run with `cargo test --release -p geared-servo-host-tests --test diagnose_foreign -- --ignored --skip diagnose_names_effects`"]
fn a_fold_that_does_not_see_the_voltage_limit_leaves_it_where_the_fit_put_it() {
    let making = Making::with_sensors(Sensors::AngleOnly);
    let c = foreign::case_with(Kind::Single(Effect::VoltageLimit), 1, &making).unwrap();
    let out = c.diagnose(&Options::default()).unwrap();
    eprintln!("{}: {}", c.label(), fmt_steps(&out));
    assert!(
        verdict_right(&c, &out, true),
        "the limit alone, explained: {} (unexplained {})",
        fmt_steps(&out),
        out.unexplained
    );
    let step = &out.steps[0];
    assert!(
        step.indistinguishable_from.is_empty(),
        "nothing beside the limit: {}",
        fmt_steps(&out)
    );
    let (_, v) = c.expected[0];
    let want = c.expected_fitted(Effect::VoltageLimit, v);
    assert!(
        (final_value(&out, step) / want - 1.0).abs() <= VALUE_TOL,
        "limit {} for {want}",
        final_value(&out, step)
    );
}
