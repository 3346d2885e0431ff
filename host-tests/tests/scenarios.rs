//! Fault scenarios: files, playback, and bad scenarios as clear errors.

use geared_servo::scenario::{Fault, Scenario, TorqueProfile};
use geared_servo::{Jam, Plant, PlantFaults, PlantState, REFERENCE};
use geared_servo_host::scenario_file::{parse, CAPACITY};
use geared_servo_host::simulate::simulate_with_scenario;
use geared_servo_host::ErrorKind;

const DT: f64 = 0.0005;

fn err(text: &str, steps: usize) -> String {
    let e = parse(text, "f.toml", DT, steps).unwrap_err();
    assert_eq!(e.kind, ErrorKind::BadInput);
    assert!(!e.message.contains('\n'));
    e.message
}

#[test]
fn bad_scenarios_are_clear_errors() {
    let cases = [
        ("[[event]]\nat_s = 0.1\napply = \"meltdown\"\n", "line 1 (event 1): unknown fault `meltdown`"),
        ("[[event]]\nat_s = 5.0\napply = \"jam\"\n", "past the end of the run"),
        ("[[event]]\nat_s = 0.1\napply = \"open_winding\"\n[[event]]\nat_s = 0.2\napply = \"shorted_winding\"\n", "event 2): `shorted_winding` overlaps the winding fault applied by event 1"),
        ("[[event]]\nat_s = 0.1\napply = \"jam\"\n[[event]]\nat_s = 0.2\napply = \"jam\"\nangle_deg = 3\n", "overlaps the jam fault"),
        ("[[event]]\nat_s = 0.2\napply = \"jam\"\n[[event]]\nat_s = 0.1\nclear = \"jam\"\n", "events must be in time order"),
        ("[[event]]\nat_s = 0.1\napply = \"load_torque\"\n", "`load_torque` needs `amplitude_nm`"),
        ("[[event]]\nat_s = 0.1\napply = \"jam\"\nclear = \"jam\"\n", "not both"),
        ("[[event]]\nat_s = 0.1\napply = \"jam\"\nspeed = 3\n", "unknown field `speed`"),
        ("[[event]]\nat_s = \"soon\"\napply = \"jam\"\n", "line 2"),
        ("[[event]]\nat_s = 0.1\napply = \"tach_dropout\"\nlevel = \"half\"\n", "`level` = `half`"),
        ("[[event]]\nat_s = 0.1\napply = \"tach_stuck\"\ncounts = 5\n[[event]]\nat_s = 0.2\napply = \"tach_offset\"\ncounts = 5\n", "overlaps the tach fault applied by event 1"),
        ("[[event]]\nat_s = 0.1\napply = \"broken_tooth\"\nangle_deg = 0\nwidth_deg = 3\ntorque_loss = 2\n", "`torque_loss` must be within 0–1"),
    ];
    for (text, want) in cases {
        let msg = err(text, 2000);
        assert!(msg.starts_with("f.toml: "), "{msg}");
        assert!(msg.contains(want), "expected `{want}` in `{msg}`");
    }
    let mut many = String::new();
    for k in 0..=CAPACITY {
        many.push_str(&format!(
            "[[event]]\nat_s = {}\napply = \"friction_factor\"\nfactor = 1.5\n",
            k as f64 * 0.001
        ));
    }
    assert!(err(&many, 2000).contains("more than the scenario capacity"));
}

