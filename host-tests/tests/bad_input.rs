//! Bad input gets its own clear error, never a panic: parameters, parameter files, records
//! and command lines.

use clap::Parser;
use geared_servo::effects::Domain;
use geared_servo::{ActuatorParams, Effect, ParamError, Plant, Stiffness, REFERENCE};
use geared_servo_cli::{run, Cli};
use geared_servo_host::{params_file, record, ErrorKind};

type Setter = dyn Fn(&mut ActuatorParams, f64);
type OwnSetter = fn(&mut ActuatorParams, f64);

/// Every scalar parameter with its key and whether zero is allowed (off).
fn fields() -> Vec<(&'static str, Box<Setter>, bool)> {
    fn geo(p: &mut ActuatorParams) -> &mut geared_servo::ToothGeometry {
        match &mut p.gears.stiffness {
            Stiffness::Geometry { stage1, .. } => stage1,
            Stiffness::Measured { .. } => unreachable!("reference uses geometry"),
        }
    }
    fn shaft2(p: &mut ActuatorParams) -> &mut geared_servo::Shaft {
        match &mut p.gears.stiffness {
            Stiffness::Geometry { shaft2, .. } => shaft2,
            Stiffness::Measured { .. } => unreachable!("reference uses geometry"),
        }
    }
    let own: Vec<(&'static str, OwnSetter, bool)> = vec![
        ("sample_period_s", |p, v| p.sample_period_s = v, false),
        (
            "motor.resistance_ohm",
            |p, v| p.motor.resistance_ohm = v,
            false,
        ),
        ("motor.inductance_h", |p, v| p.motor.inductance_h = v, false),
        (
            "motor.torque_constant_nm_per_a",
            |p, v| p.motor.torque_constant_nm_per_a = v,
            false,
        ),
        (
            "motor.back_emf_v_s_per_rad",
            |p, v| p.motor.back_emf_v_s_per_rad = v,
            false,
        ),
        (
            "motor.tach_v_s_per_rad",
            |p, v| p.motor.tach_v_s_per_rad = v,
            false,
        ),
        (
            "motor.inertia_kg_m2",
            |p, v| p.motor.inertia_kg_m2 = v,
            false,
        ),
        (
            "motor.coulomb_friction_nm",
            |p, v| p.motor.coulomb_friction_nm = v,
            true,
        ),
        ("gear_stage_1.ratio", |p, v| p.gears.stage1_ratio = v, false),
        ("gear_stage_2.ratio", |p, v| p.gears.stage2_ratio = v, false),
        (
            "gear_stage_1.gear_pitch_diameter_m",
            |p, v| geo(p).gear_pitch_diameter_m = v,
            false,
        ),
        (
            "gear_stage_1.face_width_m",
            |p, v| geo(p).face_width_m = v,
            false,
        ),
        (
            "gear_stage_1.pinion_lewis_factor",
            |p, v| geo(p).pinion_lewis_factor = v,
            false,
        ),
        (
            "gear_stage_1.gear_youngs_modulus_pa",
            |p, v| geo(p).gear_youngs_modulus_pa = v,
            false,
        ),
        (
            "fixed_shaft.diameter_m",
            |p, v| shaft2(p).diameter_m = v,
            false,
        ),
        ("fixed_shaft.length_m", |p, v| shaft2(p).length_m = v, false),
        ("load.inertia_kg_m2", |p, v| p.load.inertia_kg_m2 = v, false),
        (
            "load.coulomb_friction_nm",
            |p, v| p.load.coulomb_friction_nm = v,
            true,
        ),
        ("backlash.total_deg", |p, v| p.backlash_deg = v, true),
    ];
    // Every effect but the gain error and the signed ones, whose domains are not "zero or
    // positive" (a ratio's is, from 1 up).
    let effects = Effect::ALL
        .into_iter()
        .filter(|e| !matches!(e.domain(), Domain::GainError | Domain::Signed))
        .map(|e| {
            let set = move |p: &mut ActuatorParams, v| p.effects.set(e, v);
            (e.key(), Box::new(set) as Box<Setter>, true)
        });
    own.into_iter()
        .map(|(k, f, z)| (k, Box::new(f) as Box<Setter>, z))
        .chain(effects)
        .collect()
}

