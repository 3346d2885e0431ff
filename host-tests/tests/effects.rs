//! Each optional effect does what its name says (INTERFACES.md "Effect names"): against the
//! independent RK4 reference where that reference models it, against exact identities
//! (shift, scale, clamp) or a finer emulator otherwise.

use geared_servo::{Effect, Plant, PlantState, REFERENCE};
use geared_servo_host::params_file;
use geared_servo_host_tests::records::{emulate, sine, square};
use geared_servo_host_tests::reference::{relative_rms_error, Reference};

#[test]
fn dissipative_and_spring_effects_agree_with_the_rk4_reference() {
    // Backlash and friction on, as in plant_accuracy; records MODEL.md lists as not chaotic.
    let base = REFERENCE.with_backlash_deg(0.08);
    let h = base.sample_period_s;
    let n = (0.5 / h) as usize;
    let records = [
        ("10 V sine 80 Hz", sine(10.0, 80.0, n, h)),
        ("10 V square 0.25 s", square(10.0, 0.25, n, h)),
    ];
    // Values that change the response by several percent (checked below), so an effect that
    // is silently ignored fails the test.
    let cases = [
        (Effect::MotorViscous, 6.0e-6),
        (Effect::LoadViscous, 1.0e-2),
        (Effect::MeshDamping, 0.05),
        (Effect::HingeStiffness, 5.0),
    ];
    for (name, value) in cases {
        let mut p = base;
        p.effects.set(name, value);
        for (rname, v) in &records {
            let refr = Reference::new(&p, 1e-6).unwrap().run_tach(v);
            let fine = Reference::new(&p, 0.5e-6).unwrap().run_tach(v);
            // The reference is converged on this record (not in a rattle regime).
            assert!(
                relative_rms_error(&refr, &fine) < 5e-4,
                "{name} {rname}: reference not converged"
            );
            let emu = emulate(&p, v);
            let e = relative_rms_error(&emu, &refr);
            let without = emulate(&base, v);
            let change = relative_rms_error(&without, &refr);
            eprintln!(
                "{name} on {rname}: error {:.4} %, effect changes output by {:.1} %",
                100.0 * e,
                100.0 * change
            );
            assert!(
                change > 0.03,
                "{name} {rname}: effect too small to test ({change})"
            );
            // Same 1 % RMS bound as the plant's own accuracy claim (issue #2).
            assert!(e <= 0.01, "{name} {rname}: relative RMS error {e}");
        }
    }
}

#[test]
fn whole_step_input_delay_shifts_the_output_exactly() {
    let p0 = REFERENCE.with_backlash_deg(0.08);
    let h = p0.sample_period_s;
    let v = square(10.0, 0.1, 2000, h);
    let y0 = emulate(&p0, &v);
    for d in [1usize, 2, 5] {
        let mut p = p0;
        p.effects.input_delay = d as f64 * h;
        let y = emulate(&p, &v);
        // Rows 0..=d see no command yet: the plant stays exactly at rest.
        assert!(y.iter().take(d + 1).all(|&x| x == 0.0), "delay {d}");
        for k in 0..y0.len() - d {
            assert_eq!(y[k + d], y0[k], "delay {d} steps, row {k}");
        }
    }
}

#[test]
fn fractional_input_delay_matches_a_twice_finer_emulator_with_a_whole_step() {
    // Linear plant (no friction, no backlash): both runs are exact discretisations, so they
    // must agree to f32 rounding. Half a step at 0.5 ms is one whole step at 0.25 ms with each
    // command held for two fine steps.
    let p = REFERENCE.without_friction();
    let h = p.sample_period_s;
    let v = sine(10.0, 37.0, 4000, h);
    let mut coarse = p;
    coarse.effects.input_delay = 0.5 * h;
    let yc = emulate(&coarse, &v);
    let mut fine = p;
    fine.sample_period_s = h / 2.0;
    fine.effects.input_delay = h / 2.0;
    let vf: Vec<f64> = v.iter().flat_map(|&x| [x, x]).collect();
    let yf: Vec<f64> = emulate(&fine, &vf).into_iter().step_by(2).collect();
    let e = relative_rms_error(&yc, &yf);
    // f32 state, some 4000 steps: 1e-4 relative is far above rounding, far below any error of
    // the split (a wrong split point shifts by 0.25 ms: 6 % at 37 Hz).
    assert!(e < 1e-4, "relative RMS error {e}");
    // And it lies between the undelayed and the one-step-delayed output.
    let y0 = emulate(&p, &v);
    let mut one = p;
    one.effects.input_delay = h;
    let y1 = emulate(&one, &v);
    let mid: Vec<f64> = y0.iter().zip(&y1).map(|(a, b)| 0.5 * (a + b)).collect();
    assert!(
        relative_rms_error(&yc, &mid) < 0.01,
        "{}",
        relative_rms_error(&yc, &mid)
    );
}