#[test]
fn scenario_playback_equals_stepping_with_the_faults_by_hand() {
    let text = "[[event]]\nat_s = 0.05\napply = \"load_torque\"\nprofile = \"gust\"\namplitude_nm = 0.3\nduration_s = 0.02\n\
[[event]]\nat_s = 0.1\napply = \"jam\"\n[[event]]\nat_s = 0.15\nclear = \"jam\"\n";
    let n = 400;
    let volts: Vec<f64> = (0..n).map(|k| 8.0 * (k as f64 * 0.03).sin()).collect();
    let mut sc = parse(text, "f.toml", DT, n).unwrap();
    let p = REFERENCE.with_backlash_deg(0.05);
    let cols = simulate_with_scenario(&p, DT, &volts, Some(&mut sc)).unwrap();
    // By hand.
    let plant = Plant::new(&p).unwrap();
    let mut st = PlantState::REST;
    let mut tach = vec![0.0f32];
    for (k, &v) in volts.iter().enumerate().take(n - 1) {
        let mut f = PlantFaults::NONE;
        if (100..140).contains(&k) {
            let ph = std::f32::consts::TAU * (k - 100) as f32 / 40.0;
            f.load_torque_nm = 0.5 * 0.3 * (1.0 - geared_servo::math::sin_cos(ph).1);
        }
        if (200..300).contains(&k) {
            f.jam = Jam::Here;
        }
        tach.push(plant.step_with_faults(&mut st, v as f32, &f).tach_voltage_v);
    }
    for (k, (a, b)) in cols[0].iter().zip(&tach).enumerate() {
        assert_eq!(*a as f32, *b, "row {k}");
    }
    // The load angle is frozen while jammed (rows 201..=300 sample after jammed steps).
    let angle = &cols[2];
    assert!(angle[201..=300].iter().all(|a| *a == angle[201]));
    assert!(angle[301..].iter().any(|a| *a != angle[201]));
}

#[test]
fn a_schedule_fires_each_event_at_its_step() {
    let mut s: Scenario<8> = Scenario::new();
    s.push(3, Fault::FrictionFactor(2.0)).unwrap();
    s.push(
        3,
        Fault::LoadTorque(TorqueProfile::Step { amplitude_nm: 0.1 }),
    )
    .unwrap();
    s.push(7, Fault::ClearLoadTorque).unwrap();
    s.push(7, Fault::FrictionFactor(1.0)).unwrap();
    let seen: Vec<(f32, f32)> = (0..10)
        .map(|k| {
            let f = s.advance(k);
            (f.plant.friction_factor, f.plant.load_torque_nm)
        })
        .collect();
    for (k, (ff, t)) in seen.into_iter().enumerate() {
        let on = (3..7).contains(&k);
        assert_eq!(ff, if on { 2.0 } else { 1.0 }, "step {k}");
        assert_eq!(t, if on { 0.1 } else { 0.0 }, "step {k}");
    }
}

#[test]
fn sensor_faults_parse_per_channel_and_simulate_refuses_them() {
    use geared_servo::SensorFault;
    use geared_servo_host::scenario_file::has_io_faults;
    let text = "[[event]]\nat_s = 0.1\napply = \"tach_dropout\"\n[[event]]\nat_s = 0.1\napply = \"pot_lost_lsbs\"\nbits = 4\n\
[[event]]\nat_s = 0.2\nclear = \"tach_dropout\"\n[[event]]\nat_s = 0.3\napply = \"bus_sag\"\nfactor = 0.7\n";
    let mut sc = parse(text, "f.toml", DT, 2000).unwrap();
    assert_eq!(has_io_faults(&sc), Some(0));
    let f = *sc.advance(200);
    assert_eq!(
        (f.tach, f.pot),
        (SensorFault::Dropout(false), SensorFault::LostLsbs(4))
    );
    let f = *sc.advance(600);
    assert_eq!(
        (f.tach, f.pot, f.bus_factor),
        (SensorFault::None, SensorFault::LostLsbs(4), 0.7)
    );
    // A bus sag alone is fine for simulate (it scales the applied voltage).
    let only_sag = parse(
        "[[event]]\nat_s = 0.3\napply = \"bus_sag\"\nfactor = 0.5\n",
        "f.toml",
        DT,
        2000,
    )
    .unwrap();
    assert_eq!(has_io_faults(&only_sag), None);
}