#[test]
fn each_non_finite_parameter_names_its_field() {
    for (key, set, _) in fields() {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut p = REFERENCE;
            set(&mut p, bad);
            assert_eq!(
                Plant::new(&p).err(),
                Some(ParamError::NonFinite(key)),
                "{key} = {bad}"
            );
        }
    }
}

#[test]
fn each_negative_parameter_names_its_field() {
    for (key, set, zero_ok) in fields() {
        let mut p = REFERENCE;
        set(&mut p, -1.0);
        let expected = if zero_ok {
            ParamError::Negative(key)
        } else {
            ParamError::NonPositive(key)
        };
        assert_eq!(Plant::new(&p).err(), Some(expected), "{key} = -1");
        let mut p = REFERENCE;
        set(&mut p, 0.0);
        if zero_ok {
            assert!(Plant::new(&p).is_ok(), "{key} = 0 (off) must be accepted");
        } else {
            assert_eq!(
                Plant::new(&p).err(),
                Some(ParamError::NonPositive(key)),
                "{key} = 0"
            );
        }
    }
}

#[test]
fn out_of_range_parameters_say_why() {
    let mut p = REFERENCE;
    p.effects.tach_gain = -1.0;
    let e = Plant::new(&p).unwrap_err();
    assert_eq!(e, ParamError::OutOfRange("effects.tach_gain"));
    assert!(e.to_string().contains("greater than -1"), "{e}");
    let mut p = REFERENCE;
    p.backlash_deg = 45.0;
    assert_eq!(
        Plant::new(&p).err(),
        Some(ParamError::OutOfRange("backlash.total_deg"))
    );
    let mut p = REFERENCE;
    p.effects.input_delay = 1.0;
    assert_eq!(
        Plant::new(&p).err(),
        Some(ParamError::OutOfRange("effects.input_delay"))
    );
    let mut p = REFERENCE;
    p.sample_period_s = 10.0;
    assert_eq!(
        Plant::new(&p).err(),
        Some(ParamError::OutOfRange("sample_period_s"))
    );
}

#[test]
fn bundled_reference_file_equals_the_const() {
    let p = params_file::parse(params_file::REFERENCE_TOML, "ref").unwrap();
    assert_eq!(p, REFERENCE);
    // And the repository copy is the shared reference, byte for byte.
    let shared = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/reference-actuator.toml");
    if let Ok(text) = std::fs::read_to_string(&shared) {
        assert_eq!(
            text,
            params_file::REFERENCE_TOML,
            "data/reference-actuator.toml differs from ../shared"
        );
    }
}

/// Bit for bit: `Debug` prints the shortest representation that reads back to the same
/// `f64`, so equal text means equal bits (and tells -0.0 from 0.0, which `==` does not).
fn bits(p: &ActuatorParams) -> String {
    format!("{p:?}")
}

fn written_and_read(p: &ActuatorParams) -> ActuatorParams {
    let text = params_file::to_toml(p, &["a header".into(), "over two lines".into()]).unwrap();
    assert!(text.starts_with("# a header\n# over two lines\n"), "{text}");
    params_file::parse(&text, "roundtrip").unwrap()
}

#[test]
fn every_shipped_parameter_file_reads_back_identically_after_writing() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut files = vec![
        dir.join("data/reference-actuator.toml"),
        dir.join("data/kord-geartrain.toml"),
    ];
    files.push(dir.join("../shared/reference-actuator.toml"));
    let mut read = 0;
    for path in files.iter().filter(|f| f.exists()) {
        let p = params_file::load(Some(path)).unwrap();
        assert_eq!(bits(&written_and_read(&p)), bits(&p), "{}", path.display());
        read += 1;
    }
    assert!(read >= 2, "the repository's own files are there");
    assert_eq!(
        bits(&params_file::parse(params_file::REFERENCE_TOML, "ref").unwrap()),
        bits(&REFERENCE)
    );
}