#[test]
fn voltage_limit_saturates_the_applied_voltage() {
    let mut p = REFERENCE.with_backlash_deg(0.08);
    p.effects.voltage_limit = 6.0;
    let v = sine(10.0, 20.0, 2000, p.sample_period_s);
    let limited = Plant::new(&p).unwrap();
    let free = Plant::new(&REFERENCE.with_backlash_deg(0.08)).unwrap();
    let (mut a, mut b) = (PlantState::REST, PlantState::REST);
    for &x in &v {
        let oa = limited.step(&mut a, x as f32);
        let ob = free.step(&mut b, (x as f32).clamp(-6.0, 6.0));
        assert!(oa.applied_voltage_v.abs() <= 6.0);
        assert_eq!(oa.tach_voltage_v, ob.tach_voltage_v);
    }
    // A limit above every command changes nothing, bit for bit.
    p.effects.voltage_limit = 50.0;
    assert_eq!(
        emulate(&p, &v),
        emulate(&REFERENCE.with_backlash_deg(0.08), &v)
    );
}

#[test]
fn tach_gain_scales_the_tachometer_and_nothing_else() {
    let mut p = REFERENCE.with_backlash_deg(0.08);
    p.effects.tach_gain = 0.1;
    let v = square(10.0, 0.1, 2000, p.sample_period_s);
    let scaled = Plant::new(&p).unwrap();
    let plain = Plant::new(&REFERENCE.with_backlash_deg(0.08)).unwrap();
    let (mut a, mut b) = (PlantState::REST, PlantState::REST);
    for &x in &v {
        let oa = scaled.step(&mut a, x as f32);
        let ob = plain.step(&mut b, x as f32);
        assert_eq!(oa.motor_speed_rad_s, ob.motor_speed_rad_s);
        let want = 1.1 * f64::from(ob.tach_voltage_v);
        // One f32 rounding of the product k_ts (1 + g) ω.
        assert!((f64::from(oa.tach_voltage_v) - want).abs() <= 1e-6 * want.abs().max(1e-3));
    }
}

/// A registry entry without physics fails here: every effect, at a value inside its
/// plausible range, changes the tachometer output of a square-wave or a slow sine record, and
/// it does so
/// through the parameter file's key (what `synth --effect` and `[effects]` set).
#[test]
fn every_registered_effect_changes_the_output_within_its_plausible_range() {
    let base = REFERENCE.with_backlash_deg(0.08);
    let h = base.sample_period_s;
    // 20 V: above the lower half of the voltage-limit range, so a limit there clips. And a
    // slow 1 V sine, whose reversals stick (about 0.5 V overcomes the Coulomb friction), so
    // that breakaway friction and the dead band show; each record is judged on its own.
    let records = [square(20.0, 0.1, 1000, h), sine(1.0, 2.0, 2000, h)];
    let y0: Vec<Vec<f64>> = records.iter().map(|v| emulate(&base, v)).collect();
    for e in Effect::ALL {
        let (lo, hi) = e.plausible_range();
        // The geometric mean of a positive range; the upper end of a signed one.
        let x = if lo > 0.0 { (lo * hi).sqrt() } else { hi };
        let text = params_file::to_toml(&base, &[]).unwrap().replace(
            &format!("{} = 0e0", e.name()),
            &format!("{} = {x:e}", e.name()),
        );
        let p = params_file::parse(&text, "effect.toml").unwrap();
        assert_eq!(p.effects.get(e), x, "{e}: the file's key sets the effect");
        let change = records
            .iter()
            .zip(&y0)
            .map(|(v, y)| relative_rms_error(&emulate(&p, v), y))
            .fold(0.0, f64::max);
        eprintln!(
            "{e} = {x:e} {}: output changes by {:.3} %",
            e.unit(),
            100.0 * change
        );
        // 0.1 %: far above the f32 rounding of a 2000-step run, and well below what any of
        // these values does (the smallest change, the delay's, is 2 %).
        assert!(change > 1e-3, "{e} = {x:e}: output changed by {change}");
    }
}