#[test]
fn written_parameter_files_read_back_identically() {
    let mut p = REFERENCE.with_backlash_deg(0.05);
    // Every effect on, with values that have no short decimal form (a ratio from 1 up).
    for (i, e) in Effect::ALL.into_iter().enumerate() {
        let v = (i as f64 + 1.0) / 3.0e4;
        p.effects.set(
            e,
            if e.domain() == Domain::Ratio {
                1.0 + v
            } else {
                v
            },
        );
    }
    p.motor.inertia_kg_m2 = 2.5e-7 * (1.0 + f64::EPSILON);
    assert_eq!(bits(&written_and_read(&p)), bits(&p));
    // The [stiffness] form, and the fixed-axis layout.
    p.gears.stiffness = Stiffness::Measured {
        k1_nm_per_rad: 80.0 / 3.0,
        k2_nm_per_rad: 700.0,
    };
    p.gears.revolving = false;
    let back = written_and_read(&p);
    assert_eq!(bits(&back), bits(&p));
    assert!(matches!(back.gears.stiffness, Stiffness::Measured { .. }));
}

/// Every numeric key of a written file, in both stiffness forms, made NaN: the error names
/// exactly that key. The core's key paths (in `ParamError`) are thereby checked against the
/// file schema of the host.
#[test]
fn every_written_key_is_the_key_validation_names() {
    let mut measured = REFERENCE;
    measured.gears.stiffness = Stiffness::Measured {
        k1_nm_per_rad: 80.0,
        k2_nm_per_rad: 700.0,
    };
    let mut checked = 0;
    for p in [REFERENCE, measured] {
        let text = params_file::to_toml(&p, &[]).unwrap();
        let doc: toml::Table = text.parse().unwrap();
        let mut paths = Vec::new();
        for (k, v) in &doc {
            match v {
                toml::Value::Table(t) => paths.extend(
                    t.iter()
                        .filter(|(_, x)| x.is_float())
                        .map(|(kk, _)| (Some(k.clone()), kk.clone())),
                ),
                x if x.is_float() => paths.push((None, k.clone())),
                _ => {}
            }
        }
        for (table, key) in paths {
            let mut d = doc.clone();
            let slot = match &table {
                Some(t) => d.get_mut(t).and_then(|t| t.as_table_mut()).unwrap(),
                None => &mut d,
            };
            slot.insert(key.clone(), toml::Value::Float(f64::NAN));
            let path = table.map(|t| format!("{t}.{key}")).unwrap_or(key);
            let e = params_file::parse(&toml::to_string(&d).unwrap(), "f.toml").unwrap_err();
            assert_eq!(
                e.message,
                format!("f.toml: key `{path}` must be a finite number")
            );
            checked += 1;
        }
    }
    // 1 + 7 + 7 + 3 + 7 + 3 + 2 + 1 geometry-form keys, 1 + 7 + 2 + 2 + 2 + 1 measured, and
    // every effect in each.
    assert_eq!(checked, 31 + 15 + 2 * Effect::ALL.len());
}

fn toml_error(edit: impl Fn(&str) -> String) -> String {
    let text = edit(params_file::REFERENCE_TOML);
    let e = params_file::parse(&text, "act.toml").unwrap_err();
    assert_eq!(e.kind, ErrorKind::BadInput);
    assert!(!e.message.contains('\n'), "one line: {}", e.message);
    e.message
}

#[test]
fn broken_parameter_files_name_file_and_key() {
    type Edit = Box<dyn Fn(&str) -> String>;
    let cases: Vec<(Edit, &str)> = vec![
        (
            Box::new(|t| t.replace("resistance_ohm = 32.5 ", "resistance_ohm = -32.5 ")),
            "key `motor.resistance_ohm` must be greater than zero",
        ),
        (
            Box::new(|t| t.replace("inertia_kg_m2 = 1.0e-3 ", "inertia_kg_m2 = nan ")),
            "key `load.inertia_kg_m2` must be a finite number",
        ),
        (
            Box::new(|t| t.replace("inductance_h = 0.8e-3 ", "inductance = 0.8e-3 ")),
            "unknown key `motor.inductance`",
        ),
        (
            Box::new(|t| t.replace("inductance_h = 0.8e-3 ", "")),
            "missing key `motor.inductance_h`",
        ),
        (
            Box::new(|t| t.replace("ratio = 5 ", "ratio = \"5\" ")),
            "key `gear_stage_1.ratio`",
        ),
        (
            Box::new(|t| t.replace("[load]", "[lod]")),
            "unknown key `lod`",
        ),
        (
            Box::new(|t| t.replace("face_width_m = 0.003 ", "")),
            "missing key `gear_stage_1.face_width_m`",
        ),
        (
            Box::new(|t| format!("{t}\n[stiffness]\nk1_nm_per_rad = 1.0\nk2_nm_per_rad = 2.0\n")),
            "conflicts with the [stiffness] table",
        ),
        (
            Box::new(|t| t.replace("total_deg = 0.0 ", "total_deg = [1] ")),
            "key `backlash.total_deg`",
        ),
        (
            Box::new(|t| t.replace("[motor]", "[motor")),
            "act.toml: line",
        ),
    ];
    for (edit, want) in cases {
        let msg = toml_error(edit);
        assert!(msg.starts_with("act.toml: "), "{msg}");
        assert!(msg.contains(want), "expected `{want}` in `{msg}`");
    }
}