/// `synth --effect NAME=VALUE` and the parameter file's `[effects]` key make the same record
/// for every registered effect (both go through the registry), and a value outside an
/// effect's domain, given either way, is a one-line bad-input error naming the key.
#[test]
fn synth_effect_flag_and_the_files_key_agree_for_every_effect() {
    use clap::Parser;
    use geared_servo_cli::{run, Cli};
    use geared_servo_host::error::ErrorKind;
    let dir = std::env::temp_dir().join(format!("gs-synth-effects-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let base = REFERENCE.with_backlash_deg(0.08);
    let base_file = dir.join("base.toml");
    std::fs::write(&base_file, params_file::to_toml(&base, &[]).unwrap()).unwrap();
    let synth = |params: &std::path::Path, out: &std::path::Path, effect: Option<String>| {
        let mut args: Vec<String> = [
            "geared-servo",
            "--params",
            params.to_str().unwrap(),
            "synth",
            "--output",
            out.to_str().unwrap(),
            "--excitation",
            "square",
            "--f-min",
            "5",
            // Above the lower half of the voltage-limit range (as above).
            "--amplitude",
            "20",
            "--duration",
            "0.2",
        ]
        .map(String::from)
        .to_vec();
        if let Some(e) = effect {
            args.extend(["--effect".to_string(), e]);
        }
        run(&Cli::try_parse_from(args).unwrap())
    };
    let rows = |path: &std::path::Path| -> Vec<String> {
        std::fs::read_to_string(path)
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#'))
            .map(String::from)
            .collect()
    };
    let plain = dir.join("plain.csv");
    synth(&base_file, &plain, None).unwrap();
    for e in Effect::ALL {
        let (lo, hi) = e.plausible_range();
        let x = if lo > 0.0 { (lo * hi).sqrt() } else { lo };
        let (by_flag, by_key) = (dir.join("flag.csv"), dir.join("key.csv"));
        synth(&base_file, &by_flag, Some(format!("{}={x:e}", e.name()))).unwrap();
        let mut p = base;
        p.effects.set(e, x);
        let file = dir.join("key.toml");
        std::fs::write(&file, params_file::to_toml(&p, &[]).unwrap()).unwrap();
        synth(&file, &by_key, None).unwrap();
        let flag = rows(&by_flag);
        assert!(flag == rows(&by_key), "{e}: flag and key differ");
        assert!(flag != rows(&plain), "{e} changes nothing");
    }
    // Outside the domain: a ratio below 1, a negative dead band or lag, a NaN offset.
    for (name, bad) in [
        ("stiction_ratio", "0.5"),
        ("drive_deadband", "-1"),
        ("tach_lag", "-1e-3"),
        ("gravity_torque", "-0.1"),
    ] {
        let err = synth(
            &base_file,
            &dir.join("x.csv"),
            Some(format!("{name}={bad}")),
        )
        .err()
        .unwrap_or_else(|| panic!("{name}={bad} accepted"));
        assert_eq!(err.kind, ErrorKind::BadInput, "{name}");
        assert!(
            err.message.contains(&format!("effects.{name}")) && !err.message.contains('\n'),
            "{}",
            err.message
        );
        let text = params_file::to_toml(&base, &[])
            .unwrap()
            .replace(&format!("{name} = 0e0"), &format!("{name} = {bad}"));
        let err = params_file::parse(&text, "bench.toml").unwrap_err();
        assert_eq!(err.kind, ErrorKind::BadInput);
        assert!(
            err.message
                .starts_with(&format!("bench.toml: key `effects.{name}` must")),
            "{}",
            err.message
        );
        eprintln!("{name} = {bad}: {}", err.message);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