#[test]
fn measured_stiffness_replaces_geometry() {
    let text = "[motor]\nresistance_ohm = 32.5\ninductance_h = 0.8e-3\ntorque_constant_nm_per_a = 0.02\n\
back_emf_v_s_per_rad = 0.02\ntach_v_s_per_rad = 0.01\ninertia_kg_m2 = 2.5e-7\ncoulomb_friction_nm = 2e-4\n\
[gear_stage_1]\nratio = 5\n[gear_stage_2]\nratio = 9\nrevolving = true\n\
[stiffness]\nk1_nm_per_rad = 78.358664\nk2_nm_per_rad = 700.032462\n\
[load]\ninertia_kg_m2 = 1e-3\ncoulomb_friction_nm = 5e-3\n[backlash]\ntotal_deg = 0.0\n";
    let p = params_file::parse(text, "m.toml").unwrap();
    let d = p.derived().unwrap();
    assert!((d.f_ar_hz - 127.585).abs() < 1e-3, "{}", d.f_ar_hz);
}

fn csv_error(text: &str) -> String {
    let e = record::parse(text, "m.csv", true).unwrap_err();
    assert_eq!(e.kind, ErrorKind::BadInput);
    assert!(!e.message.contains('\n'));
    e.message
}

#[test]
fn broken_records_name_line_and_column() {
    let cases = [
        (
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,,0\n",
            "line 3, column `motor_voltage_v`: empty field",
        ),
        (
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,abc,0\n",
            "line 3, column `motor_voltage_v`: `abc` is not a number",
        ),
        (
            "time_s,tach_voltage_v\n0,0\n0.0005,1\n",
            "missing required column `motor_voltage_v`",
        ),
        (
            "motor_voltage_v,tach_voltage_v\n0,0\n1,1\n",
            "missing required column `time_s`",
        ),
        (
            "time_s,motor_voltage_v\n0,0\n0.0005,1\n",
            "no output column",
        ),
        (
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.001,1,0\n0.0005,1,0\n",
            "line 4, column `time_s`: time 0.0005 does not increase",
        ),
        (
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,1,0\n0.001,1,0\n0.0025,1,0\n0.003,1,0\n",
            "line 5, column `time_s`: a gap of",
        ),
        (
            "# a: b\ntime_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,1\n",
            "line 4: has 2 fields, the header has 3",
        ),
        (
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.0005,inf,0\n",
            "`inf` is not finite",
        ),
        (
            "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n",
            "needs at least two data rows",
        ),
        ("", "no header row"),
    ];
    for (text, want) in cases {
        let msg = csv_error(text);
        assert!(msg.contains(want), "expected `{want}` in `{msg}`");
    }
}

#[test]
fn comments_and_unknown_columns_are_kept_and_reported() {
    let r = record::parse("# rig: test\n# sample_period_s: 0.0005\ntime_s,extra,motor_voltage_v,tach_voltage_v\n0,9,1,0\n0.0005,9,2,0.1\n0.001,9,3,0.2\n", "m.csv", true).unwrap();
    assert_eq!(r.meta("rig"), Some("test"));
    assert_eq!(r.motor_voltage_v, vec![1.0, 2.0, 3.0]);
    assert_eq!(r.output("tach_voltage_v"), Some(&[0.0, 0.1, 0.2][..]));
    assert!((r.sample_period_s - 0.0005).abs() < 1e-12);
    assert_eq!(r.warnings.len(), 1);
    assert!(r.warnings[0].contains("`extra`"));
}

#[test]
fn command_line_bad_input_exits_with_status_two() {
    let dir = std::env::temp_dir().join(format!("gs-bad-input-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad_csv = dir.join("bad.csv");
    std::fs::write(&bad_csv, "time_s,motor_voltage_v\n0,1\n0.0005,x\n").unwrap();
    let missing = dir.join("missing.toml");
    let out = dir.join("out.csv");
    let cases: Vec<Vec<String>> = vec![
        vec![
            "info".into(),
            "--params".into(),
            missing.display().to_string(),
        ],
        vec![
            "simulate".into(),
            "--input".into(),
            bad_csv.display().to_string(),
            "--output".into(),
            out.display().to_string(),
        ],
        vec![
            "simulate".into(),
            "--input".into(),
            bad_csv.display().to_string(),
            "--output".into(),
            out.display().to_string(),
            "--backlash-deg=-1".into(),
        ],
    ];
    for args in cases {
        let cli =
            Cli::try_parse_from(std::iter::once("geared-servo".to_string()).chain(args.clone()))
                .unwrap();
        let e = match run(&cli) {
            Ok(_) => panic!("{args:?} should fail"),
            Err(e) => e,
        };
        assert_eq!(e.exit_code(), 2, "{args:?}: {e}");
        assert!(!e.message.contains('\n'));
    }
    // Usage errors are clap's (exit status 2 in the binary).
    assert!(Cli::try_parse_from(["geared-servo", "simulate"]).is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn simulate_writes_the_record_convention() {
    let dir = std::env::temp_dir().join(format!("gs-sim-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("in.csv");
    let mut text = String::from("time_s,motor_voltage_v\n");
    for k in 0..400 {
        text.push_str(&format!(
            "{},{}\n",
            k as f64 * 0.0005,
            if k < 200 { 5.0 } else { -5.0 }
        ));
    }
    std::fs::write(&input, text).unwrap();
    let output = dir.join("out.csv");
    let cli = Cli::try_parse_from([
        "geared-servo",
        "simulate",
        "--input",
        input.to_str().unwrap(),
        "--output",
        output.to_str().unwrap(),
    ])
    .unwrap();
    run(&cli).unwrap();
    let r = record::read(&output, true).unwrap();
    assert_eq!(r.len(), 400);
    for c in [
        "tach_voltage_v",
        "motor_speed_rad_s",
        "load_angle_deg",
        "current_a",
    ] {
        assert!(r.output(c).is_some(), "{c}");
    }
    // Row 0 is the initial state (at rest); the voltage of row k acts from row k on.
    let tach = r.output("tach_voltage_v").unwrap();
    assert_eq!(tach[0], 0.0);
    assert!(tach[199] > 0.5 && tach[399] < 0.0);
    // Same numbers as stepping the plant directly.
    let plant = Plant::new(&REFERENCE).unwrap();
    let mut st = geared_servo::PlantState::REST;
    for k in 0..399 {
        let o = plant.step(&mut st, if k < 200 { 5.0 } else { -5.0 });
        assert_eq!(tach[k + 1] as f32, o.tach_voltage_v, "row {}", k + 1);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Regression (found by the `record_csv` fuzz target): a quoted field spanning lines was
/// echoed verbatim and made the error span lines.
#[test]
fn quoted_multi_line_field_still_gives_a_one_line_error() {
    let text = "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.001,\"# a\nb\nc\",0\n";
    let e = record::parse(text, "m.csv", true).unwrap_err();
    assert!(!e.message.contains('\n'), "{}", e.message);
    assert!(e.message.contains("is not a number"), "{}", e.message);
    let long = format!(
        "time_s,motor_voltage_v,tach_voltage_v\n0,1,0\n0.001,{},0\n",
        "x".repeat(10_000)
    );
    let e = record::parse(&long, "m.csv", true).unwrap_err();
    assert!(
        e.message.len() < 200,
        "a 10 kB field is cut: {} bytes",
        e.message.len()
    );
}

#[test]
fn control_characters_in_a_scenario_stay_on_one_line() {
    let e = geared_servo_host::scenario_file::parse(
        "[[event]]\nat_s = 0.1\napply = \"a\\nb\"\n",
        "f.toml",
        0.0005,
        2000,
    )
    .unwrap_err();
    assert!(
        !e.message.contains('\n') && e.message.contains("unknown fault `a\\nb`"),
        "{}",
        e.message
    );
}
